/* SPDX-License-Identifier: MIT */
/*
 * --model-lib FILE:SYMBOL of dth run and dth sweep: model types loaded from shared objects (dlopen)
 * into the registry. A FILE without a slash that exists in the working folder is that file (dlopen
 * alone would search only the library path for it); messages name the path tried.
 */
#include <dlfcn.h>
#include <stdio.h>
#include <string.h>
#include <unistd.h>
#include "cli.h"

int cli_modlib_add(cli_modlibs *l, const char *v)
{
    const char *colon = strrchr(v, ':');
    if (!colon || colon == v || !colon[1] || l->nargs >= CLI_MAX_MODLIBS) {
        cli_error("--model-lib: '%s' is not FILE.so:SYMBOL%s", v, l->nargs >= CLI_MAX_MODLIBS ? " (at most 16)" : "");
        return -1;
    }
    l->args[l->nargs++] = v;
    return 0;
}

const char *cli_modlib_file(const cli_modlibs *l, int i, char *buf, size_t len)
{
    const char *v = l->args[i];
    snprintf(buf, len, "%.*s", (int)(strrchr(v, ':') - v), v);
    return buf;
}

int cli_modlib_load(cli_modlibs *l, dth_registry *reg)
{
    for (int i = 0; i < l->nargs; i++) {
        char file[4096], path[4100];
        const char *sym = strrchr(l->args[i], ':') + 1;
        cli_modlib_file(l, i, file, sizeof file);
        /* a name without a slash: the file of that name here, if there is one */
        int local = !strchr(file, '/') && access(file, F_OK) == 0;
        snprintf(path, sizeof path, "%s%s", local ? "./" : "", file);
        void *h = dlopen(path, RTLD_NOW | RTLD_LOCAL);
        if (!h) {
            const char *why = dlerror();
            if (strchr(file, '/') || local)
                cli_error("--model-lib: cannot load '%s': %s", path, why ? why : "dlopen failed");
            else
                cli_error("--model-lib: cannot load '%s': no such file in the working folder, and the library path "
                          "has none (%s)", file, why ? why : "dlopen failed");
            return CLI_USAGE;
        }
        l->h[l->n++] = h;
        const dth_model_type *t = dlsym(h, sym);
        char why[256];
        if (!t) {
            cli_error("--model-lib: '%s' has no model table '%s'", path, sym);
            return CLI_USAGE;
        }
        if (dth_model_type_check(t, why, sizeof why)) { /* a table of another layout: refused by name */
            cli_error("--model-lib: '%s' in '%s': %s", sym, path, why);
            return CLI_USAGE;
        }
        if (dth_registry_add_model(reg, t)) {
            cli_error("--model-lib: cannot register model '%s' from '%s' (a duplicate name?)", t->name, path);
            return CLI_USAGE;
        }
    }
    return 0;
}

void cli_modlib_close(cli_modlibs *l)
{
    for (int i = 0; i < l->n; i++) dlclose(l->h[i]);
    l->n = 0;
}
