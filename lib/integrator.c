/* SPDX-License-Identifier: MIT */
/*
 * The DTH step (paper, Theorem "DTH Equations"): Newton's method on the bordered system for
 * (zbar - z_k, lambda), start modes, compensated vertex updates, per-vertex diagnostics
 * (regions of section 5) and the tangent map of a step.
 */
#include <math.h>
#include <stdio.h>
#include <stdint.h>
#include <string.h>
#include "dth_internal.h"
#include "integrator_impl.h"
#include "lu_small.h"
#include "newton.h"

const char *dth_region_name(dth_region r)
{
    switch (r) {
    case DTH_REGION_I: return "I";
    case DTH_REGION_II: return "II";
    case DTH_REGION_III: return "III";
    default: return "-";
    }
}

const char *dth_branch_name(dth_branch b)
{
    switch (b) {
    case DTH_BRANCH_MINUS: return "minus";
    case DTH_BRANCH_PLUS: return "plus";
    case DTH_BRANCH_GHOST: return "ghost";
    case DTH_BRANCH_EXACT: return "exact";
    case DTH_BRANCH_REG: return "reg";
    default: return "-";
    }
}

dth_region dth_region_of(double psi, double dpsi, double K)
{
    if (psi == 0) return dpsi != 0 ? DTH_REGION_III : DTH_REGION_NONE;
    return dpsi * dpsi <= 24 * K * fabs(psi) ? DTH_REGION_I : DTH_REGION_II;
}

static const struct dth__linsolver *linsolver_of(dth_linsolve kind);
static void seterr(dth_integrator *it, const char *fmt, ...) __attribute__((format(printf, 2, 3)));
static void seterr(dth_integrator *it, const char *fmt, ...)
{
    va_list ap;
    va_start(ap, fmt);
    vsnprintf(it->errmsg, sizeof it->errmsg, fmt, ap);
    va_end(ap);
}

int dth_integrator_new(const dth_model *model, const dth_options *opt_in, dth_integrator **out)
{
    if (!out) return DTH_EINVAL;
    *out = NULL;
    if (!model || !opt_in || opt_in->size != sizeof(dth_options)) return DTH_EINVAL;
    dth_options o = *opt_in, *opt = &o;
    int crc = dth_options_check(model, opt, NULL, 0); /* resolves linsolve AUTO */
    if (crc) return crc;
    size_t n = dth_model_dof(model);
    dth_linsolve kind = opt->linsolve;
    int auton = dth_model_get_info(model)->autonomous;
    size_t msz = auton ? 2 * n + 1 : 2 * n + 3;
    int dense = !dth__linsolve_find(kind)->banded; /* banded: no O(n^2) buffers */
    const dth_allocator *al = opt->alloc;
    dth_integrator *it = dth_calloc(al, 1, sizeof *it);
    if (!it) return DTH_ENOMEM;
    it->model = model;
    it->opt = *opt;
    it->alloc = al;
    it->kind = kind;
    it->ls = linsolver_of(kind);
    it->n = n;
    it->N = 2 * n + 2;
    it->d = 2 * n + 1;
    it->auton = auton;
    it->m = (int)msz;
    size_t N = it->N, d = it->d, m = msz;
    size_t nd = 0, rv = opt->finish == DTH_FINISH_REVERSIBLE;
    /* one block of doubles, carved below */
    size_t sizes[] = {N, N, N, N, N, N, N, N, N, N, d, (size_t)dense * d * d, N, d, (size_t)dense * m * m, m, m, m,
                      dth_model_work_size(model), (size_t)dense * m * N,
                      dth_model_get_type(model)->hdiff ? 0 : 2 * d, N, rv * m, rv * N, rv * N, rv * N, rv * N, rv * N, rv * N};
    /* hwork: dth__model_hdiff's rule only; xlo, yc, ydel, ygl, vc, yprev, vcsrc: the reversible finish only */
    for (size_t i = 0; i < sizeof sizes / sizeof sizes[0]; i++) nd += sizes[i];
    it->block = dth_calloc(al, nd, sizeof(double));
    it->piv = dth_calloc(al, 2 * m, sizeof(int));
    if (!it->block || !it->piv) {
        dth_integrator_free(it);
        return DTH_ENOMEM;
    }
    double *p = it->block;
    double **slots[] = {&it->st.z, &it->st.zlo, &it->st.zbar, &it->st.dprev, &it->st.dprev2, &it->st.dprev3, &it->dnew, &it->znew, &it->znewlo,
                        &it->zb, &it->grad, &it->hess, &it->u, &it->ybar, &it->A, &it->F, &it->x, &it->dx,
                        &it->work, &it->B, &it->hwork, &it->zblo, &it->xlo, &it->yc, &it->ydel, &it->ygl, &it->vc, &it->yprev, &it->vcsrc};
    for (size_t i = 0; i < sizeof slots / sizeof slots[0]; i++) {
        *slots[i] = sizes[i] ? p : NULL;
        p += sizes[i];
    }
    if (!dense) {
        it->hess = it->A = it->B = NULL;
        int rc = dth__band_new(model, kind == DTH_LINSOLVE_BANDED, al, &it->band);
        if (rc) {
            dth_integrator_free(it);
            return rc;
        }
    }
    it->act = it->piv + m;
    it->nsmall = auton && dense && dth__lu_small(kind, it->m) && n <= 3 ? (int)n : 0;
    it->small_schur = it->nsmall && kind != DTH_LINSOLVE_SMALL_LU && dth_model_get_info(model)->separable;
    it->rev = opt->finish == DTH_FINISH_REVERSIBLE; /* the reversible finish (dense only, above) */
    it->meval = dth_model_get_type(model)->eval;
    it->mhdiff = dth_model_get_type(model)->hdiff;
    it->mself = dth__model_self(model);
    /* unknowns: the z-components that Newton solves for, then lambda */
    int a = 0;
    for (size_t j = 0; j < N; j++) {
        if (it->auton && (j == it->n || j == N - 1)) continue; /* t and wp in closed form */
        it->act[a++] = (int)j;
    }
    it->st.dir = opt->h > 0 ? 1.0 : -1.0;
    it->st.lam_hint = opt->h;
    it->st.h = opt->h;
    it->st.psi_step = -2;
    it->reg = opt->regularizer;
    int brc = DTH_OK;
    if (it->reg) {
        /* the hook's workspace, the copy of the state vectors a failed regularizer step is undone
         * from, and of the regularizer's own state */
        it->rbuf = dth_calloc(al, (4 + DTH__STATE_NVEC) * N, sizeof(double));
        it->snap = it->rbuf ? it->rbuf + 4 * N : NULL;
        it->regsnap_len = dth__reg_state_size(it->reg);
        if (it->regsnap_len) it->regsnap = dth_calloc(al, it->regsnap_len, 1);
        if (!it->rbuf || (it->regsnap_len && !it->regsnap)) brc = DTH_ENOMEM;
    }
    if (!brc) brc = dth__branch_create(it);
    if (brc) {
        dth_integrator_free(it);
        return brc;
    }
    snprintf(it->errmsg, sizeof it->errmsg, "no error");
    *out = it;
    return DTH_OK;
}

void dth_integrator_free(dth_integrator *it)
{
    if (!it) return;
    dth_free(it->alloc, it->block);
    dth_free(it->alloc, it->piv);
    dth__band_free(it->band, it->alloc);
    dth__branch_free(it);
    dth_free(it->alloc, it->rbuf);
    dth_free(it->alloc, it->regsnap);
    dth_free(it->alloc, it);
}

const double *dth_integrator_vertex(const dth_integrator *it) { return it->st.z; }
const double *dth_integrator_midpoint(const dth_integrator *it) { return it->st.have_mid ? it->st.zbar : NULL; }
double dth_integrator_lambda(const dth_integrator *it) { return it->st.lam; }
double dth_integrator_energy(const dth_integrator *it) { return it ? -(it->st.z[it->N - 1] + it->st.zlo[it->N - 1]) : NAN; }

long dth_integrator_steps(const dth_integrator *it) { return it->st.steps; }
size_t dth_integrator_dim(const dth_integrator *it) { return it->N; }
const dth_model *dth_integrator_model(const dth_integrator *it) { return it->model; }
const char *dth_integrator_errmsg(const dth_integrator *it) { return it->errmsg; }

/* Error-free sum: s + e == a + b exactly (Knuth's TwoSum). */
static inline double two_sum(double a, double b, double *e)
{
    double s = a + b, bb = s - a;
    *e = (a - (s - bb)) + (b - bb);
    return s;
}

/*
 * c = v coarsened over y = (q, t, p) (d = 2n + 1 entries): each entry rounded to the nearest
 * multiple of 2^(e - COARSE_BITS), e the binary exponent of its block's largest magnitude (the q
 * block, t, the p block), so that a coarse cell spans 2^(52 - COARSE_BITS) ulps of the block's
 * scale also for an entry near zero. A deterministic, odd function of v. Where the model is read:
 * rho_from_mid_n, coarse_n.
 */
enum { COARSE_BITS = 28 };
/* The rounding error of the product p = a b, exactly (Dekker: no fma call; |a|, |b| < 2^995). */
static inline double prod_err(double a, double b, double p)
{
    double ca = 134217729.0 * a, ah = ca - (ca - a), al = a - ah;
    double cb = 134217729.0 * b, bh = cb - (cb - b), bl = b - bh;
    return ((ah * bh - p) + ah * bl + al * bh) + al * bl;
}

/* v rounded to the nearest multiple of 2^qe (ties to even: an odd function of v) by adding and
 * subtracting 1.5 2^(qe + 52); v itself where that constant is not a normal double or v is not
 * finite. Deterministic, no library call; |v| < 2^(qe + 51) here (coarsen_y). */
static inline double round_to(double v, int qe)
{
    int ce = qe + 52;
    if (ce < -1022 || ce > 1023 || !isfinite(v)) return v;
    uint64_t b = (uint64_t)(ce + 1023) << 52;
    double C;
    memcpy(&C, &b, sizeof C);
    C *= 1.5;
    return (v + C) - C;
}

/* The binary exponent of the largest |v[j]| over j = a, a + 1, ..., b - 1 (bit patterns compared
 * as integers: no library call), -1075 if all are zero; NaN and Inf give 1024. */
static inline int max_expo(const double *v, size_t a, size_t b)
{
    uint64_t m = 0;
    for (size_t j = a; j < b; j++) {
        uint64_t u;
        memcpy(&u, &v[j], sizeof u);
        u &= ~((uint64_t)1 << 63);
        if (u > m) m = u;
    }
    int e = (int)(m >> 52);
    return e == 0 ? (m == 0 ? -1075 : -1023) : e - 1023;
}

static void coarsen_y(size_t n, const double *v, double *c)
{
    int eq = max_expo(v, 0, n) - COARSE_BITS, et = max_expo(v, n, n + 1) - COARSE_BITS;
    int ep = max_expo(v, n + 1, 2 * n + 1) - COARSE_BITS;
    for (size_t i = 0; i < n; i++) {
        c[i] = round_to(v[i], eq);
        c[n + 1 + i] = round_to(v[n + 1 + i], ep);
    }
    c[n] = round_to(v[n], et);
}

/* The vertex offset rho = H(z_k) evaluated directly (a start, or after a regularizer's step),
 * over y at the high part (rho_from_mid_n says why). */
static int rho_direct(dth_integrator *it)
{
    size_t N = it->N;
    double Hp;
    if (it->rev) { /* the vertex point rho_from_mid_n reads (and keeps) */
        coarsen_y(it->n, it->st.z, it->vc);
        it->vc[N - 1] = it->st.z[N - 1];
        memcpy(it->vcsrc, it->st.z, N * sizeof *it->vc);
    }
    int rc = dth_model_eval(it->model, it->rev ? it->vc : it->st.z, DTH_EVAL_H, &Hp, NULL, NULL);
    if (rc) return rc;
    it->st.rho = two_sum(it->st.z[N - 1], it->st.zlo[N - 1] + Hp, &it->st.rholo);
    return DTH_OK;
}

int dth__integrator_rho_reset(dth_integrator *it) { return it->opt.finish ? rho_direct(it) : DTH_OK; }

/* Inline kernels take nc: the number of degrees of freedom when it is a compile-time constant
 * (the small path instantiates them for n = 1, 2, 3, so their loops unroll; nc > 0 implies an
 * autonomous model), else 0 (it->n). */
#define AI static inline __attribute__((always_inline))

/*
 * The vertex offset's difference H(c) - H(zbar), in double-double (rho + rholo), without
 * cancellation: c is the vertex's high part over y (coarsened by coarsen_y in the reversible
 * finish), wp enters by both parts, and zbar = zb + dyh + zblo, zb the point the model was read at
 * (dyh: the reversible finish's offset from its coarse point y = zb to the midpoint's high part,
 * NULL otherwise; zblo may be NULL). Terms: the wp difference, the model's hdiff between c and zb,
 * and minus (grad + gl/2) (dyh + zblo), the Taylor terms to the midpoint (grad at zb; gl = H''(zb)
 * (dyh + zblo), NULL: none), g dyh exactly. The carried offset rho is thus H at each vertex's c: a
 * definition, exact to O(eps^2), that keeps the step's equations a function of (vertex, rho)
 * alone. The vertex's low part shows in the midpoint (zbar carries it), where the gradient is the
 * right one; read through the midpoint's gradient at the vertex it would err by |H''| |d| |zlo|,
 * about eps |d| per step, the noise that random-walked the offset and the round trip's phase.
 * The midpoint's low part matters: a double midpoint moves in steps of eps |zbar|, which changes
 * H by eps S.
 */
AI int rho_from_mid_n(dth_integrator *it, const size_t nc, const double *zb, const double *dyh, const double *zblo,
                     const double *grad, const double *gl, const double *z, const double *zlo, double *rho, double *rholo)
{
    size_t d = nc ? 2 * nc + 1 : it->d, N = d + 1;
    double dh;
    const double *c = z;
    int rc;
    if (it->rev) { /* the coarsened vertex (wp as it is), kept for the vertex it was made from */
        if (memcmp(z, it->vcsrc, N * sizeof *z) != 0) {
            coarsen_y(nc ? nc : it->n, z, it->vc);
            it->vc[d] = z[d];
            memcpy(it->vcsrc, z, N * sizeof *z);
        }
        c = it->vc;
    }
    if (it->mhdiff) { /* dth__model_hdiff without the call */
        rc = it->mhdiff(it->mself, c, zb, &dh);
        if (rc) return rc > 0 ? DTH_EDOMAIN : DTH_EMODEL;
        if (!isfinite(dh)) return DTH_EDOMAIN;
    } else {
        rc = dth__model_hdiff(it->model, c, zb, it->hwork, &dh);
        if (rc) return rc;
    }
    double wph = z[N - 1] - zb[N - 1], wpl = zlo[N - 1] - (zblo ? zblo[N - 1] : 0), l2;
    if (!dyh) { /* the compensated default: the midpoint's low part through the gradient there */
        double lo = 0;
        if (zblo)
            for (size_t j = 0; j < d; j++) lo -= grad[j] * zblo[j];
        double h2 = two_sum(dh, wph, &l2);
        *rho = two_sum(h2, l2 + (wpl + lo), rholo);
        return DTH_OK;
    }
    /* minus (g + gl/2) (dyh + zblo): g dyh exactly (dyh is up to 2^-27 |zb|), in double-double */
    double s = 0, e = 0, r = 0;
    for (size_t j = 0; j < d; j++) {
        double h = dyh ? dyh[j] : 0, l = zblo ? zblo[j] : 0, gj = grad[j], t;
        if (h != 0) {
            double p = gj * h, pe = prod_err(gj, h, p);
            s = two_sum(s, p, &t);
            e += t + pe;
        }
        r += gj * l + (gl ? 0.5 * gl[j] * (h + l) : 0);
    }
    /* the wp difference by its parts (a non-autonomous step moves wp by about lambda dH/dt, as
     * large as dh: rounded into the low part it would be noise of eps |dH/dt| lambda) */
    double l1, h1 = two_sum(dh, -s, &l1), h2 = two_sum(h1, wph, &l2);
    *rho = two_sum(h2, (l1 + l2) + (wpl - (e + r)), rholo);
    return DTH_OK;
}

static int rho_from_mid(dth_integrator *it, const double *zb, const double *zblo, const double *grad, const double *z,
                        const double *zlo, double *rho, double *rholo)
{
    return rho_from_mid_n(it, 0, zb, NULL, zblo, grad, NULL, z, zlo, rho, rholo);
}

static void reset_history(dth_integrator *it)
{
    it->st.nhist = 0;
    it->st.have_prev = 0;
    it->st.have_mid = 0;
    it->st.fact_valid = 0;
    it->st.pending_exact = 0;
    it->st.steps = 0;
    it->st.psi_known = 0;
    it->st.psi_prev = 0;
    it->st.psi_step = -2;
}

static double cubic_predict(double Hk, double psi, double dpsi, double target);
static int newton(dth_integrator *it, double lam0, const double *d0, int max_iter, dth__solution *sol);

/*
 * Vertex start: the vertex offset rho = H(z_0) whose first DTH step is exactly h. The offset
 * encodes the step (Lemma g_taylor: rho = psi h^2/8 + psi' h^3/24 + O(h^4)), and the Taylor term
 * alone misses it at large steps (harmonic omega h = 1.9: a first step of 3.2 h). A secant on rho
 * from the cubic model's value, each iterate an ordinary step solve from (y, wp = rho - H_phys(y)),
 * not committed, until lambda = h to a few ulps. Hp = H_phys(y). On failure the message names h.
 */
static int vertex_offset(dth_integrator *it, const double *y, double Hp, double h, double *rho_out)
{
    size_t N = it->N;
    double psi, dpsi;
    int rc = dth_model_psi(it->model, y, &psi, &dpsi, it->work);
    if (rc) {
        seterr(it, "model evaluation failed at the initial state");
        return rc;
    }
    double rho = psi * h * h / 8 + dpsi * h * h * h / 24, rp = 0, fp = 0;
    if (!(rho != 0) || !isfinite(rho)) rho = psi * h * h / 8;
    /* the step limit is for steps, not this solve */
    int ok = 0, max_iter = it->opt.max_iter < 30 ? 30 : it->opt.max_iter;
    double best = INFINITY, rbest = rho;
    for (int k = 0; k < 16; k++) {
        for (size_t j = 0; j < N - 1; j++) it->st.z[j] = y[j];
        it->st.z[N - 1] = rho - Hp;
        memset(it->st.zlo, 0, N * sizeof *it->st.zlo);
        reset_history(it);
        it->st.dir = h > 0 ? 1.0 : -1.0;
        double Hv, lam0;
        if ((it->opt.finish && (rc = rho_direct(it))) ||
            (rc = dth_model_eval(it->model, it->st.z, DTH_EVAL_H | DTH_EVAL_GRAD, &Hv, it->grad, NULL))) {
            seterr(it, "model evaluation failed at the initial vertex");
            return rc;
        }
        lam0 = cubic_predict(it->st.z[N - 1] + Hv, psi, dpsi, h);
        dth__flow_z(it->n, it->grad, it->u);
        for (size_t j = 0; j < N; j++) it->znewlo[j] = 0.5 * lam0 * it->u[j];
        dth__solution sol = {NAN, NAN, 0};
        rc = newton(it, lam0, it->znewlo, max_iter, &sol);
        if (rc < 0) break;
        if (rc || !(sol.lambda * h > 0)) {
            rc = DTH_OK;
            break;
        }
        /* lambda is known to its conditioning only: keep the best iterate, stop at 8 ulps or where
         * the secant no longer moves rho (the noise floor) */
        double f = sol.lambda - h;
        if (fabs(f) < best) best = fabs(f), rbest = rho;
        if (fabs(f) <= 8 * DBL_EPSILON * fabs(h)) break;
        double rn;
        if (k == 0 || f == fp) rn = rho * (h / sol.lambda) * (h / sol.lambda); /* rho ~ lambda^2 */
        else rn = rho - f * (rho - rp) / (f - fp);
        if (!isfinite(rn) || fabs(rn - rho) <= 2 * DBL_EPSILON * fabs(rho)) break;
        rp = rho, fp = f, rho = rn;
    }
    if (rc < 0) return rc;
    rho = rbest;
    ok = best <= 1e-10 * fabs(h);
    if (!ok) {
        seterr(it, "no vertex offset gives a first step of h = %.17g from this state (the step equations have no "
                   "root of that size here): a smaller [integrator] h, a midpoint start, or an explicit wp",
               h);
        return DTH_ENOROOT;
    }
    *rho_out = rho;
    return DTH_OK;
}

/*
 * The reversible finish's exact first step of a midpoint start: the offset d = (h/2) u(zbar_0) in
 * double-double (dhi + dlo, N entries each), with u = J grad H read at the coarse point of zbar_0
 * and its Taylor term (coarse_n), the products exact, as the chord steps' rows have them: the step
 * back from the first vertex then solves the very equations this step satisfies. Leaves it->yc,
 * it->ydel, it->grad, it->hess at that point and it->zblo zero (the midpoint is zbar_0, a double).
 */
/*
 * The reversible finish's Taylor term gl = H''(y) (dy + zblo) (it->hess at the coarse point y, d x d)
 * in double-double, gl + gll: the products with dy, up to 2^-27 of the scale, exactly (their
 * rounding would be noise in the step's equations); zblo's are small. As (J gl)_j over z by
 * j_of_gl, the way dth__flow_z maps the gradient.
 */
static void taylor_grad(const dth_integrator *it, size_t d, const double *dy, const double *zblo, double *gl,
                        double *gll)
{
    for (size_t j = 0; j < d; j++) {
        double a = 0, al = 0, t;
        for (size_t k = 0; k < d; k++) {
            double h = it->hess[j * d + k], p = h * dy[k];
            a = two_sum(a, p, &t);
            al += (t + prod_err(h, dy[k], p)) + h * zblo[k];
        }
        gl[j] = two_sum(a, al, &gll[j]);
    }
}

/* (J v)_j over z = (q, t, p, wp) for v over y = (q, t, p) (n degrees of freedom, d = 2n + 1). */
static inline double j_of_gl(size_t n, size_t d, size_t j, const double *v)
{
    return j < n ? v[n + 1 + j] : j == n ? 0 : j < d ? -v[j - n - 1] : -v[n];
}

static inline void coarse_n(dth_integrator *it, const size_t nc, const double *zb, double *dy);
static int exact_offset_rev(dth_integrator *it, const double *zbar, double h, double *dhi, double *dlo)
{
    size_t n = it->n, N = it->N, d = it->d;
    memcpy(it->zb, zbar, N * sizeof *zbar);
    memset(it->zblo, 0, N * sizeof *it->zblo);
    coarse_n(it, 0, it->zb, it->ydel);
    double H;
    int rc = it->meval(it->mself, it->yc, DTH_EVAL_H | DTH_EVAL_GRAD | DTH_EVAL_HESS, &H, it->grad, it->hess);
    if (rc) return rc > 0 ? DTH_EDOMAIN : DTH_EMODEL;
    double *gl = it->ygl, *gll = it->ybar, *u = it->u, hl = 0.5 * h;
    taylor_grad(it, d, it->ydel, it->zblo, gl, gll);
    dth__flow_z(n, it->grad, u);
    for (size_t j = 0; j < N; j++) {
        double ulh = j_of_gl(n, d, j, gl), ull = j_of_gl(n, d, j, gll);
        if (it->auton && j == N - 1) ulh = ull = 0; /* wp stays */
        double p = hl * u[j], q = hl * ulh, e;
        double s = two_sum(p, q, &e);
        dhi[j] = two_sum(s, (prod_err(hl, u[j], p) + prod_err(hl, ulh, q) + hl * ull) + e, &dlo[j]);
    }
    return DTH_OK;
}

int dth_integrator_start(dth_integrator *it, const double *q0, const double *p0, double t0)
{
    if (!it || !q0 || !p0 || !isfinite(t0)) return DTH_EINVAL;
    size_t n = it->n, N = it->N;
    for (size_t i = 0; i < n; i++)
        if (!isfinite(q0[i]) || !isfinite(p0[i])) {
            seterr(it, "initial value %zu is not finite", i);
            return DTH_EINVAL;
        }
    double *y = it->ybar, H;
    double h = it->st.h;
    if (!(fabs(h) > 2 * DBL_EPSILON * fabs(t0))) {
        seterr(it, "the time t0 = %.17g does not advance by steps of h = %.3g (t + h == t)", t0, h);
        return DTH_EINVAL;
    }
    memcpy(y, q0, n * sizeof *y);
    y[n] = t0;
    memcpy(y + n + 1, p0, n * sizeof *y);
    if (it->opt.start == DTH_START_MIDPOINT) {
        int rc = dth_model_eval(it->model, y, DTH_EVAL_H | DTH_EVAL_GRAD, &H, it->grad, NULL);
        if (rc) {
            seterr(it, "model evaluation failed at the initial state");
            return rc;
        }
        memcpy(it->zb, y, (N - 1) * sizeof *y);
        it->zb[N - 1] = -H;
        dth__flow_z(n, it->grad, it->u);
        /* z_0 = zbar_0 - (h/2) u, kept in double-double so the first step returns to zbar_0 (the
         * reversible finish: its offset in double-double, exact_offset_rev) */
        double *dlo = it->znewlo, *dhi = it->znew;
        if (it->rev) {
            rc = exact_offset_rev(it, it->zb, h, dhi, dlo);
            if (rc) {
                seterr(it, "model evaluation failed at the initial state");
                return rc;
            }
        } else {
            for (size_t j = 0; j < N; j++) dhi[j] = 0.5 * h * it->u[j], dlo[j] = 0;
        }
        for (size_t j = 0; j < N; j++)
            if (!isfinite(it->zb[j] - dhi[j]) || !isfinite(it->zb[j] + dhi[j])) {
                seterr(it, "the first vertex overflows (component %zu): h is too large", j);
                return DTH_EDOMAIN;
            }
        reset_history(it);
        memcpy(it->st.zbar, it->zb, N * sizeof *it->zb);
        for (size_t j = 0; j < N; j++) {
            double e, s = two_sum(it->st.zbar[j], -dhi[j], &e);
            it->st.dprev[j] = dhi[j];
            it->st.z[j] = two_sum(s, e - dlo[j], &it->st.zlo[j]);
        }
        if (it->rev) {
            /* from the coarse point, as every later step's offset (exact_offset_rev left it there) */
            rc = rho_from_mid_n(it, 0, it->yc, it->ydel, NULL, it->grad, it->ygl, it->st.z, it->st.zlo, &it->st.rho,
                                &it->st.rholo);
            if (rc) {
                seterr(it, "model evaluation failed at the first vertex");
                return rc;
            }
        } else if (it->opt.finish) {
            /* H(zbar_0) = wp + H_phys = 0 exactly (wp = -H_phys) */
            rc = rho_from_mid(it, it->st.zbar, NULL, it->grad, it->st.z, it->st.zlo, &it->st.rho, &it->st.rholo);
            if (rc) {
                seterr(it, "model evaluation failed at the first vertex");
                return rc;
            }
        }
        it->st.lam = 0;
        it->st.lam_hint = h;
        it->st.dir = h > 0 ? 1.0 : -1.0;
        it->st.pending_exact = 1;
        return DTH_OK;
    }
    double wp;
    if (it->opt.has_wp) {
        wp = it->opt.wp;
    } else {
        int rc = dth_model_eval(it->model, y, DTH_EVAL_H, &H, NULL, NULL);
        if (rc) {
            seterr(it, "model evaluation failed at the initial state");
            return rc;
        }
        double rho;
        rc = vertex_offset(it, y, H, h, &rho);
        if (rc) return rc;
        wp = rho - H;
    }
    for (size_t j = 0; j < N - 1; j++) it->st.z[j] = y[j];
    it->st.z[N - 1] = wp;
    return dth_integrator_set_vertex(it, it->st.z, h);
}

int dth_integrator_set_vertex(dth_integrator *it, const double *z, double lambda)
{
    if (!it || !z || !isfinite(lambda) || lambda == 0) return DTH_EINVAL;
    for (size_t j = 0; j < it->N; j++)
        if (!isfinite(z[j])) return DTH_EINVAL;
    if (z != it->st.z) memcpy(it->st.z, z, it->N * sizeof *z);
    memset(it->st.zlo, 0, it->N * sizeof *it->st.zlo);
    if (it->opt.finish) {
        int rc = rho_direct(it);
        if (rc) {
            seterr(it, "model evaluation failed at the vertex");
            return rc;
        }
    }
    reset_history(it);
    it->st.lam = 0;
    it->st.lam_hint = lambda;
    it->st.dir = lambda > 0 ? 1.0 : -1.0;
    return DTH_OK;
}

void dth_integrator_reverse(dth_integrator *it)
{
    /* The backward step from z_k has the midpoint of the last step: d -> -d, lambda -> -lambda. */
    for (size_t j = 0; j < it->N; j++) it->st.dprev[j] = -it->st.dprev[j];
    it->st.lam = -it->st.lam;
    it->st.lam_hint = -it->st.lam_hint;
    it->st.dir = -it->st.dir;
    it->st.h = -it->st.h;
    if (it->st.nhist > 1) it->st.nhist = 1; /* the offsets before the last one lie ahead now */
    if (it->st.pending_exact) {
        /* not stepped yet from a midpoint start: reversing means the exact step goes backward */
        it->st.pending_exact = 0;
        it->st.have_prev = 0;
        it->st.lam_hint = -it->st.h;
    }
}

/* a + b, and with lo != NULL its rounding error in *lo */
AI double sum_lo(double a, double b, double *lo) { return lo ? two_sum(a, b, lo) : a + b; }

/*
 * zbar = (z + zlo) + (x + xlo) for the unknowns x and their low part xlo (the finishing chord
 * steps' roundings, newton.h; zero during the iterations); passive t, wp in closed form
 * (autonomous). zblo (NULL: not wanted) gets the low part, zb + zblo = z + zlo + x + xlo to
 * O(eps^2 |zbar|): the finishing midpoint is not quantized to the ulp of the offset d, which would
 * leave an energy residual of eps |grad H| |d| at the midpoint (and a vertex offset that the
 * reverse step does not reproduce). Without zblo, the double sum the iterations need.
 */
AI double mid_dd(int rev, double z, double zlo, double x, double xlo, double *lo)
{
    if (!lo) return z + (zlo + x);
    if (!rev) return two_sum(z, zlo + x, lo); /* to the rounding of zlo + x, far below eps |zbar| */
    double e, s = two_sum(z, x, &e);
    return two_sum(s, (zlo + xlo) + e, lo);
}

AI void midpoint_n(const dth_integrator *it, const size_t nc, const double *x, double *zb, double *zblo)
{
    size_t n = nc ? nc : it->n, N = 2 * n + 2;
    int m = nc ? (int)(2 * nc + 1) : it->m;
    const double *z = it->st.z, *zlo = it->st.zlo, *xl = it->xlo; /* NULL unless rev: mid_dd reads it then only */
    if (nc || it->auton) {
        /* unknowns (d_q, d_p, lambda) */
        for (size_t i = 0; i < n; i++) {
            zb[i] = mid_dd(it->rev, z[i], zlo[i], x[i], xl ? xl[i] : 0, zblo ? &zblo[i] : NULL);
            zb[n + 1 + i] = mid_dd(it->rev, z[n + 1 + i], zlo[n + 1 + i], x[n + i], xl ? xl[n + i] : 0, zblo ? &zblo[n + 1 + i] : NULL);
        }
        zb[n] = mid_dd(it->rev, z[n], zlo[n], 0.5 * x[m - 1], xl ? 0.5 * xl[m - 1] : 0, zblo ? &zblo[n] : NULL);
        zb[N - 1] = sum_lo(z[N - 1], zlo[N - 1], zblo ? &zblo[N - 1] : NULL);
        return;
    }
    for (int a = 0; a < m - 1; a++) zb[a] = mid_dd(it->rev, z[a], zlo[a], x[a], xl ? xl[a] : 0, zblo ? &zblo[a] : NULL);
}

/* The Newton unknowns it->x from a step: the offset d (length N) over the active components, then
 * lambda. */
AI void unknowns_n(dth_integrator *it, const size_t nc, const double *d, double lam)
{
    size_t n = nc ? nc : it->n;
    int m = nc ? (int)(2 * nc + 1) : it->m;
    double *x = it->x;
    if (nc) {
        for (size_t i = 0; i < n; i++) {
            x[i] = d[i];
            x[n + i] = d[n + 1 + i];
        }
    } else {
        for (int a = 0; a < m - 1; a++) x[a] = d[it->act[a]];
    }
    x[m - 1] = lam;
    if (it->xlo) memset(it->xlo, 0, (size_t)m * sizeof *it->xlo);
    it->ypinned = 0;
}

void dth__integrator_set_solution(dth_integrator *it, const double *d, double lam)
{
    unknowns_n(it, 0, d, lam);
    midpoint_n(it, 0, it->x, it->zb, NULL);
}

/*
 * Residual F and, if A != NULL, the Jacobian A (column-major m x m) at the unknowns x, given
 * grad and hess of H_phys at the midpoint zb. F_a = d_j - (lambda/2) u_j(zbar); F_last = H(zbar).
 */
AI void assemble_n(const dth_integrator *it, const size_t nc, const double *x, const double *zb, double Hphys, double *F,
                   double *A)
{
    size_t n = nc ? nc : it->n, N = 2 * n + 2;
    int m = nc ? (int)(2 * nc + 1) : it->m;
    const double *g = it->grad, *Hy = it->hess;
    double lam = x[m - 1], hl = 0.5 * lam;
    F[m - 1] = zb[N - 1] + Hphys;
    if (nc || it->auton) {
        /* rows q_i: d_q - (lambda/2) dH/dp_i;  rows p_i: d_p + (lambda/2) dH/dq_i */
        size_t mm = (size_t)m;
        for (size_t i = 0; i < n; i++) {
            F[i] = x[i] - hl * g[n + 1 + i];
            F[n + i] = x[n + i] + hl * g[i];
        }
        if (!A) return;
        for (size_t i = 0; i < n; i++) {
            for (size_t k = 0; k < n; k++) {
                A[i + k * mm] = -hl * dth__dudz(n, Hy, i, k);                     /* dF_qi / d d_qk */
                A[i + (n + k) * mm] = -hl * dth__dudz(n, Hy, i, n + 1 + k);        /* dF_qi / d d_pk */
                A[n + i + k * mm] = -hl * dth__dudz(n, Hy, n + 1 + i, k);
                A[n + i + (n + k) * mm] = -hl * dth__dudz(n, Hy, n + 1 + i, n + 1 + k);
            }
            A[i + i * mm] += 1.0;
            A[n + i + (n + i) * mm] += 1.0;
            A[i + 2 * n * mm] = -0.5 * g[n + 1 + i];       /* dF / d lambda = -u/2 */
            A[n + i + 2 * n * mm] = 0.5 * g[i];
            A[2 * n + i * mm] = g[i];                      /* border: grad H */
            A[2 * n + (n + i) * mm] = g[n + 1 + i];
        }
        A[2 * n + 2 * n * mm] = 0.0;
        return;
    }
    double *u = it->u;
    dth__flow_z(n, g, u);
    for (int a = 0; a < m - 1; a++) {
        size_t j = (size_t)it->act[a];
        F[a] = x[a] - hl * u[j];
        if (!A) continue;
        for (int b = 0; b < m - 1; b++) A[a + b * m] = (a == b ? 1.0 : 0.0) - hl * dth__dudz(it->n, it->hess, j, (size_t)it->act[b]);
        A[a + (m - 1) * m] = -0.5 * u[j];
        A[(m - 1) + a * m] = (j == N - 1) ? 1.0 : g[j];
    }
    if (A) A[(m - 1) + (m - 1) * m] = 0.0;
}

static void assemble(const dth_integrator *it, const double *x, const double *zb, double Hphys, double *F, double *A)
{
    assemble_n(it, 0, x, zb, Hphys, F, A);
}

/* Scale of the terms of H at the midpoint, for round-off judgements. */
AI double h_scale_n(const dth_integrator *it, const size_t nc, const double *zb, double Hphys)
{
    size_t d = nc ? 2 * nc + 1 : it->d;
    double s = fabs(zb[d]) + fabs(Hphys);
    for (size_t j = 0; j < d; j++) s += fabs(it->grad[j] * zb[j]);
    return s;
}

static double h_scale(const dth_integrator *it, const double *zb, double Hphys) { return h_scale_n(it, 0, zb, Hphys); }

/* The cubic model of the constraint (Lemma g_taylor): root of H - psi l^2/8 - dpsi l^3/24 near
 * `target`, on its side of 0; `target` itself if the cubic has none there. */
static double cubic_predict(double Hk, double psi, double dpsi, double target)
{
    double l = target;
    if (psi != 0 && Hk / psi > 0) l = copysign(sqrt(8 * Hk / psi), target);
    for (int i = 0; i < 20; i++) {
        double c = Hk - psi * l * l / 8 - dpsi * l * l * l / 24;
        double dc = -psi * l / 4 - dpsi * l * l / 8;
        if (dc == 0) break;
        double ln = l - c / dc;
        if (!isfinite(ln) || ln * target <= 0) return target;
        if (fabs(ln - l) <= 1e-15 * fabs(l)) {
            l = ln;
            break;
        }
        l = ln;
    }
    return (l * target > 0 && fabs(l) < 16 * fabs(target) && fabs(l) > fabs(target) / 16) ? l : target;
}

/* Block of a z-index: 0 positions q, 1 time t, 2 momenta p, 3 wp. */
static int block_of(const dth_integrator *it, int j)
{
    size_t n = it->n;
    return j < (int)n ? 0 : j == (int)n ? 1 : j < (int)(2 * n + 1) ? 2 : 3;
}

/*
 * Convergence is judged per block (q, t, p, wp) in the max-norm of |z| + |zbar|, not per
 * component: a component that is itself round-off sized (a particle at rest) has no relative
 * precision to reach. An all-zero block falls back to the largest block scale.
 */
AI double block_max(const double *z, const double *zb, size_t lo, size_t hi)
{
    double s = 0;
    for (size_t j = lo; j < hi; j++) {
        double v = fabs(z[j]) + fabs(zb[j]);
        if (v > s) s = v;
    }
    return s;
}

AI void block_scales_n(dth_integrator *it, const size_t nc, const double *zb, double bs[4])
{
    size_t n = nc ? nc : it->n;
    double top = 0;
    bs[0] = block_max(it->st.z, zb, 0, n);
    bs[1] = block_max(it->st.z, zb, n, n + 1);
    bs[2] = block_max(it->st.z, zb, n + 1, 2 * n + 1);
    bs[3] = block_max(it->st.z, zb, 2 * n + 1, 2 * n + 2);
    for (int b = 0; b < 4; b++)
        if (bs[b] > top) top = bs[b]; /* fmax without the call: top is never NaN */
    for (int b = 0; b < 4; b++)
        if (bs[b] == 0) bs[b] = top > 0 ? top : 1.0;
    it->ibq = 1 / bs[0]; /* the judge multiplies (a division per iteration costs more than the rest) */
    it->ibp = 1 / bs[2];
}

/* ---- the step as a Newton problem (newton.h) ---- */

/*
 * The linear-solver table: the path that factors and solves the step's bordered system (paper,
 * Theorem "DTH Equations") and gives its tangent map. Dense (kinds dense, small, small-lu): the
 * Jacobian assembled from the dense Hessian, LU by LAPACK or written out (dth__lu_*); the small
 * path's instances for n = 1..3 (SMALL_OPS below) inline the same LU or their Schur complement.
 * Banded (banded, banded-lu): banded.c, which evaluates the model's banded Hessian itself.
 */
struct dth__linsolver {
    unsigned hess; /* DTH_EVAL_HESS: the Newton loop evaluates the dense Hessian and assembles it->A */
    int (*factor)(dth_integrator *it, double lam); /* at it->zb (gradient in it->grad) */
    int (*solve)(dth_integrator *it, double *b);   /* b = J^-1 b with the last factors */
    int (*tangent)(dth_integrator *it, double *M); /* the last step's tangent map (refactors) */
};

static int dense_factor(dth_integrator *it, double lam)
{
    (void)lam;
    return dth__lu_factor(it->kind, it->m, it->A, it->piv);
}
static int dense_solve(dth_integrator *it, double *b) { return dth__lu_solve(it->kind, it->m, it->A, it->piv, 1, b); }
static int dense_tangent(dth_integrator *it, double *M);
static int band_factor(dth_integrator *it, double lam)
{
    return dth__band_factor(it->band, it->model, it->zb, it->grad, lam);
}
static int band_solve(dth_integrator *it, double *b) { return dth__band_solve(it->band, b); }
static int band_tangent(dth_integrator *it, double *M)
{
    return dth__band_tangent(it->band, it->model, it->st.zbar, it->st.lam, M);
}

static const struct dth__linsolver dense_ls = {DTH_EVAL_HESS, dense_factor, dense_solve, dense_tangent};
static const struct dth__linsolver band_ls = {0, band_factor, band_solve, band_tangent};

static const struct dth__linsolver *linsolver_of(dth_linsolve kind)
{
    return dth__linsolve_find(kind)->banded ? &band_ls : &dense_ls;
}

/*
 * The reversible finish (compensate = 2): the point y where a chord step evaluates the model, and
 * dy = zbar - y (zbar = zb + zblo, dy's high part here, zblo the rest): y is the midpoint coarsened
 * to a multiple of 2^-28 of its blocks' scales (coarsen_y), and the step reads the model there with
 * its Taylor terms, g(zbar) = g(y) + H''(y) dy and H(zbar) = H(y) + (g + H'' dy / 2) dy. With
 * dy <= 2^-27 of the scale the gradient's next term, H''' dy^2 / 2, is about eps (a fixed, smooth
 * change of the equations, as the model's own rounding is) and the energy's below eps^2. Why not at
 * zbar itself: the model's values carry their own rounding, eps |g|, different at every double
 * point, and lambda amplifies a change of the equations by about 1/lambda^2 (it is fixed at second
 * order); where the chord steps move the double midpoint by an ulp, the equations jump and the step
 * and its reverse settle at different roots. The coarse point is the same for both (their
 * double-double midpoints agree to about 2^-100) unless the root lies within that rounding of a
 * cell's edge (step_again). Pinned (step_again): y stays.
 */
static inline void coarse_n(dth_integrator *it, const size_t nc, const double *zb, double *dy)
{
    size_t d = nc ? 2 * nc + 1 : it->d;
    if (!it->ypinned) coarsen_y(nc ? nc : it->n, zb, it->yc);
    for (size_t j = 0; j < d; j++) {
        double c = it->yc[j];
        dy[j] = zb[j] - c; /* exact (c is a multiple of zb's ulp within 2^-28 of the scale); zblo is the rest */
    }
    it->yc[d] = zb[d];
    dy[d] = 0;
}

/*
 * (x + xlo) - (hl + hlo) (u + ulh + ull) with one rounding at the end: the products hl u and hl ulh
 * exactly (prod_err gives their errors), where ulh + ull = (J H''(y) (zbar - y))_j, up to 2^-27 |u|.
 */
AI double exact_row(double x, double xlo, double hl, double hlo, double u, double ulh, double ull)
{
    double ph = hl * u, pl = prod_err(hl, u, ph), qh = hl * ulh, ql = prod_err(hl, ulh, qh), e1, e2;
    double s1 = two_sum(x, -ph, &e1), s2 = two_sum(s1, -qh, &e2);
    return s2 + (((((xlo - pl) - ql) - hlo * u) - (hl * ull + hlo * ulh)) + (e1 + e2));
}

/*
 * The compensated finish of a step, as the residual of its chord steps (newton.h): the constraint
 * row from the carried vertex offset, E = rho_k + (H(zbar) - H(z_k)), the difference from the
 * model's hdiff: its error scales with the step instead of with the energy's size. The direct value
 * wp + H_phys(zbar) (in F on entry) carries eps S, S = |wp| + |H_phys| + sum |dH/dy_j y_j|, and
 * lambda is fixed by a second-order effect (paper, Lemma g_taylor), so that noise moves lambda by
 * about 4 eps S / (|psi| lambda^2): the reason for the carried offset.
 * The carried offset random-walks by about eps sum |dH/dy_j delta_j| per step; where it has drifted
 * from the direct value by more than tau = 4 eps S, the step takes the direct value instead (and
 * the next offset is measured from this midpoint again), so the midpoint energy stays within tau of
 * exact. Both rules give the backward step the same equation at the same midpoint (the carried
 * offset of z_(k+1) is measured from zbar), so the map stays time-reversible. it->zb, it->zblo,
 * it->Hphys and it->grad belong to x (eval_n).
 */
AI int compensated_n(dth_integrator *it, const size_t nc, const double *x, double *F)
{
    size_t n = nc ? nc : it->n;
    int m = nc ? (int)(2 * nc + 1) : it->m;
    /* the offset rows d - (lambda/2) u to O(eps^2 |d|), with the low parts of the unknowns: a
     * residual rounded to eps |d| moves lambda by about eps |d| |grad H| / (|psi| lambda^2 / 4) (the
     * constraint fixes lambda at second order), which the reverse step would not reproduce */
    size_t d = 2 * n + 1;
    if (!it->rev) { /* the compensated constraint alone (the rows as assemble_n has them) */
        double dh, dhlo;
        int rc = rho_from_mid_n(it, nc, it->zb, NULL, it->zblo, it->grad, NULL, it->st.z, it->st.zlo, &dh, &dhlo);
        if (rc) {
            seterr(it, "model evaluation failed in the compensated constraint: %s", dth_strerror(rc));
            return rc;
        }
        double ec = (it->st.rho - dh) + (it->st.rholo - dhlo), rd = F[m - 1];
        double tau = 4 * DBL_EPSILON * h_scale_n(it, nc, it->zb, it->Hphys);
        F[m - 1] = fabs(ec - rd) <= tau ? ec : rd;
        return DTH_OK;
    }
    const double *xl = it->xlo, hl = 0.5 * x[m - 1], hlo = 0.5 * xl[m - 1], *dy = it->ydel;
    /* the gradient's change from y to the midpoint, gl = H''(y) (zbar - y), in double-double (the
     * products with dy, up to 2^-27 |zbar|, exactly): its rounding would be noise in the rows */
    double *gl = it->ygl, *gll = it->ybar;
    taylor_grad(it, d, dy, it->zblo, gl, gll);
    if (nc || it->auton) {
        for (size_t i = 0; i < n; i++) {
            F[i] = exact_row(x[i], xl[i], hl, hlo, it->grad[n + 1 + i], gl[n + 1 + i], gll[n + 1 + i]);
            F[n + i] = exact_row(x[n + i], xl[n + i], hl, hlo, -it->grad[i], -gl[i], -gll[i]);
        }
    } else {
        for (int a = 0; a < m - 1; a++) {
            size_t j = (size_t)it->act[a];
            F[a] = exact_row(x[a], xl[a], hl, hlo, it->u[j], j_of_gl(n, d, j, gl), j_of_gl(n, d, j, gll));
        }
    }
    double dh, dhlo;
    int rc = rho_from_mid_n(it, nc, it->yc, dy, it->zblo, it->grad, gl, it->st.z, it->st.zlo, &dh, &dhlo); /* H(z_k) - H(zbar) */
    if (rc) {
        seterr(it, "model evaluation failed in the compensated constraint: %s", dth_strerror(rc));
        return rc;
    }
    /* no fallback to the direct value here: the carried offset is what makes the step its own
     * reverse (its random walk, eps |grad H| |d| per step, is the energy's) */
    F[m - 1] = (it->st.rho - dh) + (it->st.rholo - dhlo);
    return DTH_OK;
}

/*
 * The small path's Schur complement (dth__small_schur) at the Hessian and gradient in it->hess /
 * it->grad: 0 if it applies (q-p block zero, T'' diagonal and positive, K and the border regular),
 * else 1 (the caller factors the whole bordered matrix). Eliminating d_p from B (d_q, d_p) = r gives
 *     K w_q = r_q + (lambda/2) T'' r_p,   w_p = r_p - (lambda/2) V'' w_q,   K = I + (lambda^2/4) T'' V''
 * (T'' times the symmetric T''^-1 + (lambda^2/4) V'' of banded.c: no division by T''). The border:
 * y2 = B^-1 c = c + e with B e = c - B c = (lambda/4) (T'' g_q, V'' g_p), so that s = -g^T y2 = -g^T e
 * (g^T c = 0 exactly, pair by pair) is computed without cancellation.
 */
AI int schur_factor_n(dth_integrator *it, const size_t n, double lam)
{
    dth__small_schur *S = &it->ss;
    const size_t d = 2 * n + 1;
    const double *Hy = it->hess, *g = it->grad;
    for (size_t i = 0; i < n; i++) {
        double tpp = Hy[(n + 1 + i) * d + n + 1 + i];
        if (!(tpp > 0)) return 1;
        for (size_t k = 0; k < n; k++)
            if (Hy[i * d + n + 1 + k] != 0 || (k != i && Hy[(n + 1 + i) * d + n + 1 + k] != 0)) return 1;
        S->t[i] = tpp;
    }
    double hl = 0.5 * lam, c = hl * hl, vg[3], eq[3];
    S->hl = hl;
    for (size_t i = 0; i < n; i++) {
        S->g[i] = g[i];
        S->g[n + i] = g[n + 1 + i];
        for (size_t k = 0; k < n; k++) {
            double v = Hy[i * d + k];
            S->V[i * n + k] = v;
            S->K[i + k * n] = (i == k ? 1.0 : 0.0) + c * (S->t[i] * v);
        }
    }
    if (lu_factor_m((int)n, S->K, S->piv, S->kinv) != DTH_OK) return 1;
    for (size_t i = 0; i < n; i++) {
        double a = 0;
        for (size_t k = 0; k < n; k++) a += S->V[i * n + k] * S->g[n + k];
        vg[i] = a;
        eq[i] = S->t[i] * (0.5 * hl * S->g[i] + hl * (0.5 * hl * a));
    }
    lu_solve_m((int)n, S->K, S->piv, S->kinv, eq);
    double sc = 0;
    for (size_t i = 0; i < n; i++) {
        double ve = 0;
        for (size_t k = 0; k < n; k++) ve += S->V[i * n + k] * eq[k];
        double ep = 0.5 * hl * vg[i] - hl * ve;
        S->y2[i] = -0.5 * S->g[n + i] + eq[i];
        S->y2[n + i] = 0.5 * S->g[i] + ep;
        sc -= S->g[i] * eq[i] + S->g[n + i] * ep;
    }
    S->sinv = 1 / sc;
    return isfinite(sc) && sc != 0 ? 0 : 1;
}

/* b = J^-1 b with the Schur complement's factors. */
AI void schur_solve_n(const dth_integrator *it, const size_t n, double *b)
{
    const dth__small_schur *S = &it->ss;
    double wq[3], wp[3], gw = 0;
    for (size_t i = 0; i < n; i++) wq[i] = b[i] + S->hl * (S->t[i] * b[n + i]);
    lu_solve_m((int)n, S->K, S->piv, S->kinv, wq);
    for (size_t i = 0; i < n; i++) {
        double vw = 0;
        for (size_t k = 0; k < n; k++) vw += S->V[i * n + k] * wq[k];
        wp[i] = b[n + i] - S->hl * vw;
        gw += S->g[i] * wq[i] + S->g[n + i] * wp[i];
    }
    double al = (b[2 * n] - gw) * S->sinv;
    for (size_t i = 0; i < n; i++) {
        b[i] = wq[i] - S->y2[i] * al;
        b[n + i] = wp[i] - S->y2[n + i] * al;
    }
    b[2 * n] = al;
}

/* nc > 0: the small path for an autonomous model with n = nc (written out, no library call) */
AI int eval_n(dth_integrator *it, const size_t nc, const double *x, double *F, int jac)
{
    int m = nc ? (int)(2 * nc + 1) : it->m;
    /* a chord step's compensated constraint (compensated_n) needs the midpoint's low part, and
     * evaluates the model at the coarsened midpoint y (coarse_n) */
    int fin = !jac && it->opt.finish;
    midpoint_n(it, nc, x, it->zb, fin ? it->zblo : NULL);
    /* the model's outputs are not swept for NaN/Inf here (the Hessian alone is (2n+1)^2): a
     * non-finite value shows in the correction, and step_judge finds out why */
    unsigned what = DTH_EVAL_H | DTH_EVAL_GRAD | (jac || (fin && it->rev) ? it->ls->hess : 0u);
    int at_y = fin && it->rev;
    if (at_y) coarse_n(it, nc, it->zb, it->ydel);
    int rc = it->meval(it->mself, at_y ? it->yc : it->zb, what, &it->Hphys, it->grad, it->hess);
    if (rc) {
        rc = rc > 0 ? DTH_EDOMAIN : DTH_EMODEL;
        seterr(it, "model evaluation failed at a trial midpoint (iteration %d): %s", it->nt.iter, dth_strerror(rc));
        return rc;
    }
    int schur = nc && jac && it->small_schur; /* try the Schur complement first: A is not assembled */
    assemble_n(it, nc, x, it->zb, it->Hphys, F, jac && it->ls->hess && !schur ? it->A : NULL);
    if (!jac) return it->opt.finish ? compensated_n(it, nc, x, F) : DTH_OK;
    if (schur) {
        it->ss.on = !schur_factor_n(it, nc, x[m - 1]);
        if (it->ss.on) return DTH_OK;
        assemble_n(it, nc, x, it->zb, it->Hphys, F, it->A); /* it does not apply here: LU */
    }
    rc = nc ? lu_factor_m((int)(2 * nc + 1), it->A, it->piv, NULL) : it->ls->factor(it, x[m - 1]);
    if (rc == DTH_ESINGULAR || rc == DTH_ELAPACK)
        seterr(it, "bordered Jacobian is singular at iteration %d (lambda = %.17g)", it->nt.iter, x[m - 1]);
    else if (rc)
        seterr(it, "model evaluation failed at a trial midpoint (iteration %d): %s", it->nt.iter, dth_strerror(rc));
    return rc;
}

static int step_eval(void *ctx, const double *x, double *F, int jac) { return eval_n(ctx, 0, x, F, jac); }

static int step_solve(void *ctx, double *b)
{
    dth_integrator *it = ctx;
    return it->ls->solve(it, b);
}

/* The relative correction of an autonomous step: the q block, the p block (never zero:
 * block_scales), lambda. NaN propagates. */
AI double correction_n(const dth_integrator *it, const size_t nc, const double *x, const double *dx)
{
    size_t n = nc ? nc : it->n;
    double cq = 0, cp = 0;
    for (size_t i = 0; i < n; i++) {
        double a = fabs(dx[i]), b = fabs(dx[n + i]);
        if (!(a <= cq)) cq = a;
        if (!(b <= cp)) cp = b;
    }
    double l = fabs(x[2 * n]), rq = cq * it->ibq, rp = cp * it->ibp, rl = fabs(dx[2 * n]) / (l > 0 ? l : 1e-300);
    double r = rq;
    if (!(rp <= r)) r = rp;
    if (!(rl <= r)) r = rl;
    return r;
}

/* What step_judge does beyond the rate: divergence (is it the model's domain?) and a stall. */
static int judge_slow(dth_integrator *it, int v, const double *x, const double *dx, const double *F,
                      dth__newton_track *tr, int *verdict)
{
    int m = it->m;
    const double *bs = it->bs;
    if (v == DTH__NT_DIVERGED || !isfinite(x[m - 1])) {
        /* a non-finite model output (not swept in step_eval) is the model's domain, not Newton's */
        int rc = dth_model_eval(it->model, it->zb, DTH_EVAL_H | DTH_EVAL_GRAD | it->ls->hess, &it->Hphys, it->grad,
                                it->hess);
        if (!rc && !it->ls->hess) rc = dth__model_hess_band(it->model, it->zb, it->work);
        if (rc) {
            seterr(it, "model evaluation failed at a trial midpoint (iteration %d): %s", tr->iter, dth_strerror(rc));
            return rc;
        }
        seterr(it, "Newton diverged at iteration %d", tr->iter);
        return DTH_ENOCONV;
    }
    /* The correction stopped decreasing: accept only if the energy residual is at
     * round-off and the state residual at round-off or below what the noise of lambda
     * itself causes (lambda is fixed by a second-order effect, so its correction can
     * stall well above eps: paper, Lemma g_taylor; a residual d - (lambda/2) u then
     * carries (dlambda/2) u). */
    double fs = 0, ds = 0, rl = fabs(dx[m - 1]) / fabs(x[m - 1]);
    for (int a = 0; a < m - 1; a++) {
        int j = it->act[a];
        fs = fmax(fs, fabs(F[a]) / bs[block_of(it, j)]);
        ds = fmax(ds, fabs(x[a]) / bs[block_of(it, j)]);
    }
    double hs = h_scale(it, it->zb, it->Hphys);
    if (!isfinite(fs)) fs = INFINITY;
    if (fs <= 1e3 * DBL_EPSILON + 2 * fmin(rl, 1e-6) * ds && fabs(F[m - 1]) <= 1e3 * DBL_EPSILON * hs) {
        *verdict = DTH__NT_DONE;
        return DTH_OK;
    }
    if (tr->iter >= 8) {
        seterr(it, "Newton stalled at relative correction %.3g (residual %.3g)", tr->r, fabs(F[m - 1]));
        return DTH_ENOCONV;
    }
    *verdict = DTH__NT_MORE;
    return DTH_OK;
}

AI int judge_n(dth_integrator *it, const size_t nc, const double *x, const double *dx, const double *F,
               dth__newton_track *tr, int *verdict)
{
    int m = nc ? (int)(2 * nc + 1) : it->m;
    double r = 0;
    if (nc || it->auton) {
        r = correction_n(it, nc, x, dx);
    } else {
        for (int a = 0; a < m; a++) {
            double sc = a == m - 1 ? fabs(x[a]) : it->bs[block_of(it, it->act[a])];
            double ra = fabs(dx[a]) / (sc > 0 ? sc : 1e-300);
            if (!(ra <= r)) r = ra; /* NaN propagates */
        }
    }
    tr->r = r;
    int v = dth__newton_rate_inl(r, tr->r_prev, tr->iter, 4 * DBL_EPSILON);
    if (v == DTH__NT_DIVERGED || v == DTH__NT_STALLED || !isfinite(x[m - 1])) {
        int rc = judge_slow(it, v, x, dx, F, tr, &v);
        if (rc) return rc;
    }
    /* converged: a compensated step still finishes with its chord step (compensated_n) */
    *verdict = v == DTH__NT_DONE && it->opt.finish ? DTH__NT_CHORD : v;
    return DTH_OK;
}

static int step_judge(void *ctx, const double *x, const double *dx, const double *F, dth__newton_track *tr, int *verdict)
{
    return judge_n(ctx, 0, x, dx, F, tr, verdict);
}

/*
 * One more compensated chord step where the last one moved the midpoint out of the coarse cell its
 * evaluation point y stood for (coarse_n: a root is consistent, the reverse step finding the same
 * one, only once the last evaluation's y is the converged midpoint's); where the root is not yet
 * resolved to 2^-100 (the chord steps converge at the rate of the factors' distance to the root,
 * about the last Newton correction, or of the solve's own round-off); or where the last one moved
 * lambda so far (a stalled Newton at tiny steps) that the chord's own second-order error
 * dlambda^2 / lambda is above eps lambda. Where the root sits at a cell boundary, so that each
 * cell's gradient puts it in the other (the gradients' roundings differ), the chords alternate
 * between two cells: y is then pinned to the componentwise lower of the two, which the reverse
 * step picks as well. At most 6 chord steps.
 */
static int step_again(void *ctx, const double *x, const double *dx, int chords)
{
    dth_integrator *it = ctx;
    if (!it->opt.finish || chords >= (it->rev ? 6 : 3)) return 0;
    double dl = dx[it->m - 1], l = x[it->m - 1];
    if (dl * dl > DBL_EPSILON * (l * l)) return 1; /* (dl / l)^2 > eps */
    if (!it->rev) return 0;
    double e = 0, rate = fmax(it->nt.r, 1e-12);
    for (int a = 0; a < it->m; a++)
        if (x[a] != 0) e = fmax(e, fabs(dx[a] / x[a]));
    int more = rate * e > 0x1p-100;
    if (it->ypinned) return more;
    double *zb = it->u, *lo = it->znewlo; /* scratch (N each) until the next evaluation / the commit */
    midpoint_n(it, 0, x, zb, lo);
    int moved = 0, back = chords >= 2;
    coarsen_y(it->n, zb, lo);
    for (size_t j = 0; j < it->d; j++) {
        moved |= lo[j] != it->yc[j];
        back &= lo[j] == it->yprev[j];
        zb[j] = lo[j];
    }
    if (!moved) return more;
    if (back) { /* alternating: pin */
        for (size_t j = 0; j < it->d; j++) it->yc[j] = fmin(it->yc[j], zb[j]);
        it->ypinned = 1;
        return 1;
    }
    memcpy(it->yprev, it->yc, it->d * sizeof *it->yc);
    return 1;
}

static const dth__newton_ops step_ops = {step_eval, step_solve, step_judge};

/* The small path's instances for n = 1, 2, 3 (m = 3, 5, 7). */
#define SMALL_OPS(N)                                                                                            \
    AI int eval_##N(void *c, const double *x, double *F, int jac) { return eval_n(c, N, x, F, jac); }             \
    AI int solve_##N(void *c, double *b)                                                                          \
    {                                                                                                             \
        dth_integrator *it = c;                                                                                   \
        if (it->ss.on) schur_solve_n(it, N, b); /* set only where it->small_schur */                              \
        else lu_solve_m(2 * N + 1, it->A, it->piv, NULL, b);                                                      \
        return DTH_OK;                                                                                            \
    }                                                                                                             \
    AI int judge_##N(void *c, const double *x, const double *dx, const double *F, dth__newton_track *tr, int *v)     \
    {                                                                                                             \
        return judge_n(c, N, x, dx, F, tr, v);                                                                    \
    }                                                                                                             \
    static const dth__newton_ops small_ops_##N = {eval_##N, solve_##N, judge_##N};
SMALL_OPS(1)
SMALL_OPS(2)
SMALL_OPS(3)

/*
 * Newton on the step from the seed (lam0, d0); nc > 0: the small path, whose driver (newton.h) and
 * callbacks are inlined. After it: the accepted midpoint in it->zb, its direct energy residual, and
 * its low part for the commit.
 */
AI int newton_n(dth_integrator *it, const size_t nc, const dth__newton_ops *ops, double lam0, const double *d0,
                int max_iter, dth__solution *sol)
{
    size_t n = nc ? nc : it->n, N = 2 * n + 2;
    int m = nc ? (int)(2 * nc + 1) : it->m;
    double *x = it->x, *zb = it->zb;
    unknowns_n(it, nc, d0, lam0);
    sol->iters = 0;
    sol->residual = NAN;
    midpoint_n(it, nc, x, zb, NULL);
    block_scales_n(it, nc, zb, it->bs);
    int rc = dth__newton_iterate(ops, step_again, it, m, max_iter, x, it->rev ? it->xlo : NULL, it->F, it->dx, &it->nt);
    sol->iters = it->nt.iter;
    if (rc == DTH_ENOCONV && it->nt.verdict == DTH__NT_MAXITER)
        seterr(it, "Newton did not converge in %d iterations (last correction %.3g)", it->nt.iter, it->nt.r);
    if (rc) return rc;
    midpoint_n(it, nc, x, zb, it->opt.finish ? it->zblo : NULL);
    rc = it->meval(it->mself, zb, DTH_EVAL_H, &it->Hphys, NULL, NULL);
    if (!rc && !isfinite(it->Hphys)) rc = 1;
    if (rc) {
        rc = rc > 0 ? DTH_EDOMAIN : DTH_EMODEL;
        seterr(it, "model evaluation failed at the converged midpoint: %s", dth_strerror(rc));
        return rc;
    }
    sol->residual = fabs(zb[N - 1] + it->Hphys);
    sol->lambda = x[m - 1];
    return DTH_OK;
}

/* newton_n for the path at hand, at most max_iter iterations */
static int newton(dth_integrator *it, double lam0, const double *d0, int max_iter, dth__solution *sol)
{
    switch (it->nsmall) {
    case 1: return newton_n(it, 1, &small_ops_1, lam0, d0, max_iter, sol);
    case 2: return newton_n(it, 2, &small_ops_2, lam0, d0, max_iter, sol);
    case 3: return newton_n(it, 3, &small_ops_3, lam0, d0, max_iter, sol);
    default: return newton_n(it, 0, &step_ops, lam0, d0, max_iter, sol);
    }
}

int dth__newton(dth_integrator *it, double lam0, const double *d0, dth__solution *sol)
{
    return newton(it, lam0, d0, it->opt.max_iter, sol);
}

/* Commit the solution in it->x / it->zb: new vertex z + 2 d in double-double. */
AI int commit_n(dth_integrator *it, const size_t nc, double lam)
{
    size_t n = nc ? nc : it->n, N = 2 * n + 2;
    int m = nc ? (int)(2 * nc + 1) : it->m;
    /* new vertex into scratch first (znew: the full offset d, then z + 2 d): a finite midpoint can
     * still give an overflowing vertex, and then the state stays untouched */
    double *zn = it->znew, *zl = it->znewlo, *dl = zl; /* dl: the offset's low part (read before zl[j] is written) */
    if (nc || it->auton) {
        /* autonomous: t advances by lambda/2, wp stays */
        for (size_t i = 0; i < n; i++) {
            zn[i] = it->x[i];
            zn[n + 1 + i] = it->x[n + i];
        }
        zn[n] = 0.5 * lam;
        zn[N - 1] = 0;
        if (it->rev) {
            for (size_t i = 0; i < n; i++) {
                dl[i] = it->xlo[i];
                dl[n + 1 + i] = it->xlo[n + i];
            }
            dl[n] = 0.5 * it->xlo[m - 1];
            dl[N - 1] = 0;
        }
    } else {
        for (int a = 0; a < m - 1; a++) zn[it->act[a]] = it->x[a];
        if (it->rev)
            for (int a = 0; a < m - 1; a++) dl[it->act[a]] = it->xlo[a];
    }
    double *d = it->dnew; /* scratch: becomes the newest history slot */
    int finite = 1;
    for (size_t j = 0; j < N; j++) {
        d[j] = zn[j];
        if (it->rev) { /* z + zlo + 2 (d + dlo) in double-double */
            double e, sj = two_sum(it->st.z[j], 2 * d[j], &e);
            zn[j] = two_sum(sj, (it->st.zlo[j] + 2 * dl[j]) + e, &zl[j]);
        } else { /* to the rounding of 2 d + zlo */
            zn[j] = two_sum(it->st.z[j], 2 * d[j] + it->st.zlo[j], &zl[j]);
        }
        finite &= isfinite(zn[j]) != 0;
    }
    if (!finite) {
        size_t j = 0;
        while (isfinite(zn[j])) j++;
        seterr(it, "the new vertex overflows (component %zu)", j);
        return DTH_EDOMAIN;
    }
    if (nc || it->auton) { /* wp carried bit for bit */
        zn[N - 1] = it->st.z[N - 1];
        zl[N - 1] = it->st.zlo[N - 1];
    }
    double rho = it->st.rho, rholo = it->st.rholo;
    if (it->opt.finish) {
        /* the new vertex's offset measured from this step's midpoint (it->grad is there) */
        /* the exact first step of a midpoint start has its midpoint exact in double */
        int rc;
        if (!it->rev) {
            rc = rho_from_mid_n(it, nc, it->zb, NULL, it->st.pending_exact ? NULL : it->zblo, it->grad, NULL, zn, zl, &rho,
                                &rholo);
        } else {
            /* from the last chord step's point y, with its gradient and Hessian (coarse_n) */
            size_t nd = N - 1;
            double *dy = it->ydel, *gl = it->ygl;
            for (size_t j = 0; j < nd; j++) dy[j] = it->zb[j] - it->yc[j];
            dy[nd] = 0;
            taylor_grad(it, nd, dy, it->zblo, gl, it->ybar);
            rc = rho_from_mid_n(it, nc, it->yc, dy, it->zblo, it->grad, gl, zn, zl, &rho, &rholo);
        }
        if (rc) {
            seterr(it, "model evaluation failed at the new vertex: %s", dth_strerror(rc));
            return rc;
        }
    }
    it->st.rho = rho;
    it->st.rholo = rholo;
    for (size_t j = 0; j < N; j++) {
        it->st.z[j] = zn[j];
        it->st.zlo[j] = zl[j];
        it->st.zbar[j] = it->zb[j];
    }
    /* the predictor's history: the last three offsets and steps (the oldest slot is the next scratch) */
    it->dnew = it->st.dprev3;
    it->st.dprev3 = it->st.dprev2;
    it->st.dprev2 = it->st.dprev;
    it->st.dprev = d;
    it->st.lam3 = it->st.lam2;
    it->st.lam2 = it->st.lam;
    it->st.nhist = it->st.nhist < 3 ? it->st.nhist + 1 : 3;
    it->st.fact_valid = 1; /* an ordinary step: a tangent map exists (a regularizer's step clears it) */
    it->st.lam = lam;
    it->st.have_prev = 1;
    it->st.have_mid = 1;
    it->st.steps++;
    return DTH_OK;
}

static int commit(dth_integrator *it, double lam)
{
    switch (it->nsmall) {
    case 1: return commit_n(it, 1, lam);
    case 2: return commit_n(it, 2, lam);
    case 3: return commit_n(it, 3, lam);
    default: return commit_n(it, 0, lam);
    }
}

int dth__integrator_commit(dth_integrator *it, double lam) { return commit(it, lam); }

/* The predictor of the next step: quadratic extrapolation of (d, lambda) over the last three
 * ordinary steps, else the reflection of the last offset (the next midpoint offset mirrors it). */
static const double *predict(dth_integrator *it, double *lam0)
{
    size_t N = it->N;
    *lam0 = it->st.lam;
    if (it->st.nhist < 3) return it->st.dprev;
    double l = 3 * (it->st.lam - it->st.lam2) + it->st.lam3;
    if (!(l * it->st.dir > 0) || !(fabs(l) <= 2 * fabs(it->st.lam)) || !(2 * fabs(l) >= fabs(it->st.lam))) return it->st.dprev;
    double *d = it->znewlo;
    for (size_t j = 0; j < N; j++) d[j] = 3 * (it->st.dprev[j] - it->st.dprev2[j]) + it->st.dprev3[j];
    *lam0 = l;
    return d;
}

/* One step; on failure the caller (dth_integrator_step) puts the state back. */
static int step(dth_integrator *it, dth_step_info *info)
{
    size_t N = it->N;
    if (it->st.pending_exact) {
        /* Midpoint start: zbar_0 and lambda = h solve the step equations exactly. */
        double lam = it->st.lam_hint;
        unknowns_n(it, 0, it->st.dprev, lam);
        int rc;
        if (it->rev) {
            /* the start's offset again (exact_offset_rev is deterministic: dhi is dprev), with its low
             * part for the commit; the model left at the coarse point for the new offset */
            double *dhi = it->dnew, *dlo = it->yprev; /* scratch until the commit */
            rc = exact_offset_rev(it, it->st.zbar, lam, dhi, dlo);
            if (!rc) rc = dth_model_eval(it->model, it->st.zbar, DTH_EVAL_H, &it->Hphys, NULL, NULL);
            for (int a = 0; a < it->m - 1; a++) it->xlo[a] = dlo[it->act[a]];
        } else {
            memcpy(it->zb, it->st.zbar, N * sizeof *it->zb);
            rc = dth_model_eval(it->model, it->zb, DTH_EVAL_H | DTH_EVAL_GRAD, &it->Hphys, it->grad, NULL);
        }
        if (rc) {
            seterr(it, "model evaluation failed at the first (exact) midpoint");
            return rc;
        }
        rc = commit(it, lam);
        if (rc) return rc;
        it->st.nhist = 1;
        it->st.pending_exact = 0;
        info->lambda = lam;
        info->iters = 0;
        info->residual = fabs(it->st.zbar[N - 1] + it->Hphys);
        info->branch = DTH_BRANCH_EXACT;
        return DTH_OK;
    }
    int pre = 0;
    if (it->reg && dth__reg_replaces_all(it)) {
        /* a regularizer that replaces every step: no ordinary step unless it keeps one */
        int rc = dth__reg_pre(it, info);
        if (rc != DTH__REG_PLAIN) return rc;
        pre = 1;
    }
    int pre_iters = info->iters;
    double lam0;
    const double *d0;
    if (it->st.have_prev) {
        d0 = predict(it, &lam0);
    } else {
        double Hphys, psi, dpsi;
        int rc = dth_model_eval(it->model, it->st.z, DTH_EVAL_H | DTH_EVAL_GRAD, &Hphys, it->grad, NULL);
        if (!rc) rc = dth_model_psi(it->model, it->st.z, &psi, &dpsi, it->work);
        if (rc) {
            seterr(it, "model evaluation failed at the vertex");
            return rc;
        }
        lam0 = cubic_predict(it->st.z[N - 1] + Hphys, psi, dpsi, it->st.lam_hint);
        dth__flow_z(it->n, it->grad, it->u);
        for (size_t j = 0; j < N; j++) it->znewlo[j] = 0.5 * lam0 * it->u[j];
        d0 = it->znewlo;
    }
    dth__solution sol = {NAN, NAN, 0};
    int rc = dth__newton(it, lam0, d0, &sol);
    info->iters = pre_iters + sol.iters;
    info->residual = sol.residual;
    /* which root (branch.c): Newton's if physical, else the physical root ahead, else a status */
    dth_branch br;
    rc = dth__branch_select(it, rc, &sol, &br);
    if (it->reg) {
        /* psi = 0 crossings (regularize.c) */
        sol.iters += pre_iters;
        return dth__reg_step(it, rc, &sol, br, info, pre);
    }
    if (rc) {
        if (rc == DTH_ENOROOT && isfinite(sol.lambda)) info->lambda = sol.lambda;
        return rc;
    }
    info->iters = sol.iters;
    info->residual = sol.residual;
    rc = commit(it, sol.lambda);
    if (rc) return rc;
    info->lambda = sol.lambda;
    info->branch = br;
    return DTH_OK;
}

/* The vectors of the step state, by name (the pointers rotate in commit): their slots in v. */
#define VEC_SLOT(name, kind, check, doc) VEC_SLOT_##kind(name)
#define VEC_SLOT_VEC(name) &it->st.name,
#define VEC_SLOT_F64(name)
#define VEC_SLOT_INT(name)
#define VEC_SLOT_LONG(name)
static void state_vectors(dth_integrator *it, double **v[DTH__STATE_NVEC])
{
    double **list[DTH__STATE_NVEC] = {DTH__STATE_FIELDS(VEC_SLOT)};
    memcpy(v, list, sizeof list);
}
#undef VEC_SLOT
#undef VEC_SLOT_VEC
#undef VEC_SLOT_F64
#undef VEC_SLOT_INT
#undef VEC_SLOT_LONG

void dth__state_snapshot(dth_integrator *it)
{
    it->snapped = 1;
    double **v[DTH__STATE_NVEC];
    state_vectors(it, v);
    for (size_t k = 0; k < DTH__STATE_NVEC; k++) memcpy(it->snap + k * it->N, *v[k], it->N * sizeof(double));
}

static void state_rollback(dth_integrator *it)
{
    double **v[DTH__STATE_NVEC];
    state_vectors(it, v);
    for (size_t k = 0; k < DTH__STATE_NVEC; k++) memcpy(*v[k], it->snap + k * it->N, it->N * sizeof(double));
}

int dth_integrator_step(dth_integrator *it, dth_step_info *info)
{
    dth_step_info tmp;
    if (!info) info = &tmp;
    memset(info, 0, sizeof *info);
    if (!it) return DTH_EINVAL;
    /* A failed step leaves the state as it was: the scalars and the vector pointers are kept
     * here, the regularizer's own state too (its hook may change it before the step fails); the
     * vectors change only in commits, an ordinary step's is atomic and a regularizer's multi-part
     * commit keeps a copy of them (it->snap, reg_finish). */
    dth__state saved = it->st;
    double *dnew = it->dnew;
    if (it->regsnap_len) dth__reg_save_state(it->reg, it->regsnap);
    it->snapped = 0;
    it->errmsg[0] = '\0'; /* the message describes this step */
    int rc = step(it, info);
    if (!rc) memcpy(it->errmsg, "no error", sizeof "no error");
    else if (!it->errmsg[0]) snprintf(it->errmsg, sizeof it->errmsg, "%s", dth_strerror(rc));
    if (rc) {
        it->st = saved;
        it->dnew = dnew;
        if (it->snapped) state_rollback(it); /* into the buffers the names had */
        if (it->regsnap_len) dth__reg_load_state(it->reg, it->regsnap, it->regsnap_len);
    }
    return rc;
}

int dth_integrator_tangent(dth_integrator *it, double *M)
{
    if (!it || !M) return DTH_EINVAL;
    if (!it->st.fact_valid) return DTH_EINVAL; /* no step yet, or a regularizer's step */
    return it->ls->tangent(it, M);
}

/* The dense paths' tangent map: the bordered Jacobian at the converged midpoint, refactored. */
static int dense_tangent(dth_integrator *it, double *M)
{
    size_t n = it->n, N = it->N;
    int m = it->m;
    double lam = it->st.lam;
    /* the Jacobian at the converged midpoint (not at Newton's last iterate), factored afresh */
    int rc = dth_model_eval(it->model, it->st.zbar, DTH_EVAL_H | DTH_EVAL_GRAD | DTH_EVAL_HESS, &it->Hphys, it->grad,
                            it->hess);
    if (rc) return rc;
    unknowns_n(it, 0, it->st.dprev, lam);
    assemble(it, it->x, it->st.zbar, it->Hphys, it->F, it->A);
    rc = dth__lu_factor(it->kind, m, it->A, it->piv);
    if (rc) return rc;
    /* B = dF/dz_k (m x N, column-major): rows of -(lambda/2) J H_zz, last row grad H. */
    double *B = it->B;
    for (size_t l = 0; l < N; l++) {
        for (int a = 0; a < m - 1; a++) B[(size_t)a + l * (size_t)m] = 0.5 * lam * dth__dudz(n, it->hess, (size_t)it->act[a], l);
        B[(size_t)(m - 1) + l * (size_t)m] = l == N - 1 ? -1.0 : -it->grad[l];
    }
    /* X = -A^{-1} B: derivatives of the unknowns (d, lambda) with respect to z_k (B holds -B). */
    rc = dth__lu_solve(it->kind, m, it->A, it->piv, (int)N, B);
    if (rc) return rc;
    /* M = I + 2 dd/dz_k; autonomous: d_t = lambda/2, d_wp = 0. */
    memset(M, 0, N * N * sizeof *M);
    for (size_t i = 0; i < N; i++) M[i * N + i] = 1.0;
    for (int a = 0; a < m - 1; a++) {
        size_t j = (size_t)it->act[a];
        for (size_t l = 0; l < N; l++) M[j * N + l] += 2 * B[(size_t)a + l * (size_t)m];
    }
    if (it->auton)
        for (size_t l = 0; l < N; l++) M[n * N + l] += B[(size_t)(m - 1) + l * (size_t)m];
    return DTH_OK;
}

int dth_diagnose(const dth_model *model, const double *z, double lambda_root, double K,
                 dth_diag *dg, double *work)
{
    if (!model || !z || !dg || !work) return DTH_EINVAL;
    size_t n = dth_model_dof(model), N = 2 * n + 2;
    double Hphys;
    int rc = dth_model_eval(model, z, DTH_EVAL_H, &Hphys, NULL, NULL);
    if (!rc) rc = dth_model_psi(model, z, &dg->psi, &dg->dpsi, work);
    if (rc) return rc;
    dg->H = z[N - 1] + Hphys;
    if (!(K > 0)) K = dth_model_get_info(model)->K;
    if (!(K > 0) && lambda_root != 0 && isfinite(lambda_root)) {
        double l = lambda_root, l2 = l * l;
        K = fabs(dg->H - dg->psi * l2 / 8 - dg->dpsi * l2 * l / 24) / (l2 * l2);
    }
    dg->K = K > 0 ? K : 0;
    dg->region = dth_region_of(dg->psi, dg->dpsi, dg->K);
    return DTH_OK;
}

void dth_interpolate(size_t n, const double *za, const double *zb, double t, double *z)
{
    size_t N = 2 * n + 2;
    double ta = za[n], tb = zb[n];
    double s = tb != ta ? (t - ta) / (tb - ta) : 0.0;
    for (size_t j = 0; j < N; j++) z[j] = za[j] + s * (zb[j] - za[j]);
    z[n] = t;
}
