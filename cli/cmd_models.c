/* SPDX-License-Identifier: MIT */
/*
 * dth models, dth regularizers: the registered model types and regularizers: a line with the
 * name, parameters with defaults and the description, then one indented line per parameter
 * with its own description (from the type's parameter table).
 */
#include <stdio.h>
#include <string.h>
#include "cli.h"

static void print_entry(const char *name, const dth_param_spec *params, size_t n, const char *doc)
{
    printf("%s", name);
    for (size_t j = 0; j < n; j++) printf(" %s=%s", params[j].key, params[j].def ? params[j].def : "?");
    printf(" -- %s\n", doc ? doc : "");
    size_t w = 0;
    for (size_t j = 0; j < n; j++) w = strlen(params[j].key) > w ? strlen(params[j].key) : w;
    for (size_t j = 0; j < n; j++)
        printf("    %-*s  %s%s%s\n", (int)w, params[j].key, params[j].doc ? params[j].doc : "",
               params[j].def && params[j].def[0] ? "; default " : "", params[j].def ? params[j].def : "");
}

/* The common frame: usage, no arguments, the registry; `regularizers` picks the list. */
static int list(int argc, char **argv, int regularizers)
{
    const char *what = regularizers ? "regularizers" : "models";
    if (argc > 1) {
        if (!strcmp(argv[1], "-h") || !strcmp(argv[1], "--help")) {
            printf("usage: dth %s\n  per %s: a line with the name, the parameters as key=default (key=? when "
                   "required or\n  derived) and the description after ' -- '%s; then one indented line per "
                   "parameter\n  with its description\n", what, regularizers ? "regularizer" : "model",
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
    return cli_flush_stdout();
}

int cli_cmd_models(int argc, char **argv) { return list(argc, argv, 0); }
int cli_cmd_regularizers(int argc, char **argv) { return list(argc, argv, 1); }
