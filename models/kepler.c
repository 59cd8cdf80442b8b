/* SPDX-License-Identifier: MIT */
/*
 * Kepler problem H = |p|^2/2 - mu/|q| in Cartesian coordinates (2 or 3 dimensions): the paper's
 * example of a model whose psi changes sign on bound orbits with e^2 > 5/8 (section 5).
 * Exact D^3 H for psi', angular momentum and Laplace-Runge-Lenz invariants, and the exact
 * elliptic solution by Kepler's equation with f and g functions.
 */
#include <float.h>
#include <math.h>
#include <stdio.h>
#include "dth/models.h"

#define PI 3.14159265358979323846

typedef struct kepler {
    size_t n; /* spatial dimension, 2 or 3 */
    double mu;
} kepler;

static const dth_param_spec params[] = {
    {"mu", "1", "gravitational parameter mu = G M (> 0)"},
    {"dim", NULL, "spatial dimension 2 or 3 (default: the number of q values, else 2)"},
};

static int create(const dth_model_args *a, void **self, dth_model_info *info)
{
    double mu, dim;
    int rc = dth_args_double(a, "mu", 1.0, &mu);
    if (rc) return rc;
    if (!(mu > 0)) return dth_args_error(a, "parameter 'mu' must be > 0 (got %g)", mu);
    rc = dth_args_double(a, "dim", 0.0, &dim);
    if (rc) return rc;
    size_t n;
    if (dth_args_get(a, "dim")) {
        if (dim != 2 && dim != 3) return dth_args_error(a, "parameter 'dim' must be 2 or 3 (got %g)", dim);
        n = (size_t)dim;
        if (a->n_hint && a->n_hint != n)
            return dth_args_error(a, "parameter 'dim' is %zu but %zu q values were given", n, a->n_hint);
    } else {
        n = a->n_hint ? a->n_hint : 2;
        if (n != 2 && n != 3)
            return dth_args_error(a, "kepler needs 2 or 3 q values (got %zu; parameter 'dim')", n);
    }
    kepler *k = dth_calloc(a->alloc, 1, sizeof *k);
    if (!k) return DTH_ENOMEM;
    k->n = n;
    k->mu = mu;
    *self = k;
    *info = (dth_model_info){.n = n, .autonomous = 1, .separable = 1, .hess_kind = DTH_HESS_DENSE};
    return DTH_OK;
}

static void destroy(void *self, const dth_allocator *alloc) { dth_free(alloc, self); }

static inline double dot(size_t n, const double *a, const double *b)
{
    double s = 0;
    for (size_t i = 0; i < n; i++) s += a[i] * b[i];
    return s;
}

/* The callbacks below are written once for a dimension n known at compile time (2 or 3), so that
 * their loops unroll: the step evaluates them several times per step. */
#define KI static inline __attribute__((always_inline))

/* y = (q, t, p); q = 0 is outside the domain. */
KI int eval_n(const kepler *k, const size_t n, const double *y, unsigned what, double *H, double *g, double *hs)
{
    size_t d = 2 * n + 1;
    const double *q = y, *p = y + n + 1;
    double r2 = dot(n, q, q);
    if (!(r2 > 0) || !isfinite(r2)) return 1;
    double r = sqrt(r2), mr3 = k->mu / (r2 * r);
    if (what & DTH_EVAL_H) *H = 0.5 * dot(n, p, p) - k->mu / r;
    if (what & DTH_EVAL_GRAD) {
        for (size_t i = 0; i < n; i++) {
            g[i] = mr3 * q[i];
            g[n + 1 + i] = p[i];
        }
        g[n] = 0;
    }
    if (what & DTH_EVAL_HESS) {
        /* V_ij = mu (delta_ij / r^3 - 3 q_i q_j / r^5); the p block is the identity */
        for (size_t i = 0; i < d * d; i++) hs[i] = 0;
        for (size_t i = 0; i < n; i++) {
            for (size_t j = 0; j <= i; j++) /* mirrored: exactly symmetric */
                hs[i * d + j] = hs[j * d + i] = -3 * mr3 * q[i] * q[j] / r2;
            hs[i * d + i] += mr3;
            hs[(n + 1 + i) * d + (n + 1 + i)] = 1;
        }
    }
    return 0;
}

static int eval(const void *self, const double *y, unsigned what, double *H, double *g, double *hs)
{
    const kepler *k = self;
    return k->n == 2 ? eval_n(k, 2, y, what, H, g, hs) : eval_n(k, 3, y, what, H, g, hs);
}

/* H(y1) - H(y0) = sum (p1 - p0)(p1 + p0)/2 + mu (r1 - r0)/(r1 r0), r1 - r0 = (q1 - q0).(q1 + q0)/(r1 + r0). */
KI int hdiff_n(const kepler *k, const size_t n, const double *y1, const double *y0, double *dH)
{
    double r1 = sqrt(dot(n, y1, y1)), r0 = sqrt(dot(n, y0, y0)), dd = 0, kin = 0;
    if (!(r1 > 0) || !(r0 > 0)) return 1;
    for (size_t i = 0; i < n; i++) {
        dd += (y1[i] - y0[i]) * (y1[i] + y0[i]);
        kin += (y1[n + 1 + i] - y0[n + 1 + i]) * (y1[n + 1 + i] + y0[n + 1 + i]);
    }
    *dH = 0.5 * kin + k->mu * (dd / (r1 + r0)) / (r1 * r0);
    return 0;
}

static int hdiff(const void *self, const double *y1, const double *y0, double *dH)
{
    const kepler *k = self;
    return k->n == 2 ? hdiff_n(k, 2, y1, y0, dH) : hdiff_n(k, 3, y1, y0, dH);
}

/* D^3 H[u,u,u] = mu (q.v) (15 (q.v)^2 / r^7 - 9 |v|^2 / r^5), v the q part of u. */
static int third(const void *self, const double *y, const double *u, double *d3)
{
    const kepler *k = self;
    size_t n = k->n;
    double r2 = dot(n, y, y);
    if (!(r2 > 0)) return 1;
    double r = sqrt(r2), qv = dot(n, y, u), vv = dot(n, u, u);
    *d3 = k->mu * qv * (15 * qv * qv / r2 - 9 * vv) / (r2 * r2 * r);
    return 0;
}

static size_t n_invariants(const void *self) { return ((const kepler *)self)->n == 2 ? 4 : 7; }

static const char *invariant_name(const void *self, size_t i)
{
    static const char *const names2[] = {"L", "Ax", "Ay", "omega"};
    static const char *const names3[] = {"Lx", "Ly", "Lz", "Ax", "Ay", "Az", "omega"};
    if (((const kepler *)self)->n == 2) return i < 4 ? names2[i] : NULL;
    return i < 7 ? names3[i] : NULL;
}

/* Angular momentum L = q x p and Laplace-Runge-Lenz vector A = p x L - mu q/|q|
 * = q (|p|^2 - mu/|q|) - p (q.p). omega is the argument of pericentre: in 2-D the angle of A;
 * in 3-D measured from the ascending node in the orbital plane, or for an equatorial orbit
 * (node undefined) the longitude of pericentre counted in the direction of motion. */
static int invariants(const void *self, const double *y, double *out)
{
    const kepler *k = self;
    size_t n = k->n;
    const double *q = y, *p = y + n + 1;
    double r2 = dot(n, q, q);
    if (!(r2 > 0)) return 1;
    double c = dot(n, p, p) - k->mu / sqrt(r2), qp = dot(n, q, p), A[3] = {0, 0, 0};
    for (size_t i = 0; i < n; i++) A[i] = c * q[i] - qp * p[i];
    if (n == 2) {
        out[0] = q[0] * p[1] - q[1] * p[0];
        out[1] = A[0];
        out[2] = A[1];
        out[3] = atan2(A[1], A[0]);
        return 0;
    }
    double L[3] = {q[1] * p[2] - q[2] * p[1], q[2] * p[0] - q[0] * p[2], q[0] * p[1] - q[1] * p[0]};
    double N[3] = {-L[1], L[0], 0}; /* node line z x L */
    double nn = hypot(N[0], N[1]), ll = sqrt(dot(3, L, L));
    double om;
    if (nn > 1e-12 * ll) {
        double NxA[3] = {N[1] * A[2] - N[2] * A[1], N[2] * A[0] - N[0] * A[2], N[0] * A[1] - N[1] * A[0]};
        om = atan2(dot(3, NxA, L) / ll, dot(3, N, A));
    } else {
        om = atan2(L[2] >= 0 ? A[1] : -A[1], A[0]);
    }
    for (int i = 0; i < 3; i++) {
        out[i] = L[i];
        out[3 + i] = A[i];
    }
    out[6] = om;
    return 0;
}

/* E - sin E, accurate for small E (series) where the difference cancels. */
static double e_minus_sin(double E)
{
    if (fabs(E) >= 0.5) return E - sin(E);
    double E2 = E * E, term = E * E2 / 6, s = term;
    for (int k = 4; k < 40; k += 2) {
        term *= -E2 / (double)(k * (k + 1));
        s += term;
        if (fabs(term) <= 1e-17 * fabs(s)) break;
    }
    return s;
}

/* Kepler residual E - e sin E - M, written (1 - e) E + e (E - sin E) - M so that it stays
 * accurate near pericentre of very eccentric orbits. */
static double kepler_residual(double E, double e, double M) { return (1 - e) * E + e * e_minus_sin(E) - M; }

/*
 * Solve E - e sin E = M for 0 <= e < 1, M in [0, pi]. The root lies in [M, min(pi, M + e)].
 * Starter: the real root of the cubic (1 - e) E + e E^3/6 = M (Kepler's equation to third
 * order, exact in the limit e -> 1, M -> 0) when it is small, else M + 0.85 e (Danby).
 * Halley's iteration, kept inside the shrinking bracket by bisection.
 */
static double solve_kepler(double e, double M)
{
    if (M == 0) return 0;
    double lo = M, hi = fmin(PI, M + e);
    double E;
    if (e > 0) {
        /* E^3 + P E - Q = 0 with P = 6 (1 - e)/e > 0, Q = 6 M / e: one real root (Cardano) */
        double P = 6 * (1 - e) / e, Q = 6 * M / e;
        double s = sqrt(Q * Q / 4 + P * P * P / 27);
        E = cbrt(Q / 2 + s) - P / (3 * cbrt(Q / 2 + s));
        if (!(E < 1)) E = M + 0.85 * e;
    } else {
        return M;
    }
    if (!(E > lo && E < hi)) E = 0.5 * (lo + hi);
    for (int it = 0; it < 100; it++) {
        double f = kepler_residual(E, e, M);
        if (f == 0) return E;
        if (f > 0) hi = E;
        else lo = E;
        double s = sin(E), f1 = 1 - e * cos(E), f2 = e * s;
        double dE = f / f1;
        dE = f / (f1 - 0.5 * dE * f2); /* Halley */
        double En = E - dE;
        if (!(En > lo && En < hi)) En = 0.5 * (lo + hi);
        if (fabs(En - E) <= 2 * DBL_EPSILON * fabs(En) || hi - lo <= 2 * DBL_EPSILON * fabs(E)) return En;
        E = En;
    }
    return E;
}

/*
 * Exact solution of a bound (elliptic) orbit: returns 1 if the energy of y0 is >= 0, or q0 = 0.
 * Orbital elements from y0: 1/a = 2/r0 - v0^2/mu, e cos E0 = 1 - r0/a, e sin E0 = (q0.p0)/sqrt(mu a),
 * mean anomaly M0 = E0 - e sin E0 and mean motion nm = sqrt(mu/a^3). Kepler's equation gives E at
 * time t, and with dE = E - E0 the f and g functions, in forms free of cancellation:
 *   f = 1 - (a/r0)(1 - cos dE),              g = ((r0/a) sin dE + e sin E0 (1 - cos dE)) / nm,
 *   r = r0 + a (e cos E0 (1 - cos dE) + e sin E0 sin dE),
 *   fd = -sqrt(mu a) sin dE / (r r0),        gd = 1 - (a/r)(1 - cos dE),
 * q = f q0 + g p0, p = fd q0 + gd p0. g carries no explicit t, so long times lose nothing to
 * cancellation; the mean anomaly is reduced modulo 2 pi.
 */
static int exact(const void *self, const double *y0, double t, double *y)
{
    const kepler *k = self;
    size_t n = k->n;
    const double *q0 = y0, *p0 = y0 + n + 1;
    double mu = k->mu, r0 = sqrt(dot(n, q0, q0)), v2 = dot(n, p0, p0), sig = dot(n, q0, p0);
    if (!(r0 > 0)) return 1;
    double alpha = 2 / r0 - v2 / mu; /* 1/a */
    if (!(alpha > 0)) return 1;
    double a = 1 / alpha, sma = sqrt(mu * a), nm = sqrt(mu * alpha * alpha * alpha);
    double ec0 = 1 - r0 * alpha, es0 = sig / sma, e = hypot(ec0, es0);
    if (!(e < 1)) return 1;
    double E0 = atan2(es0, ec0), M0 = E0 - es0;
    double M = remainder(M0 + nm * (t - y0[n]), 2 * PI);
    double E = M >= 0 ? solve_kepler(e, M) : -solve_kepler(e, -M);
    double dE = E - E0, s = sin(dE), sh = sin(0.5 * dE), hc = 2 * sh * sh;
    double f = 1 - a / r0 * hc, g = (r0 * alpha * s + es0 * hc) / nm;
    double r = r0 + a * (ec0 * hc + es0 * s);
    double fd = -sma * s / (r * r0), gd = 1 - a / r * hc;
    for (size_t i = 0; i < n; i++) {
        y[i] = f * q0[i] + g * p0[i];
        y[n + 1 + i] = fd * q0[i] + gd * p0[i];
    }
    y[n] = t;
    return 0;
}

/* The one singular point: the centre. */
static int domain(const void *self, const double *y, char *why, size_t len)
{
    const kepler *k = self;
    double r2 = dot(k->n, y, y);
    if (r2 > 0 && isfinite(r2)) return 0;
    if (k->n == 2) snprintf(why, len, "the centre r = 0 is singular (q1 = %g, q2 = %g)", y[0], y[1]);
    else snprintf(why, len, "the centre r = 0 is singular (q1 = %g, q2 = %g, q3 = %g)", y[0], y[1], y[2]);
    return 1;
}

const dth_model_type dth_model_kepler = {
DTH_MODEL_TYPE_HEAD,
    .name = "kepler",
    .doc = "Kepler problem H = |p|^2/2 - mu/|q| in 2 or 3 Cartesian dimensions",
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
    .domain = domain,
};
