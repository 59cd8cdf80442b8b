/* SPDX-License-Identifier: MIT */
/*
 * Regularizer "symkick" (paper, section 7): a time-reversible, energy-exact crossing of psi = 0.
 * Where the ordinary step from z_a fails or crosses psi = 0, the step is replaced by a kicked
 * segment (dth_kicked_segment: midpoint on H = 0, chord = (lambda J grad H + mu n)(zbar), n the
 * (q, p)-gradient of H with quadratic invariants projected out) whose length l solves
 *     2 l = |l_-(z_a)| + |l_+(z_b)|,
 * l_-(z_a): the cubic-model root (Lemma g_taylor) at z_a against the direction of travel (the
 * step that encodes the incoming one), l_+(z_b): the root at z_b = z_a + 2 d along it. The
 * condition and the segment are symmetric under reversal ((z_b, -l, -mu) has the same midpoint
 * and the same equation), so a backward run retraces the crossing; the kick is what lets the
 * vertex offset H ~ psi l^2/8 change sign while the midpoint stays on H = 0.
 */
#include <math.h>
#include <string.h>
#include "dth/regularize.h"
#include "reg_common.h"

typedef struct symkick {
    const dth_model *model;
    size_t n;
    double *ks, *work, *zb, *zc, *zm, *g;
    double max_ratio, margin;
} symkick;

static const dth_param_spec params[] = {
    {"max_ratio", "4", "refuse a crossing step further than this factor from the incoming root (> 1)"},
    {"margin", "1.5", "ordinary steps must keep |psi/psi'| >= margin |lambda| at both ends (> 0)"},
};

static int create(const dth_reg_args *a, void **self)
{
    size_t n = dth_model_dof(a->model), N = 2 * n + 2;
    size_t nks = dth_kicked_segment_work_size(a->model), nw = dth_model_work_size(a->model);
    symkick *r = dth_calloc(a->alloc, 1, sizeof *r);
    if (!r) return DTH_ENOMEM;
    *self = r;
    double mr = 4;
    for (size_t i = 0; i < a->nkv; i++)
        if (!strcmp(a->kv[i].key, "max_ratio") && (dth_parse_double(a->kv[i].value, &mr) || !(mr > 1))) {
            if (a->err && a->errlen) {
                size_t k = 0;
                const char *msg = "parameter 'max_ratio' must be a number > 1";
                for (; msg[k] && k + 1 < a->errlen; k++) a->err[k] = msg[k];
                a->err[k] = '\0';
            }
            return DTH_EINVAL;
        }
    r->ks = dth_calloc(a->alloc, nks + nw + 4 * N, sizeof(double));
    if (!r->ks) return DTH_ENOMEM;
    r->model = a->model;
    r->n = n;
    r->max_ratio = mr;
    r->margin = 1.5;
    for (size_t i = 0; i < a->nkv; i++)
        if (!strcmp(a->kv[i].key, "margin") && (dth_parse_double(a->kv[i].value, &r->margin) || !(r->margin > 0))) {
            if (a->err && a->errlen) {
                size_t k = 0;
                const char *msg = "parameter 'margin' must be a number > 0";
                for (; msg[k] && k + 1 < a->errlen; k++) a->err[k] = msg[k];
                a->err[k] = '\0';
            }
            return DTH_EINVAL;
        }
    r->work = r->ks + nks;
    r->zb = r->work + nw;
    r->g = r->zb + N;
    r->zc = r->g + N;
    r->zm = r->zc + N;
    return DTH_OK;
}

static void destroy(void *self, const dth_allocator *alloc)
{
    symkick *r = self;
    if (!r) return;
    dth_free(alloc, r->ks);
    dth_free(alloc, r);
}

/* |cubic root| at z on `side` (0 if none): the step the vertex's offset encodes there. */
static int root_at(symkick *r, const double *z, double side, double *l)
{
    double H, psi, dpsi;
    int rc = dth__reg_vertex(r->model, z, &H, &psi, &dpsi, r->work);
    if (rc) return rc;
    *l = fabs(dth_cubic_root(H, psi, dpsi, side));
    return DTH_OK;
}

/*
 * A chain of k kicked segments of the same length l from z_a (offsets in d, k * N), ending at
 * r->zb. *f = psi at the midpoint of the middle segment; *lb = root at the end on the side of travel.
 */
static int chain(symkick *r, const dth_reg_event *ev, int k, double l, double *d, double *mu,
                 double *f, double *lb, double *res, int *iters)
{
    size_t N = ev->N;
    const double *z = ev->z, *zlo = ev->zlo;
    for (int s = 0; s < k; s++) {
        double *ds = d + (size_t)s * N;
        int it;
        int rc = dth_kicked_segment(r->model, z, zlo, ev->dir * l, ds, &mu[s], res, &it, r->ks);
        *iters += it;
        if (rc) return rc;
        if (s == k / 2) {
            for (size_t j = 0; j < N; j++) r->zm[j] = z[j] + (ds[j] + (zlo ? zlo[j] : 0));
            rc = dth_model_psi(r->model, r->zm, f, NULL, r->work);
            if (rc) return rc;
        }
        double *zn = (s % 2) ? r->zc : r->zb;
        for (size_t j = 0; j < N; j++) zn[j] = z[j] + (2 * ds[j] + (zlo ? zlo[j] : 0));
        z = zn;
        zlo = NULL;
    }
    if (z != r->zb) memcpy(r->zb, z, N * sizeof *z);
    int rc = root_at(r, r->zb, ev->dir, lb);
    if (rc) return rc;
    return DTH_OK;
}

/* Solve psi(middle midpoint) = 0 over l for a chain of k segments (secant); d holds the chain. */
static int solve_chain(symkick *r, const dth_reg_event *ev, int k, double l0, double *d, double *l_out,
                       double *lb, double *res, int *iters)
{
    size_t n = r->n, N = ev->N;
    double mu[DTH_REG_MAX_SEG] = {0};
    for (int s = 0; s < k; s++) {
        double *ds = d + (size_t)s * N;
        memset(ds, 0, N * sizeof *ds);
        for (size_t i = 0; i < n; i++) {
            ds[i] = 0.5 * ev->dir * l0 * r->g[n + 1 + i];
            ds[n + 1 + i] = -0.5 * ev->dir * l0 * r->g[i];
        }
    }
    double f0, l1, f1, lmin = l0 / r->max_ratio, lmax = l0 * r->max_ratio;
    int rc = chain(r, ev, k, l0, d, mu, &f0, lb, res, iters);
    if (rc) return rc;
    l1 = l0 * (f0 * ev->psi_sign > 0 ? 1.05 : 0.95); /* psi_mid falls toward 0 as l grows */
    for (int it = 0;; it++) {
        if (it == 60 || !(l1 > lmin && l1 < lmax)) return DTH_EREFUSED;
        rc = chain(r, ev, k, l1, d, mu, &f1, lb, res, iters);
        if (rc) return rc;
        if (f1 == 0 || l1 == l0) break;
        double slope = (f1 - f0) / (l1 - l0);
        if (!(slope != 0) || !isfinite(slope)) return DTH_EREFUSED;
        double l2 = l1 - f1 / slope;
        l0 = l1;
        f0 = f1;
        double step = fabs(l2 - l1);
        l1 = l2;
        if (step <= 1e-12 * l1) break; /* psi at the midpoint is at its round-off */
    }
    rc = chain(r, ev, k, l1, d, mu, &f1, lb, res, iters); /* the chain at the converged length */
    if (rc) return rc;
    *l_out = l1;
    return DTH_OK;
}

static int apply(void *self, const dth_reg_event *ev, dth_reg_action *act)
{
    symkick *r = self;
    double la, Ha, psi, dpsi;
    int rc = dth__reg_vertex(r->model, ev->z, &Ha, &psi, &dpsi, r->work);
    if (rc) return rc;
    la = fabs(dth_cubic_root(Ha, psi, dpsi, -ev->dir));
    if (!(la > 0)) return DTH_EREFUSED;
    double Hk;
    rc = dth_model_eval(r->model, ev->z, DTH_EVAL_H | DTH_EVAL_GRAD, &Hk, r->g, NULL);
    if (rc) return rc;
    /* distance to psi = 0 along the flow, linearly: the span of the chain is twice that */
    if (!(dpsi * ev->dir * psi < 0)) {
        /* psi = 0 is not ahead (the screen rejected a step leaving it): keep the ordinary step */
        if (ev->plain_status == DTH_OK && ev->plain_psi_sign == ev->psi_sign) return DTH_OK;
        return DTH_EREFUSED;
    }
    double span = -2 * psi / (dpsi * ev->dir);
    /* Chains of 1 and 3 equal kicked segments centred on psi = 0 (an odd number of kicks flips the
     * sign of the vertex offset); take the one whose length is nearest (in ratio) to the mean of
     * the steps its two ends encode. Every quantity compared is a function of the pair of end
     * vertices, so the choice is the same when the chain is traversed backward. */
    static const int ks[3] = {1, 3, 5};
    double best = INFINITY, lbest = 0;
    int kbest = 0, iters = 0;
    double res = 0;
    for (int c = 0; c < 3; c++) {
        double l, lb, rs = 0;
        rc = solve_chain(r, ev, ks[c], span / ks[c], act->d, &l, &lb, &rs, &iters);
        if (rc < 0) return rc;
        if (rc || !(lb > 0)) continue;
        double psi_e;
        rc = dth_model_psi(r->model, r->zb, &psi_e, NULL, r->work);
        if (rc) return rc;
        int sb = psi_e > 0 ? 1 : (psi_e < 0 ? -1 : 0);
        if (sb == ev->psi_sign) continue;
        double mean = 0.5 * (la + lb), ratio = l > mean ? l / mean : mean / l;
        if (ratio < best * (1 - 1e-9)) {
            best = ratio;
            lbest = l;
            kbest = ks[c];
            res = rs;
        }
    }
    act->iters = iters;
    if (!kbest) return DTH_EREFUSED;
    if (kbest != 5) { /* act->d holds the last solved chain (k = 5): re-solve the chosen one */
        double l, lb;
        rc = solve_chain(r, ev, kbest, lbest, act->d, &l, &lb, &res, &act->iters);
        if (rc) return rc > 0 ? DTH_EREFUSED : rc;
        lbest = l;
    }
    act->what = DTH_REG_REPLACE;
    act->nseg = kbest;
    for (int s = 0; s < kbest; s++) act->lambda[s] = ev->dir * lbest;
    act->residual = res;
    return DTH_OK;
}

/* Ordinary steps keep clear of psi = 0: both ends at least `margin` steps away (linear estimate
 * |psi / psi'|), so a crossing chain starts far enough back to span about 2 margin steps. */
static int admit(void *self, const double *za, const double *zb, double lambda)
{
    symkick *r = self;
    const double *zs[2] = {za, zb};
    for (int e = 0; e < 2; e++) {
        double psi, dpsi;
        int rc = dth_model_psi(r->model, zs[e], &psi, &dpsi, r->work);
        if (rc) return -1;
        if (fabs(psi) < r->margin * fabs(lambda) * fabs(dpsi)) return 0;
    }
    return 1;
}

const dth_regularizer_type dth_reg_symkick = {
    .name = "symkick",
    .doc = "symmetric kicked segment: energy-exact, time-reversible, keeps quadratic invariants; not symplectic",
    .params = params,
    .n_params = sizeof params / sizeof params[0],
    .create = create,
    .destroy = destroy,
    .apply = apply,
    .admit = admit,
};
