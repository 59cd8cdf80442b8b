/* SPDX-License-Identifier: MIT */
/* The small dense LU (partial pivoting, column-major, 1-based pivots like LAPACK) as inline kernels,
 * so that callers with a compile-time size get unrolled loops: linsolve.c dispatches on m, the DTH
 * step's small path (integrator.c) instantiates them for its own m. */
#ifndef DTH_LU_SMALL_H
#define DTH_LU_SMALL_H

#include <math.h>
#include "dth/status.h"

/* Doolittle LU with partial pivoting, column-major, in place; piv 1-based like LAPACK; dinv (NULL:
 * not kept) gets the reciprocals of the pivots, for solves that multiply instead of dividing (a
 * division's latency dominates a solve of this size). Inlined for each m <= DTH__SMALL_MAX, so that
 * the loops unroll for the size at hand (and a constant NULL dinv folds away). */
static inline __attribute__((always_inline)) int lu_factor_m(const int m, double *a, int *piv, double *dinv)
{
#pragma GCC unroll 8
    for (int k = 0; k < m; k++) {
        int p = k;
        double best = fabs(a[k + k * m]);
        for (int i = k + 1; i < m; i++) {
            double v = fabs(a[i + k * m]);
            if (v > best) best = v, p = i;
        }
        piv[k] = p + 1;
        if (!(best > 0)) { /* NaN: the solve shows it (the remaining pivots are set, so it stays in bounds) */
            for (int j = k + 1; j < m; j++) piv[j] = j + 1;
            if (dinv)
                for (int j = k; j < m; j++) dinv[j] = best;
            return best == 0 ? DTH_ESINGULAR : DTH_OK;
        }
        if (p != k)
            for (int j = 0; j < m; j++) {
                double t = a[k + j * m];
                a[k + j * m] = a[p + j * m];
                a[p + j * m] = t;
            }
        double inv = 1.0 / a[k + k * m];
        if (dinv) dinv[k] = inv;
        for (int i = k + 1; i < m; i++) a[i + k * m] *= inv;
#pragma GCC unroll 8
        for (int j = k + 1; j < m; j++) {
            double akj = a[k + j * m];
#pragma GCC unroll 8
            for (int i = k + 1; i < m; i++) a[i + j * m] -= a[i + k * m] * akj;
        }
    }
    return DTH_OK;
}

/* x = A^-1 x with lu_factor_m's factors; dinv: the reciprocals of the pivots it kept (the back
 * substitution multiplies by them), NULL: divide by the pivots. */
static inline __attribute__((always_inline)) void lu_solve_m(const int m, const double *a, const int *piv,
                                                             const double *dinv, double *x)
{
    for (int k = 0; k < m; k++) {
        int p = piv[k] - 1;
        if (p != k) {
            double t = x[k];
            x[k] = x[p];
            x[p] = t;
        }
    }
#pragma GCC unroll 8
    for (int j = 0; j < m; j++) {
        double xj = x[j];
#pragma GCC unroll 8
        for (int i = j + 1; i < m; i++) x[i] -= a[i + j * m] * xj;
    }
#pragma GCC unroll 8
    for (int j = m - 1; j >= 0; j--) {
        if (dinv) x[j] *= dinv[j];
        else x[j] /= a[j + j * m];
        double xj = x[j];
#pragma GCC unroll 8
        for (int i = 0; i < j; i++) x[i] -= a[i + j * m] * xj;
    }
}

#endif
