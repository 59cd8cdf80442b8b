/* SPDX-License-Identifier: MIT */
/*
 * Step control by the run's constant (control.h; issue 26 item 1): integrator.h_max and integrator.tol.
 * The orbit, Kepler e = 0.9 from its pericentre (q = 0.1, 0; p = 0, sqrt(19)), midpoint start,
 * the default regularizer land, 10 orbits:
 *  - h_max = 0.01: every step <= 0.0105, the run ends (DTH_OK), final position error <= 1e-2 against
 *    Kepler's equation (dth_model_exact), L at the vertices constant to 1e-13 relative, the energy at
 *    every midpoint to 1e-13 relative. (With h = 0.01 itself the steps reach 96 h.)
 *  - tol = 1e-4: the true final position error within a factor 10 of 1e-4, with the pilot over the
 *    whole run and with a pilot over the first orbit (extrapolated, and said so).
 * A calibration that saw too little (a pilot shorter than the first excursion) leaves the run to its
 * guard: DTH_ESTEPSIZE after the first step above 1.05 h_max. The law l(z; C), argument checks, and a
 * calibration leaves the caller's regularizer and report as they were.
 */
#include <math.h>
#include <stdio.h>
#include <string.h>
#include "cu_main.h"
#include "dth/dth.h"
#include "dth_internal.h"

#define TWO_PI 6.283185307179586
static const double Q0[2] = {0.1, 0}, P0[2] = {0, 4.358898943540674}, T10 = 10 * TWO_PI;

static dth_model *kepler(void)
{
    dth_model *m = NULL;
    CU_ASSERT_FATAL(dth_model_new(&dth_model_kepler, NULL, 0, 0, NULL, &m, NULL, 0) == DTH_OK);
    return m;
}

static void law_check(double C, double psi, double dpsi)
{
    double l = dth_control_law(C, psi, dpsi);
    double c = pow(l, 6) * sqrt(pow(psi, 4) + pow(dpsi * l, 4));
    CU_ASSERT(fabs(c / C - 1) < 1e-12);
}

static void test_law(void)
{
    law_check(1e-12, 3, 0);
    law_check(1e-12, 0, -2);
    law_check(1e-12, 1e-3, 5);
    law_check(2.5e-40, -7e4, 1e6);
    law_check(1e30, 0.5, 0.1);
    CU_ASSERT(fabs(dth_control_law(64, 1, 0) - 2) < 1e-15);           /* (C / psi^2)^(1/6) */
    CU_ASSERT(fabs(dth_control_law(256, 0, 1) - 2) < 1e-15);          /* (C / psi'^2)^(1/8) */
    CU_ASSERT(isinf(dth_control_law(1, 0, 0)));
    CU_ASSERT(isnan(dth_control_law(0, 1, 1)));
    CU_ASSERT(isnan(dth_control_law(1, NAN, 1)));
}

/* What a run saw: every step, the energy at every midpoint, L at every vertex, the end. */
typedef struct watch {
    const dth_model *m;
    double E0, L0, dE, dL, lam_max;
    long steps;
    int have_L;
} watch;

static double ang(const double *z) { return z[0] * z[4] - z[1] * z[3]; }

static int on_mid(void *user, const dth_sample *s)
{
    watch *w = user;
    double H;
    if (s->kind != DTH_SAMPLE_MIDPOINT) return 0;
    CU_ASSERT_FATAL(dth_model_eval(w->m, s->z, DTH_EVAL_H, &H, NULL, NULL) == DTH_OK);
    w->dE = fmax(w->dE, fabs(H - w->E0));
    if (!w->have_L) {
        w->L0 = ang(s->za);
        w->have_L = 1;
    }
    w->dL = fmax(w->dL, fmax(fabs(ang(s->za) - w->L0), fabs(ang(s->zb) - w->L0)));
    w->lam_max = fmax(w->lam_max, fabs(s->step->lambda));
    w->steps++;
    return 0;
}

/* The calibrated run: midpoint rows, the guard of the report, to T; the position at T by dense output
 * on the last step, its error against Kepler's equation into *err. */
static int run(const dth_model *m, const dth_options *o0, const dth_control_report *r, double T, watch *w,
               double *err, dth_run_state *st)
{
    dth_options o = *o0;
    o.h = r->h0;
    dth_integrator *it = NULL;
    CU_ASSERT_FATAL(dth_integrator_new(m, &o, &it) == DTH_OK);
    CU_ASSERT_FATAL(dth_integrator_start(it, Q0, P0, 0) == DTH_OK);
    double y0[6] = {Q0[0], Q0[1], 0, P0[0], P0[1], 0}, H;
    CU_ASSERT_FATAL(dth_model_eval(m, y0, DTH_EVAL_H, &H, NULL, NULL) == DTH_OK);
    memset(w, 0, sizeof *w);
    w->m = m;
    w->E0 = H;
    dth_run_config c;
    dth_run_config_default(&c);
    c.has_t_end = 1;
    c.t_end = T;
    c.t0 = 0;
    c.points = DTH_POINTS_MIDPOINTS;
    c.sample = on_mid;
    c.user = w;
    c.step_max = r->step_max;
    dth_run_state_init(st);
    int rc = dth_run(it, &c, st);
    /* the end: dense output at T on the last step (z_(k-1) = 2 zbar - z_k) */
    const double *zb = dth_integrator_vertex(it), *zm = dth_integrator_midpoint(it);
    double za[6], ua[6], ub[6], wk[5], z[6], ex[6];
    for (int j = 0; j < 6; j++) za[j] = 2 * zm[j] - zb[j];
    CU_ASSERT_FATAL(dth_flow(m, za, ua, wk) == DTH_OK && dth_flow(m, zb, ub, wk) == DTH_OK);
    dth_dense_eval(2, za, zb, zm, ua, ub, fmin(T, zb[2]), z);
    CU_ASSERT_FATAL(dth_model_exact(m, y0, z[2], ex) == DTH_OK);
    *err = hypot(z[0] - ex[0], z[1] - ex[1]);
    dth_integrator_free(it);
    return rc;
}

static void options(const dth_model *m, dth_options *o, dth_regularizer **rg)
{
    dth_options_default(o);
    o->h = 0.01;
    o->estimate = 1;
    CU_ASSERT_FATAL(dth_regularizer_new(&dth_reg_land, NULL, 0, m, NULL, rg, NULL, 0) == DTH_OK);
    o->regularizer = *rg;
}

static void report(const char *what, const dth_control_report *r, const watch *w, double err)
{
    printf("\n    %s: h0 %.6g, C %.4g, %d passes (%d restarts), %ld pilot steps to t = %.4g%s; run: %ld steps, "
           "largest %.5g, error %.3g, dE %.2g, dL %.2g", what, r->h0, r->C, r->passes, r->hmax_restarts, r->steps,
           r->t_pilot, r->extrapolated ? " (extrapolated)" : "", w->steps, w->lam_max, err, w->dE / fabs(w->E0),
           w->dL / fabs(w->L0));
}

/* The done-when for h_max. */
static void test_hmax(void)
{
    dth_model *m = kepler();
    dth_regularizer *rg;
    dth_options o;
    options(m, &o, &rg);
    dth_control ctl;
    dth_control_default(&ctl);
    ctl.h_max = 0.01;
    dth_control_report r = {.size = sizeof r};
    char err[256];
    int rc = dth_control_calibrate(m, &o, Q0, P0, 0, T10, &ctl, &r, err, sizeof err);
    CU_ASSERT_FATAL(rc == DTH_OK);
    CU_ASSERT(r.hmax_settled == 1);
    CU_ASSERT(r.step_max == 1.05 * 0.01);
    CU_ASSERT(r.h0 > 0 && r.h0 < 0.01);
    watch w;
    dth_run_state st;
    double e;
    rc = run(m, &o, &r, T10, &w, &e, &st);
    report("h_max = 0.01", &r, &w, e);
    CU_ASSERT(rc == DTH_OK);
    CU_ASSERT(st.stop == DTH_RUN_END);
    CU_ASSERT(w.lam_max <= 0.0105);
    CU_ASSERT(st.lam_max <= 0.0105);
    CU_ASSERT(e <= 1e-2);
    CU_ASSERT(w.dL <= 1e-13 * fabs(w.L0));
    CU_ASSERT(w.dE <= 1e-13 * fabs(w.E0));
    CU_ASSERT(st.crossings > 0); /* the bound binds in the psi = 0 bands, which land carries */
    dth_regularizer_free(rg);
    dth_model_free(m);
}

/* The done-when for tol, with the pilot over the run and over its first orbit. */
static void test_tol(void)
{
    dth_model *m = kepler();
    for (int k = 0; k < 2; k++) {
        /* a fresh regularizer for each run: land keeps the C it took from a run's first steps */
        dth_regularizer *rg;
        dth_options o;
        options(m, &o, &rg);
        dth_control ctl;
        dth_control_default(&ctl);
        ctl.tol = 1e-4;
        if (k) ctl.pilot = TWO_PI;
        dth_control_report r = {.size = sizeof r};
        char err[256];
        CU_ASSERT_FATAL(dth_control_calibrate(m, &o, Q0, P0, 0, T10, &ctl, &r, err, sizeof err) == DTH_OK);
        CU_ASSERT(r.extrapolated == k);
        CU_ASSERT(r.step_max == 0);
        CU_ASSERT(r.est >= 1e-4 && r.est <= 64e-4);
        watch w;
        dth_run_state st;
        double e;
        int rc = run(m, &o, &r, T10, &w, &e, &st);
        report(k ? "tol = 1e-4, pilot one orbit" : "tol = 1e-4", &r, &w, e);
        printf(" (predicted %.3g, the run's estimate %.3g)", r.est_pred, st.err_q);
        CU_ASSERT(rc == DTH_OK);
        CU_ASSERT(e >= 1e-5 && e <= 1e-3);
        CU_ASSERT(w.dE <= 1e-13 * fabs(w.E0));
        dth_regularizer_free(rg);
    }
    dth_model_free(m);
}

/* A pilot that ends before the first excursion sees nothing to bind: the run's guard stops it after its
 * first step above 1.05 h_max, with that step in the state. */
static void test_guard(void)
{
    dth_model *m = kepler();
    dth_regularizer *rg;
    dth_options o;
    options(m, &o, &rg);
    dth_control ctl;
    dth_control_default(&ctl);
    ctl.h_max = 0.01;
    ctl.pilot = 0.005;
    dth_control_report r = {.size = sizeof r};
    CU_ASSERT_FATAL(dth_control_calibrate(m, &o, Q0, P0, 0, T10, &ctl, &r, NULL, 0) == DTH_OK);
    CU_ASSERT(r.hmax_settled == 1 && r.hmax_restarts == 0 && r.h0 == 0.01);
    watch w;
    dth_run_state st;
    double e;
    int rc = run(m, &o, &r, T10, &w, &e, &st);
    CU_ASSERT(rc == DTH_ESTEPSIZE);
    CU_ASSERT(st.stop == DTH_RUN_FAILED);
    CU_ASSERT(st.lam_max > 0.0105 && st.lam_max < 0.02);
    CU_ASSERT(w.steps == st.k); /* the rows up to the stop, that step's included */
    /* a bound the config refuses */
    dth_integrator *it = NULL;
    CU_ASSERT_FATAL(dth_integrator_new(m, &o, &it) == DTH_OK);
    CU_ASSERT_FATAL(dth_integrator_start(it, Q0, P0, 0) == DTH_OK);
    dth_run_config c;
    dth_run_config_default(&c);
    c.steps = 3;
    c.step_max = -1;
    char msg[200];
    CU_ASSERT(dth_run_check(it, &c, &st, msg, sizeof msg) == DTH_EINVAL && strstr(msg, "step_max"));
    dth_integrator_free(it);
    dth_regularizer_free(rg);
    dth_model_free(m);
}

/* Refusals leave the report as it was; a calibration leaves the regularizer's state as it was. */
static void test_contract(void)
{
    dth_model *m = kepler();
    dth_regularizer *rg;
    dth_options o;
    options(m, &o, &rg);
    dth_control ctl;
    dth_control_default(&ctl);
    dth_control_report r, r0;
    memset(&r, 0x5a, sizeof r);
    r.size = sizeof r;
    r0 = r;
    char err[256];
    CU_ASSERT(dth_control_calibrate(m, &o, Q0, P0, 0, T10, &ctl, &r, err, sizeof err) == DTH_EINVAL); /* nothing asked */
    CU_ASSERT(strstr(err, "h_max") != NULL);
    ctl.h_max = 0.01;
    CU_ASSERT(dth_control_calibrate(m, &o, Q0, P0, 0, -1, &ctl, &r, err, sizeof err) == DTH_EINVAL); /* t_end behind */
    ctl.pilot = 2 * T10;
    CU_ASSERT(dth_control_calibrate(m, &o, Q0, P0, 0, T10, &ctl, &r, err, sizeof err) == DTH_EINVAL);
    CU_ASSERT(strstr(err, "pilot") != NULL);
    ctl.pilot = NAN;
    ctl.size--;
    CU_ASSERT(dth_control_calibrate(m, &o, Q0, P0, 0, T10, &ctl, &r, err, sizeof err) == DTH_EINVAL);
    ctl.size++;
    dth_options b = o;
    b.method = "rk4";
    b.regularizer = NULL;
    CU_ASSERT(dth_control_calibrate(m, &b, Q0, P0, 0, T10, &ctl, &r, err, sizeof err) == DTH_EUNSUPPORTED);
    CU_ASSERT(memcmp(&r, &r0, sizeof r) == 0);
    /* the regularizer's state (land: C not yet fixed) is the same after a calibration as before */
    size_t len = dth__reg_state_size(rg);
    CU_ASSERT_FATAL(len > 0 && len <= 256);
    unsigned char before[256], after[256];
    dth__reg_save_state(rg, before);
    ctl.pilot = TWO_PI;
    CU_ASSERT(dth_control_calibrate(m, &o, Q0, P0, 0, T10, &ctl, &r, err, sizeof err) == DTH_OK);
    dth__reg_save_state(rg, after);
    CU_ASSERT(memcmp(before, after, len) == 0);
    dth_regularizer_free(rg);
    dth_model_free(m);
}

/* ---------------------------------------------------------------- scenes: integrator.h_max, tol, pilot */

#define KEPLER_SCENE "[model]\nname = kepler\n[initial]\nq = %s, 0\np = 0, %s\n[integrator]\n%s\n"

/* The setup of a Kepler scene from its pericentre q with speed p and the [integrator] lines `integ`,
 * with overrides; the status (the message in err). */
static int scene_setup(const char *q, const char *p, const char *integ, const char *const *sets, size_t nsets,
                       dth_run_setup *rs, char *err, size_t len)
{
    dth_registry *reg = NULL;
    CU_ASSERT_FATAL(dth_registry_new(NULL, &reg) == DTH_OK && dth_registry_add_builtin(reg) == DTH_OK);
    dth_scene *s = NULL;
    char text[512];
    snprintf(text, sizeof text, KEPLER_SCENE, q, p, integ);
    CU_ASSERT_FATAL(dth_scene_new(NULL, &s) == DTH_OK);
    CU_ASSERT_FATAL(dth_scene_load_mem(s, "k.ini", text, strlen(text), err, len) == DTH_OK);
    for (size_t i = 0; i < nsets; i++) CU_ASSERT_FATAL(dth_scene_set(s, sets[i], err, len) == DTH_OK);
    err[0] = '\0';
    int rc = dth_scene_setup(s, reg, rs, err, len);
    dth_scene_free(s);
    dth_registry_free(reg);
    return rc;
}

/* h may be left out with h_max or tol; the setup carries the keys, the guard and the h asked for;
 * dth_run_setup_control sets the first step; dth_run_config_from_setup passes the guard on. */
static void test_scene_keys(void)
{
    dth_run_setup rs;
    char err[512];
    CU_ASSERT_FATAL(scene_setup("0.1", "4.358898943540674", "h_max = 0.01\nt_end = 6.283185307179586", NULL, 0, &rs,
                                err, sizeof err) == DTH_OK);
    CU_ASSERT(rs.h_max == 0.01 && rs.tol == 0 && isnan(rs.pilot));
    CU_ASSERT(rs.opt.h == 0.01 && rs.h_asked == 0.01); /* h defaults to h_max */
    CU_ASSERT(rs.step_max == 1.05 * 0.01);
    dth_run_config cfg;
    dth_run_config_from_setup(&cfg, &rs);
    CU_ASSERT(cfg.step_max == rs.step_max); /* an uncalibrated run is guarded too */
    dth_control_report r = {.size = sizeof r};
    CU_ASSERT_FATAL(dth_run_setup_control(&rs, &r, err, sizeof err) == DTH_OK);
    CU_ASSERT(r.passes >= 2 && r.hmax_settled);
    CU_ASSERT(rs.opt.h == r.h0 && r.h0 < 0.001 && rs.h_asked == 0.01);
    dth_run_setup_clear(&rs);
    /* backwards in time: h defaults to -h_max, the first step is negative */
    CU_ASSERT_FATAL(scene_setup("0.1", "4.358898943540674", "h_max = 0.05\nt_end = -1", NULL, 0, &rs, err,
                                sizeof err) == DTH_OK);
    CU_ASSERT(rs.opt.h == -0.05);
    CU_ASSERT(dth_run_setup_control(&rs, NULL, err, sizeof err) == DTH_OK && rs.opt.h < 0 && rs.opt.h > -0.05);
    dth_run_setup_clear(&rs);
    /* tol alone: h defaults to a thousandth of the run */
    CU_ASSERT_FATAL(scene_setup("0.1", "4.358898943540674", "tol = 1e-3\nt_end = 2", NULL, 0, &rs, err, sizeof err) ==
                    DTH_OK);
    CU_ASSERT(rs.opt.h == 0.002 && rs.step_max == 0);
    dth_run_setup_clear(&rs);
    /* neither: dth_run_setup_control changes nothing */
    CU_ASSERT_FATAL(scene_setup("0.1", "4.358898943540674", "h = 0.01\nt_end = 2", NULL, 0, &rs, err, sizeof err) ==
                    DTH_OK);
    CU_ASSERT(rs.step_max == 0 && rs.h_asked == 0.01);
    r.passes = 7;
    CU_ASSERT(dth_run_setup_control(&rs, &r, err, sizeof err) == DTH_OK && r.passes == 0 && r.h0 == 0.01 &&
              rs.opt.h == 0.01);
    dth_run_setup_clear(&rs);
}

/* What the scene refuses, at the line of the key. */
static void test_scene_refusals(void)
{
    static const struct {
        const char *integ, *set, *want;
    } cases[] = {
        {"h_max = 0.01\nsteps = 10", NULL, "k.ini:7: integrator.h_max: calibrates the run up to its end"},
        {"tol = 1e-4\nh = 0.01\nsteps = 10", NULL, "k.ini:7: integrator.tol: calibrates the run up to its end"},
        {"h_max = 0.01\nt_end = 1", "integrator.method=rk4", "k.ini:7: integrator.h_max: chooses the constant of a DTH run"},
        {"h = 0.01\nt_end = 1\npilot = 0.5", NULL, "k.ini:9: integrator.pilot: the end of the pilots of h_max and tol"},
        {"h_max = 0.01\nt_end = 1\npilot = 2", NULL, "k.ini:9: integrator.pilot: 2: the pilots' end must lie after"},
        {"h_max = 0.01\nt_end = 1\npilot = -1", NULL, "k.ini:9: integrator.pilot: -1: the pilots' end must lie after"},
        {"h_max = -0.01\nt_end = 1", NULL, "k.ini:7: integrator.h_max: '-0.01' is not"},
        {"tol = -1\nh = 0.1\nt_end = 1", NULL, "k.ini:7: integrator.tol: '-1' is not"},
        {"t_end = 1", NULL, "k.ini: missing [integrator] h= (the first step; its sign sets the direction), or h_max= or tol="},
        {"h_max = 0.01\nt_end = 1\nstart = vertex", "initial.wp=0.5", "integrator.h_max: chooses the first step, which "
                                                                        "the explicit initial.wp"},
    };
    for (size_t i = 0; i < sizeof cases / sizeof cases[0]; i++) {
        dth_run_setup rs;
        char err[512];
        const char *sets[1] = {cases[i].set};
        int rc = scene_setup("0.1", "4.358898943540674", cases[i].integ, sets, cases[i].set ? 1 : 0, &rs, err, sizeof err);
        CU_ASSERT(rc == DTH_EINVAL);
        if (rc == DTH_OK) dth_run_setup_clear(&rs);
        int has = strstr(err, cases[i].want) != NULL;
        if (!has) printf("\n    case %zu: got \"%s\", want \"%s\"", i, err, cases[i].want);
        CU_ASSERT(has);
    }
}

/* Kepler e = 0.99 from its pericentre, one orbit, h_max = 0.01: the first passes' first steps fail at
 * the pericentre's crossing (the regularizer cannot land them), the calibration comes down until one
 * runs, then binds the law; the run takes every step <= 0.0105 with its error below 1e-2. */
static void test_failing_pilots(void)
{
    dth_run_setup rs;
    char err[512];
    CU_ASSERT_FATAL(scene_setup("0.01", "14.106735979665885", "h_max = 0.01\nt_end = 6.283185307179586", NULL, 0, &rs,
                                err, sizeof err) == DTH_OK);
    dth_control_report r = {.size = sizeof r};
    CU_ASSERT_FATAL(dth_run_setup_control(&rs, &r, err, sizeof err) == DTH_OK);
    printf("\n    e = 0.99: h0 %.4g after %d passes (%d restarts), %ld pilot steps", r.h0, r.passes, r.hmax_restarts,
           r.steps);
    CU_ASSERT(r.hmax_restarts >= 2);
    dth_integrator *it = NULL;
    CU_ASSERT_FATAL(dth_integrator_new(rs.model, &rs.opt, &it) == DTH_OK);
    CU_ASSERT_FATAL(dth_integrator_start(it, rs.q0, rs.p0, rs.t0) == DTH_OK);
    dth_run_config c;
    dth_run_config_from_setup(&c, &rs);
    dth_run_state st;
    dth_run_state_init(&st);
    int rc = dth_run(it, &c, &st);
    const double *z = dth_integrator_vertex(it);
    double y0[6] = {0.01, 0, 0, 0, 14.106735979665885, 0}, ex[6];
    CU_ASSERT_FATAL(dth_model_exact(rs.model, y0, z[2], ex) == DTH_OK);
    double e = hypot(z[0] - ex[0], z[1] - ex[1]);
    printf("; run: %ld steps, largest %.5g, error %.3g at the last vertex", st.k, st.lam_max, e);
    CU_ASSERT(rc == DTH_OK && st.stop == DTH_RUN_END);
    CU_ASSERT(st.lam_max <= 0.0105);
    CU_ASSERT(e <= 1e-2);
    dth_integrator_free(it);
    dth_run_setup_clear(&rs);
}

static CU_TestInfo tests[] = {
    {"the step law l(z; C) and its limits", test_law},
    {"h_max = 0.01 on Kepler e = 0.9 from the pericentre: every step <= 0.0105", test_hmax},
    {"tol = 1e-4 on the same orbit: the error within 10x of tol", test_tol},
    {"a step above 1.05 h_max stops the run (DTH_ESTEPSIZE)", test_guard},
    {"refusals, and the caller's regularizer untouched", test_contract},
    {"scene keys: h from h_max or tol, the guard, dth_run_setup_control", test_scene_keys},
    {"scene refusals at the line of the key", test_scene_refusals},
    {"Kepler e = 0.99, h_max = 0.01: failing pilots come down, the run passes", test_failing_pilots},
    CU_TEST_INFO_NULL,
};

CU_SuiteInfo dth_test_suites[] = {
    {.pName = "control", .pTests = tests},
    CU_SUITE_INFO_NULL,
};
