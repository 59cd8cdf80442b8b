/* SPDX-License-Identifier: MIT */
/**
 * @file control.h  Step control by the run's constant: choose the first step of a DTH run so that
 * every step stays below a bound (h_max) or the estimated global error at t_end stays below a
 * tolerance (tol).
 *
 * DTH does not choose its steps from h: away from psi = 0 an ordinary step keeps lambda^6 psi(zbar)^2
 * constant along the run, and near psi = 0 the steps follow the same constant C through the law
 *     l(z; C):   l^6 sqrt(psi^4 + (psi' l)^4) = C       (psi' = d psi / dt)
 * (docs/theory.md, "What h fixes"). h only sets C through the first step. dth_control_calibrate sets C
 * instead, by silent pilot integrations (no samples, no output) from the run's own initial state, and
 * returns the first step h0 that gives it: run the integrator with opt.h = h0 (a midpoint start's first
 * step is h0 exactly, and the regularizer 'land' takes its C from the steps that follow).
 *
 *  - h_max: C <= min over the orbit of c(z) = h_m^6 sqrt(psi^4 + (psi' h_m)^4), h_m = 0.98 h_max (l is
 *    monotone in C, so this is "every step <= h_m"). The minimum is taken over the pilots' midpoints
 *    with psi interpolated between consecutive midpoints by the cubic Hermite of (psi, psi'). The first
 *    pass starts with the step h_max (opt->h gives the direction only); at its first excursion (a step
 *    above 1.02 h_max) it is followed to its end, C recalibrated, and the next pass starts from t0 with
 *    h0 = l(z0; C). The new C is the least c(z) over every midpoint seen so far; where that explains
 *    less than the excursion's largest step L (a step at a psi = 0 crossing, which the regularizer
 *    takes and the law only approximates), C (h_m / L)^8 (steps at psi = 0 scale as C^(1/8)). A pass
 *    whose step failed (e.g. a first step too large to cross psi = 0 near the start) restarts with the
 *    law's C, or where the law sees nothing with half the steps, then a quarter, ...; no later pass
 *    takes a C as large as one whose pass failed. A pass that reaches the pilots' end without an
 *    excursion or a failure ends the calibration (at most max_passes passes; the last C found is then
 *    taken unverified). The run carries the guard dth_run_config.step_max = 1.05 h_max
 *    (dth_control_report.step_max): a part of the orbit the pilots did not see stops it with
 *    DTH_ESTEPSIZE.
 *  - tol: the estimated global position error grows as C^(1/3) (steps ~ C^(1/6), error ~ lambda^2).
 *    Pilots with the error estimate (dth_options.estimate) start at the C of opt->h (with h_max as well,
 *    the smaller of that and h_max's). A pilot stops early where its estimate passes a tenth of the
 *    largest |q| (orbit-sized: far too coarse; its estimate counts as that tenth). While a pilot's
 *    estimate at t_end (extrapolated linearly in time from a pilot that ends before t_end) lies outside
 *    [tol, 64 tol], or is orbit-sized, or a step failed: C <- C (16 tol / est)^3 (at most 2^18 times
 *    larger; an orbit-sized one at least 2^18 times smaller; a failed step without an estimate: C / 2^12)
 *    and another pilot; then C <- C (tol / (2 est))^3. With both, C is the smaller of the two.
 *
 * The pilots use the caller's options (copied: method dth only, the regularizer borrowed, its state
 * saved and restored around each pilot through its type's field list) and the caller's
 * model; nothing of the caller's is changed, also on failure. Calibrate with the regularizer in the state
 * the run starts from: 'land' keeps the C it took from a run's first steps, so a regularizer that already
 * ran would carry that C into the calibrated run.
 */
#ifndef DTH_CONTROL_H
#define DTH_CONTROL_H

#include <stddef.h>
#include "dth/model.h"
#include "dth/integrator.h"

#ifdef __cplusplus
extern "C" {
#endif

/** What to control. Initialize with dth_control_default(). */
typedef struct dth_control {
    size_t size;      /**< sizeof(dth_control) where the caller was compiled (set by dth_control_default;
                           dth_control_calibrate refuses another) */
    double h_max;     /**< > 0: every step at most h_max; 0: no bound */
    double tol;       /**< > 0: the estimated global position error |q - q_exact| at t_end at most tol; 0: none */
    double pilot;     /**< the time the pilots run to (between t0 and t_end); NaN: t_end */
    int max_passes;   /**< h_max: passes at most (default 8: the first and 7 restarts) */
    int max_pilots;   /**< tol: pilots at most before the final choice (default 8) */
} dth_control;

/** Defaults: size, h_max = tol = 0 (nothing to control), pilot = NaN (t_end), max_passes = 8,
 *  max_pilots = 8. */
DTH_API void dth_control_default(dth_control *c);

/** What the calibration found. */
typedef struct dth_control_report {
    size_t size;         /**< sizeof(dth_control_report) where the caller was compiled: set it before the call
                              (dth_control_calibrate refuses another) */
    double h0;           /**< the first step to run with (the sign of opt->h) */
    double C;            /**< the run's constant, l^6 sqrt(psi^4 + (psi' l)^4) at the initial state with l = |h0| */
    double C_hmax;       /**< the constant h_max asks for (INFINITY without h_max) */
    double C_tol;        /**< the constant tol asks for (INFINITY without tol) */
    double step_max;     /**< the guard for dth_run_config.step_max: 1.05 h_max (0 without h_max) */
    int passes;          /**< pilot integrations run (h_max passes and tol pilots) */
    long steps;          /**< steps spent in them */
    double t_pilot;      /**< the time the pilots ran to */
    int extrapolated;    /**< tol: the estimate came from a pilot that ended before t_end, extrapolated
                              linearly in time */
    double est;          /**< tol: the last pilot's estimate at t_end (extrapolated if so); NaN without tol */
    double est_pred;     /**< tol: the error predicted for the run, est (C / C_pilot)^(1/3); NaN without tol */
    int hmax_restarts;   /**< h_max: the passes that ended at an excursion */
    int hmax_settled;    /**< h_max: 1 if the last pass reached the pilots' end with every step <= 1.02 h_max;
                              0 if max_passes ran out first (the run's guard stops it where a step exceeds
                              step_max) */
    double t_excursion;  /**< h_max: the time of the last excursion's first step (NaN: none) */
    int pilot_status;    /**< DTH_OK, or the status of a step that failed in the last pass (the run meets it
                              too: the calibration used what that pass saw before it) */
    double t_failed;     /**< the vertex time where that step failed (NaN: none) */
} dth_control_report;

/**
 * Calibrate the run's constant for `ctl` (h_max, tol or both) by pilot integrations of `model` from
 * (q0, p0) at t0 (n values each) with the options `opt` (as the run will use them; opt->h: the first
 * pass's step and the direction of travel) to ctl->pilot (NaN: t_end). The calibrated run takes
 * opt->h = rep->h0 and dth_run_config.step_max = rep->step_max.
 * @return DTH_OK (rep filled); DTH_EINVAL (NULL, a wrong size, h_max and tol both 0, a value out of range,
 *   t_end or the pilot's end not finite or behind t0 in the direction of opt->h, a vertex start with an
 *   explicit wp); DTH_EUNSUPPORTED (a method other than dth); dth_options_check's status; DTH_ENOMEM; the
 *   status of a pilot that could not start (dth_integrator_new, dth_integrator_start); DTH_EDOMAIN where psi
 *   and psi' vanish together (at the initial state or on a pilot); tol: the last pilot's status where no
 *   pilot gave an estimate; DTH_ESTEPSIZE where the calibrated first step cannot advance t0. A step that
 *   fails in a pilot is not an error: the calibration takes a smaller constant (rep->pilot_status says
 *   where the last pass failed). err (may be NULL) gets a one-line message naming the setting. On failure
 *   rep is untouched.
 */
DTH_API int dth_control_calibrate(const dth_model *model, const dth_options *opt, const double *q0, const double *p0,
                                  double t0, double t_end, const dth_control *ctl, dth_control_report *rep, char *err,
                                  size_t errlen);

struct dth_run_setup; /* scene.h */

/**
 * A scene's step control: where the setup asks for integrator.h_max or integrator.tol (rs->h_max, rs->tol
 * > 0), dth_control_calibrate from its initial state to its t_end (pilots to rs->pilot; the first guess
 * rs->h_asked), then rs->opt.h = rep->h0 and rs->step_max = rep->step_max, so that an integrator made from
 * rs->opt and a run configured by dth_run_config_from_setup run the calibrated constant. Where neither is
 * asked for: DTH_OK, rs unchanged, rep (if not NULL) with passes = 0 and h0 = rs->opt.h.
 * rep may be NULL; if not, its size must be set. @return as dth_control_calibrate; on failure rs is unchanged.
 */
DTH_API int dth_run_setup_control(struct dth_run_setup *rs, dth_control_report *rep, char *err, size_t errlen);

/**
 * The step l(z; C) of the law l^6 sqrt(psi^4 + (psi' l)^4) = C (C > 0; psi' = d psi / dt): at psi = 0
 * l = (C / psi'^2)^(1/8), far from it l = (C / psi^2)^(1/6). INFINITY where psi = psi' = 0, NaN for a
 * C that is not > 0 or a non-finite input.
 */
DTH_API double dth_control_law(double C, double psi, double dpsi);

#ifdef __cplusplus
}
#endif
#endif
