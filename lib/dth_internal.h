/* SPDX-License-Identifier: MIT */
/* Internal declarations shared by the library's files (dth__ prefix, not installed). */
#ifndef DTH_INTERNAL_H
#define DTH_INTERNAL_H

#include <float.h>
#include <stddef.h>
#include "dth/integrator.h"
#include "dth/model.h"

/** The model's own state pointer (for calling optional callbacks directly). */
const void *dth__model_self(const dth_model *m);
/** 1 if the model type's parameter spec accepts `key`. */
int dth__model_accepts_key(const dth_model_type *t, const char *key);
/** u = J grad H over y = (q, t, p): (dH/dp, 1, -dH/dq). */
void dth__flow_y(size_t n, const double *grad, double *u);
/** Parse a comma-separated list of finite doubles; 0 on success. */
int dth__parse_list(const char *v, double *out, size_t max, size_t *count);

/* ---- dense LU through LAPACKE (linsolve.c is the only file that calls LAPACK) ---- */

/** Factor the column-major m x m matrix a in place; piv gets m pivots.
 *  @return DTH_OK, DTH_ESINGULAR, DTH_ELAPACK. */
int dth__lu_factor(int m, double *a, int *piv);
/** Solve with the factors for nrhs column-major right-hand sides in b (ldb = m). */
int dth__lu_solve(int m, const double *a, const int *piv, int nrhs, double *b);

#endif
