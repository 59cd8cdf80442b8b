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
    {"parameters", test_params},
    CU_TEST_INFO_NULL,
};

CU_SuiteInfo dth_test_suites[] = {
    {.pName = "land", .pTests = tests},
    CU_SUITE_INFO_NULL,
};
