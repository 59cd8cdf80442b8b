/* SPDX-License-Identifier: MIT */
/* Dense LU for the bordered Newton system of the DTH step (LAPACKE); banded.c has the banded solve. */
#include <lapacke.h>
#include "dth_internal.h"

_Static_assert(sizeof(lapack_int) == sizeof(int), "pivots are stored as int");

int dth__lu_factor(int m, double *a, int *piv)
{
    /* The _work variants skip LAPACKE's NaN scan and layout copies: the caller checks inputs. */
    lapack_int info = LAPACKE_dgetrf_work(LAPACK_COL_MAJOR, m, m, a, m, piv);
    if (info < 0) return DTH_ELAPACK;
    if (info > 0) return DTH_ESINGULAR;
    return DTH_OK;
}

int dth__lu_solve(int m, const double *a, const int *piv, int nrhs, double *b)
{
    lapack_int info = LAPACKE_dgetrs_work(LAPACK_COL_MAJOR, 'N', m, nrhs, a, m, piv, b, m);
    return info < 0 ? DTH_ELAPACK : DTH_OK;
}
