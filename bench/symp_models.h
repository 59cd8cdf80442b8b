/* SPDX-License-Identifier: MIT */
/* User models of bench_symplectic (not library models): the Fermi-Pasta-Ulam-Tsingou alpha-beta
 * chain with fixed ends and the Henon-Heiles system, written against <dth/dth.h> only, with the
 * optional third-derivative and exact-difference callbacks the DTH step and the regularizers use. */
#ifndef DTH_BENCH_SYMP_MODELS_H
#define DTH_BENCH_SYMP_MODELS_H

#include <math.h>
#include <string.h>
#include "dth/dth.h"

/* ---- FPUT chain: H = sum p_i^2/2 + sum_{b=0..N} phi(q_(b+1) - q_b), q_0 = q_(N+1) = 0,
 *      phi(x) = x^2/2 + alpha x^3/3 + beta x^4/4 ---- */

typedef struct fput {
    size_t N;
    double alpha, beta;
} fput;

static const dth_param_spec fput_params[] = {
    {"N", "16", "number of moving masses (fixed ends)"},
    {"alpha", "0", "cubic coefficient of the bond potential"},
    {"beta", "1", "quartic coefficient of the bond potential"},
};

static int fput_create(const dth_model_args *a, void **self, dth_model_info *info)
{
    double Nd, al, be;
    int rc = dth_args_double(a, "N", 16, &Nd);
    if (!rc) rc = dth_args_double(a, "alpha", 0, &al);
    if (!rc) rc = dth_args_double(a, "beta", 1, &be);
    if (rc) return rc;
    if (!(Nd >= 2 && Nd <= 4096 && Nd == floor(Nd))) return dth_args_error(a, "parameter 'N' must be an integer in [2, 4096]");
    fput *m = dth_calloc(a->alloc, 1, sizeof *m);
    if (!m) return DTH_ENOMEM;
    m->N = (size_t)Nd;
    m->alpha = al;
    m->beta = be;
    *self = m;
    *info = (dth_model_info){.n = m->N, .autonomous = 1, .separable = 1, .hess_kind = DTH_HESS_BANDED, .bandwidth = 2};
    return DTH_OK;
}

static void fput_destroy(void *self, const dth_allocator *alloc) { dth_free(alloc, self); }

/* bond b = 0..N: x_b = q_(b+1) - q_b with the fixed ends (q indices 1..N map to y[0..N-1]) */
static double fput_bond(const fput *m, const double *q, size_t b)
{
    double right = b < m->N ? q[b] : 0, left = b > 0 ? q[b - 1] : 0;
    return right - left;
}

static int fput_eval(const void *self, const double *y, unsigned what, double *H, double *g, double *h)
{
    const fput *m = self;
    size_t N = m->N, d = 2 * N + 1;
    const double *q = y, *p = y + N + 1;
    if (what & DTH_EVAL_H) {
        double s = 0;
        for (size_t i = 0; i < N; i++) s += 0.5 * p[i] * p[i];
        for (size_t b = 0; b <= N; b++) {
            double x = fput_bond(m, q, b), x2 = x * x;
            s += x2 * (0.5 + x * (m->alpha / 3 + x * m->beta / 4));
        }
        *H = s;
    }
    if (what & DTH_EVAL_GRAD) {
        memset(g, 0, d * sizeof *g);
        for (size_t b = 0; b <= N; b++) {
            double x = fput_bond(m, q, b), f = x * (1 + x * (m->alpha + x * m->beta));
            if (b < N) g[b] += f;      /* d x_b / d q_(b+1) = +1 */
            if (b > 0) g[b - 1] -= f;  /* d x_b / d q_b = -1 */
        }
        for (size_t i = 0; i < N; i++) g[N + 1 + i] = p[i];
    }
    if (what & DTH_EVAL_HESS) {
        memset(h, 0, d * d * sizeof *h);
        for (size_t b = 0; b <= N; b++) {
            double x = fput_bond(m, q, b), k = 1 + x * (2 * m->alpha + 3 * m->beta * x);
            if (b < N) h[b * d + b] += k;
            if (b > 0) h[(b - 1) * d + b - 1] += k;
            if (b > 0 && b < N) {
                h[b * d + b - 1] -= k;
                h[(b - 1) * d + b] -= k;
            }
        }
        for (size_t i = 0; i < N; i++) h[(N + 1 + i) * d + N + 1 + i] = 1;
    }
    return 0;
}

/* sum H_ijk u_i u_j u_k = sum_b phi'''(x_b) (u_(b+1) - u_b)^3 over the q part of u */
static int fput_third(const void *self, const double *y, const double *u, double *d3)
{
    const fput *m = self;
    double s = 0;
    for (size_t b = 0; b <= m->N; b++) {
        double x = fput_bond(m, y, b), du = fput_bond(m, u, b);
        s += (2 * m->alpha + 6 * m->beta * x) * du * du * du;
    }
    *d3 = s;
    return 0;
}

/* H(y1) - H(y0) term by term, each term an exactly antisymmetric product of a difference and a
 * symmetric sum: phi(a) - phi(b) = (a - b) ((a + b)/2 + alpha (a^2 + ab + b^2)/3 + beta (a + b)(a^2 + b^2)/4) */
static int fput_hdiff(const void *self, const double *y1, const double *y0, double *dH)
{
    const fput *m = self;
    size_t N = m->N;
    double s = 0;
    for (size_t i = 0; i < N; i++) s += 0.5 * (y1[N + 1 + i] - y0[N + 1 + i]) * (y1[N + 1 + i] + y0[N + 1 + i]);
    for (size_t b = 0; b <= N; b++) {
        double a = fput_bond(m, y1, b), c = fput_bond(m, y0, b);
        double dr = b < N ? y1[b] - y0[b] : 0, dl = b > 0 ? y1[b - 1] - y0[b - 1] : 0, dx = dr - dl;
        double sum = a + c, sq = a * a + c * c, pr = a * c;
        s += dx * (0.5 * sum + m->alpha * (sq + pr) / 3 + m->beta * sum * sq / 4);
    }
    *dH = s;
    return 0;
}

/* banded Hessian over x = (q_1, p_1, ..., q_N, p_N), half-bandwidth 2 */
static int fput_band(const void *self, const double *y, double *band)
{
    const fput *m = self;
    size_t N = m->N, w = 2, W = 2 * w + 1;
    memset(band, 0, 2 * N * W * sizeof *band);
    for (size_t b = 0; b <= N; b++) {
        double x = fput_bond(m, y, b), k = 1 + x * (2 * m->alpha + 3 * m->beta * x);
        if (b < N) band[(2 * b) * W + w] += k;
        if (b > 0) band[(2 * (b - 1)) * W + w] += k;
        if (b > 0 && b < N) {
            band[(2 * b) * W + (w - 2)] -= k;       /* row q_(b+1), column q_b */
            band[(2 * (b - 1)) * W + (w + 2)] -= k; /* row q_b, column q_(b+1) */
        }
    }
    for (size_t i = 0; i < N; i++) band[(2 * i + 1) * W + w] = 1;
    return 0;
}

static const dth_model_type fput_type = {
DTH_MODEL_TYPE_HEAD,
    .name = "fput",
    .doc = "FPUT alpha-beta chain with fixed ends (bench_symplectic's user model)",
    .params = fput_params,
    .n_params = sizeof fput_params / sizeof fput_params[0],
    .create = fput_create,
    .destroy = fput_destroy,
    .eval = fput_eval,
    .third = fput_third,
    .hess_band = fput_band,
    .hdiff = fput_hdiff,
};

/* ---- Henon-Heiles: H = (px^2 + py^2)/2 + (x^2 + y^2)/2 + x^2 y - y^3/3 ---- */

static int hh_create(const dth_model_args *a, void **self, dth_model_info *info)
{
    (void)a;
    *self = NULL;
    *info = (dth_model_info){.n = 2, .autonomous = 1, .separable = 1, .hess_kind = DTH_HESS_DENSE};
    return DTH_OK;
}

static int hh_eval(const void *self, const double *y, unsigned what, double *H, double *g, double *h)
{
    (void)self;
    double x = y[0], yy = y[1], px = y[3], py = y[4];
    if (what & DTH_EVAL_H) *H = 0.5 * (px * px + py * py) + 0.5 * (x * x + yy * yy) + x * x * yy - yy * yy * yy / 3;
    if (what & DTH_EVAL_GRAD) {
        memset(g, 0, 5 * sizeof *g);
        g[0] = x + 2 * x * yy, g[1] = yy + x * x - yy * yy, g[3] = px, g[4] = py;
    }
    if (what & DTH_EVAL_HESS) {
        memset(h, 0, 25 * sizeof *h);
        h[0] = 1 + 2 * yy, h[1] = h[5] = 2 * x, h[6] = 1 - 2 * yy, h[18] = h[24] = 1;
    }
    return 0;
}

/* V_xxy = 2, V_yyy = -2: sum H_ijk u_i u_j u_k = 3 V_xxy ux^2 uy + V_yyy uy^3 */
static int hh_third(const void *self, const double *y, const double *u, double *d3)
{
    (void)self;
    (void)y;
    *d3 = 6 * u[0] * u[0] * u[1] - 2 * u[1] * u[1] * u[1];
    return 0;
}

/* exactly antisymmetric H(y1) - H(y0): x1^2 y1 - x0^2 y0 = (x1^2 - x0^2)(y1 + y0)/2 + (x1^2 + x0^2)(y1 - y0)/2 */
static int hh_hdiff(const void *self, const double *y1, const double *y0, double *dH)
{
    (void)self;
    double dx = y1[0] - y0[0], sx = y1[0] + y0[0], dy = y1[1] - y0[1], sy = y1[1] + y0[1];
    double dpx = y1[3] - y0[3], spx = y1[3] + y0[3], dpy = y1[4] - y0[4], spy = y1[4] + y0[4];
    double x2d = dx * sx, x2s = y1[0] * y1[0] + y0[0] * y0[0];
    double y3d = dy * (y1[1] * y1[1] + y0[1] * y0[1] + y1[1] * y0[1]);
    *dH = 0.5 * (dpx * spx + dpy * spy) + 0.5 * (x2d + dy * sy) + 0.5 * (x2d * sy + x2s * dy) - y3d / 3;
    return 0;
}

static const dth_model_type hh_type = {
DTH_MODEL_TYPE_HEAD,
    .name = "henon-heiles",
    .doc = "Henon-Heiles (bench_symplectic's user model)",
    .create = hh_create,
    .destroy = NULL,
    .eval = hh_eval,
    .third = hh_third,
    .hdiff = hh_hdiff,
};

/* ---- two coupled rotating pendula: H = (p1^2 + p2^2)/2 - cos q1 - cos q2 - eps cos(q1 - q2) ---- */

typedef struct rotors {
    double eps;
} rotors;

static const dth_param_spec rotors_params[] = {
    {"eps", "0.1", "coupling"},
};

static int rotors_create(const dth_model_args *a, void **self, dth_model_info *info)
{
    double e;
    int rc = dth_args_double(a, "eps", 0.1, &e);
    if (rc) return rc;
    rotors *m = dth_calloc(a->alloc, 1, sizeof *m);
    if (!m) return DTH_ENOMEM;
    m->eps = e;
    *self = m;
    *info = (dth_model_info){.n = 2, .autonomous = 1, .separable = 1, .hess_kind = DTH_HESS_DENSE};
    return DTH_OK;
}

static void rotors_destroy(void *self, const dth_allocator *alloc) { dth_free(alloc, self); }

static int rotors_eval(const void *self, const double *y, unsigned what, double *H, double *g, double *h)
{
    const rotors *m = self;
    double q1 = y[0], q2 = y[1], p1 = y[3], p2 = y[4], d = q1 - q2;
    if (what & DTH_EVAL_H) *H = 0.5 * (p1 * p1 + p2 * p2) - cos(q1) - cos(q2) - m->eps * cos(d);
    if (what & DTH_EVAL_GRAD) {
        double c = m->eps * sin(d);
        memset(g, 0, 5 * sizeof *g);
        g[0] = sin(q1) + c, g[1] = sin(q2) - c, g[3] = p1, g[4] = p2;
    }
    if (what & DTH_EVAL_HESS) {
        double c = m->eps * cos(d);
        memset(h, 0, 25 * sizeof *h);
        h[0] = cos(q1) + c, h[6] = cos(q2) + c, h[1] = h[5] = -c, h[18] = h[24] = 1;
    }
    return 0;
}

static int rotors_third(const void *self, const double *y, const double *u, double *d3)
{
    const rotors *m = self;
    double du = u[0] - u[1];
    *d3 = -sin(y[0]) * u[0] * u[0] * u[0] - sin(y[1]) * u[1] * u[1] * u[1] - m->eps * sin(y[0] - y[1]) * du * du * du;
    return 0;
}

/* -(cos a1 - cos a0) = 2 sin((a1 + a0)/2) sin((a1 - a0)/2): exactly antisymmetric */
static int rotors_hdiff(const void *self, const double *y1, const double *y0, double *dH)
{
    const rotors *m = self;
    double d1 = y1[0] - y0[0], s1 = y1[0] + y0[0], d2 = y1[1] - y0[1], s2 = y1[1] + y0[1];
    double dc = d1 - d2, sc = s1 - s2;
    *dH = 0.5 * ((y1[3] - y0[3]) * (y1[3] + y0[3]) + (y1[4] - y0[4]) * (y1[4] + y0[4])) + 2 * sin(0.5 * s1) * sin(0.5 * d1) +
          2 * sin(0.5 * s2) * sin(0.5 * d2) + 2 * m->eps * sin(0.5 * sc) * sin(0.5 * dc);
    return 0;
}

static const dth_model_type rotors_type = {
DTH_MODEL_TYPE_HEAD,
    .name = "rotors",
    .doc = "two coupled pendula (bench_symplectic's user model)",
    .params = rotors_params,
    .n_params = sizeof rotors_params / sizeof rotors_params[0],
    .create = rotors_create,
    .destroy = rotors_destroy,
    .eval = rotors_eval,
    .third = rotors_third,
    .hdiff = rotors_hdiff,
};

#endif
