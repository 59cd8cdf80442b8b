/* SPDX-License-Identifier: MIT */
/*
 * The reversible finish (dth_options.compensate = 2; paper, Theorem "DTH Equations": the step is its
 * own reverse): S steps forward, dth_integrator_reverse, S steps back must return to the start, in
 * q, p and t, to a few ulps; the compensated default and implicit midpoint on the same orbits are
 * printed beside it. The pendulum, Kepler e = 0.6 and the user-written Henon-Heiles model
 * (docs/examples/henon_heiles.c, whose hdiff is the library's quadrature rule: reversibility does not
 * rest on an exact energy difference). Also: the midpoint energy over 10^5 steps without the
 * compensated default's fallback, the tangent map, and the options it refuses.
 */
#include <float.h>
#include <math.h>
#include <stdio.h>
#include <string.h>
#include "cu_main.h"
#include "dth/dth.h"
#include "test_util.h"
#include "../docs/examples/henon_heiles.h"

enum { MAXZ = 8 };

typedef struct trip {
    double dz, dt; /* max |q, p - start| / max(|q0|, |p0|, 1), |t - t0| / span */
    int rc;
} trip;

/* S steps of DTH, reverse, S back: from the start vertex (through the midpoint start's constructed
 * first step) if from_start, else from the vertex after it; with linsolve (AUTO: the small path). */
static trip dth_trip_ls(const dth_model *m, const double *q0, const double *p0, double h, long S, int compensate,
                        dth_linsolve ls, int from_start)
{
    dth_options o;
    dth_options_default(&o);
    o.h = h;
    o.finish = (dth_finish)compensate;
    o.linsolve = ls;
    dth_integrator *it = NULL;
    trip r = {0, 0, 0};
    CU_ASSERT_EQUAL_FATAL(dth_integrator_new(m, &o, &it), DTH_OK);
    CU_ASSERT_EQUAL_FATAL(dth_integrator_start(it, q0, p0, 0.0), DTH_OK);
    dth_step_info inf;
    if (!from_start) r.rc = dth_integrator_step(it, &inf);
    size_t n = dth_model_dof(m), N = 2 * n + 2;
    double z0[MAXZ];
    memcpy(z0, dth_integrator_vertex(it), N * sizeof *z0);
    for (long k = 0; !r.rc && k < S; k++) r.rc = dth_integrator_step(it, &inf);
    double span = dth_integrator_vertex(it)[n] - z0[n];
    dth_integrator_reverse(it);
    for (long k = 0; !r.rc && k < S; k++) r.rc = dth_integrator_step(it, &inf);
    const double *z = dth_integrator_vertex(it);
    double sc = 1;
    for (size_t i = 0; i < n; i++) sc = fmax(sc, fmax(fabs(z0[i]), fabs(z0[n + 1 + i])));
    for (size_t i = 0; i < n; i++) r.dz = fmax(r.dz, fmax(fabs(z[i] - z0[i]), fabs(z[n + 1 + i] - z0[n + 1 + i])) / sc);
    r.dt = fabs(z[n] - z0[n]) / fabs(span);
    dth_integrator_free(it);
    return r;
}

static trip dth_trip(const dth_model *m, const double *q0, const double *p0, double h, long S, int compensate)
{
    return dth_trip_ls(m, q0, p0, h, S, compensate, DTH_LINSOLVE_AUTO, 0);
}

static double midpoint_trip(const dth_model *m, const double *q0, const double *p0, double h, long S)
{
    dth_integrator *f = NULL;
    dth_options o;
    dth_options_default(&o);
    o.method = "midpoint";
    o.h = h;
    CU_ASSERT_EQUAL_FATAL(dth_integrator_new(m, &o, &f), DTH_OK);
    CU_ASSERT_EQUAL_FATAL(dth_integrator_start(f, q0, p0, 0.0), DTH_OK);
    size_t n = dth_model_dof(m);
    double y0[MAXZ], d = 0, sc = 1;
    memcpy(y0, dth_integrator_vertex(f), (2 * n + 1) * sizeof *y0);
    for (long k = 0; k < S; k++) CU_ASSERT_EQUAL_FATAL(dth_integrator_step(f, NULL), DTH_OK);
    dth_integrator_reverse(f);
    for (long k = 0; k < S; k++) CU_ASSERT_EQUAL_FATAL(dth_integrator_step(f, NULL), DTH_OK);
    const double *y = dth_integrator_vertex(f);
    for (size_t i = 0; i < n; i++) sc = fmax(sc, fmax(fabs(y0[i]), fabs(y0[n + 1 + i])));
    for (size_t i = 0; i < n; i++) d = fmax(d, fmax(fabs(y[i] - y0[i]), fabs(y[n + 1 + i] - y0[n + 1 + i])) / sc);
    dth_integrator_free(f);
    return d;
}

/* Henon-Heiles at energy E from x = 0, y = y0, p_x = px (p_y > 0 from E). */
static void hh_start(double E, double y0, double px, double *q, double *p)
{
    q[0] = 0, q[1] = y0;
    p[0] = px;
    p[1] = sqrt(2 * (E - (0.5 * y0 * y0 - y0 * y0 * y0 / 3)) - px * px);
}

static void test_round_trips(void)
{
    dth_model *pen = model(&dth_model_pendulum, NULL, 0, 1);
    dth_model *kep = model(&dth_model_kepler, NULL, 0, 2);
    dth_model *hh = model(&example_henon_heiles, NULL, 0, 2);
    double pq = 1, pp = 0, kq[2] = {0.4, 0}, kp[2] = {0, 0}, hq[2], hp[2], hq2[2], hp2[2];
    kp[1] = sqrt(2 / kq[0] - 1); /* e = 0.6: pericentre r = 0.4 of a = 1, v^2 = 2/r - 1/a (mu = 1) */
    hh_start(1.0 / 12, 0.1, 0.35, hq, hp);
    hh_start(1.0 / 12, 0.1, 0.2, hq2, hp2);
    struct {
        const char *name;
        const dth_model *m;
        const double *q, *p;
        double h;
        long S;
    } orb[] = {{"pendulum, 1 rad, h = 0.05", pen, &pq, &pp, 0.05, 5000}, {"pendulum, 1 rad, h = 0.001", pen, &pq, &pp, 1e-3, 5000},
               {"Kepler e = 0.6, h = 0.01", kep, kq, kp, 0.01, 5000}, {"Henon-Heiles p_x = 0.35", hh, hq, hp, 0.05, 5000},
               {"Henon-Heiles p_x = 0.20", hh, hq2, hp2, 0.05, 5000}};
    for (size_t i = 0; i < sizeof orb / sizeof orb[0]; i++) {
        trip r = dth_trip(orb[i].m, orb[i].q, orb[i].p, orb[i].h, orb[i].S, 2);
        trip c = dth_trip(orb[i].m, orb[i].q, orb[i].p, orb[i].h, orb[i].S, 1);
        double im = midpoint_trip(orb[i].m, orb[i].q, orb[i].p, orb[i].h, orb[i].S);
        printf("\n    %s, %ld steps there and back: reversible %.1e (t %.1e), compensated %.1e, implicit midpoint %.1e",
               orb[i].name, orb[i].S, r.dz, r.dt, c.dz, im);
        CU_ASSERT_EQUAL(r.rc, DTH_OK);
        CU_ASSERT(r.dz <= 4 * DBL_EPSILON);
        CU_ASSERT(r.dt <= 4 * DBL_EPSILON);
    }
    /* the general dense path (LAPACK) and the small path's LU, from the start vertex through the
     * midpoint start's constructed first step */
    dth_linsolve lss[3] = {DTH_LINSOLVE_DENSE, DTH_LINSOLVE_SMALL_LU, DTH_LINSOLVE_SMALL};
    for (int i = 0; i < 3; i++) {
        trip a = dth_trip_ls(kep, kq, kp, 0.01, 3000, 2, lss[i], 1), b = dth_trip_ls(hh, hq, hp, 0.05, 3000, 2, lss[i], 1);
        printf("\n    linsolve %s, from the start vertex: Kepler %.1e, Henon-Heiles %.1e", dth_linsolve_name(lss[i]), a.dz, b.dz);
        CU_ASSERT(a.rc == DTH_OK && a.dz <= 4 * DBL_EPSILON && a.dt <= 4 * DBL_EPSILON);
        CU_ASSERT(b.rc == DTH_OK && b.dz <= 4 * DBL_EPSILON && b.dt <= 4 * DBL_EPSILON);
    }
    dth_model *fo = model(&test_forced_type, NULL, 0, 1);
    double fq = 1, fp = 0;
    trip f = dth_trip_ls(fo, &fq, &fp, 0.05, 3000, 2, DTH_LINSOLVE_AUTO, 1);
    printf("\n    forced oscillator (non-autonomous), from the start vertex: %.1e (t %.1e)", f.dz, f.dt);
    CU_ASSERT(f.rc == DTH_OK && f.dz <= 4 * DBL_EPSILON && f.dt <= 4 * DBL_EPSILON);
    dth_model_free(fo);
    dth_model_free(pen);
    dth_model_free(kep);
    dth_model_free(hh);
}

/* Without the compensated default's fallback to the direct value, the midpoint energy is the carried
 * offset's: its round-off walks (eps |grad H| |d| per step), within a few ulps of the terms over
 * 10^5 steps. */
static void test_energy(void)
{
    dth_model *m = model(&example_henon_heiles, NULL, 0, 2);
    double q[2], p[2];
    hh_start(1.0 / 12, 0.1, 0.35, q, p);
    dth_options o;
    dth_options_default(&o);
    o.h = 0.05;
    o.finish = (dth_finish)2;
    dth_integrator *it = NULL;
    CU_ASSERT_EQUAL_FATAL(dth_integrator_new(m, &o, &it), DTH_OK);
    CU_ASSERT_EQUAL_FATAL(dth_integrator_start(it, q, p, 0.0), DTH_OK);
    double worst = 0;
    dth_step_info inf;
    for (long k = 0; k < 100000; k++) {
        CU_ASSERT_EQUAL_FATAL(dth_integrator_step(it, &inf), DTH_OK);
        worst = fmax(worst, energy_ulps(m, dth_integrator_midpoint(it)));
    }
    printf("\n    Henon-Heiles, 10^5 steps: midpoint energy within %.1f ulps of its terms", worst);
    CU_ASSERT(worst <= 16);
    dth_integrator_free(it);
    dth_model_free(m);
}

/* The tangent map of a reversible step is symplectic as the default's. */
static void test_tangent(void)
{
    dth_model *m = model(&example_henon_heiles, NULL, 0, 2);
    double q[2], p[2], M[MAXZ * MAXZ], worst[3] = {0, 0, 0};
    hh_start(1.0 / 12, 0.1, 0.35, q, p);
    for (int c = 1; c <= 2; c++) {
        dth_options o;
        dth_options_default(&o);
        o.h = 0.05;
        o.finish = (dth_finish)c;
        dth_integrator *it = NULL;
        CU_ASSERT_EQUAL_FATAL(dth_integrator_new(m, &o, &it), DTH_OK);
        CU_ASSERT_EQUAL_FATAL(dth_integrator_start(it, q, p, 0.0), DTH_OK);
        for (int k = 0; k < 200; k++) {
            CU_ASSERT_EQUAL_FATAL(dth_integrator_step(it, NULL), DTH_OK);
            CU_ASSERT_EQUAL_FATAL(dth_integrator_tangent(it, M), DTH_OK);
            double nm = 0;
            for (int a = 0; a < 36; a++) nm = fmax(nm, fabs(M[a]));
            worst[c] = fmax(worst[c], symplectic_defect(2, M, 1) / (nm * nm));
        }
        dth_integrator_free(it);
    }
    printf("\n    symplectic defect / max|M|^2 of the tangent map over 200 steps: %.1e reversible, %.1e compensated",
           worst[2], worst[1]);
    CU_ASSERT(worst[2] <= 1e-13);
    dth_model_free(m);
}

static void test_refused(void)
{
    dth_kv kv[] = {{"preset", "chain"}, {"size", "10"}, {"dim", "1"}};
    dth_model *chain = model(&dth_model_coupled, kv, 3, 0);
    dth_options o;
    dth_options_default(&o);
    o.finish = (dth_finish)2;
    o.linsolve = DTH_LINSOLVE_BANDED; /* no dense Hessian to read the Taylor terms from */
    dth_integrator *it = NULL;
    CU_ASSERT_EQUAL(dth_integrator_new(chain, &o, &it), DTH_EUNSUPPORTED);
    CU_ASSERT_PTR_NULL(it);
    o.linsolve = DTH_LINSOLVE_DENSE;
    CU_ASSERT_EQUAL(dth_integrator_new(chain, &o, &it), DTH_OK);
    dth_integrator_free(it);
    it = NULL;
    o.finish = (dth_finish)3;
    CU_ASSERT_EQUAL(dth_integrator_new(chain, &o, &it), DTH_EINVAL);
    o.finish = (dth_finish)-1;
    CU_ASSERT_EQUAL(dth_integrator_new(chain, &o, &it), DTH_EINVAL);
    dth_model_free(chain);
}

/* The vertices a driver run samples: how many arrived by a step flagged DTH_STEP_NONREVERSIBLE. */
typedef struct flag_count {
    long nonrev, vertices;
} flag_count;

static int count_flags(void *user, const dth_sample *s)
{
    flag_count *f = user;
    /* each leg's last vertex comes as its END sample */
    if (!(s->kind == DTH_SAMPLE_VERTEX || (s->kind == DTH_SAMPLE_END && !s->za)) || s->k == 0) return 0;
    f->vertices++;
    if (s->step->flags & DTH_STEP_NONREVERSIBLE) f->nonrev++;
    return 0;
}

/*
 * The run driver's round trip as dth run --roundtrip does it (S steps, dth_integrator_reverse, on to
 * vertex 2 S) from the start vertex: its distance to the start over the largest |q|, |p|, with the
 * driver's count of non-reversible steps (dth_run_state.nonreversible, both legs) against the steps'
 * flags, and the crossings of the way out.
 */
static double driver_trip(const dth_model *m, const dth_regularizer_type *rt, const dth_kv *kv, size_t nkv, double q0,
                          double p0, long S, dth_finish fin, dth_run_state *st, long *flagged, long *crossings)
{
    char err[256];
    dth_regularizer *r = NULL;
    CU_ASSERT_FATAL(dth_regularizer_new(rt, kv, nkv, m, NULL, &r, err, sizeof err) == DTH_OK);
    dth_options o;
    dth_options_default(&o);
    o.h = 0.05;
    o.finish = fin;
    o.regularizer = r;
    dth_integrator *it = NULL;
    CU_ASSERT_FATAL(dth_integrator_new(m, &o, &it) == DTH_OK);
    CU_ASSERT_FATAL(dth_integrator_start(it, &q0, &p0, 0.0) == DTH_OK);
    double z0[4];
    memcpy(z0, dth_integrator_vertex(it), sizeof z0);
    flag_count f = {0, 0};
    dth_run_config c;
    dth_run_config_default(&c);
    c.steps = S;
    c.points = DTH_POINTS_VERTICES;
    c.sample = count_flags;
    c.user = &f;
    dth_run_state_init(st);
    CU_ASSERT_EQUAL_FATAL(dth_run(it, &c, st), DTH_OK);
    *crossings = st->crossings;
    dth_integrator_reverse(it);
    c.steps = 2 * S;
    st->k0 = S;
    st->t_stop = st->t;
    CU_ASSERT_EQUAL_FATAL(dth_run(it, &c, st), DTH_OK);
    const double *z = dth_integrator_vertex(it);
    double e = fmax(fabs(z[0] - z0[0]), fabs(z[2] - z0[2])) / fmax(fabs(z0[0]), fabs(z0[2]));
    *flagged = f.nonrev;
    CU_ASSERT_EQUAL(f.vertices, 2 * S);
    dth_integrator_free(it);
    dth_regularizer_free(r);
    return e;
}

/*
 * Reversibility stated per run (issue 23 item 4): the driver counts the steps that are not their own
 * reverse, exactly the steps flagged so. `prescribed` under the reversible finish takes none, and its
 * round trip through >= 100 crossings of the rotating pendulum returns exactly, also from the start
 * vertex (the midpoint start's exact first step obeys its constant step law); under the compensated
 * finish to round-off. `land` resets the offset at each crossing and corrects the clock near it: those
 * steps are counted, and its round trip does not return. `prescribed` on the 1-D oscillator, where no
 * kicked segment exists (its energy is a quadratic invariant), keeps ordinary steps (fallback = yes):
 * counted too.
 */
static void test_driver_counts(void)
{
    dth_model *pen = model(&dth_model_pendulum, NULL, 0, 1), *har = model(&dth_model_harmonic, NULL, 0, 1);
    dth_kv a0[] = {{"alpha", "0"}};
    dth_run_state st;
    long fl, cr;
    double e = driver_trip(pen, &dth_reg_prescribed, a0, 1, 0, 2.2, 4400, DTH_FINISH_REVERSIBLE, &st, &fl, &cr);
    printf("\n    prescribed, reversible finish, rotating pendulum 2 x 4400 steps from the start vertex (%ld crossings out): "
           "%.1e, %ld non-reversible", cr, e, st.nonreversible);
    CU_ASSERT(cr >= 100);
    CU_ASSERT(e == 0);
    CU_ASSERT_EQUAL(st.nonreversible, 0);
    CU_ASSERT_EQUAL(fl, 0);
    e = driver_trip(pen, &dth_reg_prescribed, a0, 1, 0, 2.2, 4400, DTH_FINISH_COMPENSATED, &st, &fl, &cr);
    printf("\n    prescribed, compensated finish, the same: %.1e, %ld non-reversible", e, st.nonreversible);
    CU_ASSERT(e <= 1e-12);
    CU_ASSERT_EQUAL(st.nonreversible, 0);
    for (int f = 1; f <= 2; f++) {
        e = driver_trip(pen, &dth_reg_land, NULL, 0, 0, 2.2, 127, (dth_finish)f, &st, &fl, &cr);
        printf("\n    land, %s finish, rotating pendulum 2 x 127 steps (%ld crossings out): %.1e, %ld non-reversible "
               "(%ld flagged)", dth_finish_name((dth_finish)f), cr, e, st.nonreversible, fl);
        CU_ASSERT(st.nonreversible >= cr && st.nonreversible == fl);
        CU_ASSERT(e > 1e-6);
    }
    e = driver_trip(har, &dth_reg_prescribed, NULL, 0, 1, 0, 100, DTH_FINISH_REVERSIBLE, &st, &fl, &cr);
    printf("\n    prescribed on the 1-D oscillator (no kicked segment: fallback): %ld of 200 steps non-reversible (%ld "
           "flagged), round trip %.1e", st.nonreversible, fl, e);
    CU_ASSERT(st.nonreversible >= 190 && st.nonreversible == fl);
    dth_model_free(pen);
    dth_model_free(har);
}

static CU_TestInfo reversible_tests[] = {
    {"round trips return to the start", test_round_trips},
    {"midpoint energy over 10^5 steps", test_energy},
    {"tangent map symplectic", test_tangent},
    {"banded solvers and other values refused", test_refused},
    {"the driver counts the steps that are not their own reverse", test_driver_counts},
    CU_TEST_INFO_NULL,
};

CU_SuiteInfo dth_test_suites[] = {{"reversible", NULL, NULL, NULL, NULL, reversible_tests}, CU_SUITE_INFO_NULL};
