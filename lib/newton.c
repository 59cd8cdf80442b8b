/* SPDX-License-Identifier: MIT */
/*
 * The one Newton driver of the library (its loop: newton.h): the DTH step's bordered system (paper,
 * Theorem "DTH Equations"), the decoupled solve of Theorem "Decoupling", the kicked segment and the
 * Gauss baselines all iterate through it, each with its own residual/Jacobian, linear solver and
 * convergence test.
 */
#include "newton.h"

int dth__newton_rate(double r, double r_prev, int iter, double tol) { return dth__newton_rate_inl(r, r_prev, iter, tol); }

int dth__newton_run(const dth__newton_ops *ops, void *ctx, int m, int max_iter, double *x, double *F, double *dx,
                    dth__newton_track *tr)
{
    return dth__newton_iterate(ops, NULL, ctx, m, max_iter, x, NULL, F, dx, tr);
}
