/* SPDX-License-Identifier: MIT */
/**
 * @file methods.h  The methods an integrator steps with (dth_options.method): the DTH step and
 * fixed-step baselines of the physical system, for comparison with DTH (paper, section 1: the
 * symplectic and energy-conserving methods SEM integration competes with); and the conditioning
 * limits of the DTH step (paper, Lemma g_taylor: g'(lambda) ~ -psi lambda / 4, so lambda is fixed
 * by a second-order effect).
 *
 * The baselines integrate y = (q, t, p) with dy/dt = (dH/dp, 1, -dH/dq), using the model's gradient
 * and Hessian through dth_model_eval, with the step dth_options.h; an integrator of a baseline
 * reports the extended state z = (q, t, p, wp) with wp = -H_phys at the start, carried unchanged
 * (so H(z) is the energy error), has no midpoints and no tangent map. Methods, selected by name:
 *   "midpoint"       implicit midpoint rule (1-stage Gauss), Newton with LU;
 *   "gauss4"         2-stage Gauss-Legendre, order 4, symplectic, Newton on the stage system;
 *   "rk4"            classical explicit Runge-Kutta, order 4;
 *   "verlet"         Stormer-Verlet (kick-drift-kick), separable models only;
 *   "midpoint-proj"  implicit midpoint followed by the simple orthogonal projection onto the
 *                    initial energy along grad_(q,p) H (not symmetric, not symplectic);
 *                    autonomous models only.
 * The state update is compensated (y kept as a double-double sum), like the DTH vertex. The step
 * record (dth_step_info) of a baseline has lambda = h, its Newton iterations, and for
 * "midpoint-proj" the projection's iterations in proj_iters.
 */
#ifndef DTH_METHODS_H
#define DTH_METHODS_H

#include <stddef.h>
#include "dth/model.h"

#ifdef __cplusplus
extern "C" {
#endif

/** Number of methods dth_options.method accepts ("dth" first, then the baselines). */
DTH_API size_t dth_method_count(void);
/** Name of method i (0 <= i < count), NULL out of range. */
DTH_API const char *dth_method_name(size_t i);
/** One-line description of the method called `name`, NULL if unknown. */
DTH_API const char *dth_method_doc(const char *name);

/**
 * Conditioning limit of the DTH step at the vertex z (length 2n+2). The step lambda solves
 * g(lambda) = H(zbar(lambda)) = 0 with g(lambda) ~ H_k - psi lambda^2/8, so an error dg in
 * evaluating H at the midpoint moves lambda by dg / |g'| = 4 dg / (|psi| |lambda|). With dg =
 * eps * S, S = |wp| + |H_phys| + sum_j |dH/dy_j y_j| (the size of the terms that cancel in
 * H(zbar)), the relative accuracy of lambda is about 4 eps S / (|psi| lambda^2). This returns
 *     *h_min = sqrt(4 eps S / (|psi| rel_tol)),
 * the smallest |lambda| whose relative accuracy is still rel_tol (rel_tol in (0, 1]). Below it
 * lambda (and t, which sums the lambdas) is round-off noise at that level.
 * `work` must hold dth_model_work_size(model) doubles.
 * @return DTH_OK; DTH_EINVAL (bad arguments); DTH_ESINGULAR when psi = 0 at z (region III or an
 * equilibrium: the step is then fixed by psi', *h_min = INFINITY as a warning); model status.
 */
DTH_API int dth_step_floor(const dth_model *model, const double *z, double rel_tol,
                           double *h_min, double *work);

/**
 * The step floor's twin: the largest step the physical root is known to allow at the vertex z
 * (length 2n+2). In region II (psi'^2 > 24 K |psi|) the physical roots lambda+- have
 * s = -(psi'/psi) lambda below 6/5 (paper, Theorem EU_2): beyond |lambda| = 6/5 |psi / psi'| the
 * physical root has met the ghost (a fold), which is where a stiff step (omega h near 2) ends. This
 * returns *h_max = 6/5 |psi / psi'| (INFINITY where psi' = 0: region I, the cubic bound of Theorem
 * EU_1 then needs K). A run that ended at such a fold passes with a step law about h_max/|lambda|
 * smaller, or with the default regularizer where it can carry the fold.
 * `work` must hold dth_model_work_size(model) doubles.
 * @return DTH_OK; DTH_EINVAL; DTH_ESINGULAR where psi = 0 (*h_max = 0); the model's status.
 */
DTH_API int dth_step_ceiling(const dth_model *model, const double *z, double *h_max, double *work);

#ifdef __cplusplus
}
#endif
#endif
