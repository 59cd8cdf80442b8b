/* SPDX-License-Identifier: MIT */
/*
 * The DTH step as a Newton problem (paper, Theorem "DTH Equations"): the bordered system's residual
 * and Jacobian, its compensated and reversible finishes, the small path's Schur complement, the
 * linear-solver table (dense LU, banded), Newton's driver instances for the generic path and the
 * small path (n = 1, 2, 3, written out), and the commit of a solution as the next vertex.
 */
#include <float.h>
#include <math.h>
#include <stdio.h>
#include <stdint.h>
#include <string.h>
#include "dth_kernels.h"
#include "lu_small.h"
#include "newton.h"

/*
 * Residual F and, if A != NULL, the Jacobian A (column-major m x m) at the unknowns x, given
 * grad and hess of H_phys at the midpoint zb. F_a = d_j - (lambda/2) u_j(zbar); F_last = H(zbar).
 */
AI void assemble_n(const dth__dth *it, const size_t nc, const double *x, const double *zb, double Hphys, double *F,
                   double *A)
{
    size_t n = nc ? nc : it->n, N = 2 * n + 2;
    int m = nc ? (int)(2 * nc + 1) : it->m;
    const double *g = it->grad, *Hy = it->hess;
    double lam = x[m - 1], hl = 0.5 * lam;
    F[m - 1] = zb[N - 1] + Hphys;
    if (it->level != 0) F[m - 1] += it->level; /* a constraint moved to the level H = -s (dth_core.h) */
    if (nc || it->auton) {
        /* rows q_i: d_q - (lambda/2) dH/dp_i;  rows p_i: d_p + (lambda/2) dH/dq_i */
        size_t mm = (size_t)m;
        for (size_t i = 0; i < n; i++) {
            F[i] = x[i] - hl * g[n + 1 + i];
            F[n + i] = x[n + i] + hl * g[i];
        }
        if (!A) return;
        for (size_t i = 0; i < n; i++) {
            for (size_t k = 0; k < n; k++) {
                A[i + k * mm] = -hl * dth__dudz(n, Hy, i, k);                     /* dF_qi / d d_qk */
                A[i + (n + k) * mm] = -hl * dth__dudz(n, Hy, i, n + 1 + k);        /* dF_qi / d d_pk */
                A[n + i + k * mm] = -hl * dth__dudz(n, Hy, n + 1 + i, k);
                A[n + i + (n + k) * mm] = -hl * dth__dudz(n, Hy, n + 1 + i, n + 1 + k);
            }
            A[i + i * mm] += 1.0;
            A[n + i + (n + i) * mm] += 1.0;
            A[i + 2 * n * mm] = -0.5 * g[n + 1 + i];       /* dF / d lambda = -u/2 */
            A[n + i + 2 * n * mm] = 0.5 * g[i];
            A[2 * n + i * mm] = g[i];                      /* border: grad H */
            A[2 * n + (n + i) * mm] = g[n + 1 + i];
        }
        A[2 * n + 2 * n * mm] = 0.0;
        return;
    }
    double *u = it->u;
    dth__flow_z(n, g, u);
    for (int a = 0; a < m - 1; a++) {
        size_t j = (size_t)it->act[a];
        F[a] = x[a] - hl * u[j];
        if (!A) continue;
        for (int b = 0; b < m - 1; b++) A[a + b * m] = (a == b ? 1.0 : 0.0) - hl * dth__dudz(it->n, it->hess, j, (size_t)it->act[b]);
        A[a + (m - 1) * m] = -0.5 * u[j];
        A[(m - 1) + a * m] = (j == N - 1) ? 1.0 : g[j];
    }
    if (A) A[(m - 1) + (m - 1) * m] = 0.0;
}

static void assemble(const dth__dth *it, const double *x, const double *zb, double Hphys, double *F, double *A)
{
    assemble_n(it, 0, x, zb, Hphys, F, A);
}

/* Scale of the terms of H at the midpoint, for round-off judgements. */
AI double h_scale_n(const dth__dth *it, const size_t nc, const double *zb, double Hphys)
{
    size_t d = nc ? 2 * nc + 1 : it->d;
    double s = fabs(zb[d]) + fabs(Hphys);
    for (size_t j = 0; j < d; j++) s += fabs(it->grad[j] * zb[j]);
    return s;
}

static double h_scale(const dth__dth *it, const double *zb, double Hphys) { return h_scale_n(it, 0, zb, Hphys); }

/* The cubic model of the constraint (Lemma g_taylor): root of H - psi l^2/8 - dpsi l^3/24 near
 * `target`, on its side of 0; `target` itself if the cubic has none there. */
double dth__cubic_predict(double Hk, double psi, double dpsi, double target)
{
    double l = target;
    if (psi != 0 && Hk / psi > 0) l = copysign(sqrt(8 * Hk / psi), target);
    for (int i = 0; i < 20; i++) {
        double c = Hk - psi * l * l / 8 - dpsi * l * l * l / 24;
        double dc = -psi * l / 4 - dpsi * l * l / 8;
        if (dc == 0) break;
        double ln = l - c / dc;
        if (!isfinite(ln) || ln * target <= 0) return target;
        if (fabs(ln - l) <= 1e-15 * fabs(l)) {
            l = ln;
            break;
        }
        l = ln;
    }
    return (l * target > 0 && fabs(l) < 16 * fabs(target) && fabs(l) > fabs(target) / 16) ? l : target;
}

/* Block of a z-index: 0 positions q, 1 time t, 2 momenta p, 3 wp. */
static int block_of(const dth__dth *it, int j)
{
    size_t n = it->n;
    return j < (int)n ? 0 : j == (int)n ? 1 : j < (int)(2 * n + 1) ? 2 : 3;
}

/*
 * Convergence is judged per block (q, t, p, wp) in the max-norm of |z| + |zbar|, not per
 * component: a component that is itself round-off sized (a particle at rest) has no relative
 * precision to reach. An all-zero block falls back to the largest block scale.
 */
AI double block_max(const double *z, const double *zb, size_t lo, size_t hi)
{
    double s = 0;
    for (size_t j = lo; j < hi; j++) {
        double v = fabs(z[j]) + fabs(zb[j]);
        if (v > s) s = v;
    }
    return s;
}

AI void block_scales_n(dth__dth *it, const size_t nc, const double *zb, double bs[4])
{
    size_t n = nc ? nc : it->n;
    double top = 0;
    bs[0] = block_max(it->st.z, zb, 0, n);
    bs[1] = block_max(it->st.z, zb, n, n + 1);
    bs[2] = block_max(it->st.z, zb, n + 1, 2 * n + 1);
    bs[3] = block_max(it->st.z, zb, 2 * n + 1, 2 * n + 2);
    for (int b = 0; b < 4; b++)
        if (bs[b] > top) top = bs[b]; /* fmax without the call: top is never NaN */
    for (int b = 0; b < 4; b++)
        if (bs[b] == 0) bs[b] = top > 0 ? top : 1.0;
    it->ibq = 1 / bs[0]; /* the judge multiplies (a division per iteration costs more than the rest) */
    it->ibp = 1 / bs[2];
}

/* ---- the step as a Newton problem (newton.h) ---- */

/*
 * The linear-solver table: the path that factors and solves the step's bordered system (paper,
 * Theorem "DTH Equations") and gives its tangent map. Dense (kinds dense, small, small-lu): the
 * Jacobian assembled from the dense Hessian, LU by LAPACK or written out (dth__lu_*); the small
 * path's instances for n = 1..3 (SMALL_OPS below) inline the same LU or their Schur complement.
 * Banded (banded, banded-lu): banded.c, which evaluates the model's banded Hessian itself.
 */
struct dth__linsolver {
    unsigned hess; /* DTH_EVAL_HESS: the Newton loop evaluates the dense Hessian and assembles it->A */
    int (*factor)(dth__dth *it, double lam); /* at it->zb (gradient in it->grad) */
    int (*solve)(dth__dth *it, double *b);   /* b = J^-1 b with the last factors */
    int (*tangent)(dth__dth *it, double *M); /* the last step's tangent map (refactors) */
};

static int dense_factor(dth__dth *it, double lam)
{
    (void)lam;
    return dth__lu_factor(it->kind, it->m, it->A, it->piv);
}
static int dense_solve(dth__dth *it, double *b) { return dth__lu_solve(it->kind, it->m, it->A, it->piv, 1, b); }
static int band_factor(dth__dth *it, double lam)
{
    return dth__band_factor(it->band, it->model, it->zb, it->grad, lam);
}
static int band_solve(dth__dth *it, double *b) { return dth__band_solve(it->band, b); }
static int band_tangent(dth__dth *it, double *M)
{
    return dth__band_tangent(it->band, it->model, it->st.zbar, it->st.lam, M);
}

const struct dth__linsolver dth__dense_ls = {DTH_EVAL_HESS, dense_factor, dense_solve, dth__dense_tangent};
const struct dth__linsolver dth__band_ls = {0, band_factor, band_solve, band_tangent};


/*
 * The compensated finish of a step, as the residual of its chord steps (newton.h): the constraint
 * row from the carried vertex offset, E = rho_k + (H(zbar) - H(z_k)), the difference from the
 * model's hdiff: its error scales with the step instead of with the energy's size. The direct value
 * wp + H_phys(zbar) (in F on entry) carries eps S, S = |wp| + |H_phys| + sum |dH/dy_j y_j|, and
 * lambda is fixed by a second-order effect (paper, Lemma g_taylor), so that noise moves lambda by
 * about 4 eps S / (|psi| lambda^2): the reason for the carried offset.
 * The carried offset random-walks by about eps sum |dH/dy_j delta_j| per step; where it has drifted
 * from the direct value by more than tau = 4 eps S, the step takes the direct value instead (and
 * the next offset is measured from this midpoint again), so the midpoint energy stays within tau of
 * exact. Both rules give the backward step the same equation at the same midpoint (the carried
 * offset of z_(k+1) is measured from zbar), so the map stays time-reversible. it->zb, it->zblo,
 * it->Hphys and it->grad belong to x (eval_n).
 */
AI int compensated_n(dth__dth *it, const size_t nc, const double *x, double *F)
{
    size_t n = nc ? nc : it->n;
    int m = nc ? (int)(2 * nc + 1) : it->m;
    /* the offset rows d - (lambda/2) u to O(eps^2 |d|), with the low parts of the unknowns: a
     * residual rounded to eps |d| moves lambda by about eps |d| |grad H| / (|psi| lambda^2 / 4) (the
     * constraint fixes lambda at second order), which the reverse step would not reproduce */
    size_t d = 2 * n + 1;
    if (!it->rev) { /* the compensated constraint alone (the rows as assemble_n has them) */
        double dh, dhlo;
        int rc = rho_from_mid_n(it, nc, it->zb, NULL, it->zblo, it->grad, NULL, it->st.z, it->st.zlo, &dh, &dhlo);
        if (rc) {
            dth__seterr(it, "model evaluation failed in the compensated constraint: %s", dth_strerror(rc));
            return rc;
        }
        double ec = (it->st.rho - dh) + (it->st.rholo - dhlo), rd = F[m - 1];
        if (it->level != 0) ec += it->level;
        double tau = 4 * DBL_EPSILON * h_scale_n(it, nc, it->zb, it->Hphys);
        F[m - 1] = fabs(ec - rd) <= tau ? ec : rd;
        return DTH_OK;
    }
    const double *xl = it->xlo, hl = 0.5 * x[m - 1], hlo = 0.5 * xl[m - 1], *dy = it->ydel;
    /* the gradient's change from y to the midpoint, gl = H''(y) (zbar - y), in double-double (the
     * products with dy, up to 2^-27 |zbar|, exactly): its rounding would be noise in the rows */
    double *gl = it->ygl, *gll = it->ybar;
    taylor_grad(it, d, dy, it->zblo, gl, gll);
    if (nc || it->auton) {
        for (size_t i = 0; i < n; i++) {
            F[i] = exact_row(x[i], xl[i], hl, hlo, it->grad[n + 1 + i], gl[n + 1 + i], gll[n + 1 + i]);
            F[n + i] = exact_row(x[n + i], xl[n + i], hl, hlo, -it->grad[i], -gl[i], -gll[i]);
        }
    } else {
        for (int a = 0; a < m - 1; a++) {
            size_t j = (size_t)it->act[a];
            F[a] = exact_row(x[a], xl[a], hl, hlo, it->u[j], j_of_gl(n, d, j, gl), j_of_gl(n, d, j, gll));
        }
    }
    double dh, dhlo;
    int rc = rho_from_mid_n(it, nc, it->yc, dy, it->zblo, it->grad, gl, it->st.z, it->st.zlo, &dh, &dhlo); /* H(z_k) - H(zbar) */
    if (rc) {
        dth__seterr(it, "model evaluation failed in the compensated constraint: %s", dth_strerror(rc));
        return rc;
    }
    /* no fallback to the direct value here: the carried offset is what makes the step its own
     * reverse (its random walk, eps |grad H| |d| per step, is the energy's) */
    F[m - 1] = (it->st.rho - dh) + (it->st.rholo - dhlo);
    if (it->level != 0) F[m - 1] += it->level;
    return DTH_OK;
}

/*
 * The small path's Schur complement (dth__small_schur) at the Hessian and gradient in it->hess /
 * it->grad: 0 if it applies (q-p block zero, T'' diagonal and positive, K and the border regular),
 * else 1 (the caller factors the whole bordered matrix). Eliminating d_p from B (d_q, d_p) = r gives
 *     K w_q = r_q + (lambda/2) T'' r_p,   w_p = r_p - (lambda/2) V'' w_q,   K = I + (lambda^2/4) T'' V''
 * (T'' times the symmetric T''^-1 + (lambda^2/4) V'' of banded.c: no division by T''). The border:
 * y2 = B^-1 c = c + e with B e = c - B c = (lambda/4) (T'' g_q, V'' g_p), so that s = -g^T y2 = -g^T e
 * (g^T c = 0 exactly, pair by pair) is computed without cancellation.
 */
AI int schur_factor_n(dth__dth *it, const size_t n, double lam)
{
    dth__small_schur *S = &it->ss;
    const size_t d = 2 * n + 1;
    const double *Hy = it->hess, *g = it->grad;
    for (size_t i = 0; i < n; i++) {
        double tpp = Hy[(n + 1 + i) * d + n + 1 + i];
        if (!(tpp > 0)) return 1;
        for (size_t k = 0; k < n; k++)
            if (Hy[i * d + n + 1 + k] != 0 || (k != i && Hy[(n + 1 + i) * d + n + 1 + k] != 0)) return 1;
        S->t[i] = tpp;
    }
    double hl = 0.5 * lam, c = hl * hl, vg[3], eq[3];
    S->hl = hl;
    for (size_t i = 0; i < n; i++) {
        S->g[i] = g[i];
        S->g[n + i] = g[n + 1 + i];
        for (size_t k = 0; k < n; k++) {
            double v = Hy[i * d + k];
            S->V[i * n + k] = v;
            S->K[i + k * n] = (i == k ? 1.0 : 0.0) + c * (S->t[i] * v);
        }
    }
    if (lu_factor_m((int)n, S->K, S->piv, S->kinv) != DTH_OK) return 1;
    for (size_t i = 0; i < n; i++) {
        double a = 0;
        for (size_t k = 0; k < n; k++) a += S->V[i * n + k] * S->g[n + k];
        vg[i] = a;
        eq[i] = S->t[i] * (0.5 * hl * S->g[i] + hl * (0.5 * hl * a));
    }
    lu_solve_m((int)n, S->K, S->piv, S->kinv, eq);
    double sc = 0;
    for (size_t i = 0; i < n; i++) {
        double ve = 0;
        for (size_t k = 0; k < n; k++) ve += S->V[i * n + k] * eq[k];
        double ep = 0.5 * hl * vg[i] - hl * ve;
        S->y2[i] = -0.5 * S->g[n + i] + eq[i];
        S->y2[n + i] = 0.5 * S->g[i] + ep;
        sc -= S->g[i] * eq[i] + S->g[n + i] * ep;
    }
    S->sinv = 1 / sc;
    return isfinite(sc) && sc != 0 ? 0 : 1;
}

/* b = J^-1 b with the Schur complement's factors. */
AI void schur_solve_n(const dth__dth *it, const size_t n, double *b)
{
    const dth__small_schur *S = &it->ss;
    double wq[3], wp[3], gw = 0;
    for (size_t i = 0; i < n; i++) wq[i] = b[i] + S->hl * (S->t[i] * b[n + i]);
    lu_solve_m((int)n, S->K, S->piv, S->kinv, wq);
    for (size_t i = 0; i < n; i++) {
        double vw = 0;
        for (size_t k = 0; k < n; k++) vw += S->V[i * n + k] * wq[k];
        wp[i] = b[n + i] - S->hl * vw;
        gw += S->g[i] * wq[i] + S->g[n + i] * wp[i];
    }
    double al = (b[2 * n] - gw) * S->sinv;
    for (size_t i = 0; i < n; i++) {
        b[i] = wq[i] - S->y2[i] * al;
        b[n + i] = wp[i] - S->y2[n + i] * al;
    }
    b[2 * n] = al;
}

/* nc > 0: the small path for an autonomous model with n = nc (written out, no library call) */
AI int eval_n(dth__dth *it, const size_t nc, const double *x, double *F, int jac)
{
    int m = nc ? (int)(2 * nc + 1) : it->m;
    /* a chord step's compensated constraint (compensated_n) needs the midpoint's low part, and
     * evaluates the model at the coarsened midpoint y (coarse_n) */
    /* the compensated constraint also in the Newton iterations where the offset is within round-off
     * (it->tiny, newton_n): there the plain constraint's noise, eps S, is a visible part of the offset
     * rho ~ psi lambda^2 / 8 that fixes lambda, and the Newton root it leaves is too far from the
     * compensated root for the finishing chord steps to reach it, so the carried offset, and lambda
     * with it, would random-walk (pendulum h = 1e-7: 113 370 steps to t = 0.1 instead of 10^6) */
    int tiny = jac && it->tiny;
    int fin = (!jac || tiny) && it->opt.finish;
    midpoint_n(it, nc, x, it->zb, fin ? it->zblo : NULL);
    /* the model's outputs are not swept for NaN/Inf here (the Hessian alone is (2n+1)^2): a
     * non-finite value shows in the correction, and step_judge finds out why */
    unsigned what = DTH_EVAL_H | DTH_EVAL_GRAD | (jac || (fin && it->rev) ? it->ls->hess : 0u);
    int at_y = fin && it->rev;
    if (at_y) coarse_n(it, nc, it->zb, it->ydel);
    int rc = it->meval(it->mself, at_y ? it->yc : it->zb, what, &it->Hphys, it->grad, it->hess);
    if (rc) {
        rc = rc > 0 ? DTH_EDOMAIN : DTH_EMODEL;
        dth__seterr(it, "model evaluation failed at a trial midpoint (iteration %d): %s", it->nt.iter, dth_strerror(rc));
        return rc;
    }
    int schur = nc && jac && it->small_schur; /* try the Schur complement first: A is not assembled */
    assemble_n(it, nc, x, it->zb, it->Hphys, F, jac && it->ls->hess && !schur ? it->A : NULL);
    if (!jac) return it->opt.finish ? compensated_n(it, nc, x, F) : DTH_OK;
    if (tiny && (rc = compensated_n(it, nc, x, F)) != DTH_OK) return rc;
    if (schur) {
        it->ss.on = !schur_factor_n(it, nc, x[m - 1]);
        if (it->ss.on) return DTH_OK;
        assemble_n(it, nc, x, it->zb, it->Hphys, F, it->A); /* it does not apply here: LU */
        if (tiny && (rc = compensated_n(it, nc, x, F)) != DTH_OK) return rc;
    }
    rc = nc ? lu_factor_m((int)(2 * nc + 1), it->A, it->piv, NULL) : it->ls->factor(it, x[m - 1]);
    if (rc == DTH_ESINGULAR || rc == DTH_ELAPACK)
        dth__seterr(it, "bordered Jacobian is singular at iteration %d (lambda = %.17g)", it->nt.iter, x[m - 1]);
    else if (rc)
        dth__seterr(it, "model evaluation failed at a trial midpoint (iteration %d): %s", it->nt.iter, dth_strerror(rc));
    return rc;
}

static int step_eval(void *ctx, const double *x, double *F, int jac) { return eval_n(ctx, 0, x, F, jac); }

static int step_solve(void *ctx, double *b)
{
    dth__dth *it = ctx;
    return it->ls->solve(it, b);
}

/* The relative correction of an autonomous step: the q block, the p block (never zero:
 * block_scales), lambda. NaN propagates. */
AI double correction_n(const dth__dth *it, const size_t nc, const double *x, const double *dx)
{
    size_t n = nc ? nc : it->n;
    double cq = 0, cp = 0;
    for (size_t i = 0; i < n; i++) {
        double a = fabs(dx[i]), b = fabs(dx[n + i]);
        if (!(a <= cq)) cq = a;
        if (!(b <= cp)) cp = b;
    }
    double l = fabs(x[2 * n]), rq = cq * it->ibq, rp = cp * it->ibp, rl = fabs(dx[2 * n]) / (l > 0 ? l : 1e-300);
    double r = rq;
    if (!(rp <= r)) r = rp;
    if (!(rl <= r)) r = rl;
    return r;
}

/* What step_judge does beyond the rate: divergence (is it the model's domain?) and a stall. */
static int judge_slow(dth__dth *it, int v, const double *x, const double *dx, const double *F,
                      dth__newton_track *tr, int *verdict)
{
    int m = it->m;
    const double *bs = it->bs;
    if (v == DTH__NT_DIVERGED || !isfinite(x[m - 1])) {
        /* a non-finite model output (not swept in step_eval) is the model's domain, not Newton's */
        int rc = dth_model_eval(it->model, it->zb, DTH_EVAL_H | DTH_EVAL_GRAD | it->ls->hess, &it->Hphys, it->grad,
                                it->hess);
        if (!rc && !it->ls->hess) rc = dth__model_hess_band(it->model, it->zb, it->work);
        if (rc) {
            dth__seterr(it, "model evaluation failed at a trial midpoint (iteration %d): %s", tr->iter, dth_strerror(rc));
            return rc;
        }
        dth__seterr(it, "Newton diverged at iteration %d", tr->iter);
        return DTH_ENOCONV;
    }
    /* The correction stopped decreasing: accept only if the energy residual is at
     * round-off and the state residual at round-off or below what the noise of lambda
     * itself causes (lambda is fixed by a second-order effect, so its correction can
     * stall well above eps: paper, Lemma g_taylor; a residual d - (lambda/2) u then
     * carries (dlambda/2) u). */
    double fs = 0, ds = 0, rl = fabs(dx[m - 1]) / fabs(x[m - 1]);
    for (int a = 0; a < m - 1; a++) {
        int j = it->act[a];
        fs = fmax(fs, fabs(F[a]) / bs[block_of(it, j)]);
        ds = fmax(ds, fabs(x[a]) / bs[block_of(it, j)]);
    }
    double hs = h_scale(it, it->zb, it->Hphys);
    if (!isfinite(fs)) fs = INFINITY;
    if (fs <= 1e3 * DBL_EPSILON + 2 * fmin(rl, 1e-6) * ds && fabs(F[m - 1]) <= 1e3 * DBL_EPSILON * hs) {
        *verdict = DTH__NT_DONE;
        return DTH_OK;
    }
    if (tr->iter >= 8) {
        dth__seterr(it, "Newton stalled at relative correction %.3g (residual %.3g)", tr->r, fabs(F[m - 1]));
        return DTH_ENOCONV;
    }
    *verdict = DTH__NT_MORE;
    return DTH_OK;
}

AI int judge_n(dth__dth *it, const size_t nc, const double *x, const double *dx, const double *F,
               dth__newton_track *tr, int *verdict)
{
    int m = nc ? (int)(2 * nc + 1) : it->m;
    double r = 0;
    if (nc || it->auton) {
        r = correction_n(it, nc, x, dx);
    } else {
        for (int a = 0; a < m; a++) {
            double sc = a == m - 1 ? fabs(x[a]) : it->bs[block_of(it, it->act[a])];
            double ra = fabs(dx[a]) / (sc > 0 ? sc : 1e-300);
            if (!(ra <= r)) r = ra; /* NaN propagates */
        }
    }
    tr->r = r;
    int v = dth__newton_rate_inl(r, tr->r_prev, tr->iter, 4 * DBL_EPSILON);
    if (v == DTH__NT_DIVERGED || v == DTH__NT_STALLED || !isfinite(x[m - 1])) {
        int rc = judge_slow(it, v, x, dx, F, tr, &v);
        if (rc) return rc;
    }
    /* converged: a compensated step still finishes with its chord step (compensated_n) */
    *verdict = v == DTH__NT_DONE && it->opt.finish ? DTH__NT_CHORD : v;
    return DTH_OK;
}

static int step_judge(void *ctx, const double *x, const double *dx, const double *F, dth__newton_track *tr, int *verdict)
{
    return judge_n(ctx, 0, x, dx, F, tr, verdict);
}

/*
 * One more compensated chord step where the last one moved the midpoint out of the coarse cell its
 * evaluation point y stood for (coarse_n: a root is consistent, the reverse step finding the same
 * one, only once the last evaluation's y is the converged midpoint's); where the root is not yet
 * resolved to 2^-100 (the chord steps converge at the rate of the factors' distance to the root,
 * about the last Newton correction, or of the solve's own round-off); or where the last one moved
 * lambda so far (a stalled Newton at tiny steps) that the chord's own second-order error
 * dlambda^2 / lambda is above eps lambda. Where the root sits at a cell boundary, so that each
 * cell's gradient puts it in the other (the gradients' roundings differ), the chords alternate
 * between two cells: y is then pinned to the componentwise lower of the two, which the reverse
 * step picks as well. At most 6 chord steps.
 */
static int step_again(void *ctx, const double *x, const double *dx, int chords)
{
    dth__dth *it = ctx;
    if (!it->opt.finish || chords >= (it->rev ? 6 : 3)) return 0;
    double dl = dx[it->m - 1], l = x[it->m - 1];
    if (dl * dl > DBL_EPSILON * (l * l)) return 1; /* (dl / l)^2 > eps */
    if (!it->rev) return 0;
    double e = 0, rate = fmax(it->nt.r, 1e-12);
    for (int a = 0; a < it->m; a++)
        if (x[a] != 0) e = fmax(e, fabs(dx[a] / x[a]));
    int more = rate * e > 0x1p-100;
    if (it->ypinned) return more;
    double *zb = it->u, *lo = it->znewlo; /* scratch (N each) until the next evaluation / the commit */
    midpoint_n(it, 0, x, zb, lo);
    int moved = 0, back = chords >= 2;
    coarsen_y(it->n, zb, lo);
    for (size_t j = 0; j < it->d; j++) {
        moved |= lo[j] != it->yc[j];
        back &= lo[j] == it->yprev[j];
        zb[j] = lo[j];
    }
    if (!moved) return more;
    if (back) { /* alternating: pin */
        for (size_t j = 0; j < it->d; j++) it->yc[j] = fmin(it->yc[j], zb[j]);
        it->ypinned = 1;
        return 1;
    }
    memcpy(it->yprev, it->yc, it->d * sizeof *it->yc);
    return 1;
}

static const dth__newton_ops step_ops = {step_eval, step_solve, step_judge};

/* The small path's instances for n = 1, 2, 3 (m = 3, 5, 7). */
#define SMALL_OPS(N)                                                                                            \
    AI int eval_##N(void *c, const double *x, double *F, int jac) { return eval_n(c, N, x, F, jac); }             \
    AI int solve_##N(void *c, double *b)                                                                          \
    {                                                                                                             \
        dth__dth *it = c;                                                                                   \
        if (it->ss.on) schur_solve_n(it, N, b); /* set only where it->small_schur */                              \
        else lu_solve_m(2 * N + 1, it->A, it->piv, NULL, b);                                                      \
        return DTH_OK;                                                                                            \
    }                                                                                                             \
    AI int judge_##N(void *c, const double *x, const double *dx, const double *F, dth__newton_track *tr, int *v)     \
    {                                                                                                             \
        return judge_n(c, N, x, dx, F, tr, v);                                                                    \
    }                                                                                                             \
    static const dth__newton_ops small_ops_##N = {eval_##N, solve_##N, judge_##N};
SMALL_OPS(1)
SMALL_OPS(2)
SMALL_OPS(3)

/*
 * Newton on the step from the seed (lam0, d0); nc > 0: the small path, whose driver (newton.h) and
 * callbacks are inlined. After it: the accepted midpoint in it->zb, its direct energy residual, and
 * its low part for the commit.
 */
AI int newton_n(dth__dth *it, const size_t nc, const dth__newton_ops *ops, double lam0, const double *d0,
                int max_iter, dth__solution *sol)
{
    size_t n = nc ? nc : it->n, N = 2 * n + 2;
    int m = nc ? (int)(2 * nc + 1) : it->m;
    double *x = it->x, *zb = it->zb;
    unknowns_n(it, nc, d0, lam0);
    /* the offset within 2^12 eps S of round-off (S ~ |wp| + |H_phys(z_k)|, a switch, not a bound):
     * the iterations solve the compensated constraint too (eval_n); above it, nothing changes */
    if (it->opt.finish == DTH_FINISH_COMPENSATED) {
        /* the offset the constraint reads: H(z_k) + s (a composition's substep: its level s) */
        double wp = it->st.z[N - 1], rho = it->st.rho, off = it->level != 0 ? rho + it->level : rho;
        it->tiny = fabs(off) < 4096 * DBL_EPSILON * (fabs(wp) + fabs(rho - wp));
    }
    sol->iters = 0;
    sol->residual = NAN;
    midpoint_n(it, nc, x, zb, NULL);
    block_scales_n(it, nc, zb, it->bs);
    int rc = dth__newton_iterate(ops, step_again, it, m, max_iter, x, it->rev ? it->xlo : NULL, it->F, it->dx, &it->nt);
    sol->iters = it->nt.iter;
    if (rc == DTH_ENOCONV && it->nt.verdict == DTH__NT_MAXITER)
        dth__seterr(it, "Newton did not converge in %d iterations (last correction %.3g)", it->nt.iter, it->nt.r);
    if (rc) return rc;
    midpoint_n(it, nc, x, zb, it->opt.finish ? it->zblo : NULL);
    rc = it->meval(it->mself, zb, DTH_EVAL_H, &it->Hphys, NULL, NULL);
    if (!rc && !isfinite(it->Hphys)) rc = 1;
    if (rc) {
        rc = rc > 0 ? DTH_EDOMAIN : DTH_EMODEL;
        dth__seterr(it, "model evaluation failed at the converged midpoint: %s", dth_strerror(rc));
        return rc;
    }
    sol->residual = fabs(zb[N - 1] + it->Hphys + it->level);
    sol->lambda = x[m - 1];
    return DTH_OK;
}

/* Commit the solution in it->x / it->zb: new vertex z + 2 d in double-double, and its carried
 * offset, computed into scratch first (dth__commit). */
AI int commit_n(dth__dth *it, const size_t nc, double lam, int replaced)
{
    size_t n = nc ? nc : it->n, N = 2 * n + 2;
    int m = nc ? (int)(2 * nc + 1) : it->m;
    /* new vertex into scratch first (znew: the full offset d, then z + 2 d): a finite midpoint can
     * still give an overflowing vertex, and then the state stays untouched */
    double *zn = it->znew, *zl = it->znewlo, *dl = zl; /* dl: the offset's low part (read before zl[j] is written) */
    if (nc || it->auton) {
        /* autonomous: t advances by lambda/2, wp stays */
        for (size_t i = 0; i < n; i++) {
            zn[i] = it->x[i];
            zn[n + 1 + i] = it->x[n + i];
        }
        zn[n] = 0.5 * lam;
        zn[N - 1] = 0;
        if (it->rev) {
            for (size_t i = 0; i < n; i++) {
                dl[i] = it->xlo[i];
                dl[n + 1 + i] = it->xlo[n + i];
            }
            dl[n] = 0.5 * it->xlo[m - 1];
            dl[N - 1] = 0;
        }
    } else {
        for (int a = 0; a < m - 1; a++) zn[it->act[a]] = it->x[a];
        if (it->rev)
            for (int a = 0; a < m - 1; a++) dl[it->act[a]] = it->xlo[a];
    }
    double *d = it->dnew; /* scratch: becomes the newest history slot */
    int finite = 1;
    for (size_t j = 0; j < N; j++) {
        d[j] = zn[j];
        if (it->rev) { /* z + zlo + 2 (d + dlo) in double-double */
            double e, sj = two_sum(it->st.z[j], 2 * d[j], &e);
            zn[j] = two_sum(sj, (it->st.zlo[j] + 2 * dl[j]) + e, &zl[j]);
        } else { /* to the rounding of 2 d + zlo */
            zn[j] = two_sum(it->st.z[j], 2 * d[j] + it->st.zlo[j], &zl[j]);
        }
        finite &= isfinite(zn[j]) != 0;
    }
    if (replaced && it->jump) /* a regularizer's reset of the end vertex (DTH_STEP_RESET): no time passes */
        for (size_t j = 0; j < N; j++) {
            zn[j] = two_sum(zn[j], zl[j] + it->jump[j], &zl[j]);
            finite &= isfinite(zn[j]) != 0;
        }
    if (!finite) {
        size_t j = 0;
        while (isfinite(zn[j])) j++;
        dth__seterr(it, "the new vertex overflows (component %zu)", j);
        return DTH_EDOMAIN;
    }
    if (nc || it->auton) { /* wp carried bit for bit */
        zn[N - 1] = it->st.z[N - 1];
        zl[N - 1] = it->st.zlo[N - 1];
    }
    double rho = it->st.rho, rholo = it->st.rholo;
    if (it->opt.finish) {
        /* the new vertex's offset measured from this step's midpoint (it->grad is there); the
         * exact first step of a midpoint start has its midpoint exact in double; a regularizer's
         * segment (no midpoint of the step equations) has it evaluated at the vertex */
        int rc;
        if (replaced) {
            rc = dth__rho_direct(it, zn, zl, &rho, &rholo);
        } else if (!it->rev) {
            rc = rho_from_mid_n(it, nc, it->zb, NULL, it->st.pending_exact ? NULL : it->zblo, it->grad, NULL, zn, zl, &rho,
                                &rholo);
        } else {
            /* from the last chord step's point y, with its gradient and Hessian (coarse_n) */
            size_t nd = N - 1;
            double *dy = it->ydel, *gl = it->ygl;
            for (size_t j = 0; j < nd; j++) dy[j] = it->zb[j] - it->yc[j];
            dy[nd] = 0;
            taylor_grad(it, nd, dy, it->zblo, gl, it->ybar);
            rc = rho_from_mid_n(it, nc, it->yc, dy, it->zblo, it->grad, gl, zn, zl, &rho, &rholo);
        }
        if (rc) {
            dth__seterr(it, "model evaluation failed at the new vertex: %s", dth_strerror(rc));
            return rc;
        }
    }
    if (it->opt.finish && !replaced && it->level != 0) {
        /* measured from the midpoint, rho is H(z_(k+1)) - H(zbar), and a level-shifted step's root has
         * H(zbar) = -s (the DTH step's: 0): the carried offset H(z_(k+1)) is rho - s */
        double e, r = two_sum(rho, -it->level, &e);
        rho = two_sum(r, rholo + e, &rholo);
    }
    it->st.rho = rho;
    it->st.rholo = rholo;
    for (size_t j = 0; j < N; j++) {
        it->st.z[j] = zn[j];
        it->st.zlo[j] = zl[j];
        it->st.zbar[j] = it->zb[j];
    }
    /* the predictor's history: the last three offsets and steps (the oldest slot is the next scratch) */
    it->dnew = it->st.dprev3;
    it->st.dprev3 = it->st.dprev2;
    it->st.dprev2 = it->st.dprev;
    it->st.dprev = d;
    it->st.lam3 = it->st.lam2;
    it->st.lam2 = it->st.lam;
    it->st.nhist = it->st.nhist < 3 ? it->st.nhist + 1 : 3;
    it->st.fact_valid = !replaced; /* an ordinary step: a tangent map exists */
    it->st.lam = lam;
    it->st.have_prev = 1;
    it->st.have_mid = 1;
    it->st.steps++;
    return DTH_OK;
}

/* The kernels of each path: the generic one (nc = 0) and the small path's n = 1, 2, 3. */
#define KERNELS(NC, OPS)                                                                                        \
    static int newton_##NC(dth__dth *it, double lam0, const double *d0, int max_iter, dth__solution *sol)      \
    {                                                                                                           \
        return newton_n(it, NC, OPS, lam0, d0, max_iter, sol);                                                 \
    }                                                                                                           \
    static int commit_##NC(dth__dth *it, double lam, int replaced) { return commit_n(it, NC, lam, replaced); }
KERNELS(0, &step_ops)
KERNELS(1, &small_ops_1)
KERNELS(2, &small_ops_2)
KERNELS(3, &small_ops_3)
static const dth__kernels kernels[4] = {{newton_0, commit_0}, {newton_1, commit_1}, {newton_2, commit_2},
                                        {newton_3, commit_3}};

void dth__newton_setup(dth__dth *it)
{
    it->ls = dth__linsolve_find(it->kind)->ops; /* linsolve.c's table (kind is resolved: never AUTO) */
    it->kern = &kernels[it->nsmall];
}

int dth__tangent(dth__dth *it, double *M) { return it->ls->tangent(it, M); }

void dth__set_solution(dth__dth *it, const double *d, double lam)
{
    unknowns_n(it, 0, d, lam);
    midpoint_n(it, 0, it->x, it->zb, NULL);
}

void dth__set_solution_lo(dth__dth *it, const double *dlo)
{
    int m = it->m;
    for (int a = 0; a < m - 1; a++) it->xlo[a] = dlo[it->act[a]];
    it->xlo[m - 1] = it->auton ? 2 * dlo[it->n] : 0;
}

/* The dense paths' tangent map: the bordered Jacobian at the converged midpoint, refactored. */
int dth__dense_tangent(dth__dth *it, double *M)
{
    size_t n = it->n, N = it->N;
    int m = it->m;
    double lam = it->st.lam;
    /* the Jacobian at the converged midpoint (not at Newton's last iterate), factored afresh */
    int rc = dth_model_eval(it->model, it->st.zbar, DTH_EVAL_H | DTH_EVAL_GRAD | DTH_EVAL_HESS, &it->Hphys, it->grad,
                            it->hess);
    if (rc) return rc;
    unknowns_n(it, 0, it->st.dprev, lam);
    assemble(it, it->x, it->st.zbar, it->Hphys, it->F, it->A);
    rc = dth__lu_factor(it->kind, m, it->A, it->piv);
    if (rc) return rc;
    /* B = dF/dz_k (m x N, column-major): rows of -(lambda/2) J H_zz, last row grad H. */
    double *B = it->B;
    for (size_t l = 0; l < N; l++) {
        for (int a = 0; a < m - 1; a++) B[(size_t)a + l * (size_t)m] = 0.5 * lam * dth__dudz(n, it->hess, (size_t)it->act[a], l);
        B[(size_t)(m - 1) + l * (size_t)m] = l == N - 1 ? -1.0 : -it->grad[l];
    }
    /* X = -A^{-1} B: derivatives of the unknowns (d, lambda) with respect to z_k (B holds -B). */
    rc = dth__lu_solve(it->kind, m, it->A, it->piv, (int)N, B);
    if (rc) return rc;
    /* M = I + 2 dd/dz_k; autonomous: d_t = lambda/2, d_wp = 0. */
    memset(M, 0, N * N * sizeof *M);
    for (size_t i = 0; i < N; i++) M[i * N + i] = 1.0;
    for (int a = 0; a < m - 1; a++) {
        size_t j = (size_t)it->act[a];
        for (size_t l = 0; l < N; l++) M[j * N + l] += 2 * B[(size_t)a + l * (size_t)m];
    }
    if (it->auton)
        for (size_t l = 0; l < N; l++) M[n * N + l] += B[(size_t)(m - 1) + l * (size_t)m];
    return DTH_OK;
}
