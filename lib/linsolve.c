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
#include "lu_small.h"

_Static_assert(sizeof(lapack_int) == sizeof(int), "pivots are stored as int");

const char *dth_linsolve_name(dth_linsolve k)
{
    switch (k) {
    case DTH_LINSOLVE_AUTO: return "auto";
    case DTH_LINSOLVE_DENSE: return "dense";
    case DTH_LINSOLVE_SMALL: return "small";
    case DTH_LINSOLVE_BANDED: return "banded";
    case DTH_LINSOLVE_BANDED_LU: return "banded-lu";
    case DTH_LINSOLVE_SMALL_LU: return "small-lu";
    default: return NULL;
    }
}

int dth__lu_small(dth_linsolve k, int m)
{
    return k == DTH_LINSOLVE_SMALL || k == DTH_LINSOLVE_SMALL_LU || (k != DTH_LINSOLVE_DENSE && m <= DTH__SMALL_MAX);
}

#define SIZES(F) F(1) F(2) F(3) F(4) F(5) F(6) F(7) F(8)
#define FACT_CASE(M) case M: return lu_factor_m(M, a, piv, NULL);
#define SOLVE_CASE(M) case M: lu_solve_m(M, a, piv, NULL, x); break;
_Static_assert(DTH__SMALL_MAX == 8, "the cases below cover m = 1 .. 8");

static int small_factor(int m, double *a, int *piv)
{
    switch (m) {
        SIZES(FACT_CASE)
    default: return lu_factor_m(m, a, piv, NULL);
    }
}

static void small_solve(int m, const double *a, const int *piv, int nrhs, double *b)
{
    for (int r = 0; r < nrhs; r++) {
        double *x = b + (size_t)r * (size_t)m;
        switch (m) {
            SIZES(SOLVE_CASE)
        default: lu_solve_m(m, a, piv, NULL, x);
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
