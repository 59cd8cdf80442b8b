/* SPDX-License-Identifier: MIT */
/* Helpers shared by the C tests (static inline: a test includes the header and uses what it needs). */
#ifndef DTH_TEST_UTIL_H
#define DTH_TEST_UTIL_H

#include <float.h>
#include <math.h>
#include <stdio.h>
#include "cu_main.h"
#include "dth/dth.h"

/* A model of type t with the parameters kv[0..nkv) and n degrees of freedom (0: the type's own);
 * the test stops if it cannot be made, with the library's message on stderr. */
static inline dth_model *model(const dth_model_type *t, const dth_kv *kv, size_t nkv, size_t n)
{
    dth_model *m = NULL;
    char err[256] = "";
    int rc = dth_model_new(t, kv, nkv, n, NULL, &m, err, sizeof err);
    if (rc) fprintf(stderr, "dth_model_new(%s): %s\n", t->name, err);
    CU_ASSERT_EQUAL_FATAL(rc, DTH_OK);
    return m;
}

/* |wp + H_phys(zbar)| at a midpoint zbar = (q, t, p, wp), in units of the round-off of its terms
 * (eps (|wp| + |H| + sum_j |dH/dy_j y_j|)). Up to 31 degrees of freedom. */
static inline double energy_ulps(const dth_model *m, const double *zb)
{
    size_t n = dth_model_dof(m), N = 2 * n + 2;
    double H, g[64];
    CU_ASSERT_FATAL(N - 1 <= sizeof g / sizeof g[0]);
    CU_ASSERT_FATAL(dth_model_eval(m, zb, DTH_EVAL_H | DTH_EVAL_GRAD, &H, g, NULL) == DTH_OK);
    double s = fabs(zb[N - 1]) + fabs(H);
    for (size_t j = 0; j + 1 < N; j++) s += fabs(g[j] * zb[j]);
    return fabs(zb[N - 1] + H) / (DBL_EPSILON * s);
}

/* max |M^T J M - J| of a tangent map M over the extended z = (q, t, p, wp) (N = 2n + 2, row-major),
 * J = [[0, I], [-I, 0]] with I of size n + 1; the sums in long double if `extended`, else in double. */
static inline double symplectic_defect(size_t n, const double *M, int extended)
{
    size_t N = 2 * n + 2, h = n + 1;
    double worst = 0;
    for (size_t a = 0; a < N; a++)
        for (size_t b = 0; b < N; b++) {
            double j = (b == a + h) ? 1 : (a == b + h) ? -1 : 0, d;
            if (extended) {
                long double s = 0;
                for (size_t k = 0; k < h; k++)
                    s += (long double)M[k * N + a] * M[(h + k) * N + b] - (long double)M[(h + k) * N + a] * M[k * N + b];
                d = (double)fabsl(s - j);
            } else {
                double s = 0;
                for (size_t k = 0; k < h; k++) s += M[k * N + a] * M[(h + k) * N + b] - M[(h + k) * N + a] * M[k * N + b];
                d = fabs(s - j);
            }
            worst = fmax(worst, d);
        }
    return worst;
}

/* A forced oscillator H = p^2/2 + q^2/2 - 0.3 q cos(t), non-autonomous (t and wp are Newton
 * unknowns; wp moves): test_linsolve's and test_reversible's. */
static inline int test_forced_create(const dth_model_args *a, void **self, dth_model_info *info)
{
    (void)a;
    *self = NULL;
    *info = (dth_model_info){.n = 1, .autonomous = 0, .separable = 1};
    return DTH_OK;
}

static inline int test_forced_eval(const void *self, const double *y, unsigned what, double *H, double *g, double *h)
{
    (void)self;
    double q = y[0], t = y[1], p = y[2];
    if (what & DTH_EVAL_H) *H = 0.5 * p * p + 0.5 * q * q - 0.3 * q * cos(t);
    if (what & DTH_EVAL_GRAD) {
        g[0] = q - 0.3 * cos(t);
        g[1] = 0.3 * q * sin(t);
        g[2] = p;
    }
    if (what & DTH_EVAL_HESS) {
        double hh[9] = {1, 0.3 * sin(t), 0, 0.3 * sin(t), 0.3 * q * cos(t), 0, 0, 0, 1};
        for (int i = 0; i < 9; i++) h[i] = hh[i];
    }
    return 0;
}

static const dth_model_type test_forced_type = {
DTH_MODEL_TYPE_HEAD,
    .name = "forced", .doc = "forced oscillator", .create = test_forced_create, .eval = test_forced_eval};

#endif
