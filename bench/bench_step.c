/* SPDX-License-Identifier: MIT */
/*
 * Benchmark (not a test): cost of one DTH step for the pendulum next to a plain Stormer-Verlet
 * step measured in the same run, and a count of heap allocations made while stepping.
 * Usage: bench_step [steps]   (default 200000; median of 7 repeats)
 */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <time.h>
#include "dth/dth.h"
#include "bench_common.h"

/* Count every malloc/calloc/realloc made by the process (the step must make none). */
extern void *__libc_malloc(size_t);
extern void *__libc_calloc(size_t, size_t);
extern void *__libc_realloc(void *, size_t);
static unsigned long n_alloc;
void *malloc(size_t n);
void *calloc(size_t a, size_t b);
void *realloc(void *p, size_t n);
void *malloc(size_t n) { n_alloc++; return __libc_malloc(n); }
void *calloc(size_t a, size_t b) { n_alloc++; return __libc_calloc(a, b); }
void *realloc(void *p, size_t n) { n_alloc++; return __libc_realloc(p, n); }

enum { REPEATS = 7 };

int main(int argc, char **argv)
{
    long steps = argc > 1 ? atol(argv[1]) : 200000;
    if (steps < 1) return 2;
    dth_model *m;
    char err[256];
    if (dth_model_new(&dth_model_pendulum, NULL, 0, 1, NULL, &m, err, sizeof err)) {
        fprintf(stderr, "%s\n", err);
        return 1;
    }
    dth_options o;
    dth_options_default(&o);
    o.h = 0.05;
    double t_dth[REPEATS], t_sv[REPEATS], iters = 0, sink = 0;
    unsigned long allocs_in_loop = 0;
    for (int r = 0; r < REPEATS; r++) {
        /* DTH: libration of amplitude 1 rad */
        dth_integrator *it;
        if (dth_integrator_new(m, &o, &it)) return 1;
        double q = 1.0, p = 0.0;
        dth_integrator_start(it, &q, &p, 0.0);
        dth_step_info info;
        unsigned long a0 = n_alloc;
        double t0 = bench_now();
        for (long k = 0; k < steps; k++) {
            if (dth_integrator_step(it, &info)) {
                fprintf(stderr, "step failed: %s\n", dth_integrator_errmsg(it));
                return 1;
            }
            iters += info.iters;
        }
        t_dth[r] = (bench_now() - t0) / (double)steps;
        allocs_in_loop += n_alloc - a0;
        sink += dth_integrator_vertex(it)[0];
        dth_integrator_free(it);
        /* Stormer-Verlet (kick-drift-kick) on the same Hamiltonian, same step */
        double h = o.h, qv = 1.0, pv = 0.0;
        t0 = bench_now();
        for (long k = 0; k < steps; k++) {
            pv -= 0.5 * h * sin(qv);
            qv += h * pv;
            pv -= 0.5 * h * sin(qv);
        }
        t_sv[r] = (bench_now() - t0) / (double)steps;
        sink += qv;
    }
    qsort(t_dth, REPEATS, sizeof(double), bench_cmp_double);
    qsort(t_sv, REPEATS, sizeof(double), bench_cmp_double);
    double dth = t_dth[REPEATS / 2], sv = t_sv[REPEATS / 2];
    printf("pendulum, h = %.3g, %ld steps, median of %d runs\n", o.h, steps, REPEATS);
    printf("  DTH step            %8.3f us   (%.2f Newton iterations per step)\n", 1e6 * dth,
           iters / (double)(REPEATS * steps));
    printf("  Stormer-Verlet step %8.3f us\n", 1e6 * sv);
    printf("  ratio DTH / Verlet  %8.1f\n", dth / sv);
    printf("  heap allocations while stepping: %lu\n", allocs_in_loop);
    printf("  target: DTH step < 2 us: %s\n", dth < 2e-6 ? "met" : "NOT met");
    if (sink == 12345.678) puts("");
    dth_model_free(m);
    return 0;
}
