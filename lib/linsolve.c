/* SPDX-License-Identifier: MIT */
/*
 * Dense LU of the Newton systems (the bordered step Jacobian of the paper's Theorem "DTH Equations",
 * the decoupled solve, the kicked segment, the Gauss stages): LAPACK's dgetrf/dgetrs, and for
 * m <= DTH__SMALL_MAX an LU with partial pivoting written out here (no library call: at that size
 * a LAPACK call costs more than the arithmetic, and OpenBLAS serializes threads on a global lock).
 * banded.c has the banded solves.
 */
#include <math.h>
#include <string.h>
#include <lapacke.h>
#include "dth_internal.h"
#include "lu_small.h"

_Static_assert(sizeof(lapack_int) == sizeof(int), "pivots are stored as int");

/* The linear-solver seam: one entry per choice, with the step's factor/solve/tangent for it
 * (dth_newton.c's dth__dense_ls and dth__band_ls; banded.c has the banded solves). AUTO resolves by
 * dth__linsolve_resolve. */
static const dth__linsolve_info solvers[] = {
    {DTH_LINSOLVE_AUTO, "auto", 0, "banded for banded models, else small for m <= 8 unknowns, else dense", NULL},
    {DTH_LINSOLVE_DENSE, "dense", 0, "LAPACK dgetrf/dgetrs on the bordered system: the reference path", &dth__dense_ls},
    {DTH_LINSOLVE_SMALL, "small", 0, "written out, no library call; the Schur complement for separable models",
     &dth__dense_ls},
    {DTH_LINSOLVE_BANDED, "banded", 1, "banded models: the banded Schur complement (Cholesky), else banded LU",
     &dth__band_ls},
    {DTH_LINSOLVE_BANDED_LU, "banded-lu", 1, "banded models: banded LU of the whole step matrix", &dth__band_ls},
    {DTH_LINSOLVE_SMALL_LU, "small-lu", 0, "the small path's LU with partial pivoting, never its Schur complement",
     &dth__dense_ls},
};
enum { NSOLVERS = sizeof solvers / sizeof solvers[0] };

const dth__linsolve_info *dth__linsolve_find(dth_linsolve k)
{
    for (size_t i = 0; i < NSOLVERS; i++)
        if (solvers[i].kind == k) return &solvers[i];
    return NULL;
}

const dth__linsolve_info *dth__linsolve_at(size_t i) { return i < NSOLVERS ? &solvers[i] : NULL; }

dth_linsolve dth__linsolve_resolve(dth_linsolve k, int banded_model, size_t m)
{
    if (k != DTH_LINSOLVE_AUTO) return k;
    return banded_model ? DTH_LINSOLVE_BANDED : m <= DTH__SMALL_MAX ? DTH_LINSOLVE_SMALL : DTH_LINSOLVE_DENSE;
}

const char *dth_linsolve_name(dth_linsolve k)
{
    const dth__linsolve_info *s = dth__linsolve_find(k);
    return s ? s->name : NULL;
}

int dth_linsolve_from_name(const char *name, dth_linsolve *out)
{
    for (size_t i = 0; name && i < NSOLVERS; i++)
        if (strcmp(solvers[i].name, name) == 0) {
            if (out) *out = solvers[i].kind;
            return DTH_OK;
        }
    return DTH_ENOTFOUND;
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
