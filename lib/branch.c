/* SPDX-License-Identifier: MIT */
/*
 * Branch selection: every real root of the decoupled constraint g(lambda) = H(zbar(lambda, z_k))
 * (paper, Theorem "Decoupling", Lemmas "g_taylor" and "Monotonicity", Theorems EU_1-EU_3 and
 * "ghost") and their classes (minus, plus, ghost, double); the DTH stepper's policy (policy.c) uses
 * it for its full search.
 */
#include <math.h>
#include <stdio.h>
#include <string.h>
#include <gsl/gsl_poly.h>
#include "dth/branch.h"
#include "dth_internal.h"
#include "policy.h"

/* The physical root's reach: s <= 6/5 (Theorem EU_2 (vi)); beyond it the nearest root is a ghost. */
#define S_GHOST 1.2

struct dth_rootfinder {
    const dth_model *model;
    const dth_allocator *alloc;
    dth_root_options opt;
    size_t n, N, d;
    int auton, M;         /* M: unknowns of the decoupled solve (q, p; wp if non-autonomous) */
    int nsmall;           /* n (1..3) where vertex_quantities takes its unrolled path, else 0 */
    /* the model's callbacks and state, called directly at the vertex (vertex_quantities_n) */
    int (*meval)(const void *self, const double *y, unsigned what, double *H, double *grad, double *hess);
    int (*third)(const void *self, const double *y, const double *u, double *d3); /* NULL: none */
    const void *mself;
    int *act, *piv;       /* z-index of each unknown; LU pivots */
    dth__polish_fn polish; /* polish with the host stepper's Newton (from its current vertex), */
    void *pctx;
    dth_integrator *own;   /* or with a DTH integrator of our own (a standalone finder) */
    double *z, *grad, *hess, *u, *A, *F, *v, *work, *seed, *ze, *zf, *rz, *rb1, *rb2, *rb3, *nx, *ndx;
    /* the decoupled solve in progress (solve_at): vertex, lambda, midpoint */
    const double *sz;
    double slam, *szb, sHp; /* ... and H_phys at the last evaluated midpoint */
    double blo[DTH_MAX_ROOTS], bhi[DTH_MAX_ROOTS]; /* bracket of each root (for polishing) */
    size_t cap;           /* grid capacity (both sides and 0) */
    double *gl, *gg, *gd, *gz, *tmp; /* grid: lambda, g, g', zbar (cap x N); sort keys */
    long evals;
    double *block;
    int *iblock;
};

void dth_root_options_default(dth_root_options *o)
{
    memset(o, 0, sizeof *o);
    o->n_uniform = 64;
    o->n_geom = 40;
    o->max_iter = 30;
    o->polish = 1;
}

const char *dth_root_class_name(const dth_root *r)
{
    if (r->flags & DTH_ROOT_ZERO) return "zero";
    if (r->flags & DTH_ROOT_DOUBLE) return "double";
    return dth_branch_name(r->cls);
}

int dth__rootfinder_new(const dth_model *model, const dth_root_options *opt, const dth_allocator *alloc,
                        dth__polish_fn polish, void *ctx, dth_rootfinder **out)
{
    dth_root_options o;
    if (opt) o = *opt;
    else dth_root_options_default(&o);
    if (o.n_uniform < 1 || o.n_geom < 0 || o.max_iter < 1 || !isfinite(o.K) || o.n_uniform > 1000000 ||
        o.n_geom > 1000000)
        return DTH_EINVAL;
    dth_rootfinder *rf = dth_calloc(alloc, 1, sizeof *rf);
    if (!rf) return DTH_ENOMEM;
    rf->model = model;
    rf->alloc = alloc;
    rf->opt = o;
    rf->n = dth_model_dof(model);
    rf->N = 2 * rf->n + 2;
    rf->d = 2 * rf->n + 1;
    rf->auton = dth_model_get_info(model)->autonomous;
    rf->M = (int)(rf->auton ? 2 * rf->n : 2 * rf->n + 1);
    rf->polish = polish;
    rf->pctx = ctx;
    rf->nsmall = rf->n <= 3 ? (int)rf->n : 0;
    rf->meval = dth_model_get_type(model)->eval;
    rf->third = dth_model_get_type(model)->third;
    rf->mself = dth__model_self(model);
    size_t N = rf->N, d = rf->d, M = (size_t)rf->M;
    rf->cap = 2 * ((size_t)o.n_uniform + (size_t)o.n_geom + 8) + 1;
    size_t sizes[] = {N, d, d * d, N, M * M, M, N, dth_model_work_size(model), N, N, N, N, N, N,
                      DTH_MAX_ROOTS * N, rf->cap, rf->cap, rf->cap, rf->cap * N, rf->cap, M, M};
    double **slots[] = {&rf->z, &rf->grad, &rf->hess, &rf->u, &rf->A, &rf->F, &rf->v, &rf->work,
                        &rf->seed, &rf->ze, &rf->zf, &rf->rb1, &rf->rb2, &rf->rb3, &rf->rz,
                        &rf->gl, &rf->gg, &rf->gd, &rf->gz, &rf->tmp, &rf->nx, &rf->ndx};
    size_t nd = 0;
    for (size_t i = 0; i < sizeof sizes / sizeof sizes[0]; i++) nd += sizes[i];
    rf->block = dth_calloc(alloc, nd, sizeof(double));
    rf->iblock = dth_calloc(alloc, 2 * M + 1, sizeof(int));
    int rc = rf->block && rf->iblock ? DTH_OK : DTH_ENOMEM;
    if (!rc) {
        double *p = rf->block;
        for (size_t i = 0; i < sizeof slots / sizeof slots[0]; i++) {
            *slots[i] = p;
            p += sizes[i];
        }
        rf->act = rf->iblock;
        rf->piv = rf->iblock + M;
        int a = 0;
        for (size_t j = 0; j < N; j++) {
            if (j == rf->n || (rf->auton && j == N - 1)) continue; /* t (and wp) in closed form */
            rf->act[a++] = (int)j;
        }
    }
    if (!rc && !polish) {
        dth_options io;
        dth_options_default(&io);
        io.h = 1.0;
        io.max_iter = o.max_iter;
        io.alloc = alloc;
        io.branch_check = 0; /* the polishing integrator takes Newton's root as it is */
        rc = dth_integrator_new(model, &io, &rf->own);
    }
    if (rc) {
        dth_rootfinder_free(rf);
        return rc;
    }
    *out = rf;
    return DTH_OK;
}

int dth_rootfinder_new(const dth_model *model, const dth_root_options *opt, const dth_allocator *alloc,
                       dth_rootfinder **out)
{
    if (!out) return DTH_EINVAL;
    *out = NULL;
    if (!model) return DTH_EINVAL;
    return dth__rootfinder_new(model, opt, alloc, NULL, NULL, out);
}

void dth_rootfinder_free(dth_rootfinder *rf)
{
    if (!rf) return;
    dth_integrator_free(rf->own);
    dth_free(rf->alloc, rf->block);
    dth_free(rf->alloc, rf->iblock);
    dth_free(rf->alloc, rf);
}

/* Inline kernels take nc: the number of degrees of freedom when it is a compile-time constant
 * (n = 1, 2, 3: the loops unroll, as the integrator's small path), else 0 (rf->n). */
#define AI static inline __attribute__((always_inline))

/*
 * H, psi, psi' at the vertex with one evaluation (psi' from the model's third derivative, else by
 * dth_model_psi's difference). *pabs gets sum |u_i H_ij u_j|, the scale of psi's round-off.
 * Every instance does the same operations in the same order (the same bits, whatever nc); the
 * model's eval is called directly, with dth__model_eval_raw's statuses and checks written out.
 */
AI int vertex_quantities_n(dth_rootfinder *rf, const size_t nc, const double *z, double *H, double *psi,
                           double *dpsi, double *pabs)
{
    size_t n = nc ? nc : rf->n, d = 2 * n + 1, N = d + 1;
    const double *g = rf->grad, *hs = rf->hess;
    double Hp, us[7], *u = nc ? us : rf->u;
    /* the Hessian is not swept for NaN/Inf: psi and psi' are checked instead */
    int rc = rf->meval(rf->mself, z, DTH_EVAL_H | DTH_EVAL_GRAD | DTH_EVAL_HESS, &Hp, rf->grad, rf->hess);
    if (rc) return rc > 0 ? DTH_EDOMAIN : DTH_EMODEL;
    if (!isfinite(Hp)) return DTH_EDOMAIN;
    for (size_t j = 0; j < d; j++)
        if (!isfinite(g[j])) return DTH_EDOMAIN;
    *H = z[N - 1] + Hp;
    /* u = J grad H over y (dth__flow_y) */
    for (size_t i = 0; i < n; i++) {
        u[i] = g[n + 1 + i];
        u[n + 1 + i] = -g[i];
    }
    u[n] = 1.0;
    double s = 0, sa = 0;
    for (size_t i = 0; i < d; i++) {
        double r = 0, ra = 0;
        for (size_t j = 0; j < d; j++) {
            /* the small path reads each entry alone (volatile): the model has just stored them one
             * by one, and a vectorised load of two would wait for both stores to reach the cache
             * (a failed store-to-load forwarding: a few % of a pendulum step) */
            double t = (nc ? ((const volatile double *)hs)[i * d + j] : hs[i * d + j]) * u[j];
            r += t;
            ra += fabs(t);
        }
        s += u[i] * r;
        sa += fabs(u[i]) * ra;
    }
    *psi = s;
    *pabs = sa;
    if (!isfinite(s) || !isfinite(sa)) return DTH_EDOMAIN;
    if (rf->third) {
        int r3 = rf->third(rf->mself, z, u, dpsi);
        if (r3) return r3 > 0 ? DTH_EDOMAIN : DTH_EMODEL;
        return isfinite(*dpsi) ? DTH_OK : DTH_EDOMAIN;
    }
    return dth_model_psi(rf->model, z, NULL, dpsi, rf->work);
}

/* vertex_quantities_n's instances: the generic one, and n = 1, 2, 3 (rf->nsmall) */
#define VQ(N)                                                                                                   \
    static int vq_##N(dth_rootfinder *rf, const double *z, double *H, double *psi, double *dpsi, double *pabs)  \
    {                                                                                                           \
        return vertex_quantities_n(rf, N, z, H, psi, dpsi, pabs);                                               \
    }
VQ(0)
VQ(1)
VQ(2)
VQ(3)
static int (*const vq[4])(dth_rootfinder *, const double *, double *, double *, double *, double *) = {vq_0, vq_1, vq_2,
                                                                                                       vq_3};

static int vertex_quantities(dth_rootfinder *rf, const double *z, double *H, double *psi, double *dpsi,
                             double *pabs)
{
    return vq[rf->nsmall](rf, z, H, psi, dpsi, pabs);
}

int dth__rootfinder_vertex(dth_rootfinder *rf, const double *z, const double *zlo, double *H, double *psi,
                           double *dpsi, double *pabs)
{
    for (size_t j = 0; j < rf->N; j++) rf->z[j] = z[j] + zlo[j];
    return vertex_quantities(rf, rf->z, H, psi, dpsi, pabs);
}

const double *dth__rootfinder_point(const dth_rootfinder *rf) { return rf->z; }
const double *dth__rootfinder_root_mid(const dth_rootfinder *rf, size_t k) { return rf->rz + k * rf->N; }

/* ---- the decoupled solve as a Newton problem (newton.c): unknowns the active components of zb */

static int dec_eval(void *ctx, const double *x, double *F, int jac)
{
    dth_rootfinder *rf = ctx;
    size_t n = rf->n;
    int M = rf->M;
    double *zb = rf->szb, Hp, lam = rf->slam;
    for (int a = 0; a < M; a++) zb[rf->act[a]] = x[a];
    int rc = dth__model_eval_raw(rf->model, zb, DTH_EVAL_H | DTH_EVAL_GRAD | (jac ? DTH_EVAL_HESS : 0u), &Hp, rf->grad,
                                 rf->hess);
    if (rc) return rc;
    rf->sHp = Hp;
    dth__flow_z(n, rf->grad, rf->u);
    for (int a = 0; a < M; a++) {
        int j = rf->act[a];
        F[a] = zb[j] - rf->sz[j] - 0.5 * lam * rf->u[j];
        if (jac)
            for (int b = 0; b < M; b++)
                rf->A[a + b * M] = (a == b ? 1.0 : 0.0) - 0.5 * lam * dth__dudz(n, rf->hess, (size_t)j, (size_t)rf->act[b]);
    }
    if (!jac) return DTH_OK;
    rc = dth__lu_factor(DTH_LINSOLVE_AUTO, M, rf->A, rf->piv);
    return rc == DTH_ESINGULAR ? DTH_ENOCONV : rc;
}

static int dec_solve(void *ctx, double *b)
{
    dth_rootfinder *rf = ctx;
    return dth__lu_solve(DTH_LINSOLVE_AUTO, rf->M, rf->A, rf->piv, 1, b);
}

static int dec_judge(void *ctx, const double *x, const double *dx, const double *F, dth__newton_track *tr, int *verdict)
{
    dth_rootfinder *rf = ctx;
    (void)F;
    double r = 0;
    for (int a = 0; a < rf->M; a++) {
        double sc = fabs(rf->sz[rf->act[a]]) + fabs(x[a]);
        double ra = fabs(dx[a]) / (sc > 0 ? sc : 1e-300);
        if (!(ra <= r)) r = ra;
    }
    tr->r = r;
    int v = dth__newton_rate(r, tr->r_prev, tr->iter, 4 * DBL_EPSILON);
    if (v == DTH__NT_DIVERGED || r > 1e3) return DTH_ENOCONV;
    if (v == DTH__NT_STALLED) {
        /* a stalled correction at round-off is converged; a stalled larger one is not */
        if (r <= 1e3 * DBL_EPSILON) v = DTH__NT_DONE;
        else if (tr->iter >= 6) return DTH_ENOCONV;
        else v = DTH__NT_MORE;
    }
    *verdict = v;
    return DTH_OK;
}

static const dth__newton_ops dec_ops = {dec_eval, dec_solve, dec_judge};

/*
 * The decoupled solve at lambda (Theorem "Decoupling"): zb (in: seed, out: solution) solves
 * zb - z - (lambda/2) u(zb) = 0 with t and (autonomous) wp in closed form; then g = H(zb),
 * dg = grad H . dzb/dlambda from (I - (lambda/2) Du) dzb/dlambda = u/2, and *scale the size of the
 * terms of H (round-off of g is about eps * scale).
 */
static int solve_at(dth_rootfinder *rf, const double *z, double lam, double *zb, double *g, double *dg,
                    double *scale)
{
    size_t n = rf->n, N = rf->N, d = rf->d;
    int M = rf->M, rc;
    double Hp = 0;
    rf->evals++;
    zb[n] = z[n] + 0.5 * lam;
    if (rf->auton) zb[N - 1] = z[N - 1];
    rf->sz = z;
    rf->slam = lam;
    rf->szb = zb;
    for (int a = 0; a < M; a++) rf->nx[a] = zb[rf->act[a]];
    dth__newton_track tr;
    rc = dth__newton_run(&dec_ops, rf, M, rf->opt.max_iter + 1, rf->nx, rf->F, rf->ndx, &tr);
    if (rc) return rc == DTH_ESINGULAR ? DTH_ENOCONV : rc;
    /* the Jacobian and gradient at the solution itself */
    rc = dec_eval(rf, rf->nx, rf->F, 1);
    if (rc) return rc;
    Hp = rf->sHp;
    /* dzb/dlambda: the t column of Du enters through d t_bar / d lambda = 1/2 */
    for (int a = 0; a < M; a++) {
        int j = rf->act[a];
        rf->F[a] = 0.5 * rf->u[j] + 0.25 * lam * dth__dudz(n, rf->hess, (size_t)j, n);
    }
    rc = dec_solve(rf, rf->F);
    if (rc) return rc;
    memset(rf->v, 0, N * sizeof *rf->v);
    rf->v[n] = 0.5;
    for (int a = 0; a < M; a++) rf->v[rf->act[a]] = rf->F[a];
    double s = 0, sc = fabs(zb[N - 1]) + fabs(Hp);
    for (size_t l = 0; l < d; l++) {
        s += rf->grad[l] * rf->v[l];
        sc += fabs(rf->grad[l] * zb[l]);
    }
    s += rf->v[N - 1];
    *g = zb[N - 1] + Hp;
    *dg = s;
    *scale = sc;
    return isfinite(*g) && isfinite(*dg) ? DTH_OK : DTH_EDOMAIN;
}

/* Seed zb for lambda from a solved point (lam0, z0) with slope v0 (the last solve's dzb/dlambda). */
static void predict(const dth_rootfinder *rf, const double *z0, const double *v0, double lam0, double lam, double *zb)
{
    for (size_t j = 0; j < rf->N; j++) zb[j] = z0[j] + (lam - lam0) * v0[j];
}

int dth_decoupled(dth_rootfinder *rf, const double *z, double lambda, int steps, double *g, double *dg,
                  double *zbar)
{
    if (!rf || !z || !g || !dg || !isfinite(lambda) || steps < 1) return DTH_EINVAL;
    size_t N = rf->N;
    double *zb = rf->seed, sc;
    memcpy(zb, z, N * sizeof *zb);
    double lam0 = 0;
    int rc = DTH_OK;
    /* at lambda = 0, zbar = z and dzbar/dlambda = u(z)/2 */
    double gg, dd;
    rc = solve_at(rf, z, 0.0, zb, &gg, &dd, &sc);
    for (int k = 1; !rc && k <= steps; k++) {
        double lam = lambda * k / steps;
        predict(rf, zb, rf->v, lam0, lam, rf->ze);
        memcpy(zb, rf->ze, N * sizeof *zb);
        rc = solve_at(rf, z, lam, zb, &gg, &dd, &sc);
        lam0 = lam;
    }
    if (rc) return rc;
    *g = gg;
    *dg = dd;
    if (zbar) memcpy(zbar, zb, N * sizeof *zb);
    return DTH_OK;
}

/* ------------------------------------------------------------------------ the search */

/* The grid point i: solve from the nearest solved point toward 0 (index `from`), halving on failure. */
static int grid_solve(dth_rootfinder *rf, const double *z, size_t i, size_t from, double *tolsc)
{
    size_t N = rf->N;
    double *zi = rf->gz + i * N, *zp = rf->gz + from * N, lp = rf->gl[from], lt = rf->gl[i];
    double sc;
    /* slope at the start point: re-solve it to restore rf->v (cheap: converges at once) */
    memcpy(rf->ze, zp, N * sizeof *zp);
    int rc = solve_at(rf, z, lp, rf->ze, &rf->gg[from], &rf->gd[from], &sc);
    if (rc) return rc;
    double lcur = lp;
    for (int sub = 0; sub < 12; sub++) {
        double lnext = lt;
        for (int h = 0; h < 8; h++) {
            predict(rf, rf->ze, rf->v, lcur, lnext, zi);
            rc = solve_at(rf, z, lnext, zi, &rf->gg[i], &rf->gd[i], &sc);
            if (!rc) break;
            if (rc < 0 && rc != DTH_EMODEL) return rc;
            lnext = 0.5 * (lcur + lnext);
        }
        if (rc) return rc;
        if (lnext == lt) {
            *tolsc = fmax(*tolsc, sc);
            return DTH_OK;
        }
        memcpy(rf->ze, zi, N * sizeof *zi);
        lcur = lnext;
    }
    return DTH_ENOCONV;
}

/* g at lambda from the solved point (l0, z0): into zb; returns status. */
static int eval_from(dth_rootfinder *rf, const double *z, const double *z0, double l0, double lam, double *zb,
                     double *g, double *dg, double *sc)
{
    size_t N = rf->N;
    /* restore the slope at z0 */
    memcpy(zb, z0, N * sizeof *zb);
    double g0, d0;
    int rc = solve_at(rf, z, l0, zb, &g0, &d0, sc);
    if (rc) return rc;
    memcpy(rf->zf, zb, N * sizeof *zb);
    predict(rf, rf->zf, rf->v, l0, lam, zb);
    rc = solve_at(rf, z, lam, zb, g, dg, sc);
    if (rc) {
        /* two half steps */
        double lm = 0.5 * (l0 + lam);
        predict(rf, rf->zf, rf->v, l0, lm, zb);
        rc = solve_at(rf, z, lm, zb, g, dg, sc);
        if (rc) return rc;
        memcpy(rf->zf, zb, N * sizeof *zb);
        predict(rf, rf->zf, rf->v, lm, lam, zb);
        rc = solve_at(rf, z, lam, zb, g, dg, sc);
    }
    return rc;
}

typedef struct pt {
    double l, g, dg;
    const double *zb;
} pt;

/* Root of g in the bracket (a, b) with g(a) g(b) < 0: safeguarded Newton on g (its slope is exact)
 * with bisection. *lam, the midpoint there in out_zb, and g' there. */
static int refine(dth_rootfinder *rf, const double *z, pt a, pt b, double *lam, double *out_zb, double *slope)
{
    size_t N = rf->N;
    double *zl = rf->rb1, *zh = rf->rb2, sc;
    memcpy(zl, a.zb, N * sizeof *zl);
    memcpy(zh, b.zb, N * sizeof *zh);
    double lo = a.l, hi = b.l, glo = a.g, ghi = b.g, dlo = a.dg, dhi = b.dg;
    double x = fabs(a.g) < fabs(b.g) ? a.l : b.l;
    x = a.l - a.g * (b.l - a.l) / (b.g - a.g); /* secant start */
    if (!(x > fmin(lo, hi) && x < fmax(lo, hi))) x = 0.5 * (lo + hi);
    for (int it = 0; it < 100; it++) {
        int from_lo = fabs(x - lo) <= fabs(hi - x);
        double g, dg;
        int rc = eval_from(rf, z, from_lo ? zl : zh, from_lo ? lo : hi, x, out_zb, &g, &dg, &sc);
        if (rc) return rc;
        if (g == 0) {
            *lam = x;
            *slope = dg;
            return DTH_OK;
        }
        if ((g < 0) == (glo < 0)) {
            lo = x, glo = g, dlo = dg;
            memcpy(zl, out_zb, N * sizeof *zl);
        } else {
            hi = x, ghi = g, dhi = dg;
            memcpy(zh, out_zb, N * sizeof *zh);
        }
        if (fabs(hi - lo) <= 4 * DBL_EPSILON * fmax(fabs(lo), fabs(hi))) break;
        double xn = dg != 0 ? x - g / dg : NAN;
        if (!(xn > fmin(lo, hi) && xn < fmax(lo, hi)) || fabs(xn - x) > 0.5 * fabs(hi - lo))
            xn = 0.5 * (lo + hi);
        if (xn == x || xn == lo || xn == hi) break;
        x = xn;
    }
    int use_lo = fabs(glo) <= fabs(ghi);
    *lam = use_lo ? lo : hi;
    *slope = use_lo ? dlo : dhi;
    memcpy(out_zb, use_lo ? zl : zh, N * sizeof *zl);
    return DTH_OK;
}

/* Extremum of g in (a, b) with g'(a) g'(b) < 0: Illinois on g'. lambda, g there, midpoint in out_zb. */
static int extremum(dth_rootfinder *rf, const double *z, pt a, pt b, double *lam, double *gout, double *out_zb)
{
    double la = a.l, fa = a.dg, lb = b.l, fb = b.dg, sc, g = a.g, dg = a.dg, x = la;
    int side = 0;
    for (int it = 0; it < 80; it++) {
        x = (la * fb - lb * fa) / (fb - fa);
        if (!(x > fmin(la, lb) && x < fmax(la, lb))) x = 0.5 * (la + lb);
        int rc = eval_from(rf, z, a.zb, a.l, x, out_zb, &g, &dg, &sc);
        if (rc) return rc;
        if (dg == 0) break;
        if ((dg < 0) == (fa < 0)) {
            la = x;
            fa = dg;
            if (side == -1) fb *= 0.5;
            side = -1;
        } else {
            lb = x;
            fb = dg;
            if (side == 1) fa *= 0.5;
            side = 1;
        }
        if (fabs(lb - la) <= 8 * DBL_EPSILON * fmax(fabs(la), fabs(lb))) break;
    }
    *lam = x;
    *gout = g;
    return DTH_OK;
}

/* Polish a simple root with the bordered Newton of the step; 1 if confirmed (its midpoint in zbar). */
static int polish(dth_rootfinder *rf, const double *z, double lam, const double *zb, double lo, double hi,
                  double *lam_out, double *res, double *zbar)
{
    size_t N = rf->N;
    for (size_t j = 0; j < N; j++) rf->ze[j] = zb[j] - z[j];
    double l;
    if (rf->polish) {
        if (!rf->polish(rf->pctx, lam, rf->ze, &l, res, zbar)) return 0;
    } else {
        if (dth_integrator_set_vertex(rf->own, z, 1.0) != DTH_OK) return 0;
        if (!dth__dth_polish(dth__integrator_core(rf->own), lam, rf->ze, &l, res, zbar)) return 0;
    }
    double w = 1e-6 * fabs(hi - lo);
    if (!(l >= fmin(lo, hi) - w && l <= fmax(lo, hi) + w)) return 0;
    *lam_out = l;
    return 1;
}

static void add_root(dth_rootfinder *rf, dth_root_set *out, double lam, unsigned flags, double res, double slope,
                     const double *zb, double blo, double bhi)
{
    size_t N = rf->N;
    if (out->count >= DTH_MAX_ROOTS) {
        out->truncated = 1;
        return;
    }
    rf->blo[out->count] = blo;
    rf->bhi[out->count] = bhi;
    dth_root *r = &out->root[out->count];
    memset(r, 0, sizeof *r);
    r->lambda = lam;
    r->flags = flags;
    r->residual = res;
    r->slope = slope;
    memcpy(rf->rz + out->count * N, zb, N * sizeof *zb);
    out->count++;
}

static int cmp_double(const void *a, const void *b)
{
    double x = *(const double *)a, y = *(const double *)b;
    return (x > y) - (x < y);
}

/* Classify the roots (sorted by lambda) in place (see branch.h). */
static void classify(dth_root_set *out)
{
    double psi = out->vertex.psi, dpsi = out->vertex.dpsi;
    int pz = out->psi_zero;
    for (size_t i = 0; i < out->count; i++) {
        dth_root *r = &out->root[i];
        r->s = pz ? NAN : -(dpsi / psi) * r->lambda + 0.0; /* no -0 */
        r->cls = DTH_BRANCH_GHOST;
    }
    for (int side = -1; side <= 1; side += 2) {
        /* nearest root to 0 on this side */
        dth_root *first = NULL;
        for (size_t i = 0; i < out->count; i++) {
            dth_root *r = &out->root[i];
            if (r->flags & DTH_ROOT_ZERO || r->lambda * side <= 0) continue;
            if (!first || fabs(r->lambda) < fabs(first->lambda)) first = r;
        }
        if (!first) continue;
        int physical;
        if (pz) physical = dpsi == 0 || out->sign_H_dpsi == side || out->sign_H_dpsi == 0;
        else physical = first->s <= S_GHOST;
        if (physical) first->cls = side > 0 ? DTH_BRANCH_PLUS : DTH_BRANCH_MINUS;
    }
    for (size_t i = 0; i < out->count; i++)
        if (out->root[i].flags & DTH_ROOT_ZERO) out->root[i].cls = DTH_BRANCH_NONE;
}

static int sgn(double x) { return (x > 0) - (x < 0); }

/* How far the grid reaches, in units of the vertex's root scale ell (the largest of the Taylor model's
 * landmarks: its real roots, 6 |psi/psi'|): far enough for every root the model predicts and for the
 * integrator's searches (8 steps), near enough for its 64 uniform and 40 geometric points to resolve g
 * and follow one branch of zbar. A longer range is scanned this far only and reported as truncated
 * (dth_root_set.truncated, lo, hi). */
#define SCAN_REACH 1024.0

/* H, psi, psi' at the vertex into out. */
static int search_vertex(dth_rootfinder *rf, const double *z, dth_root_set *out)
{
    double H, psi, dpsi, pabs;
    int rc = vertex_quantities(rf, z, &H, &psi, &dpsi, &pabs);
    if (rc) return rc;
    out->vertex.H = H;
    out->vertex.psi = psi;
    out->vertex.dpsi = dpsi;
    out->psi_zero = fabs(psi) <= 32 * DBL_EPSILON * pabs;
    out->sign_H_psi = out->psi_zero ? 0 : sgn(H) * sgn(psi);
    out->sign_H_dpsi = sgn(H) * sgn(dpsi);
    return DTH_OK;
}

/*
 * The grid of |lambda| on [0, *L]: geometric and uniform points, and the cubic's landmarks (Lemma
 * g_taylor: its real roots and the extremum s = 2; Lemma Monotonicity: s = 6/5, s = 6), sorted and
 * deduplicated into x (rf->tmp). *L is cut to SCAN_REACH times the vertex's step scale if it lies
 * beyond (a range the grid cannot resolve). Returns how many points.
 */
static size_t build_grid(dth_rootfinder *rf, const dth_root_set *out, double *L)
{
    double H = out->vertex.H, psi = out->vertex.psi, dpsi = out->vertex.dpsi;
    double marks[8];
    int nm = 0;
    if (!out->psi_zero && dpsi != 0) {
        double r = fabs(psi / dpsi);
        marks[nm++] = 1.2 * r;
        marks[nm++] = 2 * r;
        marks[nm++] = 6 * r;
    }
    /* the real roots of the cubic model (of its quadratic where psi' is negligible): the first nc
     * of cr (GSL writes only those) */
    double cr[3] = {0, 0, 0};
    int nc = 0;
    if (dpsi != 0 && (out->psi_zero || fabs(dpsi) * *L > 1e-8 * fabs(psi)))
        nc = gsl_poly_solve_cubic(3 * (out->psi_zero ? 0 : psi) / dpsi, 0, -24 * H / dpsi, &cr[0], &cr[1], &cr[2]);
    else if (!out->psi_zero && psi != 0)
        nc = gsl_poly_solve_quadratic(-psi / 8, 0, H, &cr[0], &cr[1]);
    for (int i = 0; i < nc && i < 3; i++) marks[nm++] = fabs(cr[i]);
    double ell = 0; /* the root scale: the largest landmark */
    for (int i = 0; i < nm; i++)
        if (isfinite(marks[i])) ell = fmax(ell, marks[i]);
    if (ell > 0 && *L > SCAN_REACH * ell) *L = SCAN_REACH * ell;
    size_t m = 0;
    double *x = rf->tmp, Lr = *L; /* |lambda| candidates */
    for (int i = 1; i <= rf->opt.n_uniform; i++) x[m++] = Lr * i / rf->opt.n_uniform;
    for (int i = 0; i < rf->opt.n_geom; i++)
        x[m++] = Lr * pow(1e-6, (double)i / (rf->opt.n_geom > 1 ? rf->opt.n_geom - 1 : 1));
    /* each side gets the same |lambda| set except landmarks, which belong to their sign only;
     * keep it simple: add landmarks to both sides (harmless extra points) */
    for (int i = 0; i < nm; i++)
        if (isfinite(marks[i]) && marks[i] > 0 && marks[i] < Lr) x[m++] = marks[i];
    qsort(x, m, sizeof *x, cmp_double);
    size_t u = 0;
    for (size_t i = 0; i < m; i++)
        if (u == 0 || x[i] > x[u - 1] * (1 + 1e-9)) x[u++] = x[i];
    m = u;
    if (2 * m + 1 > rf->cap) m = (rf->cap - 1) / 2;
    return m;
}

/* g on the grid: lambda 0 at index c = m, c + i is +x[i-1], c - i is -x[i-1]; each side solved
 * outward from 0 until a decoupled solve fails. The solved indices into *ilo .. *ihi; the round-off
 * scale of g into *tolsc. */
static int scan_grid(dth_rootfinder *rf, const double *z, size_t m, size_t *ilo, size_t *ihi, double *tolsc)
{
    size_t N = rf->N, c = m;
    const double *x = rf->tmp;
    for (size_t i = 0; i < m; i++) {
        rf->gl[c + 1 + i] = x[i];
        rf->gl[c - 1 - i] = -x[i];
    }
    rf->gl[c] = 0;
    double sc;
    memcpy(rf->gz + c * N, z, N * sizeof *z);
    int rc = solve_at(rf, z, 0.0, rf->gz + c * N, &rf->gg[c], &rf->gd[c], &sc);
    if (rc) return rc;
    rf->gd[c] = 0; /* exactly: g'(0) = -psi * 0 / 4 */
    *tolsc = sc;
    *ilo = *ihi = c;
    for (size_t i = c + 1; i < 2 * m + 1; i++) {
        if (grid_solve(rf, z, i, i - 1, tolsc)) break;
        *ihi = i;
    }
    for (size_t i = c; i-- > 0;) {
        if (grid_solve(rf, z, i, i + 1, tolsc)) break;
        *ilo = i;
    }
    return DTH_OK;
}

/* The roots between the solved grid points ilo .. ihi (c: lambda 0): sign changes refined, extrema
 * of g examined for a double root or a hidden pair; the zero root where H_k is round-off. */
static void grid_roots(dth_rootfinder *rf, const double *z, dth_root_set *out, size_t c, size_t ilo, size_t ihi)
{
    size_t N = rf->N;
    double H = out->vertex.H, tol = out->tol, lam, slope, ge;
    if (fabs(H) <= tol) add_root(rf, out, 0.0, DTH_ROOT_ZERO | DTH_ROOT_DOUBLE, fabs(H), 0.0, z, 0, 0);
    for (size_t i = ilo; i < ihi; i++) {
        pt a = {rf->gl[i], rf->gg[i], rf->gd[i], rf->gz + i * N};
        pt b = {rf->gl[i + 1], rf->gg[i + 1], rf->gd[i + 1], rf->gz + (i + 1) * N};
        if ((i == c || i + 1 == c) && fabs(H) <= tol) continue; /* g(0) is round-off: the zero root */
        if (b.g == 0 && i + 1 < ihi) {
            add_root(rf, out, b.l, 0, 0.0, b.dg, b.zb, a.l, rf->gl[i + 2]);
            continue;
        }
        if (a.g * b.g < 0) {
            if (!refine(rf, z, a, b, &lam, rf->ze, &slope)) add_root(rf, out, lam, 0, NAN, slope, rf->ze, a.l, b.l);
        } else if (a.dg * b.dg < 0 && a.g != 0) {
            /* an extremum between grid points: a double root, a hidden pair, or nothing */
            if (extremum(rf, z, a, b, &lam, &ge, rf->rb3)) continue;
            if (fabs(ge) <= tol) {
                add_root(rf, out, lam, DTH_ROOT_DOUBLE, fabs(ge), 0.0, rf->rb3, lam, lam);
            } else if (sgn(ge) != sgn(a.g)) {
                pt e = {lam, ge, 0.0, rf->rb3};
                double l1, l2;
                if (!refine(rf, z, a, e, &l1, rf->ze, &slope)) add_root(rf, out, l1, 0, NAN, slope, rf->ze, a.l, e.l);
                if (!refine(rf, z, e, b, &l2, rf->ze, &slope)) add_root(rf, out, l2, 0, NAN, slope, rf->ze, e.l, b.l);
            }
        }
    }
}

/* Polish the simple roots with the bordered Newton of the step (their residual from g where it fails). */
static void polish_roots(dth_rootfinder *rf, const double *z, dth_root_set *out)
{
    size_t N = rf->N;
    double res, sc;
    for (size_t k = 0; k < out->count; k++) {
        dth_root *r = &out->root[k];
        if (r->flags & DTH_ROOT_DOUBLE) continue;
        const double *zk = rf->rz + k * N;
        double lp;
        if (rf->opt.polish && polish(rf, z, r->lambda, zk, rf->blo[k], rf->bhi[k], &lp, &res, rf->zf)) {
            r->lambda = lp;
            r->residual = res;
            memcpy(rf->rz + k * N, rf->zf, N * sizeof *rf->zf);
        } else {
            double g, dg;
            if (rf->opt.polish) r->flags |= DTH_ROOT_UNPOLISHED;
            r->residual = eval_from(rf, z, zk, r->lambda, r->lambda, rf->ze, &g, &dg, &sc) ? NAN : fabs(g);
        }
    }
}

/* Sort the roots by lambda; merge two closer than the resolution (g at their middle is round-off). */
static void sort_merge(dth_rootfinder *rf, const double *z, dth_root_set *out)
{
    size_t N = rf->N;
    double sc;
    for (size_t i = 1; i < out->count; i++)
        for (size_t j = i; j > 0 && out->root[j - 1].lambda > out->root[j].lambda; j--) {
            dth_root t = out->root[j];
            out->root[j] = out->root[j - 1];
            out->root[j - 1] = t;
            memcpy(rf->ze, rf->rz + j * N, N * sizeof(double));
            memcpy(rf->rz + j * N, rf->rz + (j - 1) * N, N * sizeof(double));
            memcpy(rf->rz + (j - 1) * N, rf->ze, N * sizeof(double));
        }
    for (size_t i = 0; i + 1 < out->count;) {
        dth_root *r1 = &out->root[i], *r2 = &out->root[i + 1];
        double g, dg, mid = 0.5 * (r1->lambda + r2->lambda);
        int merge = 0;
        if (r1->lambda == r2->lambda) merge = 1;
        else if (!eval_from(rf, z, rf->rz + i * N, r1->lambda, mid, rf->ze, &g, &dg, &sc) && fabs(g) <= out->tol)
            merge = 1;
        if (!merge) {
            i++;
            continue;
        }
        /* one root within the resolution; the zero root (H_k = 0) absorbs its neighbours */
        unsigned zf = (r1->flags | r2->flags) & DTH_ROOT_ZERO;
        r1->lambda = zf ? 0.0 : r1->lambda == r2->lambda ? r1->lambda : mid;
        r1->flags |= DTH_ROOT_DOUBLE | zf;
        r1->slope = 0;
        for (size_t k = i + 1; k + 1 < out->count; k++) {
            out->root[k] = out->root[k + 1];
            memcpy(rf->rz + k * N, rf->rz + (k + 1) * N, N * sizeof(double));
        }
        out->count--;
    }
}

/* The vertex's K (see branch.h; the local estimate over the solved grid points with |lambda| >= L/8)
 * and its region. */
static void vertex_region(dth_rootfinder *rf, dth_root_set *out, size_t ilo, size_t ihi, double L)
{
    double H = out->vertex.H, psi = out->vertex.psi, dpsi = out->vertex.dpsi;
    double K = rf->opt.K > 0 ? rf->opt.K : dth_model_get_info(rf->model)->K;
    if (!(K > 0)) {
        K = 0;
        for (size_t i = ilo; i <= ihi; i++) {
            double l = rf->gl[i], l2 = l * l;
            if (fabs(l) < L / 8) continue;
            double cub = H - psi * l2 / 8 - dpsi * l2 * l / 24;
            K = fmax(K, fabs(rf->gg[i] - cub) / (l2 * l2));
        }
    }
    out->vertex.K = K;
    out->vertex.region = out->psi_zero ? (dpsi != 0 ? DTH_REGION_III : DTH_REGION_NONE) : dth_region_of(psi, dpsi, K);
}

int dth_find_roots(dth_rootfinder *rf, const double *z, double L, dth_root_set *out)
{
    if (!rf || !z || !out || !(L > 0) || !isfinite(L)) return DTH_EINVAL;
    size_t N = rf->N;
    for (size_t j = 0; j < N; j++)
        if (!isfinite(z[j])) return DTH_EINVAL;
    memset(out, 0, sizeof *out);
    if (z != rf->z) memcpy(rf->z, z, N * sizeof *z);
    z = rf->z;
    rf->evals = 0;
    int rc = search_vertex(rf, z, out);
    if (rc) return rc;
    double Ls = L; /* the range scanned: L, or as far as the grid resolves */
    size_t m = build_grid(rf, out, &Ls), ilo, ihi;
    double tolsc;
    rc = scan_grid(rf, z, m, &ilo, &ihi, &tolsc);
    if (rc) return rc;
    out->lo = rf->gl[ilo];
    out->hi = rf->gl[ihi];
    out->tol = 32 * DBL_EPSILON * tolsc;
    grid_roots(rf, z, out, m, ilo, ihi);
    polish_roots(rf, z, out);
    sort_merge(rf, z, out);
    vertex_region(rf, out, ilo, ihi, Ls);
    classify(out);
    /* roots beyond the scan may exist: the list is incomplete */
    if (out->lo > -L || out->hi < L) out->truncated = 1;
    out->evals = rf->evals;
    return DTH_OK;
}
