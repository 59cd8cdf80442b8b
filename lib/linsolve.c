/* SPDX-License-Identifier: MIT */
/*
 * Dense LU of the Newton systems (the bordered step Jacobian of the paper's Theorem "DTH Equations",
 * the decoupled solve, the kicked segment, the Gauss stages): LAPACK's dgetrf/dgetrs, and for
 * m <= DTH__SMALL_MAX an LU with partial pivoting written out here (no library call: at that size
 * a LAPACK call costs more than the arithmetic, and OpenBLAS serializes threads on a global lock).
 * banded.c has the banded solves.
 */
#include <math.h>
#include <lapacke.h>
#include "dth_internal.h"

_Static_assert(sizeof(lapack_int) == sizeof(int), "pivots are stored as int");

const char *dth_linsolve_name(dth_linsolve k)
{
    switch (k) {
    case DTH_LINSOLVE_AUTO: return "auto";
    case DTH_LINSOLVE_DENSE: return "dense";
    case DTH_LINSOLVE_SMALL: return "small";
    case DTH_LINSOLVE_BANDED: return "banded";
    default: return NULL;
    }
}

int dth__lu_small(dth_linsolve k, int m) { return k == DTH_LINSOLVE_SMALL || (k != DTH_LINSOLVE_DENSE && m <= DTH__SMALL_MAX); }

/* Doolittle LU with partial pivoting, column-major, in place; piv 1-based like LAPACK. */
static int small_factor(int m, double *a, int *piv)
{
    for (int k = 0; k < m; k++) {
        int p = k;
        double best = fabs(a[k + k * m]);
        for (int i = k + 1; i < m; i++) {
            double v = fabs(a[i + k * m]);
            if (v > best) best = v, p = i;
        }
        piv[k] = p + 1;
        if (!(best > 0)) return best == 0 ? DTH_ESINGULAR : DTH_OK; /* NaN: the solve shows it */
        if (p != k)
            for (int j = 0; j < m; j++) {
                double t = a[k + j * m];
                a[k + j * m] = a[p + j * m];
                a[p + j * m] = t;
            }
        double inv = 1.0 / a[k + k * m];
        for (int i = k + 1; i < m; i++) a[i + k * m] *= inv;
        for (int j = k + 1; j < m; j++) {
            double akj = a[k + j * m];
            if (akj == 0) continue;
            for (int i = k + 1; i < m; i++) a[i + j * m] -= a[i + k * m] * akj;
        }
    }
    return DTH_OK;
}

static void small_solve(int m, const double *a, const int *piv, int nrhs, double *b)
{
    for (int r = 0; r < nrhs; r++) {
        double *x = b + (size_t)r * (size_t)m;
        for (int k = 0; k < m; k++) {
            int p = piv[k] - 1;
            if (p != k) {
                double t = x[k];
                x[k] = x[p];
                x[p] = t;
            }
        }
        for (int j = 0; j < m; j++) {
            double xj = x[j];
            for (int i = j + 1; i < m; i++) x[i] -= a[i + j * m] * xj;
        }
        for (int j = m - 1; j >= 0; j--) {
            x[j] /= a[j + j * m];
            double xj = x[j];
            for (int i = 0; i < j; i++) x[i] -= a[i + j * m] * xj;
        }
    }
}

int dth__lu_factor(dth_linsolve k, int m, double *a, int *piv)
{
    if (dth__lu_small(k, m)) return small_factor(m, a, piv);
    /* The _work variants skip LAPACKE's NaN scan and layout copies: the caller checks results. */
    lapack_int info = LAPACKE_dgetrf_work(LAPACK_COL_MAJOR, m, m, a, m, piv);
    if (info < 0) return DTH_ELAPACK;
    if (info > 0) return DTH_ESINGULAR;
    return DTH_OK;
}

int dth__lu_solve(dth_linsolve k, int m, const double *a, const int *piv, int nrhs, double *b)
{
    if (dth__lu_small(k, m)) {
        small_solve(m, a, piv, nrhs, b);
        return DTH_OK;
    }
    lapack_int info = LAPACKE_dgetrs_work(LAPACK_COL_MAJOR, 'N', m, nrhs, a, m, piv, b, m);
    return info < 0 ? DTH_ELAPACK : DTH_OK;
}

int dth__lu_det_sign(int m, const double *a, const int *piv)
{
    int s = 1;
    for (int k = 0; k < m; k++) {
        if (piv[k] - 1 != k) s = -s;
        double u = a[k + k * m];
        if (u < 0) s = -s;
        else if (!(u > 0)) return 0;
    }
    return s;
}
