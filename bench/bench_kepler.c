/* SPDX-License-Identifier: MIT */
/*
 * Benchmark (not a test): cost of one DTH step (paper, Theorem "DTH Equations") for the Kepler
 * problem, e = 0.6 from pericentre, next to the pendulum (libration of amplitude 1 rad) measured
 * in the same run, both at h = 0.01 with a midpoint start. Median of repeats, clock_gettime.
 * Usage: bench_kepler [steps]   (default 100000; median of 7 repeats)
 */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <time.h>
#include "dth/dth.h"
#include "bench_common.h"

enum { REPEATS = 7 };

/* Time `steps` DTH steps from (q0, p0); returns seconds per step, adds iterations and time
 * covered, or a negative value on failure. */
static double time_run(const dth_model *m, double h, const double *q0, const double *p0, long steps,
                       double *iters, double *t_covered)
{
    dth_options o;
    dth_options_default(&o);
    o.h = h;
    dth_integrator *it;
    if (dth_integrator_new(m, &o, &it) || dth_integrator_start(it, q0, p0, 0.0)) return -1;
    dth_step_info info;
    double t0 = bench_now();
    for (long k = 0; k < steps; k++) {
        if (dth_integrator_step(it, &info)) {
            fprintf(stderr, "step %ld failed: %s\n", k, dth_integrator_errmsg(it));
            dth_integrator_free(it);
            return -1;
        }
        *iters += info.iters;
    }
    double dt = (bench_now() - t0) / (double)steps;
    *t_covered += dth_integrator_vertex(it)[dth_model_dof(m)];
    dth_integrator_free(it);
    return dt;
}

int main(int argc, char **argv)
{
    long steps = argc > 1 ? atol(argv[1]) : 100000;
    if (steps < 1) return 2;
    dth_model *kep, *pen;
    char err[256];
    if (dth_model_new(&dth_model_kepler, NULL, 0, 2, NULL, &kep, err, sizeof err) ||
        dth_model_new(&dth_model_pendulum, NULL, 0, 1, NULL, &pen, err, sizeof err)) {
        fprintf(stderr, "%s\n", err);
        return 1;
    }
    const double e = 0.6, h = 0.01;
    double kq[2] = {1 - e, 0}, kp[2] = {0, sqrt((1 + e) / (1 - e))}, pq = 1.0, pp = 0.0;
    double tk[REPEATS], tp[REPEATS], ik = 0, ip = 0, ck = 0, cp = 0;
    for (int r = 0; r < REPEATS; r++) {
        /* interleaved, so both see the same machine load */
        tk[r] = time_run(kep, h, kq, kp, steps, &ik, &ck);
        tp[r] = time_run(pen, h, &pq, &pp, steps, &ip, &cp);
        if (tk[r] < 0 || tp[r] < 0) return 1;
    }
    qsort(tk, REPEATS, sizeof(double), bench_cmp_double);
    qsort(tp, REPEATS, sizeof(double), bench_cmp_double);
    double k = tk[REPEATS / 2], p = tp[REPEATS / 2], nr = (double)REPEATS * (double)steps;
    printf("DTH step cost, h = %g, midpoint start, %ld steps, median of %d runs\n", h, steps, REPEATS);
    printf("  kepler e = 0.6 (n = 2)   %8.3f us  (%.2f Newton iterations per step, mean step %.4f)\n",
           1e6 * k, ik / nr, ck / nr);
    printf("  pendulum amplitude 1     %8.3f us  (%.2f Newton iterations per step, mean step %.4f)\n",
           1e6 * p, ip / nr, cp / nr);
    printf("  ratio kepler / pendulum  %8.2f  (per Newton iteration %.2f)\n", k / p,
           (k / (ik / nr)) / (p / (ip / nr)));
    dth_model_free(kep);
    dth_model_free(pen);
    return 0;
}
