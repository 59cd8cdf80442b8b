/* SPDX-License-Identifier: MIT */
/*
 * Benchmark (not a test): cost per DTH step (paper, Theorem "DTH Equations") of a nonlinear 2-D
 * chain of N particles (coupled model, L = 1): the banded solve through the Schur complement
 * (linsolve = banded, the default) next to the banded LU of the whole step matrix (banded-lu, the
 * path before the Schur complement) in the same run, their repeats interleaved, N = 10 .. 10^5, with
 * the bytes the model and integrator allocate per particle; then the dense solve (N <= 200); last,
 * the bytes a regularizer (land, prescribed) allocates for N = 10 .. 1000 (untimed) at create(), and
 * prescribed's kicked-segment workspace (within create(); land's crossing workspace, a dense Newton of
 * the same order, is allocated at its first crossing only).
 * Usage: OPENBLAS_NUM_THREADS=1 bench_chain [max_dense_N [max_N]]   (defaults 200, 100000; median of 5), or
 *        bench_chain --only LINSOLVE N steps   (one untimed run of N particles with that solver: for
 *        instruction counts under callgrind; scripts/bench-instr.sh)
 */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>
#include "dth/dth.h"
#include "bench_common.h"

enum { REPEATS = 5 };

/* Counting allocator: bytes the model and the integrator hold (a header keeps each block's size). */
static size_t live, peak;
static void *count_alloc(void *ctx, size_t n)
{
    (void)ctx;
    size_t *p = malloc(n + 16);
    if (!p) return NULL;
    p[0] = n;
    live += n;
    if (live > peak) peak = live;
    return (char *)p + 16;
}
static void count_free(void *ctx, void *ptr)
{
    (void)ctx;
    if (!ptr) return;
    size_t *p = (size_t *)((char *)ptr - 16);
    live -= p[0];
    free(p);
}
static const dth_allocator counting = {count_alloc, count_free, NULL};

/* An N-particle chain (structure "auto" = banded, or "dense") and its start, reproducible. */
typedef struct chain {
    dth_model *m;
    double *q, *p;
} chain;

static int chain_new(size_t N, const char *structure, chain *c)
{
    char size[32];
    snprintf(size, sizeof size, "%zu", N);
    dth_kv kv[] = {{"preset", "chain"}, {"size", size}, {"dim", "2"}, {"L", "1"}, {"k", "1"}, {"structure", structure}};
    char err[256];
    if (dth_model_new(&dth_model_coupled, kv, 6, 0, &counting, &c->m, err, sizeof err)) {
        fprintf(stderr, "%s\n", err);
        return 1;
    }
    size_t n = 2 * N;
    c->q = calloc(n, sizeof *c->q), c->p = calloc(n, sizeof *c->p);
    unsigned long s = 12345;
    for (size_t i = 0; i < n; i++) {
        s = s * 6364136223846793005UL + 1442695040888963407UL;
        double r1 = (double)(s >> 11) / 9007199254740992.0 - 0.5;
        s = s * 6364136223846793005UL + 1442695040888963407UL;
        double r2 = (double)(s >> 11) / 9007199254740992.0 - 0.5;
        c->q[i] = (i % 2 == 0 ? (double)(i / 2) : 0.0) + 0.1 * r1;
        c->p[i] = 0.3 * r2;
    }
    return 0;
}

static void chain_free(chain *c)
{
    dth_model_free(c->m);
    free(c->q);
    free(c->p);
}

/* One timed run of `steps` steps with a linear solver: microseconds per step into *us, Newton
 * iterations into *iters, peak bytes (model and integrator) into *bytes; 0 on success. */
static int run_once(const chain *c, dth_linsolve ls, long steps, double *us, double *iters, double *bytes)
{
    dth_options o;
    dth_options_default(&o);
    o.h = 0.05;
    o.linsolve = ls;
    o.alloc = &counting;
    peak = live; /* the model's bytes */
    dth_integrator *it;
    if (dth_integrator_new(c->m, &o, &it) || dth_integrator_start(it, c->q, c->p, 0.0)) return 1;
    dth_integrator_step(it, NULL); /* the exact first step of a midpoint start */
    long nit = 0;
    double t0 = bench_now();
    for (long k = 0; k < steps; k++) {
        dth_step_info si;
        int rc = dth_integrator_step(it, &si);
        if (rc) {
            fprintf(stderr, "step %ld (%s): %s\n", k, dth_linsolve_name(ls), dth_strerror(rc));
            dth_integrator_free(it);
            return 1;
        }
        nit += si.iters;
    }
    *us = (bench_now() - t0) / (double)steps * 1e6;
    *iters = (double)nit / (double)steps;
    *bytes = (double)peak; /* the model's and the integrator's at their peak */
    dth_integrator_free(it);
    return 0;
}

typedef struct result {
    double us_step, iters; /* median microseconds per step, Newton iterations per step */
    double bytes;          /* peak bytes held by the model and integrator */
    int ok;
} result;

/* Time solvers ls[0 .. nls-1] on one chain, their repeats interleaved (medians). */
static void run(size_t N, const char *structure, const dth_linsolve *ls, int nls, long steps, result *res)
{
    chain c;
    for (int k = 0; k < nls; k++) res[k] = (result){0, 0, 0, 0};
    live = peak = 0;
    if (chain_new(N, structure, &c)) return;
    double t[2][REPEATS];
    for (int r = 0; r < REPEATS; r++)
        for (int k = 0; k < nls; k++)
            if (run_once(&c, ls[k], steps, &t[k][r], &res[k].iters, &res[k].bytes)) {
                chain_free(&c);
                return;
            }
    for (int k = 0; k < nls; k++) {
        qsort(t[k], REPEATS, sizeof t[k][0], bench_cmp_double);
        res[k].us_step = t[k][REPEATS / 2];
        res[k].ok = 1;
    }
    chain_free(&c);
}

int main(int argc, char **argv)
{
    if (argc > 4 && !strcmp(argv[1], "--only")) {
        dth_linsolve ls;
        for (ls = DTH_LINSOLVE_AUTO; dth_linsolve_name(ls); ls++)
            if (!strcmp(argv[2], dth_linsolve_name(ls))) break;
        chain c;
        double us, iters, bytes;
        if (!dth_linsolve_name(ls) || chain_new((size_t)atol(argv[3]), "auto", &c)) return 2;
        int rc = run_once(&c, ls, atol(argv[4]), &us, &iters, &bytes);
        chain_free(&c);
        return rc;
    }
    size_t max_dense = argc > 1 ? (size_t)atol(argv[1]) : 200, max_n = argc > 2 ? (size_t)atol(argv[2]) : 100000;
    const size_t Ns[] = {10, 100, 1000, 10000, 100000};
    const size_t Nd[] = {10, 20, 50, 100, 200};
    printf("# coupled chain, d = 2, L = 1, h = 0.05, midpoint start; microseconds per step (median of %d)\n", REPEATS);
    printf("# banded: Schur complement (Cholesky); banded-lu: LU of the whole step matrix; same run\n");
    printf("# path        N       n   steps   us/step  iters/step  us/iter  bytes/particle  ratio\n");
    double prev = 0, banded_at[2] = {0};
    size_t prevN = 0;
    for (size_t i = 0; i < sizeof Ns / sizeof Ns[0] && Ns[i] <= max_n; i++) {
        long steps = (long)(20000 / Ns[i]);
        if (steps < 5) steps = 5;
        const dth_linsolve both[2] = {DTH_LINSOLVE_BANDED, DTH_LINSOLVE_BANDED_LU};
        result rr[2];
        run(Ns[i], "auto", both, Ns[i] <= 10000 ? 2 : 1, steps, rr);
        result r = rr[0], l = rr[1];
        if (!r.ok) return 1;
        printf("banded    %6zu %7zu %7ld %9.1f %11.2f %8.2f %15.0f", Ns[i], 2 * Ns[i], steps, r.us_step, r.iters,
               r.us_step / r.iters, r.bytes / (double)Ns[i]);
        if (prev > 0) printf("  %.2f (N x%.0f)", r.us_step / prev, (double)Ns[i] / (double)prevN);
        printf("\n");
        if (Ns[i] <= 10000) {
            if (!l.ok) return 1;
            printf("banded-lu %6zu %7zu %7ld %9.1f %11.2f %8.2f %15.0f  banded/banded-lu %.2f\n", Ns[i], 2 * Ns[i], steps,
                   l.us_step, l.iters, l.us_step / l.iters, l.bytes / (double)Ns[i], r.us_step / l.us_step);
        }
        prev = r.us_step;
        prevN = Ns[i];
        if (i < 2) banded_at[i] = r.us_step;
    }
    prev = 0;
    for (size_t i = 0; i < sizeof Nd / sizeof Nd[0] && Nd[i] <= max_dense; i++) {
        long steps = Nd[i] <= 50 ? 200 : Nd[i] <= 100 ? 20 : 5;
        const dth_linsolve dense = DTH_LINSOLVE_AUTO;
        result r;
        run(Nd[i], "dense", &dense, 1, steps, &r);
        if (!r.ok) return 1;
        printf("dense     %6zu %7zu %7ld %9.1f %11.2f %8.2f %15.0f", Nd[i], 2 * Nd[i], steps, r.us_step, r.iters,
               r.us_step / r.iters, r.bytes / (double)Nd[i]);
        if (prev > 0) printf("  %.2f (N x%.1f)", r.us_step / prev, (double)Nd[i] / (double)prevN);
        if (Nd[i] == 10) printf("  dense/banded %.1f", r.us_step / banded_at[0]);
        if (Nd[i] == 100) printf("  dense/banded %.1f", r.us_step / banded_at[1]);
        printf("\n");
        prev = r.us_step;
        prevN = Nd[i];
    }
    /* What a regularizer adds (not timed): the bytes its create() allocates, and the kicked
     * segment's dense Newton workspace, 2 (2n + 1)^2 doubles (prescribed: part of create(); land:
     * a workspace of the same order at its first crossing, none if the run never crosses). */
    printf("# regularizer workspace (untimed; N <= min(max_N, 1000)): bytes its create() allocates, and the kicked\n"
           "# segment's dense workspace (prescribed: within create(); land: one of that order at its first crossing)\n");
    printf("# regularizer   N       n  create() bytes  kicked-segment bytes\n");
    const dth_regularizer_type *regs[] = {&dth_reg_land, &dth_reg_prescribed};
    for (size_t i = 0; i < 3 && Ns[i] <= max_n; i++) {
        chain c;
        if (chain_new(Ns[i], "auto", &c)) return 1;
        for (int k = 0; k < 2; k++) {
            dth_regularizer *rg;
            char err[256];
            live = peak = 0;
            if (dth_regularizer_new(regs[k], NULL, 0, c.m, &counting, &rg, err, sizeof err)) {
                fprintf(stderr, "%s\n", err);
                chain_free(&c);
                return 1;
            }
            printf("%-12s %6zu %7zu %15zu %21zu\n", regs[k]->name, Ns[i], 2 * Ns[i], peak,
                   dth_kicked_segment_work_size(c.m) * sizeof(double));
            dth_regularizer_free(rg);
        }
        chain_free(&c);
    }
    return 0;
}
