/* SPDX-License-Identifier: MIT */
/*
 * The library's one Newton loop (paper, Theorem "DTH Equations": the step's bordered system; also
 * the decoupled solve, the kicked segment and the Gauss baselines), inline so that a caller whose
 * problem is known at compile time (the DTH step's small path) gets its callbacks inlined;
 * newton.c holds the out-of-line dth__newton_run for the others.
 */
#ifndef DTH_NEWTON_H
#define DTH_NEWTON_H

#include <float.h>
#include <math.h>
#include <string.h>
#include "dth_internal.h"

static inline __attribute__((always_inline)) int dth__newton_rate_inl(double r, double r_prev, int iter, double tol)
{
    if (!isfinite(r)) return DTH__NT_DIVERGED;
    if (r <= tol) return DTH__NT_DONE;
    /* Quadratic rate r_(k+1) ~ r_k^3 / r_(k-1)^2: when the next correction is predicted below
     * round-off, finish with one chord step (the factors at hand, no new Jacobian) instead of a
     * full iteration. Without it the last residual keeps one sign from step to step and quadratic
     * invariants drift like N instead of Brouwer's sqrt(N). */
    if (iter >= 2 && r < 1e-6 && r * (r / r_prev) * (r / r_prev) <= DBL_EPSILON) return DTH__NT_CHORD;
    if (r >= 0.5 * r_prev) return DTH__NT_STALLED;
    return DTH__NT_MORE;
}

/*
 * dth__newton_run's loop; `again` (NULL: never) may ask for more than one finishing chord step.
 * xlo (NULL: none) receives the finishing chord steps' updates in double-double, x + xlo (zero it
 * before; the iterations leave it alone): a root resolved below the ulp of x, which the caller's
 * residual must then read (the DTH step's compensated constraint, integrator.c).
 */
static inline __attribute__((always_inline)) int dth__newton_iterate(const dth__newton_ops *ops, dth__newton_again again,
                                                                     void *ctx, const int m, int max_iter, double *x,
                                                                     double *xlo, double *F, double *dx,
                                                                     dth__newton_track *tr)
{
    tr->iter = 0;
    tr->r = NAN;
    tr->r_prev = INFINITY;
    tr->verdict = DTH__NT_MORE;
    for (int iter = 1; iter <= max_iter; iter++) {
        tr->iter = iter;
        int rc = ops->eval(ctx, x, F, 1);
        if (rc) return rc;
        memcpy(dx, F, (size_t)m * sizeof *dx);
        rc = ops->solve(ctx, dx);
        if (rc) return rc;
        for (int a = 0; a < m; a++) x[a] -= dx[a];
        int verdict = DTH__NT_MORE;
        rc = ops->judge(ctx, x, dx, F, tr, &verdict);
        tr->verdict = verdict;
        if (rc) return rc;
        if (verdict == DTH__NT_DONE) return DTH_OK;
        if (verdict == DTH__NT_CHORD) {
            /* chord steps: the residual only, the factors stay (more than one where `again` asks:
             * the DTH step's finishing residual differs from the one iterated on) */
            for (int chords = 1;; chords++) {
                rc = ops->eval(ctx, x, dx, 0);
                if (!rc) rc = ops->solve(ctx, dx);
                if (rc) return rc;
                if (xlo) {
                    for (int a = 0; a < m; a++) { /* x + xlo - dx by TwoSum, renormalized */
                        double s = x[a] - dx[a], bb = s - x[a], e = (x[a] - (s - bb)) + (-dx[a] - bb);
                        double t = xlo[a] + e, h = s + t, tt = h - s;
                        xlo[a] = (s - (h - tt)) + (t - tt);
                        x[a] = h;
                    }
                } else {
                    for (int a = 0; a < m; a++) x[a] -= dx[a];
                }
                if (!again || !again(ctx, x, dx, chords)) return DTH_OK;
            }
        }
        tr->r_prev = tr->r;
    }
    tr->verdict = DTH__NT_MAXITER;
    return DTH_ENOCONV;
}

#endif
