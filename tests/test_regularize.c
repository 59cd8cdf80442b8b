/* SPDX-License-Identifier: MIT */
/*
 * Regularization across psi = 0 (paper, section 7): the cubic-model roots, the kicked segment
 * (midpoint on H = 0, exact time advance, reversal symmetry, quadratic invariants kept), the
 * registry, and raw DTH's fold at vertex 15 on the rotating pendulum (the regularizers have their
 * own suites: test_land, test_prescribed).
 */
#include <float.h>
#include <math.h>
#include <stdio.h>
#include <string.h>
#include "cu_main.h"
#include "dth/dth.h"
#include "dth_internal.h"
#include "test_util.h"

static dth_regularizer *regul(const dth_regularizer_type *t, const dth_kv *kv, size_t nkv, const dth_model *m)
{
    dth_regularizer *r = NULL;
    char err[256];
    if (dth_regularizer_new(t, kv, nkv, m, NULL, &r, err, sizeof err)) fprintf(stderr, "%s\n", err);
    return r;
}

/* The rotating pendulum of the notes: q0 = 0, p0 = 2.2, h = 0.05, vertex start with the notes' offset. */
static dth_integrator *pendulum_run(const dth_model *m, dth_regularizer *r)
{
    dth_options o;
    dth_options_default(&o);
    o.h = 0.05;
    o.start = DTH_START_VERTEX;
    o.has_wp = 1; /* the notes' Taylor offset wp = -H_phys + psi h^2/8 */
    o.wp = -(0.5 * 2.2 * 2.2 - 1) + 2.2 * 2.2 * 0.05 * 0.05 / 8;
    o.regularizer = r;
    dth_integrator *it = NULL;
    double q0 = 0, p0 = 2.2;
    CU_ASSERT_FATAL(dth_integrator_new(m, &o, &it) == DTH_OK);
    CU_ASSERT_FATAL(dth_integrator_start(it, &q0, &p0, 0.0) == DTH_OK);
    return it;
}

/* The cubic's root is a root, is on the asked side, and no smaller one exists there. */
static void test_cubic_root(void)
{
    struct { double H, psi, dpsi, side; } c[] = {
        {8.13e-4, 0.748, -4.31, 1}, {8.13e-4, 0.748, -4.31, -1}, {1e-3, 0.0, 2.0, 1},
        {-1e-3, -0.5, 1.0, 1}, {-1e-3, 0.5, -1.0, 1}, {2e-4, 1.0, 0.0, 1},
    };
    for (size_t i = 0; i < sizeof c / sizeof c[0]; i++) {
        double l = dth_cubic_root(c[i].H, c[i].psi, c[i].dpsi, c[i].side);
        double f = c[i].H - c[i].psi * l * l / 8 - c[i].dpsi * l * l * l / 24;
        CU_ASSERT(l * c[i].side > 0);
        CU_ASSERT(fabs(f) <= 1e-14 * (fabs(c[i].H) + 1e-300) * 10);
        /* no sign change of the cubic strictly between 0 and l */
        for (int k = 1; k < 1000; k++) {
            double x = l * k / 1000.0, fx = c[i].H - c[i].psi * x * x / 8 - c[i].dpsi * x * x * x / 24;
            CU_ASSERT(fx * c[i].H > 0);
            if (!(fx * c[i].H > 0)) break;
        }
    }
    /* all terms of one sign: no root on that side */
    CU_ASSERT_EQUAL(dth_cubic_root(-1e-3, 0.5, -1.0, -1), 0.0);
    /* H/psi < 0 with psi' = 0: no root on either side */
    CU_ASSERT_EQUAL(dth_cubic_root(-1e-3, 1.0, 0.0, 1), 0.0);
    CU_ASSERT_EQUAL(dth_cubic_root(-1e-3, 1.0, 0.0, -1), 0.0);
}

/* Kicked segment: midpoint on H = 0, t advances by lambda, wp untouched; the segment from the
 * end with -lambda has the same midpoint (reversal symmetry); Kepler's L exact. */
static void kicked_case(const dth_model_type *t, size_t n, const double *z, double lambda)
{
    dth_model *m = model(t, NULL, 0, n);
    CU_ASSERT_FATAL(m != NULL);
    size_t N = 2 * n + 2;
    double work[4096], d[8] = {0}, d2[8] = {0}, zb[8], zbar[8], zbar2[8], mu = 0, mu2 = 0, res;
    int iters;
    CU_ASSERT_FATAL(dth_kicked_segment_work_size(m) <= 4096);
    CU_ASSERT_FATAL(dth_kicked_segment(m, z, NULL, lambda, d, &mu, &res, &iters, work) == DTH_OK);
    for (size_t j = 0; j < N; j++) {
        zbar[j] = z[j] + d[j];
        zb[j] = z[j] + 2 * d[j];
    }
    CU_ASSERT(energy_ulps(m, zbar) <= 16);
    CU_ASSERT_EQUAL(d[N - 1], 0.0);
    CU_ASSERT(fabs(zb[n] - z[n] - lambda) <= 4 * DBL_EPSILON * (fabs(z[n]) + fabs(lambda)));
    CU_ASSERT(mu != 0); /* the vertex is off H = 0, so a kick is needed */
    CU_ASSERT_FATAL(dth_kicked_segment(m, zb, NULL, -lambda, d2, &mu2, &res, &iters, work) == DTH_OK);
    double err = 0, sc = 0;
    for (size_t j = 0; j < N; j++) {
        zbar2[j] = zb[j] + d2[j];
        err = fmax(err, fabs(zbar2[j] - zbar[j]));
        sc = fmax(sc, fabs(zbar[j]));
    }
    CU_ASSERT(err <= 1e-13 * sc);
    CU_ASSERT(fabs(mu2 + mu) <= 1e-9 * fabs(mu));
    if (t == &dth_model_kepler) {
        double La = z[0] * z[n + 2] - z[1] * z[n + 1], Lb = zb[0] * zb[n + 2] - zb[1] * zb[n + 1];
        CU_ASSERT(fabs(La - Lb) <= 64 * DBL_EPSILON * fabs(La));
    }
    dth_model_free(m);
}

static void test_kicked_segment(void)
{
    /* pendulum vertex near psi = 0 with a positive offset (wp chosen so H(z) = 1e-3) */
    double zp[4] = {1.9, 0.0, 1.3, 0};
    zp[3] = -(0.5 * 1.3 * 1.3 - cos(1.9)) + 1e-3;
    kicked_case(&dth_model_pendulum, 1, zp, 0.1);
    kicked_case(&dth_model_pendulum, 1, zp, -0.07);
    /* Kepler e = 0.9 orbit point, offset 1e-4 */
    double zk[6] = {-1.2, 0.3, 0.0, 0.2, -0.45, 0};
    double r = hypot(zk[0], zk[1]);
    zk[5] = -(0.5 * (zk[3] * zk[3] + zk[4] * zk[4]) - 1 / r) + 1e-4;
    kicked_case(&dth_model_kepler, 2, zk, 0.05);
}

/*
 * Which invariants the kicked segment projects out is decided once per model instance (a test at
 * the current point flipped the Runge-Lenz components in and out of the projection between two
 * Newton iterations, which then cycled: Kepler e = 0.9 at t = 1014 was refused). Kepler: L only
 * (not the Runge-Lenz vector or omega); a free 2-D chain: P_x, P_y and L; the harmonic
 * oscillator: every mode energy; the pendulum: none.
 */
static void test_quadratic_mask(void)
{
    char err[256];
    dth_model *m = NULL;
    CU_ASSERT_FATAL(dth_model_new(&dth_model_kepler, NULL, 0, 2, NULL, &m, err, sizeof err) == DTH_OK);
    CU_ASSERT_EQUAL(dth_model_n_invariants(m), 4);
    CU_ASSERT_EQUAL(dth__model_quad_mask(m), 1ull);
    dth_model_free(m);
    dth_kv ckv[] = {{"preset", "chain"}, {"size", "3"}, {"dim", "2"}, {"L", "1"}};
    CU_ASSERT_FATAL(dth_model_new(&dth_model_coupled, ckv, 4, 6, NULL, &m, err, sizeof err) == DTH_OK);
    CU_ASSERT_EQUAL(dth_model_n_invariants(m), 3);
    CU_ASSERT_EQUAL(dth__model_quad_mask(m), 7ull);
    dth_model_free(m);
    CU_ASSERT_FATAL(dth_model_new(&dth_model_harmonic, NULL, 0, 3, NULL, &m, err, sizeof err) == DTH_OK);
    CU_ASSERT_EQUAL(dth__model_quad_mask(m), 7ull);
    dth_model_free(m);
    CU_ASSERT_FATAL(dth_model_new(&dth_model_pendulum, NULL, 0, 1, NULL, &m, err, sizeof err) == DTH_OK);
    CU_ASSERT_EQUAL(dth__model_quad_mask(m), 0ull);
    dth_model_free(m);
}

static void test_registry(void)
{
    dth_registry *reg = NULL;
    CU_ASSERT_FATAL(dth_registry_new(NULL, &reg) == DTH_OK);
    CU_ASSERT_FATAL(dth_registry_add_builtin(reg) == DTH_OK);
    CU_ASSERT(dth_registry_regularizer_count(reg) >= 3);
    CU_ASSERT_PTR_EQUAL(dth_registry_find_regularizer(reg, "none"), &dth_reg_none);
    CU_ASSERT_PTR_EQUAL(dth_registry_find_regularizer(reg, "land"), &dth_reg_land);
    CU_ASSERT_PTR_NULL(dth_registry_find_regularizer(reg, "smooth")); /* retired (issue 23) */
    CU_ASSERT_PTR_EQUAL(dth_registry_find_regularizer(reg, "prescribed"), &dth_reg_prescribed);
    CU_ASSERT_PTR_NULL(dth_registry_find_regularizer(reg, "reseed")); /* retired */
    CU_ASSERT_PTR_NULL(dth_registry_find_regularizer(reg, "symkick"));
    CU_ASSERT_PTR_NULL(dth_registry_find_regularizer(reg, "nope"));
    CU_ASSERT_PTR_EQUAL(dth_registry_regularizer_at(reg, 0), &dth_reg_land); /* the default first */
    CU_ASSERT_PTR_NULL(dth_registry_regularizer_at(reg, 99));
    CU_ASSERT_EQUAL(dth_registry_add_regularizer(reg, &dth_reg_none), DTH_EINVAL); /* duplicate */
    dth_registry_free(reg);
    /* unknown and bad parameters name the key */
    dth_model *m = model(&dth_model_pendulum, NULL, 0, 1);
    dth_regularizer *r = NULL;
    char err[256] = "";
    dth_kv bad = {"nosuch", "1"}, badv = {"kappa", "-1"};
    CU_ASSERT_EQUAL(dth_regularizer_new(&dth_reg_land, &bad, 1, m, NULL, &r, err, sizeof err), DTH_EINVAL);
    CU_ASSERT_PTR_NOT_NULL(strstr(err, "nosuch"));
    CU_ASSERT_EQUAL(dth_regularizer_new(&dth_reg_land, &badv, 1, m, NULL, &r, err, sizeof err), DTH_EINVAL);
    CU_ASSERT_PTR_NOT_NULL(strstr(err, "kappa"));
    CU_ASSERT_PTR_NULL(r);
    dth_model_free(m);
}

/* none: raw DTH ends at vertex 15 with the branch status, state untouched. */
static void test_none_ends(void)
{
    dth_model *m = model(&dth_model_pendulum, NULL, 0, 1);
    dth_regularizer *r = regul(&dth_reg_none, NULL, 0, m);
    dth_integrator *it = pendulum_run(m, r);
    dth_step_info inf;
    int rc = DTH_OK;
    long k = 0;
    for (; k < 100 && rc == DTH_OK; k++) rc = dth_integrator_step(it, &inf);
    CU_ASSERT_EQUAL(k - 1, 15);
    CU_ASSERT(rc == DTH_EFOLD || rc == DTH_EGHOST || rc == DTH_ENEGOFFSET);
    double z[4];
    memcpy(z, dth_integrator_vertex(it), sizeof z);
    CU_ASSERT_EQUAL(dth_integrator_step(it, &inf), rc);
    CU_ASSERT(memcmp(z, dth_integrator_vertex(it), sizeof z) == 0);
    dth_integrator_free(it);
    dth_regularizer_free(r);
    dth_model_free(m);
}

static CU_TestInfo tests[] = {
    {"cubic-model roots", test_cubic_root},
    {"kicked segment: energy, time, reversal, L", test_kicked_segment},
    {"quadratic invariants: decided once per model", test_quadratic_mask},
    {"registry and parameters", test_registry},
    {"none ends at the fold (vertex 15)", test_none_ends},
    CU_TEST_INFO_NULL,
};

CU_SuiteInfo dth_test_suites[] = {
    {.pName = "regularize", .pTests = tests},
    CU_SUITE_INFO_NULL,
};
