/* SPDX-License-Identifier: MIT */
/* dth regularizers: the registered regularizers across psi = 0 (paper, section 7), one line each. */
#include <stdio.h>
#include <string.h>
#include "cli.h"

int cli_cmd_regularizers(int argc, char **argv)
{
    if (argc > 1) {
        if (!strcmp(argv[1], "-h") || !strcmp(argv[1], "--help")) {
            printf("usage: dth regularizers\n  one line per regularizer: name, parameters as key=default, "
                   "then the description after ' -- ' (select with [regularize] method=NAME)\n");
            return CLI_OK;
        }
        cli_error("dth regularizers takes no arguments (got '%s')", argv[1]);
        return CLI_USAGE;
    }
    dth_registry *reg = cli_registry();
    if (!reg) return CLI_FAIL;
    for (size_t i = 0; i < dth_registry_regularizer_count(reg); i++) {
        const dth_regularizer_type *t = dth_registry_regularizer_at(reg, i);
        printf("%s", t->name);
        for (size_t j = 0; j < t->n_params; j++)
            printf(" %s=%s", t->params[j].key, t->params[j].def ? t->params[j].def : "?");
        printf(" -- %s\n", t->doc ? t->doc : "");
    }
    dth_registry_free(reg);
    return fflush(stdout) == 0 ? CLI_OK : CLI_FAIL;
}
