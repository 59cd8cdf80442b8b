/* SPDX-License-Identifier: MIT */
/*
 * The DTH method of order 4 (issue 22; lib/compose.c: level-shifted DTH substeps composed by Suzuki's
 * table): its order at fixed times T = 10 and T = 100 (dense output at T, never fixed step counts) on
 * the pendulum, Kepler e = 0.6 from both apsides, the user-written Henon-Heiles model and a 3-D ring
 * of springs (a pentagon of radius 1 that does not cross psi = 0: psi in [0.076, 0.565] over T = 100,
 * research r22), a forced oscillator; the structure: a symplectic composite tangent on every step, wp
 * bit for bit, Kepler's L over 1000 orbits, the vertex energy flat; checkpoints resume bit for bit;
 * reversal; every linear-solver path; psi = 0 crossings run to the end (rotating pendulum, Kepler e =
 * 0.9) and measure order 4 with a band fixed in phase space, end at the first crossing without one; the
 * options' rules (the regularizers order 4 takes); the run's stop rule.
 */
#include <float.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <gsl/gsl_errno.h>
#include <gsl/gsl_odeiv2.h>
#include "cu_main.h"
#include "dth/dth.h"
#include "test_util.h"
#include "compose.h"
#include "stepper.h"
#include "../docs/examples/henon_heiles.h"

enum { MAXN = 16, MAXZ = 2 * MAXN + 2 };
#define PI 3.14159265358979323846

/* ---- runs to fixed times: the dense output at each T ---- */

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

/* Run `o` from (q0, p0) at t = 0 to T[1], the states at T[0] and T[1] into z. Returns the status. */
static int run_to(const dth_model *m, const dth_options *o, const double *q0, const double *p0, const double T[2],
                  double z[2][MAXZ], dth_run_state *st)
{
    dth_integrator *it = NULL;
    int rc = dth_integrator_new(m, o, &it);
    CU_ASSERT_EQUAL_FATAL(rc, DTH_OK);
    CU_ASSERT_EQUAL_FATAL(dth_integrator_start(it, q0, p0, 0), DTH_OK);
    grab g = {dth_integrator_dim(it), 0, {{0}}};
    dth_run_config cfg;
    dth_run_config_default(&cfg);
    cfg.has_t_end = 1;
    cfg.t_end = T[1];
    cfg.t0 = 0;
    cfg.points = DTH_POINTS_TIMES;
    cfg.times = T;
    cfg.ntimes = 2;
    cfg.sample = on_sample;
    cfg.user = &g;
    dth_run_state_init(st);
    rc = dth_run(it, &cfg, st);
    if (rc) fprintf(stderr, "run stopped at t = %g: %s\n", st->t, dth_integrator_errmsg(it));
    memcpy(z, g.z, sizeof g.z);
    dth_integrator_free(it);
    return rc;
}

/* The reference: the model's exact solution, else GSL rk8pd at tolerance 1e-14. */
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
    double y0[2 * MAXN + 1];
    memcpy(y0, q0, n * sizeof *y0);
    y0[n] = 0;
    memcpy(y0 + n + 1, p0, n * sizeof *y0);
    if (dth_model_exact(m, y0, T, y) == DTH_OK) return;
    gctx c = {m, n, {0}, {0}};
    gsl_odeiv2_system sys = {gsl_rhs, NULL, 2 * n, &c};
    gsl_odeiv2_driver *d = gsl_odeiv2_driver_alloc_y_new(&sys, gsl_odeiv2_step_rk8pd, 1e-3, 1e-14, 1e-14);
    double x[2 * MAXN], t = 0;
    memcpy(x, q0, n * sizeof *x);
    memcpy(x + n, p0, n * sizeof *x);
    CU_ASSERT_EQUAL_FATAL(gsl_odeiv2_driver_apply(d, &t, T, x), GSL_SUCCESS);
    gsl_odeiv2_driver_free(d);
    memcpy(y, x, n * sizeof *x);
    y[n] = T;
    memcpy(y + n + 1, x + n, n * sizeof *x);
}

/* |(q, p) - (q, p)_ref| (2-norm) */
static double err_qp(size_t n, const double *z, const double *y)
{
    double s = 0;
    for (size_t j = 0; j < 2 * n + 1; j++)
        if (j != n) s += (z[j] - y[j]) * (z[j] - y[j]);
    return sqrt(s);
}

/* ---- the cases ---- */

typedef struct ocase {
    const char *name;
    const dth_model_type *type;
    dth_kv kv[4];
    size_t nkv;
    double q0[MAXN], p0[MAXN];
    double h; /* the larger of the two steps */
} ocase;

static const ocase cases[] = {
    {"pendulum", &dth_model_pendulum, {{0}}, 0, {1}, {0}, 0.05},
    {"kepler e=0.6 pericentre", &dth_model_kepler, {{0}}, 0, {0.4, 0}, {0, 2}, 0.005},
    {"kepler e=0.6 apocentre", &dth_model_kepler, {{0}}, 0, {-1.6, 0}, {0, -0.5}, 0.05},
    {"henon-heiles (user model)", &example_henon_heiles, {{0}}, 0, {0, 0.1}, {0.39665266081716, 0}, 0.05},
    {"ring of 5 in 3-D", &dth_model_coupled, {{"preset", "ring"}, {"size", "5"}, {"dim", "3"}}, 3,
     {1, 0, 0, 0.309017, 0.9510565, -0.058779, -0.809017, 0.5877855, 0.095106, -0.809017, -0.5877855, -0.095106,
      0.309017, -0.9510565, 0.058779},
     {0, 0, 0.2, 0.05, 0, -0.161803, 0.1, 0, 0.061803, 0.15, 0, 0.061803, 0.2, 0, -0.161803},
     0.025},
};

/* The order of the last halving at T = 10 and T = 100 (>= 3.8 each), Suzuki's table. */
static void test_order_fixed_times(void)
{
    const double T[2] = {10, 100};
    printf("\n  %-26s %-9s %-11s %-11s %-6s %-11s %-11s %-6s\n", "case", "h", "err T=10", "err(h/2)", "order",
           "err T=100", "err(h/2)", "order");
    for (size_t c = 0; c < sizeof cases / sizeof cases[0]; c++) {
        const ocase *k = &cases[c];
        dth_model *m = model(k->type, k->kv, k->nkv, 0);
        size_t n = dth_model_dof(m);
        double e[2][2], y[2][MAXZ];
        for (int t = 0; t < 2; t++) reference(m, k->q0, k->p0, T[t], y[t]);
        for (int s = 0; s < 2; s++) {
            dth_options o;
            dth_options_default(&o);
            o.order = 4;
            o.h = k->h / (1 << s);
            double z[2][MAXZ];
            dth_run_state st;
            CU_ASSERT_EQUAL(run_to(m, &o, k->q0, k->p0, T, z, &st), DTH_OK);
            for (int t = 0; t < 2; t++) e[s][t] = err_qp(n, z[t], y[t]);
        }
        double p10 = log2(e[0][0] / e[1][0]), p100 = log2(e[0][1] / e[1][1]);
        printf("  %-26s %-9g %-11.3e %-11.3e %-6.2f %-11.3e %-11.3e %-6.2f\n", k->name, k->h, e[0][0], e[1][0], p10,
               e[0][1], e[1][1], p100);
        CU_ASSERT(p10 >= 3.8);
        CU_ASSERT(p100 >= 3.8);
        CU_ASSERT(p10 <= 4.5 && p100 <= 4.5); /* not a lucky cancellation */
        dth_model_free(m);
    }
}

/* A non-autonomous model (t and wp are Newton unknowns, wp moves): order 4 at T = 10. */
static void test_order_forced(void)
{
    dth_model *m = model(&test_forced_type, NULL, 0, 0);
    const double T[2] = {5, 10}, q0[1] = {1}, p0[1] = {0};
    double y[2][MAXZ], e[2][2];
    for (int t = 0; t < 2; t++) reference(m, q0, p0, T[t], y[t]);
    for (int s = 0; s < 2; s++) {
        dth_options o;
        dth_options_default(&o);
        o.order = 4;
        o.h = 0.1 / (1 << s);
        double z[2][MAXZ];
        dth_run_state st;
        CU_ASSERT_EQUAL(run_to(m, &o, q0, p0, T, z, &st), DTH_OK);
        for (int t = 0; t < 2; t++) e[s][t] = err_qp(1, z[t], y[t]);
    }
    printf("\n  forced oscillator: T = 10 errors %.3e, %.3e: order %.2f\n", e[0][1], e[1][1], log2(e[0][1] / e[1][1]));
    CU_ASSERT(log2(e[0][0] / e[1][0]) >= 3.8);
    CU_ASSERT(log2(e[0][1] / e[1][1]) >= 3.8);
    dth_model_free(m);
}

/* ---- structure ---- */

static dth_integrator *started(const dth_model *m, double h, const double *q0, const double *p0, dth_regularizer *reg)
{
    dth_options o;
    dth_options_default(&o);
    o.order = 4;
    o.h = h;
    o.regularizer = reg;
    dth_integrator *it = NULL;
    CU_ASSERT_EQUAL_FATAL(dth_integrator_new(m, &o, &it), DTH_OK);
    CU_ASSERT_EQUAL_FATAL(dth_integrator_start(it, q0, p0, 0), DTH_OK);
    return it;
}

static double max_abs(const double *M, size_t len)
{
    double a = 0;
    for (size_t i = 0; i < len; i++) a = fmax(a, fabs(M[i]));
    return a;
}

/* |M^T J M - J| <= 1e-12 |M|^2 for the composite tangent of every step, wp bit for bit. */
static void check_symplectic(const dth_model *m, double h, const double *q0, const double *p0, long steps,
                             dth_regularizer *reg, long *with_map)
{
    size_t n = dth_model_dof(m), N = 2 * n + 2;
    dth_integrator *it = started(m, h, q0, p0, reg);
    double M[MAXZ * MAXZ], wp0 = dth_integrator_vertex(it)[N - 1], worst = 0;
    long bad_wp = 0;
    *with_map = 0;
    for (long k = 0; k < steps; k++) {
        CU_ASSERT_EQUAL_FATAL(dth_integrator_step(it, NULL), DTH_OK);
        double wp = dth_integrator_vertex(it)[N - 1];
        if (memcmp(&wp, &wp0, sizeof wp) != 0) bad_wp++;
        int rc = dth_integrator_tangent(it, M);
        if (rc == DTH_EINVAL && reg) continue; /* a band exit's projection has no tangent map */
        CU_ASSERT_EQUAL_FATAL(rc, DTH_OK);
        double a = max_abs(M, N * N), d = symplectic_defect(n, M, 0) / (a * a);
        worst = fmax(worst, d);
        CU_ASSERT(d <= 1e-12);
        (*with_map)++;
    }
    CU_ASSERT_EQUAL(bad_wp, 0);
    printf("  %s: %ld steps, %ld tangent maps, max |M^T J M - J| / |M|^2 = %.2e\n", dth_model_get_type(m)->name, steps,
           *with_map, worst);
    dth_integrator_free(it);
}

static void test_symplectic(void)
{
    long nm;
    printf("\n");
    dth_model *pm = model(&dth_model_pendulum, NULL, 0, 0), *km = model(&dth_model_kepler, NULL, 0, 0);
    dth_model *hm = model(&example_henon_heiles, NULL, 0, 0);
    check_symplectic(pm, 0.1, (double[]){1}, (double[]){0}, 300, NULL, &nm);
    CU_ASSERT_EQUAL(nm, 300);
    check_symplectic(km, 0.01, (double[]){0.4, 0}, (double[]){0, 2}, 600, NULL, &nm);
    CU_ASSERT_EQUAL(nm, 600);
    check_symplectic(hm, 0.1, (double[]){0, 0.1}, (double[]){0.39665266081716, 0}, 300, NULL, &nm);
    CU_ASSERT_EQUAL(nm, 300);
    /* through psi = 0: band steps (the midpoint rule's maps) too */
    dth_regularizer *reg = NULL;
    char err[256];
    CU_ASSERT_EQUAL_FATAL(dth_regularizer_new(&dth_reg_land, NULL, 0, pm, NULL, &reg, err, sizeof err), DTH_OK);
    check_symplectic(pm, 0.05, (double[]){0}, (double[]){2.2}, 300, reg, &nm);
    CU_ASSERT(nm >= 280);
    dth_regularizer_free(reg);
    dth_model_free(pm);
    dth_model_free(km);
    dth_model_free(hm);
}

/* Kepler e = 0.6 over 1000 orbits: L = q1 p2 - q2 p1 within 1e-13 relative at every vertex. */
static void test_kepler_L(void)
{
    dth_model *m = model(&dth_model_kepler, NULL, 0, 0);
    dth_integrator *it = started(m, 0.01, (double[]){0.4, 0}, (double[]){0, 2}, NULL);
    double L0 = 0.4 * 2, worst = 0, T = 2000 * PI;
    long k = 0;
    while (dth_integrator_vertex(it)[2] < T) {
        CU_ASSERT_EQUAL_FATAL(dth_integrator_step(it, NULL), DTH_OK);
        const double *z = dth_integrator_vertex(it);
        worst = fmax(worst, fabs(z[0] * z[4] - z[1] * z[3] - L0) / L0);
        k++;
    }
    printf("\n  Kepler e = 0.6, h = 0.01, 1000 orbits (%ld steps): max |L - L0| / L0 = %.2e\n", k, worst);
    CU_ASSERT(worst <= 1e-13);
    dth_integrator_free(it);
    dth_model_free(m);
}

/* The vertex energy H(z_k) = O(h^4) and flat: the largest |H(z_k)| over the last tenth of 2 10^5
 * pendulum steps within 2 % of the first tenth's (10^6 steps: bench_order4). */
static void test_vertex_energy_flat(void)
{
    dth_model *m = model(&dth_model_pendulum, NULL, 0, 0);
    dth_integrator *it = started(m, 0.1, (double[]){1}, (double[]){0}, NULL);
    long K = 200000;
    double first = 0, last = 0;
    for (long k = 0; k < K; k++) {
        CU_ASSERT_EQUAL_FATAL(dth_integrator_step(it, NULL), DTH_OK);
        const double *z = dth_integrator_vertex(it);
        double H;
        CU_ASSERT_FATAL(dth_model_eval(m, z, DTH_EVAL_H, &H, NULL, NULL) == DTH_OK);
        H += z[3];
        if (k < K / 10) first = fmax(first, fabs(H));
        if (k >= K - K / 10) last = fmax(last, fabs(H));
    }
    printf("\n  pendulum h = 0.1, %ld steps: max |H(z_k)| first tenth %.4e, last tenth %.4e\n", K, first, last);
    CU_ASSERT(first > 0 && first < 1e-5);
    CU_ASSERT(fabs(last / first - 1) <= 0.02);
    dth_integrator_free(it);
    dth_model_free(m);
}

/* ---- checkpoints, reversal, linear solvers ---- */

/* Save after k steps, go on `more`; a second integrator restored from the save goes on the same
 * steps bit for bit. */
static void resume_case(const dth_model *m, double h, const double *q0, const double *p0, dth_regularizer *reg,
                        long k, long more, int want_band)
{
    size_t N = 2 * dth_model_dof(m) + 2;
    dth_integrator *a = started(m, h, q0, p0, reg);
    dth_step_info info = {0};
    int in_band = 0;
    for (long i = 0; i < k || (want_band && !in_band && i < 10 * k); i++) {
        CU_ASSERT_EQUAL_FATAL(dth_integrator_step(a, &info), DTH_OK);
        in_band = info.branch == DTH_BRANCH_REG;
    }
    CU_ASSERT(!want_band || in_band);
    size_t len = 0;
    CU_ASSERT_EQUAL_FATAL(dth_checkpoint_save(a, NULL, 0, NULL, 0, &len), DTH_OK);
    unsigned char *buf = malloc(len);
    CU_ASSERT_FATAL(buf != NULL);
    CU_ASSERT_EQUAL_FATAL(dth_checkpoint_save(a, NULL, 0, buf, len, &len), DTH_OK);
    double za[MAXZ], zb[MAXZ];
    for (long i = 0; i < more; i++) CU_ASSERT_EQUAL_FATAL(dth_integrator_step(a, NULL), DTH_OK);
    memcpy(za, dth_integrator_vertex(a), N * sizeof *za);
    dth_integrator *b = started(m, h, q0, p0, reg);
    char err[256];
    CU_ASSERT_EQUAL_FATAL(dth_checkpoint_restore(b, buf, len, err, sizeof err), DTH_OK);
    for (long i = 0; i < more; i++) CU_ASSERT_EQUAL_FATAL(dth_integrator_step(b, NULL), DTH_OK);
    memcpy(zb, dth_integrator_vertex(b), N * sizeof *zb);
    CU_ASSERT(memcmp(za, zb, N * sizeof *za) == 0);
    CU_ASSERT_EQUAL(dth_integrator_steps(a), dth_integrator_steps(b));
    free(buf);
    dth_integrator_free(a);
    dth_integrator_free(b);
}

static void test_checkpoint(void)
{
    dth_model *km = model(&dth_model_kepler, NULL, 0, 0), *pm = model(&dth_model_pendulum, NULL, 0, 0);
    resume_case(km, 0.01, (double[]){0.4, 0}, (double[]){0, 2}, NULL, 301, 400, 0);
    dth_regularizer *reg = NULL;
    char err[256];
    CU_ASSERT_EQUAL_FATAL(dth_regularizer_new(&dth_reg_land, NULL, 0, pm, NULL, &reg, err, sizeof err), DTH_OK);
    resume_case(pm, 0.05, (double[]){0}, (double[]){2.2}, reg, 5, 300, 1); /* saved inside a band */
    /* an order-2 checkpoint does not restore into order 4 */
    dth_options o;
    dth_options_default(&o);
    dth_integrator *two = NULL, *four = started(km, 0.01, (double[]){0.4, 0}, (double[]){0, 2}, NULL);
    CU_ASSERT_EQUAL_FATAL(dth_integrator_new(km, &o, &two), DTH_OK);
    CU_ASSERT_EQUAL_FATAL(dth_integrator_start(two, (double[]){0.4, 0}, (double[]){0, 2}, 0), DTH_OK);
    unsigned char buf[8192];
    size_t len = 0;
    CU_ASSERT_EQUAL_FATAL(dth_checkpoint_save(two, NULL, 0, buf, sizeof buf, &len), DTH_OK);
    CU_ASSERT_NOT_EQUAL(dth_checkpoint_restore(four, buf, len, err, sizeof err), DTH_OK);
    dth_integrator_free(two);
    dth_integrator_free(four);
    dth_regularizer_free(reg);
    dth_model_free(km);
    dth_model_free(pm);
}

/* 200 steps forward, reverse, 200 back: the start to round-off. */
static void test_reverse(void)
{
    dth_model *m = model(&dth_model_kepler, NULL, 0, 0);
    dth_integrator *it = started(m, 0.01, (double[]){0.4, 0}, (double[]){0, 2}, NULL);
    double z0[6];
    memcpy(z0, dth_integrator_vertex(it), sizeof z0);
    for (int i = 0; i < 200; i++) CU_ASSERT_EQUAL_FATAL(dth_integrator_step(it, NULL), DTH_OK);
    dth_integrator_reverse(it);
    CU_ASSERT_EQUAL(dth_integrator_direction(it), -1.0);
    for (int i = 0; i < 200; i++) CU_ASSERT_EQUAL_FATAL(dth_integrator_step(it, NULL), DTH_OK);
    const double *z = dth_integrator_vertex(it);
    double d = 0;
    for (int j = 0; j < 6; j++) d = fmax(d, fabs(z[j] - z0[j]));
    printf("\n  Kepler 200 steps there and back: max |z - z0| = %.2e\n", d);
    CU_ASSERT(d <= 1e-10); /* round-off of 1000 substeps through two pericentres (measured 1.5e-11) */
    dth_integrator_free(it);
    dth_model_free(m);
}

/* The same run on every linear-solver path agrees to round-off, grown along the trajectory (lambda is
 * fixed at second order, so each solver's rounding moves it by eps / (psi lambda^2)). */
static void paths(const dth_model *m, const dth_linsolve *ls, size_t nls, double h, const double *q0, const double *p0,
                  long steps)
{
    size_t N = 2 * dth_model_dof(m) + 2;
    double ref[MAXZ * 4], worst = 0;
    for (size_t i = 0; i < nls; i++) {
        dth_options o;
        dth_options_default(&o);
        o.order = 4;
        o.h = h;
        o.linsolve = ls[i];
        dth_integrator *it = NULL;
        CU_ASSERT_EQUAL_FATAL(dth_integrator_new(m, &o, &it), DTH_OK);
        CU_ASSERT_EQUAL_FATAL(dth_integrator_start(it, q0, p0, 0), DTH_OK);
        for (long k = 0; k < steps; k++) CU_ASSERT_EQUAL_FATAL(dth_integrator_step(it, NULL), DTH_OK);
        const double *z = dth_integrator_vertex(it);
        if (i == 0) memcpy(ref, z, N * sizeof *z);
        for (size_t j = 0; j < N; j++) worst = fmax(worst, fabs(z[j] - ref[j]) / (1 + fabs(ref[j])));
        dth_integrator_free(it);
    }
    printf("  %s: %zu linear solvers, %ld steps: largest difference %.2e\n", dth_model_get_type(m)->name, nls, steps, worst);
    CU_ASSERT(worst <= 1e-10); /* round-off grown along the run (2e-12, 1.8e-11 measured); a wrong path: >= 1e-6 */
}

static void test_linsolve_paths(void)
{
    printf("\n");
    dth_model *km = model(&dth_model_kepler, NULL, 0, 0);
    const dth_linsolve dense[] = {DTH_LINSOLVE_SMALL, DTH_LINSOLVE_SMALL_LU, DTH_LINSOLVE_DENSE};
    paths(km, dense, 3, 0.01, (double[]){0.4, 0}, (double[]){0, 2}, 100);
    dth_kv kv[] = {{"preset", "chain"}, {"size", "8"}, {"dim", "1"}, {"L", "0.8"}};
    dth_model *cm = model(&dth_model_coupled, kv, 4, 0);
    const dth_linsolve band[] = {DTH_LINSOLVE_BANDED, DTH_LINSOLVE_BANDED_LU, DTH_LINSOLVE_DENSE};
    double q0[8], p0[8];
    for (int i = 0; i < 8; i++) q0[i] = i + 0.1 * sin(i), p0[i] = 0.2 * cos(2 * i);
    paths(cm, band, 3, 0.05, q0, p0, 200);
    dth_model_free(km);
    dth_model_free(cm);
}

/* The three finishes solve the same substeps: the compensated and reversible finishes carry the vertex
 * offset H(z_k) from substep to substep (a level-shifted root has H(zbar) = -s, not 0: carried as
 * H(zbar) it offset every later substep's level, which the compensated finish hid by falling back to
 * the direct constraint and the reversible one could not: its composite steps failed at once). */
static void test_finishes(void)
{
    dth_model *m = model(&dth_model_pendulum, NULL, 0, 0);
    double zf[3][4];
    for (int f = 0; f < 3; f++) {
        dth_options o;
        dth_options_default(&o);
        o.order = 4;
        o.h = 0.1;
        o.finish = (dth_finish)f;
        dth_integrator *it = NULL;
        CU_ASSERT_EQUAL_FATAL(dth_integrator_new(m, &o, &it), DTH_OK);
        CU_ASSERT_EQUAL_FATAL(dth_integrator_start(it, (double[]){1}, (double[]){0}, 0), DTH_OK);
        int rc = DTH_OK;
        while (!rc && dth_integrator_vertex(it)[1] < 10) rc = dth_integrator_step(it, NULL);
        CU_ASSERT_EQUAL(rc, DTH_OK);
        if (rc) fprintf(stderr, "finish %d: %s\n", f, dth_integrator_errmsg(it));
        memcpy(zf[f], dth_integrator_vertex(it), sizeof zf[f]);
        /* the carried offset is the vertex energy H(z_k) (compensated, reversible: to its coarse point) */
        const dth__comp *c = it->state;
        double H;
        CU_ASSERT_FATAL(dth_model_eval(m, zf[f], DTH_EVAL_H, &H, NULL, NULL) == DTH_OK);
        double off = fabs(c->core->st.rho - (zf[f][3] + H));
        /* compensated: to round-off (1e-16 measured; before the fix it was off by a level, ~1e-4);
         * reversible: H at its coarsened vertex, a 2^-28 cell away (5e-10 measured) */
        if (f == 1) CU_ASSERT(off <= 1e-14);
        if (f == 2) CU_ASSERT(off <= 1e-8);
        dth_integrator_free(it);
    }
    double d = 0;
    for (int f = 1; f < 3; f++)
        for (int j = 0; j < 4; j++) d = fmax(d, fabs(zf[f][j] - zf[0][j]));
    printf("\n  pendulum to t = 10: the plain, compensated and reversible finishes agree to %.2e\n", d);
    CU_ASSERT(d <= 1e-11);
    dth_model_free(m);
}

/* ---- psi = 0 crossings ---- */

/* The rotating pendulum and Kepler e = 0.9 to T = 100 with a regularizer (the default rule), and
 * with a band fixed in phase space (band_time) order 4 through crossings. */
static void cross_case(const dth_model *m, const double *q0, const double *p0, double h, double band_time,
                       double T2, double *e10, double *e100, long *crossings)
{
    dth_regularizer *reg = NULL;
    char err[256];
    CU_ASSERT_EQUAL_FATAL(dth_regularizer_new(&dth_reg_land, NULL, 0, m, NULL, &reg, err, sizeof err), DTH_OK);
    dth_options o;
    dth_options_default(&o);
    o.order = 4;
    o.h = h;
    o.regularizer = reg;
    o.band_time = band_time;
    const double T[2] = {10, T2};
    double z[2][MAXZ], y[MAXZ];
    dth_run_state st;
    CU_ASSERT_EQUAL(run_to(m, &o, q0, p0, T, z, &st), DTH_OK);
    CU_ASSERT(st.t >= T2);
    /* every band exit (a projection: no tangent map, no reverse) is flagged DTH_STEP_RESET: at least one
     * per band, and the band steps are counted as regularized (DTH_STEP_REGULARIZED) */
    CU_ASSERT(st.nonreversible >= 1 && st.nonreversible < st.regularized);
    *crossings = st.crossings;
    reference(m, q0, p0, 10, y);
    *e10 = err_qp(dth_model_dof(m), z[0], y);
    reference(m, q0, p0, T2, y);
    *e100 = err_qp(dth_model_dof(m), z[1], y);
    dth_regularizer_free(reg);
}

static void test_crossings(void)
{
    dth_model *pm = model(&dth_model_pendulum, NULL, 0, 0), *km = model(&dth_model_kepler, NULL, 0, 0);
    const double rq[1] = {0}, rp[1] = {2.2}, kq[2] = {-1.9, 0}, kp[2] = {0, -0.22941573387056177};
    double a10, a100, b10, b100;
    long nc;
    cross_case(pm, rq, rp, 0.05, 0, 100, &a10, &a100, &nc);
    printf("\n  rotating pendulum, default rule, h = 0.05: %ld crossings to T = 100, error %.2e\n", nc, a100);
    CU_ASSERT(nc >= 47);
    CU_ASSERT(a100 < 1e-3);
    cross_case(km, kq, kp, 0.05, 0, 100, &a10, &a100, &nc);
    printf("  Kepler e = 0.9 (apocentre), default rule, h = 0.05: %ld crossings to T = 100, error %.2e\n", nc, a100);
    CU_ASSERT(nc >= 64);
    CU_ASSERT(a100 < 1e-3);
    /* no crossing, no band: psi falling fast after Kepler e = 0.6's pericentre is not taken for one
     * (steps up to 21 h; the straight line of psi predicted a crossing, its parabola does not) */
    dth_regularizer *reg = NULL;
    char err[256];
    CU_ASSERT_EQUAL_FATAL(dth_regularizer_new(&dth_reg_land, NULL, 0, km, NULL, &reg, err, sizeof err), DTH_OK);
    dth_options o;
    dth_options_default(&o);
    o.order = 4;
    o.h = 0.02;
    o.regularizer = reg;
    double z[2][MAXZ];
    dth_run_state st;
    CU_ASSERT_EQUAL(run_to(km, &o, (double[]){0.4, 0}, (double[]){0, 2}, (double[]){10, 100}, z, &st), DTH_OK);
    printf("  Kepler e = 0.6, h = 0.02, regularizer attached: %ld band steps of %ld\n", st.regularized, st.k);
    CU_ASSERT_EQUAL(st.regularized, 0);
    CU_ASSERT_EQUAL(st.nonreversible, 0);
    dth_regularizer_free(reg);
    /* none (no regularizer, or an instance of 'none'): no band, the run ends at the first crossing */
    CU_ASSERT_EQUAL_FATAL(dth_regularizer_new(&dth_reg_none, NULL, 0, pm, NULL, &reg, err, sizeof err), DTH_OK);
    for (int with = 0; with < 2; with++) {
        dth_options_default(&o);
        o.order = 4;
        o.h = 0.05;
        o.regularizer = with ? reg : NULL;
        dth_integrator *it = NULL;
        CU_ASSERT_EQUAL_FATAL(dth_integrator_new(pm, &o, &it), DTH_OK);
        CU_ASSERT_EQUAL_FATAL(dth_integrator_start(it, rq, rp, 0), DTH_OK);
        int rc = DTH_OK;
        dth_step_info in;
        while (rc == DTH_OK && dth_integrator_vertex(it)[1] < 10) {
            rc = dth_integrator_step(it, &in);
            if (rc == DTH_OK) CU_ASSERT_EQUAL(in.flags & DTH_STEP_REGULARIZED, 0u);
        }
        printf("  rotating pendulum, order 4, %s: stops at t = %.3f (%s)\n", with ? "regularizer none" : "no regularizer",
               dth_integrator_vertex(it)[1], dth_status_name(rc));
        CU_ASSERT(rc != DTH_OK && dth_integrator_vertex(it)[1] < 1.5); /* at its first crossing (t = 1.03) */
        dth_integrator_free(it);
    }
    dth_regularizer_free(reg);
    cross_case(pm, rq, rp, 0.0125, 0.6, 100, &a10, &a100, &nc);
    cross_case(pm, rq, rp, 0.00625, 0.6, 100, &b10, &b100, &nc);
    printf("  rotating pendulum, band_time 0.6: h = 0.0125 -> 0.00625: T = 10 %.2e -> %.2e (order %.2f), T = 100 "
           "%.2e -> %.2e (order %.2f)\n", a10, b10, log2(a10 / b10), a100, b100, log2(a100 / b100));
    CU_ASSERT(log2(a10 / b10) >= 3.8);
    CU_ASSERT(log2(a100 / b100) >= 3.8);
    cross_case(km, kq, kp, 0.025, 0.2, 10, &a10, &a100, &nc);
    cross_case(km, kq, kp, 0.0125, 0.2, 10, &b10, &b100, &nc);
    printf("  Kepler e = 0.9, band_time 0.2: h = 0.025 -> 0.0125: T = 10 %.2e -> %.2e (order %.2f)\n", a10, b10,
           log2(a10 / b10));
    CU_ASSERT(log2(a10 / b10) >= 3.8);
    dth_model_free(pm);
    dth_model_free(km);
}

/* ---- options, dense output, events ---- */

static void test_options(void)
{
    dth_model *m = model(&dth_model_kepler, NULL, 0, 0);
    dth_options o;
    char err[512];
    dth_options_default(&o);
    o.order = 6;
    CU_ASSERT_EQUAL(dth_options_check(m, &o, err, sizeof err), DTH_EUNSUPPORTED);
    CU_ASSERT(strstr(err, "order 4") != NULL);
    o.order = 8;
    CU_ASSERT_EQUAL(dth_options_check(m, &o, err, sizeof err), DTH_EUNSUPPORTED);
    o.order = 3;
    CU_ASSERT_EQUAL(dth_options_check(m, &o, err, sizeof err), DTH_EINVAL);
    o.order = 4;
    o.table = "nope";
    CU_ASSERT_EQUAL(dth_options_check(m, &o, err, sizeof err), DTH_ENOTFOUND);
    CU_ASSERT(strstr(err, "suzuki4") != NULL);
    o.table = "yoshida4";
    CU_ASSERT_EQUAL(dth_options_check(m, &o, err, sizeof err), DTH_OK);
    o.band_time = -1;
    CU_ASSERT_EQUAL(dth_options_check(m, &o, err, sizeof err), DTH_EINVAL);
    dth_options_default(&o);
    o.table = "suzuki4"; /* order 2 */
    CU_ASSERT_EQUAL(dth_options_check(m, &o, err, sizeof err), DTH_EINVAL);
    dth_options_default(&o);
    o.method = "gauss4";
    o.order = 4;
    CU_ASSERT_EQUAL(dth_options_check(m, &o, err, sizeof err), DTH_EUNSUPPORTED);
    /* the regularizer: land (the band) and none (no band) are order 4's; prescribed (or any other, which
     * the composition would never call) is refused naming it, and stays order 2's */
    const dth_regularizer_type *regs[] = {&dth_reg_land, &dth_reg_none, &dth_reg_prescribed};
    for (size_t i = 0; i < 3; i++) {
        dth_regularizer *reg = NULL;
        CU_ASSERT_EQUAL_FATAL(dth_regularizer_new(regs[i], NULL, 0, m, NULL, &reg, err, sizeof err), DTH_OK);
        dth_options_default(&o);
        o.order = 4;
        o.regularizer = reg;
        int rc = dth_options_check(m, &o, err, sizeof err);
        if (regs[i] == &dth_reg_prescribed) {
            CU_ASSERT_EQUAL(rc, DTH_EUNSUPPORTED);
            CU_ASSERT(strstr(err, "order = 4 with regularizer 'prescribed': not supported") != NULL);
            CU_ASSERT(strstr(err, "order = 2 for 'prescribed'") != NULL);
            dth_integrator *it = NULL;
            CU_ASSERT_EQUAL(dth_integrator_new(m, &o, &it), DTH_EUNSUPPORTED);
            CU_ASSERT_PTR_NULL(it);
        } else {
            CU_ASSERT_EQUAL(rc, DTH_OK);
        }
        o.order = 2;
        CU_ASSERT_EQUAL(dth_options_check(m, &o, err, sizeof err), DTH_OK);
        dth_regularizer_free(reg);
    }
    /* order 4 has no midpoints: midpoint samples are refused, the accessor says NULL */
    dth_integrator *it = started(m, 0.01, (double[]){0.4, 0}, (double[]){0, 2}, NULL);
    /* the stop rule's bound: step_ratio^(3/2) h for order 4, step_ratio h for order 2 and a baseline of order 4 */
    CU_ASSERT_DOUBLE_EQUAL(dth_run_step_limit(it, 16), 0.64, 1e-15);
    CU_ASSERT(isinf(dth_run_step_limit(it, 0)));
    CU_ASSERT(isnan(dth_run_step_limit(NULL, 16)));
    for (int b = 0; b < 2; b++) {
        dth_options_default(&o);
        o.h = 0.01;
        o.method = b ? "gauss4" : "dth";
        dth_integrator *i2 = NULL;
        CU_ASSERT_EQUAL_FATAL(dth_integrator_new(m, &o, &i2), DTH_OK);
        CU_ASSERT_DOUBLE_EQUAL(dth_run_step_limit(i2, 16), 0.16, 1e-15);
        dth_integrator_free(i2);
    }
    CU_ASSERT_EQUAL(dth_integrator_order(it), 4);
    CU_ASSERT_STRING_EQUAL(dth_integrator_method(it), "dth");
    CU_ASSERT_EQUAL(dth_integrator_step(it, NULL), DTH_OK);
    CU_ASSERT_PTR_NULL(dth_integrator_midpoint(it));
    dth_run_config cfg;
    dth_run_config_default(&cfg);
    cfg.points = DTH_POINTS_MIDPOINTS;
    cfg.steps = 3;
    dth_run_state st;
    dth_run_state_init(&st);
    CU_ASSERT_EQUAL(dth_run(it, &cfg, &st), DTH_EINVAL);
    dth_integrator_free(it);
    dth_model_free(m);
}

typedef struct evs {
    int n;
    double t[8];
} evs;

static int on_event(void *user, const dth_sample *s)
{
    evs *e = user;
    if (e->n < 8) e->t[e->n] = s->z[2];
    e->n++;
    return 0;
}

/* Pericentre passages (q2 = 0 upward) of Kepler e = 0.6 located on the quintic dense output: at 2 pi k
 * to within the method's own phase error, converging at order 4. */
static void test_events(void)
{
    dth_model *m = model(&dth_model_kepler, NULL, 0, 0);
    double worst[2] = {0, 0};
    for (int s = 0; s < 2; s++) {
        dth_integrator *it = started(m, 0.01 / (1 << s), (double[]){0.4, 0}, (double[]){0, 2}, NULL);
        dth_event_spec spec = {1, 0, NULL, 0};
        dth_event ev = {dth_event_coordinate, &spec, 1, 0};
        evs e = {0, {0}};
        dth_run_config cfg;
        dth_run_config_default(&cfg);
        cfg.has_t_end = 1;
        cfg.t_end = 6 * 2 * PI + 1;
        cfg.events = &ev;
        cfg.nevents = 1;
        cfg.on_event = on_event;
        cfg.user = &e;
        dth_run_state st;
        dth_run_state_init(&st);
        CU_ASSERT_EQUAL(dth_run(it, &cfg, &st), DTH_OK);
        CU_ASSERT_EQUAL(e.n, 6);
        for (int k = 0; k < e.n && k < 6; k++) worst[s] = fmax(worst[s], fabs(e.t[k] - 2 * PI * (k + 1)));
        dth_integrator_free(it);
    }
    printf("\n  Kepler pericentre events: |t - 2 pi k| <= %.2e (h = 0.01), %.2e (h = 0.005): order %.2f\n", worst[0],
           worst[1], log2(worst[0] / worst[1]));
    CU_ASSERT(worst[0] < 1e-5); /* the method's own phase error after 6 orbits at h = 0.01 (3.2e-6) */
    CU_ASSERT(log2(worst[0] / worst[1]) >= 3.5);
    dth_model_free(m);
}

/* The error estimate (dth_options.estimate) of order 4: its shadow is Butcher's Runge-Kutta method of
 * order 6 (the classical one's error matches the method's: 8 to 50 times the true error). At T = 100 the
 * estimate is within 0.9 to 1.25 of the true error. */
static void test_estimate(void)
{
    dth_model *pm = model(&dth_model_pendulum, NULL, 0, 0), *km = model(&dth_model_kepler, NULL, 0, 0);
    const struct {
        const dth_model *m;
        double q0[2], p0[2], h;
    } ec[] = {{pm, {1}, {0}, 0.1}, {km, {0.4, 0}, {0, 2}, 0.01}, {km, {-1.6, 0}, {0, -0.5}, 0.1}};
    printf("\n");
    for (size_t c = 0; c < sizeof ec / sizeof ec[0]; c++) {
        size_t n = dth_model_dof(ec[c].m);
        dth_options o;
        dth_options_default(&o);
        o.order = 4;
        o.h = ec[c].h;
        o.estimate = 1;
        dth_integrator *it = NULL;
        CU_ASSERT_EQUAL_FATAL(dth_integrator_new(ec[c].m, &o, &it), DTH_OK);
        CU_ASSERT_EQUAL_FATAL(dth_integrator_start(it, ec[c].q0, ec[c].p0, 0), DTH_OK);
        while (dth_integrator_vertex(it)[n] < 100) CU_ASSERT_EQUAL_FATAL(dth_integrator_step(it, NULL), DTH_OK);
        const double *z = dth_integrator_vertex(it);
        double y[MAXZ], eq, ep, tq = 0;
        reference(ec[c].m, ec[c].q0, ec[c].p0, z[n], y);
        for (size_t i = 0; i < n; i++) tq += (z[i] - y[i]) * (z[i] - y[i]);
        tq = sqrt(tq);
        CU_ASSERT_EQUAL(dth_integrator_error(it, &eq, &ep), DTH_OK);
        printf("  %s h = %g: |dq| %.3e, estimated %.3e (ratio %.3f)\n", dth_model_get_type(ec[c].m)->name, ec[c].h, tq,
               eq, eq / tq);
        CU_ASSERT(eq / tq >= 0.9 && eq / tq <= 1.25);
        dth_integrator_free(it);
    }
    dth_model_free(pm);
    dth_model_free(km);
}

/* dth_run's stop rule (stop_error, step_ratio) with order 4, the default regularizer (the band) and the
 * estimate, on Kepler e = 0.9 from its pericentre to T = 10 orbits: at h = 0.003 the composite steps run
 * away (576 h, beyond order 4's bound 16^(3/2) h = 64 h) and the run stops with DTH_EACCURACY; at h = 0.01 the band carries every step (near h: the
 * band never exits) with an orbit-sized error, and the band's share arms the same stop; at h = 0.001 (steps
 * up to 626 h, band steps 82 %) the error stays near 5 % of |p| and the run ends. */
static void test_stop_rule(void)
{
    dth_model *km = model(&dth_model_kepler, NULL, 0, 0);
    dth_regularizer *reg = NULL;
    char err[256];
    CU_ASSERT_EQUAL_FATAL(dth_regularizer_new(&dth_reg_land, NULL, 0, km, NULL, &reg, err, sizeof err), DTH_OK);
    const double q0[2] = {0.1, 0}, p0[2] = {0, 4.358898943540674}, hs[3] = {0.003, 0.01, 0.001};
    const int want[3] = {DTH_EACCURACY, DTH_EACCURACY, DTH_OK};
    printf("\n");
    for (int c = 0; c < 3; c++) {
        dth_options o;
        dth_options_default(&o);
        o.order = 4;
        o.h = hs[c];
        o.estimate = 1;
        o.regularizer = reg;
        dth_integrator *it = NULL;
        CU_ASSERT_EQUAL_FATAL(dth_integrator_new(km, &o, &it), DTH_OK);
        CU_ASSERT_EQUAL_FATAL(dth_integrator_start(it, q0, p0, 0), DTH_OK);
        dth_run_config cfg;
        dth_run_config_default(&cfg);
        cfg.has_t_end = 1;
        cfg.t_end = 20 * PI;
        cfg.t0 = 0;
        dth_run_state st;
        dth_run_state_init(&st);
        int rc = dth_run(it, &cfg, &st);
        printf("  Kepler e = 0.9 from pericentre, h = %g: %s at t = %.2f, largest step %.0f h, band steps %ld of %ld, "
               "estimate |dp| %.2g of |p| %.3g\n", hs[c], dth_status_name(rc), st.t, st.lam_max / hs[c], st.regularized,
               st.k, st.err_p, st.p_max);
        CU_ASSERT_EQUAL(rc, want[c]);
        /* order 4's bound is step_ratio^(3/2) h (its step law tau^2 psi = const) */
        CU_ASSERT_DOUBLE_EQUAL(dth_run_step_limit(it, cfg.step_ratio), 64 * hs[c], 1e-12 * hs[c]);
        if (rc == DTH_EACCURACY) CU_ASSERT(st.err_p > 0.25 * st.p_max || st.err_q > 0.25 * st.q_max);
        if (c == 0) CU_ASSERT(st.lam_max > 64 * hs[c]);
        if (c == 1) CU_ASSERT(st.lam_max <= 64 * hs[c] && 2 * st.regularized > st.k);
        dth_integrator_free(it);
    }
    dth_regularizer_free(reg);
    dth_model_free(km);
}

/* dth_model_check's verdict says what the optional hdiff and third would save (issue 22 item 5): the
 * Henon-Heiles user model has neither, Kepler both. */
static void test_check_fallback(void)
{
    dth_model *hm = model(&example_henon_heiles, NULL, 0, 0), *km = model(&dth_model_kepler, NULL, 0, 0);
    double y[5] = {0.1, 0.2, 0, 0.3, 0.1};
    dth_model_check_report rep;
    CU_ASSERT_EQUAL_FATAL(dth_model_check(hm, y, &rep), DTH_OK);
    printf("\n  %s\n", rep.message);
    CU_ASSERT(rep.pass);
    CU_ASSERT(strstr(rep.message, "add hdiff, third: -8 gradients, -3 Hessians a step") != NULL);
    y[0] = 0.5;
    CU_ASSERT_EQUAL_FATAL(dth_model_check(km, y, &rep), DTH_OK);
    CU_ASSERT(rep.pass && strstr(rep.message, "add ") == NULL);
    dth_model_free(hm);
    dth_model_free(km);
}

static CU_TestInfo tests[] = {
    {"order 4 at T = 10 and 100: pendulum, Kepler (both apsides), Henon-Heiles, a 3-D ring", test_order_fixed_times},
    {"order 4 on a non-autonomous model", test_order_forced},
    {"symplectic composite tangent on every step, wp bit for bit", test_symplectic},
    {"Kepler L over 1000 orbits", test_kepler_L},
    {"vertex energy flat", test_vertex_energy_flat},
    {"checkpoint resume bit for bit (also inside a band)", test_checkpoint},
    {"reversal retraces", test_reverse},
    {"every linear-solver path", test_linsolve_paths},
    {"the plain, compensated and reversible finishes", test_finishes},
    {"psi = 0 crossings: run to the end, order 4 with a band fixed in phase space", test_crossings},
    {"options: order 6/8 refused, tables, no midpoints", test_options},
    {"events on the quintic dense output", test_events},
    {"the error estimate of order 4", test_estimate},
    {"the run's stop rule with order 4: run-away steps, a run carried by the band", test_stop_rule},
    {"dth_model_check says what hdiff and third would save", test_check_fallback},
    CU_TEST_INFO_NULL,
};

CU_SuiteInfo dth_test_suites[] = {
    {"compose", NULL, NULL, NULL, NULL, tests},
    CU_SUITE_INFO_NULL,
};
