/* SPDX-License-Identifier: MIT */
/*
 * MEGNO and the Lyapunov estimate (chaos.h) from the DTH tangent map: the product of the tangent
 * maps must match the separation of two actually integrated trajectories (finite differences of
 * the whole run, central differences); on the harmonic oscillator MEGNO tends to 0 for a deviation
 * along the orbit's own scaling (q, t, p, wp) -> (c q, t, c p, c^2 wp) (H scales by c^2, so the
 * scaled orbit takes the same steps and the deviation stays bounded) and to 2 for a generic one (a change of the vertex
 * offset changes the steps and so the numerical frequency: shear); it tends to 2 on a pendulum
 * libration and a regular Henon-Heiles orbit (linear growth) and grows on a chaotic Henon-Heiles
 * orbit (E = 1/6); a regularizer's step ends the indicators.
 */
#include <math.h>
#include <stdlib.h>
#include <stdio.h>
#include <string.h>
#include "cu_main.h"
#include "dth/dth.h"
#include "test_util.h"
#include "../docs/examples/henon_heiles.h"

/* Run `steps` steps (or to t_end > 0) with MEGNO updated after every step; the indicators into r. */
static void follow(const dth_model *m, const double *q, const double *p, double h, double t_end,
                   dth_regularizer *reg, int scaling, dth_megno_result *r)
{
    dth_options o;
    dth_options_default(&o);
    o.h = h;
    o.regularizer = reg;
    dth_integrator *it = NULL;
    dth_megno *g = NULL;
    CU_ASSERT_EQUAL_FATAL(dth_integrator_new(m, &o, &it), DTH_OK);
    CU_ASSERT_EQUAL_FATAL(dth_integrator_start(it, q, p, 0), DTH_OK);
    size_t n = dth_model_dof(m), N = 2 * n + 2;
    double d[8] = {0};
    memcpy(d, dth_integrator_vertex(it), N * sizeof *d);
    d[n] = 0; /* scaling: delta = d/dc (c q, t, c p, c^2 wp) at c = 1 */
    d[N - 1] *= 2;
    CU_ASSERT_EQUAL_FATAL(dth_megno_new(it, scaling ? d : NULL, NULL, &g), DTH_OK);
    while (dth_integrator_vertex(it)[n] < t_end) {
        dth_step_info info;
        int rc = dth_integrator_step(it, &info);
        CU_ASSERT_EQUAL_FATAL(rc, DTH_OK);
        CU_ASSERT_EQUAL_FATAL(dth_megno_update(g, it), DTH_OK);
        dth_megno_result r0, r1;
        dth_megno_get(g, &r0);
        CU_ASSERT_EQUAL(dth_megno_update(g, it), DTH_OK); /* no new step: nothing happens */
        dth_megno_get(g, &r1);
        CU_ASSERT(r1.steps == r0.steps && memcmp(&r1.megno, &r0.megno, sizeof r0.megno) == 0);
    }
    dth_megno_get(g, r);
    dth_megno_free(g);
    dth_integrator_free(it);
}

/* The tangent product against two integrated trajectories from vertices eps delta0 apart. */
static void test_against_trajectories(void)
{
    dth_model *m = model(&dth_model_pendulum, NULL, 0, 1);
    dth_options o;
    dth_options_default(&o);
    o.h = 0.05;
    o.start = DTH_START_VERTEX;
    dth_integrator *a = NULL, *b = NULL, *c = NULL;
    dth_megno *g = NULL;
    double q = 1, p = 0;
    CU_ASSERT_EQUAL_FATAL(dth_integrator_new(m, &o, &a), DTH_OK);
    CU_ASSERT_EQUAL_FATAL(dth_integrator_new(m, &o, &b), DTH_OK);
    CU_ASSERT_EQUAL_FATAL(dth_integrator_new(m, &o, &c), DTH_OK);
    CU_ASSERT_EQUAL_FATAL(dth_integrator_start(a, &q, &p, 0), DTH_OK);
    /* the same vertex through set_vertex for all three (b, c at +-eps delta), so their histories agree */
    double z0[4], z[4], d[4] = {0.6, 0, 0.8, 0}, eps = 1e-8;
    memcpy(z0, dth_integrator_vertex(a), sizeof z0);
    CU_ASSERT_EQUAL_FATAL(dth_integrator_set_vertex(a, z0, 0.05), DTH_OK);
    for (int i = 0; i < 4; i++) z[i] = z0[i] + eps * d[i];
    CU_ASSERT_EQUAL_FATAL(dth_integrator_set_vertex(b, z, 0.05), DTH_OK);
    for (int i = 0; i < 4; i++) z[i] = z0[i] - eps * d[i];
    CU_ASSERT_EQUAL_FATAL(dth_integrator_set_vertex(c, z, 0.05), DTH_OK);
    CU_ASSERT_EQUAL_FATAL(dth_megno_new(a, d, NULL, &g), DTH_OK);
    double dn = sqrt(d[0] * d[0] + d[2] * d[2] + d[3] * d[3]);
    for (int k = 0; k < 4000; k++) {
        dth_step_info ia, ib, ic;
        CU_ASSERT_EQUAL_FATAL(dth_integrator_step(a, &ia), DTH_OK);
        CU_ASSERT_EQUAL_FATAL(dth_integrator_step(b, &ib), DTH_OK);
        CU_ASSERT_EQUAL_FATAL(dth_integrator_step(c, &ic), DTH_OK);
        CU_ASSERT_EQUAL_FATAL(dth_megno_update(g, a), DTH_OK);
    }
    dth_megno_result r;
    dth_megno_get(g, &r);
    const double *zb = dth_integrator_vertex(b), *zc = dth_integrator_vertex(c);
    double s = 0;
    for (int i = 0; i < 4; i++) s += (zb[i] - zc[i]) * (zb[i] - zc[i]);
    double grow_fd = sqrt(s) / (2 * eps * dn), grow_tan = exp(r.lyapunov * r.span);
    printf("\n    pendulum, 4000 steps: |delta(t)|/|delta(0)| tangent %.8g, trajectories %.8g (rel. %.2e)\n",
           grow_tan, grow_fd, fabs(grow_tan / grow_fd - 1));
    CU_ASSERT_EQUAL(r.steps, 4000);
    CU_ASSERT(isnan(r.t_stop));
    CU_ASSERT(grow_fd > 10); /* the shear made it grow */
    CU_ASSERT(fabs(grow_tan / grow_fd - 1) < 1e-6);
    /* a missed step is refused */
    dth_step_info info;
    CU_ASSERT_EQUAL(dth_integrator_step(a, &info), DTH_OK);
    CU_ASSERT_EQUAL(dth_integrator_step(a, &info), DTH_OK);
    CU_ASSERT_EQUAL(dth_megno_update(g, a), DTH_EINVAL);
    dth_megno_free(g);
    dth_integrator_free(a);
    dth_integrator_free(b);
    dth_integrator_free(c);
    dth_model_free(m);
}

static void test_harmonic_and_pendulum(void)
{
    dth_megno_result r;
    dth_model *m = model(&dth_model_harmonic, NULL, 0, 1);
    double q = 1, p = 0.3;
    follow(m, &q, &p, 0.05, 2000, NULL, 1, &r);
    printf("\n    harmonic: MEGNO %.3g along the scaling, ", r.megno);
    CU_ASSERT(fabs(r.megno) < 0.01);
    CU_ASSERT(fabs(r.lyapunov) < 1e-3);
    follow(m, &q, &p, 0.05, 2000, NULL, 0, &r);
    printf("%.4f for a generic deviation; ", r.megno);
    CU_ASSERT(fabs(r.megno - 2) < 0.02);
    dth_model_free(m);
    m = model(&dth_model_pendulum, NULL, 0, 1);
    q = 2, p = 0;
    follow(m, &q, &p, 0.05, 2000, NULL, 0, &r);
    printf("pendulum libration q0 = 2: MEGNO %.4f\n", r.megno);
    CU_ASSERT(fabs(r.megno - 2) < 0.02);
    dth_model_free(m);
}

static void hh_initial(double E, double q2, double *q, double *p)
{
    q[0] = 0, q[1] = q2;
    p[0] = sqrt(2 * E - q2 * q2 + 2 * q2 * q2 * q2 / 3), p[1] = 0;
}

static void test_henon_heiles(void)
{
    dth_model *m = model(&example_henon_heiles, NULL, 0, 2);
    double q[2], p[2];
    dth_megno_result reg, cha;
    hh_initial(1.0 / 12, 0.1, q, p);
    follow(m, q, p, 0.05, 1000, NULL, 0, &reg);
    hh_initial(1.0 / 6, -0.1, q, p);
    follow(m, q, p, 0.05, 1000, NULL, 0, &cha);
    printf("\n    Henon-Heiles t = 1000: regular E = 1/12 MEGNO %.4f (Lyapunov %.4f), chaotic E = 1/6 MEGNO %.2f "
           "(Lyapunov %.4f)\n", reg.megno, reg.lyapunov, cha.megno, cha.lyapunov);
    CU_ASSERT(fabs(reg.megno - 2) < 0.02);
    CU_ASSERT(cha.megno > 20);
    CU_ASSERT(cha.lyapunov > 0.05);
    CU_ASSERT(reg.lyapunov < 0.02);
    dth_model_free(m);
}

static void test_regularized_step_ends_it(void)
{
    dth_model *m = model(&dth_model_pendulum, NULL, 0, 1);
    dth_regularizer *rg = NULL;
    char err[256];
    CU_ASSERT_EQUAL_FATAL(dth_regularizer_new(&dth_reg_land, NULL, 0, m, NULL, &rg, err, sizeof err), DTH_OK);
    double q = 0, p = 2.2; /* rotation: psi = 0 is crossed every half turn */
    dth_megno_result r;
    follow(m, &q, &p, 0.05, 20, rg, 0, &r);
    CU_ASSERT(!isnan(r.t_stop));
    CU_ASSERT(r.t_stop > 0 && r.t_stop < 3);
    CU_ASSERT(fabs(r.span - r.t_stop) < 0.06); /* a midpoint start's first vertex is h/2 before t = 0 */
    CU_ASSERT(r.steps > 0 && r.steps < 100);
    dth_regularizer_free(rg);
    dth_model_free(m);
}

static void test_arguments(void)
{
    dth_model *m = model(&dth_model_pendulum, NULL, 0, 1);
    dth_options o;
    dth_options_default(&o);
    dth_integrator *it = NULL;
    dth_megno *g = NULL;
    double q = 1, p = 0, zero[4] = {0, 0, 0, 0}, bad[4] = {NAN, 1, 0, 0};
    CU_ASSERT_EQUAL_FATAL(dth_integrator_new(m, &o, &it), DTH_OK);
    CU_ASSERT_EQUAL_FATAL(dth_integrator_start(it, &q, &p, 0), DTH_OK);
    CU_ASSERT_EQUAL(dth_megno_new(it, zero, NULL, &g), DTH_EINVAL);
    CU_ASSERT_EQUAL(dth_megno_new(it, bad, NULL, &g), DTH_EINVAL);
    CU_ASSERT_EQUAL(dth_megno_new(NULL, NULL, NULL, &g), DTH_EINVAL);
    CU_ASSERT_EQUAL(dth_megno_update(NULL, it), DTH_EINVAL);
    /* a vector of the wrong length (2 values for 2n+2 = 4) is refused before a value is read: on the
     * heap, so that a sanitizer build (scripts/ci-sanitize.sh) sees any read past it */
    double *two = malloc(2 * sizeof *two);
    CU_ASSERT_FATAL(two != NULL);
    two[0] = 1, two[1] = 2;
    CU_ASSERT_EQUAL(dth_megno_new_len(it, two, 2, NULL, &g), DTH_EINVAL);
    CU_ASSERT_EQUAL(dth_megno_new_len(it, NULL, 4, NULL, &g), DTH_EINVAL);
    CU_ASSERT_EQUAL(dth_megno_new_len(NULL, two, 2, NULL, &g), DTH_EINVAL);
    free(two);
    double four[4] = {1, 0, 0.5, 0};
    CU_ASSERT_EQUAL_FATAL(dth_megno_new_len(it, four, 4, NULL, &g), DTH_OK);
    dth_megno_free(g);
    CU_ASSERT_EQUAL_FATAL(dth_megno_new_len(it, NULL, 0, NULL, &g), DTH_OK);
    dth_megno_free(g);
    CU_ASSERT_EQUAL_FATAL(dth_megno_new(it, NULL, NULL, &g), DTH_OK);
    dth_megno_result r;
    dth_megno_get(g, &r);
    CU_ASSERT(isnan(r.megno) && r.steps == 0);
    dth_megno_free(g);
    dth_megno_free(NULL);
    dth_integrator_free(it);
    dth_model_free(m);
}

static CU_TestInfo chaos_tests[] = {
    {"tangent product = separation of integrated trajectories", test_against_trajectories},
    {"MEGNO: harmonic 0, pendulum libration 2", test_harmonic_and_pendulum},
    {"MEGNO: Henon-Heiles regular 2, chaotic grows", test_henon_heiles},
    {"a regularizer's step ends the indicators", test_regularized_step_ends_it},
    {"arguments", test_arguments},
    CU_TEST_INFO_NULL,
};

CU_SuiteInfo dth_test_suites[] = {{"chaos", NULL, NULL, NULL, NULL, chaos_tests}, CU_SUITE_INFO_NULL};
