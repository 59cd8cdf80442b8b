/* SPDX-License-Identifier: MIT */
/*
 * MEGNO and a Lyapunov estimate (chaos.h) from the tangent map of the DTH step (paper, Theorem
 * "DTH Equations": the step is a symplectic map, and its tangent map is the variational map of the
 * discrete flow).
 */
#include <math.h>
#include <string.h>
#include "dth/chaos.h"

struct dth_megno {
    const dth_allocator *alloc;
    size_t n, N;
    long k;          /* the integrator's step count at the last update */
    double t0;       /* time of the first vertex */
    double *delta;   /* the deviation vector, |delta| = 1 */
    double *M;       /* N x N tangent map (row-major) */
    double *w;       /* N */
    double lnsum;    /* sum of g_k = ln |delta_(k+1)| after renormalizing delta_k to 1 */
    double isum;     /* sum of s_k g_k */
    double ysum;     /* sum of Y(t_(k+1)) |lambda_k| */
    double y;        /* Y at the last step */
    double span;     /* |t - t0| followed */
    double t_stop;   /* where a step without a tangent map ended the indicators (NaN: none) */
    long steps;
};

int dth_megno_new(const dth_integrator *it, const double *delta0, const dth_allocator *alloc, dth_megno **out)
{
    if (!it || !out) return DTH_EINVAL;
    size_t n = dth_model_dof(dth_integrator_model(it)), N = 2 * n + 2;
    dth_megno *g = dth_calloc(alloc, 1, sizeof *g);
    if (!g) return DTH_ENOMEM;
    g->alloc = alloc;
    g->n = n;
    g->N = N;
    g->delta = dth_calloc(alloc, 2 * N + N * N, sizeof(double));
    if (!g->delta) {
        dth_megno_free(g);
        return DTH_ENOMEM;
    }
    g->w = g->delta + N;
    g->M = g->w + N;
    double s = 0;
    for (size_t i = 0; i < N; i++) {
        double v = delta0 ? delta0[i] : (i == n || i == N - 1) ? 0.0 : 1.0;
        if (!isfinite(v)) {
            dth_megno_free(g);
            return DTH_EINVAL;
        }
        g->delta[i] = v;
        s += v * v;
    }
    if (!(s > 0)) {
        dth_megno_free(g);
        return DTH_EINVAL;
    }
    s = sqrt(s);
    for (size_t i = 0; i < N; i++) g->delta[i] /= s;
    g->k = dth_integrator_steps(it);
    g->t0 = dth_integrator_vertex(it)[n];
    g->y = NAN;
    g->t_stop = NAN;
    *out = g;
    return DTH_OK;
}

int dth_megno_new_len(const dth_integrator *it, const double *delta0, size_t len, const dth_allocator *alloc,
                      dth_megno **out)
{
    if (!it) return DTH_EINVAL;
    size_t N = 2 * dth_model_dof(dth_integrator_model(it)) + 2;
    if (delta0 ? len != N : len != 0) return DTH_EINVAL;
    return dth_megno_new(it, delta0, alloc, out);
}

void dth_megno_free(dth_megno *g)
{
    if (!g) return;
    const dth_allocator *a = g->alloc;
    dth_free(a, g->delta);
    dth_free(a, g);
}

int dth_megno_update(dth_megno *g, dth_integrator *it)
{
    if (!g || !it) return DTH_EINVAL;
    long k = dth_integrator_steps(it);
    if (k == g->k) return DTH_OK;
    if (k != g->k + 1) return DTH_EINVAL;
    g->k = k;
    if (!isnan(g->t_stop)) return DTH_OK; /* ended at an earlier step */
    size_t n = g->n, N = g->N;
    double lam = dth_integrator_lambda(it), t1 = dth_integrator_vertex(it)[n];
    int rc = dth_integrator_tangent(it, g->M);
    if (rc == DTH_EINVAL) {
        /* a regularizer's step (a step was taken, so that is the reason): no tangent map */
        g->t_stop = t1 - lam;
        return DTH_OK;
    }
    if (rc) return rc;
    double s2 = 0;
    for (size_t i = 0; i < N; i++) {
        double s = 0;
        for (size_t j = 0; j < N; j++) s += g->M[i * N + j] * g->delta[j];
        g->w[i] = s;
        s2 += s * s;
    }
    double norm = sqrt(s2);
    if (!(norm > 0) || !isfinite(norm)) return DTH_EDOMAIN;
    for (size_t i = 0; i < N; i++) g->delta[i] = g->w[i] / norm;
    double gk = log(norm), span = fabs(t1 - g->t0), sk = fabs(t1 - 0.5 * lam - g->t0);
    g->lnsum += gk;
    g->isum += sk * gk;
    g->y = span > 0 ? 2 * g->isum / span : 0;
    g->ysum += g->y * fabs(lam);
    g->span = span;
    g->steps++;
    return DTH_OK;
}

void dth_megno_get(const dth_megno *g, dth_megno_result *r)
{
    if (!r) return;
    memset(r, 0, sizeof *r);
    r->megno = r->y = r->lyapunov = r->t_stop = NAN;
    if (!g) return;
    if (g->span > 0) {
        r->megno = g->ysum / g->span;
        r->lyapunov = g->lnsum / g->span;
    }
    r->y = g->y;
    r->span = g->span;
    r->steps = g->steps;
    r->t_stop = g->t_stop;
}
