/* SPDX-License-Identifier: MIT */
/*
 * Fixed-step baselines of the physical system (Runge-Kutta methods as Butcher tables with one
 * explicit and one implicit (Gauss) driver, Stormer-Verlet, midpoint + energy projection) that
 * DTH is compared against (paper, section 1), and the DTH step's conditioning limit (paper,
 * Lemma g_taylor).
 */
#include <math.h>
#include <stdarg.h>
#include <stdio.h>
#include <string.h>
#include "dth_internal.h"
#include "dth/methods.h"

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

static const method methods[] = {
    {"midpoint", "implicit midpoint rule (1-stage Gauss), order 2, symplectic", KIND_GAUSS, 1, 2, 0,
     g1_A, g1_b, g1_c, g1_d},
    {"gauss4", "2-stage Gauss-Legendre, order 4, symplectic", KIND_GAUSS, 2, 4, 0, g2_A, g2_b, g2_c, NULL},
    {"rk4", "classical Runge-Kutta, order 4, explicit", KIND_ERK, 4, 4, 0, rk4_A, rk4_b, rk4_c, NULL},
    {"verlet", "Stormer-Verlet (kick-drift-kick), order 2, symplectic, separable H only", KIND_VERLET, 1, 2, 0,
     NULL, NULL, NULL, NULL},
    {"midpoint-proj", "implicit midpoint + orthogonal projection onto the initial energy, order 2",
     KIND_GAUSS, 1, 2, 1, g1_A, g1_b, g1_c, g1_d},
};
enum { NMETHODS = sizeof methods / sizeof methods[0], MAX_ITER = 30, MAX_PROJ_ITER = 20 };

struct dth_fixed {
    const dth_model *model;
    const dth_allocator *alloc;
    const method *m;
    size_t n, d, M;   /* dof, physical dim 2n+1, Newton unknowns s*d */
    double h;
    double *y, *ylo;  /* state y = y + ylo (double-double) */
    double *Z, *Zp;   /* stage offsets Y_i - y (s*d); Zp: last step's, the predictor */
    double *Y, *K;    /* a stage point (d); stage slopes (s*d) */
    double *grad, *hess, *Jf; /* d, d*d, s*d*d (df/dy at each stage) */
    double *A, *F, *dZ, *delta, *fq; /* Newton matrix M*M, residual M, correction M, update d, Verlet force n */
    dth__newton_track nt;
    int *piv;
    double E0;        /* initial energy (projection) */
    int started, have_prev, have_force;
    long steps;
    double *block;
    char errmsg[160];
};

static void seterr(dth_fixed *f, const char *fmt, ...) __attribute__((format(printf, 2, 3)));
static void seterr(dth_fixed *f, const char *fmt, ...)
{
    va_list ap;
    va_start(ap, fmt);
    vsnprintf(f->errmsg, sizeof f->errmsg, fmt, ap);
    va_end(ap);
}

static const method *find(const char *name)
{
    if (!name) return NULL;
    for (size_t i = 0; i < NMETHODS; i++)
        if (strcmp(methods[i].name, name) == 0) return &methods[i];
    return NULL;
}

size_t dth_fixed_method_count(void) { return NMETHODS; }
const char *dth_fixed_method_name(size_t i) { return i < NMETHODS ? methods[i].name : NULL; }
const char *dth_fixed_method_doc(const char *name)
{
    const method *m = find(name);
    return m ? m->doc : NULL;
}

int dth_fixed_check(const dth_model *model, const char *name, char *why, size_t len)
{
    const method *m = find(name);
    if (why && len) why[0] = '\0';
    if (!model) return DTH_EINVAL;
    if (!m) {
        if (why && len) snprintf(why, len, "unknown method '%s'", name ? name : "(null)");
        return DTH_ENOTFOUND;
    }
    const dth_model_info *inf = dth_model_get_info(model);
    if (m->k == KIND_VERLET && !inf->separable) {
        if (why && len)
            snprintf(why, len, "method 'verlet' needs a separable H = T(p) + V(q, t); model '%s' is not",
                     dth_model_get_type(model)->name);
        return DTH_EUNSUPPORTED;
    }
    if (m->project && !inf->autonomous) {
        if (why && len)
            snprintf(why, len, "method '%s' projects onto a conserved energy; model '%s' is not autonomous",
                     m->name, dth_model_get_type(model)->name);
        return DTH_EUNSUPPORTED;
    }
    return DTH_OK;
}

void dth_fixed_free(dth_fixed *f)
{
    if (!f) return;
    dth_free(f->alloc, f->block);
    dth_free(f->alloc, f->piv);
    dth_free(f->alloc, f);
}

int dth_fixed_new(const dth_model *model, const char *name, double h, const dth_allocator *alloc,
                  dth_fixed **out)
{
    if (!out) return DTH_EINVAL;
    *out = NULL;
    if (!model || !name || !isfinite(h) || h == 0) return DTH_EINVAL;
    int rc = dth_fixed_check(model, name, NULL, 0);
    if (rc) return rc;
    dth_fixed *f = dth_calloc(alloc, 1, sizeof *f);
    if (!f) return DTH_ENOMEM;
    f->model = model;
    f->alloc = alloc;
    f->m = find(name);
    f->h = h;
    f->n = dth_model_dof(model);
    f->d = 2 * f->n + 1;
    size_t s = (size_t)f->m->s, d = f->d;
    f->M = f->m->k == KIND_GAUSS ? s * d : 0;
    size_t M = f->M, gauss = f->m->k == KIND_GAUSS; /* only the implicit methods need Jacobians */
    size_t sizes[] = {d, d, s * d, s * d, d, s * d, d, gauss * d * d, gauss * s * d * d, M * M, M, M, d, f->n};
    size_t nd = 0;
    for (size_t i = 0; i < sizeof sizes / sizeof sizes[0]; i++) nd += sizes[i];
    f->block = dth_calloc(alloc, nd, sizeof(double));
    f->piv = dth_calloc(alloc, M ? M : 1, sizeof(int));
    if (!f->block || !f->piv) {
        dth_fixed_free(f);
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

int dth_fixed_set_h(dth_fixed *f, double h)
{
    if (!f || !isfinite(h) || h == 0) return DTH_EINVAL;
    if (f->have_prev) /* stage offsets scale with h: keep the predictor consistent */
        for (size_t k = 0; k < (size_t)f->m->s * f->d; k++) f->Zp[k] *= h / f->h;
    f->h = h;
    return DTH_OK;
}

const double *dth_fixed_state(const dth_fixed *f) { return f->y; }
long dth_fixed_steps(const dth_fixed *f) { return f->steps; }
double dth_fixed_h(const dth_fixed *f) { return f->h; }
const dth_model *dth_fixed_model(const dth_fixed *f) { return f->model; }
const char *dth_fixed_name(const dth_fixed *f) { return f->m->name; }
int dth_fixed_order(const dth_fixed *f) { return f->m->order; }
const char *dth_fixed_errmsg(const dth_fixed *f) { return f->errmsg; }

int dth_fixed_start(dth_fixed *f, const double *q0, const double *p0, double t0)
{
    if (!f || !q0 || !p0 || !isfinite(t0)) return DTH_EINVAL;
    size_t n = f->n, d = f->d;
    for (size_t i = 0; i < n; i++)
        if (!isfinite(q0[i]) || !isfinite(p0[i])) {
            seterr(f, "initial value %zu is not finite", i);
            return DTH_EINVAL;
        }
    double *y = f->Y, E;
    memcpy(y, q0, n * sizeof *y);
    y[n] = t0;
    memcpy(y + n + 1, p0, n * sizeof *y);
    int rc = dth_model_eval(f->model, y, DTH_EVAL_H, &E, NULL, NULL);
    if (rc) {
        seterr(f, "model evaluation failed at the initial state: %s", dth_strerror(rc));
        return rc;
    }
    memcpy(f->y, y, d * sizeof *y);
    memset(f->ylo, 0, d * sizeof *y);
    f->E0 = E;
    f->started = 1;
    f->have_prev = 0;
    f->have_force = 0;
    f->steps = 0;
    return DTH_OK;
}

/* Error-free sum: s + e == a + b exactly (Knuth's TwoSum). */
static inline double two_sum(double a, double b, double *e)
{
    double s = a + b, bb = s - a;
    *e = (a - (s - bb)) + (b - bb);
    return s;
}

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

int dth_fixed_step(dth_fixed *f, dth_fixed_info *info)
{
    dth_fixed_info tmp;
    if (!info) info = &tmp;
    memset(info, 0, sizeof *info);
    if (!f) return DTH_EINVAL;
    if (!f->started) {
        seterr(f, "dth_fixed_step before dth_fixed_start");
        return DTH_EINVAL;
    }
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
    return DTH_OK;
}

int dth_step_floor(const dth_model *model, const double *z, double rel_tol, double *h_min, double *work)
{
    if (!model || !z || !h_min || !work || !(rel_tol > 0 && rel_tol <= 1)) return DTH_EINVAL;
    size_t n = dth_model_dof(model), d = 2 * n + 1;
    double Hp, psi;
    double *g = work; /* the first d doubles; dth_model_psi uses the whole of work afterwards */
    int rc = dth_model_eval(model, z, DTH_EVAL_H | DTH_EVAL_GRAD, &Hp, g, NULL);
    if (rc) return rc;
    double S = fabs(z[d]) + fabs(Hp);
    for (size_t j = 0; j < d; j++) S += fabs(g[j] * z[j]);
    rc = dth_model_psi(model, z, &psi, NULL, work);
    if (rc) return rc;
    if (psi == 0) {
        *h_min = INFINITY;
        return DTH_ESINGULAR;
    }
    *h_min = sqrt(4 * DBL_EPSILON * S / (fabs(psi) * rel_tol));
    return DTH_OK;
}

int dth_step_ceiling(const dth_model *model, const double *z, double *h_max, double *work)
{
    if (!model || !z || !h_max || !work) return DTH_EINVAL;
    double psi, dpsi;
    int rc = dth_model_psi(model, z, &psi, &dpsi, work);
    if (rc) return rc;
    if (psi == 0) {
        *h_max = 0;
        return DTH_ESINGULAR;
    }
    *h_max = dpsi != 0 ? 1.2 * fabs(psi / dpsi) : INFINITY;
    return DTH_OK;
}
