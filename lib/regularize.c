/* SPDX-License-Identifier: MIT */
/*
 * Regularizer instances, the integrator's hook where psi = 0 (paper, section 7), and the building
 * blocks of the shipped regularizers: the kicked segment and the roots of the cubic model of the
 * step constraint (Lemma g_taylor).
 */
#include <float.h>
#include <math.h>
#include <stdio.h>
#include <string.h>
#include "dth/regularize.h"
#include "dth_internal.h"
#include "fields.h"
#include "kick.h"

struct dth_regularizer {
    const dth_regularizer_type *type; /* &t */
    dth_regularizer_type t;           /* the caller's table, checked and copied (model.h) */
    void *self;
    const dth_allocator *alloc;
    size_t N;                         /* 2n + 2 of the model: a F64_PTR field's count 0 */
};

static int spec_accepts(const dth_regularizer_type *t, const char *key)
{
    for (size_t i = 0; i < t->n_params; i++) {
        const char *k = t->params[i].key;
        size_t len = strlen(k);
        if (len && k[len - 1] == '*' ? strncmp(k, key, len - 1) == 0 : strcmp(k, key) == 0) return 1;
    }
    return 0;
}

int dth_regularizer_type_check(const dth_regularizer_type *t, char *err, size_t errlen)
{
    if (!t) {
        dth__set_err(err, errlen, "no regularizer table (NULL)");
        return DTH_EINVAL;
    }
    int rc = dth__abi_check(t->abi, t->size, 3, DTH_REG_TYPE_VERSION, sizeof *t, "regularizer", err, errlen);
    if (rc) return rc;
    if (!t->name || !t->name[0] || !t->apply) {
        dth__set_err(err, errlen, "regularizer table '%s' lacks %s", t->name && t->name[0] ? t->name : "(unnamed)",
                     !t->name || !t->name[0] ? "a name" : "its apply callback");
        return DTH_EINVAL;
    }
    char why[160];
    if (dth__fields_valid(t->fields, t->n_fields, 1, why, sizeof why)) {
        dth__set_err(err, errlen, "regularizer table '%s': %s", t->name, why);
        return DTH_EINVAL;
    }
    return DTH_OK;
}

int dth_regularizer_new(const dth_regularizer_type *utype, const dth_kv *kv, size_t nkv,
                        const dth_model *model, const dth_allocator *alloc, dth_regularizer **out,
                        char *err, size_t errlen)
{
    if (out) *out = NULL;
    if (err && errlen) err[0] = '\0';
    if (!out || !model || (nkv && !kv)) {
        if (err && errlen) snprintf(err, errlen, "invalid arguments to dth_regularizer_new");
        return DTH_EINVAL;
    }
    if (dth_regularizer_type_check(utype, err, errlen)) return DTH_EINVAL;
    dth_regularizer_type tcopy;
    dth__table_copy(&tcopy, sizeof tcopy, utype, utype->size);
    const dth_regularizer_type *type = &tcopy;
    for (size_t i = 0; i < nkv; i++) {
        if (!kv[i].key || !kv[i].value || !spec_accepts(type, kv[i].key)) {
            if (err && errlen)
                snprintf(err, errlen, "regularizer '%s' has no parameter '%s'", type->name,
                         kv[i].key ? kv[i].key : "(null)");
            return DTH_EINVAL;
        }
    }
    dth_regularizer *r = dth_calloc(alloc, 1, sizeof *r);
    if (!r) return DTH_ENOMEM;
    r->t = tcopy;
    r->type = &r->t;
    type = r->type;
    r->alloc = alloc;
    r->N = 2 * dth_model_dof(model) + 2;
    if (type->create) {
        dth_reg_args a = {kv, nkv, model, alloc, err, errlen};
        int rc = type->create(&a, &r->self);
        if (rc) {
            if (err && errlen && !err[0]) snprintf(err, errlen, "regularizer '%s': %s", type->name, dth_strerror(rc));
            if (r->self && type->destroy) type->destroy(r->self, alloc);
            dth_free(alloc, r);             /* type points into r: the message is written first */
            return rc < 0 ? rc : DTH_EINVAL;
        }
    }
    *out = r;
    return DTH_OK;
}

void dth_regularizer_free(dth_regularizer *r)
{
    if (!r) return;
    if (r->type->destroy) r->type->destroy(r->self, r->alloc);
    dth_free(r->alloc, r);
}

const dth_regularizer_type *dth_regularizer_get_type(const dth_regularizer *r) { return r ? r->type : NULL; }

/* ---- the instance's state: its type's field list (regularize.h) ---- */

const dth_field *dth__reg_fields(const dth_regularizer *r, size_t *n)
{
    *n = r && r->self ? r->type->n_fields : 0;
    return *n ? r->type->fields : NULL;
}

void *dth__reg_self(const dth_regularizer *r) { return r ? r->self : NULL; }

size_t dth__reg_veclen(const dth_regularizer *r) { return r ? r->N : 0; }

int dth__reg_loaded(dth_regularizer *r)
{
    return r && r->self && r->type->state_loaded ? r->type->state_loaded(r->self) : 0;
}

/* A field's bytes in the instance: its member, or the doubles its pointer points to. */
static char *field_bytes(const dth_regularizer *r, const dth_field *f, size_t *len)
{
    char *p = (char *)r->self + f->offset;
    if (f->kind != DTH_FIELD_F64_PTR) {
        *len = dth__field_size(f);
        return p;
    }
    *len = (size_t)dth__field_count(f, r->N) * sizeof(double);
    char *v;
    memcpy(&v, p, sizeof v);
    return v;
}

size_t dth__reg_state_size(const dth_regularizer *r)
{
    size_t n, total = 0, len;
    const dth_field *f = dth__reg_fields(r, &n);
    for (size_t i = 0; i < n; i++) {
        field_bytes(r, &f[i], &len);
        total += len;
    }
    return total;
}

void dth__reg_save_state(const dth_regularizer *r, void *buf)
{
    size_t n, len;
    const dth_field *f = dth__reg_fields(r, &n);
    char *out = buf;
    for (size_t i = 0; i < n; i++) {
        const char *p = field_bytes(r, &f[i], &len);
        if (len) memcpy(out, p, len);
        out += len;
    }
}

int dth__reg_load_state(dth_regularizer *r, const void *buf, size_t len)
{
    if (len != dth__reg_state_size(r)) return -1;
    size_t n, l;
    const dth_field *f = dth__reg_fields(r, &n);
    const char *in = buf;
    for (size_t i = 0; i < n; i++) {
        char *p = field_bytes(r, &f[i], &l);
        if (l) memcpy(p, in, l);
        in += l;
    }
    return dth__reg_loaded(r) < 0 ? -1 : 0;
}

int dth__reg_admit(dth_regularizer *r, const double *za, const double *zb, double lambda)
{
    return r->type->admit(r->self, za, zb, lambda);
}

int dth__reg_observe(dth_regularizer *r, const dth_reg_step *st, double *dt)
{
    return r->type->observe(r->self, st, dt);
}

int dth__reg_replaces_all(const dth_regularizer *r)
{
    return r && r->type->replaces_all && r->type->replaces_all(r->self);
}

int dth_regularizer_apply(dth_regularizer *r, const dth_reg_event *ev, dth_reg_action *act)
{
    if (!r || !ev || !act) return DTH_EINVAL;
    return r->type->apply(r->self, ev, act);
}

/* ------------------------------------------------------------------ cubic model roots */

double dth_cubic_root(double H, double psi, double dpsi, double side)
{
    /* c(s x) = H - psi x^2/8 - s dpsi x^3/24 for x > 0: p(x) = a x^3 + b x^2 + H. */
    double s = side >= 0 ? 1.0 : -1.0, a = -s * dpsi / 24, b = -psi / 8;
    if (!isfinite(H) || !isfinite(psi) || !isfinite(dpsi)) return 0;
    if (H == 0) return 0;
    /* Bracket the smallest positive root: p(0) = H; p has at most two positive turning points
     * (x = 0 and x = -2b/(3a)), so scan [0, inf) in pieces where p is monotone. */
    double xs[1];
    int nx = 0;
    double xt = (a != 0) ? -2 * b / (3 * a) : INFINITY;
    if (xt > 0 && isfinite(xt)) xs[nx++] = xt;
    double lo = 0, plo = H;
    for (int piece = 0; piece <= nx; piece++) {
        double hi;
        if (piece < nx) hi = xs[piece];
        else {
            /* last monotone piece: p -> sign(a) inf (or sign(b) inf if a == 0) */
            double lead = a != 0 ? a : b;
            if (lead == 0 || (lead > 0) == (plo > 0)) return 0;
            hi = lo > 0 ? 2 * lo : 1.0;
            for (int k = 0; k < 2200; k++) {
                double ph = (a * hi + b) * hi * hi + H;
                if ((ph > 0) != (plo > 0) || ph == 0) break;
                hi *= 2;
                if (!isfinite(hi)) return 0;
            }
        }
        double phi = (a * hi + b) * hi * hi + H;
        if (phi == 0) return s * hi;
        if ((phi > 0) != (plo > 0)) {
            /* bisection to a tight bracket, then Newton polish: a pure function of (H, psi, dpsi) */
            double l = lo, h = hi;
            for (int k = 0; k < 200 && h - l > 4 * DBL_EPSILON * h; k++) {
                double mid = 0.5 * (l + h), pm = (a * mid + b) * mid * mid + H;
                if (pm == 0) return s * mid;
                if ((pm > 0) == (plo > 0)) l = mid;
                else h = mid;
            }
            /* Newton polish: smooth in (H, psi, dpsi) down to round-off */
            double x = 0.5 * (l + h);
            for (int k = 0; k < 3; k++) {
                double px = (a * x + b) * x * x + H, dp = (3 * a * x + 2 * b) * x;
                if (dp == 0) break;
                double xn = x - px / dp;
                if (!(xn >= l && xn <= h)) break;
                x = xn;
            }
            return s * x;
        }
        lo = hi;
        plo = phi;
    }
    return 0;
}

/* ------------------------------------------------------------------ kicked segment */

/* Workspace layout of dth_kicked_segment (doubles). */
static size_t ks_layout(size_t n, size_t ninv, size_t *off)
{
    size_t d = 2 * n + 1, m = 2 * n + 1, q = 2 * n;
    size_t sz[] = {d, d, d * d, m * m, m, m, q, ninv * q, 2 * ninv + 8, d, (m + 1) / 2 + 1, q, m};
    size_t tot = 0;
    for (size_t i = 0; i < sizeof sz / sizeof sz[0]; i++) {
        off[i] = tot;
        tot += sz[i];
    }
    return tot;
}

size_t dth__model_ninv(const dth_model *model)
{
    const dth_model_type *t = dth_model_get_type(model);
    return (t->n_invariants && t->invariants) ? t->n_invariants(dth__model_self(model)) : 0;
}

size_t dth_kicked_segment_work_size(const dth_model *model)
{
    size_t off[13];
    return ks_layout(dth_model_dof(model), dth__model_ninv(model), off);
}

/*
 * Gradients over (q, p) of the invariants that are at most quadratic, by central differences
 * (exact up to round-off for such invariants), orthonormalized into G (rows). Which invariants
 * are quadratic was probed once when the model was made (model.c): the midpoint identity only
 * keeps those, projecting out e.g. the Runge-Lenz vector would remove the whole kick, and a test
 * at the current point could switch the projection between two Newton iterations (a third
 * difference along one direction vanishes on a hypersurface). Row j holds S grad I_j (S = diag(sc), the kick's metric) before
 * the orthonormalization. Returns the number of rows kept; graw (NULL: not wanted) gets the gradients
 * grad I_j themselves (all ni rows), kidx (NULL: not wanted) the index j of each kept row.
 */
size_t dth__quad_invariant_basis_ex(const dth_model *model, const double *y, const double *sc, double *G,
                                    double *ys, double *tmp, double *graw, size_t *kidx)
{
    const dth_model_type *t = dth_model_get_type(model);
    const void *self = dth__model_self(model);
    size_t n = dth_model_dof(model), q = 2 * n, ni = dth__model_ninv(model), kept = 0;
    if (!ni) return 0;
    double *Ip = tmp, *Im = tmp + ni;
    if (ni > 64) return 0;
    unsigned long long mask = dth__model_quad_mask(model);
    /* gradients by central differences */
    for (size_t i = 0; i < q; i++) {
        size_t yi = i < n ? i : i + 1;
        double h = 1e-3 * fmax(1.0, fabs(y[yi]));
        memcpy(ys, y, (2 * n + 1) * sizeof *ys);
        ys[yi] = y[yi] + h;
        if (t->invariants(self, ys, Ip) != 0) return 0;
        ys[yi] = y[yi] - h;
        if (t->invariants(self, ys, Im) != 0) return 0;
        for (size_t j = 0; j < ni; j++) G[j * q + i] = sc[i] * (Ip[j] - Im[j]) / (2 * h);
        if (graw) /* the gradients themselves (the reversible finish's projector, kl_cell) */
            for (size_t j = 0; j < ni; j++) graw[j * q + i] = (Ip[j] - Im[j]) / (2 * h);
    }
    /* modified Gram-Schmidt over the kept rows, dropping dependent ones */
    for (size_t j = 0; j < ni; j++) {
        if (!((mask >> j) & 1u)) continue;
        double *g = G + j * q, g0 = 0;
        for (size_t i = 0; i < q; i++) g0 = fmax(g0, fabs(g[i]));
        for (size_t r = 0; r < kept; r++) {
            double *b = G + r * q, dot = 0;
            for (size_t i = 0; i < q; i++) dot += g[i] * b[i];
            for (size_t i = 0; i < q; i++) g[i] -= dot * b[i];
        }
        double nn = 0;
        for (size_t i = 0; i < q; i++) nn += g[i] * g[i];
        nn = sqrt(nn);
        if (!(nn > 1e-8 * g0) || g0 == 0) continue;
        double *dst = G + kept * q;
        for (size_t i = 0; i < q; i++) dst[i] = g[i] / nn;
        if (kidx) kidx[kept] = j;
        kept++;
    }
    return kept;
}

/* The squared Frobenius norms of the Hessian's q-q and p-p blocks (the kick's metric). */
void dth__kick_metric_blocks(size_t n, const double *hs, double *fq_out, double *fp_out)
{
    size_t d = 2 * n + 1;
    double fq = 0, fp = 0;
    for (size_t i = 0; i < n; i++)
        for (size_t j = 0; j < n; j++) {
            fq += hs[i * d + j] * hs[i * d + j];
            fp += hs[(n + 1 + i) * d + (n + 1 + j)] * hs[(n + 1 + i) * d + (n + 1 + j)];
        }
    *fq_out = fq;
    *fp_out = fp;
}

/* rho of the kick's metric from the blocks' norms; *smooth (may be NULL) = 1 where rho is the smooth
 * (fp/fq)^(1/4), 0 where it is clamped or falls back to 1 */
double dth__kick_metric_rho(double fq, double fp, int *smooth)
{
    double rho = 1;
    int f = 0;
    if (fq > 0 && fp > 0 && isfinite(fq) && isfinite(fp)) {
        double r = sqrt(sqrt(fp / fq));
        rho = fmin(1e6, fmax(1e-6, r));
        f = rho == r;
    }
    if (smooth) *smooth = f;
    return rho;
}

/*
 * The kick's metric S = diag(s_q I, s_p I) at the midpoint, from the Hessian's blocks:
 * s_q / s_p = rho = sqrt(|H_pp| / |H_qq|) (Frobenius norms), s_q s_p = 1. In the coordinates
 * this metric makes Euclidean, the two blocks of the Hessian have the same size, the local
 * frequency sqrt(|H_qq| |H_pp|); the part of dH(zbar)/dmu that the flow couples in, relative to the
 * kick's own |P S grad H|^2, is then bounded by lambda omega / (2 sin theta), theta the angle
 * between S grad H and the invariants' S grad I. With the Euclidean metric instead that bound grows
 * like |H_qq| / (omega sin theta): at a Kepler pericentre (|H_qq| ~ 2/r^3) grad H and grad L are then
 * nearly parallel (theta ~ r^1.5) and dH/dmu could pass through 0 (no kicked segment). A block
 * that vanishes (a free particle, the pendulum at q = pi/2) falls back to rho = 1 or is clamped
 * to [1e-6, 1e6]. Used only for models with quadratic invariants to project: with none, n = grad H
 * and the Euclidean metric is kept (on the rotating pendulum the scaled kick, tried, gave a larger
 * period-error constant at the same order). A function of the midpoint only, so the segment stays
 * its own reverse.
 */
void dth__kick_metric(const dth_model *model, size_t n, const double *hs, double *sc)
{
    double fq, fp;
    if (!dth__model_quad_mask(model)) {
        /* nothing to project: n = grad H, dH/dmu = |grad H|^2/2 + O(lambda) */
        for (size_t i = 0; i < 2 * n; i++) sc[i] = 1;
        return;
    }
    dth__kick_metric_blocks(n, hs, &fq, &fp);
    double rho = dth__kick_metric_rho(fq, fp, NULL);
    double s_q = sqrt(rho), s_p = 1 / s_q;
    for (size_t i = 0; i < n; i++) {
        sc[i] = s_q;
        sc[n + i] = s_p;
    }
}

/* The kicked segment as a Newton problem (newton.c): unknowns (d_q, d_p, mu). */
typedef struct ks_ctx {
    const dth_model *model;
    const double *z, *zlo;
    double lambda, wp, H;
    size_t n;
    int m;
    double *y, *g, *hs, *A, *nv, *G, *tmp, *ys, *sc;
    int *piv;
} ks_ctx;

/* midpoint y = z + d over (q, p); t advances by lambda/2 */
static void ks_midpoint(const ks_ctx *c, const double *x, double *y)
{
    size_t n = c->n;
    for (size_t j = 0; j < 2 * n + 1; j++) {
        double lo = c->zlo ? c->zlo[j] : 0;
        double dj = j < n ? x[j] : (j == n ? 0.5 * c->lambda : x[j - 1]);
        y[j] = c->z[j] + (lo + dj);
    }
}

/*
 * The kick direction at the midpoint y (gradient g, Hessian hs): n = S P S grad H over (q, p), with
 * S = diag(sc) the kick's metric and P the projector off S grad I of the quadratic invariants
 * (G: their orthonormal rows, `kept` of them): grad I . n = 0 (the midpoint identity keeps I) and
 * grad H . n = |P S grad H|^2 > 0.
 */
size_t dth__kick_dir(const dth_model *model, size_t n, const double *y, const double *g, const double *hs, double *sc,
                       double *G, double *ys, double *tmp, double *nv)
{
    size_t q = 2 * n;
    dth__kick_metric(model, n, hs, sc);
    for (size_t i = 0; i < n; i++) {
        nv[i] = sc[i] * g[i];
        nv[n + i] = sc[n + i] * g[n + 1 + i];
    }
    size_t kept = dth__quad_invariant_basis_ex(model, y, sc, G, ys, tmp, NULL, NULL);
    for (size_t r = 0; r < kept; r++) {
        double dot = 0;
        for (size_t i = 0; i < q; i++) dot += nv[i] * G[r * q + i];
        for (size_t i = 0; i < q; i++) nv[i] -= dot * G[r * q + i];
    }
    for (size_t i = 0; i < q; i++) nv[i] *= sc[i];
    return kept;
}

/*
 * The kick's block of a Newton Jacobian (column-major, leading dimension m, rows and columns 0..2n-1 over
 * (q, p)): I - (lambda/2) d u / d y - (kmu/2) S P S H, the derivatives of S and P left out (they are
 * multiplied by mu, which is tiny; the projected Hessian term is needed: without it Newton converges only
 * linearly where grad H is far from n, e.g. at Kepler pericentres).
 */
void dth__kick_block(size_t n, size_t m, const double *hs, const double *sc, const double *G, size_t kept, double lam,
                       double kmu, double *A)
{
    size_t d = 2 * n + 1, q = 2 * n;
    for (size_t a = 0; a < q; a++) {
        size_t ya = a < n ? a : a + 1; /* y-index of this (q, p) component */
        for (size_t b = 0; b < q; b++) {
            size_t yb = b < n ? b : b + 1;
            A[a + b * m] = (a == b ? 1.0 : 0.0) - 0.5 * lam * dth__dudz(n, hs, ya, yb) - 0.5 * kmu * sc[a] * sc[a] * hs[ya * d + yb];
        }
    }
    for (size_t rr = 0; rr < kept; rr++)
        for (size_t b = 0; b < q; b++) {
            size_t yb = b < n ? b : b + 1;
            double sb = 0;
            for (size_t k = 0; k < q; k++) sb += G[rr * q + k] * sc[k] * hs[(k < n ? k : k + 1) * d + yb];
            for (size_t a = 0; a < q; a++) A[a + b * m] += 0.5 * kmu * sc[a] * G[rr * q + a] * sb;
        }
}

static int ks_eval(void *ctx, const double *x, double *F, int jac)
{
    ks_ctx *c = ctx;
    const dth_model *model = c->model;
    size_t n = c->n, q = 2 * n, m = (size_t)c->m;
    double *y = c->y, *g = c->g, *hs = c->hs, *A = c->A, *nv = c->nv;
    ks_midpoint(c, x, y);
    int rc = dth__model_eval_raw(model, y, DTH_EVAL_H | DTH_EVAL_GRAD | DTH_EVAL_HESS, &c->H, g, hs);
    if (rc) return rc;
    size_t kept = dth__kick_dir(model, n, y, g, hs, c->sc, c->G, c->ys, c->tmp, nv);
    /* F = d - (lambda/2) u - (mu/2) n, u = (dH/dp, -dH/dq); F_last = wp + H */
    double lam = c->lambda, kmu = x[q];
    for (size_t i = 0; i < n; i++) {
        F[i] = x[i] - 0.5 * lam * g[n + 1 + i] - 0.5 * kmu * nv[i];
        F[n + i] = x[n + i] + 0.5 * lam * g[i] - 0.5 * kmu * nv[n + i];
    }
    F[q] = c->wp + c->H;
    if (!jac) return DTH_OK;
    /* Jacobian over (d_q, d_p, mu) */
    dth__kick_block(n, m, hs, c->sc, c->G, kept, lam, kmu, A);
    for (size_t a = 0; a < q; a++) {
        A[a + q * m] = -0.5 * nv[a];
        A[q + a * m] = g[a < n ? a : a + 1];
    }
    A[q + q * m] = 0;
    return dth__lu_factor(DTH_LINSOLVE_AUTO, c->m, A, c->piv);
}

static int ks_solve(void *ctx, double *b)
{
    ks_ctx *c = ctx;
    return dth__lu_solve(DTH_LINSOLVE_AUTO, c->m, c->A, c->piv, 1, b);
}

static int ks_judge(void *ctx, const double *x, const double *dx, const double *F, dth__newton_track *tr, int *verdict)
{
    ks_ctx *c = ctx;
    size_t n = c->n, d = 2 * n + 1, q = 2 * n;
    int m = c->m;
    /* rd: the offsets only (mu inherits H's round-off, magnified), against the size of the
     * whole (q, p) state (a component near 0 only sees the round-off of the others) */
    double r = 0, rd = 0, zs = 1e-300;
    for (int a = 0; a < m; a++) {
        double scl;
        if (a == m - 1) scl = fabs(x[a]) + fabs(c->lambda) + 1e-300; /* mu next to the flow term */
        else {
            size_t j = (size_t)a < n ? (size_t)a : (size_t)a + 1;
            scl = fabs(c->z[j]) + fabs(c->y[j]) + 1e-300;
        }
        r = fmax(r, fabs(dx[a]) / scl);
        if (a < m - 1) {
            rd = fmax(rd, fabs(dx[a]));
            zs = fmax(zs, scl);
        }
    }
    rd /= zs;
    tr->r = r;
    int v = dth__newton_rate(r, tr->r_prev, tr->iter, 4 * DBL_EPSILON);
    if (v == DTH__NT_DIVERGED) return DTH_ENOCONV;
    /* no chord finish: the Jacobian leaves out the projection's derivative, so the rate is not
     * quadratic where mu is not tiny, and the chord's predicted residual is not reached (the
     * invariants, kept only by an exact segment, then drift) */
    if (v == DTH__NT_CHORD) v = DTH__NT_MORE;
    if (v == DTH__NT_STALLED) {
        /* stalled: accept if the energy residual is at the round-off of its terms */
        double hsc = fabs(c->wp) + fabs(c->H);
        for (size_t j = 0; j < d; j++) hsc += fabs(c->g[j] * c->y[j]);
        /* mu judged by the chord it moves, |dmu| |n| (|mu| may be far below lambda's scale) */
        double nn = 0;
        for (size_t i = 0; i < q; i++) nn += c->nv[i] * c->nv[i];
        double rmu = fabs(dx[m - 1]) * sqrt(nn) / zs;
        if (fabs(F[m - 1]) <= 256 * DBL_EPSILON * hsc && rd < 1e-11 && (r < 1e-8 || rmu < 1e-11)) v = DTH__NT_DONE;
        else if (tr->iter >= 12) return DTH_ENOCONV;
        else v = DTH__NT_MORE;
    }
    *verdict = v;
    return DTH_OK;
}

static const dth__newton_ops ks_ops = {ks_eval, ks_solve, ks_judge};

int dth_kicked_segment(const dth_model *model, const double *z, const double *zlo, double lambda,
                       double *dz, double *mu, double *residual, int *iters, double *work)
{
    if (!model || !z || !dz || !mu || !work || !isfinite(lambda)) return DTH_EINVAL;
    if (!dth_model_get_info(model)->autonomous) return DTH_EUNSUPPORTED;
    size_t n = dth_model_dof(model), N = 2 * n + 2, q = 2 * n, ni = dth__model_ninv(model);
    size_t off[13];
    ks_layout(n, ni, off);
    ks_ctx c = {model, z, zlo, lambda, z[N - 1] + (zlo ? zlo[N - 1] : 0), 0, n, (int)(2 * n + 1),
                work + off[0], work + off[1], work + off[2], work + off[3], work + off[6], work + off[7],
                work + off[8], work + off[9], work + off[11], (int *)(work + off[10])};
    double *F = work + off[4], *x = work + off[5], *dx = work + off[12];
    for (size_t i = 0; i < n; i++) {
        x[i] = dz[i];
        x[n + i] = dz[n + 1 + i];
    }
    x[q] = *mu;
    dth__newton_track tr;
    int rc = dth__newton_run(&ks_ops, &c, c.m, 40, x, F, dx, &tr);
    if (iters) *iters = tr.iter;
    if (rc) return rc;
    ks_midpoint(&c, x, c.y);
    rc = dth_model_eval(model, c.y, DTH_EVAL_H, &c.H, NULL, NULL);
    if (rc) return rc;
    for (size_t i = 0; i < n; i++) {
        dz[i] = x[i];
        dz[n + 1 + i] = x[n + i];
    }
    dz[n] = 0.5 * lambda;
    dz[N - 1] = 0;
    *mu = x[q];
    if (residual) *residual = fabs(c.wp + c.H);
    return DTH_OK;
}

size_t dth__quad_invariant_basis(const dth_model *model, const double *y, const double *sc, double *G, double *ys,
                                 double *tmp)
{
    return dth__quad_invariant_basis_ex(model, y, sc, G, ys, tmp, NULL, NULL);
}

/* ------------------------------------------------------------------ the kicked segment, lambda unknown */

/*
 * A kicked segment from the vertex z (+ zlo) whose time step lambda is an unknown too, closed by a
 * condition on the segment's end vertex z_b = z + 2 d (close->eval: its value and gradient over y), or
 * by lambda = close->lambda when close->eval is NULL: ONE Newton on x = (d_q, d_p, lambda, mu),
 *     d - (1/2)(lambda u(zbar) + mu n(zbar)) = 0,  wp + H(zbar) = 0,  c(z_b) = 0,
 * t advancing by lambda. The Jacobian is ks_eval's block plus the lambda column (-u/2) and the closing
 * row (2 dc/dy at z_b). Autonomous models only.
 */
typedef struct kj_ctx {
    const dth_model *model;
    const double *z, *zlo;
    const dth__kj_close *close;
    double wp, H;
    size_t n, d, m;
    double *y, *yb, *g, *hs, *A, *F, *dx, *nv, *G, *tmp, *ys, *sc, *gc;
    int *piv;
} kj_ctx;

size_t dth__kicked_joint_work_size(const dth_model *model)
{
    size_t n = dth_model_dof(model), d = 2 * n + 1, m = 2 * n + 2, ni = dth__model_ninv(model);
    return 3 * d + d * d + m * m + 4 * m + 2 * n + ni * 2 * n + 2 * ni + 8 + d + 2 * n + d + (m + 1) / 2 + 1;
}

/* zbar and z_b over y from x = (d_q, d_p, lambda, mu) */
static void kj_points(const kj_ctx *c, const double *x)
{
    size_t n = c->n;
    for (size_t j = 0; j < c->d; j++) {
        double lo = c->zlo ? c->zlo[j] : 0;
        double dj = j < n ? x[j] : (j == n ? 0.5 * x[2 * n] : x[j - 1]);
        c->y[j] = c->z[j] + (lo + dj);
        c->yb[j] = c->z[j] + (lo + 2 * dj);
    }
}

static int kj_eval(kj_ctx *c, const double *x)
{
    size_t n = c->n, q = 2 * n, m = c->m, d = c->d;
    double *A = c->A, *F = c->F, *g = c->g, *nv = c->nv, lam = x[q], kmu = x[q + 1];
    kj_points(c, x);
    int rc = dth__model_eval_raw(c->model, c->y, DTH_EVAL_H | DTH_EVAL_GRAD | DTH_EVAL_HESS, &c->H, g, c->hs);
    if (rc) return rc;
    size_t kept = dth__kick_dir(c->model, n, c->y, g, c->hs, c->sc, c->G, c->ys, c->tmp, nv);
    for (size_t i = 0; i < n; i++) {
        F[i] = x[i] - 0.5 * lam * g[n + 1 + i] - 0.5 * kmu * nv[i];
        F[n + i] = x[n + i] + 0.5 * lam * g[i] - 0.5 * kmu * nv[n + i];
    }
    F[q] = c->wp + c->H;
    memset(A, 0, m * m * sizeof *A);
    dth__kick_block(n, m, c->hs, c->sc, c->G, kept, lam, kmu, A);
    for (size_t a = 0; a < q; a++) {
        size_t ya = a < n ? a : a + 1;
        A[a + q * m] = -0.5 * (a < n ? g[n + 1 + a] : -g[a - n]); /* d F / d lambda = -u/2 */
        A[a + (q + 1) * m] = -0.5 * nv[a];
        A[q + a * m] = g[ya];
    }
    if (c->close->eval) {
        rc = c->close->eval(c->close->ctx, c->yb, &F[q + 1], c->gc);
        if (rc) return rc;
        for (size_t a = 0; a < q; a++) A[q + 1 + a * m] = 2 * c->gc[a < n ? a : a + 1];
    } else {
        F[q + 1] = lam - c->close->lambda;
        A[q + 1 + q * m] = 1;
    }
    (void)d;
    return dth__lu_factor(DTH_LINSOLVE_AUTO, (int)m, A, c->piv);
}

int dth__kicked_joint(const dth_model *model, const double *z, const double *zlo, const dth__kj_close *close, double *dz,
                      double *lambda, double *mu, double *residual, int *iters, double *work)
{
    if (!dth_model_get_info(model)->autonomous) return DTH_EUNSUPPORTED;
    size_t n = dth_model_dof(model), N = 2 * n + 2, d = 2 * n + 1, m = 2 * n + 2, q = 2 * n, ni = dth__model_ninv(model);
    kj_ctx c = {.model = model, .z = z, .zlo = zlo, .close = close, .wp = z[N - 1] + (zlo ? zlo[N - 1] : 0), .n = n,
                .d = d, .m = m};
    double *p = work, *xv;
    double **slots[] = {&c.y, &c.yb, &c.g, &c.hs, &c.A, &c.F, &c.dx, &c.nv, &c.G, &c.tmp, &c.ys, &c.sc, &c.gc, &xv};
    size_t sizes[] = {d, d, d, d * d, m * m, m, m, q, ni * q, 2 * ni + 8, d, q, d, m};
    for (size_t i = 0; i < sizeof sizes / sizeof sizes[0]; i++) {
        *slots[i] = p;
        p += sizes[i];
    }
    c.piv = (int *)p;
    for (size_t i = 0; i < n; i++) {
        xv[i] = dz[i];
        xv[n + i] = dz[n + 1 + i];
    }
    xv[q] = *lambda;
    xv[q + 1] = *mu;
    double rprev = INFINITY, zs = 1e-300; /* the scale of (q, p): t plays no part (no bits depend on it) */
    for (size_t j = 0; j < d; j++)
        if (j != n) zs = fmax(zs, fabs(z[j]));
    int it, rc = DTH_ENOCONV;
    for (it = 1; it <= 40; it++) {
        rc = DTH_ENOCONV;
        int er = kj_eval(&c, xv);
        if (er) {
            rc = er;
            break;
        }
        memcpy(c.dx, c.F, m * sizeof *c.dx);
        dth__lu_solve(DTH_LINSOLVE_AUTO, (int)m, c.A, c.piv, 1, c.dx);
        double r = 0, nn = 0;
        for (size_t a = 0; a < m; a++) {
            xv[a] -= c.dx[a];
            if (!isfinite(xv[a])) return DTH_ENOCONV;
        }
        for (size_t a = 0; a < q; a++) nn += c.nv[a] * c.nv[a];
        for (size_t a = 0; a <= q; a++) {
            size_t j = a < n ? a : a < q ? a + 1 : n;
            double sc = a == q ? fabs(xv[q]) + 1e-300 : fabs(z[j]) + fabs(c.y[j]) + 1e-300;
            r = fmax(r, fabs(c.dx[a]) / sc);
        }
        r = fmax(r, fabs(c.dx[q + 1]) * sqrt(nn) / zs);
        if (r <= 4 * DBL_EPSILON) {
            rc = DTH_OK;
            break;
        }
        if (it >= 3 && r > 0.25 * rprev) { /* no longer quadratic: accept at the noise floor, else give up late */
            /* the noise floor: r, or the chords the last corrections move, against the state's size (where |q|
             * is large, e.g. angles after many turns, a short step's lambda is not resolved to 1e-9 of itself) */
            double uu = 0, rs = 0;
            for (size_t j = 0; j < d; j++)
                if (j != n) uu += c.g[j] * c.g[j];
            for (size_t a = 0; a < q; a++) rs = fmax(rs, fabs(c.dx[a]));
            rs = fmax(rs, fmax(fabs(c.dx[q]) * sqrt(uu), fabs(c.dx[q + 1]) * sqrt(nn))) / zs;
            if (r < 1e-9 || rs < 1e-11) {
                rc = DTH_OK;
                break;
            }
            if (it > 15) break;
        }
        rprev = r;
    }
    if (iters) *iters = it;
    if (rc) return rc;
    kj_points(&c, xv);
    rc = dth_model_eval(model, c.y, DTH_EVAL_H, &c.H, NULL, NULL);
    if (rc) return rc;
    for (size_t i = 0; i < n; i++) {
        dz[i] = xv[i];
        dz[n + 1 + i] = xv[n + i];
    }
    dz[n] = 0.5 * xv[q];
    dz[N - 1] = 0;
    *lambda = xv[q];
    *mu = xv[q + 1];
    if (residual) *residual = fabs(c.wp + c.H);
    return DTH_OK;
}

size_t dth__kick_work_size(const dth_model *model)
{
    size_t n = dth_model_dof(model), ni = dth__model_ninv(model);
    return 2 * n + ni * 2 * n + 2 * ni + 8 + (2 * n + 1) + 2 * n + 3 * (2 * n + 1) + (2 * n + 1) * (2 * n + 1);
}

int dth__kick_at(const dth_model *model, const double *y, double *nv, double *work)
{
    size_t n = dth_model_dof(model), d = 2 * n + 1, q = 2 * n, ni = dth__model_ninv(model);
    double *G = work, *tmp = G + ni * q, *ys = tmp + 2 * ni + 8, *sc = ys + d, *g = sc + q, *hs = g + 3 * d;
    int rc = dth__model_eval_raw(model, y, DTH_EVAL_GRAD | DTH_EVAL_HESS, NULL, g, hs);
    if (rc) return rc;
    dth__kick_dir(model, n, y, g, hs, sc, G, ys, tmp, nv);
    return DTH_OK;
}
