/* SPDX-License-Identifier: MIT */
/*
 * What the run driver accepts (run.h: dth_run_check): every rule on a dth_run_config with a message
 * naming the setting, in one place; dth_run calls it first, dth run and the Python package call it
 * for the message.
 */
#include <math.h>
#include <stdio.h>
#include "dth/run.h"
#include "dth_internal.h"

/* The step the next one will be about: the last one taken, or before the first the step asked for
 * (the options' h; a baseline's lambda is its h). */
static double known_step(const dth_integrator *it)
{
    double lam = fabs(dth_integrator_lambda(it));
    return lam > 0 ? lam : fabs(dth__integrator_h(it));
}

int dth_run_check(const dth_integrator *it, const dth_run_config *cfg, const dth_run_state *st, char *err,
                  size_t errlen)
{
#define NO(...) return dth__set_err(err, errlen, __VA_ARGS__), DTH_EINVAL
    if (err && errlen) err[0] = '\0';
    if (!it || !cfg || !st) NO("dth_run: no integrator, configuration or state (NULL)");
    if (cfg->size != sizeof *cfg)
        NO("dth_run_config.size = %zu, not %zu: fill the configuration with dth_run_config_default (a caller "
           "built against another layout of run.h)", cfg->size, sizeof *cfg);
    double dir = dth_integrator_direction(it);
    const double *z = dth_integrator_vertex(it);
    size_t n = dth_model_dof(dth_integrator_model(it));
    if (cfg->every < 1) NO("every = %ld: at least 1", cfg->every);
    if (cfg->points == DTH_POINTS_MIDPOINTS && !dth__integrator_has_midpoints(it))
        NO("points = midpoints: the method '%s' has no midpoints (method = dth only)", dth_integrator_method(it));
    if (cfg->points == DTH_POINTS_TIMES && !cfg->times) {
        if (!(cfg->dt > 0 && isfinite(cfg->dt))) NO("dt = %.17g: output times need a positive, finite dt", cfg->dt);
        /* the step known before the run; a longer one later is caught as it is taken (run.c) */
        double lam = known_step(it);
        if (lam > 0 && !(lam / cfg->dt <= DTH_RUN_MAX_SAMPLES_PER_STEP))
            NO("dt = %.3g asks for %.3g rows per step of %.3g: at most %d (a larger dt, or vertices)", cfg->dt,
               lam / cfg->dt, lam, DTH_RUN_MAX_SAMPLES_PER_STEP);
    }
    if (cfg->points == DTH_POINTS_TIMES && cfg->times) {
        for (size_t i = 0; i < cfg->ntimes; i++) {
            if (!isfinite(cfg->times[i])) NO("times[%zu] = %g: output times must be finite", i, cfg->times[i]);
            if (i && dir * (cfg->times[i] - cfg->times[i - 1]) < 0)
                NO("times[%zu] = %.17g lies before times[%zu] = %.17g: output times are ordered in the direction of "
                   "travel (%s)", i, cfg->times[i], i - 1, cfg->times[i - 1], dir > 0 ? "increasing" : "decreasing");
        }
    }
    if (!(cfg->step_max >= 0) || isinf(cfg->step_max))
        NO("step_max = %g: the largest step must be finite and >= 0 (0: no bound)", cfg->step_max);
    if (cfg->nevents && !cfg->events) NO("nevents = %zu but no events (NULL)", cfg->nevents);
    for (size_t e = 0; e < cfg->nevents; e++)
        if (!cfg->events[e].g) NO("event %zu has no function g (NULL)", e);
    if (cfg->has_t_end) {
        if (!isfinite(cfg->t_end)) NO("t_end = %g: must be finite", cfg->t_end);
        /* the run's time window starts at t0 (fresh) or where the last call's samples ended */
        double from = st->started ? st->t_stop : isnan(cfg->t0) ? (z ? z[n] : NAN) : cfg->t0;
        if (dir * (cfg->t_end - from) < 0)
            NO("t_end = %.17g lies behind %s t = %.17g (the direction of travel is %s time)", cfg->t_end,
               st->started ? "where the run stands," : "the run's start,", from, dir > 0 ? "increasing" : "decreasing");
    } else {
        if (cfg->steps < 0) NO("steps = %ld: must not be negative", cfg->steps);
        if (st->started && cfg->steps < st->k)
            NO("steps = %ld lies behind where the run stands, vertex %ld (the vertex index counts from the run's "
               "start)", cfg->steps, st->k);
    }
    return DTH_OK;
#undef NO
}
