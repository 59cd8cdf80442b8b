/* SPDX-License-Identifier: MIT */
/*
 * dth_integrator_tangent against a high-precision reference (paper, Theorem "DTH Equations": the
 * step is symplectic in extended phase space): from the vertex the library stepped from, the
 * step's derivative is formed by implicit differentiation in long double (80-bit) with long-double
 * models, at the library's own step and at the step re-solved in long double. The library's tangent
 * map must match the first to 1e-13, the second within the step's own conditioning, and be
 * symplectic (M^T J M = J) to 1e-13, on the pendulum, a 3-D inclined Kepler orbit and a
 * user-written Henon-Heiles model (docs/examples/henon_heiles.c).
 */
#include <float.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include "cu_main.h"
#include "dth/dth.h"
#include "dth_core.h"
#include "test_util.h"
#include "../docs/examples/henon_heiles.h"

enum { MAXN = 3, MAXZ = 2 * MAXN + 2, MAXM = 2 * MAXN + 1 };
typedef long double ld;

/* ---- long-double models over y = (q, t, p): H, gradient, Hessian (autonomous) ---- */

typedef void (*ld_model)(const ld *y, ld *H, ld *g, ld *h);

static void ld_pendulum(const ld *y, ld *H, ld *g, ld *h)
{
    ld q = y[0], p = y[2];
    *H = 0.5L * p * p - cosl(q);
    memset(g, 0, 3 * sizeof *g);
    memset(h, 0, 9 * sizeof *h);
    g[0] = sinl(q), g[2] = p;
    h[0] = cosl(q), h[8] = 1;
}

static void ld_kepler3(const ld *y, ld *H, ld *g, ld *h)
{
    const int n = 3, d = 7;
    const ld *q = y, *p = y + 4;
    ld r2 = q[0] * q[0] + q[1] * q[1] + q[2] * q[2], r = sqrtl(r2), r3 = r2 * r;
    *H = 0.5L * (p[0] * p[0] + p[1] * p[1] + p[2] * p[2]) - 1 / r;
    memset(g, 0, d * sizeof *g);
    memset(h, 0, d * d * sizeof *h);
    for (int i = 0; i < n; i++) {
        g[i] = q[i] / r3;
        g[4 + i] = p[i];
        for (int j = 0; j < n; j++) h[i * d + j] = (i == j ? 1 / r3 : 0) - 3 * q[i] * q[j] / (r3 * r2);
        h[(4 + i) * d + 4 + i] = 1;
    }
}

/* Henon-Heiles (the example user model, docs/examples/henon_heiles.c, at lambda = 1):
 * H = (px^2 + py^2)/2 + (x^2 + y^2)/2 + x^2 y - y^3/3 */
static void ld_henon(const ld *y, ld *H, ld *g, ld *h)
{
    ld x = y[0], yy = y[1], px = y[3], py = y[4];
    *H = 0.5L * (px * px + py * py) + 0.5L * (x * x + yy * yy) + x * x * yy - yy * yy * yy / 3;
    memset(g, 0, 5 * sizeof *g);
    memset(h, 0, 25 * sizeof *h);
    g[0] = x + 2 * x * yy, g[1] = yy + x * x - yy * yy, g[3] = px, g[4] = py;
    h[0] = 1 + 2 * yy, h[1] = h[5] = 2 * x, h[6] = 1 - 2 * yy, h[18] = h[24] = 1;
}

/* ---- the step and its derivative in long double ---- */

/* Dense LU solve with partial pivoting, row-major m x m, nrhs columns of b (m x nrhs row-major). */
static void ld_solve(int m, ld *A, int nrhs, ld *b)
{
    for (int k = 0; k < m; k++) {
        int p = k;
        for (int i = k + 1; i < m; i++)
            if (fabsl(A[i * m + k]) > fabsl(A[p * m + k])) p = i;
        for (int j = 0; j < m; j++) {
            ld t = A[k * m + j];
            A[k * m + j] = A[p * m + j], A[p * m + j] = t;
        }
        for (int j = 0; j < nrhs; j++) {
            ld t = b[k * nrhs + j];
            b[k * nrhs + j] = b[p * nrhs + j], b[p * nrhs + j] = t;
        }
        for (int i = k + 1; i < m; i++) {
            ld f = A[i * m + k] / A[k * m + k];
            for (int j = k; j < m; j++) A[i * m + j] -= f * A[k * m + j];
            for (int j = 0; j < nrhs; j++) b[i * nrhs + j] -= f * b[k * nrhs + j];
        }
    }
    for (int k = m - 1; k >= 0; k--)
        for (int j = 0; j < nrhs; j++) {
            ld s = b[k * nrhs + j];
            for (int l = k + 1; l < m; l++) s -= A[k * m + l] * b[l * nrhs + j];
            b[k * nrhs + j] = s / A[k * m + k];
        }
}

/* The bordered Jacobian over (d_q, d_p, lambda) at the midpoint with gradient g and Hessian h. */
static void ld_jacobian(int n, ld lam, const ld *g, const ld *h, ld *A)
{
    int d = 2 * n + 1, m = 2 * n + 1;
    memset(A, 0, (size_t)(m * m) * sizeof *A);
    for (int i = 0; i < n; i++) {
        for (int k = 0; k < n; k++) {
            A[i * m + k] = -0.5L * lam * h[(n + 1 + i) * d + k];
            A[i * m + n + k] = -0.5L * lam * h[(n + 1 + i) * d + n + 1 + k];
            A[(n + i) * m + k] = 0.5L * lam * h[i * d + k];
            A[(n + i) * m + n + k] = 0.5L * lam * h[i * d + n + 1 + k];
        }
        A[i * m + i] += 1, A[(n + i) * m + n + i] += 1;
        A[i * m + 2 * n] = -0.5L * g[n + 1 + i];
        A[(n + i) * m + 2 * n] = 0.5L * g[i];
        A[2 * n * m + i] = g[i];
        A[2 * n * m + n + i] = g[n + 1 + i];
    }
}

/*
 * From vertex z (long double), solve the step near (d0, lam0) and form M = dz_{k+1}/dz_k.
 * Returns 0 on convergence.
 */
static int ld_step_tangent(ld_model f, int n, const ld *z, const ld *d0, ld lam0, int solve, ld *M, ld *lam_out)
{
    int N = 2 * n + 2, d = 2 * n + 1, m = 2 * n + 1;
    ld x[MAXM], zb[MAXZ], H, g[MAXM], h[MAXM * MAXM], A[MAXM * MAXM], F[MAXM];
    for (int i = 0; i < n; i++) x[i] = d0[i], x[n + i] = d0[n + 1 + i];
    x[2 * n] = lam0;
    int it;
    ld r_prev = INFINITY, r_last = INFINITY;
    for (it = 0; solve && it < 50; it++) {
        for (int i = 0; i < n; i++) zb[i] = z[i] + x[i], zb[n + 1 + i] = z[n + 1 + i] + x[n + i];
        zb[n] = z[n] + 0.5L * x[2 * n], zb[N - 1] = z[N - 1];
        f(zb, &H, g, h);
        ld lam = x[2 * n];
        for (int i = 0; i < n; i++) F[i] = x[i] - 0.5L * lam * g[n + 1 + i], F[n + i] = x[n + i] + 0.5L * lam * g[i];
        F[2 * n] = zb[N - 1] + H;
        ld_jacobian(n, lam, g, h, A);
        ld_solve(m, A, 1, F);
        ld r = 0;
        for (int a = 0; a < m; a++) {
            x[a] -= F[a];
            r = fmaxl(r, fabsl(F[a]) / (1 + fabsl(x[a])));
        }
        /* lambda is fixed by a second-order effect: its correction stalls near eps_ld times
         * scale(H) / (psi lambda^2 / 8), far below double's eps */
        r_last = r;
        if (r < 1e-18L || (it >= 3 && r >= r_prev)) break;
        r_prev = r;
    }
    if (solve && (it == 50 || r_last > 1e-15L)) return 1;
    /* derivative at the solution: -A^-1 B, B = dF/dz_k */
    for (int i = 0; i < n; i++) zb[i] = z[i] + x[i], zb[n + 1 + i] = z[n + 1 + i] + x[n + i];
    zb[n] = z[n] + 0.5L * x[2 * n], zb[N - 1] = z[N - 1];
    f(zb, &H, g, h);
    ld lam = x[2 * n];
    *lam_out = lam;
    ld_jacobian(n, lam, g, h, A);
    ld B[MAXM * MAXZ];
    for (int l = 0; l < N; l++) {
        for (int i = 0; i < n; i++) {
            /* rows of -(lambda/2) J H_zz over z_k, negated: the right-hand side -B */
            B[i * N + l] = l < d ? 0.5L * lam * h[(n + 1 + i) * d + l] : 0;
            B[(n + i) * N + l] = l < d ? -0.5L * lam * h[i * d + l] : 0;
        }
        B[2 * n * N + l] = l == N - 1 ? -1 : (l < d ? -g[l] : 0);
    }
    ld_solve(m, A, N, B);
    memset(M, 0, (size_t)(N * N) * sizeof *M);
    for (int i = 0; i < N; i++) M[i * N + i] = 1;
    for (int i = 0; i < n; i++)
        for (int l = 0; l < N; l++) {
            M[i * N + l] += 2 * B[i * N + l];
            M[(n + 1 + i) * N + l] += 2 * B[(n + i) * N + l];
        }
    for (int l = 0; l < N; l++) M[n * N + l] += B[2 * n * N + l];
    return 0;
}

/*
 * Step `steps` times; at every `every`-th step compare the tangent map with two references:
 *  - at the library's own step (its converged midpoint and lambda, differentiated in long double):
 *    the tangent map of the step as taken, which must hold to 1e-13;
 *  - at the step re-solved in long double from the same vertex: the two differ by the step's own
 *    conditioning (lambda is fixed by a second-order effect, so the double step carries a relative
 *    error of about eps |grad H|^2 / (|psi| lambda) even with the compensated constraint), and the
 *    tangent maps differ by about that much; asserted within 1e-13 + 50 |dlambda / lambda|.
 */
static void check(const dth_model *m, ld_model f, const double *q0, const double *p0, double h, int steps, int every)
{
    int n = (int)dth_model_dof(m), N = 2 * n + 2;
    dth_options o;
    dth_options_default(&o);
    o.h = h;
    dth_integrator *it = NULL;
    CU_ASSERT_EQUAL_FATAL(dth_integrator_new(m, &o, &it), DTH_OK);
    CU_ASSERT_EQUAL_FATAL(dth_integrator_start(it, q0, p0, 0.0), DTH_OK);
    double M[MAXZ * MAXZ], worst = 0, wsym = 0, wre = 0, wlam = 0;
    ld Mr[MAXZ * MAXZ], zl[MAXZ], dl[MAXZ], lam_ld;
    for (int k = 0; k < steps; k++) {
        /* the vertex as the library holds it: a double-double sum */
        for (int j = 0; j < N; j++) zl[j] = (ld)dth__integrator_core(it)->st.z[j] + (ld)dth__integrator_core(it)->st.zlo[j];
        dth_step_info info;
        CU_ASSERT_EQUAL_FATAL(dth_integrator_step(it, &info), DTH_OK);
        if (k == 0 || k % every) continue;
        CU_ASSERT_EQUAL_FATAL(dth_integrator_tangent(it, M), DTH_OK);
        const double *zb = dth_integrator_midpoint(it);
        for (int j = 0; j < N; j++) dl[j] = (ld)zb[j] - zl[j];
        double mm = 0, e = 0, er = 0;
        for (int i = 0; i < N * N; i++) mm = fmax(mm, fabs(M[i]));
        /* at the library's own step */
        CU_ASSERT_EQUAL_FATAL(ld_step_tangent(f, n, zl, dl, info.lambda, 0, Mr, &lam_ld), 0);
        for (int i = 0; i < N * N; i++) e = fmax(e, fabs(M[i] - (double)Mr[i]));
        /* at the step re-solved in long double */
        CU_ASSERT_EQUAL_FATAL(ld_step_tangent(f, n, zl, dl, info.lambda, 1, Mr, &lam_ld), 0);
        for (int i = 0; i < N * N; i++) er = fmax(er, fabs(M[i] - (double)Mr[i]));
        double dlam = (double)fabsl((info.lambda - lam_ld) / lam_ld);
        CU_ASSERT(er / mm <= 1e-13 + 50 * dlam);
        worst = fmax(worst, e / mm);
        wre = fmax(wre, er / mm);
        wlam = fmax(wlam, dlam);
        wsym = fmax(wsym, symplectic_defect((size_t)n, M, 1) / (mm * mm));
    }
    printf("\n    %-12s h = %g: |M - M_ld| / |M| <= %.2e at its own step, %.2e at the re-solved step (|dlambda / lambda| "
           "<= %.1e); |M^T J M - J| / |M|^2 <= %.2e",
           dth_model_get_type(m)->name, h, worst, wre, wlam, wsym);
    CU_ASSERT(worst <= 1e-13);
    CU_ASSERT(wsym <= 1e-13);
    dth_integrator_free(it);
}

static void test_pendulum(void)
{
    dth_model *m = model(&dth_model_pendulum, NULL, 0, 1);
    double q = 1.2, p = 0.4;
    check(m, ld_pendulum, &q, &p, 0.1, 400, 7);
    check(m, ld_pendulum, &q, &p, 0.01, 2000, 37);
    dth_model_free(m);
}

static void test_kepler3(void)
{
    dth_model *m = model(&dth_model_kepler, NULL, 0, 3);
    /* e = 0.7, inclined */
    double e = 0.7, v = sqrt((1 + e) / (1 - e)), c = cos(0.5), s = sin(0.5);
    double q[3] = {1 - e, 0, 0}, p[3] = {0, v * c, v * s};
    check(m, ld_kepler3, q, p, 0.01, 3000, 29);
    dth_model_free(m);
}

static void test_henon(void)
{
    dth_model *m = model(&example_henon_heiles, NULL, 0, 2);
    double q[2] = {0.1, -0.2}, p[2] = {0.3, 0.25}; /* E ~ 0.1 */
    check(m, ld_henon, q, p, 0.05, 2000, 31);
    dth_model_free(m);
}

static CU_TestInfo tests[] = {
    {"pendulum: tangent map to 1e-13, symplectic to 1e-13", test_pendulum},
    {"3-D inclined Kepler e = 0.7", test_kepler3},
    {"Henon-Heiles (a user model)", test_henon},
    CU_TEST_INFO_NULL,
};

CU_SuiteInfo dth_test_suites[] = {
    {.pName = "tangent", .pTests = tests},
    CU_SUITE_INFO_NULL,
};
