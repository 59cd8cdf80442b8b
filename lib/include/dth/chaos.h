/* SPDX-License-Identifier: MIT */
/**
 * @file chaos.h  Chaos indicators from the tangent map of the DTH step: MEGNO (the Mean Exponential
 * Growth factor of Nearby Orbits, Cincotta and Simo 2000) and a finite-time estimate of the largest
 * Lyapunov exponent.
 *
 * A deviation vector delta (2n+2 values over the extended state z = (q, t, p, wp)) is carried
 * through every step by the step's tangent map M = dz_(k+1)/dz_k (dth_integrator_tangent), and
 * renormalized after each step. With g_k = ln(|delta_(k+1)| / |delta_k|) over the step from t_k
 * to t_(k+1) = t_k + lambda_k and s_k = t_k + lambda_k/2 - t_0 the step's midpoint time:
 *     Y(t_(k+1)) = (2 / (t_(k+1) - t_0)) sum_(j <= k) s_j g_j      (MEGNO: 2/t int s d ln|delta|)
 *     <Y>(t)     = (1 / (t - t_0)) sum_k Y(t_(k+1)) |lambda_k|     (its running mean)
 *     lyapunov   = ln(|delta(t)| / |delta(t_0)|) / (t - t_0)
 * For a quasi-periodic (regular) orbit |delta| grows linearly and <Y> tends to 2; for a stable
 * periodic orbit with no shear it tends to 0; for a chaotic orbit it grows like lyapunov t / 2.
 *
 * Steps without a tangent map: a regularizer's step (DTH_STEP_REGULARIZED: a kicked segment, or a
 * changeover step of the smooth regularizer) has none, and the regularized map is neither
 * symplectic nor smooth in the initial condition (its choice between step kinds is a discrete
 * one: two rotating-pendulum trajectories 1e-9 apart take 362 and 363 regularized steps by t = 60
 * and then differ by a step's local error). Substitutes were tried and rejected: carrying delta
 * across such steps by the linearized flow's Cayley map, or by central differences of the
 * regularized step, makes MEGNO grow linearly in t on the rotating pendulum (a spurious Lyapunov
 * exponent of 0.2) where nearby trajectories separate linearly. So the indicators END at the first
 * step without a tangent map: t_stop records where, and megno, lyapunov and span cover the
 * ordinary stretch before it. A run that never regularizes (no psi = 0 crossing) is followed whole.
 *
 * Memory: (2n+2)^2 doubles for the tangent map; each step costs one tangent map (a refactorization
 * at the converged midpoint) and a matrix-vector product.
 */
#ifndef DTH_CHAOS_H
#define DTH_CHAOS_H

#include <stddef.h>
#include "dth/integrator.h"

#ifdef __cplusplus
extern "C" {
#endif

/** MEGNO and Lyapunov accumulators for one trajectory. Opaque. */
typedef struct dth_megno dth_megno;

/** What dth_megno_get reports. */
typedef struct dth_megno_result {
    double megno;     /**< the mean <Y>(t) (NaN before the first step) */
    double y;         /**< Y(t) at the last step */
    double lyapunov;  /**< ln(|delta(t)| / |delta(t_0)|) / (t - t_0) */
    double span;      /**< |t - t_0| followed */
    long steps;       /**< steps followed */
    double t_stop;    /**< the start time of the first step without a tangent map, which ended the
                           indicators (NaN: every step so far had one) */
} dth_megno_result;

/**
 * Start following the integrator `it` from its current vertex (time t_0), with the deviation
 * vector delta0 (2n+2 values, not all zero; NULL: equal weight 1/sqrt(2n) on every q and p).
 * @return DTH_OK, DTH_EINVAL (bad arguments, a zero or non-finite delta0), DTH_ENOMEM.
 */
DTH_API int dth_megno_new(const dth_integrator *it, const double *delta0, const dth_allocator *alloc,
                          dth_megno **out);
/**
 * dth_megno_new with the length of delta0 given and checked: `len` must be 2n+2 (0 with delta0 NULL).
 * For callers whose vector comes from outside the program's control (a language binding, a file):
 * dth_megno_new reads 2n+2 values from delta0 whatever it holds.
 * @return as dth_megno_new; DTH_EINVAL also for another length.
 */
DTH_API int dth_megno_new_len(const dth_integrator *it, const double *delta0, size_t len, const dth_allocator *alloc,
                              dth_megno **out);
/** Free; NULL is a no-op. */
DTH_API void dth_megno_free(dth_megno *g);

/**
 * Account for the integrator's last step. Call it after every step (for example from the run
 * driver's progress callback with progress_every = 1, and once after dth_run returns); a call
 * with no new step since the last one does nothing.
 * A step without a tangent map ends the indicators (see above); later calls only count steps.
 * @return DTH_OK; DTH_EINVAL if more than one step was taken since the last call (a step was
 * missed) or `it` went back; the tangent map's status (the model's); DTH_EDOMAIN if delta
 * overflows or vanishes.
 */
DTH_API int dth_megno_update(dth_megno *g, dth_integrator *it);

/** The indicators so far. */
DTH_API void dth_megno_get(const dth_megno *g, dth_megno_result *r);

#ifdef __cplusplus
}
#endif
#endif
