/* SPDX-License-Identifier: MIT */
/*
 * Regularizer "reseed" (paper, section 7): the simple comparison scheme. Where the ordinary step
 * fails or crosses psi = 0, take a kicked segment (dth_kicked_segment) whose time step equals the
 * incoming one, then move the new vertex along the (q, p)-gradient of H until its offset is the
 * one the cubic model (Lemma g_taylor) gives for that same step on the new side of psi = 0.
 * Energy-exact (wp untouched, midpoint on H = 0); gives up time reversibility (it reads the
 * incoming step), symplecticity and exact quadratic invariants (the re-seed is not projected).
 */
#include <math.h>
#include <stdio.h>
#include <string.h>
#include "dth/regularize.h"
#include "reg_common.h"

typedef struct reseed {
    const dth_model *model;
    size_t n;
    double step; /* fixed crossing step, 0: the incoming one */
    double *ks, *work, *zb, *g;
} reseed;

static const dth_param_spec params[] = {
    {"step", "0", "time step of the crossing and the one re-seeded after it; 0: the incoming step"},
};

static int create(const dth_reg_args *a, void **self)
{
    size_t n = dth_model_dof(a->model), N = 2 * n + 2;
    size_t nks = dth_kicked_segment_work_size(a->model), nw = dth_model_work_size(a->model);
    reseed *r = dth_calloc(a->alloc, 1, sizeof *r);
    if (!r) return DTH_ENOMEM;
    *self = r;
    r->ks = dth_calloc(a->alloc, nks + nw + 2 * N, sizeof(double));
    if (!r->ks) return DTH_ENOMEM;
    r->model = a->model;
    for (size_t i = 0; i < a->nkv; i++)
        if (!strcmp(a->kv[i].key, "step") && (dth_parse_double(a->kv[i].value, &r->step) || r->step < 0)) {
            if (a->err && a->errlen) snprintf(a->err, a->errlen, "parameter 'step' must be a number >= 0 (got '%s')", a->kv[i].value);
            return DTH_EINVAL;
        }
    r->n = n;
    r->work = r->ks + nks;
    r->zb = r->work + nw;
    r->g = r->zb + N;
    return DTH_OK;
}

static void destroy(void *self, const dth_allocator *alloc)
{
    reseed *r = self;
    if (!r) return;
    dth_free(alloc, r->ks);
    dth_free(alloc, r);
}

static int apply(void *self, const dth_reg_event *ev, dth_reg_action *act)
{
    reseed *r = self;
    size_t n = r->n, N = ev->N;
    double L = r->step > 0 ? r->step : (fabs(ev->lam_in) > 0 ? fabs(ev->lam_in) : fabs(ev->plain_lambda));
    if (!(L > 0)) return DTH_EREFUSED;
    double lam = ev->dir * L, mu = 0, res, Hk;
    int iters, rc;
    /* seed: the straight flow segment */
    rc = dth_model_eval(r->model, ev->z, DTH_EVAL_H | DTH_EVAL_GRAD, &Hk, r->g, NULL);
    if (rc) return rc;
    for (size_t i = 0; i < n; i++) {
        act->d[i] = 0.5 * lam * r->g[n + 1 + i];
        act->d[n + 1 + i] = -0.5 * lam * r->g[i];
    }
    rc = dth_kicked_segment(r->model, ev->z, ev->zlo, lam, act->d, &mu, &res, &iters, r->ks);
    if (rc) return rc > 0 ? DTH_EREFUSED : rc;
    for (size_t j = 0; j < N; j++) r->zb[j] = ev->z[j] + (2 * act->d[j] + ev->zlo[j]);
    /* the offset that encodes the step L forward from zb, by the cubic model there */
    double Hb, psi, dpsi;
    rc = dth__reg_vertex(r->model, r->zb, &Hb, &psi, &dpsi, r->work);
    if (rc) return rc;
    double target = psi * L * L / 8 + dpsi * lam * lam * lam / 24;
    /* move along n = (dH/dq, dH/dp) at zb: H(zb + s n) = target (scalar Newton, n frozen) */
    double Hphys;
    rc = dth_model_eval(r->model, r->zb, DTH_EVAL_GRAD, &Hphys, r->g, NULL);
    if (rc) return rc;
    double nn = 0;
    for (size_t i = 0; i < n; i++) nn += r->g[i] * r->g[i] + r->g[n + 1 + i] * r->g[n + 1 + i];
    if (!(nn > 0)) return DTH_EREFUSED;
    double *y = r->work, s = (target - Hb) / nn; /* work is free again after the diagnosis */
    for (int k = 0; k < 20; k++) {
        memcpy(y, r->zb, (N - 1) * sizeof *y);
        for (size_t i = 0; i < n; i++) {
            y[i] += s * r->g[i];
            y[n + 1 + i] += s * r->g[n + 1 + i];
        }
        double Hy;
        rc = dth_model_eval(r->model, y, DTH_EVAL_H, &Hy, NULL, NULL);
        if (rc) return DTH_EREFUSED;
        double f = r->zb[N - 1] + Hy - target;
        double ds = -f / nn;
        s += ds;
        if (fabs(ds) <= 4e-16 * fabs(s) || f == 0) break;
    }
    for (size_t i = 0; i < n; i++) {
        act->fix[i] = s * r->g[i];
        act->fix[n + 1 + i] = s * r->g[n + 1 + i];
    }
    act->what = DTH_REG_REPLACE | DTH_REG_FIXUP;
    act->nseg = 1;
    act->lambda[0] = lam;
    act->residual = res;
    act->iters = iters;
    return DTH_OK;
}

const dth_regularizer_type dth_reg_reseed = {
    .name = "reseed",
    .params = params,
    .n_params = sizeof params / sizeof params[0],
    .doc = "kicked segment of the incoming step, then re-seed the vertex offset (energy-exact; not reversible, not symplectic)",
    .create = create,
    .destroy = destroy,
    .apply = apply,
};
