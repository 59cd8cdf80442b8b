/* SPDX-License-Identifier: MIT */
/*
 * The "prescribed" regularizer (paper, section 7): every step a kicked segment whose step is
 * lambda = arc/|u(zbar)|^alpha at its own midpoint. Checked: exact energy (wp bit-identical,
 * midpoints on H = 0) through psi = 0 crossings, the step law at the midpoint, time reversal
 * (round trips through many crossings), quadratic invariants (Kepler's L, the chain's momenta),
 * second-order phase of the rotating pendulum against the exact period, the kick's O(h^3) size,
 * and parameter checking.
 */
#include <float.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include "cu_main.h"
#include "dth/dth.h"
#include "test_util.h"

#define PI 3.14159265358979323846

typedef struct setup {
    dth_model *m;
    dth_regularizer *r;
    dth_integrator *it;
    size_t N;
} setup;

/* wp: the start's wp (a vertex start that does not solve for it), NAN: none */
static setup open_run_fin(const dth_model_type *t, const dth_kv *mkv, size_t nmkv, size_t n, const char *alpha,
                          const double *q0, const double *p0, double h, dth_start start, dth_finish finish, double wp)
{
    setup s = {0};
    char err[256];
    dth_kv kv = {"alpha", alpha};
    CU_ASSERT_FATAL(dth_model_new(t, mkv, nmkv, n, NULL, &s.m, err, sizeof err) == DTH_OK);
    CU_ASSERT_FATAL(dth_regularizer_new(&dth_reg_prescribed, &kv, 1, s.m, NULL, &s.r, err, sizeof err) == DTH_OK);
    dth_options o;
    dth_options_default(&o);
    o.h = h;
    o.start = start;
    o.finish = finish;
    o.has_wp = !isnan(wp);
    o.wp = o.has_wp ? wp : 0;
    o.regularizer = s.r;
    o.branch_check = 0; /* the ordinary step is only looked at, never kept */
    CU_ASSERT_FATAL(dth_integrator_new(s.m, &o, &s.it) == DTH_OK);
    CU_ASSERT_FATAL(dth_integrator_start(s.it, q0, p0, 0.0) == DTH_OK);
    s.N = dth_integrator_dim(s.it);
    return s;
}

static setup open_run_start(const dth_model_type *t, const dth_kv *mkv, size_t nmkv, size_t n, const char *alpha,
                            const double *q0, const double *p0, double h, dth_start start)
{
    return open_run_fin(t, mkv, nmkv, n, alpha, q0, p0, h, start, DTH_FINISH_COMPENSATED, NAN);
}

static setup open_run(const dth_model_type *t, const dth_kv *mkv, size_t nmkv, size_t n, const char *alpha,
                      const double *q0, const double *p0, double h)
{
    return open_run_start(t, mkv, nmkv, n, alpha, q0, p0, h, DTH_START_MIDPOINT);
}

static void close_run(setup *s)
{
    dth_integrator_free(s->it);
    dth_regularizer_free(s->r);
    dth_model_free(s->m);
}

/* |u| over (q, p) at y. */
static double speed(const dth_model *m, const double *y)
{
    size_t n = dth_model_dof(m);
    double H, g[32], s = 0;
    CU_ASSERT_FATAL(dth_model_eval(m, y, DTH_EVAL_H | DTH_EVAL_GRAD, &H, g, NULL) == DTH_OK);
    for (size_t i = 0; i < n; i++) s += g[i] * g[i] + g[n + 1 + i] * g[n + 1 + i];
    return sqrt(s);
}

/*
 * Forward S steps after the first, reverse, S back: relative distance to the start; counts the
 * crossings; checks every step on the way: wp bit-identical, midpoint on H = 0, the step law.
 * mismatched (NULL: not counted): the number of vertices on the way back that differ in any bit from
 * the vertex of the same index on the way out.
 */
static double round_trip_v(setup *s, long S, double alpha, long *crossings, long *mismatched)
{
    size_t N = s->N;
    dth_step_info inf;
    CU_ASSERT_FATAL(dth_integrator_step(s->it, &inf) == DTH_OK);
    double z0[32], wp0 = dth_integrator_vertex(s->it)[N - 1], arc = NAN, err = 0, nz = 0, law = 0, eu = 0;
    memcpy(z0, dth_integrator_vertex(s->it), N * sizeof *z0);
    double *out = mismatched ? malloc((size_t)(S + 1) * N * sizeof *out) : NULL;
    CU_ASSERT_FATAL(!mismatched || out);
    if (out) memcpy(out, z0, N * sizeof *out);
    if (mismatched) *mismatched = 0;
    *crossings = 0;
    int wp_ok = 1;
    for (int leg = 0; leg < 2; leg++) {
        for (long k = 0; k < S; k++) {
            int rc = dth_integrator_step(s->it, &inf);
            CU_ASSERT_EQUAL_FATAL(rc, DTH_OK);
            CU_ASSERT(inf.flags & DTH_STEP_REGULARIZED);
            if (!leg && (inf.flags & DTH_STEP_CROSSING)) ++*crossings;
            if (out && !leg) memcpy(out + (size_t)(k + 1) * N, dth_integrator_vertex(s->it), N * sizeof *out);
            if (out && leg && memcmp(out + (size_t)(S - 1 - k) * N, dth_integrator_vertex(s->it), N * sizeof *out))
                ++*mismatched;
            const double *zb = dth_integrator_midpoint(s->it);
            eu = fmax(eu, energy_ulps(s->m, zb));
            if (dth_integrator_vertex(s->it)[N - 1] != wp0) wp_ok = 0;
            /* the step law at the midpoint: lambda |u(zbar)|^alpha is the same constant */
            double a = fabs(inf.lambda) * pow(speed(s->m, zb), alpha);
            if (isnan(arc)) arc = a;
            law = fmax(law, fabs(a - arc) / arc);
        }
        if (!leg) dth_integrator_reverse(s->it);
    }
    CU_ASSERT(wp_ok);
    CU_ASSERT(eu <= 8);
    CU_ASSERT(law <= 1e-13);
    const double *z = dth_integrator_vertex(s->it);
    for (size_t j = 0; j < N; j++) {
        nz = fmax(nz, fabs(z0[j]));
        err = fmax(err, fabs(z[j] - z0[j]));
    }
    free(out);
    return err / nz;
}

static double round_trip(setup *s, long S, double alpha, long *crossings)
{
    return round_trip_v(s, S, alpha, crossings, NULL);
}

/* Rotating pendulum, alpha = 0: 2000 steps through >= 10 crossings and back to 1e-9. */
static void test_pendulum_round_trip(void)
{
    double q0 = 0, p0 = 2.2;
    /* a midpoint start (the arc from the exact first step) and a vertex start (no incoming step:
     * the first step takes the arc from the ordinary step's lambda, later ones skip it) */
    for (int v = 0; v < 2; v++) {
        setup s = open_run_start(&dth_model_pendulum, NULL, 0, 1, "0", &q0, &p0, 0.05,
                                 v ? DTH_START_VERTEX : DTH_START_MIDPOINT);
        long cr;
        double e = round_trip(&s, 2000, 0, &cr);
        CU_ASSERT(cr >= 10);
        CU_ASSERT(e <= 1e-9);
        close_run(&s);
    }
}

/* Kepler e = 0.9 from apocentre, alpha = 0.75: two orbits there and back; L exact throughout. */
static void test_kepler_round_trip_L(void)
{
    double e = 0.9, q0[2] = {-(1 + e), 0}, p0[2] = {0, -sqrt((1 - e) / (1 + e))};
    setup s = open_run(&dth_model_kepler, NULL, 0, 2, "0.75", q0, p0, 0.05);
    long cr;
    double rt = round_trip(&s, 1000, 0.75, &cr);
    CU_ASSERT(cr >= 8);
    CU_ASSERT(rt <= 1e-9);
    /* forward again (the vertex is not (q0, p0): midpoint start): L at every vertex to a few
     * ulps, through the crossings */
    dth_integrator_reverse(s.it);
    const double *z0 = dth_integrator_vertex(s.it);
    double L0 = z0[0] * z0[4] - z0[1] * z0[3], Lerr = 0;
    for (int k = 0; k < 1000; k++) {
        dth_step_info inf;
        CU_ASSERT_EQUAL_FATAL(dth_integrator_step(s.it, &inf), DTH_OK);
        const double *z = dth_integrator_vertex(s.it);
        Lerr = fmax(Lerr, fabs(z[0] * z[4] - z[1] * z[3] - L0) / fabs(L0));
    }
    CU_ASSERT(Lerr <= 1e-14);
    close_run(&s);
}

/* 2-D chain of 3 (k = 1, L = 1) started compressed: psi changes sign; round trip; momenta exact. */
static void test_chain(void)
{
    dth_kv mkv[] = {{"preset", "chain"}, {"size", "3"}, {"dim", "2"}, {"L", "1"}};
    double q0[6] = {0, 0, 0.5, 0, 1.0, 0}, p0[6] = {0, 1, 0, -2, 0, 1.5};
    setup s = open_run(&dth_model_coupled, mkv, 4, 6, "0", q0, p0, 0.02);
    long cr;
    double rt = round_trip(&s, 1000, 0, &cr);
    CU_ASSERT(cr >= 10);
    CU_ASSERT(rt <= 1e-9);
    /* forward 1000 steps more: linear momentum (px, py) and angular momentum at every vertex */
    dth_integrator_reverse(s.it);
    double P0[3], perr = 0;
    for (int k = 0; k <= 1000; k++) {
        dth_step_info inf;
        if (k) CU_ASSERT_EQUAL_FATAL(dth_integrator_step(s.it, &inf), DTH_OK);
        const double *z = dth_integrator_vertex(s.it), *p = z + 7;
        double P[3] = {0, 0, 0};
        for (int i = 0; i < 3; i++) {
            P[0] += p[2 * i];
            P[1] += p[2 * i + 1];
            P[2] += z[2 * i] * p[2 * i + 1] - z[2 * i + 1] * p[2 * i];
        }
        if (!k) memcpy(P0, P, sizeof P0);
        for (int j = 0; j < 3; j++) perr = fmax(perr, fabs(P[j] - P0[j]));
    }
    CU_ASSERT(fabs(P0[1] - 0.5) <= 1e-12 && fabs(P0[2]) > 0.1);
    CU_ASSERT(perr <= 1e-13);
    close_run(&s);
}

/*
 * The reversible finish (dth_options.finish = DTH_FINISH_REVERSIBLE, scene key integrator.reversible):
 * each segment is finished in double-double with the model, the kick and the step law read at the
 * coarsened midpoint (regularize.c, dth__kicked_law_rev), so that the segment back from its end finds
 * the same midpoint and the way back retraces every vertex of the way out bit for bit: the rotating
 * pendulum and Kepler e = 0.9 (alpha = 1, the scenes' orbits) through >= 100 crossings, the pendulum
 * over 2 x 20000 steps. The 2-D chain (its momenta projected out of the kick, kicks up to 6e-3 where
 * dH/dmu is small) returns to the last bit of its largest coordinate: there a segment's conditioning
 * amplifies the double-double resolution of the midpoints (about 2^-100) until, late on the way back,
 * a coordinate near 0 differs in its last bits. The compensated finish's distance on the same orbits
 * is printed beside it (round-off growth, 1e-13 to 1e-11).
 */
static void test_reversible_finish(void)
{
    double pq = 0, pp = 2.2, e = 0.9, kq[2] = {-(1 + e), 0}, kp[2] = {0, -sqrt((1 - e) / (1 + e))};
    dth_kv chain[] = {{"preset", "chain"}, {"size", "3"}, {"dim", "2"}, {"L", "1"}};
    double cq[6] = {0, 0, 0.5, 0, 1.0, 0}, cp[6] = {0, 1, 0, -2, 0, 1.5};
    struct {
        const char *name;
        const dth_model_type *t;
        const dth_kv *mkv;
        size_t nmkv, n;
        const char *alpha;
        const double *q, *p;
        double h;
        long S, min_cross;
        int exact; /* every vertex bit for bit (else: the end within 4 eps) */
        dth_start start; /* a vertex start with wp = -H + psi h^2/8 (no incoming step: the arc from the
                            ordinary step, which seeds the first segment) */
    } orb[] = {{"rotating pendulum, h = 0.05", &dth_model_pendulum, NULL, 0, 1, "0", &pq, &pp, 0.05, 4400, 100, 1, DTH_START_MIDPOINT},
               {"rotating pendulum, h = 0.05, long", &dth_model_pendulum, NULL, 0, 1, "0", &pq, &pp, 0.05, 20000, 450, 1, DTH_START_MIDPOINT},
               {"rotating pendulum, vertex start", &dth_model_pendulum, NULL, 0, 1, "0", &pq, &pp, 0.05, 2000, 40, 1, DTH_START_VERTEX},
               {"Kepler e = 0.9, alpha = 1, h = 0.05", &dth_model_kepler, NULL, 0, 2, "1", kq, kp, 0.05, 23000, 100, 1, DTH_START_MIDPOINT},
               {"2-D chain of 3, h = 0.02", &dth_model_coupled, chain, 4, 6, "0", cq, cp, 0.02, 1000, 20, 0, DTH_START_MIDPOINT}};
    for (size_t i = 0; i < sizeof orb / sizeof orb[0]; i++) {
        double rt[2];
        long cr[2], mism = -1;
        for (int f = 0; f < 2; f++) {
            setup s = open_run_fin(orb[i].t, orb[i].mkv, orb[i].nmkv, orb[i].n, orb[i].alpha, orb[i].q, orb[i].p, orb[i].h,
                                   orb[i].start, f ? DTH_FINISH_COMPENSATED : DTH_FINISH_REVERSIBLE,
                                   orb[i].start == DTH_START_VERTEX ? -(0.5 * pp * pp - 1) + pp * pp * 0.05 * 0.05 / 8 : NAN);
            rt[f] = round_trip_v(&s, orb[i].S, atof(orb[i].alpha), &cr[f], f ? NULL : &mism);
            close_run(&s);
        }
        printf("\n    %s, 2 x %ld steps, %ld crossings: reversible %.1e (%ld vertices differ), compensated %.1e",
               orb[i].name, orb[i].S, cr[0], rt[0], mism, rt[1]);
        CU_ASSERT(cr[0] >= orb[i].min_cross);
        CU_ASSERT(rt[0] <= 4 * DBL_EPSILON);
        if (orb[i].exact) {
            CU_ASSERT(rt[0] == 0);
            CU_ASSERT_EQUAL(mism, 0);
        }
    }
}

/* Under the reversible finish the kick is still projected off the quadratic invariants (the projector
 * continued from the coarse point to the midpoint): Kepler's L through pericentres as under the
 * compensated finish (test_kepler_round_trip_L); wp untouched, midpoints on H = 0. */
static void test_reversible_invariants(void)
{
    double e = 0.9, q0[2] = {-(1 + e), 0}, p0[2] = {0, -sqrt((1 - e) / (1 + e))};
    setup s = open_run_fin(&dth_model_kepler, NULL, 0, 2, "0.75", q0, p0, 0.05, DTH_START_MIDPOINT, DTH_FINISH_REVERSIBLE, NAN);
    const double *z0 = dth_integrator_vertex(s.it);
    double L0 = z0[0] * z0[4] - z0[1] * z0[3], Lerr = 0, wp0 = z0[5], eu = 0;
    int crossings = 0;
    for (int k = 0; k < 2000; k++) {
        dth_step_info inf;
        CU_ASSERT_EQUAL_FATAL(dth_integrator_step(s.it, &inf), DTH_OK);
        if (inf.flags & DTH_STEP_CROSSING) crossings++;
        const double *z = dth_integrator_vertex(s.it);
        Lerr = fmax(Lerr, fabs(z[0] * z[4] - z[1] * z[3] - L0) / fabs(L0));
        CU_ASSERT(z[5] == wp0);
        eu = fmax(eu, energy_ulps(s.m, dth_integrator_midpoint(s.it)));
    }
    printf("\n    Kepler e = 0.9, 2000 steps, %d crossings: |dL|/L %.1e, midpoint energy within %.1f ulps", crossings, Lerr, eu);
    CU_ASSERT(crossings >= 8);
    CU_ASSERT(Lerr <= 1e-14);
    CU_ASSERT(eu <= 8);
    close_run(&s);
}

/* Mean time per revolution over revolutions 1..R+1 (linear interpolation of t at q = 2 pi j). */
static double mean_period(double h, int R)
{
    double q0 = 0, p0 = 2.2, qa = 0, ta = 0, t1 = NAN, tR = NAN;
    setup s = open_run(&dth_model_pendulum, NULL, 0, 1, "0", &q0, &p0, h);
    for (int j = 1; j <= R + 1;) {
        dth_step_info inf;
        CU_ASSERT_EQUAL_FATAL(dth_integrator_step(s.it, &inf), DTH_OK);
        const double *z = dth_integrator_vertex(s.it);
        while (j <= R + 1 && z[0] >= 2 * PI * j) {
            double t = ta + (2 * PI * j - qa) / (z[0] - qa) * (z[1] - ta);
            if (j == 1) t1 = t;
            if (j == R + 1) tR = t;
            j++;
        }
        qa = z[0];
        ta = z[1];
    }
    close_run(&s);
    return (tR - t1) / R;
}

/*
 * Phase: the period error against the exact 2 K(k) k (k^2 = 2/(1 + E), E = p0^2/2 - 1; the
 * value below is GSL's gsl_sf_ellint_Kcomp) falls by 4 per halving of h.
 */
static void test_phase_order(void)
{
    const double T = 4.221680066865676;
    double e1 = mean_period(0.05, 20) - T, e2 = mean_period(0.025, 20) - T, e3 = mean_period(0.0125, 20) - T;
    double o1 = log2(e1 / e2), o2 = log2(e2 / e3);
    CU_ASSERT(fabs(o1 - 2) <= 0.05);
    CU_ASSERT(fabs(o2 - 2) <= 0.05);
    CU_ASSERT(fabs(e1) <= 2e-4);
}

/* The kick: mu = grad H . (z_b - z_a)/|grad H|^2 at the midpoint (no invariants) is O(h^3). */
static double max_kick(double h)
{
    double q0 = 0, p0 = 2.2, mx = 0;
    setup s = open_run(&dth_model_pendulum, NULL, 0, 1, "0", &q0, &p0, h);
    dth_step_info inf;
    CU_ASSERT_FATAL(dth_integrator_step(s.it, &inf) == DTH_OK);
    while (dth_integrator_vertex(s.it)[1] < 10) {
        double za[4], H, g[3];
        memcpy(za, dth_integrator_vertex(s.it), sizeof za);
        CU_ASSERT_EQUAL_FATAL(dth_integrator_step(s.it, &inf), DTH_OK);
        const double *zb = dth_integrator_vertex(s.it);
        CU_ASSERT_FATAL(dth_model_eval(s.m, dth_integrator_midpoint(s.it), DTH_EVAL_H | DTH_EVAL_GRAD, &H, g, NULL) == DTH_OK);
        mx = fmax(mx, fabs((g[0] * (zb[0] - za[0]) + g[2] * (zb[2] - za[2])) / (g[0] * g[0] + g[2] * g[2])));
    }
    close_run(&s);
    return mx;
}

static void test_kick_order(void)
{
    double k1 = max_kick(0.05), k2 = max_kick(0.025);
    CU_ASSERT(fabs(log2(k1 / k2) - 3) <= 0.1);
    CU_ASSERT(k1 > 0 && k1 <= 1e-4);
}

/*
 * Existence where it used to fail: Kepler e = 0.99, h = 0.0125, alpha = 0.75, a midpoint on the
 * first pericentre (t = pi). With L projected out of a Euclidean kick, H(zbar(mu)) had a minimum
 * above 0 there (dH/dmu = |n|^2/2 + (lambda/4) u^T H_zz n passed 0: at a pericentre grad H and
 * grad L are nearly parallel in the Euclidean metric). The kick's scaled metric (regularize.c,
 * kick_metric) makes them far from parallel: with fallback=no every step through 10 pericentres is
 * a kicked segment, wp is bit-identical and L is kept.
 */
static void test_segment_at_pericentre(void)
{
    double e = 0.99, q0[2] = {-(1 + e), 0}, p0[2] = {0, -sqrt((1 - e) / (1 + e))};
    dth_model *m = NULL;
    dth_regularizer *r = NULL;
    dth_integrator *it = NULL;
    char err[256], arc[64];
    CU_ASSERT_FATAL(dth_model_new(&dth_model_kepler, NULL, 0, 2, NULL, &m, err, sizeof err) == DTH_OK);
    dth_options o;
    dth_options_default(&o);
    o.h = 0.0125;
    /* the arc measured at the first vertex after the exact first step (the configuration in
     * which a midpoint lands on the first pericentre) */
    CU_ASSERT_FATAL(dth_integrator_new(m, &o, &it) == DTH_OK);
    CU_ASSERT_FATAL(dth_integrator_start(it, q0, p0, 0.0) == DTH_OK);
    CU_ASSERT_FATAL(dth_integrator_step(it, NULL) == DTH_OK);
    double g[5], H, I[4];
    CU_ASSERT_FATAL(dth_model_eval(m, dth_integrator_vertex(it), DTH_EVAL_GRAD, &H, g, NULL) == DTH_OK);
    snprintf(arc, sizeof arc, "%.17g", o.h * pow(sqrt(g[0] * g[0] + g[1] * g[1] + g[3] * g[3] + g[4] * g[4]), 0.75));
    dth_integrator_free(it);
    it = NULL;
    dth_kv kv[] = {{"alpha", "0.75"}, {"fallback", "no"}, {"arc", arc}};
    CU_ASSERT_FATAL(dth_regularizer_new(&dth_reg_prescribed, kv, 3, m, NULL, &r, err, sizeof err) == DTH_OK);
    o.regularizer = r;
    o.branch_check = 0;
    CU_ASSERT_FATAL(dth_integrator_new(m, &o, &it) == DTH_OK);
    CU_ASSERT_FATAL(dth_integrator_start(it, q0, p0, 0.0) == DTH_OK);
    double wp0 = dth_integrator_vertex(it)[5];
    CU_ASSERT_FATAL(dth_model_invariants(m, dth_integrator_vertex(it), I) == DTH_OK);
    double L0 = I[0], dL = 0;
    int peri = 0, crossings = 0;
    long k;
    for (k = 0; dth_integrator_vertex(it)[2] < 20 * PI; k++) {
        dth_step_info inf;
        int rc = dth_integrator_step(it, &inf);
        CU_ASSERT_EQUAL_FATAL(rc, DTH_OK);
        if (k > 0) CU_ASSERT_FATAL(inf.flags & DTH_STEP_REGULARIZED);
        if (inf.flags & DTH_STEP_CROSSING) crossings++;
        const double *z = dth_integrator_vertex(it);
        if (hypot(z[0], z[1]) < 0.02) peri = 1;
        CU_ASSERT_FATAL(dth_model_invariants(m, z, I) == DTH_OK);
        dL = fmax(dL, fabs(I[0] - L0));
    }
    CU_ASSERT(peri);
    CU_ASSERT(crossings >= 36); /* four per orbit */
    CU_ASSERT(dth_integrator_vertex(it)[5] == wp0);
    CU_ASSERT(dL <= 1e-15);
    dth_integrator_free(it);
    dth_regularizer_free(r);
    dth_model_free(m);
}

/*
 * Where no kicked segment can exist: the 1-D harmonic oscillator reports its energy as a
 * (quadratic) invariant, so projecting it out leaves no kick. fallback=no refuses at the first
 * replaced step with the state untouched; fallback=yes keeps every ordinary DTH step (energy
 * exact, the run carries on), each flagged DTH_STEP_ONEWAY (not reversible: the step back asks the
 * regularizer again, which takes its segment where one exists). Under both finishes.
 */
static void test_fallback(void)
{
    double q0 = 1, p0 = 0;
    for (int c = 0; c < 4; c++) {
        int fb = c & 1;
        dth_model *m = NULL;
        dth_regularizer *r = NULL;
        dth_integrator *it = NULL;
        char err[256];
        CU_ASSERT_FATAL(dth_model_new(&dth_model_harmonic, NULL, 0, 1, NULL, &m, err, sizeof err) == DTH_OK);
        dth_kv kv[] = {{"fallback", fb ? "yes" : "no"}};
        CU_ASSERT_FATAL(dth_regularizer_new(&dth_reg_prescribed, kv, 1, m, NULL, &r, err, sizeof err) == DTH_OK);
        dth_options o;
        dth_options_default(&o);
        o.h = 0.1;
        o.start = DTH_START_MIDPOINT;
        o.finish = c < 2 ? DTH_FINISH_COMPENSATED : DTH_FINISH_REVERSIBLE;
        o.regularizer = r;
        CU_ASSERT_FATAL(dth_integrator_new(m, &o, &it) == DTH_OK);
        CU_ASSERT_FATAL(dth_integrator_start(it, &q0, &p0, 0.0) == DTH_OK);
        CU_ASSERT_FATAL(dth_integrator_step(it, NULL) == DTH_OK); /* the exact first step */
        double z1[4], wp0 = dth_integrator_vertex(it)[3];
        int rc = DTH_OK, kept = 0, oneway = 0;
        for (int k = 0; k < 100 && !rc; k++) {
            dth_step_info inf;
            memcpy(z1, dth_integrator_vertex(it), sizeof z1);
            rc = dth_integrator_step(it, &inf);
            if (!rc && !(inf.flags & DTH_STEP_REGULARIZED)) kept++;
            /* a kept step is flagged: the step back from its end asks the regularizer again */
            if (!rc && !(inf.flags & DTH_STEP_REGULARIZED) && (inf.flags & DTH_STEP_ONEWAY)) oneway++;
            if (!rc && (inf.flags & DTH_STEP_REGULARIZED)) CU_ASSERT_EQUAL(inf.flags & DTH_STEP_NONREVERSIBLE, 0);
        }
        CU_ASSERT_EQUAL(oneway, kept);
        /* the first of these steps may be a kicked segment with mu = 0: seeded with the ordinary
         * step (the arc is fixed there, so the law gives the ordinary step's lambda), it already
         * solves the equations; later seeds do not, and Newton's mu column is zero */
        if (fb) {
            CU_ASSERT_EQUAL(rc, DTH_OK);
            CU_ASSERT(kept >= 99);
            CU_ASSERT(dth_integrator_vertex(it)[3] == wp0);
        } else {
            CU_ASSERT_EQUAL(rc, DTH_EREFUSED);
            CU_ASSERT(memcmp(z1, dth_integrator_vertex(it), sizeof z1) == 0);
            /* the message says why, and what may help */
            CU_ASSERT(strstr(dth_integrator_errmsg(it), "no kicked segment") != NULL);
            CU_ASSERT(strstr(dth_integrator_errmsg(it), "alpha") != NULL);
        }
        dth_integrator_free(it);
        dth_regularizer_free(r);
        dth_model_free(m);
    }
}

/* Parameters are checked; the type is registered under its name. */
static void test_params(void)
{
    dth_model *m = NULL;
    dth_regularizer *r = NULL;
    char err[256];
    CU_ASSERT_FATAL(dth_model_new(&dth_model_pendulum, NULL, 0, 1, NULL, &m, err, sizeof err) == DTH_OK);
    dth_kv bad[] = {{"alpha", "-1"}, {"arc", "0"}, {"band", "0.5"}, {"step", "1"}, {"fallback", "maybe"}};
    for (size_t i = 0; i < 5; i++) {
        CU_ASSERT_EQUAL(dth_regularizer_new(&dth_reg_prescribed, &bad[i], 1, m, NULL, &r, err, sizeof err), DTH_EINVAL);
        CU_ASSERT(r == NULL);
        CU_ASSERT(strstr(err, bad[i].key) != NULL);
    }
    dth_kv ok[] = {{"alpha", "1.5"}, {"arc", "0.01"}, {"fallback", "no"}};
    CU_ASSERT_EQUAL(dth_regularizer_new(&dth_reg_prescribed, ok, 3, m, NULL, &r, err, sizeof err), DTH_OK);
    dth_regularizer_free(r);
    dth_registry *reg = NULL;
    CU_ASSERT_FATAL(dth_registry_new(NULL, &reg) == DTH_OK);
    CU_ASSERT_FATAL(dth_registry_add_builtin(reg) == DTH_OK);
    CU_ASSERT(dth_registry_find_regularizer(reg, "prescribed") == &dth_reg_prescribed);
    dth_registry_free(reg);
    dth_model_free(m);
}

static CU_TestInfo tests[] = {
    {"pendulum: round trip through crossings, energy, step law", test_pendulum_round_trip},
    {"kepler e=0.9: round trip, L exact", test_kepler_round_trip_L},
    {"2-D chain: crossings, round trip, momenta", test_chain},
    {"reversible finish: round trips retrace every vertex", test_reversible_finish},
    {"reversible finish: L and energy kept", test_reversible_invariants},
    {"pendulum phase: second order", test_phase_order},
    {"kick is O(h^3)", test_kick_order},
    {"kepler e=0.99: a kicked segment at every step through pericentres", test_segment_at_pericentre},
    {"no kick possible (1-D harmonic): fallback keeps the ordinary step, or refuses", test_fallback},
    {"parameters and registry", test_params},
    CU_TEST_INFO_NULL,
};

CU_SuiteInfo dth_test_suites[] = {
    {.pName = "prescribed", .pTests = tests},
    CU_SUITE_INFO_NULL,
};
