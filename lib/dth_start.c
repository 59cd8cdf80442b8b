/* SPDX-License-Identifier: MIT */
/*
 * The DTH stepper's start modes (paper, Theorem "DTH Equations": the first vertex and the offset
 * that encodes the first step): the midpoint start (the initial state is the first midpoint, the
 * first step exactly h), the vertex start (a secant on the vertex offset), setting a vertex, and
 * reversing the direction of travel.
 */
#include <float.h>
#include <math.h>
#include <stdio.h>
#include <string.h>
#include "dth_kernels.h"

/* The vertex offset rho = H(z) evaluated directly (a start, or after a regularizer's step), over y
 * at the high part (rho_from_mid_n says why). */
int dth__rho_direct(dth__dth *it, const double *z, const double *zlo, double *rho, double *rholo)
{
    size_t N = it->N;
    double Hp;
    if (it->rev) { /* the vertex point rho_from_mid_n reads (and keeps) */
        coarsen_y(it->n, z, it->vc);
        it->vc[N - 1] = z[N - 1];
        memcpy(it->vcsrc, z, N * sizeof *it->vc);
    }
    int rc = dth_model_eval(it->model, it->rev ? it->vc : z, DTH_EVAL_H, &Hp, NULL, NULL);
    if (rc) return rc;
    *rho = two_sum(z[N - 1], zlo[N - 1] + Hp, rholo);
    return DTH_OK;
}

static int rho_direct(dth__dth *it) { return dth__rho_direct(it, it->st.z, it->st.zlo, &it->st.rho, &it->st.rholo); }

static void reset_history(dth__dth *it)
{
    it->st.nhist = 0;
    it->st.have_prev = 0;
    it->st.have_mid = 0;
    it->st.fact_valid = 0;
    it->st.pending_exact = 0;
    it->st.steps = 0;
    dth__policy_reset(&it->pol);
}

/*
 * Vertex start: the vertex offset rho = H(z_0) whose first DTH step is exactly h. The offset
 * encodes the step (Lemma g_taylor: rho = psi h^2/8 + psi' h^3/24 + O(h^4)), and the Taylor term
 * alone misses it at large steps (harmonic omega h = 1.9: a first step of 3.2 h). A secant on rho
 * from the cubic model's value, each iterate an ordinary step solve from (y, wp = rho - H_phys(y)),
 * not committed, until lambda = h to a few ulps. Hp = H_phys(y). On failure the message names h.
 */
static int vertex_offset(dth__dth *it, const double *y, double Hp, double h, double *rho_out)
{
    size_t N = it->N;
    double psi, dpsi;
    int rc = dth_model_psi(it->model, y, &psi, &dpsi, it->work);
    if (rc) {
        dth__seterr(it, "model evaluation failed at the initial state");
        return rc;
    }
    double rho = psi * h * h / 8 + dpsi * h * h * h / 24, rp = 0, fp = 0;
    if (!(rho != 0) || !isfinite(rho)) rho = psi * h * h / 8;
    /* the step limit is for steps, not this solve */
    int ok = 0, max_iter = it->opt.max_iter < 30 ? 30 : it->opt.max_iter;
    double best = INFINITY, rbest = rho;
    for (int k = 0; k < 16; k++) {
        for (size_t j = 0; j < N - 1; j++) it->st.z[j] = y[j];
        it->st.z[N - 1] = rho - Hp;
        memset(it->st.zlo, 0, N * sizeof *it->st.zlo);
        reset_history(it);
        it->st.dir = h > 0 ? 1.0 : -1.0;
        double Hv, lam0;
        if ((it->opt.finish && (rc = rho_direct(it))) ||
            (rc = dth_model_eval(it->model, it->st.z, DTH_EVAL_H | DTH_EVAL_GRAD, &Hv, it->grad, NULL))) {
            dth__seterr(it, "model evaluation failed at the initial vertex");
            return rc;
        }
        lam0 = dth__cubic_predict(it->st.z[N - 1] + Hv, psi, dpsi, h);
        dth__flow_z(it->n, it->grad, it->u);
        for (size_t j = 0; j < N; j++) it->znewlo[j] = 0.5 * lam0 * it->u[j];
        dth__solution sol = {NAN, NAN, 0};
        rc = dth__newton(it, lam0, it->znewlo, max_iter, &sol);
        if (rc < 0) break;
        if (rc || !(sol.lambda * h > 0)) {
            rc = DTH_OK;
            break;
        }
        /* lambda is known to its conditioning only: keep the best iterate, stop at 8 ulps or where
         * the secant no longer moves rho (the noise floor) */
        double f = sol.lambda - h;
        if (fabs(f) < best) best = fabs(f), rbest = rho;
        if (fabs(f) <= 8 * DBL_EPSILON * fabs(h)) break;
        double rn;
        if (k == 0 || f == fp) rn = rho * (h / sol.lambda) * (h / sol.lambda); /* rho ~ lambda^2 */
        else rn = rho - f * (rho - rp) / (f - fp);
        if (!isfinite(rn) || fabs(rn - rho) <= 2 * DBL_EPSILON * fabs(rho)) break;
        rp = rho, fp = f, rho = rn;
    }
    if (rc < 0) return rc;
    rho = rbest;
    ok = best <= 1e-10 * fabs(h);
    if (!ok) {
        dth__seterr(it, "no vertex offset gives a first step of h = %.17g from this state (the step equations have no "
                   "root of that size here): a smaller [integrator] h, a midpoint start, or an explicit wp",
               h);
        return DTH_ENOROOT;
    }
    *rho_out = rho;
    return DTH_OK;
}

/*
 * The reversible finish's exact first step of a midpoint start: the offset d = (h/2) u(zbar_0) in
 * double-double (dhi + dlo, N entries each), with u = J grad H read at the coarse point of zbar_0
 * and its Taylor term (coarse_n), the products exact, as the chord steps' rows have them: the step
 * back from the first vertex then solves the very equations this step satisfies. Leaves it->yc,
 * it->ydel, it->grad, it->hess at that point and it->zblo zero (the midpoint is zbar_0, a double).
 */
int dth__exact_offset_rev(dth__dth *it, const double *zbar, double h, double *dhi, double *dlo)
{
    size_t n = it->n, N = it->N, d = it->d;
    memcpy(it->zb, zbar, N * sizeof *zbar);
    memset(it->zblo, 0, N * sizeof *it->zblo);
    coarse_n(it, 0, it->zb, it->ydel);
    double H;
    int rc = it->meval(it->mself, it->yc, DTH_EVAL_H | DTH_EVAL_GRAD | DTH_EVAL_HESS, &H, it->grad, it->hess);
    if (rc) return rc > 0 ? DTH_EDOMAIN : DTH_EMODEL;
    double *gl = it->ygl, *gll = it->ybar, *u = it->u, hl = 0.5 * h;
    taylor_grad(it, d, it->ydel, it->zblo, gl, gll);
    dth__flow_z(n, it->grad, u);
    for (size_t j = 0; j < N; j++) {
        double ulh = j_of_gl(n, d, j, gl), ull = j_of_gl(n, d, j, gll);
        if (it->auton && j == N - 1) ulh = ull = 0; /* wp stays */
        double p = hl * u[j], q = hl * ulh, e;
        double s = two_sum(p, q, &e);
        dhi[j] = two_sum(s, (prod_err(hl, u[j], p) + prod_err(hl, ulh, q) + hl * ull) + e, &dlo[j]);
    }
    return DTH_OK;
}

int dth__dth_start(void *state, const double *q0, const double *p0, double t0)
{
    dth__dth *it = state;
    if (!q0 || !p0 || !isfinite(t0)) return DTH_EINVAL;
    size_t n = it->n, N = it->N;
    for (size_t i = 0; i < n; i++)
        if (!isfinite(q0[i]) || !isfinite(p0[i])) {
            dth__seterr(it, "initial value %zu is not finite", i);
            return DTH_EINVAL;
        }
    double *y = it->ybar, H;
    double h = it->st.h;
    if (!(fabs(h) > 2 * DBL_EPSILON * fabs(t0))) {
        dth__seterr(it, "the time t0 = %.17g does not advance by steps of h = %.3g (t + h == t)", t0, h);
        return DTH_EINVAL;
    }
    memcpy(y, q0, n * sizeof *y);
    y[n] = t0;
    memcpy(y + n + 1, p0, n * sizeof *y);
    if (it->opt.start == DTH_START_MIDPOINT) {
        int rc = dth_model_eval(it->model, y, DTH_EVAL_H | DTH_EVAL_GRAD, &H, it->grad, NULL);
        if (rc) {
            dth__seterr(it, "model evaluation failed at the initial state");
            return rc;
        }
        memcpy(it->zb, y, (N - 1) * sizeof *y);
        it->zb[N - 1] = -H;
        dth__flow_z(n, it->grad, it->u);
        /* z_0 = zbar_0 - (h/2) u, kept in double-double so the first step returns to zbar_0 (the
         * reversible finish: its offset in double-double, exact_offset_rev) */
        double *dlo = it->znewlo, *dhi = it->znew;
        if (it->rev) {
            rc = dth__exact_offset_rev(it, it->zb, h, dhi, dlo);
            if (rc) {
                dth__seterr(it, "model evaluation failed at the initial state");
                return rc;
            }
        } else {
            for (size_t j = 0; j < N; j++) dhi[j] = 0.5 * h * it->u[j], dlo[j] = 0;
        }
        for (size_t j = 0; j < N; j++)
            if (!isfinite(it->zb[j] - dhi[j]) || !isfinite(it->zb[j] + dhi[j])) {
                dth__seterr(it, "the first vertex overflows (component %zu): h is too large", j);
                return DTH_EDOMAIN;
            }
        reset_history(it);
        memcpy(it->st.zbar, it->zb, N * sizeof *it->zb);
        for (size_t j = 0; j < N; j++) {
            double e, s = two_sum(it->st.zbar[j], -dhi[j], &e);
            it->st.dprev[j] = dhi[j];
            it->st.z[j] = two_sum(s, e - dlo[j], &it->st.zlo[j]);
        }
        if (it->rev) {
            /* from the coarse point, as every later step's offset (exact_offset_rev left it there) */
            rc = rho_from_mid_n(it, 0, it->yc, it->ydel, NULL, it->grad, it->ygl, it->st.z, it->st.zlo, &it->st.rho,
                                &it->st.rholo);
            if (rc) {
                dth__seterr(it, "model evaluation failed at the first vertex");
                return rc;
            }
        } else if (it->opt.finish) {
            /* H(zbar_0) = wp + H_phys = 0 exactly (wp = -H_phys) */
            rc = rho_from_mid(it, it->st.zbar, NULL, it->grad, it->st.z, it->st.zlo, &it->st.rho, &it->st.rholo);
            if (rc) {
                dth__seterr(it, "model evaluation failed at the first vertex");
                return rc;
            }
        }
        it->st.lam = 0;
        it->st.lam_hint = h;
        it->st.dir = h > 0 ? 1.0 : -1.0;
        it->st.pending_exact = 1;
        return DTH_OK;
    }
    double wp;
    if (it->opt.has_wp) {
        wp = it->opt.wp;
    } else {
        int rc = dth_model_eval(it->model, y, DTH_EVAL_H, &H, NULL, NULL);
        if (rc) {
            dth__seterr(it, "model evaluation failed at the initial state");
            return rc;
        }
        double rho;
        rc = vertex_offset(it, y, H, h, &rho);
        if (rc) return rc;
        wp = rho - H;
    }
    for (size_t j = 0; j < N - 1; j++) it->st.z[j] = y[j];
    it->st.z[N - 1] = wp;
    return dth__dth_set_vertex(it, it->st.z, h);
}

int dth__dth_set_vertex(void *s, const double *z, double lambda)
{
    dth__dth *it = s;
    if (!z || !isfinite(lambda) || lambda == 0) return DTH_EINVAL;
    for (size_t j = 0; j < it->N; j++)
        if (!isfinite(z[j])) return DTH_EINVAL;
    if (z != it->st.z) memcpy(it->st.z, z, it->N * sizeof *z);
    memset(it->st.zlo, 0, it->N * sizeof *it->st.zlo);
    if (it->opt.finish) {
        int rc = rho_direct(it);
        if (rc) {
            dth__seterr(it, "model evaluation failed at the vertex");
            return rc;
        }
    }
    reset_history(it);
    it->st.lam = 0;
    it->st.lam_hint = lambda;
    it->st.dir = lambda > 0 ? 1.0 : -1.0;
    return DTH_OK;
}

void dth__dth_reverse(void *s)
{
    dth__dth *it = s;
    /* The backward step from z_k has the midpoint of the last step: d -> -d, lambda -> -lambda. */
    for (size_t j = 0; j < it->N; j++) it->st.dprev[j] = -it->st.dprev[j];
    it->st.lam = -it->st.lam;
    it->st.lam_hint = -it->st.lam_hint;
    it->st.dir = -it->st.dir;
    it->st.h = -it->st.h;
    if (it->st.nhist > 1) it->st.nhist = 1; /* the offsets before the last one lie ahead now */
    if (it->st.pending_exact) {
        /* not stepped yet from a midpoint start: reversing means the exact step goes backward */
        it->st.pending_exact = 0;
        it->st.have_prev = 0;
        it->st.lam_hint = it->st.h; /* h is flipped already: the step to aim for goes the new way */
    }
}
