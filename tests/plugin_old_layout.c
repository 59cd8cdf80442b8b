/* SPDX-License-Identifier: MIT */
/* A model plugin of the unversioned table layout (name first, no abi/size): dth must refuse it. */
#include <stddef.h>

static int create(const void *args, void **self, void *info) { (void)args, (void)info; *self = NULL; return -1; }
static int eval(const void *self, const double *y, unsigned what, double *H, double *g, double *h)
{
    (void)self, (void)y, (void)what, (void)H, (void)g, (void)h;
    return -1;
}

struct old_model_type {
    const char *name, *doc;
    const void *params;
    size_t n_params;
    int (*create)(const void *, void **, void *);
    void (*destroy)(void *, const void *);
    int (*eval)(const void *, const double *, unsigned, double *, double *, double *);
};

extern const struct old_model_type old_table;
const struct old_model_type old_table = {"old", "a table of the unversioned layout", NULL, 0, create, NULL, eval};
