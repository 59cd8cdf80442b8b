/* SPDX-License-Identifier: MIT */
/*
 * Tests of the fixed-step baselines (lib/methods.c: orders, invariants, reversibility, failure
 * leaves the state untouched) and of the DTH step at the extremes (paper, Lemma g_taylor:
 * conditioning at tiny steps, tiny amplitudes, the near-separatrix pendulum, large steps).
 */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <CUnit/CUnit.h>
#include "cu_main.h"
#include "dth/dth.h"
#include "dth_internal.h"

/* ---- test-local models ---- */

static int tm_create(const dth_model_args *a, void **self, dth_model_info *info, int sep, int aut)
{
    *self = NULL;
    *info = (dth_model_info){.n = 1, .autonomous = aut, .separable = sep};
    return DTH_OK;
}
static int ns_create(const dth_model_args *a, void **self, dth_model_info *info) { return tm_create(a, self, info, 0, 1); }
static int na_create(const dth_model_args *a, void **self, dth_model_info *info) { return tm_create(a, self, info, 1, 0); }
static int dm_create(const dth_model_args *a, void **self, dth_model_info *info) { return tm_create(a, self, info, 1, 1); }

/* Non-separable: H = (1 + q^2) p^2 / 2 + q^2 / 2. */
static int ns_eval(const void *s, const double *y, unsigned what, double *H, double *g, double *hs)
{
    double q = y[0], p = y[2];
    if (what & DTH_EVAL_H) *H = 0.5 * (1 + q * q) * p * p + 0.5 * q * q;
    if (what & DTH_EVAL_GRAD) { g[0] = q * p * p + q; g[1] = 0; g[2] = (1 + q * q) * p; }
    if (what & DTH_EVAL_HESS) {
        double v[9] = {p * p + 1, 0, 2 * q * p, 0, 0, 0, 2 * q * p, 0, 1 + q * q};
        memcpy(hs, v, sizeof v);
    }
    return 0;
}
static const dth_model_type nonsep = {DTH_MODEL_TYPE_HEAD, .name = "nonsep", .create = ns_create, .eval = ns_eval};

/* Resonantly forced oscillator: H = p^2/2 + q^2/2 - q cos t; q'' + q = cos t. */
static int na_eval(const void *s, const double *y, unsigned what, double *H, double *g, double *hs)
{
    double q = y[0], t = y[1], p = y[2];
    if (what & DTH_EVAL_H) *H = 0.5 * p * p + 0.5 * q * q - q * cos(t);
    if (what & DTH_EVAL_GRAD) { g[0] = q - cos(t); g[1] = q * sin(t); g[2] = p; }
    if (what & DTH_EVAL_HESS) {
        double v[9] = {1, sin(t), 0, sin(t), q * cos(t), 0, 0, 0, 1};
        memcpy(hs, v, sizeof v);
    }
    return 0;
}
static int na_exact(const void *s, const double *y0, double t, double *y)
{
    double q0 = y0[0], p0 = y0[2]; /* from t0 = 0 */
    y[0] = q0 * cos(t) + p0 * sin(t) + 0.5 * t * sin(t);
    y[1] = t;
    y[2] = -q0 * sin(t) + p0 * cos(t) + 0.5 * (sin(t) + t * cos(t));
    return 0;
}
static const dth_model_type forced = {DTH_MODEL_TYPE_HEAD, .name = "forced", .create = na_create, .eval = na_eval, .exact = na_exact};

/* Harmonic oscillator defined only for |q| < 1 (to make steps fail). */
static int dm_eval(const void *s, const double *y, unsigned what, double *H, double *g, double *hs)
{
    double q = y[0], p = y[2];
    if (fabs(q) >= 1) return 1;
    if (what & DTH_EVAL_H) *H = 0.5 * p * p + 0.5 * q * q;
    if (what & DTH_EVAL_GRAD) { g[0] = q; g[1] = 0; g[2] = p; }
    if (what & DTH_EVAL_HESS) {
        double v[9] = {1, 0, 0, 0, 0, 0, 0, 0, 1};
        memcpy(hs, v, sizeof v);
    }
    return 0;
}
static const dth_model_type domain = {DTH_MODEL_TYPE_HEAD, .name = "domain", .create = dm_create, .eval = dm_eval};

static dth_model *mk(const dth_model_type *t, const dth_kv *kv, size_t nkv, size_t nh)
{
    dth_model *m = NULL;
    CU_ASSERT_FATAL(dth_model_new(t, kv, nkv, nh, NULL, &m, NULL, 0) == DTH_OK);
    return m;
}

/* The baselines through the integrator (dth_options.method): the methods after "dth". */
static size_t baseline_count(void) { return dth_method_count() - 1; }
static const char *baseline_name(size_t i) { return dth_method_name(i + 1); }

static int fixed_new(const dth_model *m, const char *meth, double h, dth_integrator **f)
{
    dth_options o;
    dth_options_default(&o);
    o.method = meth;
    o.h = h;
    return dth_integrator_new(m, &o, f);
}

static int fixed_check(const dth_model *m, const char *meth, char *why, size_t len)
{
    dth_options o;
    dth_options_default(&o);
    o.method = meth;
    return dth_options_check(m, &o, why, len);
}

/* The step of a baseline, changed: the state set again (as it is) with step h. */
static int fixed_set_h(dth_integrator *f, double h)
{
    double z[16];
    memcpy(z, dth_integrator_vertex(f), dth_integrator_dim(f) * sizeof *z);
    return dth_integrator_set_vertex(f, z, h);
}

static int exact(const dth_model *m, const double *y0, double t, double *y)
{
    return dth_model_get_type(m)->exact(dth__model_self(m), y0, t, y);
}

/* Error |y - exact| (max norm over q, p) after integrating to T with `steps` steps. */
static double global_error(const dth_model *m, const char *meth, const double *q0, const double *p0,
                           double T, long steps)
{
    size_t n = dth_model_dof(m), d = 2 * n + 1;
    dth_integrator *f = NULL;
    CU_ASSERT_FATAL(fixed_new(m, meth, T / (double)steps, &f) == DTH_OK);
    CU_ASSERT_FATAL(dth_integrator_start(f, q0, p0, 0) == DTH_OK);
    for (long k = 0; k < steps; k++) CU_ASSERT_FATAL(dth_integrator_step(f, NULL) == DTH_OK);
    const double *y = dth_integrator_vertex(f);
    double y0[16], ye[16], e = 0;
    memcpy(y0, q0, n * sizeof *q0);
    y0[n] = 0;
    memcpy(y0 + n + 1, p0, n * sizeof *p0);
    CU_ASSERT_FATAL(exact(m, y0, y[n], ye) == 0);
    CU_ASSERT_DOUBLE_EQUAL(y[n], T, 1e-14 * T);
    for (size_t j = 0; j < d; j++)
        if (j != n) e = fmax(e, fabs(y[j] - ye[j]));
    dth_integrator_free(f);
    return e;
}

/* ---- fixed-step baselines ---- */

static void test_names(void)
{
    dth_model *m = mk(&dth_model_pendulum, NULL, 0, 1), *ns = mk(&nonsep, NULL, 0, 1), *na = mk(&forced, NULL, 0, 1);
    dth_integrator *f = NULL;
    CU_ASSERT(baseline_count() == 5);
    for (size_t i = 0; i < baseline_count(); i++) {
        const char *name = baseline_name(i);
        CU_ASSERT_PTR_NOT_NULL(dth_method_doc(name));
        CU_ASSERT(fixed_new(m, name, 0.1, &f) == DTH_OK);
        CU_ASSERT_STRING_EQUAL(dth_integrator_method(f), name);
        dth_integrator_free(f);
    }
    CU_ASSERT_PTR_NULL(baseline_name(5));
    CU_ASSERT(fixed_new(m, "euler", 0.1, &f) == DTH_ENOTFOUND && f == NULL);
    CU_ASSERT(fixed_new(m, "rk4", 0.0, &f) == DTH_EINVAL);
    CU_ASSERT(fixed_new(m, "rk4", NAN, &f) == DTH_EINVAL);
    char why[160];
    CU_ASSERT(fixed_new(ns, "verlet", 0.1, &f) == DTH_EUNSUPPORTED && f == NULL);
    CU_ASSERT(fixed_check(ns, "verlet", why, sizeof why) == DTH_EUNSUPPORTED);
    CU_ASSERT_PTR_NOT_NULL(strstr(why, "separable"));
    CU_ASSERT_PTR_NOT_NULL(strstr(why, "nonsep"));
    CU_ASSERT(fixed_check(na, "midpoint-proj", why, sizeof why) == DTH_EUNSUPPORTED);
    CU_ASSERT_PTR_NOT_NULL(strstr(why, "autonomous"));
    CU_ASSERT(fixed_check(ns, "gauss4", why, sizeof why) == DTH_OK);
    /* stepping before start */
    CU_ASSERT(fixed_new(m, "midpoint", 0.1, &f) == DTH_OK);
    CU_ASSERT(dth_integrator_step(f, NULL) == DTH_EINVAL);
    dth_integrator_free(f);
    dth_integrator_free(NULL);
    dth_model_free(m);
    dth_model_free(ns);
    dth_model_free(na);
}

/* Convergence orders against exact solutions: log2 of the error ratio at h and h/2. */
static void check_orders(const dth_model *m, const double *q0, const double *p0, double T, long N)
{
    for (size_t i = 0; i < baseline_count(); i++) {
        const char *name = baseline_name(i);
        if (fixed_check(m, name, NULL, 0)) continue;
        double e1 = global_error(m, name, q0, p0, T, N), e2 = global_error(m, name, q0, p0, T, 2 * N);
        double ord = log2(e1 / e2);
        dth_integrator *f;
        CU_ASSERT_FATAL(fixed_new(m, name, 1, &f) == DTH_OK);
        int want = dth_integrator_order(f);
        dth_integrator_free(f);
        CU_ASSERT(fabs(ord - want) < 0.25);
        if (fabs(ord - want) >= 0.25) fprintf(stderr, "%s: order %.3f (errors %.3g %.3g)\n", name, ord, e1, e2);
    }
}

static void test_orders(void)
{
    dth_model *pend = mk(&dth_model_pendulum, NULL, 0, 1), *na = mk(&forced, NULL, 0, 1);
    double q0 = 1, p0 = 0.3;
    check_orders(pend, &q0, &p0, 3.0, 40);
    q0 = 0.5;
    p0 = -0.2;
    check_orders(na, &q0, &p0, 4.0, 40); /* non-autonomous, with t inside the Newton system */
    dth_model_free(pend);
    dth_model_free(na);
}

/* Gauss methods conserve quadratic invariants (per-mode energies of a harmonic oscillator,
 * the angular momentum of Kepler) to round-off; Verlet conserves its modified energy. */
static void test_quadratic_invariants(void)
{
    dth_kv kv[] = {{"omega", "1,2.5"}};
    dth_model *h2 = mk(&dth_model_harmonic, kv, 1, 2), *kep = mk(&dth_model_kepler, NULL, 0, 2);
    const char *gauss[] = {"midpoint", "gauss4"};
    for (int g = 0; g < 2; g++) {
        double q0[2] = {1, -0.3}, p0[2] = {0.2, 0.7}, I0[2], I[2], dmax = 0;
        dth_integrator *f;
        CU_ASSERT_FATAL(fixed_new(h2, gauss[g], 0.3, &f) == DTH_OK);
        CU_ASSERT_FATAL(dth_integrator_start(f, q0, p0, 0) == DTH_OK);
        dth_model_get_type(h2)->invariants(dth__model_self(h2), dth_integrator_vertex(f), I0);
        for (int k = 0; k < 2000; k++) {
            CU_ASSERT_FATAL(dth_integrator_step(f, NULL) == DTH_OK);
            dth_model_get_type(h2)->invariants(dth__model_self(h2), dth_integrator_vertex(f), I);
            for (int i = 0; i < 2; i++) dmax = fmax(dmax, fabs(I[i] - I0[i]) / I0[i]);
        }
        CU_ASSERT(dmax < 1e-13);
        if (dmax >= 1e-13) fprintf(stderr, "%s: harmonic invariant drift %.3g\n", gauss[g], dmax);
        dth_integrator_free(f);
        /* Kepler e = 0.6 from pericentre: L = q x p (invariant 0) */
        double kq[2] = {0.4, 0}, kp[2] = {0, sqrt(1.6 / 0.4)}, L0[8], L[8];
        CU_ASSERT_FATAL(fixed_new(kep, gauss[g], 0.02, &f) == DTH_OK);
        CU_ASSERT_FATAL(dth_integrator_start(f, kq, kp, 0) == DTH_OK);
        dth_model_get_type(kep)->invariants(dth__model_self(kep), dth_integrator_vertex(f), L0);
        dmax = 0;
        for (int k = 0; k < 1000; k++) {
            CU_ASSERT_FATAL(dth_integrator_step(f, NULL) == DTH_OK);
            dth_model_get_type(kep)->invariants(dth__model_self(kep), dth_integrator_vertex(f), L);
            dmax = fmax(dmax, fabs(L[0] - L0[0]));
        }
        CU_ASSERT(dmax < 1e-13);
        dth_integrator_free(f);
    }
    /* Verlet on the oscillator (omega = 1, 2.5): p^2 + w^2 (1 - h^2 w^2/4) q^2 per mode */
    double q0[2] = {1, -0.3}, p0[2] = {0.2, 0.7}, h = 0.3, w[2] = {1, 2.5}, J0[2], dmax = 0;
    dth_integrator *f;
    CU_ASSERT_FATAL(fixed_new(h2, "verlet", h, &f) == DTH_OK);
    CU_ASSERT_FATAL(dth_integrator_start(f, q0, p0, 0) == DTH_OK);
    for (int i = 0; i < 2; i++) J0[i] = p0[i] * p0[i] + w[i] * w[i] * (1 - h * h * w[i] * w[i] / 4) * q0[i] * q0[i];
    for (int k = 0; k < 2000; k++) {
        CU_ASSERT_FATAL(dth_integrator_step(f, NULL) == DTH_OK);
        const double *y = dth_integrator_vertex(f);
        for (int i = 0; i < 2; i++) {
            double J = y[3 + i] * y[3 + i] + w[i] * w[i] * (1 - h * h * w[i] * w[i] / 4) * y[i] * y[i];
            dmax = fmax(dmax, fabs(J - J0[i]) / J0[i]);
        }
    }
    CU_ASSERT(dmax < 1e-13);
    dth_integrator_free(f);
    dth_model_free(h2);
    dth_model_free(kep);
}

/* RK4 on y' = (p, -q): each step multiplies the energy by |R(ih)|^2 = 1 - h^6/72 + h^8/576. */
static void test_rk4_damping(void)
{
    dth_model *m = mk(&dth_model_harmonic, NULL, 0, 1);
    double q0 = 1, p0 = 0, h = 0.5, E0 = 0.5;
    dth_integrator *f;
    CU_ASSERT_FATAL(fixed_new(m, "rk4", h, &f) == DTH_OK);
    CU_ASSERT_FATAL(dth_integrator_start(f, &q0, &p0, 0) == DTH_OK);
    double r = 1 - pow(h, 6) / 72 + pow(h, 8) / 576;
    for (int k = 1; k <= 200; k++) {
        CU_ASSERT_FATAL(dth_integrator_step(f, NULL) == DTH_OK);
        const double *y = dth_integrator_vertex(f);
        double E = 0.5 * (y[0] * y[0] + y[2] * y[2]);
        CU_ASSERT_DOUBLE_EQUAL(E, E0 * pow(r, k), 1e-14);
    }
    dth_integrator_free(f);
    dth_model_free(m);
}

/* Projection holds the energy to round-off; plain midpoint does not (pendulum). */
static void test_projection(void)
{
    dth_model *m = mk(&dth_model_pendulum, NULL, 0, 1);
    double q0 = 2.0, p0 = 0, E0 = -cos(2.0), dproj = 0, dmid = 0;
    dth_integrator *f, *g;
    CU_ASSERT_FATAL(fixed_new(m, "midpoint-proj", 0.2, &f) == DTH_OK);
    CU_ASSERT_FATAL(fixed_new(m, "midpoint", 0.2, &g) == DTH_OK);
    CU_ASSERT_FATAL(dth_integrator_start(f, &q0, &p0, 0) == DTH_OK);
    CU_ASSERT_FATAL(dth_integrator_start(g, &q0, &p0, 0) == DTH_OK);
    for (int k = 0; k < 1000; k++) {
        dth_step_info inf;
        CU_ASSERT_FATAL(dth_integrator_step(f, &inf) == DTH_OK);
        CU_ASSERT(inf.iters >= 1 && inf.proj_iters >= 1 && inf.proj_iters <= 5);
        CU_ASSERT_FATAL(dth_integrator_step(g, NULL) == DTH_OK);
        const double *y = dth_integrator_vertex(f), *x = dth_integrator_vertex(g);
        dproj = fmax(dproj, fabs(0.5 * y[2] * y[2] - cos(y[0]) - E0));
        dmid = fmax(dmid, fabs(0.5 * x[2] * x[2] - cos(x[0]) - E0));
    }
    CU_ASSERT(dproj < 1e-14);
    CU_ASSERT(dmid > 1e-4); /* the projection did something */
    dth_integrator_free(f);
    dth_integrator_free(g);
    dth_model_free(m);
}

/* Symmetric methods retrace their steps with -h. */
static void test_reversible(void)
{
    dth_model *m = mk(&dth_model_kepler, NULL, 0, 2);
    const char *sym[] = {"midpoint", "gauss4", "verlet"};
    for (int s = 0; s < 3; s++) {
        double q0[2] = {0.4, 0}, p0[2] = {0, 2}, dev = 0;
        dth_integrator *f;
        CU_ASSERT_FATAL(fixed_new(m, sym[s], 0.01, &f) == DTH_OK);
        CU_ASSERT_FATAL(dth_integrator_start(f, q0, p0, 0) == DTH_OK);
        for (int k = 0; k < 300; k++) CU_ASSERT_FATAL(dth_integrator_step(f, NULL) == DTH_OK);
        dth_integrator_reverse(f);
        CU_ASSERT(dth_integrator_lambda(f) == -0.01);
        for (int k = 0; k < 300; k++) CU_ASSERT_FATAL(dth_integrator_step(f, NULL) == DTH_OK);
        const double *y = dth_integrator_vertex(f);
        dev = fmax(fmax(fabs(y[0] - q0[0]), fabs(y[1] - q0[1])), fmax(fabs(y[3] - p0[0]), fabs(y[4] - p0[1])));
        CU_ASSERT(dev < 1e-11);
        CU_ASSERT(fabs(y[2]) < 1e-15);
        CU_ASSERT(dth_integrator_steps(f) == 600);
        dth_integrator_free(f);
    }
    dth_model_free(m);
}

/* A failed step leaves the state bit for bit as it was; a smaller step then succeeds. */
static void test_failed_step(void)
{
    dth_model *m = mk(&domain, NULL, 0, 1);
    for (size_t i = 0; i < baseline_count(); i++) {
        const char *name = baseline_name(i);
        double q0 = 0.9, p0 = 1.0, before[3];
        dth_integrator *f;
        CU_ASSERT_FATAL(fixed_new(m, name, 0.001, &f) == DTH_OK);
        CU_ASSERT_FATAL(dth_integrator_start(f, &q0, &p0, 0) == DTH_OK);
        for (int k = 0; k < 10; k++) CU_ASSERT_FATAL(dth_integrator_step(f, NULL) == DTH_OK);
        memcpy(before, dth_integrator_vertex(f), sizeof before);
        CU_ASSERT(fixed_set_h(f, 0.5) == DTH_OK); /* counts steps afresh */
        int rc = dth_integrator_step(f, NULL);
        CU_ASSERT(rc == DTH_EDOMAIN);
        CU_ASSERT(memcmp(before, dth_integrator_vertex(f), sizeof before) == 0);
        CU_ASSERT(dth_integrator_steps(f) == 0);
        CU_ASSERT_PTR_NOT_NULL(strstr(dth_integrator_errmsg(f), "model evaluation failed"));
        CU_ASSERT(fixed_set_h(f, 0.001) == DTH_OK);
        CU_ASSERT(dth_integrator_step(f, NULL) == DTH_OK);
        CU_ASSERT(dth_integrator_vertex(f)[0] > before[0]);
        dth_integrator_free(f);
    }
    dth_model_free(m);
}

/* ---- DTH at the extremes ---- */

typedef struct run_result {
    int rc;          /* status of the first failing step, or DTH_OK */
    long steps;      /* accepted steps */
    double emid;     /* largest |H_phys(midpoint) - E0| */
    double lam_noise;/* rms of second differences of lambda / sqrt(6), relative to the last lambda */
    double lam_last;
    double err;      /* max-norm error of the last vertex against the exact solution at its time */
    int finite;      /* every accepted vertex finite */
} run_result;

static run_result run_comp(const dth_model *m, double q0, double p0, double h, long steps, int compensate)
{
    run_result r = {0};
    dth_options o;
    dth_options_default(&o);
    o.h = h;
    o.finish = (dth_finish)compensate;
    dth_integrator *it = NULL;
    CU_ASSERT_FATAL(dth_integrator_new(m, &o, &it) == DTH_OK);
    CU_ASSERT_FATAL(dth_integrator_start(it, &q0, &p0, 0) == DTH_OK);
    double E0 = 0.5 * p0 * p0 - cos(q0), l[3] = {0}, s2 = 0;
    long ns = 0;
    r.finite = 1;
    for (r.steps = 0; r.steps < steps; r.steps++) {
        dth_step_info inf;
        r.rc = dth_integrator_step(it, &inf);
        if (r.rc) break;
        const double *zb = dth_integrator_midpoint(it), *z = dth_integrator_vertex(it);
        r.emid = fmax(r.emid, fabs(0.5 * zb[2] * zb[2] - cos(zb[0]) - E0));
        for (int j = 0; j < 4; j++) r.finite &= isfinite(z[j]);
        l[0] = l[1];
        l[1] = l[2];
        l[2] = inf.lambda;
        if (r.steps >= 3) {
            double d2 = l[2] - 2 * l[1] + l[0];
            s2 += d2 * d2;
            ns++;
        }
    }
    r.lam_last = l[2];
    r.lam_noise = ns ? sqrt(s2 / (double)ns / 6) / fabs(l[2]) : 0;
    const double *z = dth_integrator_vertex(it);
    double y0[3] = {q0, 0, p0}, ye[3];
    CU_ASSERT(exact(m, y0, z[1], ye) == 0);
    r.err = fmax(fabs(z[0] - ye[0]), fabs(z[2] - ye[2]));
    dth_integrator_free(it);
    return r;
}

static run_result run_pend(const dth_model *m, double q0, double p0, double h, long steps)
{
    return run_comp(m, q0, p0, h, steps, 1);
}

static double floor_at(const dth_model *m, double q0, double p0)
{
    double z[4] = {q0, 0, p0, -(0.5 * p0 * p0 - cos(q0))}, hmin = 0;
    double *work = malloc(dth_model_work_size(m) * sizeof *work);
    CU_ASSERT_FATAL(work != NULL);
    CU_ASSERT(dth_step_floor(m, z, 1.0, &hmin, work) == DTH_OK);
    free(work);
    return hmin;
}

/*
 * Tiny steps. With the plain constraint (compensate = 0), the measured round-off noise of lambda
 * stays below the conditioning estimate (h_min / lambda)^2 of dth_step_floor (rel_tol = 1) and
 * within a factor 100 of it, and grows as lambda^-2. The compensated constraint (the default)
 * removes that noise: at h = 1e-6 lambda's noise is at most 1e-8 relative (it is 2.6e-4 without),
 * and at least 1000 times below the plain constraint's down to h = 1e-7. Well above the floor the
 * scheme converges.
 */
static void test_tiny_steps(void)
{
    dth_model *m = mk(&dth_model_pendulum, NULL, 0, 1);
    double q0 = 0, p0 = 2 * sin(0.5); /* amplitude 1 rad */
    double hmin = floor_at(m, q0, p0);
    CU_ASSERT(hmin > 1e-8 && hmin < 1e-7);
    double prev_noise = 0, prev_lam = 0;
    for (double h = 1e-6; h >= 0.99e-7; h /= 10) {
        run_result r = run_comp(m, q0, p0, h, 2000, 0), c = run_comp(m, q0, p0, h, 2000, 1);
        CU_ASSERT(r.rc == DTH_OK && r.finite && c.rc == DTH_OK && c.finite);
        printf("\n    h = %g: lambda noise %.2e plain, %.2e compensated", h, r.lam_noise, c.lam_noise);
        CU_ASSERT(c.lam_noise <= r.lam_noise / 1000);
        if (h > 0.5e-6) CU_ASSERT(c.lam_noise <= 1e-8);
        CU_ASSERT(c.emid < 1e-15 && c.err < 1e-12);
        double pred = (hmin / r.lam_last) * (hmin / r.lam_last);
        CU_ASSERT(r.lam_noise <= pred);
        CU_ASSERT(r.lam_noise >= pred / 100);
        if (prev_noise > 0) {
            double expect = (prev_lam / r.lam_last) * (prev_lam / r.lam_last);
            CU_ASSERT(r.lam_noise / prev_noise > expect / 4 && r.lam_noise / prev_noise < expect * 4);
        }
        prev_noise = r.lam_noise;
        prev_lam = r.lam_last;
        CU_ASSERT(r.emid < 1e-15);
        CU_ASSERT(r.err < 1e-12);
    }
    /* h = 1e-3, far above the floor: noise is the smooth variation of lambda only */
    run_result r = run_pend(m, q0, p0, 1e-3, 2000);
    CU_ASSERT(r.rc == DTH_OK && r.err < 1e-6 && r.lam_noise < 1e-6);
    dth_model_free(m);
}

/* Near equilibrium: amplitude 1e-4 integrates correctly; at 1e-8 the step is below the plain
 * constraint's floor (psi ~ 1e-16): the floor's diagnostic warns, and the compensated finish still
 * integrates it. */
static void test_tiny_amplitude(void)
{
    dth_model *m = mk(&dth_model_pendulum, NULL, 0, 1);
    double h = 0.1;
    CU_ASSERT(floor_at(m, 1e-4, 0) < h / 100);
    run_result r = run_pend(m, 1e-4, 0, h, 200);
    CU_ASSERT(r.rc == DTH_OK && r.finite);
    /* relative to the amplitude, the error is the linear oscillator's O(h^2) phase error, the
     * same as at amplitude 1e-2 (where round-off is negligible) */
    run_result big = run_pend(m, 1e-2, 0, h, 200);
    CU_ASSERT(big.rc == DTH_OK);
    CU_ASSERT(fabs(r.err / 1e-4 - big.err / 1e-2) < 0.05 * big.err / 1e-2);
    CU_ASSERT(fabs(r.lam_last - h) < 1e-3 * h);
    double fl = floor_at(m, 1e-8, 0);
    CU_ASSERT(fl > h); /* the diagnostic warns */
    r = run_pend(m, 1e-8, 0, h, 200);
    CU_ASSERT(r.finite);
    /* below the plain constraint's floor the compensated Newton (the carried offset in the Newton
     * iterations and in the branch check) still resolves lambda: the run completes with the linear
     * oscillator's relative phase error, as at amplitude 1e-2 */
    CU_ASSERT(r.rc == DTH_OK);
    CU_ASSERT(r.steps == 200);
    CU_ASSERT(fabs(r.err / 1e-8 - big.err / 1e-2) < 0.05 * big.err / 1e-2);
    dth_model_free(m);
}

/* Energy 1e-8 below the separatrix: psi changes sign near the turning point, where raw DTH's
 * physical root merges with the ghost (paper, section 5): every run stops there with DTH_EFOLD,
 * right to O(h^2) up to that point. */
static void test_near_separatrix(void)
{
    dth_model *m = mk(&dth_model_pendulum, NULL, 0, 1);
    double p0 = sqrt(2 * (2 - 1e-8));
    const double hs[] = {0.01, 0.05, 0.5};
    for (int i = 0; i < 3; i++) {
        run_result r = run_pend(m, 0, p0, hs[i], 3000);
        CU_ASSERT(r.finite);
        CU_ASSERT(r.emid < 1e-14);
        /* stops at the fold (after 127, 24, 2 steps); the last vertex is right to O(h^2)
         * (err / h^2 = 3.6, 0.62, 0.17 measured) */
        CU_ASSERT(r.rc == DTH_EFOLD);
        CU_ASSERT(r.steps > 0 && r.steps < 3000);
        CU_ASSERT(r.err < 5 * hs[i] * hs[i]);
    }
    dth_model_free(m);
}

/* Large steps on the pendulum (period ~ 6.7): finite states, exact midpoint energy, and a
 * status rather than a run on for h beyond the period's scale. */
static void test_large_steps(void)
{
    dth_model *m = mk(&dth_model_pendulum, NULL, 0, 1);
    const double hs[] = {1, 2, 5};
    for (int i = 0; i < 3; i++) {
        run_result r = run_pend(m, 1, 0, hs[i], 100);
        CU_ASSERT(r.finite);
        CU_ASSERT(r.emid < 1e-14);
        if (hs[i] >= 2) CU_ASSERT(r.rc > 0);
    }
    /* fixed-step methods at h = 5: finite or a status */
    for (size_t i = 0; i < baseline_count(); i++) {
        double q0 = 1, p0 = 0;
        dth_integrator *f;
        CU_ASSERT_FATAL(fixed_new(m, baseline_name(i), 5, &f) == DTH_OK);
        CU_ASSERT_FATAL(dth_integrator_start(f, &q0, &p0, 0) == DTH_OK);
        for (int k = 0; k < 100; k++) {
            int rc = dth_integrator_step(f, NULL);
            const double *y = dth_integrator_vertex(f);
            CU_ASSERT(isfinite(y[0]) && isfinite(y[2]));
            if (rc) break;
        }
        dth_integrator_free(f);
    }
    dth_model_free(m);
}

static void test_floor_args(void)
{
    dth_model *m = mk(&dth_model_pendulum, NULL, 0, 1);
    double work[64], hmin = 0;
    /* psi = p^2 cos q + sin^2 q = 0 at q = pi/2, p = anything: cos = 0 and sin^2 = 1, so not 0;
     * at q = 0, p = 0 (equilibrium) psi = 0 */
    double z0[4] = {0, 0, 0, 1};
    CU_ASSERT(dth_step_floor(m, z0, 1.0, &hmin, work) == DTH_ESINGULAR && isinf(hmin));
    double z[4] = {1, 0, 0.5, 0};
    CU_ASSERT(dth_step_floor(m, z, 0.0, &hmin, work) == DTH_EINVAL);
    CU_ASSERT(dth_step_floor(m, z, 1.0, &hmin, work) == DTH_OK);
    double h1 = hmin;
    CU_ASSERT(dth_step_floor(m, z, 1e-4, &hmin, work) == DTH_OK);
    CU_ASSERT_DOUBLE_EQUAL(hmin, 100 * h1, 1e-12 * hmin); /* scales as rel_tol^-1/2 */
    dth_model_free(m);
}

static CU_TestInfo fixed_tests[] = {
    {"method names and unsupported models", test_names},
    {"orders against exact solutions", test_orders},
    {"quadratic invariants (Gauss) and Verlet's modified energy", test_quadratic_invariants},
    {"rk4 energy damping |R(ih)|^2", test_rk4_damping},
    {"midpoint-proj holds the energy", test_projection},
    {"symmetric methods retrace with -h", test_reversible},
    {"failed step leaves the state untouched", test_failed_step},
    CU_TEST_INFO_NULL,
};

static CU_TestInfo extreme_tests[] = {
    {"step floor arguments and scaling", test_floor_args},
    {"tiny steps: lambda noise vs the floor", test_tiny_steps},
    {"tiny amplitudes", test_tiny_amplitude},
    {"near the separatrix", test_near_separatrix},
    {"large steps", test_large_steps},
    CU_TEST_INFO_NULL,
};

CU_SuiteInfo dth_test_suites[] = {
    {.pName = "fixed", .pTests = fixed_tests},
    {.pName = "extremes", .pTests = extreme_tests},
    CU_SUITE_INFO_NULL,
};
