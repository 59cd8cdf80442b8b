/* SPDX-License-Identifier: MIT */
/*
 * n-dimensional harmonic oscillator H = sum_i p_i^2/(2 m_i) + m_i w_i^2 q_i^2/2. psi > 0
 * everywhere (region I of the paper, section 5); exact solution and per-mode energies.
 */
#include <math.h>
#include <stdio.h>
#include "dth/models.h"

typedef struct harmonic {
    size_t n;
    double *mass, *omega;
    char (*names)[24];
} harmonic;

static const dth_param_spec params[] = {
    {"n", NULL, "degrees of freedom (default: from the lists or the number of q values)"},
    {"mass", "1", "masses m_i: one value, or n comma-separated values (> 0)"},
    {"omega", "1", "angular frequencies w_i: one value, or n values (> 0)"},
};

static void destroy(void *self, const dth_allocator *alloc)
{
    harmonic *h = self;
    if (!h) return;
    dth_free(alloc, h->mass);
    dth_free(alloc, h->omega);
    dth_free(alloc, h->names);
    dth_free(alloc, h);
}

enum { MAXN = 4096 };

static int create(const dth_model_args *a, void **self, dth_model_info *info)
{
    double nn = 0;
    int rc = dth_args_double(a, "n", 0, &nn);
    if (rc) return rc;
    if (nn < 0 || nn != floor(nn) || nn > MAXN) return dth_args_error(a, "parameter 'n' must be an integer in 1..%d", MAXN);
    harmonic *h = dth_calloc(a->alloc, 1, sizeof *h);
    if (!h) return DTH_ENOMEM;
    *self = h;
    double *ml = dth_calloc(a->alloc, MAXN, sizeof *ml), *wl = dth_calloc(a->alloc, MAXN, sizeof *wl);
    size_t nm = 0, nw = 0;
    if (!ml || !wl) rc = DTH_ENOMEM;
    if (!rc) rc = dth_args_list(a, "mass", ml, MAXN, &nm);
    if (!rc) rc = dth_args_list(a, "omega", wl, MAXN, &nw);
    size_t n = (size_t)nn;
    /* n: explicit, else the caller's number of q values, else the lists' length */
    if (!rc && !n) n = a->n_hint ? a->n_hint : nm > 1 ? nm : nw > 1 ? nw : 1;
    if (!rc && nm > 1 && nm != n) rc = dth_args_error(a, "parameter 'mass' has %zu values, expected 1 or %zu", nm, n);
    if (!rc && nw > 1 && nw != n) rc = dth_args_error(a, "parameter 'omega' has %zu values, expected 1 or %zu", nw, n);
    if (!rc) {
        h->n = n;
        h->mass = dth_calloc(a->alloc, n, sizeof *h->mass);
        h->omega = dth_calloc(a->alloc, n, sizeof *h->omega);
        h->names = dth_calloc(a->alloc, n, sizeof *h->names);
        if (!h->mass || !h->omega || !h->names) rc = DTH_ENOMEM;
    }
    for (size_t i = 0; !rc && i < n; i++) {
        h->mass[i] = nm == 0 ? 1.0 : nm == 1 ? ml[0] : ml[i];
        h->omega[i] = nw == 0 ? 1.0 : nw == 1 ? wl[0] : wl[i];
        if (!(h->mass[i] > 0)) rc = dth_args_error(a, "parameter 'mass': value %zu must be > 0", i + 1);
        else if (!(h->omega[i] > 0)) rc = dth_args_error(a, "parameter 'omega': value %zu must be > 0", i + 1);
        snprintf(h->names[i], sizeof h->names[i], "E%zu", i + 1);
    }
    dth_free(a->alloc, ml);
    dth_free(a->alloc, wl);
    if (rc) return rc; /* dth_model_new destroys *self */
    *info = (dth_model_info){.n = n, .autonomous = 1, .separable = 1, .hess_kind = DTH_HESS_DENSE};
    return DTH_OK;
}

static int eval(const void *self, const double *y, unsigned what, double *H, double *g, double *hs)
{
    const harmonic *h = self;
    size_t n = h->n, d = 2 * n + 1;
    const double *q = y, *p = y + n + 1;
    if (what & DTH_EVAL_H) {
        double s = 0;
        for (size_t i = 0; i < n; i++) {
            double k = h->mass[i] * h->omega[i] * h->omega[i];
            s += 0.5 * p[i] * p[i] / h->mass[i] + 0.5 * k * q[i] * q[i];
        }
        *H = s;
    }
    if (what & DTH_EVAL_GRAD) {
        g[n] = 0;
        for (size_t i = 0; i < n; i++) {
            g[i] = h->mass[i] * h->omega[i] * h->omega[i] * q[i];
            g[n + 1 + i] = p[i] / h->mass[i];
        }
    }
    if (what & DTH_EVAL_HESS) {
        for (size_t i = 0; i < d * d; i++) hs[i] = 0;
        for (size_t i = 0; i < n; i++) {
            hs[i * d + i] = h->mass[i] * h->omega[i] * h->omega[i];
            hs[(n + 1 + i) * d + (n + 1 + i)] = 1 / h->mass[i];
        }
    }
    return 0;
}

static int third(const void *self, const double *y, const double *u, double *d3)
{
    *d3 = 0; /* quadratic Hamiltonian */
    return 0;
}

static size_t n_invariants(const void *self) { return ((const harmonic *)self)->n; }
static const char *invariant_name(const void *self, size_t i) { return ((const harmonic *)self)->names[i]; }

static int invariants(const void *self, const double *y, double *out)
{
    const harmonic *h = self;
    size_t n = h->n;
    for (size_t i = 0; i < n; i++) {
        double q = y[i], p = y[n + 1 + i];
        out[i] = 0.5 * p * p / h->mass[i] + 0.5 * h->mass[i] * h->omega[i] * h->omega[i] * q * q;
    }
    return 0;
}

static int exact(const void *self, const double *y0, double t, double *y)
{
    const harmonic *h = self;
    size_t n = h->n;
    double tau = t - y0[n];
    for (size_t i = 0; i < n; i++) {
        double w = h->omega[i], mw = h->mass[i] * w, c = cos(w * tau), s = sin(w * tau);
        double q = y0[i], p = y0[n + 1 + i];
        y[i] = q * c + p / mw * s;
        y[n + 1 + i] = p * c - mw * q * s;
    }
    y[n] = t;
    return 0;
}

/* H(y1) - H(y0) term by term as (a - b)(a + b): no cancellation of the energies' size. */
static int hdiff(const void *self, const double *y1, const double *y0, double *dH)
{
    const harmonic *h = self;
    size_t n = h->n;
    double s = 0;
    for (size_t i = 0; i < n; i++) {
        double k = h->mass[i] * h->omega[i] * h->omega[i];
        double dq = y1[i] - y0[i], sq = y1[i] + y0[i], dp = y1[n + 1 + i] - y0[n + 1 + i], sp = y1[n + 1 + i] + y0[n + 1 + i];
        s += 0.5 * dp * sp / h->mass[i] + 0.5 * k * dq * sq;
    }
    *dH = s;
    return 0;
}

const dth_model_type dth_model_harmonic = {
DTH_MODEL_TYPE_HEAD,
    .name = "harmonic",
    .doc = "harmonic oscillator H = sum p_i^2/(2 m_i) + m_i omega_i^2 q_i^2/2 (n degrees of freedom)",
    .params = params,
    .n_params = sizeof params / sizeof params[0],
    .create = create,
    .destroy = destroy,
    .eval = eval,
    .hdiff = hdiff,
    .third = third,
    .n_invariants = n_invariants,
    .invariant_name = invariant_name,
    .invariants = invariants,
    .exact = exact,
};
