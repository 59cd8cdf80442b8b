/* SPDX-License-Identifier: MIT */
/*
 * The DTH method of order 4 (issue 22; lib/compose.c), its figures (not a test): (1) the order at fixed
 * times T = 10 and 100 of every coefficient table (suzuki4, yoshida4, and the nominally 6th/8th-order
 * yoshida6a, kahanli6, kahanli8) on five models; (2) why the 6th/8th-order tables measure 4: the
 * order-3 condition's residual R3 = sum lambda_i^3 / tau^3 along a Kepler orbit, O(h^2) for every
 * table; (3) Kepler e = 0.6 over 1000 orbits, CPU of order 4 against order 2 at equal final position
 * error 1e-5 (each curve interpolated), in one run; (4) orders through psi = 0 crossings; (5) the vertex
 * energy over 10^6 steps and the error estimate against the true error.
 * Usage: bench_order4 [--full] [--only 1..5]   (quick mode: seconds; --full: the docs' figures)
 */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>
#include <gsl/gsl_errno.h>
#include <gsl/gsl_odeiv2.h>
#include "dth/dth.h"
#include "compose.h"
#include "stepper.h"
#include "../docs/examples/henon_heiles.h"

enum { MAXN = 16, MAXZ = 2 * MAXN + 2 };
#define PI 3.14159265358979323846

static double cpu_now(void)
{
    struct timespec ts;
    clock_gettime(CLOCK_PROCESS_CPUTIME_ID, &ts);
    return (double)ts.tv_sec + 1e-9 * (double)ts.tv_nsec;
}

static dth_model *make(const dth_model_type *t, const dth_kv *kv, size_t nkv)
{
    dth_model *m = NULL;
    char err[256];
    if (dth_model_new(t, kv, nkv, 0, NULL, &m, err, sizeof err)) {
        fprintf(stderr, "model %s: %s\n", t->name, err);
        exit(1);
    }
    return m;
}

/* ---- references: the exact solution, else GSL rk8pd at 1e-14 ---- */

typedef struct gctx {
    const dth_model *m;
    size_t n;
    double y[2 * MAXN + 1], g[2 * MAXN + 1];
} gctx;

static int gsl_rhs(double t, const double x[], double dx[], void *p)
{
    gctx *c = p;
    size_t n = c->n;
    memcpy(c->y, x, n * sizeof *x);
    c->y[n] = t;
    memcpy(c->y + n + 1, x + n, n * sizeof *x);
    if (dth_model_eval(c->m, c->y, DTH_EVAL_GRAD, NULL, c->g, NULL)) return GSL_EBADFUNC;
    for (size_t i = 0; i < n; i++) {
        dx[i] = c->g[n + 1 + i];
        dx[n + i] = -c->g[i];
    }
    return GSL_SUCCESS;
}

static void reference(const dth_model *m, const double *q0, const double *p0, double T, double *y)
{
    size_t n = dth_model_dof(m);
    double y0[2 * MAXN + 1], x[2 * MAXN], t = 0;
    memcpy(y0, q0, n * sizeof *y0);
    y0[n] = 0;
    memcpy(y0 + n + 1, p0, n * sizeof *y0);
    if (dth_model_exact(m, y0, T, y) == DTH_OK) return;
    gctx c = {m, n, {0}, {0}};
    gsl_odeiv2_system sys = {gsl_rhs, NULL, 2 * n, &c};
    gsl_odeiv2_driver *d = gsl_odeiv2_driver_alloc_y_new(&sys, gsl_odeiv2_step_rk8pd, 1e-3, 1e-14, 1e-14);
    memcpy(x, q0, n * sizeof *x);
    memcpy(x + n, p0, n * sizeof *x);
    gsl_odeiv2_driver_apply(d, &t, T, x);
    gsl_odeiv2_driver_free(d);
    memcpy(y, x, n * sizeof *x);
    y[n] = T;
    memcpy(y + n + 1, x + n, n * sizeof *x);
}

static double err_qp(size_t n, const double *z, const double *y, int q_only)
{
    double s = 0;
    for (size_t j = 0; j < 2 * n + 1; j++)
        if (j != n && (!q_only || j < n)) s += (z[j] - y[j]) * (z[j] - y[j]);
    return sqrt(s);
}

/* ---- a run to fixed times (dense output at each) ---- */

typedef struct grab {
    size_t N;
    int got;
    double z[2][MAXZ];
} grab;

static int on_sample(void *user, const dth_sample *s)
{
    grab *g = user;
    if ((s->kind == DTH_SAMPLE_TIME || s->kind == DTH_SAMPLE_END) && g->got < 2) memcpy(g->z[g->got++], s->z, g->N * sizeof *s->z);
    return 0;
}

typedef struct runres {
    int rc;
    long steps, iters, band;
    double cpu, t_fail;
} runres;

static long iters_sum; /* Newton iterations of the run in progress (the progress callback's sum) */
static int on_progress(void *user, const dth_run_state *st)
{
    (void)user;
    iters_sum += st->in.iters;
    return 0;
}

static runres run_to(const dth_model *m, const dth_options *o, const double *q0, const double *p0, const double *T,
                     size_t nT, double z[2][MAXZ])
{
    runres r = {0, 0, 0, 0, 0, NAN};
    dth_integrator *it = NULL;
    double c0 = cpu_now();
    if ((r.rc = dth_integrator_new(m, o, &it)) != DTH_OK || (r.rc = dth_integrator_start(it, q0, p0, 0)) != DTH_OK) {
        dth_integrator_free(it);
        return r;
    }
    grab g = {dth_integrator_dim(it), 0, {{0}}};
    dth_run_config cfg;
    dth_run_config_default(&cfg);
    cfg.has_t_end = 1;
    cfg.t_end = T[nT - 1];
    cfg.t0 = 0;
    cfg.points = DTH_POINTS_TIMES;
    cfg.times = T;
    cfg.ntimes = nT;
    cfg.sample = on_sample;
    cfg.user = &g;
    cfg.progress = on_progress;
    cfg.progress_every = 1;
    dth_run_state st;
    dth_run_state_init(&st);
    r.rc = dth_run(it, &cfg, &st);
    r.cpu = cpu_now() - c0;
    r.steps = st.k;
    r.band = st.regularized;
    if (r.rc) r.t_fail = st.t;
    memcpy(z, g.z, sizeof g.z);
    dth_integrator_free(it);
    return r;
}

/* ---- (1) orders per table ---- */

typedef struct ocase {
    const char *name;
    const dth_model_type *type;
    dth_kv kv[3];
    size_t nkv;
    double q0[MAXN], p0[MAXN];
    double h0;
} ocase;

static const ocase cases[] = {
    {"pendulum", &dth_model_pendulum, {{0}}, 0, {1}, {0}, 0.2},
    {"kepler-peri", &dth_model_kepler, {{0}}, 0, {0.4, 0}, {0, 2}, 0.02},
    {"kepler-apo", &dth_model_kepler, {{0}}, 0, {-1.6, 0}, {0, -0.5}, 0.2},
    {"henon-heiles", &example_henon_heiles, {{0}}, 0, {0, 0.1}, {0.39665266081716, 0}, 0.4},
    {"ring5-3d", &dth_model_coupled, {{"preset", "ring"}, {"size", "5"}, {"dim", "3"}}, 3,
     {1, 0, 0, 0.309017, 0.9510565, -0.058779, -0.809017, 0.5877855, 0.095106, -0.809017, -0.5877855, -0.095106,
      0.309017, -0.9510565, 0.058779},
     {0, 0, 0.2, 0.05, 0, -0.161803, 0.1, 0, 0.061803, 0.15, 0, 0.061803, 0.2, 0, -0.161803},
     0.2},
};

static void orders(int full)
{
    static const char *tables[] = {"suzuki4", "yoshida4", "yoshida6a", "kahanli6", "kahanli8"};
    int ntab = full ? 5 : 2, nh = full ? 5 : 3;
    const double T[2] = {10, 100};
    printf("\n## (1) Order at fixed times T = 10 / T = 100 (the last halving; 'fails': a composite step found no\n"
           "## admissible root at that h, the run stopped; error = |(q, p) - exact| at T by the dense output)\n\n");
    printf("| case | h | %s |\n|---|---|", full ? "suzuki4 | yoshida4 | yoshida6a | kahanli6 | kahanli8" : "suzuki4 | yoshida4");
    for (int t = 0; t < ntab; t++) printf("---|");
    printf("\n");
    for (size_t c = 0; c < sizeof cases / sizeof cases[0]; c++) {
        const ocase *k = &cases[c];
        dth_model *m = make(k->type, k->kv, k->nkv);
        size_t n = dth_model_dof(m);
        double y[2][MAXZ], e[5][6][2];
        int fail[5][6];
        for (int t = 0; t < 2; t++) reference(m, k->q0, k->p0, T[t], y[t]);
        for (int s = 0; s < nh; s++) {
            double h = k->h0 / (1 << (s + (full ? 0 : 2)));
            printf("| %s | %g |", k->name, h);
            for (int tb = 0; tb < ntab; tb++) {
                dth_options o;
                dth_options_default(&o);
                o.order = 4;
                o.h = h;
                o.table = tables[tb];
                double z[2][MAXZ];
                runres r = run_to(m, &o, k->q0, k->p0, T, 2, z);
                fail[tb][s] = r.rc != DTH_OK;
                for (int t = 0; t < 2; t++) e[tb][s][t] = fail[tb][s] ? NAN : err_qp(n, z[t], y[t], 0);
                if (fail[tb][s]) printf(" fails (t = %.3g) |", r.t_fail);
                else printf(" %.3e / %.3e |", e[tb][s][0], e[tb][s][1]);
            }
            printf("\n");
        }
        printf("| %s | **order** |", k->name);
        for (int tb = 0; tb < ntab; tb++) {
            int s = nh - 1;
            if (fail[tb][s] || fail[tb][s - 1]) printf(" - |");
            else printf(" **%.2f / %.2f** |", log2(e[tb][s - 1][0] / e[tb][s][0]), log2(e[tb][s - 1][1] / e[tb][s][1]));
        }
        printf("\n");
        dth_model_free(m);
    }
}

/* ---- (2) the order conditions along a run ---- */

static void conditions(int full)
{
    static const char *tables[] = {"suzuki4", "yoshida4", "yoshida6a", "kahanli6", "kahanli8"};
    printf("\n## (2) Why every table measures order 4: along one Kepler e = 0.6 orbit from pericentre, the\n"
           "## substeps lambda_i = gamma_i tau (1 + delta_i): max |delta| / h and R3 = |sum lambda_i^3| / tau^3\n"
           "## over h^2 (order 6 would need R3 = O(h^4), order 5 sum lambda_i^5 = O(tau^5 h^2) too): R3 / h^2 does\n"
           "## not fall with h for any table, so the local error is O(tau^5) whatever the table\n\n");
    printf("| table | h | max abs delta / h | max R3 / h^2 | max abs(sum lambda^5) / tau^5 | composite steps |\n"
           "|---|---|---|---|---|---|\n");
    dth_model *m = make(&dth_model_kepler, NULL, 0);
    for (int tb = 0; tb < (full ? 5 : 2); tb++) {
        for (double h = 0.01; h > 0.002; h /= 2) {
            dth_options o;
            dth_options_default(&o);
            o.order = 4;
            o.h = h;
            o.table = tables[tb];
            dth_integrator *it = NULL;
            if (dth_integrator_new(m, &o, &it) || dth_integrator_start(it, (double[]){0.4, 0}, (double[]){0, 2}, 0))
                exit(1);
            const dth__comp *c = it->state;
            double dmax = 0, r3 = 0, r5 = 0;
            long k = 0;
            int rc = DTH_OK;
            while (dth_integrator_vertex(it)[2] < 2 * PI && (rc = dth_integrator_step(it, NULL)) == DTH_OK) {
                if (++k == 1) continue; /* the start step: lambda_i = gamma_i h exactly */
                double tau = 0, s3 = 0, s5 = 0;
                for (int i = 0; i < c->m; i++) tau += c->sg.lam1[i];
                for (int i = 0; i < c->m; i++) {
                    double l = c->sg.lam1[i];
                    s3 += l * l * l;
                    s5 += l * l * l * l * l;
                    dmax = fmax(dmax, fabs(l / (c->tab->g[i] * tau) - 1));
                }
                r3 = fmax(r3, fabs(s3) / (tau * tau * tau));
                r5 = fmax(r5, fabs(s5) / pow(fabs(tau), 5));
            }
            if (rc) printf("| %s | %g | fails at t = %.3g | | | %ld |\n", tables[tb], h, dth_integrator_vertex(it)[2], k);
            else printf("| %s | %g | %.3g | %.4g | %.3g | %ld |\n", tables[tb], h, dmax / h, r3 / (h * h), r5, k);
            dth_integrator_free(it);
        }
    }
    dth_model_free(m);
}

/* ---- (3) CPU at equal error, Kepler e = 0.6 ---- */

/* log-log interpolation of cpu at error `target` on the points (err, cpu), err falling; NaN if not bracketed */
static double cpu_at(const double *err, const double *cpu, int n, double target)
{
    for (int i = 0; i + 1 < n; i++)
        if ((err[i] - target) * (err[i + 1] - target) <= 0 && err[i] != err[i + 1]) {
            double w = log(target / err[i]) / log(err[i + 1] / err[i]);
            return exp(log(cpu[i]) + w * log(cpu[i + 1] / cpu[i]));
        }
    return NAN;
}

static void cost(int full)
{
    double orbits = full ? 1000 : 30, target = full ? 1e-5 : 3e-7, T[1] = {2 * PI * orbits};
    /* steps that bracket the target (error ~ h^2 T resp. h^4 T) */
    double s = pow(orbits / 1000.0, -0.5) * sqrt(target / 1e-5), s4 = pow(orbits / 1000.0, -0.25) * pow(target / 1e-5, 0.25);
    const struct {
        const char *label;
        int order;
        const char *table;
        double h[3];
    } meth[] = {{"order 2", 2, NULL, {1.25e-4 * s, 8.63e-5 * s, 6e-5 * s}},
                {"order 4 suzuki4", 4, "suzuki4", {0.0042 * s4, 0.0031 * s4, 0.0024 * s4}},
                {"order 4 yoshida4", 4, "yoshida4", {0.0016 * s4, 0.00116 * s4, 0.0009 * s4}}};
    dth_model *m = make(&dth_model_kepler, NULL, 0);
    double y[MAXZ], cpu_t[3];
    reference(m, (double[]){0.4, 0}, (double[]){0, 2}, T[0], y);
    printf("\n## (3) Kepler e = 0.6 from pericentre, %g orbits: CPU at equal final position error %.0e (release build)\n\n",
           orbits, target);
    printf("| method | h | steps | Newton iterations per (sub)step | final position error | CPU s |\n|---|---|---|---|---|---|\n");
    for (int k = 0; k < 3; k++) {
        double e[3], c[3];
        for (int i = 0; i < 3; i++) {
            dth_options o;
            dth_options_default(&o);
            o.order = meth[k].order;
            o.table = meth[k].table;
            o.h = meth[k].h[i];
            iters_sum = 0;
            double z[2][MAXZ];
            runres r = run_to(m, &o, (double[]){0.4, 0}, (double[]){0, 2}, T, 1, z);
            if (r.rc) exit(1);
            long steps = r.steps, iters = iters_sum;
            c[i] = r.cpu;
            e[i] = hypot(z[0][0] - y[0], z[0][1] - y[1]);
            int subs = meth[k].order == 2 ? 1 : dth__table_find(meth[k].table)->stages;
            printf("| %s | %.4g | %ld | %.2f | %.3e | %.3f |\n", meth[k].label, o.h, steps, (double)iters / (double)(steps * subs),
                   e[i], c[i]);
        }
        cpu_t[k] = cpu_at(e, c, 3, target);
    }
    printf("\nCPU at error %.0e (interpolated): order 2 %.3f s, suzuki4 %.3f s, yoshida4 %.3f s: order 4 / order 2 = %.3f "
           "(suzuki4), %.3f (yoshida4); target <= 0.1\n", target, cpu_t[0], cpu_t[1], cpu_t[2], cpu_t[1] / cpu_t[0],
           cpu_t[2] / cpu_t[0]);
    dth_model_free(m);
}

/* ---- (4) through psi = 0 crossings ---- */

static void crossings(int full)
{
    const struct {
        const char *name;
        double q0[2], p0[2], h0, band_time;
        const dth_model_type *t;
    } cc[] = {{"rotating pendulum (0, 2.2)", {0}, {2.2}, 0.1, 0, &dth_model_pendulum},
              {"rotating pendulum (0, 2.2)", {0}, {2.2}, 0.1, 0.6, &dth_model_pendulum},
              {"Kepler e = 0.9 from apocentre", {-1.9, 0}, {0, -0.22941573387056177}, 0.1, 0, &dth_model_kepler},
              {"Kepler e = 0.9 from apocentre", {-1.9, 0}, {0, -0.22941573387056177}, 0.1, 0.2, &dth_model_kepler}};
    printf("\n## (4) Through psi = 0 crossings (suzuki4, a regularizer attached: the band; band_time 0 is the default\n"
           "## rule, a crossing entered 4 steps ahead; band_time > 0: a band fixed in phase space)\n\n");
    printf("| case | band_time | h | steps | band steps | crossings | error T = 10 | error T = 100 |\n|---|---|---|---|---|---|---|---|\n");
    const double T[2] = {10, 100};
    for (size_t c = 0; c < sizeof cc / sizeof cc[0]; c++) {
        dth_model *m = make(cc[c].t, NULL, 0);
        size_t n = dth_model_dof(m);
        dth_regularizer *reg = NULL;
        char err[256];
        if (dth_regularizer_new(&dth_reg_land, NULL, 0, m, NULL, &reg, err, sizeof err)) exit(1);
        double y[2][MAXZ], e[6][2];
        for (int t = 0; t < 2; t++) reference(m, cc[c].q0, cc[c].p0, T[t], y[t]);
        int nh = full ? 5 : 3;
        for (int s = 0; s < nh; s++) {
            dth_options o;
            dth_options_default(&o);
            o.order = 4;
            o.h = cc[c].h0 / (1 << (s + (full ? 0 : 2)));
            o.regularizer = reg;
            o.band_time = cc[c].band_time;
            double z[2][MAXZ];
            dth_run_state st;
            dth_integrator *it = NULL;
            if (dth_integrator_new(m, &o, &it) || dth_integrator_start(it, cc[c].q0, cc[c].p0, 0)) exit(1);
            grab g = {2 * n + 2, 0, {{0}}};
            dth_run_config cfg;
            dth_run_config_default(&cfg);
            cfg.has_t_end = 1, cfg.t_end = 100, cfg.t0 = 0, cfg.points = DTH_POINTS_TIMES, cfg.times = T, cfg.ntimes = 2;
            cfg.sample = on_sample, cfg.user = &g;
            dth_run_state_init(&st);
            int rc = dth_run(it, &cfg, &st);
            memcpy(z, g.z, sizeof z);
            for (int t = 0; t < 2; t++) e[s][t] = err_qp(n, z[t], y[t], 0);
            if (rc) printf("| %s | %g | %g | stopped at t = %g: %s |\n", cc[c].name, cc[c].band_time, o.h, st.t, dth_integrator_errmsg(it));
            else printf("| %s | %g | %g | %ld | %ld | %ld | %.3e | %.3e |\n", cc[c].name, cc[c].band_time, o.h, st.k, st.regularized,
                        st.crossings, e[s][0], e[s][1]);
            dth_integrator_free(it);
        }
        printf("| %s | %g | orders |", cc[c].name, cc[c].band_time);
        for (int s = 1; s < nh; s++) printf(" %.2f/%.2f", log2(e[s - 1][0] / e[s][0]), log2(e[s - 1][1] / e[s][1]));
        printf(" | | | | |\n");
        dth_regularizer_free(reg);
        dth_model_free(m);
    }
}

/* ---- (5) long runs and the error estimate ---- */

static void longruns(int full)
{
    long K = full ? 1000000 : 100000;
    dth_model *m = make(&dth_model_pendulum, NULL, 0);
    dth_options o;
    dth_options_default(&o);
    o.order = 4;
    o.h = 0.1;
    dth_integrator *it = NULL;
    if (dth_integrator_new(m, &o, &it) || dth_integrator_start(it, (double[]){1}, (double[]){0}, 0)) exit(1);
    printf("\n## (5) The vertex energy H(z_k) = wp + H_phys(z_k) over %ld composite steps (pendulum q0 = 1, h = 0.1,\n"
           "## suzuki4): max |H(z_k)| per window of steps\n\n| steps | max abs H(z_k) | mean abs H(z_k) |\n|---|---|---|\n", K);
    long lo = 0;
    double mx = 0, sum = 0;
    for (long k = 1; k <= K; k++) {
        if (dth_integrator_step(it, NULL)) exit(1);
        const double *z = dth_integrator_vertex(it);
        double H;
        dth_model_eval(m, z, DTH_EVAL_H, &H, NULL, NULL);
        H = fabs(H + z[3]);
        mx = fmax(mx, H);
        sum += H;
        if (k == 10 * (lo ? lo : 1) || k == K) {
            printf("| %ld..%ld | %.4e | %.4e |\n", lo + 1, k, mx, sum / (double)(k - lo));
            lo = k, mx = 0, sum = 0;
        }
    }
    printf("\nt = %.1f at the end\n", dth_integrator_vertex(it)[1]);
    dth_integrator_free(it);
    dth_model_free(m);
    /* the error estimate against the true error */
    printf("\n## The error estimate (dth_options.estimate; its shadow: Butcher's Runge-Kutta method of order 6)\n\n"
           "| case | h | true abs(dq) at T = 100 | estimate | ratio |\n|---|---|---|---|---|\n");
    for (size_t c = 0; c < 3; c++) {
        const ocase *k = &cases[c];
        dth_model *mm = make(k->type, k->kv, k->nkv);
        for (double h = k->h0 / 2; h > k->h0 / 9; h /= 2) {
            dth_options oo;
            dth_options_default(&oo);
            oo.order = 4;
            oo.h = h;
            oo.estimate = 1;
            dth_integrator *ii = NULL;
            if (dth_integrator_new(mm, &oo, &ii) || dth_integrator_start(ii, k->q0, k->p0, 0)) exit(1);
            size_t n = dth_model_dof(mm);
            while (dth_integrator_vertex(ii)[n] < 100)
                if (dth_integrator_step(ii, NULL)) exit(1);
            const double *z = dth_integrator_vertex(ii);
            double y[MAXZ], eq, ep;
            reference(mm, k->q0, k->p0, z[n], y);
            dth_integrator_error(ii, &eq, &ep);
            double tq = err_qp(n, z, y, 1);
            printf("| %s | %g | %.3e | %.3e | %.3f |\n", k->name, h, tq, eq, eq / tq);
            dth_integrator_free(ii);
        }
        dth_model_free(mm);
    }
}

int main(int argc, char **argv)
{
    int full = 0, only = 0;
    for (int i = 1; i < argc; i++) {
        if (!strcmp(argv[i], "--full")) full = 1;
        else if (!strcmp(argv[i], "--only") && i + 1 < argc) only = atoi(argv[++i]);
        else {
            fprintf(stderr, "usage: bench_order4 [--full] [--only 1..5]\n");
            return 2;
        }
    }
    printf("# bench_order4 (%s mode)\n", full ? "full" : "quick");
    if (!only || only == 1) orders(full);
    if (!only || only == 2) conditions(full);
    if (!only || only == 3) cost(full);
    if (!only || only == 4) crossings(full);
    if (!only || only == 5) longruns(full);
    return 0;
}
