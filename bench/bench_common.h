/* SPDX-License-Identifier: MIT */
/* Shared by the benchmark programs: a monotonic clock and a comparison for sorting timings. */
#ifndef DTH_BENCH_COMMON_H
#define DTH_BENCH_COMMON_H

#include <stdlib.h>
#include <time.h>

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

#endif
