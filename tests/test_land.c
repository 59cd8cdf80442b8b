/* SPDX-License-Identifier: MIT */
/*
 * The regularizer `land` (regularize/land.c; paper, section 7; docs/regularization.md, "land"):
 * where raw DTH runs it is raw DTH bit for bit (Kepler e = 0.6, a libration); through psi = 0 it is
 * second order at fixed times against the exact solutions (the rotating pendulum's elliptic
 * functions, Kepler's equation), with one replaced step per crossing, energy-exact midpoints and
 * Kepler's angular momentum kept; its clock correction moves t only, and only once the run has
 * crossed; its parameters are checked.
 */
#include <math.h>
#include <stdio.h>
#include <string.h>
#include "cu_main.h"
#include "dth/dth.h"

typedef struct end_point {
    double z[8];
} end_point;

static int on_sample(void *user, const dth_sample *s)
{
    if (s->kind == DTH_SAMPLE_END) memcpy(((end_point *)user)->z, s->z, sizeof ((end_point *)user)->z);
    return 0;
}

static dth_model *make(const dth_model_type *t, size_t n)
{
    dth_model *m = NULL;
    CU_ASSERT_FATAL(dth_model_new(t, NULL, 0, n, NULL, &m, NULL, 0) == DTH_OK);
    return m;
}

static dth_regularizer *reg(const dth_model *m, const dth_regularizer_type *t, const char *key, const char *val)
{
    dth_regularizer *r = NULL;
    dth_kv kv = {key, val};
    CU_ASSERT_FATAL(dth_regularizer_new(t, &kv, key ? 1 : 0, m, NULL, &r, NULL, 0) == DTH_OK);
    return r;
}

/* A midpoint-start run to T with the regularizer (NULL: none): its position error at T against the
 * model's exact solution, and the steps it replaced. */
static double run_error(const dth_model *m, const dth_regularizer_type *rt, const double *q0, const double *p0,
                        double h, double T, long *replaced, long *crossings)
{
    dth_options o;
    dth_options_default(&o);
    o.h = h;
    dth_regularizer *rg = rt ? reg(m, rt, NULL, NULL) : NULL;
    o.regularizer = rg;
    dth_integrator *it = NULL;
    CU_ASSERT_FATAL(dth_integrator_new(m, &o, &it) == DTH_OK);
    CU_ASSERT_FATAL(dth_integrator_start(it, q0, p0, 0) == DTH_OK);
    dth_run_config c;
    dth_run_config_default(&c);
    c.has_t_end = 1;
    c.t_end = T;
    c.t0 = 0;
    end_point e;
    c.sample = on_sample;
    c.user = &e;
    dth_run_state st;
    dth_run_state_init(&st);
    int rc = dth_run(it, &c, &st);
    CU_ASSERT(rc == DTH_OK);
    *replaced = st.regularized;
    *crossings = st.crossings;
    size_t n = dth_model_dof(m);
    double y0[8] = {0}, ye[8], err = 0;
    memcpy(y0, q0, n * sizeof *y0);
    memcpy(y0 + n + 1, p0, n * sizeof *y0);
    CU_ASSERT_FATAL(dth_model_exact(m, y0, T, ye) == DTH_OK);
    for (size_t i = 0; i < n; i++) err = fmax(err, fabs(e.z[i] - ye[i]));
    dth_integrator_free(it);
    dth_regularizer_free(rg);
    return rc ? NAN : err;
}

/* Orders at T between successive h = 0.05 / 2^k, k = 0..3; each must reach `min`. */
static void orders(const char *name, const dth_model *m, const double *q0, const double *p0, double T, double min,
                   long want_replaced)
{
    double prev = NAN;
    for (int k = 0; k < 4; k++) {
        double h = 0.05 / (1 << k);
        long rep = 0, cr = 0;
        double err = run_error(m, &dth_reg_land, q0, p0, h, T, &rep, &cr);
        double ord = k ? log2(prev / err) : NAN;
        printf("  [%s T = %g h = %g: error %.4e order %.3f, %ld replaced, %ld crossings]\n", name, T, h, err, ord, rep,
               cr);
        if (k) CU_ASSERT(ord >= min);
        CU_ASSERT(rep == want_replaced);
        CU_ASSERT(cr == rep); /* one replaced step per crossing, none elsewhere */
        prev = err;
    }
}

/* Issue 23's figure: the rotating pendulum through psi = 0 at second order (measured 2.10, 1.96, 1.95 at
 * T = 10 and 2.03, 2.00, 1.97 at T = 100; without the clock 1.11 at T = 100). */
static void test_pendulum_order(void)
{
    dth_model *m = make(&dth_model_pendulum, 1);
    double q0 = 0, p0 = 2.2;
    orders("pendulum p0 = 2.2", m, &q0, &p0, 10, 1.85, 5);
    orders("pendulum p0 = 2.2", m, &q0, &p0, 100, 1.85, 47);
    dth_model_free(m);
}

/* Kepler e = 0.9 from the apocentre: measured 1.79, 2.00, 1.91 (T = 10) and 1.82, 1.88, 1.93 (T = 100). The
 * shortfall from 2 is the transverse part of the crossings' local error (a precession), which a clock
 * correction cannot remove (docs/regularization.md): asserted at 1.75. */
static void test_kepler_order(void)
{
    dth_model *m = make(&dth_model_kepler, 2);
    double e = 0.9, q0[2] = {-(1 + e), 0}, p0[2] = {0, -sqrt((1 - e) / (1 + e))};
    orders("Kepler e = 0.9", m, q0, p0, 10, 1.75, 7);
    orders("Kepler e = 0.9", m, q0, p0, 100, 1.75, 64);
    dth_model_free(m);
}

/* Steps of two integrators side by side: every vertex equal bit for bit (t too if with_t), no flag. */
static void same_steps(const dth_model *m, const dth_regularizer_type *a, const double *q0, const double *p0, double h,
                       long steps)
{
    dth_integrator *it[2] = {NULL, NULL};
    dth_regularizer *rg[2] = {NULL, NULL};
    for (int g = 0; g < 2; g++) {
        dth_options o;
        dth_options_default(&o);
        o.h = h;
        rg[g] = reg(m, g ? a : &dth_reg_none, NULL, NULL);
        o.regularizer = rg[g];
        CU_ASSERT_FATAL(dth_integrator_new(m, &o, &it[g]) == DTH_OK);
        CU_ASSERT_FATAL(dth_integrator_start(it[g], q0, p0, 0) == DTH_OK);
    }
    size_t N = 2 * dth_model_dof(m) + 2;
    long diff = 0, flagged = 0;
    for (long k = 0; k < steps; k++) {
        dth_step_info in[2];
        for (int g = 0; g < 2; g++) CU_ASSERT_FATAL(dth_integrator_step(it[g], &in[g]) == DTH_OK);
        diff += memcmp(dth_integrator_vertex(it[0]), dth_integrator_vertex(it[1]), N * sizeof(double)) != 0;
        flagged += in[1].flags != 0;
    }
    CU_ASSERT(diff == 0);
    CU_ASSERT(flagged == 0);
    for (int g = 0; g < 2; g++) {
        dth_integrator_free(it[g]);
        dth_regularizer_free(rg[g]);
    }
}

/* Where raw DTH runs, land is raw DTH bit for bit: scenes/kepler-e06.ini's orbit (psi > 0 all along) at
 * h = 0.05 and 0.025 (the old default replaced 30 of 50 and 27 of 99 steps there), and librations. */
static void test_raw_where_raw_runs(void)
{
    dth_model *k = make(&dth_model_kepler, 2), *p = make(&dth_model_pendulum, 1);
    double kq[2] = {0.4, 0}, kp[2] = {0, 2};
    same_steps(k, &dth_reg_land, kq, kp, 0.05, 1000);
    same_steps(k, &dth_reg_land, kq, kp, 0.025, 2000);
    double q0 = 0, p0 = 1, q1 = 1, p1 = 0;
    same_steps(p, &dth_reg_land, &q0, &p0, 0.05, 2000);
    same_steps(p, &dth_reg_land, &q1, &p1, 1e-4, 20000);
    dth_model_free(k);
    dth_model_free(p);
}

/*
 * The replaced steps: energy at the midpoint to round-off, Kepler's angular momentum kept through
 * them; the clock moves t only (q, p, wp equal bit for bit with clock = no), not before the first
 * crossing, and flags the steps it moved.
 */
static void test_replaced_and_clock(void)
{
    dth_model *m = make(&dth_model_kepler, 2);
    double e = 0.9, q0[2] = {-(1 + e), 0}, p0[2] = {0, -sqrt((1 - e) / (1 + e))};
    dth_integrator *it[2] = {NULL, NULL};
    dth_regularizer *rg[2] = {NULL, NULL};
    for (int g = 0; g < 2; g++) {
        dth_options o;
        dth_options_default(&o);
        o.h = 0.02;
        rg[g] = reg(m, &dth_reg_land, "clock", g ? "no" : "yes");
        o.regularizer = rg[g];
        CU_ASSERT_FATAL(dth_integrator_new(m, &o, &it[g]) == DTH_OK);
        CU_ASSERT_FATAL(dth_integrator_start(it[g], q0, p0, 0) == DTH_OK);
    }
    const double *z0 = dth_integrator_vertex(it[0]);
    double L0 = z0[0] * z0[4] - z0[1] * z0[3], dL = 0, maxres = 0;
    long replaced = 0, clocked = 0, qp_diff = 0, t_early = 0, t_late = 0, bad_flags = 0;
    for (long k = 0; k < 2000; k++) {
        dth_step_info in[2];
        for (int g = 0; g < 2; g++) CU_ASSERT_FATAL(dth_integrator_step(it[g], &in[g]) == DTH_OK);
        const double *a = dth_integrator_vertex(it[0]), *b = dth_integrator_vertex(it[1]);
        qp_diff += memcmp(a, b, 2 * sizeof *a) != 0 || memcmp(a + 3, b + 3, 3 * sizeof *a) != 0;
        if (in[0].flags & DTH_STEP_REGULARIZED) {
            replaced++;
            maxres = fmax(maxres, in[0].residual);
            bad_flags += !(in[0].flags & DTH_STEP_RESET) || !(in[0].flags & DTH_STEP_CROSSING);
        }
        if (in[0].flags & DTH_STEP_CLOCK) clocked++;
        if (!replaced) t_early += a[2] != b[2];
        else t_late += a[2] != b[2];
        bad_flags += (in[1].flags & DTH_STEP_CLOCK) != 0;
        dL = fmax(dL, fabs(a[0] * a[4] - a[1] * a[3] - L0));
    }
    printf("  [Kepler e = 0.9, h = 0.02: %ld replaced, %ld clock-corrected, max |H(zbar)| %.2e, max |dL| %.2e]\n",
           replaced, clocked, maxres, dL);
    CU_ASSERT(replaced >= 4);
    CU_ASSERT(maxres <= 1e-13);
    CU_ASSERT(dL <= 1e-13);
    CU_ASSERT(qp_diff == 0);
    CU_ASSERT(t_early == 0);
    CU_ASSERT(t_late > 0);
    CU_ASSERT(clocked > replaced);
    CU_ASSERT(bad_flags == 0);
    for (int g = 0; g < 2; g++) {
        dth_integrator_free(it[g]);
        dth_regularizer_free(rg[g]);
    }
    dth_model_free(m);
}

/* ---------------------------------------------------------------- robustness (issue 23, the refusals) */

/* Two coupled rotating pendula, H = (p1^2 + p2^2)/2 - cos q1 - cos q2 - eps cos(q1 - q2), eps = 0.1 (the model of
 * bench_symplectic's section B), with its third derivative. */
static int rot_eval(const void *self, const double *y, unsigned what, double *H, double *g, double *h)
{
    (void)self;
    const double eps = 0.1, q1 = y[0], q2 = y[1], p1 = y[3], p2 = y[4], d = q1 - q2;
    if (what & DTH_EVAL_H) *H = 0.5 * (p1 * p1 + p2 * p2) - cos(q1) - cos(q2) - eps * cos(d);
    if (what & DTH_EVAL_GRAD) {
        memset(g, 0, 5 * sizeof *g);
        g[0] = sin(q1) + eps * sin(d);
        g[1] = sin(q2) - eps * sin(d);
        g[3] = p1;
        g[4] = p2;
    }
    if (what & DTH_EVAL_HESS) {
        double c = eps * cos(d);
        memset(h, 0, 25 * sizeof *h);
        h[0] = cos(q1) + c;
        h[6] = cos(q2) + c;
        h[1] = h[5] = -c;
        h[18] = h[24] = 1;
    }
    return 0;
}

static int rot_third(const void *self, const double *y, const double *u, double *d3)
{
    (void)self;
    double du = u[0] - u[1];
    *d3 = -sin(y[0]) * u[0] * u[0] * u[0] - sin(y[1]) * u[1] * u[1] * u[1] - 0.1 * sin(y[0] - y[1]) * du * du * du;
    return 0;
}

static int rot_create(const dth_model_args *a, void **self, dth_model_info *info)
{
    (void)a;
    *self = NULL;
    *info = (dth_model_info){.n = 2, .autonomous = 1, .separable = 1, .hess_kind = DTH_HESS_DENSE};
    return DTH_OK;
}

static const dth_model_type rotors_type = {
    DTH_MODEL_TYPE_HEAD,
    .name = "rotors",
    .doc = "two coupled rotating pendula (test)",
    .create = rot_create,
    .eval = rot_eval,
    .third = rot_third,
};

/* A land run with steps from the start (q0, p0; the midpoint start, or a vertex start) to T or the first
 * failure: its status, end vertex (N <= 16), steps, replaced steps and crossings, the largest |H(zbar)| of
 * its midpoints against the energy and the largest change of the model's invariant `inv` (-1: none) at
 * its vertices. */
typedef struct land_run {
    int rc;
    char why[512];
    double z[16], t, hmax, inv_drift;
    long steps, replaced, crossings;
} land_run;

static land_run run_land(const dth_model *m, const double *q0, const double *p0, double h, double T, int vertex_start,
                         int inv)
{
    land_run o;
    memset(&o, 0, sizeof o);
    dth_options op;
    dth_options_default(&op);
    op.h = h;
    op.start = vertex_start ? DTH_START_VERTEX : DTH_START_MIDPOINT;
    dth_regularizer *rg = reg(m, &dth_reg_land, NULL, NULL);
    op.regularizer = rg;
    dth_integrator *it = NULL;
    CU_ASSERT_FATAL(dth_integrator_new(m, &op, &it) == DTH_OK);
    CU_ASSERT_FATAL(dth_integrator_start(it, q0, p0, 0) == DTH_OK);
    size_t n = dth_model_dof(m), N = 2 * n + 2;
    double I0[8] = {0}, I[8];
    if (inv >= 0) CU_ASSERT_FATAL(dth_model_invariants(m, dth_integrator_vertex(it), I0) == DTH_OK);
    while (dth_integrator_vertex(it)[n] < T) {
        dth_step_info in;
        o.rc = dth_integrator_step(it, &in);
        if (o.rc) {
            snprintf(o.why, sizeof o.why, "%s", dth_integrator_errmsg(it));
            break;
        }
        o.steps++;
        o.replaced += (in.flags & DTH_STEP_REGULARIZED) != 0;
        o.crossings += (in.flags & DTH_STEP_CROSSING) != 0;
        const double *zb = dth_integrator_midpoint(it), *z = dth_integrator_vertex(it);
        double H;
        CU_ASSERT_FATAL(dth_model_eval(m, zb, DTH_EVAL_H, &H, NULL, NULL) == DTH_OK);
        o.hmax = fmax(o.hmax, fabs(H + zb[N - 1]));
        if (inv >= 0) {
            CU_ASSERT_FATAL(dth_model_invariants(m, z, I) == DTH_OK);
            o.inv_drift = fmax(o.inv_drift, fabs(I[inv] - I0[inv]));
        }
    }
    memcpy(o.z, dth_integrator_vertex(it), N * sizeof *o.z);
    o.t = o.z[n];
    dth_integrator_free(it);
    dth_regularizer_free(rg);
    return o;
}

/*
 * Kepler e = 0.9 at steps far too large for its pericentre (h = 0.5, 1: the pericentre's time scale is 0.02).
 * Before, land stopped at h = 1 (t = 2.96: "the offset reset onto the run's step invariant did not
 * converge": the fallback segment's end could reach the level set only by crossing psi = 0 first, where the
 * own-side target jumps). Now both run to t = 100 through every crossing (64), with energy-exact midpoints
 * and L kept at the vertices; h = 2 resolves nothing at the pericentre and stops, naming a smaller h, not a
 * reset that failed to converge.
 */
static void test_kepler_coarse(void)
{
    dth_model *m = make(&dth_model_kepler, 2);
    double e = 0.9, q0[2] = {-(1 + e), 0}, p0[2] = {0, -sqrt((1 - e) / (1 + e))};
    const double hs[] = {0.5, 1};
    for (int i = 0; i < 2; i++) {
        land_run o = run_land(m, q0, p0, hs[i], 100, 0, 0);
        printf("  [Kepler e = 0.9, h = %g: %s at t = %.4g, %ld steps, %ld replaced, %ld crossings, max |H(zbar)| %.1e, "
               "max |dL| %.1e%s%s]\n", hs[i], dth_status_name(o.rc), o.t, o.steps, o.replaced, o.crossings, o.hmax,
               o.inv_drift, o.rc ? ": " : "", o.why);
        CU_ASSERT(o.rc == DTH_OK);
        CU_ASSERT(o.t >= 100);
        CU_ASSERT(o.crossings == 64);
        CU_ASSERT(o.hmax <= 1e-13);
        CU_ASSERT(o.inv_drift <= 1e-12);
    }
    land_run o = run_land(m, q0, p0, 2, 100, 0, 0);
    printf("  [Kepler e = 0.9, h = 2: %s at t = %.4g: %s]\n", dth_status_name(o.rc), o.t, o.why);
    if (o.rc) {
        CU_ASSERT(o.rc == DTH_EREFUSED);
        CU_ASSERT(strstr(o.why, "a smaller h") != NULL);
        CU_ASSERT(strstr(o.why, "did not converge") == NULL);
    }
    dth_model_free(m);
}

/*
 * The long runs bench_symplectic had refused: the coupled rotors (step 56599, t = 3771) and the compressed 2-D
 * chain of three masses (step 36409, t = 727.8). Their cause was the size of the state, not the time: psi's
 * gradient, which closes the landing segment and moves the reset, took a difference step proportional to
 * max |y| (angles after many turns, a chain drifting with its momentum), too coarse there. The same runs
 * started where the rotors have turned 10^4 times (q + 2 pi 10^4) or the chain has drifted (x + 1000) were
 * refused at once (t = 0.48 and t = 2.46); now they take the steps of the untranslated runs, and the rotors run
 * past t = 3771 from the bench's start.
 */
static void test_long_runs(void)
{
    dth_model *m = NULL;
    CU_ASSERT_FATAL(dth_model_new(&rotors_type, NULL, 0, 2, NULL, &m, NULL, 0) == DTH_OK);
    const double tw = 2 * 3.14159265358979323846 * 1e4;
    double q0[2] = {0, 0}, qs[2] = {tw, tw}, p0[2] = {2.5, 4.05};
    land_run a = run_land(m, q0, p0, 0.05, 300, 0, -1), b = run_land(m, qs, p0, 0.05, 300, 0, -1);
    double dq = 0;
    for (int i = 0; i < 2; i++) dq = fmax(dq, fmax(fabs(b.z[i] - tw - a.z[i]), fabs(b.z[3 + i] - a.z[3 + i])));
    printf("  [rotors to t = 300: %ld steps, %ld replaced, %ld crossings; turned 10^4 times: %s, %ld steps, %ld "
           "replaced, end %.1e apart%s%s]\n", a.steps, a.replaced, a.crossings, dth_status_name(b.rc), b.steps, b.replaced,
           dq, b.rc ? ": " : "", b.why);
    CU_ASSERT(a.rc == DTH_OK && b.rc == DTH_OK);
    CU_ASSERT(a.crossings > 300 && a.replaced == a.crossings);
    CU_ASSERT(b.steps == a.steps && b.replaced == a.replaced && b.crossings == a.crossings);
    CU_ASSERT(dq <= 1e-6);
    land_run c = run_land(m, q0, p0, 0.05, 3800, 0, -1);
    printf("  [rotors to t = 3800: %s at t = %.6g, %ld steps, %ld replaced, %ld crossings, max |H(zbar)| %.1e%s%s]\n",
           dth_status_name(c.rc), c.t, c.steps, c.replaced, c.crossings, c.hmax, c.rc ? ": " : "", c.why);
    CU_ASSERT(c.rc == DTH_OK && c.t >= 3800);
    CU_ASSERT(c.replaced == c.crossings);
    CU_ASSERT(c.hmax <= 1e-11); /* H of 10 with terms cos q at q ~ 10^4: their round-off */
    dth_model_free(m);

    dth_kv kv[] = {{"preset", "chain"}, {"size", "3"}, {"dim", "2"}, {"L", "1"}};
    CU_ASSERT_FATAL(dth_model_new(&dth_model_coupled, kv, 4, 6, NULL, &m, NULL, 0) == DTH_OK);
    double x0[6] = {0, 0, 0.5, 0, 1, 0}, xs[6] = {1000, 0, 1000.5, 0, 1001, 0}, v0[6] = {0, 1, 0, -2, 0, 1.5};
    land_run d = run_land(m, x0, v0, 0.02, 100, 0, 2), f = run_land(m, xs, v0, 0.02, 100, 0, 2);
    printf("  [2-D chain to t = 100: %ld steps, %ld replaced, %ld crossings; moved by x + 1000: %s at t = %.4g, %ld steps, "
           "%ld replaced, max |H(zbar)| %.1e, max |dLz| %.1e%s%s]\n", d.steps, d.replaced, d.crossings,
           dth_status_name(f.rc), f.t, f.steps, f.replaced, f.hmax, f.inv_drift, f.rc ? ": " : "", f.why);
    CU_ASSERT(d.rc == DTH_OK && f.rc == DTH_OK);
    CU_ASSERT(f.t >= 100);
    CU_ASSERT(d.crossings > 50 && f.crossings > 50);
    CU_ASSERT(f.hmax <= 1e-12 && d.hmax <= 1e-12);
    CU_ASSERT(f.inv_drift <= 1e-9 && d.inv_drift <= 1e-11);
    dth_model_free(m);
}

/*
 * A fold at the very first step: raw DTH's rotating pendulum stops at vertex 16 (the fold); an integrator put
 * on that vertex (dth_integrator_set_vertex) with land, or a vertex start next to psi = 0, was refused ("a
 * crossing at the first step"). Now the first step is a replaced one that crosses, with the step constant of
 * the vertex's own step invariant, and the run goes on with one replaced step per crossing.
 */
static void test_first_step_fold(void)
{
    dth_model *m = make(&dth_model_pendulum, 1);
    dth_options o;
    dth_options_default(&o);
    o.h = 0.05;
    dth_regularizer *rn = reg(m, &dth_reg_none, NULL, NULL), *rl = reg(m, &dth_reg_land, NULL, NULL);
    o.regularizer = rn;
    dth_integrator *a = NULL, *b = NULL;
    double q0 = 0, p0 = 2.2;
    CU_ASSERT_FATAL(dth_integrator_new(m, &o, &a) == DTH_OK);
    CU_ASSERT_FATAL(dth_integrator_start(a, &q0, &p0, 0) == DTH_OK);
    dth_step_info in;
    int rc = DTH_OK;
    long k;
    for (k = 0; k < 100 && !(rc = dth_integrator_step(a, &in)); k++) {
    }
    CU_ASSERT(rc == DTH_EFOLD);
    CU_ASSERT(k == 16);
    double z[4];
    memcpy(z, dth_integrator_vertex(a), sizeof z);
    o.regularizer = rl;
    CU_ASSERT_FATAL(dth_integrator_new(m, &o, &b) == DTH_OK);
    CU_ASSERT_FATAL(dth_integrator_start(b, &q0, &p0, 0) == DTH_OK);
    CU_ASSERT_FATAL(dth_integrator_set_vertex(b, z, 0.05) == DTH_OK);
    rc = dth_integrator_step(b, &in);
    printf("  [set_vertex at raw DTH's fold (k = 16, t = %.4f): first step %s, flags %u%s%s]\n", z[1], dth_status_name(rc),
           in.flags, rc ? ": " : "", rc ? dth_integrator_errmsg(b) : "");
    CU_ASSERT(rc == DTH_OK);
    CU_ASSERT((in.flags & DTH_STEP_REGULARIZED) && (in.flags & DTH_STEP_CROSSING));
    long replaced = 1, crossings = 1;
    while (!rc && dth_integrator_vertex(b)[1] < 20) {
        rc = dth_integrator_step(b, &in);
        replaced += (in.flags & DTH_STEP_REGULARIZED) != 0;
        crossings += (in.flags & DTH_STEP_CROSSING) != 0;
    }
    /* the exact solution from the start (q0, p0) at the run's end time, the same orbit to O(h^2) */
    const double *ze = dth_integrator_vertex(b);
    double y0[3] = {q0, 0, p0}, ye[3];
    CU_ASSERT_FATAL(dth_model_exact(m, y0, ze[1], ye) == DTH_OK);
    printf("  [... to t = %.4f: %s, %ld replaced, %ld crossings, |dq| %.2e]\n", ze[1], dth_status_name(rc), replaced,
           crossings, fabs(ze[0] - ye[0]));
    CU_ASSERT(rc == DTH_OK);
    CU_ASSERT(replaced == crossings && crossings == 10);
    CU_ASSERT(fabs(ze[0] - ye[0]) <= 0.02);
    dth_integrator_free(a);
    dth_integrator_free(b);
    dth_regularizer_free(rn);
    dth_regularizer_free(rl);
    /* a vertex start next to psi = 0 (q = 1.95, p = 1.5: the first step folds) */
    double q1 = 1.95, p1 = 1.5;
    land_run v = run_land(m, &q1, &p1, 0.05, 20, 1, -1);
    printf("  [vertex start at q = 1.95, p = 1.5: %s at t = %.4g, %ld steps, %ld replaced, %ld crossings%s%s]\n",
           dth_status_name(v.rc), v.t, v.steps, v.replaced, v.crossings, v.rc ? ": " : "", v.why);
    CU_ASSERT(v.rc == DTH_OK && v.t >= 20);
    CU_ASSERT(v.replaced == v.crossings && v.crossings == 10);
    CU_ASSERT(v.hmax <= 1e-13);
    dth_model_free(m);
}

static void test_params(void)
{
    dth_model *m = make(&dth_model_pendulum, 1);
    const char *bad[][2] = {{"kappa", "0"}, {"kappa", "nan"}, {"bound", "1"}, {"clock", "maybe"},
                            {"invariant", "-1"}, {"invariant", "0"}};
    for (size_t i = 0; i < sizeof bad / sizeof bad[0]; i++) {
        dth_regularizer *r = NULL;
        dth_kv kv = {bad[i][0], bad[i][1]};
        char err[256] = "";
        CU_ASSERT(dth_regularizer_new(&dth_reg_land, &kv, 1, m, NULL, &r, err, sizeof err) == DTH_EINVAL);
        CU_ASSERT(strstr(err, bad[i][0]) != NULL);
        CU_ASSERT(r == NULL);
    }
    dth_model_free(m);
}

static CU_TestInfo tests[] = {
    {"raw DTH bit for bit where it runs", test_raw_where_raw_runs},
    {"pendulum through psi = 0: order >= 1.85", test_pendulum_order},
    {"Kepler e = 0.9: order >= 1.75", test_kepler_order},
    {"replaced steps and the clock", test_replaced_and_clock},
    {"Kepler e = 0.9 at h = 0.5, 1 (and 2)", test_kepler_coarse},
    {"long runs: rotors, 2-D chain, translated", test_long_runs},
    {"a fold at the first step", test_first_step_fold},
    {"parameters", test_params},
    CU_TEST_INFO_NULL,
};

CU_SuiteInfo dth_test_suites[] = {
    {.pName = "land", .pTests = tests},
    CU_SUITE_INFO_NULL,
};
