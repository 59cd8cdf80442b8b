/* SPDX-License-Identifier: MIT */
/**
 * @file methods.h  Fixed-step baseline integrators of the physical system, for comparison with
 * DTH (paper, section 1: the symplectic and energy-conserving methods SEM integration competes
 * with), and the conditioning limit of the DTH step (paper, Lemma g_taylor: g'(lambda) ~ -psi
 * lambda / 4, so lambda is fixed by a second-order effect).
 *
 * The baselines integrate y = (q, t, p) (length 2n+1) with dy/dt = (dH/dp, 1, -dH/dq), using
 * the model's gradient and Hessian through dth_model_eval. Methods, selected by name:
 *   "midpoint"       implicit midpoint rule (1-stage Gauss), Newton with LU;
 *   "gauss4"         2-stage Gauss-Legendre, order 4, symplectic, Newton on the stage system;
 *   "rk4"            classical explicit Runge-Kutta, order 4;
 *   "verlet"         Stormer-Verlet (kick-drift-kick), separable models only;
 *   "midpoint-proj"  implicit midpoint followed by the simple orthogonal projection onto the
 *                    initial energy along grad_(q,p) H (not symmetric, not symplectic);
 *                    autonomous models only.
 * The state update is compensated (y kept as a double-double sum), like the DTH vertex.
 */
#ifndef DTH_METHODS_H
#define DTH_METHODS_H

#include <stddef.h>
#include "dth/model.h"

#ifdef __cplusplus
extern "C" {
#endif

/** A fixed-step integrator of the physical system. Opaque. */
typedef struct dth_fixed dth_fixed;

/** Record of one fixed step. */
typedef struct dth_fixed_info {
    int iters;       /**< Newton iterations (LU factorizations) of the step, 0 if explicit */
    int proj_iters;  /**< projection iterations (midpoint-proj), else 0 */
} dth_fixed_info;

/** Number of methods dth_fixed_new accepts. */
DTH_API size_t dth_fixed_method_count(void);
/** Name of method i (0 <= i < count), NULL out of range. */
DTH_API const char *dth_fixed_method_name(size_t i);
/** One-line description of the method called `name`, NULL if unknown. */
DTH_API const char *dth_fixed_method_doc(const char *name);

/**
 * Create a fixed-step integrator with step h (its sign is the direction) for `model` (borrowed).
 * All working memory is allocated here; stepping allocates nothing.
 * @return DTH_OK; DTH_ENOTFOUND (unknown method name); DTH_EINVAL (h == 0 or not finite, NULL
 * argument); DTH_EUNSUPPORTED ("verlet" on a non-separable model, "midpoint-proj" on a
 * non-autonomous one: dth_fixed_new writes no message, see dth_fixed_check); DTH_ENOMEM.
 */
DTH_API int dth_fixed_new(const dth_model *model, const char *method, double h,
                          const dth_allocator *alloc, dth_fixed **out);

/**
 * Can `method` integrate `model`? Writes a one-line reason into `why` (may be NULL) when not.
 * @return DTH_OK, DTH_ENOTFOUND, DTH_EUNSUPPORTED.
 */
DTH_API int dth_fixed_check(const dth_model *model, const char *method, char *why, size_t len);

/** Free; NULL is a no-op. */
DTH_API void dth_fixed_free(dth_fixed *f);

/**
 * Set the initial state. @return DTH_OK, DTH_EINVAL (non-finite input), DTH_EDOMAIN /
 * DTH_EMODEL from the model.
 */
DTH_API int dth_fixed_start(dth_fixed *f, const double *q0, const double *p0, double t0);

/**
 * One step of size h. On failure the state is exactly as before the call.
 * @return DTH_OK, DTH_ENOCONV (Newton or projection did not converge), DTH_ESINGULAR,
 * DTH_EDOMAIN, DTH_EMODEL, DTH_EINVAL (not started).
 */
DTH_API int dth_fixed_step(dth_fixed *f, dth_fixed_info *info);

/** Change the step size for the following steps. @return DTH_OK, DTH_EINVAL. */
DTH_API int dth_fixed_set_h(dth_fixed *f, double h);

/** The current state y = (q, t, p), length 2n+1. */
DTH_API const double *dth_fixed_state(const dth_fixed *f);
/** Steps taken since start. */
DTH_API long dth_fixed_steps(const dth_fixed *f);
/** The current step size h (signed). */
DTH_API double dth_fixed_h(const dth_fixed *f);
/** The model it integrates. */
DTH_API const dth_model *dth_fixed_model(const dth_fixed *f);
/** The method's name. */
DTH_API const char *dth_fixed_name(const dth_fixed *f);
/** Classical order of the method. */
DTH_API int dth_fixed_order(const dth_fixed *f);
/** Detail of the last failure (a fixed string if none). */
DTH_API const char *dth_fixed_errmsg(const dth_fixed *f);

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
