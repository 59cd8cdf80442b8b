/* SPDX-License-Identifier: MIT */
/*
 * The linear solvers of the DTH step's Newton system (paper, Theorem "DTH Equations") agree with
 * the LAPACK dense path to round-off: from common vertices, every path takes the same step (lambda
 * and the new vertex within the conditioning of lambda, eps scale(H) / (|psi| lambda^2 / 8)), carries
 * wp bit for bit, and gives the same tangent map. Covers the small path (n = 1, 2, 3 instantiated and
 * the generic one; its Schur complement for separable models with diagonal T'', indefinite K included,
 * its LU where T'' is not diagonal, and small-lu), the non-autonomous case, and the banded paths
 * (Schur complement by Cholesky, by LU where it is not positive definite, and the banded LU of the
 * whole matrix).
 */
#include <float.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include "cu_main.h"
#include "dth/dth.h"
#include "dth_internal.h"
#include "dth_core.h"
#include "test_util.h"

/* ---- a separable model whose T'' is not diagonal (the small path's Schur complement does not apply) ---- */

static int mass_create(const dth_model_args *a, void **self, dth_model_info *info)
{
    (void)a;
    *self = NULL;
    *info = (dth_model_info){.n = 2, .autonomous = 1, .separable = 1};
    return DTH_OK;
}

/* H = (p1^2 + p2^2)/2 + 0.4 p1 p2 + (q1^2 + 2 q2^2)/2 + 0.1 q1^4 */
static int mass_eval(const void *self, const double *y, unsigned what, double *H, double *g, double *h)
{
    (void)self;
    double q1 = y[0], q2 = y[1], p1 = y[3], p2 = y[4];
    if (what & DTH_EVAL_H) *H = 0.5 * (p1 * p1 + p2 * p2) + 0.4 * p1 * p2 + 0.5 * (q1 * q1 + 2 * q2 * q2) + 0.1 * q1 * q1 * q1 * q1;
    if (what & DTH_EVAL_GRAD) {
        g[0] = q1 + 0.4 * q1 * q1 * q1;
        g[1] = 2 * q2;
        g[2] = 0;
        g[3] = p1 + 0.4 * p2;
        g[4] = p2 + 0.4 * p1;
    }
    if (what & DTH_EVAL_HESS) {
        for (int i = 0; i < 25; i++) h[i] = 0;
        h[0] = 1 + 1.2 * q1 * q1;
        h[6] = 2;
        h[18] = h[24] = 1;
        h[19] = h[23] = 0.4;
    }
    return 0;
}

static const dth_model_type mass_type = {DTH_MODEL_TYPE_HEAD, .name = "mass", .doc = "non-diagonal mass", .create = mass_create,
                                         .eval = mass_eval};

/* ---- the comparison ---- */

/* Nonzero: banded integrators factor the Schur complement with LAPACK's dpbtrf, not the written-out LDL^T. */
static int band_lapack;

static dth_integrator *make(const dth_model *m, double h, dth_linsolve ls, const double *q, const double *p)
{
    dth_options o;
    dth_options_default(&o);
    o.h = h;
    o.linsolve = ls;
    o.branch_check = 0; /* the same root from both: the paths are what is compared */
    dth_integrator *it = NULL;
    CU_ASSERT_EQUAL_FATAL(dth_integrator_new(m, &o, &it), DTH_OK);
    if (dth__integrator_core(it)->band) dth__band_lapack_only(dth__integrator_core(it)->band, band_lapack);
    CU_ASSERT_EQUAL_FATAL(dth_integrator_start(it, q, p, 0.0), DTH_OK);
    return it;
}

/* What dth__band_mode reports: the banded path of the last factorization (lib/banded.c). */
enum { BAND_SCHUR_CHOL = 1, BAND_SCHUR_LU, BAND_GENERAL };

/*
 * `steps` steps of the reference (dense) integrator; before each, the other is set to the
 * reference's vertex. Returns the largest difference relative to the conditioning bound.
 * want_mode: the banded path every step after the first (which solves nothing) must take
 * (dth__band_mode), 0: not checked.
 */
static double compare(const dth_model *m, double h, dth_linsolve ls, const double *q, const double *p, int steps,
                      int want_mode)
{
    size_t n = dth_model_dof(m), N = 2 * n + 2;
    dth_integrator *ref = make(m, h, DTH_LINSOLVE_DENSE, q, p), *oth = make(m, h, ls, q, p);
    double *g = calloc(N, sizeof *g), *w = calloc(dth_model_work_size(m), sizeof *w);
    double *Mr = calloc(N * N, sizeof *Mr), *Mo = calloc(N * N, sizeof *Mo), *zc = calloc(N, sizeof *zc);
    double worst = 0, tworst = 0;
    int other_mode = 0;
    for (int k = 0; k < steps; k++) {
        if (k > 0) {
            memcpy(zc, dth_integrator_vertex(ref), N * sizeof *zc);
            double lam = dth_integrator_lambda(ref);
            CU_ASSERT_EQUAL_FATAL(dth_integrator_set_vertex(ref, zc, lam), DTH_OK);
            CU_ASSERT_EQUAL_FATAL(dth_integrator_set_vertex(oth, zc, lam), DTH_OK);
        }
        const double *z = dth_integrator_vertex(ref);
        double Hp, psi;
        CU_ASSERT_FATAL(dth_model_eval(m, z, DTH_EVAL_H | DTH_EVAL_GRAD, &Hp, g, NULL) == DTH_OK);
        CU_ASSERT_FATAL(dth_model_psi(m, z, &psi, NULL, w) == DTH_OK);
        double sc = fabs(z[N - 1]) + fabs(Hp);
        for (size_t j = 0; j < N - 1; j++) sc += fabs(g[j] * z[j]);
        dth_step_info sr, so;
        CU_ASSERT_EQUAL_FATAL(dth_integrator_step(ref, &sr), DTH_OK);
        CU_ASSERT_EQUAL_FATAL(dth_integrator_step(oth, &so), DTH_OK);
        if (want_mode && k > 0 && dth__band_mode(dth__integrator_core(oth)->band) != want_mode) other_mode++;
        double lam = sr.lambda, kappa = DBL_EPSILON * sc / (fabs(psi) * lam * lam / 8);
        if (k == 0) kappa = DBL_EPSILON; /* the exact first step of a midpoint start: no solve */
        double dl = fabs(so.lambda - lam) / fabs(lam), dz = 0;
        const double *zr = dth_integrator_vertex(ref), *zo = dth_integrator_vertex(oth);
        for (size_t j = 0; j < N; j++) dz = fmax(dz, fabs(zr[j] - zo[j]) / (1 + fabs(zr[j])));
        worst = fmax(worst, fmax(dl, dz) / kappa);
        if (dth_model_get_info(m)->autonomous) CU_ASSERT(zr[N - 1] == zo[N - 1]); /* wp bit for bit */
        if (k == steps - 1) {
            CU_ASSERT_EQUAL(dth_integrator_tangent(ref, Mr), DTH_OK);
            CU_ASSERT_EQUAL(dth_integrator_tangent(oth, Mo), DTH_OK);
            double mm = 0;
            for (size_t i = 0; i < N * N; i++) {
                tworst = fmax(tworst, fabs(Mr[i] - Mo[i]));
                mm = fmax(mm, fabs(Mr[i]));
            }
            tworst /= mm;
        }
    }
    printf("\n    %-8s n = %zu, %s%s vs dense: largest difference %.2f x the conditioning bound, tangent maps %.1e",
           dth_model_get_type(m)->name, n, dth_linsolve_name(ls),
           dth__integrator_core(oth)->band ? (dth__band_mode(dth__integrator_core(oth)->band) == 1 ? (band_lapack ? " (Schur, dpbtrf)" : " (Schur, LDL^T)") : " (LU)") : "",
           worst, tworst);
    CU_ASSERT(worst <= 4);
    CU_ASSERT(tworst <= 1e-11);
    CU_ASSERT_EQUAL(other_mode, 0);
    dth_integrator_free(ref);
    dth_integrator_free(oth);
    free(g), free(w), free(Mr), free(Mo), free(zc);
    return worst;
}

/* After one ordinary step: did the small path's last factorization take its Schur complement? */
static int schur_used(const dth_model *m, double h, dth_linsolve ls, const double *q, const double *p)
{
    dth_integrator *it = make(m, h, ls, q, p);
    CU_ASSERT_EQUAL(dth_integrator_step(it, NULL), DTH_OK); /* the exact first step */
    CU_ASSERT_EQUAL(dth_integrator_step(it, NULL), DTH_OK);
    int on = dth__integrator_core(it)->small_schur && dth__integrator_core(it)->ss.on;
    dth_integrator_free(it);
    return on;
}

static void test_small(void)
{
    dth_model *pen = model(&dth_model_pendulum, NULL, 0, 1);
    double q1 = 1.0, p1 = 0.3;
    compare(pen, 0.1, DTH_LINSOLVE_SMALL, &q1, &p1, 200, 0);
    compare(pen, 0.1, DTH_LINSOLVE_SMALL_LU, &q1, &p1, 200, 0);
    compare(pen, 0.1, DTH_LINSOLVE_AUTO, &q1, &p1, 50, 0);
    CU_ASSERT(schur_used(pen, 0.1, DTH_LINSOLVE_AUTO, &q1, &p1));
    CU_ASSERT(!schur_used(pen, 0.1, DTH_LINSOLVE_SMALL_LU, &q1, &p1));
    /* near the top with a large step (branch_check off: the roots taken are far out, lambda ~ 200)
     * K = 1 + (lambda^2/4) cos q is negative; from common vertices the Schur complement takes the
     * dense path's steps to a few ulps (below the conditioning bound's reach at this lambda) */
    {
        double qt = 3.0, pt = 1.2, zc[4], worst = 0;
        dth_integrator *r = make(pen, 1.0, DTH_LINSOLVE_DENSE, &qt, &pt), *o = make(pen, 1.0, DTH_LINSOLVE_SMALL, &qt, &pt);
        int neg = 0;
        for (int k = 0; k < 4; k++) {
            if (k > 0) {
                memcpy(zc, dth_integrator_vertex(r), sizeof zc);
                double lam = dth_integrator_lambda(r);
                CU_ASSERT_EQUAL_FATAL(dth_integrator_set_vertex(r, zc, lam), DTH_OK);
                CU_ASSERT_EQUAL_FATAL(dth_integrator_set_vertex(o, zc, lam), DTH_OK);
            }
            dth_step_info sr, so;
            CU_ASSERT_EQUAL_FATAL(dth_integrator_step(r, &sr), DTH_OK);
            CU_ASSERT_EQUAL_FATAL(dth_integrator_step(o, &so), DTH_OK);
            worst = fmax(worst, fabs(so.lambda - sr.lambda) / fabs(sr.lambda));
            neg += dth__integrator_core(o)->ss.on && dth__integrator_core(o)->ss.K[0] < 0;
        }
        printf("\n    pendulum near the top, K < 0 in %d steps: lambda up to %.0f agrees to %.1e", neg,
               dth_integrator_lambda(r), worst);
        CU_ASSERT(neg >= 2);
        CU_ASSERT(worst <= 16 * DBL_EPSILON);
        dth_integrator_free(r);
        dth_integrator_free(o);
    }
    dth_model_free(pen);
    /* Kepler 2-D (n = 2) and an inclined 3-D orbit (n = 3) */
    dth_model *k2 = model(&dth_model_kepler, NULL, 0, 2);
    double q2[2] = {0.4, 0}, p2[2] = {0, 2};
    compare(k2, 0.01, DTH_LINSOLVE_SMALL, q2, p2, 300, 0);
    compare(k2, 0.01, DTH_LINSOLVE_SMALL_LU, q2, p2, 300, 0);
    CU_ASSERT(schur_used(k2, 0.01, DTH_LINSOLVE_SMALL, q2, p2));
    dth_model_free(k2);
    dth_model *k3 = model(&dth_model_kepler, NULL, 0, 3);
    double q3[3] = {0.3, 0.1, 0.05}, p3[3] = {0.1, 1.6, 0.9};
    compare(k3, 0.01, DTH_LINSOLVE_SMALL, q3, p3, 300, 0);
    compare(k3, 0.01, DTH_LINSOLVE_SMALL_LU, q3, p3, 300, 0);
    CU_ASSERT(schur_used(k3, 0.01, DTH_LINSOLVE_SMALL, q3, p3));
    dth_model_free(k3);
    /* separable, T'' not diagonal: the small path factors the whole bordered matrix */
    dth_model *mm = model(&mass_type, NULL, 0, 2);
    double qm[2] = {0.7, -0.3}, pm[2] = {0.2, 0.5};
    compare(mm, 0.05, DTH_LINSOLVE_SMALL, qm, pm, 200, 0);
    CU_ASSERT(!schur_used(mm, 0.05, DTH_LINSOLVE_SMALL, qm, pm));
    dth_model_free(mm);
    /* the generic small LU (m = 5, not instantiated: non-autonomous) */
    dth_model *f = model(&test_forced_type, NULL, 0, 1);
    double qf = 0.5, pf = 0.2;
    compare(f, 0.05, DTH_LINSOLVE_SMALL, &qf, &pf, 200, 0);
    dth_model_free(f);
}

/* A chain in `dim` = 2 or 3 dimensions; `compress` scales the initial spacing (1: at rest length). */
static void chain_dim(size_t dim, size_t Np, double compress, double spring_k, dth_linsolve ls, double h, int steps,
                      int want_mode)
{
    char size[32], kk[32], dd[8];
    snprintf(size, sizeof size, "%zu", Np);
    snprintf(kk, sizeof kk, "%g", spring_k);
    snprintf(dd, sizeof dd, "%zu", dim);
    dth_kv kv[] = {{"preset", "chain"}, {"size", size}, {"dim", dd}, {"L", "1"}, {"k", kk}};
    dth_model *m = model(&dth_model_coupled, kv, 5, dim * Np);
    size_t n = dim * Np;
    double *q = calloc(n, sizeof *q), *p = calloc(n, sizeof *p);
    for (size_t i = 0; i < Np; i++) {
        q[dim * i] = compress * (double)i;
        q[dim * i + 1] = 0.05 * sin(3.0 * (double)i);
        p[dim * i] = 0.1 * cos(2.0 * (double)i);
        p[dim * i + 1] = 0.2 * sin(1.0 + (double)i);
        if (dim == 3) {
            q[dim * i + 2] = 0.04 * cos(5.0 * (double)i);
            p[dim * i + 2] = 0.15 * sin(2.0 + (double)i);
        }
    }
    compare(m, h, ls, q, p, steps, want_mode);
    free(q), free(p);
    dth_model_free(m);
}

static void chain(size_t Np, double compress, double spring_k, dth_linsolve ls, double h, int steps, int want_mode)
{
    chain_dim(2, Np, compress, spring_k, ls, h, steps, want_mode);
}

static void test_banded(void)
{
    /* the Schur complement K by Cholesky: the written-out LDL^T of K (half-bandwidth 3) */
    chain(10, 1.0, 1.0, DTH_LINSOLVE_BANDED, 0.05, 100, BAND_SCHUR_CHOL);
    band_lapack = 1;
    chain(10, 1.0, 1.0, DTH_LINSOLVE_BANDED, 0.05, 100, BAND_SCHUR_CHOL); /* LAPACK's dpbtrf */
    band_lapack = 0;
    /* half-bandwidth 5: the LDL^T's general loops */
    chain_dim(3, 8, 1.0, 1.0, DTH_LINSOLVE_BANDED, 0.05, 100, BAND_SCHUR_CHOL);
    chain(10, 1.0, 1.0, DTH_LINSOLVE_BANDED_LU, 0.05, 100, BAND_GENERAL); /* the banded LU of the whole matrix */
    chain(10, 1.0, 1.0, DTH_LINSOLVE_SMALL, 0.05, 30, 0); /* the written-out LU at m = 41 */
}

/* Compressed stiff springs and a large step make T''^-1 + (lambda^2/4) V'' indefinite: the
 * Schur path falls back to its banded LU, and still agrees. */
static void test_schur_indefinite(void)
{
    char err[256];
    dth_kv kv[] = {{"preset", "chain"}, {"size", "6"}, {"dim", "2"}, {"L", "1"}, {"k", "400"}};
    dth_model *m = NULL;
    CU_ASSERT_EQUAL_FATAL(dth_model_new(&dth_model_coupled, kv, 5, 12, NULL, &m, err, sizeof err), DTH_OK);
    double q[12], p[12];
    for (int i = 0; i < 6; i++) {
        q[2 * i] = 0.5 * i, q[2 * i + 1] = 0.01 * (i % 2);
        p[2 * i] = 0, p[2 * i + 1] = 0.1 * (i % 3);
    }
    dth_integrator *it = make(m, 0.15, DTH_LINSOLVE_BANDED, q, p);
    dth_step_info si;
    CU_ASSERT_EQUAL(dth_integrator_step(it, &si), DTH_OK);
    int rc = dth_integrator_step(it, &si);
    if (rc == DTH_OK) CU_ASSERT_EQUAL(dth__band_mode(dth__integrator_core(it)->band), BAND_SCHUR_LU);
    printf("\n    compressed stiff chain: step %s, banded mode %d (2: LU of the Schur complement)",
           dth_strerror(rc), dth__band_mode(dth__integrator_core(it)->band));
    CU_ASSERT_EQUAL(rc, DTH_OK);
    dth_integrator_free(it);
    compare(m, 0.15, DTH_LINSOLVE_BANDED, q, p, 3, 0); /* omega h = 3: the fourth step has no root */
    dth_model_free(m);
}

/* A NaN pivot: the written-out LU reports success and its solve gives NaN, within bounds (the
 * pivots after the NaN column are set: they used to be left as the caller's zeros, and the solve read
 * x[-1]; found by fuzz_integrator). */
static void test_nan_pivot(void)
{
    for (int m = 1; m <= 8; m++) {
        double *a = calloc((size_t)(m * m), sizeof *a), *b = calloc((size_t)m, sizeof *b);
        int *piv = calloc((size_t)m, sizeof *piv); /* zeros, as a fresh integrator's */
        for (int i = 0; i < m; i++) {
            a[i + i * m] = 1.0 + i;
            b[i] = 1.0;
        }
        a[0] = NAN;
        CU_ASSERT_EQUAL(dth__lu_factor(DTH_LINSOLVE_SMALL, m, a, piv), DTH_OK);
        for (int i = 0; i < m; i++) CU_ASSERT(piv[i] >= 1 && piv[i] <= m);
        CU_ASSERT_EQUAL(dth__lu_solve(DTH_LINSOLVE_SMALL, m, a, piv, 1, b), DTH_OK);
        CU_ASSERT(isnan(b[0]));
        free(a), free(b), free(piv);
    }
}

/* Forcing a path the model cannot use is refused up front. */
static void test_refusals(void)
{
    dth_model *pen = model(&dth_model_pendulum, NULL, 0, 1);
    dth_options o;
    dth_options_default(&o);
    dth_integrator *it = NULL;
    o.linsolve = DTH_LINSOLVE_BANDED;
    CU_ASSERT_EQUAL(dth_integrator_new(pen, &o, &it), DTH_EUNSUPPORTED);
    o.linsolve = (dth_linsolve)99;
    CU_ASSERT_EQUAL(dth_integrator_new(pen, &o, &it), DTH_EINVAL);
    CU_ASSERT_PTR_NULL(it);
    CU_ASSERT_STRING_EQUAL(dth_linsolve_name(DTH_LINSOLVE_BANDED_LU), "banded-lu");
    CU_ASSERT_STRING_EQUAL(dth_linsolve_name(DTH_LINSOLVE_SMALL_LU), "small-lu");
    CU_ASSERT_PTR_NULL(dth_linsolve_name((dth_linsolve)99));
    dth_model_free(pen);
}

static CU_TestInfo tests[] = {
    {"small path against LAPACK dense (n = 1, 2, 3, Schur and LU, non-autonomous)", test_small},
    {"banded paths against dense (chain)", test_banded},
    {"Schur complement not positive definite: LU fallback", test_schur_indefinite},
    {"paths a model cannot use are refused", test_refusals},
    {"a NaN pivot stays within bounds", test_nan_pivot},
    CU_TEST_INFO_NULL,
};

CU_SuiteInfo dth_test_suites[] = {
    {.pName = "linsolve", .pTests = tests},
    CU_SUITE_INFO_NULL,
};
