/* SPDX-License-Identifier: MIT */
/*
 * Fixed-step baselines of the physical system that DTH is compared against (paper, section 1):
 * Runge-Kutta methods as Butcher tables with one explicit and one implicit (Gauss) driver,
 * Stormer-Verlet, midpoint + energy projection. Each method is a type of the stepper table
 * (stepper.h); a new Runge-Kutta method is one entry of `methods` below.
 */
#include <math.h>
#include <stdarg.h>
#include <stdio.h>
#include <string.h>
#include "dth_internal.h"
#include "dd.h"
#include "stepper.h"

typedef enum kind { KIND_ERK, KIND_GAUSS, KIND_VERLET } kind;

/* A method as data: Butcher table (row-major A); for Gauss methods optionally d = b^T A^{-1} when
 * it is exact in double, so the update y + sum_i d_i Z_i needs no slopes at the final stages. */
typedef struct method {
    const char *name;
    const char *doc;
    kind k;
    int s, order;
    int project; /* follow each step with the projection onto the initial energy */
    const double *A, *b, *c, *d;
} method;

#define SQRT3 1.7320508075688772935
static const double g1_A[] = {0.5}, g1_b[] = {1.0}, g1_c[] = {0.5}, g1_d[] = {2.0};
/* a12 = 1/2 - a21 exactly (Sterbenz), so the stored table satisfies the symplecticity condition
 * b_i a_ij + b_j a_ji = b_i b_j exactly, not only to the rounding of the coefficients. */
#define G2_A21 (0.25 + SQRT3 / 6)
static const double g2_A[] = {0.25, 0.5 - G2_A21, G2_A21, 0.25};
static const double g2_b[] = {0.5, 0.5}, g2_c[] = {0.5 - SQRT3 / 6, 0.5 + SQRT3 / 6};
static const double rk4_A[] = {0, 0, 0, 0, 0.5, 0, 0, 0, 0, 0.5, 0, 0, 0, 0, 1, 0};
static const double rk4_b[] = {1.0 / 6, 1.0 / 3, 1.0 / 3, 1.0 / 6}, rk4_c[] = {0, 0.5, 0.5, 1};

/* Each method's name and description, once: for its table entry and its stepper type. */
#define M0 "midpoint", "implicit midpoint rule (1-stage Gauss), order 2, symplectic"
#define M1 "gauss4", "2-stage Gauss-Legendre, order 4, symplectic"
#define M2 "rk4", "classical Runge-Kutta, order 4, explicit"
#define M3 "verlet", "Stormer-Verlet (kick-drift-kick), order 2, symplectic, separable H only"
#define M4 "midpoint-proj", "implicit midpoint + orthogonal projection onto the initial energy, order 2"
static const method methods[] = {
    {M0, KIND_GAUSS, 1, 2, 0, g1_A, g1_b, g1_c, g1_d},
    {M1, KIND_GAUSS, 2, 4, 0, g2_A, g2_b, g2_c, NULL},
    {M2, KIND_ERK, 4, 4, 0, rk4_A, rk4_b, rk4_c, NULL},
    {M3, KIND_VERLET, 1, 2, 0, NULL, NULL, NULL, NULL},
    {M4, KIND_GAUSS, 1, 2, 1, g1_A, g1_b, g1_c, g1_d},
};
enum { NMETHODS = sizeof methods / sizeof methods[0], MAX_ITER = 30, MAX_PROJ_ITER = 20 };

typedef struct dth_fixed {
    const dth_model *model;
    const dth_allocator *alloc;
    const method *m;
    size_t n, d, M;   /* dof, physical dim 2n+1, Newton unknowns s*d */
    double h;
    double *y, *ylo;  /* state y = y + ylo (double-double), N = 2n + 2 entries: (q, t, p) and wp = -E0 */
    double *Z, *Zp;   /* stage offsets Y_i - y (s*d); Zp: last step's, the predictor */
    double *Y, *K;    /* a stage point (d); stage slopes (s*d) */
    double *grad, *hess, *Jf; /* d, d*d, s*d*d (df/dy at each stage) */
    double *A, *F, *dZ, *delta, *fq; /* Newton matrix M*M, residual M, correction M, update d, Verlet force n */
    dth__newton_track nt;
    int *piv;
    double E0;        /* initial energy (projection; -wp) */
    int started, have_prev, have_force;
    long steps;
    size_t N, Zlen;   /* 2n + 2; the predictor's s d */
    double *block;
    char errmsg[160];
} dth_fixed;

static void seterr(dth_fixed *f, const char *fmt, ...) __attribute__((format(printf, 2, 3)));
static void seterr(dth_fixed *f, const char *fmt, ...)
{
    va_list ap;
    va_start(ap, fmt);
    vsnprintf(f->errmsg, sizeof f->errmsg, fmt, ap);
    va_end(ap);
}

/* The model rules of method m (dth_options_check calls them through the type). */
static int check_method(const method *m, const dth_model *model, char *why, size_t len)
{
    const dth_model_info *inf = dth_model_get_info(model);
    if (m->k == KIND_VERLET && !inf->separable) {
        dth__set_err(why, len, "method 'verlet' needs a separable H = T(p) + V(q, t); model '%s' is not",
                     dth_model_get_type(model)->name);
        return DTH_EUNSUPPORTED;
    }
    if (m->project && !inf->autonomous) {
        dth__set_err(why, len, "method '%s' projects onto a conserved energy; model '%s' is not autonomous", m->name,
                     dth_model_get_type(model)->name);
        return DTH_EUNSUPPORTED;
    }
    if (m->k != KIND_VERLET && m->k != KIND_ERK && m->k != KIND_GAUSS) return DTH_EINVAL;
    return DTH_OK;
}

static void destroy(void *s)
{
    dth_fixed *f = s;
    if (!f) return;
    dth_free(f->alloc, f->block);
    dth_free(f->alloc, f->piv);
    dth_free(f->alloc, f);
}

static int create_method(const method *m, const dth_model *model, const dth_options *o, void **out)
{
    const dth_allocator *alloc = o->alloc;
    dth_fixed *f = dth_calloc(alloc, 1, sizeof *f);
    if (!f) return DTH_ENOMEM;
    f->model = model;
    f->alloc = alloc;
    f->m = m;
    f->h = o->h;
    f->n = dth_model_dof(model);
    f->d = 2 * f->n + 1;
    f->N = f->d + 1;
    size_t s = (size_t)f->m->s, d = f->d;
    f->Zlen = s * d;
    f->M = f->m->k == KIND_GAUSS ? s * d : 0;
    size_t M = f->M, gauss = f->m->k == KIND_GAUSS; /* only the implicit methods need Jacobians */
    size_t sizes[] = {f->N, f->N, s * d, s * d, d, s * d, d, gauss * d * d, gauss * s * d * d, M * M, M, M, d, f->n};
    size_t nd = 0;
    for (size_t i = 0; i < sizeof sizes / sizeof sizes[0]; i++) nd += sizes[i];
    f->block = dth_calloc(alloc, nd, sizeof(double));
    f->piv = dth_calloc(alloc, M ? M : 1, sizeof(int));
    if (!f->block || !f->piv) {
        destroy(f);
        return DTH_ENOMEM;
    }
    double *p = f->block;
    double **slots[] = {&f->y, &f->ylo, &f->Z, &f->Zp, &f->Y, &f->K, &f->grad, &f->hess, &f->Jf,
                        &f->A, &f->F, &f->dZ, &f->delta, &f->fq};
    for (size_t i = 0; i < sizeof slots / sizeof slots[0]; i++) {
        *slots[i] = p;
        p += sizes[i];
    }
    snprintf(f->errmsg, sizeof f->errmsg, "no error");
    *out = f;
    return DTH_OK;
}

/* The step h, changed: the predictor's stage offsets scale with it. */
static void set_h(dth_fixed *f, double h)
{
    if (f->have_prev) /* stage offsets scale with h: keep the predictor consistent */
        for (size_t k = 0; k < (size_t)f->m->s * f->d; k++) f->Zp[k] *= h / f->h;
    f->h = h;
}

/* The state y (q, t, p) and its energy; wp = -E0 carried with it. */
static int set_state(dth_fixed *f, const double *y)
{
    size_t d = f->d;
    double E;
    for (size_t j = 0; j < d; j++)
        if (!isfinite(y[j])) {
            seterr(f, "initial value %zu is not finite", j);
            return DTH_EINVAL;
        }
    int rc = dth_model_eval(f->model, y, DTH_EVAL_H, &E, NULL, NULL);
    if (rc) {
        seterr(f, "model evaluation failed at the initial state: %s", dth_strerror(rc));
        return rc;
    }
    memcpy(f->y, y, d * sizeof *y);
    memset(f->ylo, 0, f->N * sizeof *y);
    f->E0 = E;
    f->y[d] = -E;
    f->started = 1;
    f->have_prev = 0;
    f->have_force = 0;
    f->steps = 0;
    return DTH_OK;
}

static int start(void *s, const double *q0, const double *p0, double t0)
{
    dth_fixed *f = s;
    if (!q0 || !p0 || !isfinite(t0)) return DTH_EINVAL;
    size_t n = f->n;
    double *y = f->Y;
    memcpy(y, q0, n * sizeof *y);
    y[n] = t0;
    memcpy(y + n + 1, p0, n * sizeof *y);
    return set_state(f, y);
}

/* z (q, t, p, wp): the state; lambda: the step from here on (its sign the direction). */
static int set_vertex(void *s, const double *z, double lambda)
{
    dth_fixed *f = s;
    if (!z || !isfinite(lambda) || lambda == 0) return DTH_EINVAL;
    int rc = set_state(f, z);
    if (rc) return rc;
    f->h = lambda;
    return DTH_OK;
}

static void reverse(void *s)
{
    dth_fixed *f = s;
    set_h(f, -f->h);
}

static const double *vertex(const void *s) { return ((const dth_fixed *)s)->y; }
static const double *midpoint(const void *s) { (void)s; return NULL; }
static double lambda(const void *s) { return ((const dth_fixed *)s)->h; }
static double direction(const void *s) { return ((const dth_fixed *)s)->h > 0 ? 1.0 : -1.0; }
static double energy(const void *s) { return ((const dth_fixed *)s)->E0; }
static long steps(const void *s) { return ((const dth_fixed *)s)->steps; }
static int order(const void *s) { return ((const dth_fixed *)s)->m->order; }
static const char *errmsg(const void *s) { return ((const dth_fixed *)s)->errmsg; }

/* Y = y + (ylo + off): a point near the state, rounded once. */
static void point(const dth_fixed *f, const double *off, double *Y)
{
    for (size_t j = 0; j < f->d; j++) Y[j] = f->y[j] + (f->ylo[j] + off[j]);
}

/* y += delta in double-double; the time advances by exactly h (compensated). */
static void advance(dth_fixed *f, const double *delta)
{
    for (size_t j = 0; j < f->d; j++) {
        double e, dj = j == f->n ? f->h : delta[j];
        f->y[j] = two_sum(f->y[j], dj + f->ylo[j], &e);
        f->ylo[j] = e;
    }
}

/* Slope f(y) = (dH/dp, 1, -dH/dq) and, if J != NULL, its Jacobian (row-major d x d). */
static int slope(dth_fixed *f, const double *Y, double *u, double *J)
{
    size_t n = f->n, d = f->d;
    int rc = dth_model_eval(f->model, Y, J ? DTH_EVAL_GRAD | DTH_EVAL_HESS : DTH_EVAL_GRAD, NULL,
                            f->grad, J ? f->hess : NULL);
    if (rc) return rc;
    dth__flow_y(n, f->grad, u);
    if (J) {
        const double *Hs = f->hess;
        for (size_t l = 0; l < d; l++) {
            for (size_t i = 0; i < n; i++) {
                J[i * d + l] = Hs[(n + 1 + i) * d + l];
                J[(n + 1 + i) * d + l] = -Hs[i * d + l];
            }
            J[n * d + l] = 0;
        }
    }
    return DTH_OK;
}

/* Explicit Runge-Kutta step from the table. */
static int step_erk(dth_fixed *f)
{
    const method *m = f->m;
    size_t d = f->d, s = (size_t)m->s;
    double h = f->h;
    for (size_t i = 0; i < s; i++) {
        for (size_t j = 0; j < d; j++) {
            double acc = 0;
            for (size_t l = 0; l < i; l++) acc += m->A[i * s + l] * f->K[l * d + j];
            f->Z[j] = h * acc;
        }
        point(f, f->Z, f->Y);
        f->Y[f->n] = f->y[f->n] + (f->ylo[f->n] + m->c[i] * h);
        int rc = slope(f, f->Y, f->K + i * d, NULL);
        if (rc) {
            seterr(f, "model evaluation failed at stage %zu: %s", i + 1, dth_strerror(rc));
            return rc;
        }
    }
    for (size_t j = 0; j < d; j++) {
        double acc = 0;
        for (size_t i = 0; i < s; i++) acc += m->b[i] * f->K[i * d + j];
        f->delta[j] = h * acc;
    }
    advance(f, f->delta);
    return DTH_OK;
}

/* ---- Gauss collocation stages as a Newton problem (newton.c): unknowns Z (s*d) ---- */

static int gauss_eval(void *ctx, const double *Z, double *F, int jac)
{
    dth_fixed *f = ctx;
    const method *m = f->m;
    size_t d = f->d, s = (size_t)m->s, M = f->M;
    double h = f->h;
    for (size_t i = 0; i < s; i++) {
        point(f, Z + i * d, f->Y);
        int rc = slope(f, f->Y, f->K + i * d, jac ? f->Jf + i * d * d : NULL);
        if (rc) {
            seterr(f, "model evaluation failed at stage %zu (iteration %d): %s", i + 1, f->nt.iter, dth_strerror(rc));
            return rc;
        }
    }
    /* residual and column-major Jacobian */
    for (size_t i = 0; i < s; i++)
        for (size_t j = 0; j < d; j++) {
            double acc = 0;
            for (size_t l = 0; l < s; l++) acc += m->A[i * s + l] * f->K[l * d + j];
            F[i * d + j] = Z[i * d + j] - h * acc;
        }
    if (!jac) return DTH_OK;
    for (size_t i = 0; i < s; i++)
        for (size_t l = 0; l < s; l++) {
            double ha = h * m->A[i * s + l];
            const double *Jl = f->Jf + l * d * d;
            for (size_t j = 0; j < d; j++)
                for (size_t k = 0; k < d; k++) {
                    double v = -ha * Jl[j * d + k] + (i == l && j == k ? 1.0 : 0.0);
                    f->A[(i * d + j) + (l * d + k) * M] = v;
                }
        }
    int rc = dth__lu_factor(DTH_LINSOLVE_AUTO, (int)M, f->A, f->piv);
    if (rc) seterr(f, "stage Jacobian is singular at iteration %d", f->nt.iter);
    return rc;
}

static int gauss_solve(void *ctx, double *b)
{
    dth_fixed *f = ctx;
    return dth__lu_solve(DTH_LINSOLVE_AUTO, (int)f->M, f->A, f->piv, 1, b);
}

static int gauss_judge(void *ctx, const double *Z, const double *dZ, const double *F, dth__newton_track *tr, int *verdict)
{
    dth_fixed *f = ctx;
    (void)F;
    /* norm-wise relative correction: a componentwise one never reaches round-off on components
     * that are themselves round-off (p = 0 at rest, say) */
    double cmax = 0, smax = 0;
    for (size_t k = 0; k < f->M; k++) {
        double c = fabs(dZ[k]), sc = fabs(f->y[k % f->d]) + fabs(Z[k]);
        if (!(c <= cmax)) cmax = c; /* NaN propagates */
        if (sc > smax) smax = sc;
    }
    double r = cmax / (smax > 0 ? smax : 1e-300);
    tr->r = r;
    int v = dth__newton_rate(r, tr->r_prev, tr->iter, 4 * DBL_EPSILON);
    if (v == DTH__NT_DIVERGED) {
        seterr(f, "Newton diverged at iteration %d", tr->iter);
        return DTH_ENOCONV;
    }
    /* the chord finish of the DTH step, without the extra residual: this baseline stops at the
     * predicted-converged iterate (as it always has), so both pay for the same accuracy */
    if (v == DTH__NT_CHORD) v = DTH__NT_DONE;
    if (v == DTH__NT_STALLED) {
        if (r <= 1e3 * DBL_EPSILON && tr->iter >= 8) v = DTH__NT_DONE; /* stalled at round-off */
        else if (tr->iter >= 8) {
            seterr(f, "Newton stalled at relative correction %.3g", r);
            return DTH_ENOCONV;
        } else v = DTH__NT_MORE;
    }
    *verdict = v;
    return DTH_OK;
}

static const dth__newton_ops gauss_ops = {gauss_eval, gauss_solve, gauss_judge};

/*
 * Gauss collocation step: Newton on F_i = Z_i - h sum_j a_ij f(y + Z_j) = 0 with the exact
 * Jacobian (delta_ij I - h a_ij df/dy(Y_j)) and the stopping rule of the DTH step (so both pay
 * for the same accuracy), through the library's Newton driver. Predictor: the last step's stage
 * offsets.
 */
static int step_gauss(dth_fixed *f, int *iters)
{
    const method *m = f->m;
    size_t d = f->d, s = (size_t)m->s, M = f->M;
    double h = f->h;
    int rc;
    if (f->have_prev) {
        memcpy(f->Z, f->Zp, M * sizeof *f->Z);
    } else {
        rc = slope(f, f->y, f->K, NULL);
        if (rc) {
            seterr(f, "model evaluation failed at the state: %s", dth_strerror(rc));
            return rc;
        }
        for (size_t i = 0; i < s; i++)
            for (size_t j = 0; j < d; j++) f->Z[i * d + j] = m->c[i] * h * f->K[j];
    }
    rc = dth__newton_run(&gauss_ops, f, (int)M, MAX_ITER, f->Z, f->F, f->dZ, &f->nt);
    *iters = f->nt.iter;
    if (rc == DTH_ENOCONV && f->nt.verdict == DTH__NT_MAXITER)
        seterr(f, "Newton did not converge in %d iterations (last correction %.3g)", f->nt.iter, f->nt.r);
    if (rc) return rc;
    if (m->d) { /* exact d (midpoint: d = 2): y + sum_i d_i Z_i */
        for (size_t j = 0; j < d; j++) {
            double acc = 0;
            for (size_t i = 0; i < s; i++) acc += m->d[i] * f->Z[i * d + j];
            f->delta[j] = acc;
        }
        return DTH_OK;
    }
    /* y + h sum_i b_i f(Y_i), with f at the final stages from the last slopes corrected to first
     * order by the last Newton correction (-dZ): rounded d = b^T A^{-1} would break the exact
     * symplecticity of the stored table and make quadratic invariants drift linearly. */
    for (size_t i = 0; i < s; i++) {
        const double *Ji = f->Jf + i * d * d;
        for (size_t j = 0; j < d; j++) {
            double c = 0;
            for (size_t k = 0; k < d; k++) c += Ji[j * d + k] * f->dZ[i * d + k];
            f->K[i * d + j] -= c;
        }
    }
    for (size_t j = 0; j < d; j++) {
        double acc = 0;
        for (size_t i = 0; i < s; i++) acc += m->b[i] * f->K[i * d + j];
        f->delta[j] = h * acc;
    }
    return DTH_OK;
}

/*
 * Simple orthogonal projection (Hairer, Lubich, Wanner, GNI IV.4): move the proposed state
 * y + delta along v = grad_(q,p) H there, by mu with H(y + delta + mu v) = E0, by simplified
 * Newton (derivative |v|^2 frozen). t is not moved. Writes the moved delta.
 */
static int project(dth_fixed *f, int *iters)
{
    size_t n = f->n, d = f->d;
    double *Y = f->Y, *v = f->K, Hc;
    double *delta = f->delta;
    delta[n] = f->h;
    point(f, delta, Y);
    int rc = dth_model_eval(f->model, Y, DTH_EVAL_H | DTH_EVAL_GRAD, &Hc, f->grad, NULL);
    if (rc) goto fail_eval;
    double vv = 0, scale = fabs(f->E0);
    for (size_t j = 0; j < d; j++) {
        v[j] = j == n ? 0.0 : f->grad[j];
        vv += v[j] * v[j];
        scale += fabs(f->grad[j] * Y[j]);
    }
    if (!(vv > 0)) { /* an equilibrium: nothing to project along; energy is what it is */
        *iters = 0;
        return DTH_OK;
    }
    double mu = 0, rprev = INFINITY;
    for (int it = 1; it <= MAX_PROJ_ITER; it++) {
        double r = Hc - f->E0;
        *iters = it;
        if (fabs(r) <= 2 * DBL_EPSILON * scale) return DTH_OK;
        if (fabs(r) >= 0.5 * rprev) {
            if (fabs(r) <= 32 * DBL_EPSILON * scale) return DTH_OK; /* round-off floor */
            break;
        }
        rprev = fabs(r);
        double dmu = r / vv;
        mu -= dmu;
        for (size_t j = 0; j < d; j++) delta[j] -= dmu * v[j];
        delta[n] = f->h;
        point(f, delta, Y);
        rc = dth_model_eval(f->model, Y, DTH_EVAL_H, &Hc, NULL, NULL);
        if (rc) goto fail_eval;
    }
    seterr(f, "energy projection did not converge (mu = %.3g)", mu);
    return DTH_ENOCONV;
fail_eval:
    seterr(f, "model evaluation failed in the energy projection: %s", dth_strerror(rc));
    return rc;
}

/* Stormer-Verlet, kick-drift-kick; the force at the end of a step is kept for the next. */
static int step_verlet(dth_fixed *f)
{
    size_t n = f->n, d = f->d;
    double h = f->h, *Y = f->Y, *u = f->K, *fq_new = f->Zp; /* Zp: no predictor in Verlet */
    int rc;
    memset(f->Z, 0, d * sizeof *f->Z);
    if (!f->have_force) {
        point(f, f->Z, Y);
        rc = slope(f, Y, u, NULL);
        if (rc) goto fail;
        for (size_t i = 0; i < n; i++) f->fq[i] = u[n + 1 + i]; /* -dV/dq(q, t) */
    }
    /* p_half, then dT/dp(p_half) at t + h/2 */
    for (size_t i = 0; i < n; i++) f->Z[n + 1 + i] = 0.5 * h * f->fq[i];
    f->Z[n] = 0.5 * h;
    point(f, f->Z, Y);
    rc = slope(f, Y, u, NULL);
    if (rc) goto fail;
    for (size_t i = 0; i < n; i++) f->Z[i] = h * u[i];
    f->Z[n] = h;
    point(f, f->Z, Y);
    rc = slope(f, Y, u, NULL);
    if (rc) goto fail;
    for (size_t i = 0; i < n; i++) {
        fq_new[i] = u[n + 1 + i];
        f->delta[i] = f->Z[i];
        f->delta[n + 1 + i] = 0.5 * h * (f->fq[i] + fq_new[i]);
    }
    advance(f, f->delta);
    memcpy(f->fq, fq_new, n * sizeof *fq_new);
    f->have_force = 1;
    return DTH_OK;
fail:
    seterr(f, "model evaluation failed in the Verlet step: %s", dth_strerror(rc));
    return rc;
}

/* One step of size h; on failure the state is exactly as before (y changes only in advance). */
static int step(void *s, dth_step_info *info)
{
    dth_fixed *f = s;
    if (!f->started) {
        seterr(f, "a step before the start");
        return DTH_EINVAL;
    }
    info->lambda = f->h;
    int rc;
    switch (f->m->k) {
    case KIND_ERK:
        rc = step_erk(f);
        break;
    case KIND_VERLET:
        rc = step_verlet(f);
        break;
    default:
        rc = step_gauss(f, &info->iters);
        if (!rc && f->m->project) rc = project(f, &info->proj_iters);
        if (!rc) {
            advance(f, f->delta);
            memcpy(f->Zp, f->Z, f->M * sizeof *f->Z);
            f->have_prev = 1;
        }
        break;
    }
    if (rc) return rc;
    f->steps++;
    snprintf(f->errmsg, sizeof f->errmsg, "no error");
    return DTH_OK;
}

/* ---- checkpoint sections: the state (N-vectors), the predictor's stage offsets, Verlet's force ---- */

#define FIXED_STATE(X)                                                                              \
    X(y, VEC, FINITE, "the state (q, t, p) and wp = -E0, high part")                               \
    X(ylo, VEC, FINITE, "its low part")                                                             \
    X(h, F64, HSTEP, "the step (its sign the direction)")                                         \
    X(E0, F64, FINITE, "the initial energy")                                                        \
    X(started, INT, BOOL, "started")                                                                \
    X(have_prev, INT, BOOL, "Zp holds the last step's stage offsets")                               \
    X(have_force, INT, BOOL, "fq holds the force at the state (Verlet)")                            \
    X(steps, LONG, COUNT, "steps since the start")
#define ENTRY(name, kind, check, doc) DTH__FIELD(dth_fixed, name, kind, check),
static const dth__field state_fields[] = {FIXED_STATE(ENTRY)};
#undef ENTRY
static const dth__field zp_field[] = {DTH__FIELD(dth_fixed, Zp, VEC, FINITE)};
static const dth__field fq_field[] = {DTH__FIELD(dth_fixed, fq, VEC, FINITE)};

static size_t sections(void *s, dth__section *out)
{
    dth_fixed *f = s;
    out[0] = (dth__section){"state", state_fields, sizeof state_fields / sizeof state_fields[0], f, f->N};
    out[1] = (dth__section){"predictor", zp_field, 1, f, f->Zlen};
    out[2] = (dth__section){"force", fq_field, 1, f, f->n};
    return 3;
}

/* A restored state's rules between fields: a state holds steps only once started, and carries
 * wp = -E0. */
static int consistent(const void *s, char *err, size_t errlen)
{
    const dth_fixed *f = s;
    if (!f->started && (f->steps || f->have_prev || f->have_force)) {
        snprintf(err, errlen, "field 'steps', 'have_prev' or 'have_force' is set, yet 'started' = 0");
        return DTH_EPARSE;
    }
    if (f->started && f->y[f->d] != -f->E0) {
        snprintf(err, errlen, "field 'E0' = %.17g is not minus the wp that field 'y' carries, %.17g", f->E0, f->y[f->d]);
        return DTH_EPARSE;
    }
    return DTH_OK;
}

/* One stepper type per method: the table's entries, with their own create and check. */
#define BASELINE(i)                                                                                             \
    static int create_##i(const dth_model *model, const dth_options *o, void **out)                           \
    {                                                                                                           \
        return create_method(&methods[i], model, o, out);                                                      \
    }                                                                                                           \
    static int check_##i(const dth_model *model, const dth_options *o, char *why, size_t len)                 \
    {                                                                                                           \
        (void)o;                                                                                                \
        return check_method(&methods[i], model, why, len);                                                     \
    }
BASELINE(0)
BASELINE(1)
BASELINE(2)
BASELINE(3)
BASELINE(4)
#define TYPE(i, NAME_DOC)                                                                                       \
    {NAME_DOC, .check = check_##i, .create = create_##i, .destroy = destroy, .start = start,               \
     .set_vertex = set_vertex, .step = step, .reverse = reverse, .vertex = vertex, .midpoint = midpoint,       \
     .lambda = lambda, .direction = direction, .energy = energy, .steps = steps, .order = order,               \
     .errmsg = errmsg, .wp_fixed = 1, .sections = sections, .consistent = consistent}
static const dth__stepper_type types[NMETHODS] = {TYPE(0, M0), TYPE(1, M1), TYPE(2, M2), TYPE(3, M3), TYPE(4, M4)};
_Static_assert(NMETHODS == 5, "one BASELINE and TYPE entry per method");

size_t dth__baseline_count(void) { return NMETHODS; }
const dth__stepper_type *dth__baseline_at(size_t i) { return i < NMETHODS ? &types[i] : NULL; }
