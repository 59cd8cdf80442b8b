/* SPDX-License-Identifier: MIT */
/* Helpers shared by the shipped regularizers (regularize/: none, prescribed, land; paper, section 7). */
#ifndef DTH_REG_COMMON_H
#define DTH_REG_COMMON_H

#include <stdio.h>
#include <string.h>
#include "dth/regularize.h"

/* A create() error: "parameter 'KEY' must be WHAT" into a->err (if given); DTH_EINVAL. */
static inline int dth__reg_param_err(const dth_reg_args *a, const char *key, const char *what)
{
    if (a->err && a->errlen) snprintf(a->err, a->errlen, "parameter '%s' must be %s", key, what);
    return DTH_EINVAL;
}

/* |grad_(q,p) H|^2 from a gradient g of length 2n+2 (q at 0..n-1, p at n+1..2n; t and wp left out). */
static inline double dth__reg_grad_qp2(const double *g, size_t n)
{
    double s = 0;
    for (size_t i = 0; i < n; i++) s += g[i] * g[i] + g[n + 1 + i] * g[n + 1 + i];
    return s;
}

/* The Euler half step d = (lam/2) J grad H(z + zlo) over (q, p), zero in t and wp: a kicked
 * segment's seed when there is no better one. y, g: scratch of length 2n+2 (y's wp entry is not
 * written; H does not read it); d is left untouched if the evaluation fails. */
static inline int dth__reg_euler_seed(const dth_model *m, size_t n, const double *z, const double *zlo, double lam,
                                      double *d, double *y, double *g)
{
    size_t N = 2 * n + 2;
    for (size_t j = 0; j < N - 1; j++) y[j] = z[j] + zlo[j];
    double H;
    int rc = dth_model_eval(m, y, DTH_EVAL_H | DTH_EVAL_GRAD, &H, g, NULL);
    if (rc) return rc;
    memset(d, 0, N * sizeof *d);
    for (size_t i = 0; i < n; i++) {
        d[i] = 0.5 * lam * g[n + 1 + i];
        d[n + 1 + i] = -0.5 * lam * g[i];
    }
    return DTH_OK;
}

#endif
