/* SPDX-License-Identifier: MIT */
/* Shared by the benchmark programs: a monotonic clock, a comparison for sorting timings, and a
 * fixed-step baseline's integrator (dth_options.method). */
#ifndef DTH_BENCH_COMMON_H
#define DTH_BENCH_COMMON_H

#include <stdlib.h>
#include <time.h>
#include "dth/dth.h"

/* Seconds on a monotonic clock. */
static inline double bench_now(void)
{
    struct timespec ts;
    clock_gettime(CLOCK_MONOTONIC, &ts);
    return (double)ts.tv_sec + 1e-9 * (double)ts.tv_nsec;
}

static inline int bench_cmp_double(const void *a, const void *b)
{
    double x = *(const double *)a, y = *(const double *)b;
    return (x > y) - (x < y);
}

/* An integrator of the baseline `method` with step h, started at (q0, p0, t = 0). */
static inline int bench_baseline(const dth_model *m, const char *method, double h, const double *q0, const double *p0,
                                 dth_integrator **out)
{
    dth_options o;
    dth_options_default(&o);
    o.method = method;
    o.h = h;
    int rc = dth_integrator_new(m, &o, out);
    return rc ? rc : dth_integrator_start(*out, q0, p0, 0.0);
}

/* Can `method` integrate the model? (dth_options_check) */
static inline int bench_method_check(const dth_model *m, const char *method)
{
    dth_options o;
    dth_options_default(&o);
    o.method = method;
    return dth_options_check(m, &o, NULL, 0);
}

#endif
