/* SPDX-License-Identifier: MIT */
/*
 * dth keys: the scene keys of [initial], [integrator], [output] and [events] from the library's
 * table (dth_scene_key_at): what each accepts, its default and meaning; --markdown writes the user
 * guide's key tables (scripts/keys-doc.sh puts them into docs/user-guide.md).
 */
#include <stdio.h>
#include <string.h>
#include "cli.h"

/* A table cell: s with '|' (a column) and '<' (HTML: q<i>) escaped. */
static void cell(const char *s)
{
    for (; *s; s++) {
        if (*s == '|' || *s == '<') putchar('\\');
        putchar(*s);
    }
}

/* The default as the guide shows it: required, none, a value (`30`), or words (standard output). */
static void markdown_default(const dth_scene_key_info *in)
{
    if (in->required) fputs("**required**", stdout);
    else if (!in->def[0]) fputs("none", stdout);
    else if (in->type == DTH_SCENE_TEXT || in->type == DTH_SCENE_DOFS) cell(in->def);
    else printf("`%s`", in->def);
}

static void markdown_row(size_t i, const dth_scene_key_info *in)
{
    char what[512];
    dth_scene_key_describe(i, what, sizeof what);
    printf("| `%s` | ", in->key);
    cell(what);
    fputs(" | ", stdout);
    markdown_default(in);
    fputs(" | ", stdout);
    cell(in->doc);
    const char *name, *doc;
    for (size_t j = 0; (name = dth_scene_key_choice(i, j, &doc)); j++)
        if (doc) {
            printf(" `%s`: ", name);
            cell(doc);
            putchar('.');
        }
    fputs(" |\n", stdout);
}

static void plain_entry(size_t i, const dth_scene_key_info *in)
{
    char what[512];
    dth_scene_key_describe(i, what, sizeof what);
    printf("%s.%s  %s; %s%s\n    %s\n", in->section, in->key, what, in->required ? "required" : "default: ",
           in->required ? "" : in->def[0] ? in->def : "none", in->doc);
    const char *name, *doc;
    for (size_t j = 0; (name = dth_scene_key_choice(i, j, &doc)); j++)
        if (doc) printf("      %s: %s\n", name, doc);
}

int cli_cmd_keys(int argc, char **argv)
{
    int markdown = 0;
    const char *section = NULL;
    for (int a = 1; a < argc; a++) {
        if (!strcmp(argv[a], "-h") || !strcmp(argv[a], "--help")) {
            printf("usage: dth keys [--markdown] [SECTION]\n  the keys of [initial], [integrator], [output] and "
                   "[events] (or of SECTION): what each\n  accepts, its default and meaning. --markdown: the tables "
                   "of docs/user-guide.md\n  (scripts/keys-doc.sh writes them there)\n");
            return CLI_OK;
        }
        if (!strcmp(argv[a], "--markdown")) markdown = 1;
        else if (argv[a][0] != '-' && !section) section = argv[a];
        else {
            cli_error("dth keys: unexpected argument '%s' (try dth keys --help)", argv[a]);
            return CLI_USAGE;
        }
    }
    size_t shown = 0;
    for (size_t i = 0; i < dth_scene_key_count(); i++) {
        const dth_scene_key_info *in = dth_scene_key_at(i);
        if (section && strcmp(section, in->section)) continue;
        if (markdown && (!shown || strcmp(dth_scene_key_at(i - 1)->section, in->section))) {
            if (shown) putchar('\n');
            if (!section) printf("[%s]\n\n", in->section);
            printf("| key | value | default | meaning |\n|---|---|---|---|\n");
        }
        if (markdown) markdown_row(i, in);
        else plain_entry(i, in);
        shown++;
    }
    if (!shown) {
        cli_error("dth keys: no keys in section [%s] (dth keys lists them all)", section);
        return CLI_USAGE;
    }
    return fflush(stdout) == 0 ? CLI_OK : CLI_FAIL;
}
