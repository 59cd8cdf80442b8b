/* SPDX-License-Identifier: MIT */
/*
 * The DTH step (paper, Theorem "DTH Equations"): exact energy at midpoints, wp carried bit for
 * bit, second-order convergence against exact solutions, time reversibility, symplecticity of
 * the tangent map, start modes, non-autonomous models, and failures that leave the state alone.
 */
#include <float.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include "cu_main.h"
#include "dth/dth.h"
#include "dth_internal.h"
#include "test_util.h"

static dth_integrator *new_integrator(const dth_model *m, double h, dth_start start)
{
    dth_options o;
    dth_options_default(&o);
    o.h = h;
    o.start = start;
    dth_integrator *it = NULL;
    CU_ASSERT_EQUAL(dth_integrator_new(m, &o, &it), DTH_OK);
    return it;
}

/* Energy at every midpoint equals -wp to a few ulps over 10^5 steps; wp bit-identical. */
static void energy_run(const dth_model *m, const double *q0, const double *p0, double h)
{
    dth_integrator *it = new_integrator(m, h, DTH_START_MIDPOINT);
    CU_ASSERT_FATAL(dth_integrator_start(it, q0, p0, 0.0) == DTH_OK);
    size_t N = dth_integrator_dim(it);
    double wp0 = dth_integrator_vertex(it)[N - 1], worst = 0;
    int wp_changed = 0, failed = 0;
    for (long k = 0; k < 100000; k++) {
        dth_step_info info;
        if (dth_integrator_step(it, &info) != DTH_OK) {
            failed = 1;
            break;
        }
        double u = energy_ulps(m, dth_integrator_midpoint(it));
        if (u > worst) worst = u;
        if (memcmp(&dth_integrator_vertex(it)[N - 1], &wp0, sizeof wp0) != 0) wp_changed = 1;
    }
    CU_ASSERT_FALSE(failed);
    CU_ASSERT_FALSE(wp_changed);
    CU_ASSERT(worst <= 4.0);
    printf("  [%s: worst midpoint energy error %.2f ulps of the terms over 1e5 steps]\n",
           dth_model_get_type(m)->name, worst);
    dth_integrator_free(it);
}

static void test_energy_pendulum(void)
{
    dth_model *m = model(&dth_model_pendulum, NULL, 0, 1);
    double q = 1.0, p = 0.0;
    energy_run(m, &q, &p, 0.05);
    dth_model_free(m);
}

static void test_energy_harmonic(void)
{
    dth_kv kv[] = {{"omega", "1,1.7,0.3"}, {"mass", "1,2,0.5"}};
    dth_model *m = model(&dth_model_harmonic, kv, 2, 3);
    double q[3] = {1, -0.5, 0.2}, p[3] = {0.3, 0.1, -1};
    energy_run(m, q, p, 0.02);
    dth_model_free(m);
}

/* Error of the midpoint trajectory at time T against the exact solution, for step h. */
static double global_error(const dth_model *m, const double *y0, double h, double T)
{
    size_t n = dth_model_dof(m), d = 2 * n + 1;
    dth_integrator *it = new_integrator(m, h, DTH_START_MIDPOINT);
    CU_ASSERT_FATAL(dth_integrator_start(it, y0, y0 + n + 1, y0[n]) == DTH_OK);
    double zprev[64], z[64], ye[64], zi[64];
    CU_ASSERT_FATAL(2 * n + 2 <= 64);
    memcpy(z, dth_integrator_vertex(it), (d + 1) * sizeof *z);
    while (z[n] < T) {
        memcpy(zprev, z, sizeof z);
        CU_ASSERT_FATAL(dth_integrator_step(it, NULL) == DTH_OK);
        memcpy(z, dth_integrator_vertex(it), (d + 1) * sizeof *z);
    }
    dth_interpolate(n, zprev, z, T, zi); /* dense output: second order too */
    CU_ASSERT_FATAL(dth_model_get_type(m)->exact(dth__model_self(m), y0, T, ye) == 0);
    double err = 0;
    for (size_t i = 0; i < d; i++) err = fmax(err, fabs(zi[i] - ye[i]));
    dth_integrator_free(it);
    return err;
}

static double fit_order(const dth_model *m, const double *y0, double h0, double T)
{
    double lx[4], ly[4], sx = 0, sy = 0, sxx = 0, sxy = 0;
    for (int i = 0; i < 4; i++) {
        double h = h0 / (1 << i);
        lx[i] = log(h);
        ly[i] = log(global_error(m, y0, h, T));
        sx += lx[i]; sy += ly[i]; sxx += lx[i] * lx[i]; sxy += lx[i] * ly[i];
    }
    double slope = (4 * sxy - sx * sy) / (4 * sxx - sx * sx);
    printf("  [%s: convergence order %.3f]\n", dth_model_get_type(m)->name, slope);
    return slope;
}

static void test_order_pendulum(void)
{
    dth_model *m = model(&dth_model_pendulum, NULL, 0, 1);
    double y0[3] = {1.0, 0.0, 0.0}; /* libration, amplitude 1 rad */
    double s = fit_order(m, y0, 0.1, 10.0);
    CU_ASSERT(s > 1.9 && s < 2.1);
    double y1[3] = {0.0, 0.0, 1.0}; /* a different libration, through the bottom */
    s = fit_order(m, y1, 0.1, 7.0);
    CU_ASSERT(s > 1.9 && s < 2.1);
    dth_model_free(m);
}

static void test_order_harmonic(void)
{
    dth_kv kv[] = {{"omega", "1,2.5"}, {"mass", "1,3"}};
    dth_model *m = model(&dth_model_harmonic, kv, 2, 2);
    double y0[5] = {1.0, 0.2, 0.0, 0.0, -0.7};
    double s = fit_order(m, y0, 0.05, 8.0);
    CU_ASSERT(s > 1.9 && s < 2.1);
    dth_model_free(m);
}

/* Forward N steps, reverse, N steps back: the start vertex is recovered to round-off. */
static void roundtrip(const dth_model *m, const double *q0, const double *p0, double h, int steps,
                      dth_start start)
{
    dth_integrator *it = new_integrator(m, h, start);
    CU_ASSERT_FATAL(dth_integrator_start(it, q0, p0, 0.0) == DTH_OK);
    size_t N = dth_integrator_dim(it);
    double z0[64];
    memcpy(z0, dth_integrator_vertex(it), N * sizeof *z0);
    for (int k = 0; k < steps; k++) CU_ASSERT_FATAL(dth_integrator_step(it, NULL) == DTH_OK);
    dth_integrator_reverse(it);
    for (int k = 0; k < steps; k++) CU_ASSERT_FATAL(dth_integrator_step(it, NULL) == DTH_OK);
    const double *z = dth_integrator_vertex(it);
    double err = 0;
    for (size_t j = 0; j < N; j++) err = fmax(err, fabs(z[j] - z0[j]) / (1 + fabs(z0[j])));
    printf("  [%s: round trip over 2x%d steps: %.3g]\n", dth_model_get_type(m)->name, steps, err);
    /* lambda is fixed by a second-order effect (relative conditioning ~ 8/(psi h^2)), so each
     * step carries ~1e-13 of round-off in t; 2000 steps random-walk to ~1e-11 */
    CU_ASSERT(err <= 1e-10);
    dth_integrator_free(it);
}

static void test_reversibility(void)
{
    dth_model *m = model(&dth_model_pendulum, NULL, 0, 1);
    double q = 1.2, p = 0.4;
    roundtrip(m, &q, &p, 0.05, 2000, DTH_START_MIDPOINT);
    roundtrip(m, &q, &p, 0.05, 2000, DTH_START_VERTEX);
    dth_model_free(m);
    dth_kv kv[] = {{"omega", "1,1.3"}};
    m = model(&dth_model_harmonic, kv, 1, 2);
    double q2[2] = {1, 0.5}, p2[2] = {0, -0.3};
    roundtrip(m, q2, p2, 0.03, 2000, DTH_START_MIDPOINT);
    dth_model_free(m);
}

/* The step map z_k -> z_{k+1} as a function of the vertex (vertex set exactly). */
static void step_map(const dth_model *m, const double *z, double lam, double *out)
{
    dth_options o;
    dth_options_default(&o);
    o.h = lam;
    dth_integrator *it;
    CU_ASSERT_FATAL(dth_integrator_new(m, &o, &it) == DTH_OK);
    CU_ASSERT_FATAL(dth_integrator_set_vertex(it, z, lam) == DTH_OK);
    CU_ASSERT_FATAL(dth_integrator_step(it, NULL) == DTH_OK);
    memcpy(out, dth_integrator_vertex(it), dth_integrator_dim(it) * sizeof *out);
    dth_integrator_free(it);
}

static void check_tangent(const dth_model *m, const double *q0, const double *p0, double h, int steps)
{
    size_t n = dth_model_dof(m), N = 2 * n + 2;
    dth_integrator *it = new_integrator(m, h, DTH_START_MIDPOINT);
    CU_ASSERT_FATAL(dth_integrator_start(it, q0, p0, 0.0) == DTH_OK);
    double M[100], Mfd[100], z[10], zp[10], zm[10], fp[10], fm[10];
    CU_ASSERT_FATAL(N <= 10);
    CU_ASSERT_EQUAL(dth_integrator_tangent(it, M), DTH_EINVAL); /* before any step */
    for (int k = 0; k < steps; k++) {
        memcpy(z, dth_integrator_vertex(it), N * sizeof *z);
        CU_ASSERT_FATAL(dth_integrator_step(it, NULL) == DTH_OK);
        double lam = dth_integrator_lambda(it);
        CU_ASSERT_FATAL(dth_integrator_tangent(it, M) == DTH_OK);
        double def = symplectic_defect(n, M, 0), mmax = 0;
        for (size_t i = 0; i < N * N; i++) mmax = fmax(mmax, fabs(M[i]));
        CU_ASSERT(def <= 1e-10 * mmax * mmax);
        if (def > 1e-10 * mmax * mmax) printf("  [k=%d defect %.3g, max|M| %.3g]\n", k, def, mmax);
        if (k % 7 != 3 || k == 0) continue;
        /* independent check by central differences of the step map (the exact first step of a
         * midpoint start is not the vertex map, hence k > 0) */
        for (size_t j = 0; j < N; j++) {
            double e = 1e-6 * (1 + fabs(z[j]));
            memcpy(zp, z, sizeof zp);
            memcpy(zm, z, sizeof zm);
            zp[j] += e;
            zm[j] -= e;
            step_map(m, zp, lam, fp);
            step_map(m, zm, lam, fm);
            for (size_t i = 0; i < N; i++) Mfd[i * N + j] = (fp[i] - fm[i]) / (2 * e);
        }
        double diff = 0;
        for (size_t i = 0; i < N * N; i++) diff = fmax(diff, fabs(M[i] - Mfd[i]));
        CU_ASSERT(diff <= 1e-5 * mmax);
        if (diff > 1e-5 * mmax) printf("  [tangent vs differences: %.3g of %.3g]\n", diff, mmax);
    }
    dth_integrator_free(it);
}

static void test_symplectic(void)
{
    dth_model *m = model(&dth_model_pendulum, NULL, 0, 1);
    double q = 0.8, p = 0.9;
    check_tangent(m, &q, &p, 0.1, 40);
    q = 0.0; p = 2.2; /* rotation, before the first psi = 0 crossing */
    check_tangent(m, &q, &p, 0.05, 10);
    dth_model_free(m);
    dth_kv kv[] = {{"omega", "1,1.9"}, {"mass", "2,1"}};
    m = model(&dth_model_harmonic, kv, 2, 2);
    double q2[2] = {1, -0.3}, p2[2] = {0.2, 0.5};
    check_tangent(m, q2, p2, 0.05, 30);
    dth_model_free(m);
}

/* Midpoint start: z_0 is half a step before the given state, which is the first midpoint
 * exactly, and the first step is exactly h. */
static void test_midpoint_start(void)
{
    dth_model *m = model(&dth_model_pendulum, NULL, 0, 1);
    dth_integrator *it = new_integrator(m, 0.07, DTH_START_MIDPOINT);
    double q = 0.4, p = -0.9;
    CU_ASSERT_FATAL(dth_integrator_start(it, &q, &p, 2.0) == DTH_OK);
    CU_ASSERT_PTR_NULL(dth_integrator_midpoint(it));
    dth_step_info info;
    CU_ASSERT_FATAL(dth_integrator_step(it, &info) == DTH_OK);
    const double *zb = dth_integrator_midpoint(it);
    CU_ASSERT_EQUAL(info.lambda, 0.07);
    CU_ASSERT_EQUAL(info.branch, DTH_BRANCH_EXACT);
    CU_ASSERT_EQUAL(zb[0], q);
    CU_ASSERT_EQUAL(zb[1], 2.0);
    CU_ASSERT_EQUAL(zb[2], p);
    CU_ASSERT_EQUAL(zb[3], -(0.5 * p * p - cos(q)));
    CU_ASSERT_DOUBLE_EQUAL(dth_integrator_vertex(it)[1], 2.035, 1e-15);
    dth_integrator_free(it);
    dth_model_free(m);
}

/*
 * Vertex start: wp is solved for so that the first step is exactly h (to 1e-12; the Taylor term
 * psi h^2/8 gives 0.0500346 here), and dth_integrator_energy reports the energy every midpoint then
 * carries, -wp, which differs from H(z_0). The stiff case of issue 15: the harmonic oscillator with
 * omega = 100 at omega h = 1.9 from q = 1 (H(z_0) = 5000) takes a first step of h and conserves
 * 5000 / (1 + (omega h / 2)^2) = 2628.1 (the midpoint rule's vertex/midpoint energy ratio), where
 * the Taylor offset gave a first step of 3.2 h and conserved 487.5. An explicit wp is used exactly
 * and h only picks the direction.
 */
static void test_vertex_start(void)
{
    dth_model *m = model(&dth_model_pendulum, NULL, 0, 1);
    dth_integrator *it = new_integrator(m, 0.05, DTH_START_VERTEX);
    double q = 0.0, p = 2.2, h = 0.05;
    CU_ASSERT_FATAL(dth_integrator_start(it, &q, &p, 0.0) == DTH_OK);
    double E = dth_integrator_energy(it);
    CU_ASSERT_EQUAL(E, -dth_integrator_vertex(it)[3]);
    dth_step_info info;
    CU_ASSERT_FATAL(dth_integrator_step(it, &info) == DTH_OK);
    CU_ASSERT(fabs(info.lambda - h) <= 1e-12 * h);
    const double *zb = dth_integrator_midpoint(it);
    CU_ASSERT(fabs(0.5 * zb[2] * zb[2] - cos(zb[0]) - E) <= 1e-15 * 2);
    dth_integrator_free(it);

    dth_kv kv[] = {{"omega", "100"}};
    dth_model *hm = model(&dth_model_harmonic, kv, 1, 1);
    dth_options o;
    dth_options_default(&o);
    o.h = 1.9 / 100;
    o.start = DTH_START_VERTEX;
    CU_ASSERT_FATAL(dth_integrator_new(hm, &o, &it) == DTH_OK);
    q = 1, p = 0;
    CU_ASSERT_FATAL(dth_integrator_start(it, &q, &p, 0.0) == DTH_OK);
    CU_ASSERT(fabs(dth_integrator_energy(it) - 5000 / 1.9025) <= 1e-9 * 5000);
    CU_ASSERT_FATAL(dth_integrator_step(it, &info) == DTH_OK);
    CU_ASSERT(fabs(info.lambda - o.h) <= 1e-12 * o.h);
    printf("\n    harmonic omega = 100, omega h = 1.9: first step / h - 1 = %.1e, energy %.10g (5000/1.9025 = %.10g)",
           info.lambda / o.h - 1, dth_integrator_energy(it), 5000 / 1.9025);
    dth_integrator_free(it);
    dth_model_free(hm);

    dth_options_default(&o);
    o.h = -0.05;
    o.start = DTH_START_VERTEX;
    o.has_wp = 1;
    o.wp = -1.4184875;
    q = 0, p = 2.2;
    CU_ASSERT_FATAL(dth_integrator_new(m, &o, &it) == DTH_OK);
    CU_ASSERT_FATAL(dth_integrator_start(it, &q, &p, 0.0) == DTH_OK);
    CU_ASSERT_EQUAL(dth_integrator_vertex(it)[3], -1.4184875);
    CU_ASSERT_FATAL(dth_integrator_step(it, &info) == DTH_OK);
    CU_ASSERT(info.lambda < 0);
    CU_ASSERT_EQUAL(info.branch, DTH_BRANCH_MINUS);
    dth_integrator_free(it);
    dth_model_free(m);
}

/* ---- a non-autonomous model written in the test: forced oscillator ---- */
/* H = p^2/2 + q^2/2 - F q cos(W t), y = (q, t, p) */
static int forced_create(const dth_model_args *a, void **self, dth_model_info *info)
{
    *self = NULL;
    *info = (dth_model_info){.n = 1, .autonomous = 0, .separable = 1};
    return DTH_OK;
}
static int forced_eval(const void *s, const double *y, unsigned what, double *H, double *g, double *h)
{
    const double F = 0.1, W = 1.3; /* weak forcing: psi stays > 0 (no crossing) */
    double q = y[0], t = y[1], p = y[2], c = cos(W * t), sn = sin(W * t);
    if (what & DTH_EVAL_H) *H = 0.5 * p * p + 0.5 * q * q - F * q * c;
    if (what & DTH_EVAL_GRAD) {
        g[0] = q - F * c;
        g[1] = F * q * W * sn;
        g[2] = p;
    }
    if (what & DTH_EVAL_HESS) {
        double hh[9] = {1, F * W * sn, 0, F * W * sn, F * q * W * W * c, 0, 0, 0, 1};
        memcpy(h, hh, sizeof hh);
    }
    return 0;
}
static const dth_model_type forced = {
DTH_MODEL_TYPE_HEAD,
    .name = "forced", .doc = "forced oscillator", .create = forced_create, .eval = forced_eval,
};

static void test_nonautonomous(void)
{
    dth_model *m = model(&forced, NULL, 0, 1);
    CU_ASSERT_FATAL(m != NULL);
    dth_model_check_report rep;
    double y[3] = {0.3, 0.7, -0.2};
    CU_ASSERT(dth_model_check(m, y, &rep) == DTH_OK);
    CU_ASSERT(rep.grad_err < 1e-7 && rep.hess_err < 1e-6);
    double q = 1.0, p = 0.0, zf[3][4];
    double hs[3] = {0.04, 0.02, 0.01};
    for (int r = 0; r < 3; r++) {
        dth_integrator *it = new_integrator(m, hs[r], DTH_START_MIDPOINT);
        CU_ASSERT_FATAL(dth_integrator_start(it, &q, &p, 0.0) == DTH_OK);
        double wp0 = dth_integrator_vertex(it)[3], worst = 0, zprev[4], z[4];
        memcpy(z, dth_integrator_vertex(it), sizeof z);
        while (z[1] < 5.0) {
            memcpy(zprev, z, sizeof z);
            int rc = dth_integrator_step(it, NULL);
            if (rc) printf("  [forced: %s at t = %g: %s]\n", dth_status_name(rc), z[1], dth_integrator_errmsg(it));
            CU_ASSERT_FATAL(rc == DTH_OK);
            memcpy(z, dth_integrator_vertex(it), sizeof z);
            worst = fmax(worst, energy_ulps(m, dth_integrator_midpoint(it)));
        }
        CU_ASSERT(worst <= 4.0);
        CU_ASSERT(z[3] != wp0); /* wp, minus the energy, changes when H depends on t */
        dth_interpolate(1, zprev, z, 5.0, zf[r]);
        dth_integrator_free(it);
    }
    /* second order: successive differences shrink by ~4 */
    double d1 = fabs(zf[0][0] - zf[1][0]) + fabs(zf[0][2] - zf[1][2]);
    double d2 = fabs(zf[1][0] - zf[2][0]) + fabs(zf[1][2] - zf[2][2]);
    CU_ASSERT(d1 / d2 > 3.5 && d1 / d2 < 4.5);
    dth_model_free(m);
}

/* ---- failures leave the state untouched ---- */
static int nan_eval(const void *s, const double *y, unsigned what, double *H, double *g, double *h)
{
    int rc = dth_model_pendulum.eval(s, y, what, H, g, h);
    if (y[0] > 0.5 && (what & DTH_EVAL_GRAD)) g[0] = NAN;
    return rc;
}

static void test_failures(void)
{
    dth_model *m = model(&dth_model_pendulum, NULL, 0, 1);
    dth_options o;
    dth_options_default(&o);
    dth_integrator *it = NULL;
    o.h = 0;
    CU_ASSERT_EQUAL(dth_integrator_new(m, &o, &it), DTH_EINVAL);
    CU_ASSERT_PTR_NULL(it);
    o.h = NAN;
    CU_ASSERT_EQUAL(dth_integrator_new(m, &o, &it), DTH_EINVAL);
    o.h = 0.1;
    o.max_iter = 0;
    CU_ASSERT_EQUAL(dth_integrator_new(m, &o, &it), DTH_EINVAL);
    CU_ASSERT_EQUAL(dth_integrator_new(NULL, &o, &it), DTH_EINVAL);
    o.max_iter = 1; /* Newton cannot converge in one iteration from the reflection predictor */
    o.start = DTH_START_VERTEX;
    CU_ASSERT_FATAL(dth_integrator_new(m, &o, &it) == DTH_OK);
    double q = NAN, p = 0;
    CU_ASSERT_EQUAL(dth_integrator_start(it, &q, &p, 0), DTH_EINVAL);
    q = 0.3;
    CU_ASSERT_EQUAL(dth_integrator_start(it, &q, &p, INFINITY), DTH_EINVAL);
    CU_ASSERT_FATAL(dth_integrator_start(it, &q, &p, 0) == DTH_OK);
    double before[4], z[4] = {0.3, 0, 0.1, NAN};
    CU_ASSERT_EQUAL(dth_integrator_set_vertex(it, z, 0.1), DTH_EINVAL);
    memcpy(before, dth_integrator_vertex(it), sizeof before);
    dth_step_info info;
    CU_ASSERT_EQUAL(dth_integrator_step(it, &info), DTH_ENOCONV);
    CU_ASSERT(memcmp(before, dth_integrator_vertex(it), sizeof before) == 0);
    CU_ASSERT_EQUAL(dth_integrator_steps(it), 0);
    CU_ASSERT(strlen(dth_integrator_errmsg(it)) > 0);
    dth_integrator_free(it);
    dth_model_free(m);

    /* NaN from the model: DTH_EDOMAIN, state untouched */
    dth_model_type nanpend = dth_model_pendulum;
    nanpend.eval = nan_eval;
    nanpend.third = NULL;
    m = model(&nanpend, NULL, 0, 1);
    dth_options_default(&o);
    o.h = 0.1;
    CU_ASSERT_FATAL(dth_integrator_new(m, &o, &it) == DTH_OK);
    q = 0.3;
    p = 1.0;
    CU_ASSERT_FATAL(dth_integrator_start(it, &q, &p, 0) == DTH_OK);
    int rc = DTH_OK;
    long k = 0;
    while (rc == DTH_OK && k < 100) {
        memcpy(before, dth_integrator_vertex(it), sizeof before);
        rc = dth_integrator_step(it, &info);
        k++;
    }
    CU_ASSERT_EQUAL(rc, DTH_EDOMAIN);
    CU_ASSERT(memcmp(before, dth_integrator_vertex(it), sizeof before) == 0);
    dth_integrator_free(it);
    dth_model_free(m);
    dth_integrator_free(NULL);
}

static void test_status_strings(void)
{
    CU_ASSERT_STRING_EQUAL(dth_strerror(DTH_OK), "success");
    CU_ASSERT_STRING_EQUAL(dth_status_name(DTH_ENOCONV), "DTH_ENOCONV");
    CU_ASSERT_STRING_EQUAL(dth_strerror(12345), "unknown status");
    for (int s = -8; s <= 9; s++) CU_ASSERT(strcmp(dth_strerror(s), "unknown status") != 0);
}

static void test_interpolate(void)
{
    double a[4] = {0, 1, 2, -1}, b[4] = {1, 3, 0, -1}, z[4];
    dth_interpolate(1, a, b, 2.0, z);
    CU_ASSERT_DOUBLE_EQUAL(z[0], 0.5, 1e-15);
    CU_ASSERT_EQUAL(z[1], 2.0);
    CU_ASSERT_DOUBLE_EQUAL(z[2], 1.0, 1e-15);
    CU_ASSERT_EQUAL(z[3], -1);
}

/* Harmonic oscillator: psi > 0 and psi' = 0 everywhere, so every vertex is in region I. */
static void test_regions(void)
{
    dth_model *m = model(&dth_model_harmonic, NULL, 0, 1);
    double z[4] = {0.7, 0, -0.2, -0.3}, w[64];
    dth_diag dg;
    CU_ASSERT_FATAL(dth_diagnose(m, z, 0.1, 0, &dg, w) == DTH_OK);
    CU_ASSERT_EQUAL(dg.region, DTH_REGION_I);
    CU_ASSERT(dg.psi > 0);
    CU_ASSERT_EQUAL(dg.dpsi, 0);
    CU_ASSERT_DOUBLE_EQUAL(dg.H, -0.3 + 0.5 * 0.04 + 0.5 * 0.49, 1e-15);
    CU_ASSERT_EQUAL(dth_region_of(0, 1, 1), DTH_REGION_III);
    CU_ASSERT_EQUAL(dth_region_of(0, 0, 1), DTH_REGION_NONE);
    CU_ASSERT_EQUAL(dth_region_of(0.01, 1, 1), DTH_REGION_II);
    dth_model_free(m);
}

/* Every accessor and call accepts NULL (issue 21: dth_integrator_energy(NULL) gave NaN while others
 * crashed): NULL, NaN, 0 or a status back, never a crash. */
static void test_null_handle(void)
{
    double z[4] = {0}, M[16], eq, ep;
    dth_step_info inf;
    dth_integrator_free(NULL);
    dth_integrator_reverse(NULL);
    CU_ASSERT(dth_integrator_vertex(NULL) == NULL);
    CU_ASSERT(dth_integrator_midpoint(NULL) == NULL);
    CU_ASSERT(isnan(dth_integrator_lambda(NULL)));
    CU_ASSERT(isnan(dth_integrator_direction(NULL)));
    CU_ASSERT(isnan(dth_integrator_energy(NULL)));
    CU_ASSERT(dth_integrator_steps(NULL) == 0);
    CU_ASSERT(dth_integrator_dim(NULL) == 0);
    CU_ASSERT(dth_integrator_model(NULL) == NULL);
    CU_ASSERT(dth_integrator_method(NULL) == NULL);
    CU_ASSERT(dth_integrator_order(NULL) == 0);
    CU_ASSERT(dth_integrator_errmsg(NULL) != NULL);
    CU_ASSERT(dth_integrator_start(NULL, z, z, 0) == DTH_EINVAL);
    CU_ASSERT(dth_integrator_set_vertex(NULL, z, 0.1) == DTH_EINVAL);
    CU_ASSERT(dth_integrator_step(NULL, &inf) == DTH_EINVAL);
    CU_ASSERT(dth_integrator_error(NULL, &eq, &ep) != DTH_OK);
    CU_ASSERT(dth_integrator_error_at(NULL, z, &eq, &ep) != DTH_OK);
    CU_ASSERT(dth_integrator_tangent(NULL, M) != DTH_OK);
}

static CU_TestInfo energy[] = {
    {"a NULL handle: every accessor and call answers, none crashes", test_null_handle},
    {"pendulum: midpoint energy and wp over 1e5 steps", test_energy_pendulum},
    {"harmonic 3-D: midpoint energy and wp over 1e5 steps", test_energy_harmonic},
    CU_TEST_INFO_NULL,
};
static CU_TestInfo accuracy[] = {
    {"pendulum converges at second order", test_order_pendulum},
    {"harmonic converges at second order", test_order_harmonic},
    {"non-autonomous model: energy exact, wp moves, second order", test_nonautonomous},
    CU_TEST_INFO_NULL,
};
static CU_TestInfo geometry[] = {
    {"forward then backward returns to z_0", test_reversibility},
    {"tangent map is symplectic and matches differences", test_symplectic},
    CU_TEST_INFO_NULL,
};
static CU_TestInfo api[] = {
    {"midpoint start", test_midpoint_start},
    {"vertex start", test_vertex_start},
    {"failures leave the state untouched", test_failures},
    {"status strings", test_status_strings},
    {"dense output", test_interpolate},
    {"regions", test_regions},
    CU_TEST_INFO_NULL,
};

CU_SuiteInfo dth_test_suites[] = {
    {.pName = "energy", .pTests = energy},
    {.pName = "accuracy", .pTests = accuracy},
    {.pName = "geometry", .pTests = geometry},
    {.pName = "api", .pTests = api},
    CU_SUITE_INFO_NULL,
};
