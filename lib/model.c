/* SPDX-License-Identifier: MIT */
/*
 * Model instances, psi and psi' (paper, Lemmas g_lambda and g_taylor), a finite-difference
 * model checker, and parameter-parsing helpers for model writers.
 */
#include <errno.h>
#include <float.h>
#include <math.h>
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <stdint.h>
#include <string.h>
#include "dth_internal.h"

struct dth_model {
    const dth_model_type *type; /* &t: the table as this library's layout */
    dth_model_type t;           /* the caller's table, checked and copied (members past its size: NULL) */
    void *self;
    dth_model_info info;
    const dth_allocator *alloc;
    unsigned long long quad_mask; /* bit j: invariant j is (at most) quadratic in (q, p) */
};

void dth__set_err(char *err, size_t len, const char *fmt, ...)
{
    if (!err || !len) return;
    va_list ap;
    va_start(ap, fmt);
    vsnprintf(err, len, fmt, ap);
    va_end(ap);
}

static int spec_accepts(const dth_model_type *t, const char *key)
{
    for (size_t i = 0; i < t->n_params; i++) {
        const char *k = t->params[i].key;
        size_t len = strlen(k);
        if (len && k[len - 1] == '*') {
            if (strncmp(k, key, len - 1) == 0) return 1;
        } else if (strcmp(k, key) == 0) {
            return 1;
        }
    }
    return 0;
}

int dth__model_accepts_key(const dth_model_type *t, const char *key) { return spec_accepts(t, key); }

/*
 * Which invariants are (at most) quadratic in (q, p), for the kicked segment's projection
 * (regularize.c: the midpoint identity keeps exactly those). Decided once per instance, so that the
 * projection cannot switch along a trajectory: the third difference along two directions must be
 * at round-off at every probe point where the invariants evaluate (three points in [0.25, 1.25]^d
 * for models defined on a positive orthant, three in [-1, 1]^d; t = 0), and at least two points
 * must evaluate. A non-polynomial invariant passes only if its third differences vanish at all of
 * them. Invariants beyond the 64th are never projected.
 */
static int probe_quadratic(const dth_model *m, unsigned long long *mask)
{
    *mask = 0;
    const dth_model_type *t = m->type;
    size_t ni = (t->n_invariants && t->invariants) ? t->n_invariants(m->self) : 0, n = m->info.n, d = 2 * n + 1;
    if (!ni) return DTH_OK;
    if (ni > 64) ni = 64;
    size_t nall = t->n_invariants(m->self);
    double *buf = dth_calloc(m->alloc, 3 * d + 2 * nall, sizeof *buf);
    if (!buf) return DTH_ENOMEM;
    double *y0 = buf, *v = buf + d, *ys = buf + 2 * d, *I = buf + 3 * d, *D = I + nall;
    unsigned long long seed = 0x9E3779B97F4A7C15ull, pass = (ni == 64) ? ~0ull : ((1ull << ni) - 1);
    int valid = 0;
    const double c4[4] = {-1.5, -0.5, 0.5, 1.5}, w4[4] = {-1, 3, -3, 1};
    for (int pt = 0; pt < 6; pt++) {
        for (size_t i = 0; i < d; i++) {
            seed = seed * 6364136223846793005ull + 1442695040888963407ull;
            double u = (double)(seed >> 11) * 0x1.0p-53; /* [0, 1) */
            y0[i] = i == n ? 0 : (pt < 3 ? 0.25 + u : 2 * u - 1);
        }
        int ok = 1;
        unsigned long long here = pass;
        for (int dir = 0; dir < 2 && ok; dir++) {
            for (size_t i = 0; i < d; i++) {
                seed = seed * 6364136223846793005ull + 1442695040888963407ull;
                v[i] = i == n ? 0 : 0.05 * ((double)(seed >> 11) * 0x1.0p-52 - 1);
            }
            double mag[64] = {0};
            for (size_t j = 0; j < nall; j++) D[j] = 0;
            for (int k = 0; k < 4 && ok; k++) {
                for (size_t i = 0; i < d; i++) ys[i] = y0[i] + c4[k] * v[i];
                if (t->invariants(m->self, ys, I) != 0) ok = 0;
                for (size_t j = 0; ok && j < ni; j++) {
                    if (!isfinite(I[j])) ok = 0;
                    D[j] += w4[k] * I[j];
                    mag[j] += fabs(I[j]);
                }
            }
            for (size_t j = 0; ok && j < ni; j++)
                if (!(fabs(D[j]) <= 1e3 * DBL_EPSILON * mag[j])) here &= ~(1ull << j);
        }
        if (!ok) continue;
        valid++;
        pass &= here;
    }
    dth_free(m->alloc, buf);
    *mask = valid >= 2 ? pass : 0;
    return DTH_OK;
}

unsigned long long dth__model_quad_mask(const dth_model *m) { return m ? m->quad_mask : 0; }

int dth_model_type_check(const dth_model_type *t, char *err, size_t errlen)
{
    if (!t) {
        dth__set_err(err, errlen, "no model table (NULL)");
        return DTH_EINVAL;
    }
    int rc = dth__abi_check(t->abi, t->size, 2, DTH_MODEL_TYPE_VERSION, sizeof *t, "model", err, errlen);
    if (rc) return rc;
    if (!t->name || !t->name[0] || !t->create || !t->eval) {
        dth__set_err(err, errlen, "model table '%s' lacks %s", t->name && t->name[0] ? t->name : "(unnamed)",
                     !t->name || !t->name[0] ? "a name" : !t->create ? "its create callback" : "its eval callback");
        return DTH_EINVAL;
    }
    return DTH_OK;
}

int dth_model_new(const dth_model_type *utype, const dth_kv *kv, size_t nkv, size_t n_hint,
                  const dth_allocator *alloc, dth_model **out, char *err, size_t errlen)
{
    if (out) *out = NULL;
    if (!out || (nkv && !kv)) {
        dth__set_err(err, errlen, "invalid arguments to dth_model_new");
        return DTH_EINVAL;
    }
    if (dth_model_type_check(utype, err, errlen)) return DTH_EINVAL;
    dth_model_type tcopy;
    dth__table_copy(&tcopy, sizeof tcopy, utype, utype->size);
    const dth_model_type *type = &tcopy;
    for (size_t i = 0; i < nkv; i++) {
        if (!kv[i].key || !kv[i].value) {
            dth__set_err(err, errlen, "parameter %zu has no key or value", i);
            return DTH_EINVAL;
        }
        if (!spec_accepts(type, kv[i].key)) {
            dth__set_err(err, errlen, "model '%s' has no parameter '%s'", type->name, kv[i].key);
            return DTH_EINVAL;
        }
    }
    dth_model *m = dth_calloc(alloc, 1, sizeof *m);
    if (!m) {
        dth__set_err(err, errlen, "out of memory");
        return DTH_ENOMEM;
    }
    m->t = tcopy;
    m->type = &m->t;
    type = m->type;
    m->alloc = alloc;
    dth_model_args args = {kv, nkv, n_hint, alloc, err, errlen};
    if (err && errlen) err[0] = '\0';
    int rc = type->create(&args, &m->self, &m->info);
    if (rc == DTH_OK && !m->self && type->n_params > 0) {
        /* a model with parameters keeps them in its instance: none is a bug of the model (its eval
         * would read through NULL); stateless models without parameters may leave self NULL */
        dth__set_err(err, errlen, "create succeeded without an instance (*self = NULL), but the model has "
                     "parameters to keep in one: a bug in the model");
        rc = DTH_EINVAL;
    }
    if (rc == DTH_OK && (m->info.n == 0 || m->info.n > DTH__MAX_DOF)) {
        dth__set_err(err, errlen, "model '%s' reported %zu degrees of freedom (1 to 2^40 supported)", type->name,
                     m->info.n);
        rc = DTH_EINVAL;
    }
    size_t ninv = rc == DTH_OK && type->n_invariants && type->invariants ? type->n_invariants(m->self) : 0;
    if (ninv > DTH__MAX_INVARIANTS) {
        dth__set_err(err, errlen, "model '%s' reported %zu invariants (at most %zu supported)", type->name, ninv,
                     DTH__MAX_INVARIANTS);
        rc = DTH_EINVAL;
    }
    for (size_t i = 0; rc == DTH_OK && i < ninv; i++) {
        /* the names are columns of CSV files: present, not empty, no separators or control characters */
        const char *nm = type->invariant_name ? type->invariant_name(m->self, i) : NULL;
        int ok = nm && nm[0];
        for (const char *c = nm; ok && *c; c++) ok = *c != ',' && *c != '"' && (unsigned char)*c >= 0x20;
        if (!ok) {
            dth__set_err(err, errlen, "invariant %zu of %zu has %s (invariant_name returned %s%s%s)", i + 1, ninv,
                         nm && nm[0] ? "a name that cannot be a CSV column" : "no name",
                         nm ? "'" : "NULL", nm ? nm : "", nm ? "'" : "");
            rc = DTH_EINVAL;
        }
    }
    if (rc == DTH_OK && m->info.bandwidth >= 2 * m->info.n && (m->info.hess_kind == DTH_HESS_BANDED)) {
        dth__set_err(err, errlen, "model '%s' reported a Hessian bandwidth of %zu for %zu degrees of freedom",
                     type->name, m->info.bandwidth, m->info.n);
        rc = DTH_EINVAL;
    }
    if (rc != DTH_OK) {
        if (m->self && type->destroy) type->destroy(m->self, alloc);
        dth_free(alloc, m); /* type pointed into m: the caller's table names the model */
        if (err && errlen && !err[0]) dth__set_err(err, errlen, "model '%s': %s", utype->name, dth_strerror(rc));
        return rc < 0 ? rc : DTH_EINVAL;
    }
    if (rc == DTH_OK && probe_quadratic(m, &m->quad_mask) != DTH_OK) {
        dth__set_err(err, errlen, "out of memory");
        rc = DTH_ENOMEM;
    }
    if (rc != DTH_OK) {
        if (m->self && type->destroy) type->destroy(m->self, alloc);
        dth_free(alloc, m);
        return rc;
    }
    *out = m;
    return DTH_OK;
}

void dth_model_free(dth_model *m)
{
    if (!m) return;
    if (m->type->destroy) m->type->destroy(m->self, m->alloc);
    dth_free(m->alloc, m);
}

const dth_model_info *dth_model_get_info(const dth_model *m) { return m ? &m->info : NULL; }
const dth_model_type *dth_model_get_type(const dth_model *m) { return m ? m->type : NULL; }
size_t dth_model_dof(const dth_model *m) { return m ? m->info.n : 0; }
const void *dth__model_self(const dth_model *m) { return m->self; }

size_t dth_model_n_invariants(const dth_model *m)
{
    return (m && m->type->n_invariants && m->type->invariants) ? m->type->n_invariants(m->self) : 0;
}

const char *dth_model_invariant_name(const dth_model *m, size_t i)
{
    return i < dth_model_n_invariants(m) && m->type->invariant_name ? m->type->invariant_name(m->self, i) : NULL;
}

int dth_model_invariants(const dth_model *m, const double *y, double *out)
{
    if (!m || !y || !out) return DTH_EINVAL;
    if (!dth_model_n_invariants(m)) return DTH_EUNSUPPORTED;
    int rc = m->type->invariants(m->self, y, out);
    return rc > 0 ? DTH_EDOMAIN : rc < 0 ? DTH_EMODEL : DTH_OK;
}

int dth_model_exact(const dth_model *m, const double *y0, double t, double *y)
{
    if (!m || !y0 || !y || !isfinite(t)) return DTH_EINVAL;
    if (!m->type->exact) return DTH_EUNSUPPORTED;
    int rc = m->type->exact(m->self, y0, t, y);
    return rc > 0 ? DTH_EDOMAIN : rc < 0 ? DTH_EMODEL : DTH_OK;
}

static int all_finite(const double *v, size_t n)
{
    for (size_t i = 0; i < n; i++)
        if (!isfinite(v[i])) return 0;
    return 1;
}

int dth_model_eval(const dth_model *m, const double *y, unsigned what, double *H, double *grad,
                   double *hess)
{
    size_t d = 2 * m->info.n + 1;
    int rc = m->type->eval(m->self, y, what, H, grad, hess);
    if (rc > 0) return DTH_EDOMAIN;
    if (rc < 0) return DTH_EMODEL;
    if ((what & DTH_EVAL_H) && !isfinite(*H)) return DTH_EDOMAIN;
    if ((what & DTH_EVAL_GRAD) && !all_finite(grad, d)) return DTH_EDOMAIN;
    if ((what & DTH_EVAL_HESS) && !all_finite(hess, d * d)) return DTH_EDOMAIN;
    return DTH_OK;
}

int dth__model_eval_raw(const dth_model *m, const double *y, unsigned what, double *H, double *grad, double *hess)
{
    int rc = m->type->eval(m->self, y, what, H, grad, hess);
    if (rc > 0) return DTH_EDOMAIN;
    if (rc < 0) return DTH_EMODEL;
    if ((what & DTH_EVAL_H) && !isfinite(*H)) return DTH_EDOMAIN;
    if ((what & DTH_EVAL_GRAD) && !all_finite(grad, 2 * m->info.n + 1)) return DTH_EDOMAIN;
    return DTH_OK;
}

int dth__model_hdiff(const dth_model *m, const double *y1, const double *y0, double *work, double *dH)
{
    if (m->type->hdiff) {
        int rc = m->type->hdiff(m->self, y1, y0, dH);
        if (rc) return rc > 0 ? DTH_EDOMAIN : DTH_EMODEL;
        return isfinite(*dH) ? DTH_OK : DTH_EDOMAIN;
    }
    /* 4-point Gauss-Legendre on the segment, centred: nodes c +- s h with c = (y0 + y1)/2 and
     * h = (y1 - y0)/2 (both exact to swap: c is symmetric, h changes sign), pairs summed in one
     * order, so swapping y1 and y0 negates the result exactly */
    static const double s4[2] = {0.33998104358485626480, 0.86113631159405257522};
    static const double w4[2] = {0.65214515486254614263, 0.34785484513745385737};
    size_t d = 2 * m->info.n + 1;
    double *y = work, *g = work + d, acc = 0;
    for (int k = 0; k < 2; k++) {
        double pair = 0;
        for (int sg = 0; sg < 2; sg++) {
            double sk = sg ? -s4[k] : s4[k];
            for (size_t j = 0; j < d; j++) y[j] = 0.5 * (y0[j] + y1[j]) + sk * (0.5 * (y1[j] - y0[j]));
            int rc = dth_model_eval(m, y, DTH_EVAL_GRAD, NULL, g, NULL);
            if (rc) return rc;
            double dot = 0;
            for (size_t j = 0; j < d; j++) dot += g[j] * (0.5 * (y1[j] - y0[j]));
            pair += dot;
        }
        acc += w4[k] * pair;
    }
    *dH = acc;
    return DTH_OK;
}

int dth__model_banded(const dth_model *m)
{
    return m->info.hess_kind == DTH_HESS_BANDED && m->type->hess_band && m->info.autonomous;
}

int dth__model_hess_band(const dth_model *m, const double *y, double *band)
{
    int rc = m->type->hess_band(m->self, y, band);
    if (rc > 0) return DTH_EDOMAIN;
    if (rc < 0) return DTH_EMODEL;
    return all_finite(band, 2 * m->info.n * (2 * m->info.bandwidth + 1)) ? DTH_OK : DTH_EDOMAIN;
}

int dth__model_hess_band_raw(const dth_model *m, const double *y, double *band)
{
    int rc = m->type->hess_band(m->self, y, band);
    return rc > 0 ? DTH_EDOMAIN : rc < 0 ? DTH_EMODEL : DTH_OK;
}

/* Doubles of the Hessian that psi evaluates: the band for banded models, else dense. */
static size_t hess_size(const dth_model *m)
{
    size_t n = m->info.n, d = 2 * n + 1;
    return dth__model_banded(m) ? 2 * n * (2 * m->info.bandwidth + 1) : d * d;
}

/* Name of entry i of y = (q, t, p): "q3", "t", "p1". */
static void yname(size_t n, size_t i, char *buf, size_t len)
{
    if (i < n) snprintf(buf, len, "q%zu", i + 1);
    else if (i == n) snprintf(buf, len, "t");
    else snprintf(buf, len, "p%zu", i - n);
}

int dth_model_domain_check(const dth_model *m, const double *y, char *why, size_t len)
{
    if (why && len) why[0] = '\0';
    if (!m || !y) return DTH_EINVAL;
    size_t n = m->info.n, d = 2 * n + 1;
    char name[24];
    for (size_t j = 0; j < d; j++)
        if (!isfinite(y[j])) {
            yname(n, j, name, sizeof name);
            dth__set_err(why, len, "%s = %g is not finite", name, y[j]);
            return DTH_EDOMAIN;
        }
    double *g = dth_calloc(m->alloc, d, sizeof *g), H = 0;
    if (!g) return DTH_ENOMEM;
    int rc = m->type->eval(m->self, y, DTH_EVAL_H | DTH_EVAL_GRAD, &H, g, NULL);
    if (rc < 0) {
        dth__set_err(why, len, "the model's evaluation failed (%d)", rc);
        rc = DTH_EMODEL;
    } else if (rc > 0 || !isfinite(H)) {
        rc = DTH_EDOMAIN;
    } else {
        for (size_t j = 0; j < d && !rc; j++)
            if (!isfinite(g[j])) {
                rc = DTH_EDOMAIN;
                yname(n, j, name, sizeof name);
                dth__set_err(why, len, "dH/d%s is not finite", name);
            }
    }
    if (rc == DTH_EDOMAIN && (!why || !len || !why[0] || m->type->domain)) {
        char own[160] = "";
        if (m->type->domain && m->type->domain(m->self, y, own, sizeof own) && own[0])
            dth__set_err(why, len, "%s", own);
        else if (!why || !len || !why[0])
            dth__set_err(why, len, "%s", isfinite(H) ? "outside the model's domain" : "H is not finite");
    }
    dth_free(m->alloc, g);
    return rc;
}

size_t dth_model_work_size(const dth_model *m)
{
    size_t d = 2 * m->info.n + 1;
    return hess_size(m) + 4 * d;
}

/* u = J grad H restricted to y = (q, t, p): (dH/dp, 1, -dH/dq). */
void dth__flow_y(size_t n, const double *grad, double *u)
{
    for (size_t i = 0; i < n; i++) {
        u[i] = grad[n + 1 + i];
        u[n + 1 + i] = -grad[i];
    }
    u[n] = 1.0;
}

/* v^T A v for a dense symmetric row-major A. */
static double quad_form(size_t d, const double *A, const double *v)
{
    double s = 0;
    for (size_t i = 0; i < d; i++) {
        double r = 0;
        for (size_t j = 0; j < d; j++) r += A[i * d + j] * v[j];
        s += v[i] * r;
    }
    return s;
}

/* u^T H u with the Hessian the model was evaluated for (banded: the t row/column is zero). */
static double hess_form(const dth_model *m, const double *hess, const double *u)
{
    size_t n = m->info.n, d = 2 * n + 1;
    if (!dth__model_banded(m)) return quad_form(d, hess, u);
    size_t w = m->info.bandwidth, bw = 2 * w + 1, nn = 2 * n;
    double acc = 0;
    for (size_t a = 0; a < nn; a++) {
        size_t lo = a > w ? a - w : 0, hi = a + w < nn - 1 ? a + w : nn - 1;
        double r = 0;
        for (size_t b = lo; b <= hi; b++) r += hess[a * bw + b + w - a] * u[(b & 1) ? n + 1 + b / 2 : b / 2];
        acc += u[(a & 1) ? n + 1 + a / 2 : a / 2] * r;
    }
    return acc;
}

/* The Hessian psi needs at y: banded or dense. */
static int psi_hess(const dth_model *m, const double *y, double *hess)
{
    if (dth__model_banded(m)) return dth__model_hess_band(m, y, hess);
    return dth_model_eval(m, y, DTH_EVAL_HESS, NULL, NULL, hess);
}

int dth_model_psi(const dth_model *m, const double *y, double *psi, double *dpsi, double *work)
{
    size_t n = m->info.n, d = 2 * n + 1;
    double *hess = work, *grad = work + hess_size(m), *u = grad + d, *ys = u + d;
    double H;
    int band = dth__model_banded(m);
    int rc = dth_model_eval(m, y, DTH_EVAL_GRAD | (band ? 0u : DTH_EVAL_HESS), &H, grad, hess);
    if (!rc && band) rc = dth__model_hess_band(m, y, hess);
    if (rc) return rc;
    dth__flow_y(n, grad, u);
    if (psi) *psi = hess_form(m, hess, u);
    if (!dpsi) return DTH_OK;
    /* psi' = [psi, H] = D^3 H[u, u, u]: the term 2 (H_zz u)^T J (H_zz u) vanishes (J skew). */
    if (m->type->third) {
        double d3;
        int r3 = m->type->third(m->self, y, u, &d3);
        if (r3 > 0) return DTH_EDOMAIN;
        if (r3 < 0) return DTH_EMODEL;
        if (!isfinite(d3)) return DTH_EDOMAIN;
        *dpsi = d3;
        return DTH_OK;
    }
    /* Central difference of u^T H_yy(y + e u) u in e with u fixed: error O(e^2) + eps/e. */
    double ynorm = 0, unorm = 0;
    for (size_t i = 0; i < d; i++) {
        if (i != n) ynorm = fmax(ynorm, fabs(y[i])); /* (q, p): the time's size sets no step */
        unorm = fmax(unorm, fabs(u[i]));
    }
    double e = cbrt(DBL_EPSILON) * fmax(ynorm, 1.0) / unorm;
    double f[2];
    for (int s = 0; s < 2; s++) {
        double sg = s ? -1.0 : 1.0;
        for (size_t i = 0; i < d; i++) ys[i] = y[i] + sg * e * u[i];
        rc = psi_hess(m, ys, hess);
        if (rc) return rc;
        f[s] = hess_form(m, hess, u);
    }
    *dpsi = (f[0] - f[1]) / (2 * e);
    return DTH_OK;
}

/* ---------------------------------------------------------------- model checker */

/* The verdict: pass when every mismatch is within the threshold; the message names the worst, and
 * what the optional hdiff and third would save where the model has not got them (the fallbacks: a
 * 4-point Gauss-Legendre rule on the gradient for each of about 2 differences of H a DTH step, 10 a
 * composite step of order 4; a difference of 2 Hessians for psi'; bench/bench_fallback prints the
 * counts and the cost: the Henon-Heiles user model steps 1.6x faster with both, 1.3x at order 4). */
static void check_verdict(const dth_model *m, size_t n, dth_model_check_report *rep)
{
    double tol = rep->tol;
    char a[24], b[24], entry[64];
    const char *what = "gradient";
    double worst = rep->grad_err;
    yname(n, rep->grad_idx, a, sizeof a);
    snprintf(entry, sizeof entry, "dH/d%s", a);
    if (rep->hess_err > worst) {
        worst = rep->hess_err;
        what = "Hessian";
        yname(n, rep->hess_i, a, sizeof a);
        yname(n, rep->hess_j, b, sizeof b);
        snprintf(entry, sizeof entry, "d2H/d%s d%s", a, b);
    }
    if (rep->sym_err > worst) {
        worst = rep->sym_err, what = "Hessian symmetry";
        snprintf(entry, sizeof entry, "H_ij - H_ji");
    }
    if (rep->third_err > worst) {
        worst = rep->third_err, what = "third derivative";
        snprintf(entry, sizeof entry, "D3H[u,u,u]");
    }
    if (rep->band_err > worst) {
        worst = rep->band_err, what = "banded Hessian";
        snprintf(entry, sizeof entry, "hess_band");
    }
    rep->pass = worst <= tol;
    const char *add = "";
    if (!m->type->hdiff && !m->type->third)
        add = "; add hdiff, third: -8 gradients, -3 Hessians a step (Henon-Heiles: 1.6x faster)";
    else if (!m->type->hdiff)
        add = "; add hdiff: -8 gradients a step (Henon-Heiles: 1.1x faster, 1.3x at order 4)";
    else if (!m->type->third)
        add = "; add third: -3 Hessians a step (Henon-Heiles: 1.3x faster)";
    snprintf(rep->message, sizeof rep->message, "%s: worst %s %s mismatches finite differences by %.2g (relative; threshold %.1e)",
             rep->pass ? "pass" : "FAIL", what, entry, worst, tol);
    size_t l = strlen(rep->message);
    if (l + strlen(add) < sizeof rep->message) memcpy(rep->message + l, add, strlen(add) + 1);
}

/*
 * dth_model_check's guarded evaluation: every output the model writes (gradient, Hessian, third
 * derivative, banded Hessian, invariants) in its own slice of one block with a canary of GUARD
 * doubles (a NaN payload) before and after each, so that a model writing past an output, or before
 * it, is named (outputs of a run are slices of one block with no gap: such a write would silently
 * change another output). Returns 1 and the message in `what` when a canary was touched.
 */
enum { GUARD = 8 };
static const uint64_t canary_bits = 0x7ff4dead5eedbeefULL;

static void canary_fill(double *p)
{
    for (int i = 0; i < GUARD; i++) memcpy(&p[i], &canary_bits, sizeof canary_bits);
}

static int canary_ok(const double *p)
{
    for (int i = 0; i < GUARD; i++)
        if (memcmp(&p[i], &canary_bits, sizeof canary_bits)) return 0;
    return 1;
}

static int guarded_eval(const dth_model *m, const double *y, char *what, size_t len)
{
    size_t n = m->info.n, d = 2 * n + 1, nb = 0, ni = m->type->n_invariants && m->type->invariants ? m->type->n_invariants(m->self) : 0;
    if (m->info.hess_kind == DTH_HESS_BANDED && m->type->hess_band) nb = 2 * n * (2 * m->info.bandwidth + 1);
    size_t sizes[5] = {d, d * d, 1, nb, ni};
    const char *names[5] = {"gradient (2n+1 doubles)", "Hessian ((2n+1)^2 doubles)", "third derivative (1 double)",
                            "banded Hessian (2n (2w+1) doubles)", "invariants (n_invariants doubles)"};
    size_t total = GUARD;
    for (int k = 0; k < 5; k++) total += sizes[k] + GUARD;
    double *blk = dth_calloc(m->alloc, total, sizeof(double)), *out[5], *u = NULL, H;
    if (!blk) return -1;
    double *p = blk;
    canary_fill(p);
    p += GUARD;
    for (int k = 0; k < 5; k++) {
        out[k] = p;
        p += sizes[k];
        canary_fill(p);
        p += GUARD;
    }
    u = dth_calloc(m->alloc, d, sizeof *u);
    int bad = -1;
    if (u) {
        (void)m->type->eval(m->self, y, DTH_EVAL_H | DTH_EVAL_GRAD | DTH_EVAL_HESS, &H, out[0], out[1]);
        dth__flow_y(n, out[0], u);
        if (m->type->third) (void)m->type->third(m->self, y, u, out[2]);
        if (nb) (void)m->type->hess_band(m->self, y, out[3]);
        if (ni) (void)m->type->invariants(m->self, y, out[4]);
        bad = 0;
        for (int k = 0; k < 5 && !bad; k++)
            if (!canary_ok(out[k] - GUARD) || !canary_ok(out[k] + sizes[k])) {
                snprintf(what, len, "FAIL: model '%s' wrote %s its %s", m->type->name,
                         canary_ok(out[k] - GUARD) ? "past the end of" : "before the start of", names[k]);
                bad = 1;
            }
    }
    dth_free(m->alloc, u);
    dth_free(m->alloc, blk);
    return bad;
}

/* dth_model_check's third-derivative check: D^3 H[u,u,u] against a difference of the Hessian form
 * along u = J grad H held fixed. */
static int check_third(const dth_model *m, const double *y, const double *grad, double hscale, double *u, double *yy,
                       double *hp, dth_model_check_report *rep)
{
    size_t n = m->info.n, d = 2 * n + 1;
    int rc = DTH_OK;
    /* Compare D^3 H[u,u,u] with a difference of the Hessian form along a fixed direction. */
    dth__flow_y(n, grad, u);
    double unorm = 0, ynorm = 0, d3 = 0, f[2];
    for (size_t i = 0; i < d; i++) {
        unorm = fmax(unorm, fabs(u[i]));
        if (i != n) ynorm = fmax(ynorm, fabs(y[i])); /* (q, p): the time's size sets no step */
    }
    double e = cbrt(DBL_EPSILON) * fmax(ynorm, 1.0) / unorm, fd = 0;
    int r3 = m->type->third(m->self, y, u, &d3);
    if (r3) rc = r3 > 0 ? DTH_EDOMAIN : DTH_EMODEL;
    double sc3 = hscale * unorm * unorm * unorm / fmax(ynorm, 1.0);
    /* differences at e and e/2, Richardson-extrapolated; e divided by 4 while they disagree
     * by more than the threshold (at most 8 times), as for the gradient and the Hessian */
    for (int shrink = 0; !rc; shrink++) {
        double f2[2];
        for (int s = 0; s < 4 && !rc; s++) {
            double es = (s & 1 ? -e : e) * (s & 2 ? 0.5 : 1.0);
            for (size_t i = 0; i < d; i++) yy[i] = y[i] + es * u[i];
            rc = dth_model_eval(m, yy, DTH_EVAL_HESS, NULL, NULL, hp);
            if (!rc) (s & 2 ? f2 : f)[s & 1] = quad_form(d, hp, u);
        }
        if (rc) break;
        double a = (f[0] - f[1]) / (2 * e), b = (f2[0] - f2[1]) / e;
        fd = (4 * b - a) / 3;
        if (fabs(a - b) <= rep->tol * fmax(fmax(fabs(fd), fabs(d3)), sc3) || shrink == 8) break;
        e *= 0.25;
    }
    if (!rc) rep->third_err = fabs(fd - d3) / fmax(fmax(fabs(fd), fabs(d3)), sc3);
    return rc;
}

/* dth_model_check's banded Hessian against the dense one. */
static int check_band(const dth_model *m, const double *y, const double *hess, double hscale, dth_model_check_report *rep)
{
    size_t n = m->info.n, d = 2 * n + 1;
    int rc = DTH_OK;
    size_t w = m->info.bandwidth, bw = 2 * w + 1, nn = 2 * n;
    double *band = dth_calloc(m->alloc, nn * bw, sizeof(double));
    if (!band) rc = DTH_ENOMEM;
    else if (m->type->hess_band(m->self, y, band) != 0) rc = DTH_EMODEL;
    else {
        /* interleaved index x_(2i) = q_i -> y_i, x_(2i+1) = p_i -> y_(n+1+i) */
        for (size_t a = 0; a < nn; a++)
            for (size_t b = 0; b < nn; b++) {
                size_t ya = (a % 2) ? n + 1 + a / 2 : a / 2, yb = (b % 2) ? n + 1 + b / 2 : b / 2;
                double dense = hess[ya * d + yb];
                double bv = 0;
                if ((a > b ? a - b : b - a) <= w) bv = band[a * bw + (b + w - a)];
                rep->band_err = fmax(rep->band_err, fabs(bv - dense) / hscale);
            }
    }
    dth_free(m->alloc, band);
    return rc;
}

/* the block of coordinate i of y = (q, t, p): 0, 1, 2 */
static int blk(size_t n, size_t i) { return i < n ? 0 : i == n ? 1 : 2; }
int dth_model_check(const dth_model *m, const double *y, dth_model_check_report *rep)
{
    if (!m || !y || !rep) return DTH_EINVAL;
    memset(rep, 0, sizeof *rep);
    rep->tol = DTH_MODEL_CHECK_TOL;
    size_t n = m->info.n, d = 2 * n + 1;
    int g = guarded_eval(m, y, rep->message, sizeof rep->message);
    if (g < 0) return DTH_ENOMEM;
    if (g) return DTH_OK; /* pass = 0 and the message name the output overrun */
    double *buf = dth_calloc(m->alloc, 3 * d * d + 9 * d, sizeof(double));
    if (!buf) return DTH_ENOMEM;
    double *hess = buf, *hp = hess + d * d, *hm = hp + d * d;
    double *grad = hm + d * d, *gp = grad + d, *gm = gp + d, *yy = gm + d, *u = yy + d;
    double H, Hp, Hm;
    int rc = dth_model_eval(m, y, DTH_EVAL_H | DTH_EVAL_GRAD | DTH_EVAL_HESS, &H, grad, hess);
    double gscale = 0, hscale = 0;
    for (size_t i = 0; !rc && i < d; i++) gscale = fmax(gscale, fabs(grad[i]));
    for (size_t i = 0; !rc && i < d * d; i++) hscale = fmax(hscale, fabs(hess[i]));
    gscale = fmax(gscale, 1e-300);
    hscale = fmax(hscale, 1e-300);
    double bmax[3][3] = {{0}};
    for (size_t i = 0; !rc && i < d; i++)
        for (size_t j = 0; j < d; j++) {
            double *b = &bmax[blk(n, i)][blk(n, j)];
            *b = fmax(*b, fabs(hess[i * d + j]));
        }
    /* per coordinate, central differences at e and e/2, Richardson-extrapolated (error O(e^4));
     * the step starts at cbrt(eps) max(|y_j|, 1) and is divided by 4 while the two differences
     * disagree by more than the threshold (their difference measures the O(e^2) truncation error:
     * the model's own length scale, e.g. |q| near a Kepler pericentre, is below the start step),
     * at most 8 times (round-off then dominates). */
    double *gp2 = u + d, *gm2 = u + 2 * d, *nz = u + 3 * d; /* past u (the allocation has 9 d) */
    for (size_t j = 0; !rc && j < d; j++) {
        double e = cbrt(DBL_EPSILON) * fmax(fabs(y[j]), 1.0), dg = 0, dg2 = 0;
        for (int shrink = 0;; shrink++) {
            double Hp2, Hm2;
            memcpy(yy, y, d * sizeof *yy);
            yy[j] = y[j] + e;
            if ((rc = dth_model_eval(m, yy, DTH_EVAL_H | DTH_EVAL_GRAD, &Hp, gp, NULL))) break;
            yy[j] = y[j] - e;
            if ((rc = dth_model_eval(m, yy, DTH_EVAL_H | DTH_EVAL_GRAD, &Hm, gm, NULL))) break;
            yy[j] = y[j] + 0.5 * e;
            if ((rc = dth_model_eval(m, yy, DTH_EVAL_H | DTH_EVAL_GRAD, &Hp2, gp2, NULL))) break;
            yy[j] = y[j] - 0.5 * e;
            if ((rc = dth_model_eval(m, yy, DTH_EVAL_H | DTH_EVAL_GRAD, &Hm2, gm2, NULL))) break;
            dg = (Hp - Hm) / (2 * e), dg2 = (Hp2 - Hm2) / e;
            double tr = fabs(dg - dg2) / fmax(gscale, fabs(H) + 1e-300);
            for (size_t i = 0; i < d; i++) {
                double a = (gp[i] - gm[i]) / (2 * e), b = (gp2[i] - gm2[i]) / e;
                tr = fmax(tr, fabs(a - b) / fmax(hscale, gscale));
                /* round-off of the extrapolated quotient: 8 ulps of each gradient value, amplified */
                nz[i] = 8 * DBL_EPSILON * fmax(fmax(fabs(gp[i]), fabs(gm[i])), fmax(fabs(gp2[i]), fabs(gm2[i]))) * (3 / e);
                gp[i] = (4 * b - a) / 3; /* the extrapolated column */
            }
            if (tr <= rep->tol || shrink == 8) break;
            e *= 0.25;
        }
        if (rc) break;
        double ge = fabs((4 * dg2 - dg) / 3 - grad[j]) / fmax(gscale, fabs(H) + 1e-300);
        if (ge > rep->grad_err) {
            rep->grad_err = ge;
            rep->grad_idx = j;
        }
        for (size_t i = 0; i < d; i++) {
            /* each entry against its own magnitude, max(sqrt(|H_ii H_jj|), |H_ij|), at least 1e-3
             * of the largest entry of its block (q, t, p rows and columns: a zero entry whose
             * quotient is round-off passes), after the quotient's own round-off nz */
            double hij = hess[i * d + j], fd = gp[i];
            double sc = fmax(fmax(sqrt(fabs(hess[i * d + i]) * fabs(hess[j * d + j])), fabs(hij)),
                             1e-3 * bmax[blk(n, i)][blk(n, j)]);
            double dev = fmax(fabs(fd - hij) - nz[i], 0.0);
            double he = sc > 0 ? dev / sc : 0;
            if (he > rep->hess_err) {
                rep->hess_err = he;
                rep->hess_i = i;
                rep->hess_j = j;
            }
        }
    }
    for (size_t i = 0; !rc && i < d; i++)
        for (size_t j = 0; j < i; j++)
            rep->sym_err = fmax(rep->sym_err, fabs(hess[i * d + j] - hess[j * d + i]) / hscale);
    if (!rc && m->type->third) rc = check_third(m, y, grad, hscale, u, yy, hp, rep);
    if (!rc && m->info.hess_kind == DTH_HESS_BANDED && m->type->hess_band) rc = check_band(m, y, hess, hscale, rep);
    dth_free(m->alloc, buf);
    if (!rc) check_verdict(m, n, rep);
    return rc;
}

/* ---------------------------------------------------------------- parameter helpers */

int dth_parse_double(const char *s, double *out)
{
    if (!s) return -1;
    while (*s == ' ' || *s == '\t') s++;
    if (!*s) return -1;
    char *end;
    errno = 0;
    double v = strtod(s, &end);
    if (end == s) return -1;
    while (*end == ' ' || *end == '\t') end++;
    if (*end) return -1;
    if (!isfinite(v)) return -1;
    if (errno == ERANGE && fabs(v) > 1.0) return -1; /* overflow; underflow to a denormal is fine */
    *out = v;
    return 0;
}

const char *dth_args_get(const dth_model_args *a, const char *key)
{
    const char *v = NULL;
    for (size_t i = 0; a && i < a->nkv; i++)
        if (strcmp(a->kv[i].key, key) == 0) v = a->kv[i].value; /* last one wins */
    return v;
}

int dth_args_error(const dth_model_args *a, const char *fmt, ...)
{
    if (a && a->err && a->errlen) {
        va_list ap;
        va_start(ap, fmt);
        vsnprintf(a->err, a->errlen, fmt, ap);
        va_end(ap);
    }
    return DTH_EINVAL;
}

int dth_args_double(const dth_model_args *a, const char *key, double def, double *out)
{
    const char *v = dth_args_get(a, key);
    if (!v) {
        *out = def;
        return DTH_OK;
    }
    if (dth_parse_double(v, out)) return dth_args_error(a, "parameter '%s': '%s' is not a finite number", key, v);
    return DTH_OK;
}

int dth_args_list(const dth_model_args *a, const char *key, double *out, size_t max, size_t *count)
{
    *count = 0;
    const char *v = dth_args_get(a, key);
    if (!v) return DTH_OK;
    return dth__parse_list(v, out, max, count) ? dth_args_error(a, "parameter '%s': '%s' is not a list of at most %zu finite numbers", key, v, max) : DTH_OK;
}

/* One item of a list: the text from s to stop (a comma or the end), read as dth_parse_double reads a
 * string, in place: an item may be as long as its line (a token buffer once cut it at 127). */
static int parse_item(const char *s, const char *stop, double *out)
{
    while (s < stop && (*s == ' ' || *s == '\t')) s++;
    if (s == stop) return -1;
    char *end;
    errno = 0;
    double v = strtod(s, &end);
    if (end == s || end > stop) return -1;
    while (end < stop && (*end == ' ' || *end == '\t')) end++;
    if (end != stop || !isfinite(v)) return -1;
    if (errno == ERANGE && fabs(v) > 1.0) return -1; /* overflow; underflow to a denormal is fine */
    *out = v;
    return 0;
}

int dth__parse_list(const char *v, double *out, size_t max, size_t *count)
{
    size_t k = 0;
    *count = 0;
    const char *s = v;
    for (;;) {
        const char *c = strchr(s, ',');
        const char *stop = c ? c : s + strlen(s);
        if (k >= max) return -1;
        if (parse_item(s, stop, &out[k])) return -1;
        k++;
        if (!c) break;
        s = c + 1;
    }
    *count = k;
    return 0;
}

size_t dth__model_gpsi_work(const dth_model *m)
{
    size_t d = 2 * m->info.n + 1;
    return dth_model_work_size(m) + d * d + 6 * d;
}

/* D^3 H[u, u, e_i] for every i by polarization of the model's cubic form T(v) = D^3H[v, v, v]:
 * D^3H[u, u, b] = (T(u + b) - T(u - b) - 2 T(b)) / 6 with b = s e_i, s = max |u_i| (no step to choose:
 * exact to the round-off of T, at any |y|). */
static int d3uu_third(const dth_model *m, const double *y, const double *u, double *out, double *v)
{
    size_t d = 2 * m->info.n + 1;
    double s = 0;
    for (size_t i = 0; i < d; i++) s = fmax(s, fabs(u[i]));
    if (!(s > 0)) {
        memset(out, 0, d * sizeof *out);
        return DTH_OK;
    }
    for (size_t i = 0; i < d; i++) {
        if (i == m->info.n && m->info.autonomous) {
            out[i] = 0; /* no t dependence */
            continue;
        }
        double t[3];
        for (int k = 0; k < 3; k++) {
            for (size_t j = 0; j < d; j++) v[j] = k == 2 ? 0 : u[j];
            v[i] += k == 1 ? -s : s;
            int r3 = m->type->third(m->self, y, v, &t[k]);
            if (r3) return r3 > 0 ? DTH_EDOMAIN : DTH_EMODEL;
        }
        out[i] = (t[0] - t[1] - 2 * t[2]) / (6 * s);
        if (!isfinite(out[i])) return DTH_EDOMAIN;
    }
    return DTH_OK;
}

int dth__model_grad_psi(const dth_model *m, const double *y, double *gpsi, double *psi, double *dpsi, double *work)
{
    size_t n = m->info.n, d = 2 * n + 1;
    double *A = work + dth_model_work_size(m), *g = A + d * d, *u = g + d, *ys = u + d, *gp = ys + d, *gm = gp + d,
           *v = gm + d;
    int rc = dth_model_psi(m, y, psi, dpsi, work);
    if (!rc) rc = dth_model_eval(m, y, DTH_EVAL_GRAD | DTH_EVAL_HESS, NULL, g, A);
    if (rc) return rc;
    dth__flow_y(n, g, u);
    if (m->type->third) {
        /* D^3 H[u, u, .] from the model's third derivative (into gm) */
        rc = d3uu_third(m, y, u, gm, ys);
        if (rc) return rc;
    } else {
        /* D^3 H[u, u, .] by the second difference of the gradient along u (error O(e^2) + eps / e^2; the step
         * grows with |y|, so it is coarse where |q| is large, e.g. angles after many turns: give the model
         * `third`) */
        double ynorm = 1, unorm = 0;
        for (size_t i = 0; i < d; i++) {
            if (i != n) ynorm = fmax(ynorm, fabs(y[i])); /* (q, p): the time's size sets no step */
            unorm = fmax(unorm, fabs(u[i]));
        }
        double e = sqrt(sqrt(DBL_EPSILON)) * ynorm / unorm;
        for (size_t i = 0; i < d; i++) ys[i] = y[i] + e * u[i];
        rc = dth_model_eval(m, ys, DTH_EVAL_GRAD, NULL, gp, NULL);
        for (size_t i = 0; !rc && i < d; i++) ys[i] = y[i] - e * u[i];
        if (!rc) rc = dth_model_eval(m, ys, DTH_EVAL_GRAD, NULL, gm, NULL);
        if (rc) return rc;
        for (size_t i = 0; i < d; i++) gm[i] = (gp[i] - 2 * g[i] + gm[i]) / (e * e);
    }
    /* + 2 A J^T A u: v = A u, (J^T v)_q = -v_p, (J^T v)_p = v_q over y */
    for (size_t i = 0; i < d; i++) {
        double s = 0;
        for (size_t j = 0; j < d; j++) s += A[i * d + j] * u[j];
        v[i] = s;
    }
    for (size_t i = 0; i < n; i++) {
        ys[i] = -v[n + 1 + i];
        ys[n + 1 + i] = v[i];
    }
    ys[n] = 0;
    for (size_t i = 0; i < d; i++) {
        double s = 0;
        for (size_t j = 0; j < d; j++) s += A[i * d + j] * ys[j];
        gpsi[i] = gm[i] + 2 * s;
    }
    return DTH_OK;
}

int dth__model_d3aab(const dth_model *m, const double *y, const double *a, const double *b, double *out, double *work)
{
    size_t n = m->info.n, d = 2 * n + 1;
    double *v = work, *ys = work + d, *hess = ys + d;
    if (m->type->third) { /* polarization: D^3H[a, a, b] = (T(a + b) - T(a - b) - 2 T(b)) / 6, T(x) = D^3H[x, x, x] */
        double t[3];
        for (int k = 0; k < 3; k++) {
            for (size_t i = 0; i < d; i++) v[i] = k == 0 ? a[i] + b[i] : k == 1 ? a[i] - b[i] : b[i];
            int r3 = m->type->third(m->self, y, v, &t[k]);
            if (r3) return r3 > 0 ? DTH_EDOMAIN : DTH_EMODEL;
        }
        *out = (t[0] - t[1] - 2 * t[2]) / 6;
        return isfinite(*out) ? DTH_OK : DTH_EDOMAIN;
    }
    /* central difference of a^T H(y + e b) a in e */
    double ynorm = 1, bnorm = 0, f[2];
    for (size_t i = 0; i < d; i++) {
        if (i != n) ynorm = fmax(ynorm, fabs(y[i])); /* (q, p): the time's size sets no step */
        bnorm = fmax(bnorm, fabs(b[i]));
    }
    if (!(bnorm > 0)) {
        *out = 0;
        return DTH_OK;
    }
    double e = cbrt(DBL_EPSILON) * ynorm / bnorm;
    for (int s = 0; s < 2; s++) {
        for (size_t i = 0; i < d; i++) ys[i] = y[i] + (s ? -e : e) * b[i];
        int rc = dth_model_eval(m, ys, DTH_EVAL_HESS, NULL, NULL, hess);
        if (rc) return rc;
        f[s] = quad_form(d, hess, a);
    }
    *out = (f[0] - f[1]) / (2 * e);
    return DTH_OK;
}

size_t dth__model_d3_work(const dth_model *m)
{
    size_t d = 2 * m->info.n + 1;
    return 2 * d + d * d;
}
