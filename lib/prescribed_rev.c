/* SPDX-License-Identifier: MIT */
/* The reversible finish of prescribed's kicked segment (paper, section 7; docs/theory.md, "A step that is its own reverse"). */
#include <float.h>
#include <math.h>
#include <string.h>
#include "dth/regularize.h"
#include "dd.h"
#include "dth_internal.h"
#include "kick.h"
#include "newton.h"

/*
 * A kicked segment whose step is a law read at its own midpoint, lambda = dir arc / |u(zbar)|^alpha
 * (u the (q, p) part of J grad H; the regularizer `prescribed`), finished the way the DTH step's
 * reversible finish (dth_newton.c; docs/theory.md, "A step that is its own reverse") finishes the
 * ordinary step, so that the segment from z_a and the one back from its end z_b (-lambda, -mu) find
 * the same midpoint to about 2^-100:
 *   - ONE Newton on x = (d_q, d_p, lambda, mu) in double (newton.h's driver): the rows
 *     d - (lambda/2) u(zbar) - (mu/2) n(zbar), wp + H(zbar), lambda - law(zbar) at the double midpoint;
 *   - then chord steps on the same factors, x carrying a low part (the driver's xlo), whose residual
 *     reads the model at the coarse point y (dd.h's coarsen_y of the double-double midpoint; one "cell"
 *     per y) and continues it to the midpoint by Taylor terms: g(zbar) = g(y) + H''(y) w, w = zbar - y
 *     (taylor_grad_h), H(zbar) = H(y) + (g + H'' w / 2) w, the rows by exact products (exact_row_kick),
 *     and the law as law(y) (1 + delta)^(-alpha/2), delta = (|u(zbar)|^2 - |u(y)|^2) / |u(y)|^2, by its
 *     Taylor polynomial to delta^4 in double-double (|delta| is about 2^-27 |H''| |zbar| / |u|);
 *   - the kick direction n = S P S g (kick_dir: S the metric, P the projector off S grad I of the
 *     quadratic invariants) continued the same way (kl_cell, kl_kick): n(y) once per cell, plus its
 *     first-order change along w, computed from small quantities only (so its rounding is small too):
 *     g's (above), S's (the gradient of its log at y, by differences of the Hessian's block norms), and
 *     P's (grad I(zbar) = grad I(y) + H_I w, exact for a quadratic invariant, H_I found once per run),
 *     the projection solved through the Gram matrix of S grad I. So the equations neither jump at a
 *     cell's edge by more than second-order terms (a kick frozen per cell jumps by mu |n'| times the
 *     cell, and the root may then be consistent in two cells: the direction of approach decides), nor
 *     lose the quadratic invariants (grad I(zbar) . n = 0 to round-off);
 *   - the chord steps go on until the root is resolved to 2^-100 of the scales the vertex resolves and
 *     its coarse cell is the one the last residual read; where two cells alternate, y is pinned to the
 *     componentwise lower (as step_again in dth_newton.c).
 * Both directions read the same numbers: negating (d, lambda, mu) negates every residual exactly. What
 * is left: a root within the equations' jump (the model's rounding at y, the second-order terms) of a
 * cell's edge, as for the ordinary step.
 */
enum { KL_MAX_CHORDS = 12 };

typedef struct kl_ctx {
    const dth_model *model;
    const double *z, *zlo;
    double arc, alpha, dir, wp, wplo, H;
    size_t n, d, m, q, ni;
    double *y, *g, *hs, *nv, *G, *tmp, *ys, *sc, *A, *xlo;
    int *piv;
    /* a cell: the model at the coarse point y = yc (cached by ckey), the kick there and what continues it */
    double *yc, *yprev, *ynext, *ckey, *cg, *chs, *cnv, *csc;
    double *graw, *ka, *kB, *kc0, *kr0, *ku0, *gsig, *HI;
    size_t *kidx, kept;
    int *kpiv;
    double cH, cs0, cL0;
    int cvalid, pinned;
    int hi_ok;        /* the cell's H_I holds the invariants' Hessians (kl_inv_hessians) */
    double *hi_state; /* in the workspace, kept from call to call: H_I not yet looked for (0), found
                         at the fixed point (1), to be found per cell (2) */
    /* a chord: the midpoint and its Taylor terms, the kick's change */
    double *zb, *zblo, *dy, *gl, *gll, *n1, *w, *ds, *dv, *da, *kBp, *krhs, *kdc;
    double rnewton, eprev; /* the last Newton correction, the last chord's size (0: start afresh) */
} kl_ctx;

/* the workspace: the slots of kl_ctx in this order (sizes by kl_layout) */
enum { KL_SLOTS = 42 };

static size_t kl_layout(size_t n, size_t ni, size_t *off)
{
    size_t d = 2 * n + 1, q = 2 * n, m = 2 * n + 2, k2 = ni * ni, iw = (ni + 1) / 2 + 1;
    size_t sz[KL_SLOTS] = {d, d, d * d, q, ni * q, 2 * ni + 8, d, q, m * m, m, m, m, m, /* y .. xlo (0-12): F dx x at 9-11 */
                           d, d, d, d, d, d * d, q, q,                                 /* yc .. csc (13-20) */
                           ni * q, ni * q, k2, ni, ni, q, q, ni * q * q,               /* graw .. HI (21-28) */
                           d, d, d, d, d, q, d, q, q, ni * q, k2, ni, ni};             /* zb .. kdc (29-41) */
    size_t tot = 0;
    for (size_t i = 0; i < KL_SLOTS; i++) {
        off[i] = tot;
        tot += sz[i];
    }
    /* piv, kpiv (twice: B and B'), kidx (as doubles), then the state kept from call to call: whether HI
     * holds the invariants' Hessians */
    return tot + (m + 1) / 2 + 1 + 2 * iw + ni + 1;
}

size_t dth__kicked_law_work_size(const dth_model *model)
{
    size_t off[KL_SLOTS];
    return kl_layout(dth_model_dof(model), dth__model_ninv(model), off);
}

static double kl_law(const kl_ctx *c, double s)
{
    return c->dir * (c->alpha == 0 ? c->arc : c->arc / pow(sqrt(s), c->alpha));
}

/* |u|^2 over (q, p) from a gradient over y */
static double kl_speed2(size_t n, const double *g)
{
    double s = 0;
    for (size_t i = 0; i < n; i++) s += g[i] * g[i] + g[n + 1 + i] * g[n + 1 + i];
    return s;
}

/* y index of the (q, p) index i */
static size_t kl_yi(size_t n, size_t i) { return i < n ? i : i + 1; }

/* the Newton iterations: the residual and Jacobian at the double midpoint */
static int kl_newton_eval(kl_ctx *c, const double *x, double *F)
{
    size_t n = c->n, q = c->q, m = c->m, d = c->d;
    double *g = c->g, *hs = c->hs, *nv = c->nv, *A = c->A, lam = x[q], kmu = x[q + 1];
    for (size_t j = 0; j < d; j++) {
        double lo = c->zlo ? c->zlo[j] : 0;
        double dj = j < n ? x[j] : (j == n ? 0.5 * lam : x[j - 1]);
        c->y[j] = c->z[j] + (lo + dj);
    }
    int rc = dth__model_eval_raw(c->model, c->y, DTH_EVAL_H | DTH_EVAL_GRAD | DTH_EVAL_HESS, &c->H, g, hs);
    if (rc) return rc;
    size_t kept = dth__kick_dir(c->model, n, c->y, g, hs, c->sc, c->G, c->ys, c->tmp, nv);
    for (size_t i = 0; i < n; i++) {
        F[i] = x[i] - 0.5 * lam * g[n + 1 + i] - 0.5 * kmu * nv[i];
        F[n + i] = x[n + i] + 0.5 * lam * g[i] - 0.5 * kmu * nv[n + i];
    }
    F[q] = (c->wp + c->wplo) + c->H;
    double s = kl_speed2(n, g), L = kl_law(c, s);
    F[q + 1] = lam - L;
    if (!isfinite(F[q + 1])) return DTH_EDOMAIN;
    memset(A, 0, m * m * sizeof *A);
    dth__kick_block(n, m, hs, c->sc, c->G, kept, lam, kmu, A);
    for (size_t a = 0; a < q; a++) {
        size_t ya = kl_yi(n, a);
        A[a + q * m] = -0.5 * (a < n ? g[n + 1 + a] : -g[a - n]); /* d F / d lambda = -u/2 */
        A[a + (q + 1) * m] = -0.5 * nv[a];
        A[q + a * m] = g[ya];
        if (c->alpha != 0) { /* d law / d y_a = -alpha law (g . H'' e_a) / |u|^2 over (q, p) */
            double acc = 0;
            for (size_t k = 0; k < q; k++) {
                size_t yk = kl_yi(n, k);
                acc += g[yk] * hs[yk * d + ya];
            }
            A[q + 1 + a * m] = c->alpha * L * acc / s;
        }
    }
    A[q + 1 + q * m] = 1;
    return dth__lu_factor(DTH_LINSOLVE_AUTO, (int)m, A, c->piv);
}

/* the midpoint of x + xlo in double-double (t advancing by half the step) */
static void kl_midpoint(const kl_ctx *c, const double *x, const double *xlo, double *zb, double *zblo)
{
    size_t n = c->n, q = c->q;
    for (size_t j = 0; j < c->d; j++) {
        double lo = c->zlo ? c->zlo[j] : 0;
        if (j == n) zb[j] = dd_add(c->z[j], lo, 0.5 * x[q], 0.5 * xlo[q], &zblo[j]);
        else zb[j] = dd_add(c->z[j], lo, x[j < n ? j : j - 1], xlo[j < n ? j : j - 1], &zblo[j]);
    }
}

/* The law's factor (1 + delta)^(-alpha/2) - 1 = P_hi + P_lo for delta = dh + dl: its Taylor polynomial
 * c1 delta + ... + c4 delta^4 in double-double (Horner; the delta^3 and delta^4 terms in double). */
static double kl_law_poly(double alpha, double dh, double dl, double *plo)
{
    double a = 0.5 * alpha, c1 = -a, c2 = a * (a + 1) / 2, c3 = -c2 * (a + 2) / 3, c4 = -c3 * (a + 3) / 4;
    double w = c3 + dh * c4, e;
    double vh = two_sum(c2, dh * w, &e), vl = e + dl * w;                 /* c2 + delta (c3 + delta c4) */
    double p = dh * vh, pe = prod_err(dh, vh, p);
    double rh = two_sum(c1, p, &e), rl = e + (pe + dh * vl + dl * vh);     /* c1 + delta v */
    double ph = dh * rh, pl = prod_err(dh, rh, ph) + (dh * rl + dl * rh); /* delta r */
    return two_sum(ph, pl, plo);
}

/*
 * The Hessians of the quadratic invariants over (q, p), HI (q x q per invariant), by second differences
 * around y with steps h (h = 0: 1e-3 max(1, |y_j|)), exact up to round-off for a quadratic. 0, or -1
 * where the invariants cannot be evaluated or give a non-finite difference.
 */
static int kl_inv_hessians_at(kl_ctx *c, const double *y, double h)
{
    const dth_model_type *t = dth_model_get_type(c->model);
    const void *self = dth__model_self(c->model);
    size_t n = c->n, q = c->q, ni = c->ni, d = c->d;
    double *ys = c->ys, *I = c->tmp;
    unsigned long long mask = dth__model_quad_mask(c->model);
    static const double sg[4][3] = {{1, 1, 1}, {1, -1, -1}, {-1, 1, -1}, {-1, -1, 1}};
    memset(c->HI, 0, ni * q * q * sizeof *c->HI);
    for (size_t a = 0; a < q; a++)
        for (size_t b = a; b < q; b++) {
            size_t ya = kl_yi(n, a), yb = kl_yi(n, b);
            double ha = h > 0 ? h : 1e-3 * fmax(1.0, fabs(y[ya])), hb = h > 0 ? h : 1e-3 * fmax(1.0, fabs(y[yb]));
            for (int k = 0; k < 4; k++) {
                memcpy(ys, y, d * sizeof *ys);
                if (a == b) ys[ya] = y[ya] + (sg[k][0] * ha + sg[k][1] * hb);
                else {
                    ys[ya] = y[ya] + sg[k][0] * ha;
                    ys[yb] = y[yb] + sg[k][1] * hb;
                }
                if (t->invariants(self, ys, I) != 0) return -1;
                for (size_t j = 0; j < ni; j++)
                    if ((mask >> j) & 1u) c->HI[(j * q + a) * q + b] += sg[k][2] * I[j];
            }
            for (size_t j = 0; j < ni; j++) {
                double *H = c->HI + j * q * q;
                H[a * q + b] /= 4 * ha * hb;
                H[b * q + a] = H[a * q + b];
            }
        }
    for (size_t j = 0; j < ni * q * q; j++)
        if (!isfinite(c->HI[j])) return -1;
    return 0;
}

/*
 * The quadratic invariants' Hessians (constant), for the cell at y: found once per workspace (hi_state 1)
 * at a point that does not depend on the run (q and p 0.75, t = 0, steps 0.25: where the model's
 * quadratic probe evaluated them, model.c), so that a run, its reverse and a restart from a checkpoint
 * read the same numbers. Where the invariants cannot be evaluated there (hi_state 2), at each cell's y
 * (a function of the cell alone, so again the same numbers both ways and after a restart); where that
 * fails too, the projector's change is left out in this cell (hi_ok 0).
 */
static void kl_inv_hessians(kl_ctx *c, const double *y)
{
    if (*c->hi_state == 0) {
        double *y0 = c->w; /* scratch until kl_kick */
        for (size_t j = 0; j < c->d; j++) y0[j] = j == c->n ? 0 : 0.75;
        *c->hi_state = kl_inv_hessians_at(c, y0, 0.25) ? 2 : 1;
    }
    c->hi_ok = 1;
    if (*c->hi_state == 1) return;
    if (kl_inv_hessians_at(c, y, 0)) {
        memset(c->HI, 0, c->ni * c->q * c->q * sizeof *c->HI);
        c->hi_ok = 0;
    }
}

/*
 * A new cell: the model at yc (value, gradient, Hessian), the law there, and the kick n(y) = S P S g with
 * what continues it (kl_kick): the metric s, the gradient gsig of ln s_q over (q, p) (ln s_q = (ln fp -
 * ln fq) / 8, by central differences of the Hessian's block norms; 0 where the metric is clamped or
 * falls back, or a Hessian cannot be evaluated), the kept invariants' gradients (graw, kidx), the rows
 * a_r = s grad I_r (ka), their Gram matrix (kB, factored into kBp), c0 = B^-1 A v (kc0), its residual
 * A v - B c0 in double-double (kr0), u0 = v - A^T c0 (ku0, v = s g) and n(y) = s u0 (cnv).
 */
static int kl_cell(kl_ctx *c)
{
    size_t n = c->n, q = c->q, d = c->d;
    double *g = c->cg, *s = c->csc;
    int rc = dth__model_eval_raw(c->model, c->yc, DTH_EVAL_H | DTH_EVAL_GRAD | DTH_EVAL_HESS, &c->cH, g, c->chs);
    if (rc) return rc;
    c->cs0 = kl_speed2(n, g);
    c->cL0 = kl_law(c, c->cs0);
    if (!isfinite(c->cL0) || !isfinite(c->cH)) return DTH_EDOMAIN;
    unsigned long long mask = dth__model_quad_mask(c->model);
    dth__kick_metric(c->model, n, c->chs, s);
    memset(c->gsig, 0, q * sizeof *c->gsig);
    c->kept = 0;
    if (mask) {
        double fq, fp;
        int smooth;
        dth__kick_metric_blocks(n, c->chs, &fq, &fp);
        dth__kick_metric_rho(fq, fp, &smooth);
        for (size_t a = 0; smooth && a < q; a++) {
            size_t ya = kl_yi(n, a);
            double h = 1e-3 * fmax(1.0, fabs(c->yc[ya])), l[2] = {0, 0}, H;
            for (int k = 0; k < 2 && smooth; k++) {
                memcpy(c->ys, c->yc, d * sizeof *c->ys);
                c->ys[ya] = c->yc[ya] + (k ? -h : h);
                if (dth__model_eval_raw(c->model, c->ys, DTH_EVAL_H | DTH_EVAL_GRAD | DTH_EVAL_HESS, &H, c->g, c->hs)) {
                    smooth = 0;
                    break;
                }
                dth__kick_metric_blocks(n, c->hs, &fq, &fp);
                l[k] = (log(fp) - log(fq)) / 8;
                if (!isfinite(l[k])) smooth = 0;
            }
            c->gsig[a] = (l[0] - l[1]) / (2 * h);
        }
        if (!smooth) memset(c->gsig, 0, q * sizeof *c->gsig);
        c->kept = dth__quad_invariant_basis_ex(c->model, c->yc, s, c->G, c->ys, c->tmp, c->graw, c->kidx);
        if (c->kept) kl_inv_hessians(c, c->yc);
    }
    size_t k = c->kept;
    double *u0 = c->ku0;
    for (size_t i = 0; i < q; i++) u0[i] = s[i] * g[kl_yi(n, i)]; /* v = s g */
    if (k) {
        double *ka = c->ka, *B = c->kB, *c0 = c->kc0, *r0 = c->kr0, t;
        for (size_t r = 0; r < k; r++)
            for (size_t i = 0; i < q; i++) ka[r * q + i] = s[i] * c->graw[c->kidx[r] * q + i];
        for (size_t r = 0; r < k; r++)
            for (size_t u = 0; u < k; u++) {
                double b = 0;
                for (size_t i = 0; i < q; i++) b += ka[r * q + i] * ka[u * q + i];
                B[r * k + u] = b;
            }
        /* A v in double-double (its low part in r0 for now) */
        for (size_t r = 0; r < k; r++) {
            double sh = 0, sl = 0;
            for (size_t i = 0; i < q; i++) {
                double p = ka[r * q + i] * u0[i];
                sh = two_sum(sh, p, &t);
                sl += t + prod_err(ka[r * q + i], u0[i], p);
            }
            c0[r] = two_sum(sh, sl, &r0[r]);
        }
        memcpy(c->kBp, B, k * k * sizeof *B);
        rc = dth__lu_factor(DTH_LINSOLVE_AUTO, (int)k, c->kBp, c->kpiv);
        if (!rc) {
            double *av = c->kdc; /* scratch: A v's high part */
            memcpy(av, c0, k * sizeof *av);
            rc = dth__lu_solve(DTH_LINSOLVE_AUTO, (int)k, c->kBp, c->kpiv, 1, c0);
            /* r0 = A v - B c0, in double-double */
            for (size_t r = 0; !rc && r < k; r++) {
                double sh = av[r], sl = r0[r];
                for (size_t u = 0; u < k; u++) {
                    double p = B[r * k + u] * c0[u];
                    sh = two_sum(sh, -p, &t);
                    sl += t - prod_err(B[r * k + u], c0[u], p);
                }
                r0[r] = sh + sl;
            }
        }
        if (rc) return rc == DTH_ESINGULAR ? DTH_ENOCONV : rc;
        for (size_t i = 0; i < q; i++) {
            double a = 0;
            for (size_t r = 0; r < k; r++) a += ka[r * q + i] * c0[r];
            u0[i] -= a;
        }
    }
    for (size_t i = 0; i < q; i++) c->cnv[i] = s[i] * u0[i];
    memcpy(c->ckey, c->yc, d * sizeof *c->ckey);
    c->cvalid = 1;
    return DTH_OK;
}

/*
 * The kick's change from y to the midpoint, n(zbar) - n(y) (into n1), to first order in w = zbar - y
 * (gl: g's change, H''(y) w): with s' = s + ds (ds = s expm1(+-sigma), sigma = gsig . w), v' = s' g' (dv =
 * ds g + s' gl), a'_r = s' grad I_r(zbar) (da_r = ds grad I_r + s' H_I w), B' = B + M (M = A da^T + da A^T +
 * da da^T), c' = c0 + dc with B' dc = r0 + (da v + A dv + da dv) - M c0, u' - u0 = dv - da^T c' - A^T dc:
 *     n(zbar) - n(y) = ds u0 + s' (u' - u0),
 * every term small (about 2^-27 of n), so their rounding is far below the kick's own.
 */
static int kl_kick(kl_ctx *c)
{
    size_t n = c->n, q = c->q, k = c->kept;
    double *w = c->w, *ds = c->ds, *dv = c->dv, *s = c->csc, *n1 = c->n1, sigma = 0;
    for (size_t i = 0; i < q; i++) {
        size_t yi = kl_yi(n, i);
        w[i] = c->dy[yi] + c->zblo[yi];
        sigma += c->gsig[i] * w[i];
    }
    double eq = expm1(sigma), ep = expm1(-sigma);
    for (size_t i = 0; i < q; i++) {
        ds[i] = s[i] * (i < n ? eq : ep);
        dv[i] = ds[i] * c->cg[kl_yi(n, i)] + (s[i] + ds[i]) * c->gl[kl_yi(n, i)];
        n1[i] = dv[i];
    }
    if (k) {
        double *da = c->da, *ka = c->ka, *B = c->kBp, *rhs = c->krhs, *dc = c->kdc, *c0 = c->kc0;
        for (size_t r = 0; r < k; r++) {
            const double *gr = c->graw + c->kidx[r] * q, *H = c->HI + c->kidx[r] * q * q;
            for (size_t i = 0; i < q; i++) {
                double hw = 0;
                if (c->hi_ok)
                    for (size_t j = 0; j < q; j++) hw += H[i * q + j] * w[j];
                da[r * q + i] = ds[i] * gr[i] + (s[i] + ds[i]) * hw;
            }
        }
        for (size_t r = 0; r < k; r++) {
            double a = c->kr0[r];
            for (size_t i = 0; i < q; i++) /* da v + A dv + da dv, v = s g */
                a += da[r * q + i] * (s[i] * c->cg[kl_yi(n, i)] + dv[i]) + ka[r * q + i] * dv[i];
            rhs[r] = a;
        }
        for (size_t r = 0; r < k; r++)
            for (size_t u = 0; u < k; u++) {
                double mm = 0;
                for (size_t i = 0; i < q; i++)
                    mm += ka[r * q + i] * da[u * q + i] + da[r * q + i] * ka[u * q + i] + da[r * q + i] * da[u * q + i];
                B[r * k + u] = c->kB[r * k + u] + mm;
                rhs[r] -= mm * c0[u];
            }
        memcpy(dc, rhs, k * sizeof *dc);
        int rc = dth__lu_factor(DTH_LINSOLVE_AUTO, (int)k, B, c->kpiv + c->ni);
        if (!rc) rc = dth__lu_solve(DTH_LINSOLVE_AUTO, (int)k, B, c->kpiv + c->ni, 1, dc);
        if (rc) return rc == DTH_ESINGULAR ? DTH_ENOCONV : rc;
        for (size_t i = 0; i < q; i++) {
            double a = 0;
            for (size_t r = 0; r < k; r++) a += da[r * q + i] * (c0[r] + dc[r]) + ka[r * q + i] * dc[r];
            n1[i] -= a;
        }
    }
    for (size_t i = 0; i < q; i++) n1[i] = ds[i] * c->ku0[i] + (s[i] + ds[i]) * n1[i];
    return DTH_OK;
}

/* The chord steps' residual: the model at the coarse point, continued to the midpoint (above). */
static int kl_chord_eval(kl_ctx *c, const double *x, double *F)
{
    size_t n = c->n, q = c->q, d = c->d;
    const double *xlo = c->xlo;
    double *zb = c->zb, *zblo = c->zblo, *dy = c->dy, *gl = c->gl, *gll = c->gll, *n1 = c->n1, *g = c->cg;
    kl_midpoint(c, x, xlo, zb, zblo);
    if (!c->pinned) coarsen_y(n, zb, c->yc);
    int rc;
    if ((!c->cvalid || memcmp(c->yc, c->ckey, d * sizeof *c->yc) != 0) && (rc = kl_cell(c)) != DTH_OK) return rc;
    for (size_t j = 0; j < d; j++) dy[j] = zb[j] - c->yc[j]; /* exact: yc is a multiple of zb's ulp near zb */
    taylor_grad_h(c->chs, d, dy, zblo, gl, gll);
    if ((rc = kl_kick(c)) != DTH_OK) return rc;
    double hl = 0.5 * x[q], hlo = 0.5 * xlo[q], hm = 0.5 * x[q + 1], hmlo = 0.5 * xlo[q + 1];
    for (size_t i = 0; i < n; i++) {
        F[i] = exact_row_kick(x[i], xlo[i], hl, hlo, g[n + 1 + i], gl[n + 1 + i], gll[n + 1 + i], hm, hmlo, c->cnv[i], n1[i]);
        F[n + i] = exact_row_kick(x[n + i], xlo[n + i], hl, hlo, -g[i], -gl[i], -gll[i], hm, hmlo, c->cnv[n + i], n1[n + i]);
    }
    /* wp + H(zbar): wp by its parts, g dy exactly, in double-double (as rho_from_mid_n) */
    double s = 0, e = 0, r = 0, t;
    for (size_t j = 0; j < d; j++) {
        double h = dy[j], l = zblo[j];
        if (h != 0) {
            double p = g[j] * h, pe = prod_err(g[j], h, p);
            s = two_sum(s, p, &t);
            e += t + pe;
        }
        r += g[j] * l + 0.5 * gl[j] * (h + l);
    }
    double l1, h1 = two_sum(c->wp, c->cH, &l1), l2, h2 = two_sum(h1, s, &l2);
    F[q] = h2 + ((l1 + l2) + (c->wplo + (e + r)));
    /* lambda - law(zbar), law(zbar) = L0 (1 + P(delta)) */
    double L0 = c->cL0, Ph = 0, Pl = 0;
    if (c->alpha != 0) {
        double ds = 0, de = 0;
        for (size_t k = 0; k < q; k++) {
            size_t yk = kl_yi(n, k);
            double g2 = 2 * g[yk], p = g2 * gl[yk], pe = prod_err(g2, gl[yk], p);
            ds = two_sum(ds, p, &t);
            de += (t + pe) + (g2 * gll[yk] + gl[yk] * gl[yk]);
        }
        double Dl, Dh = two_sum(ds, de, &Dl);
        double dh = Dh / c->cs0, p2 = dh * c->cs0, dl = (((Dh - p2) - prod_err(dh, c->cs0, p2)) + Dl) / c->cs0;
        Ph = kl_law_poly(c->alpha, dh, dl, &Pl);
    }
    double ph = L0 * Ph, pl = prod_err(L0, Ph, ph), l3, h3 = two_sum(x[q], -L0, &l3), l4, h4 = two_sum(h3, -ph, &l4);
    F[q + 1] = h4 + ((l3 + l4) + ((xlo[q] - pl) - L0 * Pl));
    return DTH_OK;
}

static int kl_eval(void *ctx, const double *x, double *F, int jac)
{
    kl_ctx *c = ctx;
    return jac ? kl_newton_eval(c, x, F) : kl_chord_eval(c, x, F);
}

static int kl_solve(void *ctx, double *b)
{
    kl_ctx *c = ctx;
    return dth__lu_solve(DTH_LINSOLVE_AUTO, (int)c->m, c->A, c->piv, 1, b);
}

/* The size of a correction dx over the scales the vertex resolves: the q and p blocks' largest
 * magnitude, lambda's own, and mu by the chord it moves, |dmu| |n|, against the larger block. */
static double kl_size(const kl_ctx *c, const double *x, const double *dx, const double *nv)
{
    size_t n = c->n, q = c->q;
    double bq = 1e-300, bp = 1e-300, nn = 0, r = 0;
    for (size_t i = 0; i < n; i++) {
        bq = fmax(bq, fmax(fabs(c->z[i]), fabs(c->z[i] + x[i])));
        bp = fmax(bp, fmax(fabs(c->z[n + 1 + i]), fabs(c->z[n + 1 + i] + x[n + i])));
    }
    for (size_t i = 0; i < n; i++) r = fmax(r, fmax(fabs(dx[i]) / bq, fabs(dx[n + i]) / bp));
    for (size_t i = 0; i < q; i++) nn += nv[i] * nv[i];
    r = fmax(r, fabs(dx[q]) / (fabs(x[q]) + 1e-300));
    r = fmax(r, fabs(dx[q + 1]) * sqrt(nn) / fmax(bq, bp));
    return isfinite(r) ? r : INFINITY;
}

static int kl_judge(void *ctx, const double *x, const double *dx, const double *F, dth__newton_track *tr, int *verdict)
{
    kl_ctx *c = ctx;
    (void)F;
    if (!(x[c->q] * c->dir > 0) || !isfinite(x[c->q]) || !isfinite(x[c->q + 1])) return DTH_ENOCONV;
    double r = kl_size(c, x, dx, c->nv);
    tr->r = r;
    int v = dth__newton_rate(r, tr->r_prev, tr->iter, 4 * DBL_EPSILON);
    if (v == DTH__NT_DIVERGED) return DTH_ENOCONV;
    /* the Jacobian leaves out the derivatives of the kick's metric and projector: linear where mu is not
     * tiny; a stall near round-off is done (the chord steps finish it) */
    if (v == DTH__NT_STALLED && r < 1e-9) v = DTH__NT_CHORD;
    else if ((v == DTH__NT_STALLED || v == DTH__NT_MORE) && tr->iter >= 20) return DTH_ENOCONV;
    if (v == DTH__NT_DONE) v = DTH__NT_CHORD; /* always finished by the chord steps */
    if (v == DTH__NT_CHORD) {
        c->rnewton = r;
        c->eprev = 0;
        c->cvalid = 0;
        c->pinned = 0;
    }
    *verdict = v;
    return DTH_OK;
}

/* More chord steps? (as step_again in dth_newton.c) */
static int kl_again(void *ctx, const double *x, const double *dx, int chords)
{
    kl_ctx *c = ctx;
    double e = kl_size(c, x, dx, c->cnv), eprev = c->eprev;
    c->eprev = e;
    if (chords >= KL_MAX_CHORDS) return 0;
    /* resolved to 2^-100: the next correction predicted from the observed rate (the first chord's, or
     * the first in a new cell's, from the last Newton correction, at least 1e-6: the Jacobian leaves out
     * the kick's metric and projector); at the noise floor (no longer shrinking) nothing is left */
    int more;
    if (e == 0) more = 0;
    else if (eprev == 0) more = fmax(c->rnewton, 1e-6) * e > 0x1p-100;
    else more = e < 0.5 * eprev && fmax(e / eprev, 1e-12) * e > 0x1p-100;
    if (c->pinned) return more;
    kl_midpoint(c, x, c->xlo, c->zb, c->zblo);
    coarsen_y(c->n, c->zb, c->ynext);
    size_t d = c->d;
    int moved = memcmp(c->ynext, c->yc, d * sizeof *c->yc) != 0;
    int back = chords >= 2 && memcmp(c->ynext, c->yprev, d * sizeof *c->yc) == 0;
    if (!moved) return more;
    c->eprev = 0; /* the next chord reads another cell: its size starts afresh */
    if (back) { /* alternating between two cells: pin to the componentwise lower */
        for (size_t j = 0; j < d; j++) c->yc[j] = fmin(c->yc[j], c->ynext[j]);
        c->pinned = 1;
        return 1;
    }
    memcpy(c->yprev, c->yc, d * sizeof *c->yc);
    return 1;
}

static const dth__newton_ops kl_ops = {kl_eval, kl_solve, kl_judge};

int dth__kicked_law_rev(const dth_model *model, const double *z, const double *zlo, double arc, double alpha,
                        double dir, double *dz, double *dzlo, double *lambda, double *mu, double *residual, int *iters,
                        double *work)
{
    if (!dth_model_get_info(model)->autonomous) return DTH_EUNSUPPORTED;
    size_t n = dth_model_dof(model), N = 2 * n + 2, d = 2 * n + 1, q = 2 * n, m = 2 * n + 2, ni = dth__model_ninv(model);
    if (ni > 64) ni = 0; /* quad_invariant_basis projects nothing then */
    size_t off[KL_SLOTS], tot = kl_layout(n, ni, off);
    kl_ctx c = {.model = model, .z = z, .zlo = zlo, .arc = arc, .alpha = alpha, .dir = dir, .wp = z[N - 1],
                .wplo = zlo ? zlo[N - 1] : 0, .n = n, .d = d, .m = m, .q = q, .ni = ni};
    double *F = work + off[9], *dx = work + off[10], *x = work + off[11];
    double **slots[KL_SLOTS] = {&c.y,   &c.g,    &c.hs,  &c.nv,   &c.G,     &c.tmp,   &c.ys,   &c.sc,  &c.A,   NULL,
                                NULL,   NULL,    &c.xlo, &c.yc,   &c.yprev, &c.ynext, &c.ckey, &c.cg,  &c.chs, &c.cnv,
                                &c.csc, &c.graw, &c.ka,  &c.kB,   &c.kc0,   &c.kr0,   &c.ku0,  &c.gsig, &c.HI, &c.zb,
                                &c.zblo, &c.dy,  &c.gl,  &c.gll,  &c.n1,    &c.w,     &c.ds,   &c.dv,  &c.da,  &c.kBp,
                                &c.krhs, &c.kdc};
    for (size_t i = 0; i < KL_SLOTS; i++)
        if (slots[i]) *slots[i] = work + off[i];
    c.piv = (int *)(work + tot - ((m + 1) / 2 + 1) - 2 * ((ni + 1) / 2 + 1) - ni - 1);
    c.kpiv = (int *)(work + tot - 2 * ((ni + 1) / 2 + 1) - ni - 1);
    c.kidx = (size_t *)(void *)(work + tot - ni - 1);
    c.hi_state = work + tot - 1;
    for (size_t i = 0; i < n; i++) {
        x[i] = dz[i];
        x[n + i] = dz[n + 1 + i];
    }
    x[q] = *lambda;
    x[q + 1] = *mu;
    memset(c.xlo, 0, m * sizeof *c.xlo);
    dth__newton_track tr;
    int rc = dth__newton_iterate(&kl_ops, kl_again, &c, (int)m, 40, x, c.xlo, F, dx, &tr);
    if (iters) *iters = tr.iter;
    if (rc) return rc;
    /* the chord steps never fail: a root they did not resolve (a cell whose equations put it elsewhere
     * to the end) is no root */
    if (!(c.eprev <= 1e-12)) return DTH_ENOCONV;
    for (size_t a = 0; a < m; a++)
        if (!isfinite(x[a]) || !isfinite(c.xlo[a])) return DTH_ENOCONV;
    if (!(x[q] * dir > 0)) return DTH_ENOCONV;
    memset(dz, 0, N * sizeof *dz);
    memset(dzlo, 0, N * sizeof *dzlo);
    for (size_t i = 0; i < n; i++) {
        dz[i] = x[i];
        dz[n + 1 + i] = x[n + i];
        dzlo[i] = c.xlo[i];
        dzlo[n + 1 + i] = c.xlo[n + i];
    }
    dz[n] = 0.5 * x[q];
    dzlo[n] = 0.5 * c.xlo[q];
    *lambda = x[q];
    *mu = x[q + 1];
    if (residual) {
        for (size_t j = 0; j < d; j++) c.y[j] = z[j] + ((zlo ? zlo[j] : 0) + dz[j]);
        double H;
        rc = dth_model_eval(model, c.y, DTH_EVAL_H, &H, NULL, NULL);
        if (rc) return rc;
        *residual = fabs((c.wp + c.wplo) + H);
    }
    return DTH_OK;
}
