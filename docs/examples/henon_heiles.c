/* SPDX-License-Identifier: MIT */
/*
 * Example of a user's own model with two degrees of freedom, written only against <dth/dth.h>:
 * the Henon-Heiles Hamiltonian
 *     H = (p1^2 + p2^2)/2 + (q1^2 + q2^2)/2 + lambda (q1^2 q2 - q2^3/3),
 * whose Poincare sections (q1 = 0, p1 > 0) show invariant curves of regular orbits at E = 1/12
 * and a chaotic sea at E = 1/6 (Henon and Heiles 1964). See poincare.c and henon-heiles.ini.
 */
#include <dth/dth.h>
#include "henon_heiles.h"

typedef struct henon_heiles {
    double lambda; /* strength of the cubic coupling */
} henon_heiles;

static const dth_param_spec params[] = {
    {"lambda", "1", "strength of the cubic terms lambda (q1^2 q2 - q2^3/3)"},
};

static int create(const dth_model_args *args, void **self, dth_model_info *info)
{
    double l;
    int rc = dth_args_double(args, "lambda", 1.0, &l);
    if (rc) return rc;
    if (args->n_hint && args->n_hint != 2) return dth_args_error(args, "Henon-Heiles has two degrees of freedom");
    henon_heiles *m = dth_calloc(args->alloc, 1, sizeof *m);
    if (!m) return DTH_ENOMEM;
    m->lambda = l;
    *self = m;
    *info = (dth_model_info){.n = 2, .autonomous = 1, .separable = 1, .hess_kind = DTH_HESS_DENSE};
    return DTH_OK;
}

static void destroy(void *self, const dth_allocator *alloc) { dth_free(alloc, self); }

/* y = (q1, q2, t, p1, p2); gradient and Hessian over y (5 x 5, row-major) */
static int eval(const void *self, const double *y, unsigned what, double *H, double *g, double *h)
{
    const henon_heiles *m = self;
    double x = y[0], v = y[1], px = y[3], pv = y[4], l = m->lambda;
    if (what & DTH_EVAL_H)
        *H = 0.5 * (px * px + pv * pv) + 0.5 * (x * x + v * v) + l * (x * x * v - v * v * v / 3);
    if (what & DTH_EVAL_GRAD) {
        g[0] = x + 2 * l * x * v;
        g[1] = v + l * (x * x - v * v);
        g[2] = 0;
        g[3] = px;
        g[4] = pv;
    }
    if (what & DTH_EVAL_HESS) {
        for (int i = 0; i < 25; i++) h[i] = 0;
        h[0] = 1 + 2 * l * v;          /* d2/dq1 dq1 */
        h[1] = h[5] = 2 * l * x;       /* d2/dq1 dq2 */
        h[6] = 1 - 2 * l * v;          /* d2/dq2 dq2 */
        h[18] = h[24] = 1;             /* p1, p2 */
    }
    return 0;
}

const dth_model_type example_henon_heiles = {
DTH_MODEL_TYPE_HEAD,
    .name = "henon-heiles",
    .doc = "Henon-Heiles H = |p|^2/2 + |q|^2/2 + lambda (q1^2 q2 - q2^3/3) (example of a user model)",
    .params = params,
    .n_params = sizeof params / sizeof params[0],
    .create = create,
    .destroy = destroy,
    .eval = eval,
};
