/* SPDX-License-Identifier: MIT */
/*
 * Cost of writing one CSV row of `dth run` against the cost of the step that makes it (issue 12,
 * item 5): a pendulum row (k, t, lambda, q, p, wp, H, E) and a 2-D Kepler row formatted with
 * snprintf("%.17g") and with the CLI's formatter (cli/fmt.c, the same bytes), next to a DTH step
 * of each model, interleaved in one process, medians of 9 rounds. The row includes H_phys (one
 * model evaluation), as dth run computes it.
 * Also the run driver's own cost: dth_run with a sample at every midpoint (a callback that only
 * counts) and with dense output at every step, against the bare loop of dth_integrator_step.
 * Usage: bench_csv [rows per round]   (default 200000)
 */
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <dth/dth.h>
#include "bench_common.h"
#include "fmt.h"

enum { ROUNDS = 9 };

static volatile size_t sink;

/* One row of n dof at z with snprintf or the fast formatter, into line. */
static size_t row(int fast, const dth_model *m, size_t n, long k, const double *z, double lambda, char *line)
{
    size_t N = 2 * n + 2, len = 0;
    double Hp, v[16];
    dth_model_eval(m, z, DTH_EVAL_H, &Hp, NULL, NULL);
    size_t c = 0;
    v[c++] = z[n];
    v[c++] = lambda;
    for (size_t i = 0; i < n; i++) v[c++] = z[i];
    for (size_t i = 0; i < n; i++) v[c++] = z[n + 1 + i];
    v[c++] = z[N - 1];
    v[c++] = z[N - 1] + Hp;
    v[c++] = Hp;
    if (fast) {
        len = dth_fmt_long(k, line);
        for (size_t i = 0; i < c; i++) {
            line[len++] = ',';
            len += dth_fmt_g17(v[i], line + len);
        }
    } else {
        len = (size_t)snprintf(line, 64, "%ld", k);
        for (size_t i = 0; i < c; i++) len += (size_t)snprintf(line + len, 64, ",%.17g", v[i]);
    }
    line[len++] = '\n';
    return len;
}

static int bench_model(const char *name, const dth_model_type *t, size_t n, const double *q0, const double *p0,
                       double h, long rows)
{
    dth_model *m = NULL;
    char err[128];
    if (dth_model_new(t, NULL, 0, n, NULL, &m, err, sizeof err)) return 1;
    dth_options o;
    dth_options_default(&o);
    o.h = h;
    dth_integrator *it = NULL;
    if (dth_integrator_new(m, &o, &it) || dth_integrator_start(it, q0, p0, 0)) return 1;
    size_t N = 2 * n + 2;
    /* rows of a real trajectory, stored once: the formatters see realistic digits */
    double *zs = malloc((size_t)rows * N * sizeof *zs), *lam = malloc((size_t)rows * sizeof *lam);
    if (!zs || !lam) return 1;
    for (long k = 0; k < rows; k++) {
        dth_step_info info;
        if (dth_integrator_step(it, &info)) return 1;
        memcpy(zs + (size_t)k * N, dth_integrator_vertex(it), N * sizeof *zs);
        lam[k] = info.lambda;
    }
    double ts[ROUNDS], tp[ROUNDS], tf[ROUNDS];
    char line[1024];
    for (int r = 0; r < ROUNDS; r++) {
        double t0 = bench_now();
        for (long k = 0; k < rows; k++) dth_integrator_step(it, NULL);
        double t1 = bench_now();
        size_t s = 0;
        for (long k = 0; k < rows; k++) s += row(0, m, n, k, zs + (size_t)k * N, lam[k], line);
        double t2 = bench_now();
        for (long k = 0; k < rows; k++) s += row(1, m, n, k, zs + (size_t)k * N, lam[k], line);
        double t3 = bench_now();
        sink += s;
        ts[r] = (t1 - t0) / (double)rows;
        tp[r] = (t2 - t1) / (double)rows;
        tf[r] = (t3 - t2) / (double)rows;
    }
    /* both formatters give the same bytes */
    char a[1024], b[1024];
    for (long k = 0; k < rows; k += 97) {
        size_t la = row(0, m, n, k, zs + (size_t)k * N, lam[k], a), lb = row(1, m, n, k, zs + (size_t)k * N, lam[k], b);
        if (la != lb || memcmp(a, b, la)) {
            fprintf(stderr, "bench_csv: the formatters differ at row %ld\n", k);
            return 1;
        }
    }
    qsort(ts, ROUNDS, sizeof *ts, bench_cmp_double);
    qsort(tp, ROUNDS, sizeof *tp, bench_cmp_double);
    qsort(tf, ROUNDS, sizeof *tf, bench_cmp_double);
    double s = ts[ROUNDS / 2], p = tp[ROUNDS / 2], f = tf[ROUNDS / 2];
    printf("%-10s %9.0f %12.0f %9.2f %11.0f %9.2f %9.1f\n", name, 1e9 * s, 1e9 * p, p / s, 1e9 * f, f / s, p / f);
    free(zs);
    free(lam);
    dth_integrator_free(it);
    dth_model_free(m);
    return 0;
}

static int count(void *user, const dth_sample *s)
{
    (void)s;
    ++*(long *)user;
    return 0;
}

/* ns per step of the bare loop, dth_run with midpoint samples, dth_run with output times h apart */
static int bench_driver(long steps)
{
    dth_model *m = NULL;
    char err[128];
    if (dth_model_new(&dth_model_pendulum, NULL, 0, 1, NULL, &m, err, sizeof err)) return 1;
    dth_options o;
    dth_options_default(&o);
    o.h = 0.05;
    double q = 1, p = 0, t[3][ROUNDS];
    for (int r = 0; r < ROUNDS; r++)
        for (int v = 0; v < 3; v++) {
            dth_integrator *it = NULL;
            if (dth_integrator_new(m, &o, &it) || dth_integrator_start(it, &q, &p, 0)) return 1;
            long n = 0;
            dth_run_config c;
            dth_run_config_default(&c);
            c.steps = steps;
            c.sample = count;
            c.user = &n;
            c.points = v == 1 ? DTH_POINTS_MIDPOINTS : DTH_POINTS_TIMES;
            c.dt = 0.05;
            dth_run_state st;
            dth_run_state_init(&st);
            double t0 = bench_now();
            if (v == 0)
                for (long k = 0; k < steps; k++) dth_integrator_step(it, NULL);
            else if (dth_run(it, &c, &st))
                return 1;
            t[v][r] = (bench_now() - t0) / (double)steps;
            dth_integrator_free(it);
        }
    for (int v = 0; v < 3; v++) qsort(t[v], ROUNDS, sizeof t[v][0], bench_cmp_double);
    printf("# the run driver on the pendulum (h = 0.05), %ld steps, median of %d: bare step loop %.0f ns/step, "
           "dth_run with a midpoint sample per step %.0f ns (%.2fx), with dense output every step %.0f ns (%.2fx)\n",
           steps, ROUNDS, 1e9 * t[0][ROUNDS / 2], 1e9 * t[1][ROUNDS / 2], t[1][ROUNDS / 2] / t[0][ROUNDS / 2],
           1e9 * t[2][ROUNDS / 2], t[2][ROUNDS / 2] / t[0][ROUNDS / 2]);
    dth_model_free(m);
    return 0;
}

int main(int argc, char **argv)
{
    long rows = argc > 1 ? atol(argv[1]) : 200000;
    if (rows < 100) rows = 100;
    printf("# one CSV row of dth run (the row's values and H_phys) against one DTH step; %ld rows, median of %d rounds\n",
           rows, ROUNDS);
    printf("%-10s %9s %12s %9s %11s %9s %9s\n", "model", "step_ns", "snprintf_ns", "/step", "fmt_g17_ns", "/step",
           "speed-up");
    double q1 = 1, p1 = 0, qk[2] = {0.4, 0}, pk[2] = {0, 2};
    if (bench_model("pendulum", &dth_model_pendulum, 1, &q1, &p1, 0.05, rows)) return 1;
    if (bench_model("kepler", &dth_model_kepler, 2, qk, pk, 0.01, rows)) return 1;
    return bench_driver(rows);
}
