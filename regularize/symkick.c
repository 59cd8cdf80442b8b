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
#include <float.h>
#include <math.h>
#include <stdio.h>
#include <string.h>
#include "dth/regularize.h"
#include "reg_common.h"

typedef struct symkick {
    const dth_model *model;
    size_t n;
    double *ks, *work, *zb, *zc, *zm, *g;
    double max_ratio, margin;
    int centre;      /* condition: psi = 0 at the chain's middle midpoint (else the mirror condition) */
    double psi_mid;  /* scratch: psi there */
} symkick;

static const dth_param_spec params[] = {
    {"max_ratio", "4", "refuse a crossing step further than this factor from the incoming root (> 1)"},
    {"condition", "mirror", "chain length from: mirror (|psi/psi'| l equal at both ends) or centre (psi = 0 at the middle)"},
    {"margin", "1", "ordinary steps keep |psi/psi'| >= margin x (the step each end encodes) (> 0)"},
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
    r->margin = 1;
    for (size_t i = 0; i < a->nkv; i++)
        if (!strcmp(a->kv[i].key, "condition")) {
            if (!strcmp(a->kv[i].value, "centre")) r->centre = 1;
            else if (strcmp(a->kv[i].value, "mirror")) {
                if (a->err && a->errlen) snprintf(a->err, a->errlen, "parameter 'condition' must be mirror or centre (got '%s')", a->kv[i].value);
                return DTH_EINVAL;
            }
        }
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

/*
 * A chain of k kicked segments of the same length l from z_a (offsets in d, k * N), ending at
 * r->zb. *f = psi at the midpoint of the middle segment; *lb = root at the end on the side of travel.
 */
static int chain(symkick *r, const dth_reg_event *ev, int k, double l, double *d, double *mu,
                 double *f, double *lb, double *res, int *iters, double la, double dela)
{
    size_t N = ev->N;
    const double *z = ev->z, *zlo = ev->zlo;
    for (int s = 0; s < k; s++) {
        double *ds = d + (size_t)s * N;
        int it;
        int rc = dth_kicked_segment(r->model, z, zlo, ev->dir * l, ds, &mu[s], res, &it, r->ks);
        *iters += it;
        if (rc) return rc;
        if (r->centre && s == k / 2) {
            for (size_t j = 0; j < N; j++) r->zm[j] = z[j] + (ds[j] + (zlo ? zlo[j] : 0));
            rc = dth_model_psi(r->model, r->zm, &r->psi_mid, NULL, r->work);
            if (rc) return rc;
        }
        double *zn = (s % 2) ? r->zc : r->zb;
        for (size_t j = 0; j < N; j++) zn[j] = z[j] + (2 * ds[j] + (zlo ? zlo[j] : 0));
        z = zn;
        zlo = NULL;
    }
    if (z != r->zb) memcpy(r->zb, z, N * sizeof *z);
    double H, psi, dpsi;
    int rc = dth__reg_vertex(r->model, r->zb, &H, &psi, &dpsi, r->work);
    if (rc) return rc;
    *lb = fabs(dth_cubic_root(H, psi, dpsi, ev->dir));
    if (!(*lb > 0) || dpsi == 0) return DTH_EREFUSED;
    /* mirror condition: the end is as many encoded steps from psi = 0 as the start */
    *f = fabs(psi / dpsi) * la - dela * *lb;
    if (psi * ev->psi_sign > 0) *f = -fabs(*f) - dela * la; /* not across yet: push l up */
    if (r->centre) *f = -r->psi_mid * ev->psi_sign; /* grows with l through psi = 0 */
    return DTH_OK;
}

/* Solve psi(middle midpoint) = 0 over l for a chain of k segments (secant); d holds the chain. */
static int solve_chain(symkick *r, const dth_reg_event *ev, int k, double l0, double *d, double *l_out,
                       double *lb, double *res, int *iters, double la, double dela)
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
    int rc = chain(r, ev, k, l0, d, mu, &f0, lb, res, iters, la, dela);
    if (rc) return rc;
    /* round-off of f: psi's terms (centre) or the products |psi/psi'| l (mirror) */
    /* (the kicked segments are solved to ~1e-11 relative where Newton stalls at round-off) */
    double fscale = 1e-11 * (r->centre ? fabs(f0) + 1e-3 : dela * la);
    l1 = l0 * (f0 < 0 ? 1.05 : 0.95); /* f grows with l */
    for (int it = 0;; it++) {
        if (it == 60 || !(l1 > lmin && l1 < lmax)) return DTH_EREFUSED;
        rc = chain(r, ev, k, l1, d, mu, &f1, lb, res, iters, la, dela);
        if (rc) return rc;
        if (f1 == 0 || l1 == l0 || fabs(f1) <= fscale) break; /* f at its round-off */
        double slope = (f1 - f0) / (l1 - l0);
        if (!(slope != 0) || !isfinite(slope)) return DTH_EREFUSED;
        double l2 = l1 - f1 / slope;
        l0 = l1;
        f0 = f1;
        double step = fabs(l2 - l1);
        l1 = l2;
        if (step <= 1e-12 * l1) break; /* psi at the midpoint is at its round-off */
    }
    rc = chain(r, ev, k, l1, d, mu, &f1, lb, res, iters, la, dela); /* the chain at the converged length */
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
    /* Three equal kicked segments (an odd number of kicks flips the sign of the vertex offset;
     * three let the chain span the 2 to 4 steps that the screen leaves before psi = 0). Their
     * length solves the mirror condition |psi/psi'|(z_b) la = |psi/psi'|(z_a) lb, a function of
     * the pair of ends, so the chain is the same traversed backward, and the screen (admit)
     * reads the same number at both ends. */
    double dela = fabs(psi / dpsi), l = 0, lb, res = 0;
    int iters = 0, kbest = 0;
    /* three segments; if the mirror condition has no crossing solution with three, five then one
     * (first that works: symmetric only when the two ends agree on the same fallback) */
    static const int ks[3] = {3, 5, 1};
    for (int c = 0; c < 3 && !kbest; c++) {
        rc = solve_chain(r, ev, ks[c], span / ks[c], act->d, &l, &lb, &res, &iters, la, dela);
        if (rc < 0) return rc;
        if (rc) continue;
        double psi_e;
        rc = dth_model_psi(r->model, r->zb, &psi_e, NULL, r->work);
        if (rc) return rc;
        if (psi_e * ev->psi_sign < 0) kbest = ks[c];
    }
    act->iters = iters;
    if (!kbest) return DTH_EREFUSED;
    double lbest = l;
    act->what = DTH_REG_REPLACE;
    act->nseg = kbest;
    for (int s = 0; s < kbest; s++) act->lambda[s] = ev->dir * lbest;
    act->residual = res;
    return DTH_OK;
}

/* Ordinary steps keep clear of psi = 0: at each end e, |psi/psi'|(e) >= margin l_e, with l_e the
 * step e's offset encodes toward the other end (cubic model). A function of the pair {za, zb};
 * a crossing chain's two ends read the same by its mirror condition. */
static int admit(void *self, const double *za, const double *zb, double lambda)
{
    symkick *r = self;
    const double *zs[2] = {za, zb};
    for (int e = 0; e < 2; e++) {
        double H, psi, dpsi;
        int rc = dth__reg_vertex(r->model, zs[e], &H, &psi, &dpsi, r->work);
        if (rc) return -1;
        double side = (e == 0) == (lambda > 0) ? 1.0 : -1.0;
        double l = fabs(dth_cubic_root(H, psi, dpsi, side));
        if (!(l > 0)) l = fabs(lambda);
        if (fabs(psi) < r->margin * l * fabs(dpsi)) return 0;
    }
    return 1;
}

const dth_regularizer_type dth_reg_symkick = {
    .name = "symkick",
    .doc = "chains of kicked segments across psi = 0, each its own reverse: energy-exact, keeps quadratic invariants; not symplectic, the step size drifts over many crossings",
    .params = params,
    .n_params = sizeof params / sizeof params[0],
    .create = create,
    .destroy = destroy,
    .apply = apply,
    .admit = admit,
};
