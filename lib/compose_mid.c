/* SPDX-License-Identifier: MIT */
/*
 * The order-4 composition's prescribed-step substep (issue 22, report section 9: the start step that
 * makes the levels, the band around psi = 0): the implicit midpoint rule d = (lambda/2) J grad H(z + d)
 * with lambda given (the first block of the paper's DTH equations alone), by Newton on every linear
 * solver path (dense LU, written out for small systems, banded), its tangent map, and the symmetric
 * projection onto the reference vertex energy at a band's exit.
 */
#include <float.h>
#include <math.h>
#include <string.h>
#include "compose.h"
#include "dd.h"

struct dth__mid {
    const dth_model *model;
    const dth_allocator *al;
    dth_linsolve kind;
    size_t n, N, d, q;   /* dof, 2n + 2, 2n + 1, 2n (the unknowns: d over q and p) */
    int auton;
    dth__band *band;     /* banded models: B = I - (lambda/2) J H_xx by banded.c, else dense LU */
    size_t w, bw;        /* the Hessian's half-bandwidth, 2w + 1 */
    const double *z, *zlo;
    double lam, tbar;    /* the solve in progress: vertex, step, the midpoint's time */
    double *y, *grad, *hess, *hb, *A, *F, *x, *dx, *rhs, *G, *ys, *tmp, *sc, *nv, *zp;
    int *piv;
    size_t ninv;
    double *block;
};

void dth__mid_free(dth__mid *w)
{
    if (!w) return;
    dth__band_free(w->band, w->al);
    dth_free(w->al, w->block);
    dth_free(w->al, w->piv);
    dth_free(w->al, w);
}

int dth__mid_new(const dth_model *model, dth_linsolve kind, const dth_allocator *al, dth__mid **out)
{
    *out = NULL;
    dth__mid *w = dth_calloc(al, 1, sizeof *w);
    if (!w) return DTH_ENOMEM;
    const dth_model_info *inf = dth_model_get_info(model);
    const dth_model_type *t = dth_model_get_type(model);
    w->model = model;
    w->al = al;
    w->kind = kind;
    w->n = inf->n;
    w->N = 2 * w->n + 2;
    w->d = w->N - 1;
    w->q = 2 * w->n;
    w->auton = inf->autonomous;
    int banded = dth__linsolve_find(kind)->banded;
    w->ninv = t->n_invariants && t->invariants && dth__model_quad_mask(model) ? t->n_invariants(dth__model_self(model)) : 0;
    if (w->ninv > 64) w->ninv = 0;
    size_t d = w->d, q = w->q, dense = !banded;
    w->w = banded ? inf->bandwidth : 0;
    w->bw = 2 * w->w + 1;
    size_t sizes[] = {d, d, dense * d * d, banded ? q * w->bw : 0, dense * q * q, q, q, q, q, w->ninv * q, d,
                      2 * w->ninv, q, q, d};
    size_t nd = 0;
    for (size_t i = 0; i < sizeof sizes / sizeof sizes[0]; i++) nd += sizes[i];
    w->block = dth_calloc(al, nd, sizeof(double));
    w->piv = dth_calloc(al, q, sizeof(int));
    int rc = w->block && w->piv ? DTH_OK : DTH_ENOMEM;
    if (!rc && banded) rc = dth__band_new(model, kind == DTH_LINSOLVE_BANDED, al, &w->band);
    if (rc) {
        dth__mid_free(w);
        return rc;
    }
    double *p = w->block;
    double **slots[] = {&w->y, &w->grad, &w->hess, &w->hb, &w->A, &w->F, &w->x, &w->dx, &w->rhs, &w->G, &w->ys,
                        &w->tmp, &w->sc, &w->nv, &w->zp};
    for (size_t i = 0; i < sizeof slots / sizeof slots[0]; i++) {
        *slots[i] = sizes[i] ? p : NULL;
        p += sizes[i];
    }
    for (size_t i = 0; i < q; i++) w->sc[i] = 1;
    *out = w;
    return DTH_OK;
}

/* y index of unknown a (q_1..q_n, p_1..p_n) */
static size_t yi(size_t n, size_t a) { return a < n ? a : a + 1; }

/* The midpoint over y from the unknowns: z + (zlo + d), the time tbar. */
static void mid_point(const dth__mid *w, const double *x, double *y)
{
    size_t n = w->n;
    for (size_t a = 0; a < w->q; a++) {
        size_t j = yi(n, a);
        y[j] = w->z[j] + ((w->zlo ? w->zlo[j] : 0) + x[a]);
    }
    y[n] = w->tbar;
}

/* F = d - (lambda/2) u over (q, p); with jac the first block factored at the midpoint. */
static int mid_eval(void *ctx, const double *x, double *F, int jac)
{
    dth__mid *w = ctx;
    size_t n = w->n, q = w->q;
    double H, hl = 0.5 * w->lam;
    mid_point(w, x, w->y);
    int banded = w->band != NULL;
    unsigned what = DTH_EVAL_GRAD | (jac && !banded ? DTH_EVAL_HESS : 0u);
    int rc = dth__model_eval_raw(w->model, w->y, what, &H, w->grad, w->hess);
    if (rc) return rc;
    for (size_t i = 0; i < n; i++) {
        F[i] = x[i] - hl * w->grad[n + 1 + i];
        F[n + i] = x[n + i] + hl * w->grad[i];
    }
    if (!jac) return DTH_OK;
    if (banded) return dth__band_factor_block(w->band, w->model, w->y, w->lam);
    for (size_t a = 0; a < q; a++)
        for (size_t b = 0; b < q; b++)
            w->A[a + b * q] = (a == b ? 1.0 : 0.0) - hl * dth__dudz(n, w->hess, yi(n, a), yi(n, b));
    return dth__lu_factor(w->kind, (int)q, w->A, w->piv);
}

static int mid_solve_lin(void *ctx, double *b)
{
    dth__mid *w = ctx;
    if (w->band) return dth__band_solve_block(w->band, b);
    return dth__lu_solve(w->kind, (int)w->q, w->A, w->piv, 1, b);
}

/* Converged when the correction is at round-off of the (q, p) blocks; a correction that stalls
 * below 1e-12 of them is the noise floor. */
static int mid_judge(void *ctx, const double *x, const double *dx, const double *F, dth__newton_track *tr, int *verdict)
{
    (void)F;
    dth__mid *w = ctx;
    size_t n = w->n;
    double sq = 0, sp = 0, cq = 0, cp = 0;
    for (size_t i = 0; i < n; i++) {
        sq = fmax(sq, fabs(w->z[i]) + fabs(x[i]));
        sp = fmax(sp, fabs(w->z[n + 1 + i]) + fabs(x[n + i]));
        cq = fmax(cq, fabs(dx[i]));
        cp = fmax(cp, fabs(dx[n + i]));
    }
    double top = fmax(sq, sp);
    if (!(top > 0)) top = 1;
    double r = fmax(cq / (sq > 0 ? sq : top), cp / (sp > 0 ? sp : top));
    if (!isfinite(r)) r = INFINITY;
    tr->r = r;
    int v = dth__newton_rate(r, tr->r_prev, tr->iter, 4 * DBL_EPSILON);
    if (v == DTH__NT_DIVERGED) return DTH_ENOCONV;
    if (v == DTH__NT_STALLED) {
        if (r < 1e-12) v = DTH__NT_DONE;
        else if (tr->iter >= 10) return DTH_ENOCONV;
        else v = DTH__NT_MORE;
    }
    *verdict = v;
    return DTH_OK;
}

static const dth__newton_ops mid_ops = {mid_eval, mid_solve_lin, mid_judge};

int dth__mid_solve(dth__mid *w, const double *z, const double *zlo, double lam, double *d, double *zbar, int max_iter,
                   int *iters)
{
    size_t n = w->n, N = w->N, q = w->q;
    w->z = z;
    w->zlo = zlo;
    w->lam = lam;
    w->tbar = z[n] + ((zlo ? zlo[n] : 0) + 0.5 * lam);
    for (size_t a = 0; a < q; a++) w->x[a] = d[yi(n, a)];
    dth__newton_track tr;
    int rc = dth__newton_run(&mid_ops, w, (int)q, max_iter, w->x, w->F, w->dx, &tr);
    if (iters) *iters = tr.iter;
    if (rc) return rc;
    for (size_t a = 0; a < q; a++) d[yi(n, a)] = w->x[a];
    d[n] = 0.5 * lam;
    d[N - 1] = 0;
    mid_point(w, w->x, zbar);
    if (!w->auton) { /* wp moves by -(lambda/2) dH/dt at the midpoint */
        double H;
        rc = dth_model_eval(w->model, zbar, DTH_EVAL_GRAD, &H, w->grad, NULL);
        if (rc) return rc;
        d[N - 1] = -0.5 * lam * w->grad[n];
    }
    zbar[N - 1] = z[N - 1] + ((zlo ? zlo[N - 1] : 0) + d[N - 1]);
    return DTH_OK;
}

/* d2H / dy_a dy_b at the last Hessian evaluation (dense, or the banded layout: q_i -> 2i, p_i -> 2i + 1). */
static double hval(const dth__mid *w, size_t a, size_t b)
{
    size_t n = w->n, d = w->d;
    if (!w->band) return w->hess[a * d + b];
    if (a == n || b == n) return 0; /* banded models are autonomous */
    size_t r = a < n ? 2 * a : 2 * (a - n - 1) + 1, c = b < n ? 2 * b : 2 * (b - n - 1) + 1;
    if ((r > c ? r - c : c - r) > w->w) return 0;
    return w->hb[r * w->bw + c + w->w - r];
}

/* d u_j / d y_l over (q, t, p), u = J grad H (dth__dudz's map on hval) */
static double dudy(const dth__mid *w, size_t j, size_t l)
{
    size_t n = w->n;
    if (j < n) return hval(w, n + 1 + j, l);
    if (j > n && j < w->d) return -hval(w, j - n - 1, l);
    if (j == w->d) return -hval(w, n, l);
    return 0;
}

/*
 * M = dz' / dz of z' = z + 2 d: column l solves B X = (lambda/2) U e_l over (q, p) (U = J H_zz at zbar,
 * B = I - (lambda/2) U, t of the midpoint moving with t), M = I + 2 dd/dz; the t row is e_t (t' = t +
 * lambda), wp' = wp - lambda dH/dt(zbar) (0 for an autonomous model).
 */
int dth__mid_tangent(dth__mid *w, const double *zbar, double lam, double *M)
{
    size_t n = w->n, N = w->N, q = w->q;
    double H, hl = 0.5 * lam;
    int rc = dth_model_eval(w->model, zbar, DTH_EVAL_GRAD | (w->band ? 0u : DTH_EVAL_HESS), &H, w->grad, w->hess);
    if (!rc && w->band) rc = dth__model_hess_band(w->model, zbar, w->hb);
    if (!rc && w->band) rc = dth__band_factor_block(w->band, w->model, zbar, lam);
    if (!rc && !w->band) {
        for (size_t a = 0; a < q; a++)
            for (size_t b = 0; b < q; b++) w->A[a + b * q] = (a == b ? 1.0 : 0.0) - hl * dudy(w, yi(n, a), yi(n, b));
        rc = dth__lu_factor(w->kind, (int)q, w->A, w->piv);
    }
    if (rc) return rc;
    memset(M, 0, N * N * sizeof *M);
    for (size_t l = 0; l < N; l++) {
        M[l * N + l] = 1;
        if (l == N - 1) continue; /* nothing depends on wp */
        for (size_t a = 0; a < q; a++) w->rhs[a] = hl * dudy(w, yi(n, a), l);
        if ((rc = mid_solve_lin(w, w->rhs)) != DTH_OK) return rc;
        for (size_t a = 0; a < q; a++) M[yi(n, a) * N + l] += 2 * w->rhs[a];
        if (!w->auton) { /* wp' = wp + 2 hl u_wp(zbar): u_wp = -dH/dt */
            double s = dudy(w, N - 1, l);
            for (size_t a = 0; a < q; a++) s += dudy(w, N - 1, yi(n, a)) * w->rhs[a];
            M[(N - 1) * N + l] += 2 * hl * s;
        }
    }
    return DTH_OK;
}

/* The projection's direction at y: grad H over (q, p) with the quadratic invariants' gradients
 * projected out (into w->nv); H_phys(y) into *H. */
static int proj_dir(dth__mid *w, const double *y, double *H)
{
    size_t n = w->n, q = w->q;
    int rc = dth_model_eval(w->model, y, DTH_EVAL_H | DTH_EVAL_GRAD, H, w->grad, NULL);
    if (rc) return rc;
    for (size_t a = 0; a < q; a++) w->nv[a] = w->grad[yi(n, a)];
    size_t kept = w->ninv ? dth__quad_invariant_basis(w->model, y, w->sc, w->G, w->ys, w->tmp) : 0;
    for (size_t r = 0; r < kept; r++) {
        double dot = 0;
        for (size_t a = 0; a < q; a++) dot += w->nv[a] * w->G[r * q + a];
        for (size_t a = 0; a < q; a++) w->nv[a] -= dot * w->G[r * q + a];
    }
    return DTH_OK;
}

int dth__mid_project(dth__mid *w, double *z, double *zlo, double target)
{
    size_t n = w->n, N = w->N, q = w->q;
    double wp = z[N - 1] + zlo[N - 1], H;
    if (!w->auton) { /* the extended H = wp + H_phys onto target by wp alone */
        int rc = dth_model_eval(w->model, z, DTH_EVAL_H, &H, NULL, NULL);
        if (rc) return rc;
        z[N - 1] = two_sum(target, -H, &zlo[N - 1]);
        return DTH_OK;
    }
    double E = target - wp, mu = 0, *y = w->y, *zp = w->zp; /* zp: the projected point (its high part) */
    memcpy(zp, z, w->d * sizeof *zp);
    for (int it = 0; it < 16; it++) {
        for (size_t j = 0; j < w->d; j++) y[j] = 0.5 * (z[j] + zp[j]);
        int rc = proj_dir(w, y, &H);
        if (rc) return rc;
        memcpy(w->rhs, w->nv, q * sizeof *w->rhs); /* n at the midpoint */
        for (size_t a = 0; a < q; a++) zp[yi(n, a)] = z[yi(n, a)] + (zlo[yi(n, a)] + mu * w->rhs[a]);
        rc = proj_dir(w, zp, &H);
        if (rc) return rc;
        double slope = 0, sc = fabs(E) + fabs(H);
        for (size_t a = 0; a < q; a++) {
            slope += w->grad[yi(n, a)] * w->rhs[a];
            sc += fabs(w->grad[yi(n, a)] * zp[yi(n, a)]);
        }
        double r = H - E;
        if (fabs(r) <= 4 * DBL_EPSILON * sc || !(slope != 0)) break;
        double dmu = r / slope;
        mu -= dmu;
        if (!isfinite(mu)) return DTH_ENOCONV;
    }
    for (size_t a = 0; a < q; a++) {
        size_t j = yi(n, a);
        double e, s = two_sum(z[j], mu * w->rhs[a], &e);
        z[j] = two_sum(s, zlo[j] + e, &zlo[j]);
    }
    return DTH_OK;
}
