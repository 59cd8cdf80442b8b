/* SPDX-License-Identifier: MIT */
/*
 * The DTH method of order 4 (issue 22; the paper's DTH step, Theorem "DTH Equations", with its
 * constraint moved to a level: H(zbar) + s = 0): a composite step is a palindromic composition of
 * level-shifted DTH substeps Phi_(s_m) o ... o Phi_(s_1), each solved by the DTH core's Newton
 * (dth_newton.c, every linear-solver path) with its level s_i; the levels are fixed once by the start
 * step, an implicit-midpoint composition of tau = h from the start vertex (s_i = -H(zbar_i)), so the
 * substeps lambda_i, and tau = sum lambda_i, are solved for as in DTH (tau ~ psi^(-1/2)). Symplectic
 * (the product of the substeps' tangent maps), wp carried bit for bit, quadratic invariants kept,
 * vertex energy O(h^4). Around psi = 0 crossings a band of prescribed-step compositions carries the
 * run (compose_band.c). The stepper type dth__stepper_compose (method "dth", order 4).
 */
#include <math.h>
#include <stdio.h>
#include <string.h>
#include "compose.h"
#include "dth/regularize.h"
#include "stepper.h"

/* ---- the coefficient tables (palindromic; sources: Suzuki, Phys. Lett. A 146 (1990) 319; Yoshida,
 * Phys. Lett. A 150 (1990) 262; Kahan & Li, Math. Comp. 66 (1997) 1089 = Hairer-Lubich-Wanner, GNI
 * V.3; Yoshida's solution A re-solved in double precision by the research prototype, r22, a change of
 * 7e-15 from the published 15 digits) ---- */

#define S4P 0.41449077179437573714 /* 1 / (4 - 4^(1/3)) */
#define Y4A 1.3512071919596576340  /* 1 / (2 - 2^(1/3)) */
#define Y4B (-1.7024143839193152681) /* -2^(1/3) / (2 - 2^(1/3)) */
static const double g_suzuki4[] = {S4P, S4P, 1 - 4 * S4P, S4P, S4P};
static const double g_yoshida4[] = {Y4A, Y4B, Y4A};
static const double g_yoshida6a[] = {0.784513610477559, 0.23557321335935738, -1.1776799841788732, 1.3151863206839136,
                                     -1.1776799841788732, 0.23557321335935738, 0.784513610477559};
static const double g_kahanli6[] = {0.39216144400731413927925056, 0.33259913678935943859974864,
                                    -0.70624617255763935980996482, 0.08221359629355080023149045,
                                    0.79854399093482996339895035, 0.08221359629355080023149045,
                                    -0.70624617255763935980996482, 0.33259913678935943859974864,
                                    0.39216144400731413927925056};
static const double g_kahanli8[] = {0.13020248308889008087881763, 0.56116298177510838456196441,
                                    -0.38947496264484728640807860, 0.15884190655515560089621075,
                                    -0.39590389413323757733623154, 0.18453964097831570709183254,
                                    0.25837438768632204729397911, 0.29501172360931029887096624,
                                    -0.60550853383003451169892108, 0.29501172360931029887096624,
                                    0.25837438768632204729397911, 0.18453964097831570709183254,
                                    -0.39590389413323757733623154, 0.15884190655515560089621075,
                                    -0.38947496264484728640807860, 0.56116298177510838456196441,
                                    0.13020248308889008087881763};
#define TAB(name, nom, doc) {#name, nom, (int)(sizeof g_##name / sizeof g_##name[0]), g_##name, doc}
static const dth__table tables[] = {
    TAB(suzuki4, 4, "Suzuki's 5 stages (the default): 10-100x more accurate than yoshida4 at equal h"),
    TAB(yoshida4, 4, "Yoshida's 3 stages (a backward middle substep)"),
    TAB(yoshida6a, 6, "Yoshida's 7 stages, solution A: order 6 for a fixed-step method, order 4 here"),
    TAB(kahanli6, 6, "Kahan and Li's 9 stages: order 6 for a fixed-step method, order 4 here"),
    TAB(kahanli8, 8, "Kahan and Li's 17 stages: order 8 for a fixed-step method, order 4 here"),
};
#undef TAB

const dth__table *dth__table_at(size_t i) { return i < sizeof tables / sizeof tables[0] ? &tables[i] : NULL; }

const dth__table *dth__table_find(const char *name)
{
    if (!name) return &tables[0];
    for (size_t i = 0; dth__table_at(i); i++)
        if (strcmp(tables[i].name, name) == 0) return &tables[i];
    return NULL;
}

void dth__comp_seterr(dth__comp *c, const char *fmt, ...)
{
    va_list ap;
    va_start(ap, fmt);
    vsnprintf(c->errmsg, sizeof c->errmsg, fmt, ap);
    va_end(ap);
}

double dth__comp_level(const dth__comp *c, int i, int sigma)
{
    double s = c->sg.levels[i];
    return sigma > 0 ? s : -2 * c->st.href - s; /* the mirror about H = href: offsets H(z) + s change sign */
}

int dth__comp_place(dth__comp *c, const double *z, const double *zlo)
{
    dth__dth *k = c->core;
    if (z != k->st.z) memcpy(k->st.z, z, c->N * sizeof *z);
    if (zlo != k->st.zlo) memcpy(k->st.zlo, zlo, c->N * sizeof *zlo);
    int rc = dth__rho_direct(k, k->st.z, k->st.zlo, &k->st.rho, &k->st.rholo);
    if (rc) dth__comp_seterr(c, "model evaluation failed at the vertex: %s", dth_strerror(rc));
    return rc;
}

/* ---- create, start ---- */

static void destroy(void *s)
{
    dth__comp *c = s;
    if (!c) return;
    if (c->core) dth__stepper_dth.destroy(c->core);
    dth__mid_free(c->mid);
    dth_free(c->alloc, c->M1);
    dth_free(c->alloc, c->block);
    dth_free(c->alloc, c);
}

static int carve(dth__comp *c)
{
    size_t N = c->N, m = (size_t)c->m, mN = m * N;
    size_t sizes[] = {N, m, m, m, m, mN, mN, mN, mN, mN, mN, m, N, N, N, 3 * N, N, N, N, N, N,
                      dth_model_work_size(c->model)};
    size_t nd = 0;
    for (size_t i = 0; i < sizeof sizes / sizeof sizes[0]; i++) nd += sizes[i];
    c->block = dth_calloc(c->alloc, nd, sizeof(double));
    if (!c->block) return DTH_ENOMEM;
    double *p = c->block;
    double **slots[] = {&c->st.zprev, &c->sg.levels, &c->sg.lam1, &c->sg.lam2, &c->sg.lam3, &c->hs.d1, &c->hs.d2,
                        &c->hs.d3, &c->hs.mids,
                        &c->nd1, &c->nmids, &c->nlam, &c->sz, &c->szlo, &c->szbar, &c->sdp, &c->y, &c->ylo,
                        &c->d, &c->u, &c->g, &c->pw};
    for (size_t i = 0; i < sizeof slots / sizeof slots[0]; i++) {
        *slots[i] = p;
        p += sizes[i];
    }
    return DTH_OK;
}

static int create(const dth_model *model, const dth_options *opt, void **out)
{
    dth__comp *c = dth_calloc(opt->alloc, 1, sizeof *c);
    if (!c) return DTH_ENOMEM;
    c->model = model;
    c->alloc = opt->alloc;
    c->opt = *opt;
    c->tab = dth__table_find(opt->table);
    c->m = c->tab->stages;
    c->n = dth_model_dof(model);
    c->N = 2 * c->n + 2;
    c->auton = dth_model_get_info(model)->autonomous;
    /* land (the default) switches the band on, none off (dth_options_check refuses any other) */
    c->band_on = opt->regularizer && strcmp(dth_regularizer_get_type(opt->regularizer)->name, "none") != 0;
    /* the core: the DTH step of order 2 without policy (the composition screens its substeps) */
    dth_options co = *opt;
    co.order = 2;
    co.table = NULL;
    co.band_time = 0;
    co.regularizer = NULL;
    co.branch_check = 0;
    void *core = NULL;
    int rc = carve(c);
    if (!rc) rc = dth__stepper_dth.create(model, &co, &core);
    c->core = core;
    if (!rc) rc = dth__mid_new(model, c->core->kind, c->alloc, &c->mid);
    if (rc) {
        destroy(c);
        return rc;
    }
    c->st.h = opt->h;
    c->st.dir = opt->h > 0 ? 1.0 : -1.0;
    c->st.sigma = c->st.sign0 = 1;
    c->st.psi_est = NAN;
    c->st.kx = -1;
    c->st.d2psi = NAN;
    snprintf(c->errmsg, sizeof c->errmsg, "no error");
    *out = c;
    return DTH_OK;
}

/* A new start at the vertex z (wp included): the start step (or a band) comes next. */
static int begin(dth__comp *c, const double *z, double h)
{
    double H;
    int rc = dth__stepper_dth.set_vertex(c->core, z, h);
    if (!rc) rc = dth_model_eval(c->model, z, DTH_EVAL_H, &H, NULL, NULL);
    if (rc) {
        dth__comp_seterr(c, "model evaluation failed at the initial vertex: %s", dth_strerror(rc));
        return rc;
    }
    double *zprev = c->st.zprev;
    memset(&c->st, 0, sizeof c->st);
    c->st.zprev = zprev;
    c->st.href = z[c->N - 1] + H;
    c->st.h = h;
    c->st.dir = h > 0 ? 1.0 : -1.0;
    c->st.sigma = c->st.sign0 = 1;
    c->st.psi_est = NAN;
    c->st.kx = -1;
    c->st.d2psi = NAN;
    c->st.pending = 1;
    return c->band_on ? dth__comp_start_band(c) : DTH_OK;
}

/* Both start modes give the vertex z_0 = (q0, t0, p0) with wp = -H_phys(z_0) (or the explicit wp): a
 * vertex start, so that the first row is the initial state (a midpoint start's state as the first
 * substep's midpoint would be order 2: research r22, section 2.3). */
static int start(void *s, const double *q0, const double *p0, double t0)
{
    dth__comp *c = s;
    if (!q0 || !p0 || !isfinite(t0)) return DTH_EINVAL;
    size_t n = c->n, N = c->N;
    double *z = c->y, H;
    for (size_t i = 0; i < n; i++) {
        if (!isfinite(q0[i]) || !isfinite(p0[i])) {
            dth__comp_seterr(c, "initial value %zu is not finite", i);
            return DTH_EINVAL;
        }
        z[i] = q0[i];
        z[n + 1 + i] = p0[i];
    }
    z[n] = t0;
    if (!(fabs(c->st.h) > 2 * DBL_EPSILON * fabs(t0))) {
        dth__comp_seterr(c, "the time t0 = %.17g does not advance by steps of h = %.3g (t + h == t)", t0, c->st.h);
        return DTH_EINVAL;
    }
    int rc = dth_model_eval(c->model, z, DTH_EVAL_H, &H, NULL, NULL);
    if (rc) {
        dth__comp_seterr(c, "model evaluation failed at the initial state");
        return rc;
    }
    z[N - 1] = c->opt.has_wp ? c->opt.wp : -H;
    return begin(c, z, c->st.h);
}

static int set_vertex(void *s, const double *z, double lambda)
{
    dth__comp *c = s;
    if (!z || !isfinite(lambda) || lambda == 0) return DTH_EINVAL;
    for (size_t j = 0; j < c->N; j++)
        if (!isfinite(z[j])) return DTH_EINVAL;
    memcpy(c->y, z, c->N * sizeof *z);
    return begin(c, c->y, lambda);
}

/* ---- the composite step ---- */

/* Substep i's seed: quadratic extrapolation of (d_i, lambda_i) over the last three steps, linear over
 * two, the last one, or (no history) gamma_i tau_pred along the flow at the substep's vertex. NULL: a
 * model failure. */
static const double *predict(dth__comp *c, int i, int nh, double tau_pred, double *lam0)
{
    size_t N = c->N;
    const double *d1 = c->hs.d1 + (size_t)i * N, *d2 = c->hs.d2 + (size_t)i * N, *d3 = c->hs.d3 + (size_t)i * N;
    double l1 = c->sg.lam1[i];
    if (nh >= 3) {
        double l = 3 * (l1 - c->sg.lam2[i]) + c->sg.lam3[i];
        if (l * l1 > 0 && fabs(l) <= 2 * fabs(l1) && 2 * fabs(l) >= fabs(l1)) {
            for (size_t j = 0; j < N; j++) c->d[j] = 3 * (d1[j] - d2[j]) + d3[j];
            *lam0 = l;
            return c->d;
        }
    }
    if (nh >= 2) {
        double l = 2 * l1 - c->sg.lam2[i];
        if (l * l1 > 0 && fabs(l) <= 2 * fabs(l1) && 2 * fabs(l) >= fabs(l1)) {
            for (size_t j = 0; j < N; j++) c->d[j] = 2 * d1[j] - d2[j];
            *lam0 = l;
            return c->d;
        }
    }
    if (nh >= 1) {
        *lam0 = l1;
        return d1;
    }
    double H, l = c->tab->g[i] * tau_pred;
    int rc = dth_model_eval(c->model, c->core->st.z, DTH_EVAL_GRAD, &H, c->g, NULL);
    if (rc) {
        dth__comp_seterr(c, "model evaluation failed at the vertex of substep %d", i + 1);
        return NULL;
    }
    dth__flow_z(c->n, c->g, c->u);
    for (size_t j = 0; j < N; j++) c->d[j] = 0.5 * l * c->u[j];
    *lam0 = l;
    return c->d;
}

int dth__comp_composite(dth__comp *c, int sigma, double tau_pred, dth_step_info *info)
{
    dth__dth *k = c->core;
    size_t N = c->N;
    int m = c->m, nh = isnan(tau_pred) ? c->st.nh : 0, rc = DTH_OK;
    double tau = 0, res = 0;
    info->iters = 0;
    for (int i = 0; i < m && !rc; i++) {
        double lam0;
        const double *d0 = predict(c, i, nh, tau_pred, &lam0);
        if (!d0) return DTH_EDOMAIN;
        k->level = dth__comp_level(c, i, sigma);
        dth__solution sol = {NAN, NAN, 0};
        rc = dth__newton(k, lam0, d0, c->opt.max_iter, &sol);
        info->iters += sol.iters;
        if (rc) {
            dth__comp_seterr(c, "substep %d of %d (level %.17g): %s", i + 1, m, k->level, k->errmsg);
        } else if (!(sol.lambda * lam0 > 0) || !(fabs(sol.lambda) >= 0.5 * fabs(lam0)) ||
                   !(fabs(sol.lambda) <= 2 * fabs(lam0))) {
            /* the root on the other side, or far from the predictor: a fold or psi = 0 near */
            dth__comp_seterr(c, "substep %d of %d found lambda = %.6g where %.6g was predicted (a fold or psi = 0 "
                                "near: the regularizer land carries the run through)", i + 1, m, sol.lambda, lam0);
            rc = DTH_EFOLD;
        } else if ((rc = dth__commit(k, sol.lambda, 0)) != DTH_OK) {
            dth__comp_seterr(c, "substep %d of %d: %s", i + 1, m, k->errmsg);
        } else {
            memcpy(c->nd1 + (size_t)i * N, k->st.dprev, N * sizeof *c->nd1);
            memcpy(c->nmids + (size_t)i * N, k->st.zbar, N * sizeof *c->nmids);
            c->nlam[i] = sol.lambda;
            tau += sol.lambda;
            res = fmax(res, sol.residual);
        }
    }
    k->level = 0;
    if (rc) return rc;
    info->lambda = tau;
    info->residual = res;
    info->branch = c->st.dir > 0 ? DTH_BRANCH_PLUS : DTH_BRANCH_MINUS;
    return DTH_OK;
}

static void swap(double **a, double **b)
{
    double *t = *a;
    *a = *b;
    *b = t;
}

void dth__comp_commit_hist(dth__comp *c, int band)
{
    double tau = 0;
    for (int i = 0; i < c->m; i++) tau += c->nlam[i];
    swap(&c->hs.d3, &c->hs.d2);
    swap(&c->hs.d2, &c->hs.d1);
    swap(&c->hs.d1, &c->nd1);
    swap(&c->hs.mids, &c->nmids);
    swap(&c->sg.lam3, &c->sg.lam2);
    swap(&c->sg.lam2, &c->sg.lam1);
    swap(&c->sg.lam1, &c->nlam);
    memcpy(c->st.zprev, c->sz, c->N * sizeof *c->sz); /* the vertex the step left */
    c->st.have_prev = 1;
    c->st.nh = band ? 1 : c->st.nh < 3 ? c->st.nh + 1 : 3;
    c->st.last_band = band;
    c->st.fact_valid = 1;
    c->st.lam = tau;
    c->st.steps++;
}

/* ---- one step, atomic ---- */

static void save(dth__comp *c)
{
    dth__dth *k = c->core;
    dth__comp_snap *s = &c->sv;
    size_t N = c->N;
    s->st = c->st;
    s->core = k->st;
    s->dnew = k->dnew;
    memcpy(c->sz, k->st.z, N * sizeof *c->sz);
    memcpy(c->szlo, k->st.zlo, N * sizeof *c->sz);
    memcpy(c->szbar, k->st.zbar, N * sizeof *c->sz);
    memcpy(c->sdp, k->st.dprev, N * sizeof *c->sz);
    memcpy(c->sdp + N, k->st.dprev2, N * sizeof *c->sz);
    memcpy(c->sdp + 2 * N, k->st.dprev3, N * sizeof *c->sz);
}

void dth__comp_rewind(dth__comp *c, int all)
{
    dth__dth *k = c->core;
    const dth__comp_snap *s = &c->sv;
    size_t N = c->N;
    if (all) c->st = s->st;
    k->st = s->core;
    k->dnew = s->dnew;
    k->level = 0;
    memcpy(k->st.z, c->sz, N * sizeof *c->sz);
    memcpy(k->st.zlo, c->szlo, N * sizeof *c->sz);
    memcpy(k->st.zbar, c->szbar, N * sizeof *c->sz);
    memcpy(k->st.dprev, c->sdp, N * sizeof *c->sz);
    memcpy(k->st.dprev2, c->sdp + N, N * sizeof *c->sz);
    memcpy(k->st.dprev3, c->sdp + 2 * N, N * sizeof *c->sz);
}

/* A composite step on the current levels; with the band on, a failed or crossing one becomes a
 * band step from the same vertex. */
static int step_composite(dth__comp *c, dth_step_info *info)
{
    dth__dth *k = c->core;
    double rho1 = k->st.rho + k->st.rholo + dth__comp_level(c, 0, c->st.sigma); /* substep 1's offset */
    int rc = dth__comp_composite(c, c->st.sigma, NAN, info), undo = 0;
    if (!rc && c->band_on) rc = dth__comp_health(c, c->sz, rho1, &undo);
    if (!rc && !undo) {
        dth__comp_commit_hist(c, 0);
        return DTH_OK;
    }
    if (!c->band_on || (rc && rc != DTH_EFOLD && rc != DTH_ENOCONV && rc != DTH_ENOROOT && rc != DTH_ESINGULAR))
        return rc;
    /* into the band from the vertex before this step, with the last step's tau */
    dth__comp_rewind(c, 1); /* info keeps the failed step's iterations */
    c->st.band = 1;
    c->st.tau_b = c->st.tau_b0 = c->st.lam != 0 ? c->st.lam : c->st.h;
    return dth__comp_band_step(c, 0, info);
}

static int step(void *s, dth_step_info *info)
{
    dth__comp *c = s;
    save(c);
    c->errmsg[0] = '\0';
    int rc = c->st.pending ? dth__comp_start_step(c, info) : c->st.band ? dth__comp_band_step(c, 1, info)
                                                                         : step_composite(c, info);
    if (!rc) {
        snprintf(c->errmsg, sizeof c->errmsg, "no error");
        return DTH_OK;
    }
    if (!c->errmsg[0]) snprintf(c->errmsg, sizeof c->errmsg, "%s", dth_strerror(rc));
    dth__comp_rewind(c, 1);
    return rc;
}

/* ---- reverse, tangent, accessors ---- */

/* a[0..m) in reverse order, times f, for `len` doubles a stage */
static void flip(double *a, int m, size_t len, double f, double *tmp)
{
    for (int i = 0; i < m / 2 + m % 2; i++) {
        double *x = a + (size_t)i * len, *y = a + (size_t)(m - 1 - i) * len;
        memcpy(tmp, x, len * sizeof *tmp);
        for (size_t j = 0; j < len; j++) x[j] = f * y[j];
        if (x != y)
            for (size_t j = 0; j < len; j++) y[j] = f * tmp[j];
    }
}

/* The backward step from z_k retraces the last one: its substeps in reverse order, each the reverse
 * of the forward one (the DTH substep is symmetric), so the levels are read backwards. */
static void reverse(void *s)
{
    dth__comp *c = s;
    size_t N = c->N;
    int m = c->m;
    flip(c->sg.levels, m, 1, 1, c->g);
    flip(c->sg.lam1, m, 1, -1, c->g);
    flip(c->sg.lam2, m, 1, -1, c->g);
    flip(c->sg.lam3, m, 1, -1, c->g);
    flip(c->hs.d1, m, N, -1, c->g);
    flip(c->hs.d2, m, N, -1, c->g);
    flip(c->hs.d3, m, N, -1, c->g);
    flip(c->hs.mids, m, N, 1, c->g);
    if (c->st.nh > 1) c->st.nh = 1;
    c->st.dir = -c->st.dir;
    c->st.h = -c->st.h;
    c->st.lam = -c->st.lam;
    c->st.tau_b = -c->st.tau_b;
    dth__stepper_dth.reverse(c->core);
}

/* M = M_m ... M_1, each substep's: the DTH core's bordered tangent at its midpoint (composite steps),
 * the midpoint rule's (the start and band steps). */
static int tangent(void *s, double *M)
{
    dth__comp *c = s;
    if (!c->st.fact_valid) return DTH_EINVAL; /* no step yet, or a band exit's projection */
    dth__dth *k = c->core;
    size_t N = c->N;
    if (!c->M1) { /* at the first tangent map (2 N^2 doubles: not made for runs that never ask) */
        c->M1 = dth_calloc(c->alloc, 2 * N, N * sizeof *c->M1);
        if (!c->M1) return DTH_ENOMEM;
        c->M2 = c->M1 + N * N;
    }
    double *Mi = c->M1, *P = c->M2;
    memset(M, 0, N * N * sizeof *M);
    for (size_t j = 0; j < N; j++) M[j * N + j] = 1;
    for (int i = 0; i < c->m; i++) {
        double *mid = c->hs.mids + (size_t)i * N, lam = c->sg.lam1[i];
        int rc;
        if (c->st.last_band) {
            rc = dth__mid_tangent(c->mid, mid, lam, Mi);
        } else { /* the core's tangent reads its last step: lend it substep i's */
            double *zb = k->st.zbar, *dp = k->st.dprev, l = k->st.lam;
            k->st.zbar = mid;
            k->st.dprev = c->hs.d1 + (size_t)i * N;
            k->st.lam = lam;
            rc = dth__tangent(k, Mi);
            k->st.zbar = zb, k->st.dprev = dp, k->st.lam = l;
        }
        if (rc) return rc;
        for (size_t a = 0; a < N; a++)
            for (size_t b = 0; b < N; b++) {
                double acc = 0;
                for (size_t j = 0; j < N; j++) acc += Mi[a * N + j] * M[j * N + b];
                P[a * N + b] = acc;
            }
        memcpy(M, P, N * N * sizeof *M);
    }
    return DTH_OK;
}

static const double *vertex(const void *s) { return ((const dth__comp *)s)->core->st.z; }
static const double *midpoint(const void *s)
{
    (void)s;
    return NULL; /* the substeps' midpoints lie on their levels, not on the energy surface */
}
static double lambda(const void *s) { return ((const dth__comp *)s)->st.lam; }
static double direction(const void *s) { return ((const dth__comp *)s)->st.dir; }
static double energy(const void *s)
{
    const dth__comp *c = s;
    return -(c->core->st.z[c->N - 1] + c->core->st.zlo[c->N - 1]);
}
static long steps(const void *s) { return ((const dth__comp *)s)->st.steps; }
static int order(const void *s)
{
    (void)s;
    return 4;
}
static const char *errmsg(const void *s) { return ((const dth__comp *)s)->errmsg; }
static const double *prev_vertex(const void *s)
{
    const dth__comp *c = s;
    return c->st.have_prev ? c->st.zprev : NULL;
}

/* ---- checkpoint sections: the core's step state, the composition's ---- */

#define COMP_ENTRY(name, kind, check, doc) DTH__FIELD(dth__comp_state, name, kind, check),
#define STAGE_ENTRY(name, kind, check, doc) DTH__FIELD(dth__stage_state, name, kind, check),
#define HIST_ENTRY(name, kind, check, doc) DTH__FIELD(dth__hist_state, name, kind, check),
static const dth__field comp_fields[] = {DTH__COMP_FIELDS(COMP_ENTRY)};
static const dth__field stage_fields[] = {DTH__STAGE_FIELDS(STAGE_ENTRY)};
static const dth__field hist_fields[] = {DTH__HIST_FIELDS(HIST_ENTRY)};
#undef COMP_ENTRY
#undef STAGE_ENTRY
#undef HIST_ENTRY
#define NF(a) (sizeof a / sizeof a[0])

static size_t sections(void *s, dth__section *out)
{
    dth__comp *c = s;
    dth__section core[DTH__MAX_SECTIONS];
    dth__stepper_dth.sections(c->core, core);
    size_t m = (size_t)c->m;
    out[0] = core[0]; /* the core's step state (its policy is unused) */
    out[1] = (dth__section){"compose", comp_fields, NF(comp_fields), &c->st, c->N};
    out[2] = (dth__section){"stages", stage_fields, NF(stage_fields), &c->sg, m};
    out[3] = (dth__section){"history", hist_fields, NF(hist_fields), &c->hs, m * c->N};
    return 4;
}

typedef struct optv {
    long order, table, finish, max_iter, linsolve, band;
    double band_time;
} optv;
static const dth__field opt_fields[] = {
    DTH__FIELD(optv, order, LONG, ANY),    DTH__FIELD(optv, table, LONG, ANY),    DTH__FIELD(optv, finish, LONG, ANY),
    DTH__FIELD(optv, max_iter, LONG, ANY), DTH__FIELD(optv, linsolve, LONG, ANY), DTH__FIELD(optv, band, LONG, ANY),
    DTH__FIELD(optv, band_time, F64, ANY),
};
_Static_assert(sizeof(optv) <= 64, "options_section's scratch");

static void options_section(const void *s, dth__section *out, void *scratch)
{
    const dth__comp *c = s;
    optv *o = scratch;
    *o = (optv){4, (long)(c->tab - tables), c->opt.finish, c->opt.max_iter, (long)c->core->kind, c->band_on,
                c->opt.band_time};
    *out = (dth__section){"options", opt_fields, NF(opt_fields), o, 0};
}

static void restored(void *s)
{
    dth__comp *c = s;
    dth__stepper_dth.restored(c->core);
    snprintf(c->errmsg, sizeof c->errmsg, "no error");
}

const dth__stepper_type dth__stepper_compose = {
    .name = "dth",
    .doc = "the DTH method of order 4: a composition of level-shifted DTH steps (symplectic, wp exact, quadratic "
           "momenta exact at vertices, vertex energy O(h^4))",
    .create = create,
    .destroy = destroy,
    .start = start,
    .set_vertex = set_vertex,
    .step = step,
    .reverse = reverse,
    .vertex = vertex,
    .midpoint = midpoint,
    .lambda = lambda,
    .direction = direction,
    .energy = energy,
    .steps = steps,
    .order = order,
    .errmsg = errmsg,
    .tangent = tangent,
    .sections = sections,
    .options_section = options_section,
    .restored = restored,
    .dense5 = 1,
    .prev_vertex = prev_vertex,
};
