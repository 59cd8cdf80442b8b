/* SPDX-License-Identifier: MIT */
/*
 * Coupled oscillators and the banded step solve: derivatives (explicit, chain, ring, lattice),
 * parameter validation, conservation of linear and angular momentum and of the midpoint energy
 * -wp along a nonlinear chain (paper, Theorem "DTH Equations"), banded against dense steps,
 * tangent maps and psi, and a 10^4-particle chain that the dense path could not allocate.
 */
#include <float.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include "cu_main.h"
#include "dth/dth.h"
#include "dth_internal.h"

/* Deterministic pseudo-random numbers in [-1, 1]. */
static double rnd(unsigned long *s)
{
    *s = *s * 6364136223846793005UL + 1442695040888963407UL;
    return ((double)(*s >> 11) / 9007199254740992.0) * 2 - 1;
}

static dth_model *make(const dth_kv *kv, size_t nkv)
{
    dth_model *m = NULL;
    char err[256] = "";
    int rc = dth_model_new(&dth_model_coupled, kv, nkv, 0, NULL, &m, err, sizeof err);
    if (rc) fprintf(stderr, "coupled: %s\n", err);
    CU_ASSERT_EQUAL_FATAL(rc, DTH_OK);
    return m;
}

/*
 * A perturbed configuration: particle i of a size-wide grid (chain: one row) at spacing L,
 * displaced by up to `amp`, with random momenta of size `pm` (deterministic in seed).
 */
static void configure(size_t N, size_t dim, size_t width, double L, double amp, double pm,
                      unsigned long seed, double *y)
{
    size_t n = N * dim;
    for (size_t i = 0; i < N; i++)
        for (size_t x = 0; x < dim; x++) {
            double base = x == 0 ? (double)(i % width) * L : x == 1 ? (double)(i / width) * L : 0;
            y[i * dim + x] = base + amp * rnd(&seed);
            y[n + 1 + i * dim + x] = pm * rnd(&seed);
        }
    y[n] = 0.25;
}

/* ------------------------------------------------------------ derivatives and structure */

typedef struct check_case {
    const char *what;
    dth_kv kv[10];
    size_t nkv;
    size_t N, dim, width; /* particles, dimension, particles per grid row (configure) */
    double L;             /* spacing of the configuration */
    int banded;           /* expected Hessian kind */
} check_case;

static const check_case cases[] = {
    {"explicit 3-D with anchor",
     {{"particles", "4"}, {"dim", "3"}, {"mass", "1,2,0.5,3"}, {"spring1", "1,2,2,1.0"},
      {"spring2", "2,3,1.5,0.8"}, {"spring3", "1,4,0.7,1.2"}, {"spring4", "3,4,1,0"},
      {"anchor1", "1,0.5,0.3,0.1,0.2,-0.1"}},
     8, 4, 3, 4, 1.0, 0},
    {"chain 2-D", {{"preset", "chain"}, {"size", "6"}, {"dim", "2"}, {"L", "0.8"}, {"k", "1.3"}, {"mass", "1,2,3,4,5,6"}},
     6, 6, 2, 6, 0.8, 1},
    {"chain 1-D", {{"preset", "chain"}, {"size", "7"}, {"dim", "1"}, {"L", "1.1"}}, 4, 7, 1, 7, 1.1, 1},
    {"chain 3-D anchored", {{"preset", "chain"}, {"size", "5"}, {"dim", "3"}, {"anchor1", "1,2,0.5,0,0,0"}, {"anchor2", "5,1,0,4,0,0"}},
     5, 5, 3, 5, 1.0, 1},
    {"ring 3-D", {{"preset", "ring"}, {"size", "5"}, {"dim", "3"}}, 3, 5, 3, 5, 1.0, 0},
    {"ring 3-D forced banded", {{"preset", "ring"}, {"size", "5"}, {"dim", "3"}, {"structure", "banded"}}, 4, 5, 3, 5, 1.0, 1},
    {"lattice 2-D", {{"preset", "lattice"}, {"size", "3"}, {"dim", "2"}, {"L", "0.9"}}, 4, 9, 2, 3, 0.9, 1},
};

/* The same model declared dense (structure=dense), for comparisons. */
static dth_model *make_dense_twin(const check_case *c)
{
    dth_kv kv[11];
    memcpy(kv, c->kv, c->nkv * sizeof *kv);
    size_t nkv = c->nkv;
    kv[nkv++] = (dth_kv){"structure", "dense"};
    return make(kv, nkv);
}

static void test_derivatives(void)
{
    for (size_t ci = 0; ci < sizeof cases / sizeof cases[0]; ci++) {
        const check_case *c = &cases[ci];
        dth_model *m = make(c->kv, c->nkv), *md = make_dense_twin(c);
        const dth_model_info *info = dth_model_get_info(m);
        size_t n = c->N * c->dim, d = 2 * n + 1;
        CU_ASSERT_EQUAL(info->n, n);
        CU_ASSERT_EQUAL(info->hess_kind, c->banded ? DTH_HESS_BANDED : DTH_HESS_DENSE);
        CU_ASSERT_EQUAL(dth_model_get_info(md)->hess_kind, DTH_HESS_DENSE);
        double *y = calloc(d, sizeof *y), *w = calloc(dth_model_work_size(m), sizeof *w);
        double *wd = calloc(dth_model_work_size(md), sizeof *wd);
        for (unsigned long seed = 1; seed <= 6; seed++) {
            configure(c->N, c->dim, c->width, c->L, 0.3 * c->L, 1.0, seed, y);
            dth_model_check_report rep;
            CU_ASSERT_EQUAL_FATAL(dth_model_check(m, y, &rep), DTH_OK);
            CU_ASSERT(rep.grad_err < 1e-7);
            CU_ASSERT(rep.hess_err < 1e-7);
            CU_ASSERT(rep.sym_err == 0);
            CU_ASSERT(rep.third_err < 1e-6);
            CU_ASSERT(rep.band_err == 0); /* band and dense share one accumulation order */
            if (rep.grad_err >= 1e-7 || rep.hess_err >= 1e-7 || rep.third_err >= 1e-6)
                fprintf(stderr, "%s: grad %.3g hess %.3g third %.3g\n", c->what, rep.grad_err, rep.hess_err, rep.third_err);
            /* psi and psi' through the band agree with the dense Hessian */
            double psi, dpsi, psid, dpsid;
            CU_ASSERT_EQUAL_FATAL(dth_model_psi(m, y, &psi, &dpsi, w), DTH_OK);
            CU_ASSERT_EQUAL_FATAL(dth_model_psi(md, y, &psid, &dpsid, wd), DTH_OK);
            CU_ASSERT(fabs(psi - psid) <= 1e-13 * (1 + fabs(psid)));
            CU_ASSERT(dpsi == dpsid); /* both from `third` */
        }
        if (c->banded && info->bandwidth < n) CU_ASSERT(dth_model_work_size(m) < dth_model_work_size(md));
        free(y); free(w); free(wd);
        dth_model_free(m);
        dth_model_free(md);
    }
}

/* Hand-computed energy, force and Hessian of one spring in 2-D with L > 0, and an anchor. */
static void test_spring_values(void)
{
    dth_kv kv[] = {{"particles", "2"}, {"dim", "2"}, {"mass", "2,4"}, {"spring1", "1,2,3,1"},
                   {"anchor1", "2,5,0,1,1"}};
    dth_model *m = make(kv, 5);
    /* x1 = (0,0), x2 = (3,4): |r| = 5; p1 = (1,2), p2 = (4,0) */
    double y[9] = {0, 0, 3, 4, 0, 1, 2, 4, 0}, H, g[9], hs[81];
    CU_ASSERT_EQUAL_FATAL(dth_model_eval(m, y, DTH_EVAL_H | DTH_EVAL_GRAD | DTH_EVAL_HESS, &H, g, hs), DTH_OK);
    /* T = (1+4)/4 + 16/8 = 3.25; V = 3/2 (5-1)^2 + 5/2 |(2,3)|^2 = 24 + 32.5 */
    CU_ASSERT_DOUBLE_EQUAL(H, 3.25 + 24 + 32.5, 1e-13);
    /* force on x1: k (1 - L/s) r, r = x1 - x2 = (-3,-4): 3 * 0.8 * (-3,-4) */
    CU_ASSERT_DOUBLE_EQUAL(g[0], -7.2, 1e-14);
    CU_ASSERT_DOUBLE_EQUAL(g[1], -9.6, 1e-14);
    CU_ASSERT_DOUBLE_EQUAL(g[2], 7.2 + 5 * 2, 1e-14);
    CU_ASSERT_DOUBLE_EQUAL(g[3], 9.6 + 5 * 3, 1e-14);
    CU_ASSERT_DOUBLE_EQUAL(g[5], 0.5, 1e-15);
    CU_ASSERT_DOUBLE_EQUAL(g[7], 1.0, 1e-15);
    /* K = k ((1 - L/s) I + L r r^T / s^3): K_xx = 3 (0.8 + 9/125), K_xy = 3 * 12/125 */
    double kxx = 3 * (0.8 + 9.0 / 125), kxy = 3 * 12.0 / 125, kyy = 3 * (0.8 + 16.0 / 125);
    CU_ASSERT_DOUBLE_EQUAL(hs[0 * 9 + 0], kxx, 1e-14);
    CU_ASSERT_DOUBLE_EQUAL(hs[0 * 9 + 1], kxy, 1e-14);
    CU_ASSERT_DOUBLE_EQUAL(hs[0 * 9 + 3], -kxy, 1e-14);
    CU_ASSERT_DOUBLE_EQUAL(hs[3 * 9 + 3], kyy + 5, 1e-14);
    CU_ASSERT_DOUBLE_EQUAL(hs[5 * 9 + 5], 0.5, 1e-15);
    CU_ASSERT_EQUAL(dth_model_get_type(m)->n_invariants(dth__model_self(m)), 0); /* anchored */
    /* coincident particles with L > 0: outside the domain */
    double yc[9] = {1, 1, 1, 1, 0, 0, 0, 0, 0};
    CU_ASSERT_EQUAL(dth_model_eval(m, yc, DTH_EVAL_H, &H, NULL, NULL), DTH_EDOMAIN);
    dth_model_free(m);
    /* L = 0: quadratic, coincident particles are fine and D^3 H = 0 */
    dth_kv kq[] = {{"particles", "2"}, {"dim", "3"}, {"spring1", "1,2,3,0"}};
    m = make(kq, 3);
    double y3[13] = {0}, u[13] = {1, 2, 3, 4, 5, 6, 0, 1, 1, 1, 1, 1, 1}, d3 = 1;
    CU_ASSERT_EQUAL(dth_model_eval(m, y3, DTH_EVAL_H, &H, NULL, NULL), DTH_OK);
    CU_ASSERT_EQUAL(dth_model_get_type(m)->third(dth__model_self(m), y3, u, &d3), 0);
    CU_ASSERT_EQUAL(d3, 0.0);
    const dth_model_type *t = dth_model_get_type(m);
    CU_ASSERT_EQUAL(t->n_invariants(dth__model_self(m)), 6);
    CU_ASSERT_STRING_EQUAL(t->invariant_name(dth__model_self(m), 3), "Lx");
    dth_model_free(m);
    /* one mass value applies to every particle: dH/dp = p/m for each */
    dth_kv km[] = {{"particles", "3"}, {"dim", "1"}, {"mass", "25"}};
    m = make(km, 3);
    double y1[7] = {0, 1, 2, 0, 5, 10, 15}, g1[7];
    CU_ASSERT_EQUAL(dth_model_eval(m, y1, DTH_EVAL_H | DTH_EVAL_GRAD, &H, g1, NULL), DTH_OK);
    for (int i = 0; i < 3; i++) CU_ASSERT_DOUBLE_EQUAL(g1[4 + i], y1[4 + i] / 25, 1e-15);
    CU_ASSERT_DOUBLE_EQUAL(H, (25 + 100 + 225) / 50.0, 1e-14);
    dth_model_free(m);
}

/* ------------------------------------------------------------ validation */

static void expect_error(const dth_kv *kv, size_t nkv, const char *key)
{
    dth_model *m = (dth_model *)1;
    char err[256] = "";
    CU_ASSERT_EQUAL(dth_model_new(&dth_model_coupled, kv, nkv, 0, NULL, &m, err, sizeof err), DTH_EINVAL);
    CU_ASSERT_PTR_NULL(m);
    CU_ASSERT_PTR_NOT_NULL(strstr(err, key));
    if (!strstr(err, key)) fprintf(stderr, "expected '%s' in: %s\n", key, err);
}

static void test_validation(void)
{
    expect_error((dth_kv[]){{"particles", "0"}}, 1, "particles");
    expect_error((dth_kv[]){{"dim", "2"}}, 1, "particles");
    expect_error((dth_kv[]){{"particles", "2.5"}}, 1, "particles");
    expect_error((dth_kv[]){{"particles", "2"}, {"dim", "4"}}, 2, "dim");
    expect_error((dth_kv[]){{"particles", "2"}, {"dim", "0"}}, 2, "dim");
    expect_error((dth_kv[]){{"particles", "2"}, {"mass", "1,-1"}}, 2, "mass");
    expect_error((dth_kv[]){{"particles", "2"}, {"mass", "0"}}, 2, "mass");
    expect_error((dth_kv[]){{"particles", "3"}, {"mass", "1,2"}}, 2, "mass");
    expect_error((dth_kv[]){{"particles", "2"}, {"spring1", "1,2,1,-0.5"}}, 2, "spring1");
    expect_error((dth_kv[]){{"particles", "2"}, {"spring7", "1,3,1,1"}}, 2, "spring7");
    expect_error((dth_kv[]){{"particles", "2"}, {"spring2", "0,1,1,1"}}, 2, "spring2");
    expect_error((dth_kv[]){{"particles", "2"}, {"spring1", "2,2,1,1"}}, 2, "spring1");
    expect_error((dth_kv[]){{"particles", "2"}, {"spring1", "1,2,1"}}, 2, "spring1");
    expect_error((dth_kv[]){{"particles", "2"}, {"spring1", "1,2,-1,1"}}, 2, "spring1");
    expect_error((dth_kv[]){{"particles", "2"}, {"anchor1", "3,1,1,0,0"}}, 2, "anchor1");
    expect_error((dth_kv[]){{"particles", "2"}, {"anchor1", "1,1,-1,0,0"}}, 2, "anchor1");
    expect_error((dth_kv[]){{"particles", "2"}, {"dim", "1"}, {"anchor1", "1,1,1,0,0"}}, 3, "anchor1");
    expect_error((dth_kv[]){{"preset", "chain"}}, 1, "size");
    expect_error((dth_kv[]){{"preset", "blob"}, {"size", "3"}}, 2, "preset");
    expect_error((dth_kv[]){{"preset", "ring"}, {"size", "2"}}, 2, "size");
    expect_error((dth_kv[]){{"preset", "chain"}, {"size", "3"}, {"L", "-1"}}, 3, "L");
    expect_error((dth_kv[]){{"preset", "chain"}, {"size", "3"}, {"k", "-1"}}, 3, "k");
    expect_error((dth_kv[]){{"preset", "chain"}, {"size", "3"}, {"particles", "4"}}, 3, "particles");
    expect_error((dth_kv[]){{"preset", "chain"}, {"size", "3"}, {"structure", "sparse"}}, 3, "structure");
    /* the caller's q count must match */
    dth_model *m = NULL;
    char err[256];
    dth_kv kv[] = {{"preset", "chain"}, {"size", "3"}, {"dim", "2"}};
    CU_ASSERT_EQUAL(dth_model_new(&dth_model_coupled, kv, 3, 5, NULL, &m, err, sizeof err), DTH_EINVAL);
    CU_ASSERT_EQUAL(dth_model_new(&dth_model_coupled, kv, 3, 6, NULL, &m, err, sizeof err), DTH_OK);
    dth_model_free(m);
}

/* ------------------------------------------------------------ integration */

/* Chain of N particles in 2-D, rest length 1, k = 1 (structure: "auto" or "dense"). */
static dth_model *chain2d(size_t N, const char *structure)
{
    char size[32];
    snprintf(size, sizeof size, "%zu", N);
    dth_kv kv[] = {{"preset", "chain"}, {"size", size}, {"dim", "2"}, {"L", "1"}, {"k", "1"}, {"structure", structure}};
    return make(kv, 6);
}

static dth_integrator *start_chain(const dth_model *m, size_t N, double h, double *q, double *p)
{
    size_t n = 2 * N, d = 2 * n + 1;
    double *y = calloc(d, sizeof *y);
    configure(N, 2, N, 1.0, 0.1, 0.3, 2024, y);
    memcpy(q, y, n * sizeof *q);
    memcpy(p, y + n + 1, n * sizeof *p);
    free(y);
    dth_options o;
    dth_options_default(&o);
    o.h = h;
    dth_integrator *it = NULL;
    CU_ASSERT_EQUAL_FATAL(dth_integrator_new(m, &o, &it), DTH_OK);
    CU_ASSERT_EQUAL_FATAL(dth_integrator_start(it, q, p, 0.0), DTH_OK);
    return it;
}

/*
 * Momenta at every vertex and energy at every midpoint over `steps` steps of a 50-particle
 * chain with L > 0 (nonlinear). Prints the measured drifts.
 */
static void run_conservation(long steps)
{
    size_t N = 50, n = 2 * N, Nz = 2 * n + 2;
    dth_model *m = chain2d(N, "auto");
    CU_ASSERT_EQUAL(dth_model_get_info(m)->hess_kind, DTH_HESS_BANDED);
    double *q = calloc(n, sizeof *q), *p = calloc(n, sizeof *p);
    dth_integrator *it = start_chain(m, N, 0.05, q, p);
    const dth_model_type *t = dth_model_get_type(m);
    const void *self = dth__model_self(m);
    CU_ASSERT_EQUAL_FATAL(t->n_invariants(self), 3);
    double I0[3], I[3], dI[3] = {0}, Iscale[3] = {0}, emax = 0, efirst = 0, elast = 0;
    double *g = calloc(Nz, sizeof *g);
    CU_ASSERT_EQUAL(t->invariants(self, dth_integrator_vertex(it), I0), 0);
    /* scale of the sums: sum |p| for P, sum |x p| for L */
    const double *z = dth_integrator_vertex(it);
    for (size_t i = 0; i < N; i++) {
        Iscale[0] += fabs(z[n + 1 + 2 * i]);
        Iscale[1] += fabs(z[n + 2 + 2 * i]);
        Iscale[2] += fabs(z[2 * i] * z[n + 2 + 2 * i]) + fabs(z[2 * i + 1] * z[n + 1 + 2 * i]);
    }
    long ok = 0;
    double t_end = 0;
    for (long k = 0; k < steps; k++) {
        dth_step_info si;
        int rc = dth_integrator_step(it, &si);
        if (rc) {
            fprintf(stderr, "step %ld: %s (%s)\n", k, dth_strerror(rc), dth_integrator_errmsg(it));
            break;
        }
        ok++;
        z = dth_integrator_vertex(it);
        CU_ASSERT(t->invariants(self, z, I) == 0);
        for (int j = 0; j < 3; j++) dI[j] = fmax(dI[j], fabs(I[j] - I0[j]));
        const double *zb = dth_integrator_midpoint(it);
        /* relative to the round-off scale of H's terms at zbar: |wp| + |H| + sum |g_j zbar_j| */
        double H, sc;
        CU_ASSERT(dth_model_eval(m, zb, DTH_EVAL_H | DTH_EVAL_GRAD, &H, g, NULL) == DTH_OK);
        sc = fabs(zb[Nz - 1]) + fabs(H);
        for (size_t j = 0; j < Nz - 1; j++) sc += fabs(g[j] * zb[j]);
        double e = fabs(H + zb[Nz - 1]) / sc;
        emax = fmax(emax, e);
        if (k < steps / 10) efirst = fmax(efirst, e);
        if (k >= steps - steps / 10) elast = fmax(elast, e);
        t_end = z[n];
    }
    CU_ASSERT_EQUAL(ok, steps);
    printf("\n    chain N=%zu, %ld steps to t=%.1f: max |dPx| %.2e |dPy| %.2e |dLz| %.2e (scales %.1f %.1f %.1f), "
           "max |H(zbar)+wp|/scale %.2e (first tenth %.2e, last tenth %.2e)\n", N, ok, t_end, dI[0], dI[1], dI[2],
           Iscale[0], Iscale[1], Iscale[2], emax, efirst, elast);
    /* round-off: a few hundred ulps of the sums' scale, over all steps */
    for (int j = 0; j < 3; j++) CU_ASSERT(dI[j] <= 1e-13 * Iscale[j]);
    CU_ASSERT(emax <= 2 * DBL_EPSILON); /* at round-off at every midpoint: no growth */
    dth_integrator_free(it);
    dth_model_free(m);
    free(q);
    free(p);
    free(g);
}

static void test_conservation(void) { run_conservation(10000); }

/*
 * The banded and the dense step solve give the same steps to round-off. Each step starts both
 * from the same vertex (the dense one's), so differences do not compound through the chaotic
 * flow; lambda is only determined to about eps * scale(H) / (|psi| lambda^2 / 8) (the constraint
 * is flat to second order at the vertex), and that is the bound used.
 */
static void test_banded_vs_dense(void)
{
    size_t N = 50, n = 2 * N, Nz = 2 * n + 2;
    dth_model *mb = chain2d(N, "auto"), *md = chain2d(N, "dense");
    CU_ASSERT_EQUAL(dth_model_get_info(mb)->hess_kind, DTH_HESS_BANDED);
    CU_ASSERT_EQUAL(dth_model_get_info(md)->hess_kind, DTH_HESS_DENSE);
    double *q = calloc(n, sizeof *q), *p = calloc(n, sizeof *p), *g = calloc(Nz, sizeof *g);
    double *w = calloc(dth_model_work_size(md), sizeof *w);
    dth_integrator *ib = start_chain(mb, N, 0.05, q, p), *id = start_chain(md, N, 0.05, q, p);
    double dz_max = 0, dl_max = 0, ratio_max = 0, drift = 0;
    int iters_b = 0, iters_d = 0;
    for (int k = 0; k < 100; k++) {
        dth_step_info sb, sd;
        const double *z = dth_integrator_vertex(id);
        /* both from the same vertex with the same (cubic, history-free) predictor, so that their
         * iteration counts compare */
        if (k > 0) {
            CU_ASSERT_EQUAL_FATAL(dth_integrator_set_vertex(ib, z, dth_integrator_lambda(id)), DTH_OK);
            CU_ASSERT_EQUAL_FATAL(dth_integrator_set_vertex(id, z, dth_integrator_lambda(id)), DTH_OK);
        }
        /* conditioning of lambda at this vertex */
        double H, psi, sc;
        CU_ASSERT_FATAL(dth_model_eval(md, z, DTH_EVAL_H | DTH_EVAL_GRAD, &H, g, NULL) == DTH_OK);
        CU_ASSERT_FATAL(dth_model_psi(md, z, &psi, NULL, w) == DTH_OK);
        sc = fabs(z[Nz - 1]) + fabs(H);
        for (size_t j = 0; j < Nz - 1; j++) sc += fabs(g[j] * z[j]);
        CU_ASSERT_EQUAL_FATAL(dth_integrator_step(id, &sd), DTH_OK);
        CU_ASSERT_EQUAL_FATAL(dth_integrator_step(ib, &sb), DTH_OK);
        double kappa = DBL_EPSILON * sc / (fabs(psi) * sd.lambda * sd.lambda / 8);
        iters_b += sb.iters;
        iters_d += sd.iters;
        double dl = fabs(sb.lambda - sd.lambda) / fabs(sd.lambda), dz = 0;
        const double *zb = dth_integrator_vertex(ib), *zd = dth_integrator_vertex(id);
        for (size_t j = 0; j < Nz; j++) dz = fmax(dz, fabs(zb[j] - zd[j]) / (1 + fabs(zd[j])));
        dl_max = fmax(dl_max, dl);
        dz_max = fmax(dz_max, dz);
        ratio_max = fmax(ratio_max, fmax(dl, dz) / kappa);
        CU_ASSERT(dl <= 4 * kappa);
        CU_ASSERT(dz <= 4 * kappa);
        CU_ASSERT(zb[Nz - 1] == zd[Nz - 1]); /* wp carried bit for bit by both */
        drift = fmax(drift, kappa);
    }
    printf("\n    banded vs dense, 100 steps from common vertices: max |dz| %.2e, max |dlambda|/lambda %.2e, "
           "largest difference / (eps scale(H) / (psi lambda^2/8)) = %.2f (kappa up to %.2e), iterations %d vs %d\n",
           dz_max, dl_max, ratio_max, drift, iters_b, iters_d);
    CU_ASSERT(abs(iters_b - iters_d) <= 10);
    /* the tangent maps of the last step agree */
    double *Mb = calloc(Nz * Nz, sizeof *Mb), *Md = calloc(Nz * Nz, sizeof *Md);
    CU_ASSERT_EQUAL(dth_integrator_tangent(ib, Mb), DTH_OK);
    CU_ASSERT_EQUAL(dth_integrator_tangent(id, Md), DTH_OK);
    double tmax = 0, mscale = 0;
    for (size_t k = 0; k < Nz * Nz; k++) {
        tmax = fmax(tmax, fabs(Mb[k] - Md[k]));
        mscale = fmax(mscale, fabs(Md[k]));
    }
    printf("    tangent maps: max |dM| %.2e (max |M| %.2e)\n", tmax, mscale);
    CU_ASSERT(tmax <= 1e-9 * mscale);
    free(Mb); free(Md); free(q); free(p); free(g); free(w);
    dth_integrator_free(ib);
    dth_integrator_free(id);
    dth_model_free(mb);
    dth_model_free(md);
}

/* The banded tangent map matches differences of the step map and is symplectic (extended J). */
static void test_banded_tangent(void)
{
    size_t N = 4, n = 2 * N, Nz = 2 * n + 2;
    dth_kv kv[] = {{"preset", "ring"}, {"size", "4"}, {"dim", "2"}, {"L", "0.8"}, {"structure", "banded"}};
    dth_model *m = make(kv, 5);
    CU_ASSERT_EQUAL(dth_model_get_info(m)->hess_kind, DTH_HESS_BANDED);
    dth_options o;
    dth_options_default(&o);
    o.h = 0.1;
    dth_integrator *it;
    CU_ASSERT_EQUAL_FATAL(dth_integrator_new(m, &o, &it), DTH_OK);
    double *y = calloc(2 * n + 1, sizeof *y);
    configure(N, 2, 2, 1.0, 0.2, 0.5, 7, y);
    CU_ASSERT_EQUAL_FATAL(dth_integrator_start(it, y, y + n + 1, 0.0), DTH_OK);
    for (int k = 0; k < 3; k++) CU_ASSERT_EQUAL_FATAL(dth_integrator_step(it, NULL), DTH_OK);
    double *z0 = calloc(Nz, sizeof *z0), *M = calloc(Nz * Nz, sizeof *M), *zp = calloc(Nz, sizeof *zp);
    double *zm = calloc(Nz, sizeof *zm), *zz = calloc(Nz, sizeof *zz);
    memcpy(z0, dth_integrator_vertex(it), Nz * sizeof *z0);
    double lam = dth_integrator_lambda(it);
    /* step once from z0 to get the tangent there */
    CU_ASSERT_EQUAL_FATAL(dth_integrator_set_vertex(it, z0, lam), DTH_OK);
    CU_ASSERT_EQUAL_FATAL(dth_integrator_step(it, NULL), DTH_OK);
    CU_ASSERT_EQUAL_FATAL(dth_integrator_tangent(it, M), DTH_OK);
    /* columns of M against central differences of the step map in q and p directions */
    double fd_err = 0, e = 1e-6;
    for (size_t l = 0; l < Nz - 1; l++) {
        if (l == n) continue;
        for (int sg = 0; sg < 2; sg++) {
            memcpy(zz, z0, Nz * sizeof *zz);
            zz[l] += sg ? -e : e;
            CU_ASSERT_EQUAL_FATAL(dth_integrator_set_vertex(it, zz, lam), DTH_OK);
            CU_ASSERT_EQUAL_FATAL(dth_integrator_step(it, NULL), DTH_OK);
            memcpy(sg ? zm : zp, dth_integrator_vertex(it), Nz * sizeof *zz);
        }
        for (size_t j = 0; j < Nz; j++) fd_err = fmax(fd_err, fabs((zp[j] - zm[j]) / (2 * e) - M[j * Nz + l]));
    }
    /* symplectic in extended phase space: M^T J M = J, J = [[0, I], [-I, 0]] over (q, t | p, wp) */
    size_t h = Nz / 2;
    double sdef = 0;
    for (size_t a = 0; a < Nz; a++)
        for (size_t b = 0; b < Nz; b++) {
            double s = 0; /* (M^T J M)_ab = sum_i M_ia (J M)_ib, (J M)_ib = M_(i+h)b or -M_(i-h)b */
            for (size_t i = 0; i < Nz; i++) s += M[i * Nz + a] * (i < h ? M[(i + h) * Nz + b] : -M[(i - h) * Nz + b]);
            double J = b == a + h ? 1.0 : a == b + h ? -1.0 : 0.0;
            sdef = fmax(sdef, fabs(s - J));
        }
    printf("\n    banded tangent vs differences of the step map: %.2e; symplecticity defect %.2e\n", fd_err, sdef);
    CU_ASSERT(fd_err <= 1e-5);
    CU_ASSERT(sdef <= 1e-10);
    free(y); free(z0); free(M); free(zp); free(zm); free(zz);
    dth_integrator_free(it);
    dth_model_free(m);
}

/* Allocation accounting for the 10^4-particle chain. */
typedef struct counter {
    size_t bytes, largest;
} counter;
static void *count_alloc(void *ctx, size_t size)
{
    counter *c = ctx;
    c->bytes += size;
    if (size > c->largest) c->largest = size;
    return malloc(size);
}
static void count_free(void *ctx, void *p)
{
    (void)ctx;
    free(p);
}

/* 10^4 particles (n = 2 10^4): the dense Jacobian alone would take 12.8 GB; the banded path
 * allocates O(n w) and steps. */
static void test_big_chain(void)
{
    size_t N = 10000, n = 2 * N;
    counter cnt = {0, 0};
    dth_allocator al = {count_alloc, count_free, &cnt};
    dth_model *m = NULL;
    char err[256];
    dth_kv kv[] = {{"preset", "chain"}, {"size", "10000"}, {"dim", "2"}, {"L", "1"}};
    CU_ASSERT_EQUAL_FATAL(dth_model_new(&dth_model_coupled, kv, 4, 0, &al, &m, err, sizeof err), DTH_OK);
    CU_ASSERT_EQUAL(dth_model_get_info(m)->bandwidth, 6);
    double *q = calloc(n, sizeof *q), *p = calloc(n, sizeof *p);
    double *y = calloc(2 * n + 1, sizeof *y);
    configure(N, 2, N, 1.0, 0.05, 0.1, 99, y);
    memcpy(q, y, n * sizeof *q);
    memcpy(p, y + n + 1, n * sizeof *p);
    dth_options o;
    dth_options_default(&o);
    o.h = 0.05;
    o.alloc = &al;
    o.start = DTH_START_VERTEX; /* exercises psi through the band */
    dth_integrator *it = NULL;
    CU_ASSERT_EQUAL_FATAL(dth_integrator_new(m, &o, &it), DTH_OK);
    printf("\n    N=%zu: model + integrator allocate %.1f MB, largest block %.1f MB\n", N, cnt.bytes / 1e6, cnt.largest / 1e6);
    CU_ASSERT(cnt.bytes <= 400 * n * sizeof(double)); /* linear in n; the dense path needs 4 n^2 doubles */
    size_t before = cnt.bytes;
    CU_ASSERT_EQUAL_FATAL(dth_integrator_start(it, q, p, 0.0), DTH_OK);
    double I0[3], I[3];
    const dth_model_type *t = dth_model_get_type(m);
    CU_ASSERT_EQUAL(t->invariants(dth__model_self(m), dth_integrator_vertex(it), I0), 0);
    for (int k = 0; k < 5; k++) {
        dth_step_info si;
        CU_ASSERT_EQUAL_FATAL(dth_integrator_step(it, &si), DTH_OK);
        CU_ASSERT(si.iters <= 8);
    }
    CU_ASSERT_EQUAL(cnt.bytes, before); /* stepping allocates nothing */
    CU_ASSERT_EQUAL(t->invariants(dth__model_self(m), dth_integrator_vertex(it), I), 0);
    for (int j = 0; j < 2; j++) CU_ASSERT(fabs(I[j] - I0[j]) <= 1e-11);
    /* diagnostics work through the band */
    dth_diag dg;
    double *w = calloc(dth_model_work_size(m), sizeof *w);
    CU_ASSERT_EQUAL(dth_diagnose(m, dth_integrator_vertex(it), dth_integrator_lambda(it), 0, &dg, w), DTH_OK);
    CU_ASSERT(isfinite(dg.psi) && dg.psi > 0);
    free(w); free(q); free(p); free(y);
    dth_integrator_free(it);
    dth_model_free(m);
}

#ifdef DTH_COUPLED_LONG
static void test_conservation_long(void) { run_conservation(100000); }
#endif

static CU_TestInfo model_tests[] = {
    {"derivatives, third, band and psi (explicit, chain, ring, lattice)", test_derivatives},
    {"one spring and one anchor by hand", test_spring_values},
    {"bad parameters are rejected naming the key", test_validation},
    CU_TEST_INFO_NULL,
};
static CU_TestInfo step_tests[] = {
    {"momenta and midpoint energy conserved on a nonlinear chain (10^4 steps)", test_conservation},
    {"banded and dense step solves agree", test_banded_vs_dense},
    {"banded tangent map against differences of the step", test_banded_tangent},
    {"10^4-particle chain: linear memory, steps, diagnostics", test_big_chain},
    CU_TEST_INFO_NULL,
};
#ifdef DTH_COUPLED_LONG
static CU_TestInfo long_tests[] = {
    {"momenta and midpoint energy conserved over 10^5 steps", test_conservation_long},
    CU_TEST_INFO_NULL,
};
#endif

CU_SuiteInfo dth_test_suites[] = {
    {.pName = "coupled-model", .pTests = model_tests},
    {.pName = "coupled-step", .pTests = step_tests},
#ifdef DTH_COUPLED_LONG
    {.pName = "coupled-long", .pTests = long_tests},
#endif
    CU_SUITE_INFO_NULL,
};
