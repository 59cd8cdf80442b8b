/* SPDX-License-Identifier: MIT */
/*
 * Regularizer "smooth", the default: the regularization across psi = 0 that DTH dynamics needs
 * (paper, section 7; the changeover's distance is Theorem EU_2's s = -(psi'/psi) lambda). Ordinary
 * DTH steps wherever the step is healthy, and around each psi = 0 crossing or fold a C-infinity
 * changeover to kicked segments of a step law (docs/regularization.md, "smooth"). A step from the
 * vertex z_a solves, at its own midpoint zbar,
 *     zbar = z_a + (lambda J grad H(zbar) + mu n(zbar)) / 2,   H(zbar) = 0,
 *     (1 - w) mu = w sigma s (lambda - L),
 * where, with psi and psi' at zbar,
 *   L = dir l, l the positive root of l^6 psi_e^2 = K, psi_e^4 = psi^4 + (psi' l)^4: DTH's own step
 *     scaling (lambda^6 psi^2 is the ordinary step's adiabatic invariant, see law()), finite at
 *     psi = 0. K is fixed once, from the first step offered, or set by the parameter `invariant`;
 *   w = bump(x), x = |psi / psi'| / l, the distance to the crossing in law steps (1/x is EU_2's s):
 *     w = 1 for x <= inner (lambda = L, a law step), w = 0 for x >= outer (mu = 0, the ordinary DTH
 *     step), and a plateau w = 1/2 on the middle 60 % of [inner, outer] between two C-infinity half
 *     steps; the weight at z_a is a floor, w = max(w(zbar), w(z_a));
 *   sigma = -sign(psi) dir, and s = l psi_e / (2 c), c = |grad_(q,p) H|^2 ~ grad H . n > 0. With
 *     this sign and scale one step multiplies the excess of the vertex offset over the law's
 *     (psi L^2/8) by 1 - 2 w (0 on the plateau): it contracts, and the lambda-derivative of the
 *     changeover equation never vanishes. The other sign amplifies the excess and has a fold
 *     (docs/regularization.md also shows why no smooth changeover is exactly reversible).
 * Every ordinary stretch therefore leaves a band with its vertex offset pinned to the law's, so the
 * step does not drift from crossing to crossing. Ordinary steps are taken only where w = 0 at both
 * vertices and lambda is within a factor 2 of the law's step there (conditions on the unordered
 * pair): they are exactly DTH steps (symplectic, their own reverse). Law steps (w = 1 at both
 * vertices) are their own reverse too; the changeover steps (0 < w < 1) are neither symplectic nor
 * reversible (sigma reads dir). Where no changeover segment exists a law step is taken; where none
 * exists either (an unresolved passage), the step is refused.
 */
#include <float.h>
#include <stddef.h>
#include <math.h>
#include <string.h>
#include "dth/regularize.h"
#include "reg_common.h"

typedef struct smooth {
    const dth_model *model;
    size_t n;
    double K;          /* the law's constant in l^6 psi_e^2 = K (> 0 once fixed) */
    int K_fixed;       /* K set (parameter `invariant`, or from the first step): a constant after that */
    double inner, outer;
    const dth_allocator *alloc;
    size_t nks;        /* doubles of the kicked segment's dense Newton workspace, 2 (2n + 1)^2 */
    double *ks;        /* that workspace, allocated at the first changeover step: ordinary steps need
                        * only O(n), so a large banded model runs until it first needs a changeover */
    double *work, *d, *y, *g, *zb, *zc;
    double wc, lc;     /* the weight and the law's step at the vertex zc, cached (the next step starts there) */
    int cache_ok;
} smooth;

static const dth_param_spec params[] = {
    {"invariant", "", "the step law's constant K in l^6 (psi^4 + (psi' l)^4)^(1/2) = K (> 0); default: from the first step offered (the second of a midpoint start), so the law continues the ordinary steps"},
    {"inner", "1", "law steps where |psi/psi'| <= inner law steps from the crossing, at the midpoint (> 0)"},
    {"outer", "3.2", "ordinary DTH steps where |psi/psi'| >= outer law steps from the crossing, at both vertices, and lambda is within a factor 2 of the law's step (> inner)"},
};

static int create(const dth_reg_args *a, void **self)
{
    size_t n = dth_model_dof(a->model), N = 2 * n + 2;
    size_t nks = dth_kicked_segment_work_size(a->model), nw = dth_model_work_size(a->model);
    smooth *r = dth_calloc(a->alloc, 1, sizeof *r);
    if (!r) return DTH_ENOMEM;
    *self = r;
    r->inner = 1.0;
    r->outer = 3.2;
    for (size_t i = 0; i < a->nkv; i++) {
        const char *k = a->kv[i].key, *v = a->kv[i].value;
        if (!strcmp(k, "invariant")) {
            if (dth_parse_double(v, &r->K) || !(r->K > 0) || !isfinite(r->K))
                return dth__reg_param_err(a, k, "a number > 0");
            r->K_fixed = 1;
        }
        if (!strcmp(k, "inner") && (dth_parse_double(v, &r->inner) || !(r->inner > 0) || !isfinite(r->inner)))
            return dth__reg_param_err(a, k, "a number > 0");
        if (!strcmp(k, "outer") && (dth_parse_double(v, &r->outer) || !isfinite(r->outer)))
            return dth__reg_param_err(a, k, "a number");
    }
    if (!(r->outer > r->inner)) return dth__reg_param_err(a, "outer", "larger than inner");
    r->work = dth_calloc(a->alloc, nw + 5 * N, sizeof(double));
    if (!r->work) return DTH_ENOMEM;
    r->alloc = a->alloc;
    r->nks = nks;
    r->model = a->model;
    r->n = n;
    r->d = r->work + nw;
    r->y = r->d + N;
    r->g = r->y + N;
    r->zb = r->g + N;
    r->zc = r->zb + N;
    return DTH_OK;
}

static void destroy(void *self, const dth_allocator *alloc)
{
    smooth *r = self;
    if (!r) return;
    dth_free(alloc, r->ks);
    dth_free(alloc, r->work);
    dth_free(alloc, r);
}

/* C-infinity step: 0 for t <= 0, 1 for t >= 1. */
static double smoothstep(double t)
{
    if (t <= 0) return 0;
    if (t >= 1) return 1;
    double a = exp(-1 / t), b = exp(-1 / (1 - t));
    return a / (a + b);
}

/*
 * The law's step: the positive root l of  l^6 psi_e^2 = K  with  psi_e^4 = psi^4 + (psi' l)^4
 * (INFINITY if none). Ordinary DTH keeps l^6 psi^2 nearly constant: its vertex offset
 * rho = psi lambda^2/8 changes by lambda^3 psi'/24 per step (psi' = D^3 H[u, u, u]), so rho^3/psi,
 * i.e. lambda^6 psi^2, is its adiabatic invariant (lambda ~ psi^(-1/3); measured on the rotating
 * pendulum: 0.0404 against 0.0403 predicted between psi = 4.84 and 1.15). The psi' term keeps l
 * finite at psi = 0, l = (K / psi'^2)^(1/8), and changes l by under 0.2 % where
 * |psi / psi'| >= 2 l (a 4-norm, so that the law is ordinary DTH's step already near the band).
 */
static double law(double K, double psi, double dpsi)
{
    double a = psi * psi, b = dpsi * dpsi;
    double l = a > 0 ? pow(K / a, 1.0 / 6) : INFINITY;
    if (b > 0) l = fmin(l, pow(K / b, 1.0 / 8));
    if (!isfinite(l) || !(l > 0)) return INFINITY;
    /* Newton on s = log l: phi(s) = 6 s + log(a^2 + b^2 l^4)/2 - log K, phi' in [6, 8] */
    double lk = log(K), a2 = a * a, b2 = b * b;
    for (int k = 0; k < 60; k++) {
        double l4 = l * l * l * l, q = a2 + b2 * l4;
        double phi = 6 * log(l) + 0.5 * log(q) - lk, dphi = 6 + 2 * b2 * l4 / q;
        double ds = phi / dphi;
        l *= exp(-ds);
        if (fabs(ds) <= 2 * DBL_EPSILON) break;
    }
    return l;
}

/* psi_e = (psi^4 + (psi' l)^4)^(1/4), the law's regularized psi. */
static double psi_e(double psi, double dpsi, double l)
{
    double a = psi * psi, b = dpsi * dpsi * l * l;
    return sqrt(sqrt(a * a + b * b));
}

/* The changeover weight at a point y (length 2n+2; psi does not read wp), the sign of psi there,
 * the law's step l(y) and the scale s(y) of the law's term (below). A function of the point only. */
static int weight(smooth *r, const double *y, double *w, int *psi_sign, double *lstep, double *scale)
{
    double psi, dpsi;
    int rc = dth_model_psi(r->model, y, &psi, &dpsi, r->work);
    if (rc) return rc;
    double l = law(r->K, psi, dpsi);
    if (!isfinite(l)) return DTH_EDOMAIN; /* psi = psi' = 0: an equilibrium */
    *lstep = l;
    *psi_sign = psi > 0 ? 1 : (psi < 0 ? -1 : 0);
    double x = psi == 0 ? 0 : (dpsi != 0 ? fabs(psi) / (fabs(dpsi) * l) : INFINITY);
    /* two C-infinity half steps, 1 -> 1/2 and 1/2 -> 0, around a plateau w = 1/2 on the middle
     * 60 % of [inner, outer], where the changeover sets the vertex offset to the law's outright
     * (contraction factor 1 - 2 w = 0) */
    double wd = 0.2 * (r->outer - r->inner);
    *w = 0.5 * (1 - smoothstep((x - r->inner) / wd)) + 0.5 * (1 - smoothstep((x - (r->outer - wd)) / wd));
    if (scale) {
        /* s = l psi_e / (2 c), c = |grad_(q,p) H|^2 ~ grad H . n: the changeover's contraction
         * factor of the offset excess is then 1 - 2 w (docs/regularization.md) */
        double H;
        rc = dth_model_eval(r->model, y, DTH_EVAL_H | DTH_EVAL_GRAD, &H, r->g, NULL);
        if (rc) return rc;
        double c = dth__reg_grad_qp2(r->g, r->n);
        if (!(c > 0)) return DTH_EDOMAIN;
        *scale = l * psi_e(psi, dpsi, l) / (2 * c);
    }
    return DTH_OK;
}

/* Fix the law's constant K once, from a step lam whose midpoint is y: the law then gives that step. */
static int fix_law_constant(smooth *r, const double *y, double lam)
{
    double psi, dpsi, l = fabs(lam);
    int rc = dth_model_psi(r->model, y, &psi, &dpsi, r->work);
    if (rc) return rc;
    double l2 = l * l, pe = psi_e(psi, dpsi, l);
    r->K = l2 * l2 * l2 * pe * pe;
    if (!(r->K > 0) || !isfinite(r->K)) return DTH_EREFUSED;
    r->K_fixed = 1;
    return DTH_OK;
}

/* The changeover weight at the step's start vertex: a floor for the weight at the midpoint. */
typedef struct blend {
    double wa, la; /* the weight and the law's step at the start vertex */
} blend;

/*
 * The changeover residual of the kicked segment (r->d, mu) of step lam from z + zlo, as
 *     R = sign(psi) dir (1 - w) mu + w s (lambda - L)
 * (the changeover equation times -sigma, the law's term scaled by s = l psi_e / (2 c) so that the
 * offset excess contracts by 1 - 2 w per step), with w = max(w(zbar), w(z_a)), sign(psi), s and L
 * at the segment's own midpoint. The floor w(z_a) keeps a step that starts in the band from
 * landing on an ordinary root (w(zbar) = 0) far beyond it; ordinary steps (w = 0 at both vertices)
 * and law steps (w = 1 at both) stay their own reverse. R is increasing in lambda and continuous
 * where psi(zbar) changes sign (w = 1 there).
 */
static int residual(smooth *r, const dth_reg_event *ev, const blend *b, double lam, double mu, double *R)
{
    size_t N = ev->N;
    for (size_t j = 0; j < N; j++) r->zb[j] = ev->z[j] + (ev->zlo[j] + r->d[j]);
    double w, l, sc;
    int sg;
    int rc = weight(r, r->zb, &w, &sg, &l, &sc);
    if (rc) return rc;
    w = fmax(w, b->wa);
    *R = (sg ? sg : 1) * ev->dir * (1 - w) * mu + w * sc * (lam - ev->dir * l);
    return DTH_OK;
}

/* One evaluation: the kicked segment of step lam (its seed r->d, mu rescaled from step `from`),
 * then its changeover residual. */
static int eval_at(smooth *r, const dth_reg_event *ev, const blend *b, double from, double lam, double *mu,
                   double *res, int *total, double *R)
{
    size_t N = ev->N;
    if (from != 0 && from != lam) {
        double s = lam / from;
        for (size_t j = 0; j < N; j++) r->d[j] *= s;
        *mu *= s;
    }
    int ki = 0;
    int rc = dth_kicked_segment(r->model, ev->z, ev->zlo, lam, r->d, mu, res, &ki, r->ks);
    *total += ki;
    if (rc) return rc;
    return residual(r, ev, b, lam, *mu, R);
}

/*
 * Solve the changeover segment from the step lam0 (offset d0, or an Euler half step): bracket the
 * root of R (increasing in lambda) between lam0 / 1024 and 8 max(lam0, the law's step at the start
 * vertex), then the Illinois variant of regula falsi, each evaluation a kicked segment seeded from
 * the last one.
 */
static int solve(smooth *r, const dth_reg_event *ev, const blend *b, double lam0, const double *d0, double *lam_out,
                 double *mu, double *res, int *iters)
{
    size_t N = ev->N;
    double lam = lam0, R = 0;
    int total = 0, rc, k;
    if (d0) memcpy(r->d, d0, N * sizeof *r->d);
    else {
        rc = dth__reg_euler_seed(r->model, r->n, ev->z, ev->zlo, lam, r->d, r->y, r->g);
        if (rc) return rc;
    }
    *mu = 0;
    /* where the kicked segment of the starting step has no solution (an unresolved passage, e.g.
     * a Kepler pericentre), start from halved steps */
    double *dsave = r->y;
    memcpy(dsave, r->d, N * sizeof *r->d);
    for (int half = 0;; half++) {
        rc = eval_at(r, ev, b, 0, lam, mu, res, &total, &R);
        if (rc <= 0 || half == 3) break;
        lam *= 0.5;
        for (size_t j = 0; j < N; j++) r->d[j] = 0.5 * dsave[j];
        memcpy(dsave, r->d, N * sizeof *r->d);
        *mu = 0;
    }
    if (rc) return rc;
    /* bracket: a secant step toward the root once two points are known (R is smooth and nearly
     * linear here), else growing geometric steps; within the limits either way */
    double la = lam, Ra = R, lb = lam, Rb = R, f = 1.02, lp = 0, Rp = 0;
    double hi = 8 * fmax(fabs(lam0), b->la), lo = fabs(lam0) / 1024;
    for (k = 0; R != 0 && (Ra > 0) == (Rb > 0); k++) {
        double ln = (R < 0) == (ev->dir > 0) ? lam * f : lam / f;
        if (k > 0 && R != Rp) {
            double sec = lam - R * (lam - lp) / (R - Rp), over = lam + 1.2 * (sec - lam); /* aim just past the root */
            if ((over - lam) * (ln - lam) > 0 && over * ev->dir > 0 && fabs(over) >= lo && fabs(over) <= hi) ln = over;
        }
        if (k == 80 || fabs(ln) > hi || fabs(ln) < lo) return DTH_ENOCONV;
        lp = lam, Rp = R;
        rc = eval_at(r, ev, b, lam, ln, mu, res, &total, &R);
        if (rc) return rc;
        lam = ln;
        if ((R > 0) == (Ra > 0)) la = lam, Ra = R;
        else lb = lam, Rb = R;
        f = 1 + 1.5 * (f - 1);
    }
    /* Illinois on [la, lb]; stop where the bracket or the step is at round-off of lambda */
    int side = 0;
    for (k = 0; R != 0 && fabs(lb - la) > 4 * DBL_EPSILON * fabs(lam); k++) {
        if (k == 100) return DTH_ENOCONV;
        double ln = (la * Rb - lb * Ra) / (Rb - Ra);
        if (!(ln > fmin(la, lb) && ln < fmax(la, lb))) ln = 0.5 * (la + lb);
        if (fabs(ln - lam) <= 2 * DBL_EPSILON * fabs(lam)) break;
        rc = eval_at(r, ev, b, lam, ln, mu, res, &total, &R);
        if (rc) return rc;
        lam = ln;
        if ((R > 0) == (Ra > 0)) {
            la = lam, Ra = R;
            if (side == -1) Rb *= 0.5;
            side = -1;
        } else {
            lb = lam, Rb = R;
            if (side == 1) Ra *= 0.5;
            side = 1;
        }
    }
    *lam_out = lam;
    *iters = total;
    return DTH_OK;
}

/* The changeover weight and the law's step at a vertex z, cached for the last vertex asked (the
 * next step starts there, and apply asks for the vertex admit turned down). A function of the
 * point only (K is fixed before the first call; state_loaded drops the cache), so a hit gives
 * exactly what weight() would. */
static int vertex_weight(smooth *r, const double *z, double *w, double *l)
{
    size_t N = 2 * r->n + 2;
    if (r->cache_ok && !memcmp(z, r->zc, N * sizeof *z)) {
        *w = r->wc;
        *l = r->lc;
        return DTH_OK;
    }
    int sg;
    int rc = weight(r, z, w, &sg, l, NULL);
    if (rc) return rc;
    memcpy(r->zc, z, N * sizeof *z);
    r->wc = *w;
    r->lc = *l;
    r->cache_ok = 1;
    return DTH_OK;
}

static int apply(void *self, const dth_reg_event *ev, dth_reg_action *act)
{
    smooth *r = self;
    size_t N = ev->N;
    /* the step to start from: the ordinary one if it exists and is within a factor 2 of the
     * incoming one (a far root of the ordinary constraint, e.g. a ghost, is no guide), else the
     * incoming one; the bracket then stays within a factor 8 of it, so the root found continues
     * the trajectory */
    int plain = ev->plain_status == DTH_OK && ev->plain_lambda != 0 && ev->plain_d &&
                (ev->lam_in == 0 ||
                 (fabs(ev->plain_lambda) <= 2 * fabs(ev->lam_in) && 2 * fabs(ev->plain_lambda) >= fabs(ev->lam_in)));
    double lam0 = plain ? ev->plain_lambda : ev->lam_in;
    const double *d0 = plain ? ev->plain_d : ev->in_d;
    if (!(lam0 * ev->dir > 0)) {
        act->why = "no step to start the changeover from";
        return DTH_EREFUSED;
    }
    if (!r->ks && !(r->ks = dth_calloc(r->alloc, r->nks, sizeof(double)))) {
        act->why = "no memory for the changeover's dense Newton workspace, 2 (2n + 1)^2 doubles";
        return DTH_ENOMEM;
    }
    if (!r->K_fixed) {
        /* fix K so that the law gives lam0 at the (predicted) midpoint of the step now taken:
         * z + plain_d is the ordinary step's midpoint; z + in_d (in_d = zbar_in - z_(k-1), the
         * incoming offset reused for this step) its predicted midpoint, not the incoming midpoint
         * z - in_d; without d0, the vertex itself */
        for (size_t j = 0; j < N; j++) r->y[j] = ev->z[j] + (ev->zlo[j] + (d0 ? d0[j] : 0));
        int rc = fix_law_constant(r, r->y, lam0);
        if (rc) return rc;
    }
    double lam = 0, mu = 0, res = 0;
    int iters = 0;
    blend b;
    /* the start vertex's weight, usually cached by admit */
    for (size_t j = 0; j < N; j++) r->y[j] = ev->z[j] + ev->zlo[j];
    int rc = vertex_weight(r, r->y, &b.wa, &b.la);
    if (rc) return rc;
    rc = solve(r, ev, &b, lam0, d0, &lam, &mu, &res, &iters);
    if (rc > 0 && b.wa < 1) {
        /* no changeover segment (a vertex far off the law's offset): a law step */
        int more = 0;
        b.wa = 1;
        rc = solve(r, ev, &b, lam0, d0, &lam, &mu, &res, &more);
        iters += more;
    }
    act->iters = iters;
    if (rc > 0) act->why = "no changeover or law segment between 1/1024 of the incoming step and 8 times the law's";
    if (rc) return rc < 0 ? rc : DTH_EREFUSED;
    memcpy(act->d, r->d, N * sizeof *act->d);
    act->lambda = lam;
    act->what = DTH_REG_REPLACE;
    act->residual = res;
    return DTH_OK;
}

/* Take the ordinary step where the changeover weight is 0 at both of its vertices and its size is
 * within a factor 2 of the law's there (a ghost root is far larger): conditions on the unordered
 * pair, so an ordinary step stays its own reverse. */
static int admit(void *self, const double *za, const double *zb, double lambda)
{
    smooth *r = self;
    size_t N = 2 * r->n + 2;
    if (!r->K_fixed) {
        for (size_t j = 0; j < N; j++) r->zb[j] = 0.5 * (za[j] + zb[j]);
        if (fix_law_constant(r, r->zb, lambda)) return -1;
    }
    double wa, wb, la, lb;
    if (vertex_weight(r, za, &wa, &la)) return -1;
    if (wa != 0) return 0;
    if (vertex_weight(r, zb, &wb, &lb)) return -1;
    double q = fabs(lambda) / sqrt(la * lb);
    return wb == 0 && q >= 0.5 && q <= 2;
}

/* The state a checkpoint keeps: the law's constant K once fixed (the weight cache is only a cache). */
static const dth_field state_fields[] = {
    {"K", offsetof(smooth, K), DTH_FIELD_F64, DTH_CHECK_NONNEG, 1},
    {"K_fixed", offsetof(smooth, K_fixed), DTH_FIELD_INT, DTH_CHECK_BOOL, 1},
};

/* After a restore or a rollback: a fixed K is a law's constant; the cache is of the state before. */
static int state_loaded(void *self)
{
    smooth *r = self;
    r->cache_ok = 0;
    return r->K_fixed && !(r->K > 0) ? -1 : 0;
}

const dth_regularizer_type dth_reg_smooth = {
DTH_REG_TYPE_HEAD,
    .name = "smooth",
    .doc = "ordinary DTH (symplectic) wherever the step is healthy; around psi = 0 and folds a C-infinity changeover to kicked segments of a step law: energy-exact, keeps quadratic invariants, the step pinned at every crossing, ends only where no law segment exists (refused; dth run then suggests a smaller h); the changeover steps are neither symplectic nor reversible",
    .params = params,
    .n_params = sizeof params / sizeof params[0],
    .create = create,
    .destroy = destroy,
    .apply = apply,
    .admit = admit,
    .fields = state_fields,
    .n_fields = sizeof state_fields / sizeof state_fields[0],
    .state_loaded = state_loaded,
};
