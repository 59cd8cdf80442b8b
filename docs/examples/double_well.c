/* SPDX-License-Identifier: MIT */
/*
 * Example of a user's own model, written only against the public header <dth/dth.h>: the
 * double well H = p^2/2 + (q^4 - q^2)/2 used by Kane, Marsden and Ortiz (1999).
 * Copy this file to start a model of your own; validate it with dth_model_check().
 */
#include <dth/dth.h>
#include "double_well.h"

typedef struct double_well {
    double a; /* scale of the potential: V = a (q^4 - q^2)/2 */
} double_well;

static const dth_param_spec params[] = {
    {"a", "1", "scale of the potential V = a (q^4 - q^2)/2 (> 0)"},
};

static int create(const dth_model_args *args, void **self, dth_model_info *info)
{
    double a;
    int rc = dth_args_double(args, "a", 1.0, &a);
    if (rc) return rc;
    if (!(a > 0)) return dth_args_error(args, "parameter 'a' must be > 0");
    if (args->n_hint > 1) return dth_args_error(args, "the double well has one degree of freedom");
    double_well *m = dth_calloc(args->alloc, 1, sizeof *m);
    if (!m) return DTH_ENOMEM;
    m->a = a;
    *self = m;
    *info = (dth_model_info){.n = 1, .autonomous = 1, .separable = 1, .hess_kind = DTH_HESS_DENSE};
    return DTH_OK;
}

static void destroy(void *self, const dth_allocator *alloc) { dth_free(alloc, self); }

/* y = (q, t, p); gradient and Hessian over y */
static int eval(const void *self, const double *y, unsigned what, double *H, double *g, double *h)
{
    const double_well *m = self;
    double q = y[0], p = y[2], q2 = q * q;
    if (what & DTH_EVAL_H) *H = 0.5 * p * p + 0.5 * m->a * (q2 * q2 - q2);
    if (what & DTH_EVAL_GRAD) {
        g[0] = m->a * (2 * q2 * q - q);
        g[1] = 0;
        g[2] = p;
    }
    if (what & DTH_EVAL_HESS) {
        for (int i = 0; i < 9; i++) h[i] = 0;
        h[0] = m->a * (6 * q2 - 1);
        h[8] = 1;
    }
    return 0;
}

/* sum H_ijk u_i u_j u_k: only H_qqq = 12 a q is nonzero */
static int third(const void *self, const double *y, const double *u, double *d3)
{
    const double_well *m = self;
    *d3 = 12 * m->a * y[0] * u[0] * u[0] * u[0];
    return 0;
}

const dth_model_type example_double_well = {
DTH_MODEL_TYPE_HEAD,
    .name = "double-well",
    .doc = "double well H = p^2/2 + a (q^4 - q^2)/2 (example of a user model)",
    .params = params,
    .n_params = sizeof params / sizeof params[0],
    .create = create,
    .destroy = destroy,
    .eval = eval,
    .third = third,
};
