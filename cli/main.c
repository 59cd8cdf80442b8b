/* SPDX-License-Identifier: MIT */
/* dth: command-line front end of the library; dispatches to the subcommands of cli.h. */
#include <stdio.h>
#include <string.h>
#include "cli.h"

typedef struct command {
    const char *name, *usage, *summary;
    int (*fn)(int argc, char **argv);
} command;

static const command commands[] = {
#define CLI__ROW(name, usage, summary) {#name, usage, summary, cli_cmd_##name},
    CLI_COMMANDS(CLI__ROW)
#undef CLI__ROW
};

void cli_usage(int to_stderr)
{
    FILE *f = to_stderr ? stderr : stdout;
    fprintf(f, "usage: dth COMMAND [ARGS]\n       dth --help | --version\n\ncommands:\n");
    for (size_t i = 0; i < sizeof commands / sizeof commands[0]; i++)
        fprintf(f, "  dth %s%s%s\n      %s\n", commands[i].name, commands[i].usage[0] ? " " : "", commands[i].usage,
                commands[i].summary);
    fprintf(f, "\n");
    cli_usage_run(f);
    fprintf(f, "\nexit codes: 0 success, 1 hard error, 2 bad input or usage, 3 trajectory stopped early,\n"
               "128 + signal when interrupted; see docs/user-guide.md\n");
}

int main(int argc, char **argv)
{
    if (argc < 2) {
        cli_usage(1);
        return CLI_USAGE;
    }
    const char *c = argv[1];
    if (!strcmp(c, "--help") || !strcmp(c, "-h") || !strcmp(c, "help")) {
        cli_usage(0);
        return cli_flush_stdout();
    }
    if (!strcmp(c, "--version")) {
        printf("dth %s\n", DTH_VERSION_STRING);
        return cli_flush_stdout();
    }
    for (size_t i = 0; i < sizeof commands / sizeof commands[0]; i++)
        if (!strcmp(c, commands[i].name)) {
            int st = commands[i].fn(argc - 1, argv + 1);
            /* what a command printed to stdout (a --help, a list) must have been written: a command
             * that failed has said why */
            return st == CLI_OK ? cli_flush_stdout() : st;
        }
    cli_error("unknown command '%s' (try dth --help)", c);
    return CLI_USAGE;
}
