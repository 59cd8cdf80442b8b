/* SPDX-License-Identifier: MIT */
/*
 * Branch selection (lib/branch.c): the root structure of the decoupled constraint g at single
 * vertices against the paper's Theorems EU_1, EU_2, EU_3 and "ghost", every root against the step
 * equations, the search against a dense scan of g, and the integrator's root policy on the
 * measured pendulum crossing (q0 = 0, p0 = 2.2, h = 0.05, vertex start).
 */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include "cu_main.h"
#include "dth/dth.h"

static dth_model *pendulum(void)
{
    dth_model *m = NULL;
    CU_ASSERT_FATAL(dth_model_new(&dth_model_pendulum, NULL, 0, 1, NULL, &m, NULL, 0) == DTH_OK);
    return m;
}

static dth_rootfinder *finder(const dth_model *m)
{
    dth_rootfinder *rf = NULL;
    CU_ASSERT_FATAL(dth_rootfinder_new(m, NULL, NULL, &rf) == DTH_OK);
    return rf;
}

/* Pendulum vertex (q, t = 0, p, wp) with H(z) = wp + H_phys = H. */
static void pvertex(double q, double p, double H, double *z)
{
    double Hp = 0.5 * p * p - cos(q);
    z[0] = q;
    z[1] = 0;
    z[2] = p;
    z[3] = H - Hp;
}

static size_t count_class(const dth_root_set *s, dth_branch c)
{
    size_t k = 0;
    for (size_t i = 0; i < s->count; i++)
        if (s->root[i].cls == c && !(s->root[i].flags & DTH_ROOT_DOUBLE)) k++;
    return k;
}

/* Theorem EU_1 (region I): (i) H/psi < 0 no root; (ii) H = 0 only lambda = 0; (iii) small H/psi > 0
 * two roots of opposite sign near +-sqrt(8 H/psi); (iv) large H/psi no root. */
static void test_eu1(void)
{
    dth_model *m = pendulum();
    dth_rootfinder *rf = finder(m);
    const double qs[] = {0.3, -1.0, 2.5, 0.0};
    const double ps[] = {0.5, 0.8, 0.4, 1.5};
    for (int k = 0; k < 4; k++) {
        double q = qs[k], p = ps[k], psi = p * p * cos(q) + sin(q) * sin(q), z[4];
        dth_root_set s;
        double L = 0.3;
        /* (i) */
        pvertex(q, p, -1e-3 * psi, z);
        CU_ASSERT_EQUAL_FATAL(dth_find_roots(rf, z, L, &s), DTH_OK);
        CU_ASSERT_EQUAL(s.vertex.region, DTH_REGION_I);
        CU_ASSERT_EQUAL(s.sign_H_psi, -1);
        CU_ASSERT_EQUAL(s.count, 0);
        /* (ii) */
        double Hp = 0.5 * p * p - cos(q);
        z[3] = -Hp; /* H = wp + H_phys = 0 exactly */
        CU_ASSERT_EQUAL_FATAL(dth_find_roots(rf, z, L, &s), DTH_OK);
        CU_ASSERT_EQUAL(s.count, 1);
        CU_ASSERT(s.count == 1 && s.root[0].lambda == 0 && (s.root[0].flags & DTH_ROOT_ZERO));
        /* (iii) */
        for (double rho = 1e-3; rho >= 1e-7; rho /= 10) {
            pvertex(q, p, rho * psi, z);
            CU_ASSERT_EQUAL_FATAL(dth_find_roots(rf, z, L, &s), DTH_OK);
            CU_ASSERT_EQUAL(s.vertex.region, DTH_REGION_I);
            CU_ASSERT_EQUAL(s.count, 2);
            if (s.count != 2) continue;
            CU_ASSERT(s.root[0].lambda < 0 && s.root[1].lambda > 0);
            CU_ASSERT_EQUAL(s.root[0].cls, DTH_BRANCH_MINUS);
            CU_ASSERT_EQUAL(s.root[1].cls, DTH_BRANCH_PLUS);
            double l0 = sqrt(8 * rho);
            CU_ASSERT(fabs(-s.root[0].lambda / l0 - 1) < 0.05);
            CU_ASSERT(fabs(s.root[1].lambda / l0 - 1) < 0.05);
            /* the proof's bounds (g_bound_1): 3/32 l^2 <= H/psi <= 5/32 l^2 */
            for (int i = 0; i < 2; i++) {
                double l2 = s.root[i].lambda * s.root[i].lambda;
                CU_ASSERT(3.0 / 32 * l2 <= rho * (1 + 1e-9) && rho <= 5.0 / 32 * l2 * (1 + 1e-9));
            }
        }
        /* (iv): H/psi > 5/32 L^2 */
        pvertex(q, p, 0.2 * L * L * psi, z);
        CU_ASSERT_EQUAL_FATAL(dth_find_roots(rf, z, L, &s), DTH_OK);
        CU_ASSERT_EQUAL(s.count, 0);
    }
    dth_rootfinder_free(rf);
    dth_model_free(m);
}

/* Theorem EU_3 (region III, psi = 0 at q = 2, p = sqrt(-sin^2 2 / cos 2)): one root, on the side of
 * sign(H/psi'), near the cubic's cbrt(24 H / psi'); H = 0: only lambda = 0. */
static void test_eu3(void)
{
    dth_model *m = pendulum();
    dth_rootfinder *rf = finder(m);
    double q = 2, p = sqrt(-sin(2.0) * sin(2.0) / cos(2.0)), z[4];
    for (int sg = -1; sg <= 1; sg++) {
        for (double h = 1e-4; h >= 1e-8; h /= 100) {
            double H = sg * h;
            pvertex(q, p, H, z);
            dth_root_set s;
            CU_ASSERT_EQUAL_FATAL(dth_find_roots(rf, z, 0.2, &s), DTH_OK);
            CU_ASSERT(s.psi_zero);
            CU_ASSERT_EQUAL(s.vertex.region, DTH_REGION_III);
            CU_ASSERT_EQUAL(s.count, 1);
            if (s.count != 1) continue;
            if (sg == 0) {
                CU_ASSERT(s.root[0].lambda == 0 && (s.root[0].flags & DTH_ROOT_ZERO));
                break;
            }
            double dpsi = s.vertex.dpsi, l = s.root[0].lambda, lc = cbrt(24 * s.vertex.H / dpsi);
            CU_ASSERT(dpsi < 0);
            CU_ASSERT((l > 0) == (H / dpsi > 0));
            CU_ASSERT_EQUAL(s.root[0].cls, l > 0 ? DTH_BRANCH_PLUS : DTH_BRANCH_MINUS);
            CU_ASSERT(fabs(l / lc - 1) < 0.05);
        }
    }
    dth_rootfinder_free(rf);
    dth_model_free(m);
}

/* Run the measured crossing to vertex k; returns the integrator. */
static dth_integrator *crossing(const dth_model *m, int k, int branch_check)
{
    dth_options o;
    dth_options_default(&o);
    o.h = 0.05;
    o.start = DTH_START_VERTEX;
    o.branch_check = branch_check;
    /* the notes' offset: the Taylor term wp = -H_phys + psi h^2/8 (psi = p^2 at q = 0) */
    o.has_wp = 1;
    o.wp = -(0.5 * 2.2 * 2.2 - 1) + 2.2 * 2.2 * 0.05 * 0.05 / 8;
    dth_integrator *it = NULL;
    CU_ASSERT_FATAL(dth_integrator_new(m, &o, &it) == DTH_OK);
    double q = 0, p = 2.2;
    CU_ASSERT_FATAL(dth_integrator_start(it, &q, &p, 0) == DTH_OK);
    for (int i = 0; i < k; i++) {
        dth_step_info info;
        CU_ASSERT_FATAL(dth_integrator_step(it, &info) == DTH_OK);
        CU_ASSERT(info.branch == DTH_BRANCH_PLUS);
    }
    return it;
}

/* The notes' measured vertex 14: roots -0.0861 (minus), 0.1035 (plus, s = 0.60), 0.7197 (ghost, s = 4.1). */
static void test_vertex14(void)
{
    dth_model *m = pendulum();
    dth_rootfinder *rf = finder(m);
    dth_integrator *it = crossing(m, 14, 1);
    dth_root_set s;
    CU_ASSERT_EQUAL_FATAL(dth_find_roots(rf, dth_integrator_vertex(it), 1.0, &s), DTH_OK);
    CU_ASSERT_EQUAL_FATAL(s.count, 3);
    const double ref[3] = {-0.0861, 0.1035, 0.7197};
    const dth_branch cls[3] = {DTH_BRANCH_MINUS, DTH_BRANCH_PLUS, DTH_BRANCH_GHOST};
    /* the notes quote 4 digits; the ghost, the most sensitive to the vertex, is measured here at
     * 0.71982 (its step residual is at round-off), one unit off in the last quoted digit */
    const double tol[3] = {5e-5, 5e-5, 1.5e-4};
    for (int i = 0; i < 3; i++) {
        CU_ASSERT(fabs(s.root[i].lambda - ref[i]) < tol[i]);
        CU_ASSERT_EQUAL(s.root[i].cls, cls[i]);
        CU_ASSERT_EQUAL(s.root[i].flags, 0);
    }
    CU_ASSERT(fabs(s.root[1].s - 0.60) < 0.01);
    CU_ASSERT(fabs(s.root[2].s - 4.1) < 0.05);
    CU_ASSERT(fabs(s.vertex.psi - 0.748) < 1e-3 && fabs(s.vertex.dpsi + 4.31) < 1e-2);
    CU_ASSERT(fabs(s.vertex.H - 8.13e-4) < 1e-6);
    fprintf(stderr, "  [vertex 14: %.6f %.6f %.6f, s = %.3f %.3f %.3f, K = %.3g, region %s, %ld solves]\n",
            s.root[0].lambda, s.root[1].lambda, s.root[2].lambda, s.root[0].s, s.root[1].s, s.root[2].s,
            s.vertex.K, dth_region_name(s.vertex.region), s.evals);
    dth_integrator_free(it);
    dth_rootfinder_free(rf);
    dth_model_free(m);
}

/* Theorems EU_2 / ghost at the region II vertex of the crossing: with H/psi -> 0+, lambda+- -> 0
 * (bounded by sqrt(8 H/psi)), while the ghost stays beyond 6/5 |psi/psi'|. */
static void test_ghost(void)
{
    dth_model *m = pendulum();
    dth_rootfinder *rf = finder(m);
    dth_integrator *it = crossing(m, 14, 1);
    double z[4];
    memcpy(z, dth_integrator_vertex(it), sizeof z);
    double Hp = 0.5 * z[2] * z[2] - cos(z[0]);
    double prev_pm = INFINITY, ghost0 = 0;
    for (double rho = 1e-3; rho >= 1e-9; rho /= 10) {
        dth_root_set s;
        z[3] = -Hp; /* H = 0, then offset by rho psi */
        CU_ASSERT_EQUAL_FATAL(dth_find_roots(rf, z, 1.0, &s), DTH_OK);
        z[3] = -Hp + rho * s.vertex.psi;
        CU_ASSERT_EQUAL_FATAL(dth_find_roots(rf, z, 1.0, &s), DTH_OK);
        CU_ASSERT_EQUAL(s.vertex.region, DTH_REGION_II);
        CU_ASSERT_EQUAL(s.sign_H_psi, 1);
        CU_ASSERT_EQUAL(s.count, 3);
        CU_ASSERT_EQUAL(count_class(&s, DTH_BRANCH_MINUS), 1);
        CU_ASSERT_EQUAL(count_class(&s, DTH_BRANCH_PLUS), 1);
        CU_ASSERT_EQUAL(count_class(&s, DTH_BRANCH_GHOST), 1);
        if (s.count != 3) continue;
        double bound = 6.0 / 5 * fabs(s.vertex.psi / s.vertex.dpsi);
        /* the proof's inequalities (ghost_b), (ghost_c): l-^2 (6 + |s-|)/48 <= H/psi, l+^2 (2 - s+)/16 <= H/psi */
        double lm = s.root[0].lambda, lp = s.root[1].lambda, sm = s.root[0].s, sp = s.root[1].s;
        CU_ASSERT(lm * lm * (6 + fabs(sm)) / 48 <= rho * (1 + 1e-6));
        CU_ASSERT(lp * lp * (2 - sp) / 16 <= rho * (1 + 1e-6));
        double pm = fmax(fabs(lm), fabs(lp));
        CU_ASSERT(pm < prev_pm);
        prev_pm = pm;
        CU_ASSERT(fabs(s.root[2].lambda) > bound);
        CU_ASSERT(fabs(s.root[2].s) > 1.2 && s.root[1].s <= 1.2);
        if (ghost0 == 0) ghost0 = s.root[2].lambda;
        CU_ASSERT(fabs(s.root[2].lambda / ghost0 - 1) < 0.05);
    }
    CU_ASSERT(prev_pm < 1e-3); /* lambda+- -> 0 */
    dth_integrator_free(it);
    dth_rootfinder_free(rf);
    dth_model_free(m);
}

/* The policy: the step from vertex 14 takes lambda+ = 0.1035; from vertex 15 the roots ahead are past
 * s = 6/5 (the physical root has met the ghost), so the step refuses with DTH_EFOLD, state untouched.
 * Without the check Newton takes 0.176 silently (the notes' raw run). */
static void test_policy(void)
{
    dth_model *m = pendulum();
    dth_integrator *it = crossing(m, 15, 1);
    CU_ASSERT(fabs(dth_integrator_lambda(it) - 0.1035) < 5e-5);
    double before[4];
    memcpy(before, dth_integrator_vertex(it), sizeof before);
    long steps = dth_integrator_steps(it);
    dth_step_info info;
    int rc = dth_integrator_step(it, &info);
    CU_ASSERT_EQUAL(rc, DTH_EFOLD);
    CU_ASSERT(memcmp(before, dth_integrator_vertex(it), sizeof before) == 0);
    CU_ASSERT_EQUAL(dth_integrator_steps(it), steps);
    CU_ASSERT_EQUAL(info.branch, DTH_BRANCH_NONE);
    dth_rootfinder *rf = finder(m);
    dth_root_set s;
    CU_ASSERT_EQUAL_FATAL(dth_find_roots(rf, before, 1.0, &s), DTH_OK);
    size_t ahead = 0;
    for (size_t i = 0; i < s.count; i++)
        if (s.root[i].lambda > 0) {
            ahead++;
            CU_ASSERT(s.root[i].s > 1.2);
            CU_ASSERT_EQUAL(s.root[i].cls, DTH_BRANCH_GHOST);
        }
    CU_ASSERT_EQUAL(ahead, 2);
    fprintf(stderr, "  [vertex 15: %zu roots:", s.count);
    for (size_t i = 0; i < s.count; i++) fprintf(stderr, " %.4f (%s, s = %.2f)", s.root[i].lambda, dth_root_class_name(&s.root[i]), s.root[i].s);
    fprintf(stderr, "]\n");
    dth_integrator_free(it);
    it = crossing(m, 15, 0);
    CU_ASSERT_EQUAL(dth_integrator_step(it, &info), DTH_OK);
    CU_ASSERT(fabs(info.lambda - 0.176) < 5e-4);
    dth_integrator_free(it);
    dth_rootfinder_free(rf);
    dth_model_free(m);
}

/* ---- cross-checks on random vertices of every registered model ---- */

static double rnd(unsigned long *s)
{
    *s = *s * 6364136223846793005UL + 1442695040888963407UL;
    return ((double)(*s >> 11) / 9007199254740992.0) * 2 - 1;
}

static const dth_kv coupled_kv[] = {{"preset", "chain"}, {"size", "2"}, {"dim", "2"}};

static int make_model(const dth_model_type *t, dth_model **m)
{
    if (strcmp(t->name, "coupled") == 0) return dth_model_new(t, coupled_kv, 3, 4, NULL, m, NULL, 0);
    if (strcmp(t->name, "kepler") == 0) return dth_model_new(t, NULL, 0, 2, NULL, m, NULL, 0);
    return dth_model_new(t, NULL, 0, 1, NULL, m, NULL, 0);
}

/* Residual of the step equations at (z, lambda, zbar), computed here from the model alone. */
static double step_residual(const dth_model *m, const double *z, double lam, const double *zb, double *hres)
{
    size_t n = dth_model_dof(m), d = 2 * n + 1, N = d + 1;
    double g[64], Hp, r = 0;
    *hres = INFINITY;
    if (d > 64 || dth_model_eval(m, zb, DTH_EVAL_H | DTH_EVAL_GRAD, &Hp, g, NULL)) return INFINITY;
    for (size_t j = 0; j < N; j++) {
        double u = j < n ? g[n + 1 + j] : j == n ? 1.0 : j < d ? -g[j - n - 1] : -g[n];
        double sc = fabs(z[j]) + fabs(zb[j]) + fabs(lam * u);
        r = fmax(r, fabs(zb[j] - z[j] - 0.5 * lam * u) / (sc > 0 ? sc : 1));
    }
    double hs = fabs(zb[N - 1]) + fabs(Hp);
    for (size_t j = 0; j < d; j++) hs += fabs(g[j] * zb[j]);
    *hres = fabs(zb[N - 1] + Hp) / hs;
    return r;
}

static void random_vertex_check(const dth_model *m, int nvert, unsigned long seed)
{
    size_t n = dth_model_dof(m), N = 2 * n + 2;
    const char *name = dth_model_get_type(m)->name;
    dth_rootfinder *rf = finder(m);
    double *z = calloc(N, sizeof *z), *zb = calloc(N, sizeof *zb), *work = calloc(dth_model_work_size(m), sizeof(double));
    unsigned long s = seed;
    int checked = 0, missed = 0, bad = 0, roots = 0, doubles = 0;
    double worst_r = 0, worst_h = 0;
    enum { DENSE = 800 };
    for (int k = 0; k < nvert; k++) {
        for (size_t j = 0; j < N - 1; j++) z[j] = 1.5 * rnd(&s);
        for (size_t i = 0; i < n; i++) z[i] += 1.2 * (double)(i + 1); /* keep Kepler away from 0 */
        z[n] = 0.1 * rnd(&s);
        double Hp, psi;
        if (dth_model_eval(m, z, DTH_EVAL_H, &Hp, NULL, NULL) || dth_model_psi(m, z, &psi, NULL, work)) continue;
        double l0 = 0.05 + 0.3 * fabs(rnd(&s)), f = 0.5 + rnd(&s);
        z[N - 1] = -Hp + f * psi * l0 * l0 / 8;
        double L = 4 * l0;
        dth_root_set set;
        if (dth_find_roots(rf, z, L, &set) != DTH_OK) continue;
        checked++;
        for (size_t i = 0; i < set.count; i++) {
            const dth_root *r = &set.root[i];
            roots++;
            if (r->flags & DTH_ROOT_DOUBLE) {
                doubles++;
                continue;
            }
            CU_ASSERT(!(r->flags & DTH_ROOT_UNPOLISHED));
            double g, dg, hres;
            CU_ASSERT_FATAL(dth_decoupled(rf, z, r->lambda, 16, &g, &dg, zb) == DTH_OK);
            double res = step_residual(m, z, r->lambda, zb, &hres);
            worst_r = fmax(worst_r, res);
            worst_h = fmax(worst_h, hres);
            if (res > 1e-13 || hres > 1e-13) bad++;
        }
        /* dense scan of g over the scanned range: every sign change holds a reported root */
        double lo = set.lo, hi = set.hi, gprev = NAN, lprev = 0;
        for (int i = 0; i <= DENSE; i++) {
            double l = lo + (hi - lo) * i / DENSE, g, dg;
            int steps = 1 + (int)(fabs(l) / (L / 16));
            if (dth_decoupled(rf, z, l, steps, &g, &dg, NULL) != DTH_OK) {
                gprev = NAN;
                continue;
            }
            if (gprev * g < 0 && fabs(g) > set.tol && fabs(gprev) > set.tol) {
                int found = 0;
                double w = 1e-9 * (hi - lo);
                for (size_t r = 0; r < set.count; r++)
                    if (set.root[r].lambda >= lprev - w && set.root[r].lambda <= l + w) found = 1;
                if (!found) {
                    missed++;
                    fprintf(stderr, "  [%s: missed a root in (%.6g, %.6g), vertex %d]\n", name, lprev, l, k);
                }
            }
            gprev = g;
            lprev = l;
        }
    }
    CU_ASSERT(checked >= nvert * 9 / 10);
    CU_ASSERT_EQUAL(missed, 0);
    CU_ASSERT_EQUAL(bad, 0);
    fprintf(stderr, "  [%s: %d vertices, %d roots (%d double), missed %d, worst step residual %.2g, energy %.2g]\n",
            name, checked, roots, doubles, missed, worst_r, worst_h);
    free(z);
    free(zb);
    free(work);
    dth_rootfinder_free(rf);
}

static void test_random(void)
{
    dth_registry *r;
    CU_ASSERT_FATAL(dth_registry_new(NULL, &r) == DTH_OK);
    CU_ASSERT_FATAL(dth_registry_add_builtin(r) == DTH_OK);
    for (size_t i = 0; i < dth_registry_model_count(r); i++) {
        dth_model *m = NULL;
        if (make_model(dth_registry_model_at(r, i), &m) != DTH_OK) continue;
        random_vertex_check(m, 200, 1234 + i);
        dth_model_free(m);
    }
    dth_registry_free(r);
}

/* A failed search leaves nothing half done: bad arguments are refused. */
/* A range far beyond the vertex's root scale (issue 24): the rotating pendulum's vertex (q = 0,
 * p = 2.2, wp of scenes/pendulum-rotation.ini) has its physical roots at +-0.0500346. With L = 1e10
 * the coarse grid once labelled +-24003 minus and plus; from 1e14 on it stopped at +-0.05 with no
 * root, and neither said it was incomplete. Now the scan reaches 1024 root scales (+-51.2), finds
 * the physical pair, and reports the set as truncated with the range it covered. */
static void test_huge_range(void)
{
    dth_model *m = pendulum();
    dth_rootfinder *rf = finder(m);
    double z[4] = {0, 0, 2.2, -1.4184875000000003};
    const double Ls[] = {0.8, 1e3, 1e10, 1e14, 1e20, 1e308};
    for (size_t k = 0; k < sizeof Ls / sizeof *Ls; k++) {
        dth_root_set s;
        CU_ASSERT_EQUAL_FATAL(dth_find_roots(rf, z, Ls[k], &s), DTH_OK);
        CU_ASSERT_EQUAL(count_class(&s, DTH_BRANCH_MINUS), 1);
        CU_ASSERT_EQUAL(count_class(&s, DTH_BRANCH_PLUS), 1);
        for (size_t i = 0; i < s.count; i++)
            if (s.root[i].cls == DTH_BRANCH_MINUS || s.root[i].cls == DTH_BRANCH_PLUS)
                CU_ASSERT(fabs(fabs(s.root[i].lambda) / 0.0500345545194426 - 1) < 1e-12);
        int whole = s.lo <= -Ls[k] && s.hi >= Ls[k];
        CU_ASSERT_EQUAL(s.truncated, !whole);
        CU_ASSERT_EQUAL(whole, Ls[k] <= 51.2);  /* 1024 times the root scale sqrt(8 H/psi) = 0.05 */
        CU_ASSERT(s.hi <= 51.2 * (1 + 1e-12) && s.hi > 0.8 * (1 - 1e-12));
    }
    dth_rootfinder_free(rf);
    dth_model_free(m);
}

static void test_args(void)
{
    dth_model *m = pendulum();
    dth_rootfinder *rf = finder(m);
    double z[4] = {0.1, 0, 0.2, 1.0};
    dth_root_set s;
    CU_ASSERT_EQUAL(dth_find_roots(rf, z, 0, &s), DTH_EINVAL);
    CU_ASSERT_EQUAL(dth_find_roots(rf, z, NAN, &s), DTH_EINVAL);
    z[0] = NAN;
    CU_ASSERT_EQUAL(dth_find_roots(rf, z, 1, &s), DTH_EINVAL);
    dth_root_options o;
    dth_root_options_default(&o);
    o.n_uniform = 0;
    dth_rootfinder *bad = NULL;
    CU_ASSERT_EQUAL(dth_rootfinder_new(m, &o, NULL, &bad), DTH_EINVAL);
    CU_ASSERT(bad == NULL);
    dth_rootfinder_free(rf);
    dth_model_free(m);
}

static CU_TestInfo roots_tests[] = {
    {"Theorem EU_1 (i)-(iv): region I roots", test_eu1},
    {"Theorem EU_3 (i)-(iii): psi = 0, one root on the side of H/psi'", test_eu3},
    {"measured crossing: vertex 14 roots -0.0861, 0.1035, 0.7197", test_vertex14},
    {"Theorems EU_2 / ghost: lambda+- -> 0, |lambda*| > 6/5 |psi/psi'|", test_ghost},
    {"every root solves the step; none missed by a dense scan", test_random},
    {"invalid arguments", test_args},
    {"a range beyond the grid's reach: the physical roots, reported as truncated", test_huge_range},
    CU_TEST_INFO_NULL,
};

static CU_TestInfo policy_tests[] = {
    {"integrator refuses the fold with DTH_EFOLD, state untouched", test_policy},
    CU_TEST_INFO_NULL,
};

CU_SuiteInfo dth_test_suites[] = {
    {.pName = "roots", .pTests = roots_tests},
    {.pName = "policy", .pTests = policy_tests},
    CU_SUITE_INFO_NULL,
};
