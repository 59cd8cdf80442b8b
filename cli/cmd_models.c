/* SPDX-License-Identifier: MIT */
/* dth models: the registered model types, their parameters with defaults, and their docs. */
#include <stdio.h>
#include <string.h>
#include "cli.h"

int cli_cmd_models(int argc, char **argv)
{
    if (argc > 1) {
        if (!strcmp(argv[1], "-h") || !strcmp(argv[1], "--help")) {
            printf("usage: dth models\n  one line per model: name, parameters as key=default "
                   "(key=? when required or derived), then the description after ' -- '\n");
            return CLI_OK;
        }
        cli_error("dth models takes no arguments (got '%s')", argv[1]);
        return CLI_USAGE;
    }
    dth_registry *reg = cli_registry();
    if (!reg) return CLI_FAIL;
    for (size_t i = 0; i < dth_registry_model_count(reg); i++) {
        const dth_model_type *t = dth_registry_model_at(reg, i);
        printf("%s", t->name);
        for (size_t j = 0; j < t->n_params; j++)
            printf(" %s=%s", t->params[j].key, t->params[j].def ? t->params[j].def : "?");
        printf(" -- %s\n", t->doc ? t->doc : "");
    }
    dth_registry_free(reg);
    return fflush(stdout) == 0 ? CLI_OK : CLI_FAIL;
}
