/* SPDX-License-Identifier: MIT */
/*
 * Benchmark (not a test): the round-off noise of the DTH step size at tiny steps (paper, Lemma
 * g_taylor: g'(lambda) ~ -psi lambda / 4, so lambda is fixed by a second-order effect), next to
 * the conditioning estimate of dth_step_floor. Prints the table of docs/performance.md.
 * Usage: bench_tinystep [steps]   (default 2000 steps per h; pendulum, amplitude 1 rad)
 * The columns over the first `steps` steps cover t <= steps * h, a different time span at every h;
 * the last column is the error at one time reached by every h (the run goes on until t >= T_FIXED).
 */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include "dth/dth.h"

#define T_FIXED 0.1 /* the fixed time of the last column */

int main(int argc, char **argv)
{
    long steps = argc > 1 ? atol(argv[1]) : 2000;
    if (steps < 4) return 2;
    dth_model *m;
    if (dth_model_new(&dth_model_pendulum, NULL, 0, 1, NULL, &m, NULL, 0)) return 1;
    double q0 = 0, p0 = 2 * sin(0.5); /* amplitude 1 rad, started through the bottom */
    double z0[4] = {q0, 0, p0, -(0.5 * p0 * p0 - cos(q0))}, hmin, *work = malloc(dth_model_work_size(m) * sizeof *work);
    if (!work || dth_step_floor(m, z0, 1.0, &hmin, work)) return 1;
    printf("pendulum, amplitude 1 rad, midpoint start, %ld steps per h; h_min(rel_tol = 1) = %.2g\n", steps, hmin);
    printf("lambda noise = rms of second differences of lambda / sqrt(6), relative to lambda\n\n");
    printf("columns 2-5 over the first %ld steps (t <= %ld h); the last column at the first vertex at or after t = %g\n\n", steps,
           steps, T_FIXED);
    printf("| h | lambda noise (relative) | (h_min/lambda)^2 | last lambda | max error vs exact, first %ld steps | error vs exact at t = %g |\n"
           "|---|---|---|---|---|---|\n",
           steps, T_FIXED);
    for (double h = 1e-2; h > 0.99e-7; h /= 10) {
        dth_options o;
        dth_options_default(&o);
        o.h = h;
        dth_integrator *it;
        if (dth_integrator_new(m, &o, &it) || dth_integrator_start(it, &q0, &p0, 0)) return 1;
        double l[3] = {0}, s2 = 0, err = 0, errT = NAN;
        long ns = 0, k;
        int rc = 0;
        const double y0[3] = {q0, 0, p0};
        for (k = 0; k < steps && !rc; k++) {
            dth_step_info inf;
            rc = dth_integrator_step(it, &inf);
            if (rc) break;
            l[0] = l[1];
            l[1] = l[2];
            l[2] = inf.lambda;
            if (k >= 3) {
                double d2 = l[2] - 2 * l[1] + l[0];
                s2 += d2 * d2;
                ns++;
            }
            const double *z = dth_integrator_vertex(it);
            double ye[3];
            if (dth_model_exact(m, y0, z[1], ye) == DTH_OK) {
                double e = fmax(fabs(z[0] - ye[0]), fabs(z[2] - ye[2]));
                err = fmax(err, e);
                if (isnan(errT) && z[1] >= T_FIXED) errT = e;
            }
        }
        /* on to the fixed time where the first `steps` steps did not reach it */
        while (!rc && isnan(errT)) {
            dth_step_info inf;
            rc = dth_integrator_step(it, &inf);
            const double *z = dth_integrator_vertex(it);
            double ye[3];
            if (!rc && z[1] >= T_FIXED && dth_model_exact(m, y0, z[1], ye) == DTH_OK)
                errT = fmax(fabs(z[0] - ye[0]), fabs(z[2] - ye[2]));
        }
        double noise = ns ? sqrt(s2 / (double)ns / 6) / fabs(l[2]) : NAN;
        printf("| %.0e | %.2g | %.2g | %.3g | %.2g | %.2g |%s\n", h, noise, (hmin / h) * (hmin / h), l[2], err, errT,
               rc ? " stopped" : "");
        dth_integrator_free(it);
    }
    free(work);
    dth_model_free(m);
    return 0;
}
