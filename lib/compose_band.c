/* SPDX-License-Identifier: MIT */
/*
 * The order-4 composition's start step and its psi = 0 crossings (issue 22 items 1 and 3; research r22,
 * sections 2.2 and 7): the start step, an implicit-midpoint composition of tau = h whose midpoints make
 * the levels; the band, compositions of prescribed-step midpoint substeps (symplectic, order 4, wp
 * untouched, quadratic invariants kept; not on the levels) entered where a crossing is less than two
 * composite steps ahead (or less than band_time) or where a composite step fails; its exit, where |psi|
 * rises again, by one symmetric projection of the vertex back onto the reference vertex energy and a
 * composite step on the level set of psi's sign there (the start's, or its mirror about href).
 */
#include <math.h>
#include <string.h>
#include "compose.h"
#include "dd.h"

/* Entry: the crossing less than X_IN composite steps ahead; exit: more than X_OUT predicted steps away
 * (4 and 6: 3-7x smaller errors through crossings than the research prototype's 2 and 3, for 1-3 % more
 * steps on the rotating pendulum and Kepler e = 0.9; docs/theory.md, "Order 4 through crossings"). */
#define X_IN 4.0
#define X_OUT 6.0
/* Halvings of the band's step where a band step fails. */
#define MAX_HALVINGS 30

int dth__comp_psi(dth__comp *c, const double *z, double *psi, double *dpsi)
{
    int rc = dth_model_psi(c->model, z, psi, dpsi, c->pw);
    if (rc) dth__comp_seterr(c, "model evaluation failed in psi at the vertex: %s", dth_strerror(rc));
    return rc;
}

static int sign_of(double x) { return x > 0 ? 1 : x < 0 ? -1 : 0; }

/*
 * A composition of prescribed-step midpoint substeps lambda_i = gamma_i tau from the core's vertex, in
 * double-double (levels: each midpoint's -H(zbar_i) into the levels); the new offsets, midpoints and
 * substeps into nd1, nmids, nlam, the core placed at the new vertex. The core is untouched on failure.
 */
static int prescribed(dth__comp *c, double tau, int levels, dth_step_info *info)
{
    dth__dth *k = c->core;
    size_t N = c->N;
    double *y = c->y, *ylo = c->ylo, *d = c->d, sum = 0;
    memcpy(y, k->st.z, N * sizeof *y);
    memcpy(ylo, k->st.zlo, N * sizeof *y);
    int reuse = c->st.last_band && c->st.nh >= 1;
    for (int i = 0; i < c->m; i++) {
        double lam = c->tab->g[i] * tau, H, *zb = c->nmids + (size_t)i * N;
        int it = 0, rc;
        if (reuse && c->sg.lam1[i] == lam) { /* the band's last step had this substep: its offset */
            memcpy(d, c->hs.d1 + (size_t)i * N, N * sizeof *d);
        } else {
            if ((rc = dth_model_eval(c->model, y, DTH_EVAL_GRAD, &H, c->g, NULL)) != DTH_OK) return rc;
            dth__flow_z(c->n, c->g, c->u);
            for (size_t j = 0; j < N; j++) d[j] = 0.5 * lam * c->u[j];
        }
        rc = dth__mid_solve(c->mid, y, ylo, lam, d, zb, c->opt.max_iter, &it);
        info->iters += it;
        if (!rc && levels) {
            rc = dth_model_eval(c->model, zb, DTH_EVAL_H, &H, NULL, NULL);
            c->sg.levels[i] = -(zb[N - 1] + H);
        }
        if (rc) {
            dth__comp_seterr(c, "midpoint substep %d of %d (lambda = %.6g): %s", i + 1, c->m, lam, dth_strerror(rc));
            return rc;
        }
        for (size_t j = 0; j < N; j++) y[j] = two_sum(y[j], 2 * d[j] + ylo[j], &ylo[j]);
        memcpy(c->nd1 + (size_t)i * N, d, N * sizeof *d);
        c->nlam[i] = lam;
        sum += lam;
    }
    int rc = dth__comp_place(c, y, ylo);
    if (rc) return rc;
    info->lambda = sum;
    info->residual = 0;
    return DTH_OK;
}

int dth__comp_start_band(dth__comp *c)
{
    double psi, dpsi;
    int rc = dth__comp_psi(c, c->core->st.z, &psi, &dpsi);
    if (rc) return rc;
    if (psi != 0 && !(fabs(psi) < X_IN * fabs(c->st.h) * fabs(dpsi))) return DTH_OK;
    /* psi = 0 less than two steps away: a band first, the levels at its exit */
    c->st.pending = 0;
    c->st.band = 1;
    c->st.tau_b = c->st.tau_b0 = c->st.h;
    return DTH_OK;
}

int dth__comp_start_step(dth__comp *c, dth_step_info *info)
{
    if (c->band_on) {
        double psi, dpsi;
        int rc = dth__comp_psi(c, c->core->st.z, &psi, &dpsi);
        if (rc) return rc;
        c->st.sign0 = psi < 0 ? -1 : 1;
    }
    int rc = prescribed(c, c->st.h, 1, info);
    if (rc) return rc;
    c->st.sigma = 1;
    c->st.have_levels = 1;
    c->st.pending = 0;
    c->st.band = 0;
    c->st.tau_b = c->st.tau_b0 = 0;
    c->st.psi_est = NAN;
    dth__comp_commit_hist(c, 1);
    info->branch = DTH_BRANCH_EXACT;
    return DTH_OK;
}

/* psi' at vertex k, reached by a step of tau: psi'' from psi' at the vertex before where it was
 * evaluated there too (else NaN). */
static void record_psi(dth__comp *c, long k, double dpsi, double tau)
{
    if (c->st.kx == k) return;
    c->st.d2psi = c->st.kx == k - 1 && tau != 0 ? (dpsi - c->st.dpsi_x) / tau : NAN;
    c->st.dpsi_x = dpsi;
    c->st.kx = k;
}

/* psi reaches 0 within |x| ahead in time: on its parabola where psi'' is known (psi falling fast but
 * never crossing, as it does leaving a Kepler pericentre, is no crossing), else on its line. */
static int zero_ahead(const dth__comp *c, double psi, double dpsi, double x)
{
    double d2 = c->st.d2psi, sg = sign_of(psi);
    x = c->st.dir * fabs(x);
    if (!isfinite(d2)) return psi * dpsi * c->st.dir < 0 && fabs(psi) < fabs(x * dpsi);
    double lo = sg * (psi + dpsi * x + 0.5 * d2 * x * x), xv = d2 != 0 ? -dpsi / d2 : -x;
    if (xv / x > 0 && xv / x < 1) lo = fmin(lo, sg * (psi + 0.5 * dpsi * xv)); /* its turning point */
    return lo <= 0;
}

int dth__comp_health(dth__comp *c, const double *z0, double rho1, int *undo)
{
    (void)z0;
    *undo = 0;
    double l1 = c->nlam[0], est = 8 * rho1 / (l1 * l1), prev = c->st.psi_est, tau = 0;
    c->st.psi_est = est;
    /* psi read off the first substep (its offset is psi lambda^2 / 8 to leading order): where it moves by
     * less than 1/16 a step, the crossing is more than 16 steps away (no evaluation of psi); the plain
     * finish carries no vertex offset to read it from */
    int gate = c->opt.band_time == 0 && c->opt.finish != DTH_FINISH_PLAIN && isfinite(prev);
    if (gate && fabs(est - prev) <= fabs(est) / 16) return DTH_OK;
    double psi, dpsi;
    int rc = dth__comp_psi(c, c->core->st.z, &psi, &dpsi);
    if (rc) return rc;
    if (psi * (c->st.sigma * c->st.sign0) <= 0) { /* psi changed sign within the step */
        *undo = 1;
        return DTH_OK;
    }
    for (int i = 0; i < c->m; i++) tau += c->nlam[i];
    record_psi(c, c->st.steps + 1, dpsi, tau);
    int approaching = psi * dpsi * c->st.dir < 0;
    if (zero_ahead(c, psi, dpsi, X_IN * tau) || (approaching && fabs(psi) < c->opt.band_time * fabs(dpsi))) {
        c->st.band = 1;
        c->st.tau_b = c->st.tau_b0 = tau;
    }
    return DTH_OK;
}

/* The composite step the level set of psi's sign would take at a vertex on H = href (the exit's
 * predictor): sqrt(8 rho_1 / (psi gamma_1^2)), signed; NaN without levels or where rho_1 / psi <= 0. */
static double tau_pred_at(const dth__comp *c, double psi)
{
    if (!c->st.have_levels || psi == 0) return NAN;
    double rho1 = c->st.href + dth__comp_level(c, 0, (psi > 0 ? 1 : -1) * c->st.sign0);
    if (!(rho1 / psi > 0)) return NAN;
    return c->st.dir * sqrt(8 * rho1 / psi) / fabs(c->tab->g[0]);
}

/*
 * The band's exit at a vertex with psi, psi' there: where |psi| rises and the next crossing is more
 * than X_OUT predicted steps (and 1.5 band_time) away, project the vertex onto H = href and take a
 * composite step on the level set of psi's sign (without levels: the start step there). 1 if it was
 * taken; 0 (the state as it was) if the vertex does not pass or the step fails.
 */
static int try_exit(dth__comp *c, double psi, double dpsi, dth_step_info *info)
{
    dth__dth *k = c->core;
    int sg = sign_of(psi), sigma = sg * c->st.sign0;
    double D = dpsi != 0 ? fabs(psi / dpsi) : INFINITY, tau_pred = c->st.have_levels ? tau_pred_at(c, psi) : c->st.h;
    if (!sg || isnan(tau_pred) || zero_ahead(c, psi, dpsi, X_OUT * tau_pred)) return 0;
    if (!(D > X_OUT * fabs(tau_pred) && D > 1.5 * c->opt.band_time)) return 0;
    dth__comp_state st = c->st;
    dth_step_info in = *info;
    memcpy(c->y, k->st.z, c->N * sizeof *c->y);
    memcpy(c->ylo, k->st.zlo, c->N * sizeof *c->y);
    int rc = dth__mid_project(c->mid, c->y, c->ylo, c->st.href);
    if (!rc) rc = dth__comp_place(c, c->y, c->ylo);
    if (!rc && !c->st.have_levels) {
        c->st.sign0 = sg;
        rc = dth__comp_start_step(c, info);
    } else if (!rc) {
        rc = dth__comp_composite(c, sigma, tau_pred, info);
        if (!rc) {
            c->st.nh = 0;
            dth__comp_commit_hist(c, 0);
            c->st.sigma = sigma;
            c->st.band = 0;
            c->st.tau_b = c->st.tau_b0 = 0;
            c->st.psi_est = NAN;
        }
    }
    if (rc) { /* stay in the band */
        dth__comp_rewind(c, 0);
        c->st = st;
        *info = in;
        return 0;
    }
    c->st.fact_valid = 0; /* the projection has no tangent map, and no reverse (run.h: nonreversible) */
    info->flags |= DTH_STEP_REGULARIZED | DTH_STEP_RESET;
    return 1;
}

int dth__comp_band_step(dth__comp *c, int exit, dth_step_info *info)
{
    double psi, dpsi, psi1, dpsi1;
    int rc = dth__comp_psi(c, c->core->st.z, &psi, &dpsi);
    if (rc) return rc;
    if (exit && try_exit(c, psi, dpsi, info)) return DTH_OK;
    /* the band's step follows the composite step law where it is defined (away from psi = 0, e.g. a
     * band through a Kepler pericentre): halved while above twice the predicted step, doubled back
     * towards its entry step while below a quarter of it; constant otherwise (each band step is the
     * symplectic map of its tau_b, the switches are decisions like the entry and the exit) */
    double tp = fabs(tau_pred_at(c, psi)), tb = fabs(c->st.tau_b);
    for (int i = 0; i < MAX_HALVINGS && tb > 2 * tp; i++) c->st.tau_b *= 0.5, tb *= 0.5;
    while (2 * tb <= fabs(c->st.tau_b0) && 4 * tb < tp) c->st.tau_b *= 2, tb *= 2;
    int iters = info->iters;
    for (int halvings = 0;; halvings++) {
        info->iters = iters;
        rc = prescribed(c, c->st.tau_b, 0, info);
        if (!rc) break;
        iters = info->iters;
        if (rc < 0 || halvings >= MAX_HALVINGS) return rc;
        c->st.tau_b *= 0.5; /* for the rest of the band */
        c->st.tau_b0 = c->st.tau_b;
    }
    dth__comp_commit_hist(c, 1);
    c->st.band_steps++;
    info->branch = DTH_BRANCH_REG;
    info->flags |= DTH_STEP_REGULARIZED;
    rc = dth__comp_psi(c, c->core->st.z, &psi1, &dpsi1);
    if (rc) return rc;
    record_psi(c, c->st.steps, dpsi1, c->st.lam);
    if (sign_of(psi1) != sign_of(psi)) info->flags |= DTH_STEP_CROSSING;
    return DTH_OK;
}
