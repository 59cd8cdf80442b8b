/* SPDX-License-Identifier: MIT */
/*
 * dth models, dth regularizers: the registered model types and regularizers, one line each:
 * name, parameters with defaults, description.
 */
#include <stdio.h>
#include <string.h>
#include "cli.h"

static void print_entry(const char *name, const dth_param_spec *params, size_t n, const char *doc)
{
    printf("%s", name);
    for (size_t j = 0; j < n; j++) printf(" %s=%s", params[j].key, params[j].def ? params[j].def : "?");
    printf(" -- %s\n", doc ? doc : "");
}

/* The common frame: usage, no arguments, the registry; `regularizers` picks the list. */
static int list(int argc, char **argv, int regularizers)
{
    const char *what = regularizers ? "regularizers" : "models";
    if (argc > 1) {
        if (!strcmp(argv[1], "-h") || !strcmp(argv[1], "--help")) {
            printf("usage: dth %s\n  one line per %s: name, parameters as key=default (key=? when required or "
                   "derived), then the description after ' -- '%s\n", what, regularizers ? "regularizer" : "model",
                   regularizers ? " (select with [regularize] method=NAME)" : "");
            return CLI_OK;
        }
        cli_error("dth %s takes no arguments (got '%s')", what, argv[1]);
        return CLI_USAGE;
    }
    dth_registry *reg = cli_registry();
    if (!reg) return CLI_FAIL;
    if (regularizers) {
        for (size_t i = 0; i < dth_registry_regularizer_count(reg); i++) {
            const dth_regularizer_type *t = dth_registry_regularizer_at(reg, i);
            print_entry(t->name, t->params, t->n_params, t->doc);
        }
    } else {
        for (size_t i = 0; i < dth_registry_model_count(reg); i++) {
            const dth_model_type *t = dth_registry_model_at(reg, i);
            print_entry(t->name, t->params, t->n_params, t->doc);
        }
    }
    dth_registry_free(reg);
    return fflush(stdout) == 0 ? CLI_OK : CLI_FAIL;
}

int cli_cmd_models(int argc, char **argv) { return list(argc, argv, 0); }
int cli_cmd_regularizers(int argc, char **argv) { return list(argc, argv, 1); }
