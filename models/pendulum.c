/* SPDX-License-Identifier: MIT */
/*
 * Pendulum H = p^2/2 - omega2 cos q: the paper's running example (section 2), with an exact
 * solution by Jacobi elliptic functions (GSL) for libration, rotation and the separatrix.
 */
#include <math.h>
#include <gsl/gsl_sf_ellint.h>
#include <gsl/gsl_sf_elljac.h>
#include <float.h>
#include "dth/models.h"

#define PI 3.14159265358979323846

typedef struct pendulum {
    double w2; /* omega^2 */
} pendulum;

static const dth_param_spec params[] = {
    {"omega2", "1", "squared small-oscillation frequency omega^2 = g/l (> 0)"},
};

static int create(const dth_model_args *a, void **self, dth_model_info *info)
{
    double w2;
    int rc = dth_args_double(a, "omega2", 1.0, &w2);
    if (rc) return rc;
    if (!(w2 > 0)) return dth_args_error(a, "parameter 'omega2' must be > 0 (got %g)", w2);
    if (a->n_hint > 1) return dth_args_error(a, "the pendulum has one degree of freedom (got %zu q values)", a->n_hint);
    pendulum *p = dth_calloc(a->alloc, 1, sizeof *p);
    if (!p) return DTH_ENOMEM;
    p->w2 = w2;
    *self = p;
    *info = (dth_model_info){.n = 1, .autonomous = 1, .separable = 1, .hess_kind = DTH_HESS_DENSE};
    return DTH_OK;
}

static void destroy(void *self, const dth_allocator *alloc) { dth_free(alloc, self); }

/* y = (q, t, p) */
static int eval(const void *self, const double *y, unsigned what, double *H, double *g, double *h)
{
    const pendulum *m = self;
    double q = y[0], p = y[2], s = sin(q), c = cos(q);
    if (what & DTH_EVAL_H) *H = 0.5 * p * p - m->w2 * c;
    if (what & DTH_EVAL_GRAD) {
        g[0] = m->w2 * s;
        g[1] = 0;
        g[2] = p;
    }
    if (what & DTH_EVAL_HESS) {
        for (int i = 0; i < 9; i++) h[i] = 0;
        h[0] = m->w2 * c;
        h[8] = 1;
    }
    return 0;
}

/* H(y1) - H(y0) = (p1 - p0)(p1 + p0)/2 + 2 omega2 sin((q1 + q0)/2) sin((q1 - q0)/2). */
static int hdiff(const void *self, const double *y1, const double *y0, double *dH)
{
    const pendulum *m = self;
    double q1 = y1[0], q0 = y0[0], p1 = y1[2], p0 = y0[2];
    *dH = 0.5 * (p1 - p0) * (p1 + p0) + 2 * m->w2 * sin(0.5 * (q1 + q0)) * sin(0.5 * (q1 - q0));
    return 0;
}

static int third(const void *self, const double *y, const double *u, double *d3)
{
    const pendulum *m = self;
    *d3 = -m->w2 * sin(y[0]) * u[0] * u[0] * u[0];
    return 0;
}

/* u = F(phi, k) for any phi, by F(phi + j pi) = F(phi) + 2 j K. */
static double ellint_F_any(double phi, double k, double K)
{
    double j = nearbyint(phi / PI);
    return gsl_sf_ellint_F(phi - j * PI, k, GSL_PREC_DOUBLE) + 2 * j * K;
}

/* am(u | m) for any u, by am(u + 2 j K) = am(u) + j pi. */
static double jacobi_am(double u, double mm, double K, double *dn)
{
    double j = nearbyint(u / (2 * K)), sn, cn;
    gsl_sf_elljac_e(u - 2 * j * K, mm, &sn, &cn, dn);
    return atan2(sn, cn) + j * PI;
}

static int exact(const void *self, const double *y0, double t, double *y)
{
    const pendulum *m = self;
    double w = sqrt(m->w2), tau = w * (t - y0[1]);
    double q0 = y0[0], P0 = y0[2] / w, E = 0.5 * P0 * P0 - cos(q0);
    double q, P;
    if (fabs(E - 1) <= 4 * DBL_EPSILON) {
        /* separatrix: sin(q/2) = tanh(v), P = 2 sech(v) along the direction of motion */
        double s = P0 >= 0 ? 1.0 : -1.0, j = nearbyint(q0 / (2 * PI));
        double v = atanh(sin(0.5 * (q0 - 2 * j * PI))) + s * tau;
        q = 2 * asin(tanh(v)) + 2 * j * PI;
        P = 2 * s / cosh(v);
    } else if (E < 1) {
        /* libration: sin(q/2) = k sn(u), P = 2 k cn(u), k^2 = (1 + E)/2 */
        /* k^2 = (1 + E)/2 = sin^2(q0/2) + P0^2/4, without the cancellation of 1 + E (1 - cos q0
         * rounds to 0 below |q0| ~ 1e-8, which made every small libration a rest point) */
        double sh = sin(0.5 * q0), mm = sh * sh + 0.25 * P0 * P0, k = sqrt(mm), j = nearbyint(q0 / (2 * PI));
        if (!(mm > 0)) { /* at rest at the bottom */
            y[0] = q0; y[1] = t; y[2] = y0[2];
            return 0;
        }
        double K = gsl_sf_ellint_Kcomp(k, GSL_PREC_DOUBLE);
        double s0 = fmax(-1.0, fmin(1.0, sin(0.5 * (q0 - 2 * j * PI)) / k));
        double c0 = P0 / (2 * k);
        double u = ellint_F_any(atan2(s0, c0), k, K) + tau;
        double sn, cn, dn;
        gsl_sf_elljac_e(u, mm, &sn, &cn, &dn);
        q = 2 * asin(fmax(-1.0, fmin(1.0, k * sn))) + 2 * j * PI;
        P = 2 * k * cn;
    } else {
        /* rotation: q/2 = am(u), P = +-(2/k) dn(u), k^2 = 2/(1 + E), u = u0 +- tau/k */
        double mm = 2 / (1 + E), k = sqrt(mm), s = P0 >= 0 ? 1.0 : -1.0;
        double K = gsl_sf_ellint_Kcomp(k, GSL_PREC_DOUBLE), dn;
        double u = ellint_F_any(0.5 * q0, k, K) + s * tau / k;
        q = 2 * jacobi_am(u, mm, K, &dn);
        P = s * 2 / k * dn;
    }
    y[0] = q;
    y[1] = t;
    y[2] = w * P;
    return 0;
}

const dth_model_type dth_model_pendulum = {
DTH_MODEL_TYPE_HEAD,
    .name = "pendulum",
    .doc = "pendulum H = p^2/2 - omega2 cos q (one degree of freedom)",
    .params = params,
    .n_params = sizeof params / sizeof params[0],
    .create = create,
    .destroy = destroy,
    .eval = eval,
    .third = third,
    .exact = exact,
    .hdiff = hdiff,
};
