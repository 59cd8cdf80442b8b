/* SPDX-License-Identifier: MIT */
/*
 * The default regularizer "smooth" (paper, section 7; regularize/smooth.c) against what
 * `dth regularizers` claims for it: ordinary DTH steps (bit for bit, symplectic tangent map)
 * wherever the changeover weight vanishes; energy-exact midpoints and wp untouched through every
 * crossing; quadratic invariants kept; the run never ends at psi = 0; the step pinned at every
 * crossing (no drift); a share of non-symplectic steps that falls linearly with h; smooth steps at
 * band edges; its parameters checked with messages naming the key.
 */
#include <float.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include "cu_main.h"
#include "dth/dth.h"
#include "failing_alloc.h"
#include "test_util.h"

static int no_branch_check; /* test_branch_check_off sets it */

static dth_integrator *start(const dth_model *m, dth_regularizer *r, double h, const double *q0, const double *p0)
{
    dth_options o;
    dth_options_default(&o);
    o.h = h;
    o.branch_check = !no_branch_check;
    o.regularizer = r;
    dth_integrator *it = NULL;
    CU_ASSERT_FATAL(dth_integrator_new(m, &o, &it) == DTH_OK);
    CU_ASSERT_FATAL(dth_integrator_start(it, q0, p0, 0.0) == DTH_OK);
    return it;
}

/* Away from psi = 0 (a libration of 1 rad: psi > 0.7), every step is raw DTH's, bit for bit. */
static void test_ordinary_bit_identical(void)
{
    dth_model *m = model(&dth_model_pendulum, NULL, 0, 1);
    char err[256];
    dth_regularizer *r = NULL;
    CU_ASSERT_FATAL(dth_regularizer_new(&dth_reg_smooth, NULL, 0, m, NULL, &r, err, sizeof err) == DTH_OK);
    double q0 = 1, p0 = 0;
    dth_integrator *a = start(m, r, 0.05, &q0, &p0), *b = start(m, NULL, 0.05, &q0, &p0);
    int same = 1;
    for (int k = 0; k < 5000 && same; k++) {
        dth_step_info ia, ib;
        CU_ASSERT_FATAL(dth_integrator_step(a, &ia) == DTH_OK);
        CU_ASSERT_FATAL(dth_integrator_step(b, &ib) == DTH_OK);
        CU_ASSERT_EQUAL(ia.flags & DTH_STEP_REGULARIZED, 0u);
        same = !memcmp(dth_integrator_vertex(a), dth_integrator_vertex(b), 4 * sizeof(double));
    }
    CU_ASSERT(same);
    dth_integrator_free(a);
    dth_integrator_free(b);
    dth_regularizer_free(r);
    dth_model_free(m);
}

typedef struct pend_stats {
    int rc;
    long steps, reg, crossings;
    double worst_ulps, tangent, tangent_abs, edge_ratio, med_first, med_last, mean_first, mean_last, t;
    int wp_same, tangent_refused;
} pend_stats;

static int cmp(const void *x, const void *y)
{
    double a = *(const double *)x, b = *(const double *)y;
    return (a > b) - (a < b);
}

/* The rotating pendulum (q0 = 0, p0 = 2.2, midpoint start) through `revs` revolutions. */
static pend_stats rotating(double h, double revs, int check_tangent)
{
    pend_stats s = {0};
    dth_model *m = model(&dth_model_pendulum, NULL, 0, 1);
    char err[256];
    dth_regularizer *r = NULL;
    CU_ASSERT_FATAL(dth_regularizer_new(&dth_reg_smooth, NULL, 0, m, NULL, &r, err, sizeof err) == DTH_OK);
    double q0 = 0, p0 = 2.2, T = 4.2216800668656;
    dth_integrator *it = start(m, r, h, &q0, &p0);
    double wp0 = dth_integrator_vertex(it)[3], lprev = 0, M[16];
    size_t cap = (size_t)(revs * T / h * 1.2) + 64, nf = 0, nl = 0;
    double *first = malloc(cap * sizeof *first), *last = malloc(cap * sizeof *last);
    int prev_reg = -1;
    s.wp_same = 1;
    while (dth_integrator_vertex(it)[1] < revs * T) {
        dth_step_info inf;
        s.rc = dth_integrator_step(it, &inf);
        if (s.rc) break;
        const double *z = dth_integrator_vertex(it);
        int reg = (inf.flags & DTH_STEP_REGULARIZED) != 0;
        s.steps++;
        s.reg += reg;
        s.crossings += (inf.flags & DTH_STEP_CROSSING) != 0;
        s.worst_ulps = fmax(s.worst_ulps, energy_ulps(m, dth_integrator_midpoint(it)));
        s.wp_same &= z[3] == wp0;
        if (prev_reg >= 0 && prev_reg != reg) {
            double q = inf.lambda / lprev;
            s.edge_ratio = fmax(s.edge_ratio, q < 1 ? 1 / q : q);
        }
        prev_reg = reg;
        lprev = inf.lambda;
        if (z[1] < 10 * T && nf < cap) first[nf++] = inf.lambda, s.mean_first += inf.lambda;
        if (z[1] > (revs - 10) * T && nl < cap) last[nl++] = inf.lambda, s.mean_last += inf.lambda;
        if (check_tangent) {
            int trc = dth_integrator_tangent(it, M);
            if (reg) s.tangent_refused += trc == DTH_EINVAL;
            else if (trc == DTH_OK) {
                /* |M^T J M - J| / |M|^2 over the extended z (4 x 4) */
                double mm = 0, dmax = symplectic_defect(1, M, 0);
                for (int k = 0; k < 16; k++) mm = fmax(mm, fabs(M[k]));
                s.tangent = fmax(s.tangent, dmax / (mm * mm));
                s.tangent_abs = fmax(s.tangent_abs, dmax);
            } else {
                s.tangent = INFINITY;
            }
        }
    }
    s.t = dth_integrator_vertex(it)[1];
    qsort(first, nf, sizeof *first, cmp);
    qsort(last, nl, sizeof *last, cmp);
    s.med_first = nf ? first[nf / 2] : NAN;
    s.med_last = nl ? last[nl / 2] : NAN;
    s.mean_first /= (double)nf;
    s.mean_last /= (double)nl;
    free(first);
    free(last);
    dth_integrator_free(it);
    dth_regularizer_free(r);
    dth_model_free(m);
    return s;
}

/*
 * The rotating pendulum through 400 crossings at h = 0.05: no refusal, every midpoint on H = 0 to
 * 16 ulps of its terms, wp bit for bit, the tangent map of every ordinary step symplectic
 * (|M^T J M - J| <= 1e-13 |M|^2 and <= 1e-10; refused for the changeover steps, which have none),
 * band edges with step ratios <= 1.25, and no drift of the step (it is pinned at every crossing):
 * over the last 10 revolutions its median is within 5 % and its mean within 1 % of the first 10's
 * (a single revolution's median jumps by +-3.5 % with the pattern of steps around the crossings,
 * so windows of 10 are compared). Raw DTH stops at the first crossing.
 */
static void test_rotating_pendulum(void)
{
    pend_stats s = rotating(0.05, 200, 1);
    CU_ASSERT_EQUAL(s.rc, DTH_OK);
    CU_ASSERT(s.crossings >= 400);
    CU_ASSERT(s.worst_ulps <= 16);
    CU_ASSERT(s.wp_same);
    CU_ASSERT(s.tangent <= 1e-13);
    CU_ASSERT(s.tangent_abs <= 1e-10);
    CU_ASSERT_EQUAL(s.tangent_refused, s.reg);
    CU_ASSERT(s.edge_ratio <= 1.25);
    CU_ASSERT(fabs(s.med_last / s.med_first - 1) <= 0.05);
    CU_ASSERT(fabs(s.mean_last / s.mean_first - 1) <= 0.01);
    printf("\n    h = 0.05: %ld steps, %ld crossings, %.1f %% changeover steps, %.1f ulps, tangent defect %.1e, "
           "edge ratio %.3f, median step %.5f -> %.5f, mean %.5f -> %.5f",
           s.steps, s.crossings, 100.0 * (double)s.reg / (double)s.steps, s.worst_ulps, s.tangent, s.edge_ratio,
           s.med_first, s.med_last, s.mean_first, s.mean_last);
}

/* The share of non-symplectic steps is <= 25 % at h = 0.05 and falls at least linearly with h (the
 * band spans a fixed number of steps around each crossing). */
static void test_share_linear(void)
{
    double share[3], hs[3] = {0.05, 0.025, 0.0125};
    for (int i = 0; i < 3; i++) {
        pend_stats s = rotating(hs[i], 20, 0);
        CU_ASSERT_EQUAL(s.rc, DTH_OK);
        share[i] = (double)s.reg / (double)s.steps;
    }
    printf("\n    changeover share %.3f, %.3f, %.3f at h = 0.05, 0.025, 0.0125", share[0], share[1], share[2]);
    CU_ASSERT(share[0] <= 0.25);
    CU_ASSERT(share[1] <= 0.55 * share[0]);
    CU_ASSERT(share[2] <= 0.55 * share[1]);
}

/* Without the branch policy (branch_check = 0) no ghost root slips through: smooth admits an ordinary
 * step only within a factor 2 of its law's step (a ghost root is many times larger), so the run is
 * the same kind of run: no refusal, smooth band edges, the mean step pinned. */
static void test_branch_check_off(void)
{
    no_branch_check = 1;
    pend_stats s = rotating(0.05, 100, 0);
    no_branch_check = 0;
    CU_ASSERT_EQUAL(s.rc, DTH_OK);
    CU_ASSERT(s.crossings >= 200);
    CU_ASSERT(s.edge_ratio <= 1.25);
    CU_ASSERT(fabs(s.mean_last / s.mean_first - 1) <= 0.01);
    printf("\n    branch_check = 0: %ld crossings, mean step %.5f -> %.5f", s.crossings, s.mean_first, s.mean_last);
}

/* Kepler e = 0.9 from apocentre (psi changes sign four times per orbit): 5 orbits, L exact at the
 * vertices (kicks are projected off grad L), midpoints on H = 0. */
static void test_kepler(void)
{
    dth_model *m = model(&dth_model_kepler, NULL, 0, 2);
    char err[256];
    dth_regularizer *r = NULL;
    CU_ASSERT_FATAL(dth_regularizer_new(&dth_reg_smooth, NULL, 0, m, NULL, &r, err, sizeof err) == DTH_OK);
    double e = 0.9, q0[2] = {-(1 + e), 0}, p0[2] = {0, -sqrt((1 - e) / (1 + e))};
    dth_integrator *it = start(m, r, 0.01, q0, p0);
    const double *z = dth_integrator_vertex(it);
    double L0 = z[0] * z[4] - z[1] * z[3], worst = 0, Lerr = 0;
    long crossings = 0, reg = 0;
    int rc = DTH_OK;
    while (z[2] < 5 * 2 * 3.14159265358979 && !rc) {
        dth_step_info inf;
        rc = dth_integrator_step(it, &inf);
        if (rc) break;
        z = dth_integrator_vertex(it);
        crossings += (inf.flags & DTH_STEP_CROSSING) != 0;
        reg += (inf.flags & DTH_STEP_REGULARIZED) != 0;
        worst = fmax(worst, energy_ulps(m, dth_integrator_midpoint(it)));
        Lerr = fmax(Lerr, fabs(z[0] * z[4] - z[1] * z[3] - L0) / fabs(L0));
    }
    CU_ASSERT_EQUAL(rc, DTH_OK);
    CU_ASSERT(crossings >= 20);
    CU_ASSERT(reg > 0);
    CU_ASSERT(worst <= 16);
    CU_ASSERT(Lerr <= 1e-13);
    printf("\n    Kepler e = 0.9: %ld crossings, %ld changeover steps, %.1f ulps, L to %.1e", crossings, reg, worst, Lerr);
    dth_integrator_free(it);
    dth_regularizer_free(r);
    dth_model_free(m);
}

/* A region II fold with psi > 0 (not a crossing): the stretched 3-D ring of 5 springs of
 * scenes/coupled-ring5-3d-stretched.ini. Raw DTH stops at step 85 (psi = 1.03, psi' = -72.6: the
 * physical root meets the ghost); smooth carries it and the later crossings to t = 30 with Lz exact. */
static void test_region_two_fold(void)
{
    char err[256];
    dth_kv kv[] = {{"preset", "ring"}, {"size", "5"}, {"dim", "3"}};
    dth_model *m = NULL;
    CU_ASSERT_FATAL(dth_model_new(&dth_model_coupled, kv, 3, 15, NULL, &m, err, sizeof err) == DTH_OK);
    double q[15] = {2.000000, 0.000000, 0.000000, 0.618034, 1.902113, -0.058779, -1.618034, 1.175571, 0.095106,
                    -1.618034, -1.175571, -0.095106, 0.618034, -1.902113, 0.058779};
    double p[15] = {0, 0, 0.2, 0.05, 0, -0.161803, 0.1, 0, 0.061803, 0.15, 0, 0.061803, 0.2, 0, -0.161803};
    for (int reg = 0; reg < 2; reg++) {
        dth_regularizer *r = NULL;
        if (reg) CU_ASSERT_FATAL(dth_regularizer_new(&dth_reg_smooth, NULL, 0, m, NULL, &r, err, sizeof err) == DTH_OK);
        dth_integrator *it = start(m, r, 0.02, q, p);
        double I0[6], I[6], worst = 0;
        CU_ASSERT_FATAL(dth_model_n_invariants(m) == 6);
        dth_model_invariants(m, dth_integrator_vertex(it), I0);
        long k = 0, nreg = 0;
        int rc = DTH_OK;
        while (dth_integrator_vertex(it)[15] < 30) {
            dth_step_info inf;
            rc = dth_integrator_step(it, &inf);
            if (rc) break;
            k++;
            nreg += (inf.flags & DTH_STEP_REGULARIZED) != 0;
            dth_model_invariants(m, dth_integrator_vertex(it), I);
            worst = fmax(worst, fabs(I[5] - I0[5]));
        }
        if (!reg) {
            CU_ASSERT_EQUAL(rc, DTH_EFOLD);
            CU_ASSERT_EQUAL(k, 85);
        } else {
            CU_ASSERT_EQUAL(rc, DTH_OK);
            CU_ASSERT(nreg > 0);
            CU_ASSERT(worst <= 1e-13);
            printf("\n    stretched ring: raw DTH stops at k = 85, smooth runs to t = 30 (%ld steps, %ld in bands, Lz to %.1e)",
                   k, nreg, worst);
        }
        dth_integrator_free(it);
        dth_regularizer_free(r);
    }
    dth_model_free(m);
}

/* The step law, computed independently of regularize/smooth.c: the root l of
 * l^6 sqrt(psi^4 + (psi' l)^4) = K, by bisection on log l. */
static double law_step(double K, double psi, double dpsi)
{
    double lo = -60, hi = 20;
    for (int k = 0; k < 200; k++) {
        double mid = 0.5 * (lo + hi), l = exp(mid);
        double f = pow(l, 6) * sqrt(pow(psi, 4) + pow(dpsi * l, 4)) - K;
        if (f > 0) hi = mid;
        else lo = mid;
    }
    return exp(0.5 * (lo + hi));
}

/*
 * The options do what `dth regularizers` says: where the midpoint is within `inner` law steps of the
 * crossing (x = |psi/psi'| / l <= inner) and the step starts there too, the step is the law's,
 * l^6 psi_e^2 = K, with K from the first step it is offered (the second step of a midpoint start: the
 * exact first step bypasses the hook; its midpoint taken as the vertices' average) or `invariant`;
 * a wider `outer` widens the bands.
 */
static void test_options(void)
{
    dth_model *m = model(&dth_model_pendulum, NULL, 0, 1);
    double q0 = 0, p0 = 2.2, h = 0.05, work[64];
    CU_ASSERT_FATAL(dth_model_work_size(m) <= 64);
    /* K0 about that of the first step (midpoint (q0, p0), step h): the scale of `invariant` below */
    double y0[4] = {q0, 0, p0, -(0.5 * p0 * p0 - 1)}, psi0, dpsi0;
    CU_ASSERT_FATAL(dth_model_psi(m, y0, &psi0, &dpsi0, work) == DTH_OK);
    double K0 = pow(h, 6) * sqrt(pow(psi0, 4) + pow(dpsi0 * h, 4));
    char kbuf[64];
    snprintf(kbuf, sizeof kbuf, "%.17g", 64 * K0);
    struct {
        dth_kv kv[2];
        size_t n;
        double K;
    } cfg[] = {{{{"outer", "3.2"}}, 1, K0}, {{{"invariant", kbuf}}, 1, 64 * K0}};
    double mean_law[2] = {0, 0};
    for (int c = 0; c < 2; c++) {
        char err[256];
        dth_regularizer *r = NULL;
        CU_ASSERT_FATAL(dth_regularizer_new(&dth_reg_smooth, cfg[c].kv, cfg[c].n, m, NULL, &r, err, sizeof err) == DTH_OK);
        dth_integrator *it = start(m, r, h, &q0, &p0);
        double zprev[4], worst = 0, sum = 0, K = cfg[c].K;
        long nlaw = 0, k = 0;
        memcpy(zprev, dth_integrator_vertex(it), sizeof zprev);
        while (dth_integrator_vertex(it)[1] < 40) {
            dth_step_info inf;
            CU_ASSERT_FATAL(dth_integrator_step(it, &inf) == DTH_OK);
            if (++k == 2 && !strcmp(cfg[c].kv[0].key, "outer")) {
                /* the default K: from the second step, at the average of its vertices */
                double ym[4], ps, dps;
                for (int j = 0; j < 4; j++) ym[j] = 0.5 * (zprev[j] + dth_integrator_vertex(it)[j]);
                CU_ASSERT_FATAL(dth_model_psi(m, ym, &ps, &dps, work) == DTH_OK);
                K = pow(inf.lambda, 6) * sqrt(pow(ps, 4) + pow(dps * inf.lambda, 4));
            }
            const double *zb = dth_integrator_midpoint(it);
            double psi, dpsi, pa, da;
            CU_ASSERT_FATAL(dth_model_psi(m, zb, &psi, &dpsi, work) == DTH_OK);
            CU_ASSERT_FATAL(dth_model_psi(m, zprev, &pa, &da, work) == DTH_OK);
            double l = law_step(K, psi, dpsi), la = law_step(K, pa, da);
            if ((inf.flags & DTH_STEP_REGULARIZED) && fabs(psi / dpsi) <= 0.99 * l && fabs(pa / da) <= 0.99 * la) {
                worst = fmax(worst, fabs(inf.lambda - l) / l);
                sum += l;
                nlaw++;
            }
            memcpy(zprev, dth_integrator_vertex(it), sizeof zprev);
        }
        CU_ASSERT(nlaw >= 10);
        CU_ASSERT(worst <= 1e-9);
        mean_law[c] = sum / (double)nlaw;
        printf("\n    K = %s: %ld law steps, |lambda - l| / l <= %.1e", c ? "64 K0" : "K0", nlaw, worst);
        dth_integrator_free(it);
        dth_regularizer_free(r);
    }
    /* K^(1/6): 64 K0 gives law steps about twice as long */
    CU_ASSERT(mean_law[1] / mean_law[0] > 1.6 && mean_law[1] / mean_law[0] < 2.5);
    /* outer: the bands' share of the steps grows with it */
    double share[2];
    const char *outer[2] = {"3.2", "5"};
    for (int c = 0; c < 2; c++) {
        char err[256];
        dth_kv kv = {"outer", outer[c]};
        dth_regularizer *r = NULL;
        CU_ASSERT_FATAL(dth_regularizer_new(&dth_reg_smooth, &kv, 1, m, NULL, &r, err, sizeof err) == DTH_OK);
        dth_integrator *it = start(m, r, h, &q0, &p0);
        long steps = 0, reg = 0;
        while (dth_integrator_vertex(it)[1] < 40) {
            dth_step_info inf;
            CU_ASSERT_FATAL(dth_integrator_step(it, &inf) == DTH_OK);
            steps++;
            reg += (inf.flags & DTH_STEP_REGULARIZED) != 0;
        }
        share[c] = (double)reg / (double)steps;
        dth_integrator_free(it);
        dth_regularizer_free(r);
    }
    printf("\n    outer = 3.2: %.3f of the steps in bands, outer = 5: %.3f", share[0], share[1]);
    CU_ASSERT(share[1] > 1.3 * share[0]);
    dth_model_free(m);
}

/* Parameters: each bad value is refused with a message naming the key. */
/* The dense changeover workspace is allocated at the first changeover, once: ordinary steps allocate
 * nothing; a failed allocation fails that step with DTH_ENOMEM and leaves the state as it was; the
 * step retried then goes on exactly as a run whose allocation never failed. */
static void test_lazy_workspace(void)
{
    dth_model *m = model(&dth_model_pendulum, NULL, 0, 1);
    char err[256];
    failing_alloc fa;
    dth_allocator al = failing_alloc_make(&fa, 0);
    dth_regularizer *r = NULL, *ref = NULL;
    CU_ASSERT_FATAL(dth_regularizer_new(&dth_reg_smooth, NULL, 0, m, &al, &r, err, sizeof err) == DTH_OK);
    CU_ASSERT_FATAL(dth_regularizer_new(&dth_reg_smooth, NULL, 0, m, NULL, &ref, err, sizeof err) == DTH_OK);
    long created = fa.count;
    fa.fail_at = created + 1; /* the first allocation after create() fails */
    /* a libration (no changeover): nothing allocated */
    double q0 = 1, p0 = 0;
    dth_integrator *lib = start(m, r, 0.05, &q0, &p0);
    for (int k = 0; k < 2000; k++) CU_ASSERT_FATAL(dth_integrator_step(lib, NULL) == DTH_OK);
    CU_ASSERT_EQUAL(fa.count, created);
    dth_integrator_free(lib);
    dth_regularizer_free(r);
    fa.fail_at = 0;
    /* the rotating pendulum (a fresh instance): its first changeover fails once, then the run is
     * the reference's */
    CU_ASSERT_FATAL(dth_regularizer_new(&dth_reg_smooth, NULL, 0, m, &al, &r, err, sizeof err) == DTH_OK);
    created = fa.count;
    fa.fail_at = created + 1;
    q0 = 0, p0 = 2.2;
    dth_integrator *a = start(m, r, 0.05, &q0, &p0), *b = start(m, ref, 0.05, &q0, &p0);
    double before[4];
    int enomem = 0, same = 1, untouched = 1;
    long reg = 0;
    for (int k = 0; k < 400 && same; k++) {
        dth_step_info ia, ib;
        memcpy(before, dth_integrator_vertex(a), sizeof before);
        int rc = dth_integrator_step(a, &ia);
        if (rc == DTH_ENOMEM) {
            enomem++;
            untouched &= !memcmp(before, dth_integrator_vertex(a), sizeof before);
            rc = dth_integrator_step(a, &ia);
        }
        CU_ASSERT_FATAL(rc == DTH_OK);
        CU_ASSERT_FATAL(dth_integrator_step(b, &ib) == DTH_OK);
        reg += (ia.flags & DTH_STEP_REGULARIZED) != 0;
        same = !memcmp(dth_integrator_vertex(a), dth_integrator_vertex(b), sizeof before) && ia.flags == ib.flags;
    }
    CU_ASSERT(reg > 10);
    CU_ASSERT_EQUAL(enomem, 1);
    CU_ASSERT(untouched);
    CU_ASSERT(same);
    CU_ASSERT_EQUAL(fa.count, created + 2); /* the failed attempt and the workspace, nothing after */
    dth_integrator_free(a);
    dth_integrator_free(b);
    dth_regularizer_free(r);
    dth_regularizer_free(ref);
    CU_ASSERT_EQUAL(fa.live, 0);
    dth_model_free(m);
}

static void test_params(void)
{
    dth_model *m = model(&dth_model_pendulum, NULL, 0, 1);
    struct {
        dth_kv kv[2];
        size_t n;
        const char *key;
    } bad[] = {
        {{{"inner", "0"}}, 1, "inner"},          {{{"inner", "x"}}, 1, "inner"},
        {{{"outer", "0.5"}}, 1, "outer"},        {{{"inner", "3"}, {"outer", "2"}}, 2, "outer"},
        {{{"invariant", "-1"}}, 1, "invariant"}, {{{"invariant", "nan"}}, 1, "invariant"},
    };
    for (size_t i = 0; i < sizeof bad / sizeof bad[0]; i++) {
        dth_regularizer *r = NULL;
        char err[256] = "";
        CU_ASSERT_EQUAL(dth_regularizer_new(&dth_reg_smooth, bad[i].kv, bad[i].n, m, NULL, &r, err, sizeof err), DTH_EINVAL);
        CU_ASSERT_PTR_NOT_NULL(strstr(err, bad[i].key));
        CU_ASSERT_PTR_NULL(r);
    }
    /* a valid invariant with outer is accepted (test_options checks that a given invariant is used) */
    dth_kv kv[2] = {{"invariant", "1e-9"}, {"outer", "5"}};
    dth_regularizer *r = NULL;
    char err[256];
    CU_ASSERT_EQUAL(dth_regularizer_new(&dth_reg_smooth, kv, 2, m, NULL, &r, err, sizeof err), DTH_OK);
    dth_regularizer_free(r);
    dth_model_free(m);
}

static CU_TestInfo tests[] = {
    {"ordinary steps are raw DTH's, bit for bit", test_ordinary_bit_identical},
    {"rotating pendulum: 400 crossings, energy, tangent, pinned step", test_rotating_pendulum},
    {"changeover share falls linearly with h", test_share_linear},
    {"branch_check = 0: no ghost root taken", test_branch_check_off},
    {"Kepler e = 0.9: crossings, L exact", test_kepler},
    {"region II fold (psi > 0): a stretched 3-D ring", test_region_two_fold},
    {"options: the law in the core, invariant, outer", test_options},
    {"changeover workspace: allocated at the first changeover, once", test_lazy_workspace},
    {"parameters", test_params},
    CU_TEST_INFO_NULL,
};

CU_SuiteInfo dth_test_suites[] = {
    {.pName = "smooth", .pTests = tests},
    CU_SUITE_INFO_NULL,
};
