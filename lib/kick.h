/* SPDX-License-Identifier: MIT */
/* The kick direction's pieces (regularize.c), shared by the kicked segments there and prescribed_rev.c. */
#ifndef DTH_KICK_H
#define DTH_KICK_H

#include <stddef.h>
#include "dth/model.h"

/* The model's number of invariants (0 without an invariants callback). */
size_t dth__model_ninv(const dth_model *model);
/* The quadratic invariants' gradients at y, scaled by sc and orthonormalized into the rows of G; graw
 * (NULL: not wanted) the gradients themselves (all rows), kidx (NULL: not wanted) the invariant of each
 * kept row. ys and tmp are scratch. Returns the rows kept (dth__quad_invariant_basis without graw, kidx). */
size_t dth__quad_invariant_basis_ex(const dth_model *model, const double *y, const double *sc, double *G, double *ys,
                                    double *tmp, double *graw, size_t *kidx);
/* The squared Frobenius norms of the Hessian's q-q and p-p blocks. */
void dth__kick_metric_blocks(size_t n, const double *hs, double *fq_out, double *fp_out);
/* The metric's rho = (fp/fq)^(1/4), clamped; *smooth (may be NULL) = 1 where not clamped nor fallen back. */
double dth__kick_metric_rho(double fq, double fp, int *smooth);
/* The kick's metric S = diag(sc) at a point with Hessian hs. */
void dth__kick_metric(const dth_model *model, size_t n, const double *hs, double *sc);
/* The kick direction n = S P S grad H over (q, p) at y (gradient g, Hessian hs): its metric into sc, the
 * invariants' orthonormal rows into G (returns how many). */
size_t dth__kick_dir(const dth_model *model, size_t n, const double *y, const double *g, const double *hs, double *sc,
                     double *G, double *ys, double *tmp, double *nv);
/* The kick's block of a Newton Jacobian (column-major, leading dimension m). */
void dth__kick_block(size_t n, size_t m, const double *hs, const double *sc, const double *G, size_t kept, double lam,
                     double kmu, double *A);

#endif
