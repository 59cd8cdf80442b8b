/* SPDX-License-Identifier: MIT */
/*
 * Banded solve of the bordered Newton system of the DTH step (paper, Theorem "DTH Equations")
 * for autonomous models with a banded Hessian: O(n w^2) per factorization instead of O(n^3).
 *
 * In the interleaved order x = (q_1, p_1, ..., q_n, p_n) the step Jacobian is
 *     [ B    c ]    B = I - (lambda/2) D,  D = J H_xx (row q_i is H row p_i, row p_i is -H row q_i),
 *     [ g^T  0 ]    c = -(1/2) u,  u = J grad H,  g = grad H,
 * and the border is eliminated by blocks: y2 = B^{-1} c, Schur complement s = -g^T y2, then
 *     dlambda = (F_last - g^T B^{-1} F) / s,   dx = B^{-1} F - y2 dlambda.
 * s is small (about lambda psi / 4) because g^T u = 0: it is computed without cancellation as
 * y2 = c + e, B e = -(lambda/4) D u, s = -g^T e (g^T c = 0 exactly, pair by pair).
 *
 * B itself is solved one of two ways:
 *  - separable H = T(p) + V(q) with diagonal T'' (springs, particles): eliminating dp leaves
 *        K x_q = T''^-1 r_q + (lambda/2) r_p,   K = T''^-1 + (lambda^2/4) V'',   x_p = r_p - (lambda/2) V'' x_q,
 *    K symmetric with half the unknowns and half the bandwidth: banded Cholesky, written out here
 *    (as U^T D U, no square roots) for half-bandwidths up to DTH__BAND_OWN_KQ (at a chain's 3 a
 *    LAPACK call costs more than its arithmetic: the unblocked dpbtf2 makes BLAS calls per column,
 *    each under OpenBLAS's buffer lock), else LAPACK dpbtrf; banded LU (dgbtrf) of K where it is not positive definite (V'' indefinite,
 *    large lambda);
 *  - otherwise banded LU of B (dgbtrf, half-bandwidth w + 1), allocated at the first such step.
 */
#include <limits.h>
#include <stddef.h>
#include <lapacke.h>
#include <math.h>
#include <string.h>
#include "dth_internal.h"

_Static_assert(sizeof(lapack_int) == sizeof(int), "pivots are stored as int");

struct dth__band {
    const dth_allocator *al;
    size_t n, w, bw;   /* dof, Hessian half-bandwidth, 2w+1 */
    int nn, kb, ldab;  /* 2n, half-bandwidth of B (w+1), LAPACK leading dimension 3kb+1 */
    double *hb;        /* model Hessian band, nn x bw */
    double *ab;        /* LU factors of B in LAPACK band storage, ldab x nn (allocated when first needed) */
    int *ipiv;         /* nn pivots of B */
    int kq, ldk;       /* Schur path: half-bandwidth of K (w/2), leading dimension (3 kq + 1) */
    double *kab;       /* factors of K (n columns); tinv: T''^-1 (n); vx: V'' x_q scratch (n) */
    double *tinv, *vx;
    int *kpiv;         /* n pivots (LU of K) */
    int mode;          /* of the last factorization: SCHUR_CHOL, SCHUR_LU or GENERAL */
    int own;           /* SCHUR_CHOL: 1 if the written-out LDL^T made it (band_ldl's storage) */
    int lapack_only;   /* never the written-out Cholesky (dth__band_lapack_only, for tests) */
    double *g, *y2;    /* border row g and B^{-1} c (interleaved) */
    double *r, *grad;  /* scratch: right-hand side (nn); gradient over y (2n+1), then nn+1 */
    double s;          /* Schur complement -g^T B^{-1} c */
    double lam;        /* lambda of the factorization */
};

enum { SCHUR_CHOL = 1, SCHUR_LU, GENERAL };

int dth__band_new(const dth_model *m, int schur, const dth_allocator *al, dth__band **out)
{
    *out = NULL;
    const dth_model_info *info = dth_model_get_info(m);
    size_t n = info->n, w = info->bandwidth;
    /* LAPACK indexes the band storage with int: (3(w+1)+1) * 2n must fit */
    if (w >= 2 * n || n > INT_MAX / 2 || (3 * (w + 1) + 1) > INT_MAX / (2 * n)) return DTH_EINVAL;
    dth__band *b = dth_calloc(al, 1, sizeof *b);
    if (!b) return DTH_ENOMEM;
    b->al = al;
    b->n = n;
    b->w = w;
    b->bw = 2 * w + 1;
    b->nn = (int)(2 * n);
    b->kb = (int)w + 1;
    b->ldab = 3 * b->kb + 1;
    b->kq = (int)(w / 2);
    b->ldk = 3 * b->kq + 1;
    size_t nn = 2 * n;
    /* overflow of the products is caught by dth_calloc */
    b->hb = dth_calloc(al, nn, b->bw * sizeof(double));
    b->g = dth_calloc(al, 5 * nn + 2, sizeof(double));
    if (schur && info->separable) {
        b->kab = dth_calloc(al, n, ((size_t)b->ldk + 2) * sizeof(double));
        b->kpiv = dth_calloc(al, n, sizeof(int));
    }
    if (!b->hb || !b->g || (schur && info->separable && (!b->kab || !b->kpiv))) {
        dth__band_free(b, al);
        return DTH_ENOMEM;
    }
    if (b->kab) {
        b->tinv = b->kab + n * (size_t)b->ldk;
        b->vx = b->tinv + n;
    }
    b->y2 = b->g + nn;
    b->r = b->y2 + nn;
    b->grad = b->r + nn;
    *out = b;
    return DTH_OK;
}

void dth__band_free(dth__band *b, const dth_allocator *al)
{
    if (!b) return;
    dth_free(al, b->hb);
    dth_free(al, b->ab);
    dth_free(al, b->ipiv);
    dth_free(al, b->kab);
    dth_free(al, b->kpiv);
    dth_free(al, b->g);
    dth_free(al, b);
}

/* (D v)_r for interleaved v: D = J H_xx, row r reads H row r^1 with sign + (q rows) or - (p rows). */
static double d_times(const dth__band *b, size_t r, const double *v)
{
    size_t s = r ^ 1, w = b->w, nn = (size_t)b->nn;
    size_t lo = s > w ? s - w : 0, hi = s + w < nn - 1 ? s + w : nn - 1;
    const double *row = b->hb + s * b->bw + w - s;
    double acc = 0;
    for (size_t l = lo; l <= hi; l++) acc += row[l] * v[l];
    return (r & 1) ? -acc : acc;
}

/* Separable (no q-p coupling, the model says so) with diagonal positive T'': T''^-1 into tinv,
 * and the Schur path applies. Checks the p-p entries only. */
static int schur_applies(dth__band *b)
{
    if (!b->kab) return 0;
    size_t w = b->w, nn = (size_t)b->nn, bw = b->bw;
    for (size_t r = 1; r < nn; r += 2) {
        const double *row = b->hb + r * bw + w - r; /* row[l] = H(r, l) */
        size_t lo = r > w ? r - w : 0, hi = r + w < nn - 1 ? r + w : nn - 1;
        lo |= 1;
        for (size_t l = lo; l <= hi; l += 2)
            if (l != r && row[l] != 0) return 0; /* T'' not diagonal */
        double t = row[r];
        if (!(t > 0)) return 0;
        b->tinv[r / 2] = 1.0 / t;
    }
    return 1;
}

/* Half-bandwidths of K up to which the Cholesky is written out (no LAPACK call). */
#define DTH__BAND_OWN_KQ 16

void dth__band_lapack_only(dth__band *b, int on) { b->lapack_only = on; }

/*
 * K = U^T D U (U unit upper triangular, the square-root-free Cholesky) in dpbtrf's upper band storage:
 * U(i, j) at ab[kq + i - j + j ld] (ld = kq + 1), the diagonal slot holding 1 / D(j) (the solves
 * multiply). The kernels take kc: the half-bandwidth when it is a compile-time constant (the loops
 * unroll; the first kq columns take the general form), else 0.
 */
#define BI static inline __attribute__((always_inline))

/* Column j with its len = min(j, kq) entries above the diagonal; t: D U(., j) (len doubles). */
BI int ldl_column(double *ab, size_t kq, size_t j, const size_t len, double *t)
{
    size_t ld = kq + 1;
    double *cj = ab + j * ld + (kq - len); /* cj[a] = U(j - len + a, j), cj[len] the diagonal */
    double dd = cj[len];
    for (size_t a = 0; a < len; a++) {
        const double *ci = ab + (j - len + a) * ld + kq; /* ci[c - a] = U(j - len + c, j - len + a), ci[0] = 1/D */
        double acc = cj[a];
        for (size_t c = 0; c < a; c++) acc -= ci[(ptrdiff_t)c - (ptrdiff_t)a] * t[c];
        t[a] = acc;
        cj[a] = acc * ci[0];
        dd -= acc * cj[a];
    }
    if (!(dd > 0)) return 1;
    cj[len] = 1 / dd;
    return 0;
}

/* Returns 0, or j + 1 if the leading minor of order j + 1 is not positive definite (as dpbtrf's
 * info). t: kq doubles of scratch. */
BI int ldl_factor_k(size_t n, const size_t kc, size_t kq, double *ab, double *t)
{
    if (kc) kq = kc;
    for (size_t j = 0; j < n; j++)
        if (kc && j >= kc ? ldl_column(ab, kq, j, kc, t) : ldl_column(ab, kq, j, j < kq ? j : kq, t)) return (int)j + 1;
    return 0;
}

/* x = K^-1 x: U^T y = x, y = D^-1 y, then U x = y. */
BI void ldl_solve_k(size_t n, const size_t kc, size_t kq, const double *ab, double *x)
{
    if (kc) kq = kc;
    size_t ld = kq + 1;
    for (size_t j = 0; j < n; j++) {
        size_t len = kc && j >= kc ? kc : j < kq ? j : kq;
        const double *cj = ab + j * ld + (kq - len), *xj = x + (j - len);
        double acc = x[j];
        for (size_t a = 0; a < len; a++) acc -= cj[a] * xj[a];
        x[j] = acc;
    }
    for (size_t j = 0; j < n; j++) x[j] *= ab[kq + j * ld];
    for (size_t j = n; j-- > 0;) {
        size_t len = kc && j >= kc ? kc : j < kq ? j : kq;
        const double *cj = ab + j * ld + (kq - len);
        double *xk = x + (j - len), v = x[j];
        for (size_t a = 0; a < len; a++) xk[a] -= cj[a] * v;
    }
}

static int band_ldl(size_t n, size_t kq, double *ab, double *t)
{
    switch (kq) {
    case 1: return ldl_factor_k(n, 1, 1, ab, t);
    case 2: return ldl_factor_k(n, 2, 2, ab, t);
    case 3: return ldl_factor_k(n, 3, 3, ab, t);
    case 4: return ldl_factor_k(n, 4, 4, ab, t);
    default: return ldl_factor_k(n, 0, kq, ab, t);
    }
}

static void band_ldl_solve(size_t n, size_t kq, const double *ab, double *x)
{
    switch (kq) {
    case 1: ldl_solve_k(n, 1, 1, ab, x); break;
    case 2: ldl_solve_k(n, 2, 2, ab, x); break;
    case 3: ldl_solve_k(n, 3, 3, ab, x); break;
    case 4: ldl_solve_k(n, 4, 4, ab, x); break;
    default: ldl_solve_k(n, 0, kq, ab, x);
    }
}

/* K = T''^-1 + (lambda^2/4) V'' (q order), factored: Cholesky, else LU. */
static int schur_factor(dth__band *b, double lam)
{
    size_t n = b->n, w = b->w, bw = b->bw, kq = (size_t)b->kq;
    double c = 0.25 * lam * lam;
    /* upper band for dpbtrf (ldab kq + 1): K(i, j) at kab[kq + i - j + j (kq + 1)], i <= j */
    size_t ld = kq + 1;
    for (size_t j = 0; j < n; j++) {
        size_t lo = j > kq ? j - kq : 0;
        for (size_t i = lo; i <= j; i++) {
            double v = c * b->hb[(2 * i) * bw + (2 * j) + w - 2 * i];
            if (i == j) v += b->tinv[i];
            b->kab[kq + i - j + j * ld] = v;
        }
    }
    b->own = kq <= DTH__BAND_OWN_KQ && !b->lapack_only;
    lapack_int info = b->own ? band_ldl(n, kq, b->kab, b->vx)
                             : LAPACKE_dpbtrf_work(LAPACK_COL_MAJOR, 'U', (lapack_int)n, (lapack_int)kq, b->kab, (lapack_int)ld);
    if (info < 0) return DTH_ELAPACK;
    if (info == 0) {
        b->mode = SCHUR_CHOL;
        return DTH_OK;
    }
    /* not positive definite: general band LU of K (kl = ku = kq, ldab 3 kq + 1) */
    size_t ldk = (size_t)b->ldk;
    memset(b->kab, 0, n * ldk * sizeof *b->kab);
    for (size_t j = 0; j < n; j++) {
        size_t lo = j > kq ? j - kq : 0, hi = j + kq < n - 1 ? j + kq : n - 1;
        for (size_t i = lo; i <= hi; i++) {
            double v = c * b->hb[(2 * i) * bw + (2 * j) + w - 2 * i];
            if (i == j) v += b->tinv[i];
            b->kab[2 * kq + i - j + j * ldk] = v;
        }
    }
    info = LAPACKE_dgbtrf_work(LAPACK_COL_MAJOR, (lapack_int)n, (lapack_int)n, (lapack_int)kq, (lapack_int)kq, b->kab,
                               (lapack_int)ldk, b->kpiv);
    if (info < 0) return DTH_ELAPACK;
    if (info > 0) return DTH_ESINGULAR;
    b->mode = SCHUR_LU;
    return DTH_OK;
}

/* B = I - (lambda/2) D into band storage (A(r, l) at ab[2kb + r - l + l ldab]), factored by LU. */
static int general_factor(dth__band *b, double lam)
{
    size_t w = b->w, nn = (size_t)b->nn, ldab = (size_t)b->ldab, kb = (size_t)b->kb;
    if (!b->ab) {
        /* first step through this path: the only allocation after creation */
        b->ab = dth_calloc(b->al, nn, ldab * sizeof(double));
        b->ipiv = dth_calloc(b->al, nn, sizeof(int));
        if (!b->ab || !b->ipiv) return DTH_ENOMEM;
    }
    memset(b->ab, 0, nn * ldab * sizeof *b->ab);
    for (size_t r = 0; r < nn; r++) {
        size_t s = r ^ 1;
        double sg = (r & 1) ? 0.5 * lam : -0.5 * lam;
        size_t lo = s > w ? s - w : 0, hi = s + w < nn - 1 ? s + w : nn - 1;
        const double *row = b->hb + s * b->bw + w - s;
        for (size_t l = lo; l <= hi; l++) b->ab[2 * kb + r - l + l * ldab] = sg * row[l];
        b->ab[2 * kb + r * ldab] += 1.0;
    }
    lapack_int info = LAPACKE_dgbtrf_work(LAPACK_COL_MAJOR, b->nn, b->nn, b->kb, b->kb, b->ab, b->ldab, b->ipiv);
    if (info < 0) return DTH_ELAPACK;
    if (info > 0) return DTH_ESINGULAR;
    b->mode = GENERAL;
    return DTH_OK;
}

/* x = B^{-1} x in place (interleaved, length nn), with the factors of the last factorization. */
static int b_solve(dth__band *b, double *x)
{
    lapack_int info;
    if (b->mode == GENERAL) {
        info = LAPACKE_dgbtrs_work(LAPACK_COL_MAJOR, 'N', b->nn, b->kb, b->kb, 1, b->ab, b->ldab, b->ipiv, x, b->nn);
        return info < 0 ? DTH_ELAPACK : DTH_OK;
    }
    size_t n = b->n, w = b->w, bw = b->bw, kq = (size_t)b->kq;
    double *rq = b->vx, hl = 0.5 * b->lam;
    for (size_t i = 0; i < n; i++) rq[i] = b->tinv[i] * x[2 * i] + hl * x[2 * i + 1];
    if (b->mode == SCHUR_CHOL && b->own) {
        band_ldl_solve(n, kq, b->kab, rq);
        info = 0;
    } else if (b->mode == SCHUR_CHOL)
        info = LAPACKE_dpbtrs_work(LAPACK_COL_MAJOR, 'U', (lapack_int)n, (lapack_int)kq, 1, b->kab, (lapack_int)(kq + 1), rq,
                                   (lapack_int)n);
    else
        info = LAPACKE_dgbtrs_work(LAPACK_COL_MAJOR, 'N', (lapack_int)n, (lapack_int)kq, (lapack_int)kq, 1, b->kab,
                                   (lapack_int)b->ldk, b->kpiv, rq, (lapack_int)n);
    if (info < 0) return DTH_ELAPACK;
    /* x_q = K^-1 (...), x_p = r_p - (lambda/2) V'' x_q */
    for (size_t i = 0; i < n; i++) {
        size_t r = 2 * i, lo = i > kq ? i - kq : 0, hi = i + kq < n - 1 ? i + kq : n - 1;
        const double *row = b->hb + r * bw + w - r;
        double acc = 0;
        for (size_t j = lo; j <= hi; j++) acc += row[2 * j] * rq[j];
        x[r + 1] -= hl * acc;
    }
    for (size_t i = 0; i < n; i++) x[2 * i] = rq[i];
    return DTH_OK;
}

int dth__band_factor(dth__band *b, const dth_model *m, const double *zb, const double *grad, double lam)
{
    size_t n = b->n, nn = (size_t)b->nn;
    /* not swept for NaN/Inf (nn (2w+1) entries): a non-finite entry shows in the solution */
    int rc = dth__model_hess_band_raw(m, zb, b->hb);
    if (rc) return rc;
    b->lam = lam;
    int schur = schur_applies(b);
    rc = schur ? schur_factor(b, lam) : general_factor(b, lam);
    if (rc) return rc;
    /* u and g interleaved: u = (dH/dp_i, -dH/dq_i), g = (dH/dq_i, dH/dp_i) */
    double *u = b->r, *e = b->y2;
    for (size_t i = 0; i < n; i++) {
        b->g[2 * i] = grad[i];
        b->g[2 * i + 1] = grad[n + 1 + i];
        u[2 * i] = grad[n + 1 + i];
        u[2 * i + 1] = -grad[i];
    }
    if (schur) {
        /* D u: q rows T''_ii u_p_i, p rows -sum_j V''_ij u_q_j (the q-q band only) */
        size_t w = b->w, bw = b->bw, kq = (size_t)b->kq;
        for (size_t i = 0; i < n; i++) {
            size_t r = 2 * i, lo = i > kq ? i - kq : 0, hi = i + kq < n - 1 ? i + kq : n - 1;
            const double *row = b->hb + r * bw + w - r;
            double acc = 0;
            for (size_t j = lo; j <= hi; j++) acc += row[2 * j] * u[2 * j];
            e[r] = -0.25 * lam * (u[r + 1] / b->tinv[i]);
            e[r + 1] = 0.25 * lam * acc;
        }
    } else {
        for (size_t r = 0; r < nn; r++) e[r] = -0.25 * lam * d_times(b, r, u);
    }
    rc = b_solve(b, e);
    if (rc) return rc;
    double s = 0;
    for (size_t r = 0; r < nn; r++) {
        s -= b->g[r] * e[r];
        b->y2[r] = -0.5 * u[r] + e[r];
    }
    if (!(s != 0) || !isfinite(s)) return DTH_ESINGULAR;
    b->s = s;
    return DTH_OK;
}

int dth__band_mode(const dth__band *b) { return b ? b->mode : 0; }

int dth__band_solve(dth__band *b, double *x)
{
    size_t n = b->n, nn = (size_t)b->nn;
    double *r = b->r;
    for (size_t i = 0; i < n; i++) {
        r[2 * i] = x[i];
        r[2 * i + 1] = x[n + i];
    }
    int rc = b_solve(b, r);
    if (rc) return rc;
    double gr = 0;
    for (size_t k = 0; k < nn; k++) gr += b->g[k] * r[k];
    double dl = (x[nn] - gr) / b->s;
    for (size_t i = 0; i < n; i++) {
        x[i] = r[2 * i] - b->y2[2 * i] * dl;
        x[n + i] = r[2 * i + 1] - b->y2[2 * i + 1] * dl;
    }
    x[nn] = dl;
    return DTH_OK;
}

/*
 * Tangent map M = dz_{k+1}/dz_k ((2n+2)^2, row-major) of the step with midpoint zbar and step
 * lam, one column at a time: B is refactored at zbar (O(n w^2)), column l of -dF/dz_k is
 * (lambda/2) D e_l over (q, p) with border entry -grad H_l (-1 for wp); the t column is zero
 * (autonomous). O(n^2 w) time, O(n) extra memory; the dense path needs O(n^3) and O(n^2).
 */
int dth__band_tangent(dth__band *b, const dth_model *m, const double *zbar, double lam, double *M)
{
    size_t n = b->n, nn = (size_t)b->nn, N = 2 * n + 2, w = b->w;
    double H, *t = b->grad + 2 * n + 1;
    int rc = dth_model_eval(m, zbar, DTH_EVAL_H | DTH_EVAL_GRAD, &H, b->grad, NULL);
    if (!rc) rc = dth__band_factor(b, m, zbar, b->grad, lam);
    if (rc) return rc;
    memset(M, 0, N * N * sizeof *M);
    for (size_t i = 0; i < N; i++) M[i * N + i] = 1.0;
    for (size_t l = 0; l < N; l++) {
        if (l == n) continue;
        memset(t, 0, (nn + 1) * sizeof *t);
        if (l == N - 1) {
            t[nn] = -1.0;
        } else {
            size_t c = l < n ? 2 * l : 2 * (l - n - 1) + 1;
            t[nn] = -b->grad[l];
            size_t lo = c > w + 1 ? c - w - 1 : 0, hi = c + w + 1 < nn - 1 ? c + w + 1 : nn - 1;
            for (size_t r = lo; r <= hi; r++) {
                size_t s = r ^ 1;
                if ((s > c ? s - c : c - s) > w) continue;
                double D = b->hb[s * b->bw + c + w - s];
                t[(r & 1) ? n + r / 2 : r / 2] = 0.5 * lam * ((r & 1) ? -D : D);
            }
        }
        rc = dth__band_solve(b, t);
        if (rc) return rc;
        for (size_t a = 0; a < nn; a++) M[(a < n ? a : a + 1) * N + l] += 2 * t[a];
        M[n * N + l] += t[nn];
    }
    return DTH_OK;
}

/*
 * The step matrix's first block alone, B = I - (lambda/2) J H_xx at zb, factored (the Schur
 * complement where it applies, else banded LU): the prescribed-step midpoint solve of the order-4
 * composition's band and start (compose_mid.c), whose lambda is given. Overwrites the factors.
 */
int dth__band_factor_block(dth__band *b, const dth_model *m, const double *zb, double lam)
{
    int rc = dth__model_hess_band_raw(m, zb, b->hb);
    if (rc) return rc;
    b->lam = lam;
    return schur_applies(b) ? schur_factor(b, lam) : general_factor(b, lam);
}

/* x = B^-1 x with those factors; x over (q block, p block), 2n values. */
int dth__band_solve_block(dth__band *b, double *x)
{
    size_t n = b->n;
    double *r = b->r;
    for (size_t i = 0; i < n; i++) {
        r[2 * i] = x[i];
        r[2 * i + 1] = x[n + i];
    }
    int rc = b_solve(b, r);
    if (rc) return rc;
    for (size_t i = 0; i < n; i++) {
        x[i] = r[2 * i];
        x[n + i] = r[2 * i + 1];
    }
    return DTH_OK;
}
