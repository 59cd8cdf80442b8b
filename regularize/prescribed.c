/* SPDX-License-Identifier: MIT */
/*
 * Regularizer "prescribed" (paper, section 7: DTH dynamics needs a regularization): every step is
 * a kicked segment (dth_kicked_segment: midpoint on H = 0, chord (lambda J grad H + mu n)(zbar))
 * whose time step is prescribed by a law evaluated at the segment's own midpoint,
 *     lambda = dir * arc / |u(zbar)|^alpha,   u = the (q, p) part of J grad H,
 * with arc a constant fixed once (parameter, or from the first step: |lambda| |u(its midpoint)|^alpha).
 * The law depends on the midpoint only and each kicked segment is its own reverse, so the step
 * map is exactly time-reversible with no switching decision (with fallback=no: the default
 * fallback keeps the ordinary step where no kicked segment exists, a switch that the reverse run
 * need not repeat: flagged DTH_STEP_ONEWAY); under the integrator's reversible finish each segment
 * is finished in double-double at coarsened model reads (lib/prescribed_rev.c), so that the segment
 * back from its end finds the same midpoint to 2^-100; the step varies smoothly through psi = 0
 * and the step never ends there (dH/dmu = |n|^2/2 != 0 away from equilibria). Energy is
 * exact (wp untouched, midpoints on H = 0), quadratic invariants are kept; the kick gives up
 * symplecticity at every step. (Its former hybrid `band`, ordinary steps away from psi = 0 behind
 * a hard switch, was not reversible; the default regularizer `land` replaces only the crossing step.)
 */
#include <float.h>
#include <stddef.h>
#include <math.h>
#include <string.h>
#include "dth/integrator.h"
#include "dth/regularize.h"
#include "dth_internal.h"
#include "reg_common.h"

typedef struct prescribed {
    const dth_model *model;
    size_t n;
    double alpha, arc;
    int arc_fixed;             /* arc set (parameter, or at the first step): a constant after that */
    int fallback;              /* keep the ordinary step where no kicked segment is found */
    double lam_last, mu_last;  /* the last segment's step and kick (0: none yet); a seed only */
    double *ks, *work, *d, *y, *g, *dlast, *dlo;
    const dth_allocator *alloc;
    double *kl;                /* dth__kicked_law_rev's workspace, allocated at the first reversible step */
} prescribed;

static const dth_param_spec params[] = {
    {"alpha", "0", "step law lambda = arc / |u(zbar)|^alpha (0: constant step, 1: constant phase-space arc) (>= 0)"},
    {"arc", "", "the constant arc (> 0); default: |first step| * |u(its midpoint)|^alpha"},
    {"fallback", "yes", "yes: keep the ordinary DTH step where the kicked segment has no solution (no: refuse)"},
};

static int create(const dth_reg_args *a, void **self)
{
    size_t n = dth_model_dof(a->model), N = 2 * n + 2;
    size_t nks = dth_kicked_segment_work_size(a->model), nw = dth_model_work_size(a->model);
    prescribed *r = dth_calloc(a->alloc, 1, sizeof *r);
    if (!r) return DTH_ENOMEM;
    *self = r;
    r->fallback = 1;
    for (size_t i = 0; i < a->nkv; i++) {
        const char *k = a->kv[i].key, *v = a->kv[i].value;
        if (!strcmp(k, "alpha") && (dth_parse_double(v, &r->alpha) || !(r->alpha >= 0) || !isfinite(r->alpha)))
            return dth__reg_param_err(a, k, "a number >= 0");
        if (!strcmp(k, "arc")) {
            if (dth_parse_double(v, &r->arc) || !(r->arc > 0) || !isfinite(r->arc))
                return dth__reg_param_err(a, k, "a number > 0");
            r->arc_fixed = 1;
        }
        if (!strcmp(k, "fallback")) {
            if (!strcmp(v, "yes")) r->fallback = 1;
            else if (!strcmp(v, "no")) r->fallback = 0;
            else return dth__reg_param_err(a, k, "yes or no");
        }
    }
    r->ks = dth_calloc(a->alloc, nks + nw + 5 * N, sizeof(double));
    if (!r->ks) return DTH_ENOMEM;
    r->alloc = a->alloc;
    r->model = a->model;
    r->n = n;
    r->work = r->ks + nks;
    r->d = r->work + nw;
    r->y = r->d + N;
    r->g = r->y + N;
    r->dlast = r->g + N;
    r->dlo = r->dlast + N;
    return DTH_OK;
}

static void destroy(void *self, const dth_allocator *alloc)
{
    prescribed *r = self;
    if (!r) return;
    dth_free(alloc, r->kl);
    dth_free(alloc, r->ks);
    dth_free(alloc, r);
}

/* |u| over (q, p) at y = z + (zlo + d) (d may be NULL: at the vertex). */
static int speed_at(prescribed *r, const double *z, const double *zlo, const double *d, double *speed)
{
    size_t n = r->n;
    for (size_t j = 0; j < 2 * n + 1; j++) r->y[j] = z[j] + ((zlo ? zlo[j] : 0) + (d ? d[j] : 0));
    double H;
    int rc = dth_model_eval(r->model, r->y, DTH_EVAL_H | DTH_EVAL_GRAD, &H, r->g, NULL);
    if (rc) return rc;
    *speed = sqrt(dth__reg_grad_qp2(r->g, n));
    return isfinite(*speed) ? DTH_OK : DTH_EDOMAIN;
}

/* The law's step for a speed (signed by the direction of travel). */
static double law(const prescribed *r, double speed, double dir)
{
    return dir * (r->alpha == 0 ? r->arc : r->arc / pow(speed, r->alpha));
}

/*
 * Solve the kicked segment together with its step: lambda - law(|u(zbar(lambda))|) = 0 by a
 * secant iteration on lambda around dth_kicked_segment (seeded from the last solution, so each
 * inner solve takes one or two Newton iterations). Both directions solve the same equations for
 * the same midpoint, so the converged segment is its own reverse up to round-off.
 */
static int solve(prescribed *r, const dth_reg_event *ev, double *lam_out, double *mu, double *res, int *iters)
{
    size_t N = ev->N;
    double speed;
    int rc = speed_at(r, ev->z, ev->zlo, NULL, &speed);
    if (rc) return rc;
    double lam = law(r, speed, ev->dir);
    int total = 0, it, close = 0;
    /* seed: the last segment's offset rescaled to this step (the next midpoint offset mirrors the
     * last one; after a reversal lambda/lam_last ~ -1 gives the last midpoint back), else the
     * ordinary step's offset rescaled, else an Euler half step. Only the seed depends on history. */
    for (int attempt = 0;; attempt++) {
        memset(r->d, 0, N * sizeof *r->d);
        *mu = 0;
        if (attempt == 0 && r->lam_last != 0) {
            double s = lam / r->lam_last;
            for (size_t j = 0; j < N; j++) r->d[j] = s * r->dlast[j];
            *mu = s * r->mu_last;
        } else if (attempt <= 1 && ev->plain_d && ev->plain_lambda != 0) {
            double s = lam / ev->plain_lambda;
            for (size_t j = 0; j < N; j++) r->d[j] = s * ev->plain_d[j];
            attempt = 1;
        } else {
            rc = dth__reg_euler_seed(r->model, r->n, ev->z, ev->zlo, lam, r->d, r->y, r->g);
            if (rc) return rc;
            attempt = 2;
        }
        int ki = 0;
        rc = dth_kicked_segment(r->model, ev->z, ev->zlo, lam, r->d, mu, res, &ki, r->ks);
        total += ki;
        if (rc < 0 || (rc == DTH_OK) || attempt == 2) break;
    }
    if (rc) return rc;
    double lp = 0, fp = 0;
    for (it = 0; it < 40; it++) {
        if (it > 0) {
            int ki = 0;
            rc = dth_kicked_segment(r->model, ev->z, ev->zlo, lam, r->d, mu, res, &ki, r->ks);
            total += ki;
            if (rc) return rc;
        }
        if (r->alpha == 0) break;
        rc = speed_at(r, ev->z, ev->zlo, r->d, &speed);
        if (rc) return rc;
        double f = lam - law(r, speed, ev->dir);
        /* f carries the round-off of |u| (a few ulp of lambda): stop at 4 ulp, or one secant
         * step after reaching 64 ulp (the step then only moves lambda within that noise) */
        if (fabs(f) <= 4 * DBL_EPSILON * fabs(lam) || close) break;
        if (fabs(f) <= 64 * DBL_EPSILON * fabs(lam)) close = 1;
        double ln;
        if (it == 0 || f == fp) ln = lam - f; /* fixed-point step to start the secant */
        else ln = lam - f * (lam - lp) / (f - fp);
        if (!(ln * ev->dir > 0) || !isfinite(ln)) return DTH_ENOCONV;
        lp = lam;
        fp = f;
        /* rescale the seed to the new step (the flow part of d scales with lambda) */
        double s = ln / lam;
        for (size_t j = 0; j < N; j++) r->d[j] *= s;
        *mu *= s;
        lam = ln;
    }
    if (it == 40) return DTH_ENOCONV;
    memcpy(r->dlast, r->d, N * sizeof *r->d);
    r->lam_last = lam;
    r->mu_last = *mu;
    *lam_out = lam;
    *iters = total;
    return DTH_OK;
}

/*
 * The same segment under the integrator's reversible finish (ev->finish == DTH_FINISH_REVERSIBLE): one
 * Newton on (d, lambda, mu) with the law as its last row, finished by chord steps in double-double that
 * read the model, the kick direction and the law at the coarsened midpoint (dth__kicked_law_rev,
 * lib/prescribed_rev.c): the segment back from its end finds the same midpoint to about 2^-100, and the offset's
 * low part (r->dlo) goes to the integrator, which makes the end vertex z + 2 (d + dlo) in double-double.
 * The seeds are solve()'s.
 */
static int solve_rev(prescribed *r, const dth_reg_event *ev, double *lam_out, double *mu, double *res, int *iters)
{
    size_t N = ev->N;
    if (!r->kl && !(r->kl = dth_calloc(r->alloc, dth__kicked_law_work_size(r->model), sizeof(double))))
        return DTH_ENOMEM;
    double speed;
    int rc = speed_at(r, ev->z, ev->zlo, NULL, &speed);
    if (rc) return rc;
    double lam0 = law(r, speed, ev->dir), lam = lam0;
    int total = 0;
    for (int attempt = 0;; attempt++) {
        memset(r->d, 0, N * sizeof *r->d);
        *mu = 0;
        if (attempt == 0 && r->lam_last != 0) {
            double s = lam0 / r->lam_last;
            for (size_t j = 0; j < N; j++) r->d[j] = s * r->dlast[j];
            *mu = s * r->mu_last;
        } else if (attempt <= 1 && ev->plain_d && ev->plain_lambda != 0) {
            double s = lam0 / ev->plain_lambda;
            for (size_t j = 0; j < N; j++) r->d[j] = s * ev->plain_d[j];
            attempt = 1;
        } else {
            rc = dth__reg_euler_seed(r->model, r->n, ev->z, ev->zlo, lam0, r->d, r->y, r->g);
            if (rc) return rc;
            attempt = 2;
        }
        int ki = 0;
        lam = lam0;
        rc = dth__kicked_law_rev(r->model, ev->z, ev->zlo, r->arc, r->alpha, ev->dir, r->d, r->dlo, &lam, mu, res, &ki,
                                 r->kl);
        total += ki;
        if (rc < 0 || rc == DTH_OK || attempt == 2) break;
    }
    *iters = total;
    if (rc) return rc;
    memcpy(r->dlast, r->d, N * sizeof *r->d);
    r->lam_last = lam;
    r->mu_last = *mu;
    *lam_out = lam;
    return DTH_OK;
}

static int apply(void *self, const dth_reg_event *ev, dth_reg_action *act)
{
    prescribed *r = self;
    if (!r->arc_fixed) {
        /* fix the constant once, from the first step this instance sees */
        double l0 = ev->lam_in != 0 ? fabs(ev->lam_in) : (ev->plain_status == DTH_OK ? fabs(ev->plain_lambda) : 0);
        if (!(l0 > 0)) return DTH_EREFUSED;
        /* the speed at the incoming step's midpoint when there is one (then that step, e.g. the
         * exact first step of a midpoint start, obeys the law itself and a round trip retraces
         * it), else at the vertex */
        double speed;
        int rc;
        if (ev->lam_in != 0 && ev->in_d) {
            for (size_t j = 0; j < ev->N; j++) r->dlast[j] = -ev->in_d[j];
            rc = speed_at(r, ev->z, ev->zlo, r->dlast, &speed);
        } else {
            rc = speed_at(r, ev->z, ev->zlo, NULL, &speed);
        }
        if (rc) return rc;
        r->arc = r->alpha == 0 ? l0 : l0 * pow(speed, r->alpha);
        if (!(r->arc > 0) || !isfinite(r->arc)) return DTH_EREFUSED;
        r->arc_fixed = 1;
    }
    double lam = 0, mu = 0, res = 0;
    int iters = 0, rev = ev->finish == DTH_FINISH_REVERSIBLE;
    int rc = rev ? solve_rev(r, ev, &lam, &mu, &res, &iters) : solve(r, ev, &lam, &mu, &res, &iters);
    act->iters = iters;
    if (rc > 0 && (ev->plain_status == DTH_OK || ev->plain_pending) && r->fallback) {
        /* no kicked segment (its Newton fails where dH(zbar)/dmu passes 0): keep the ordinary
         * DTH step, itself its own reverse; the next step returns to the law */
        r->lam_last = 0;
        act->what = DTH_REG_KEEP;
        return DTH_OK;
    }
    if (rc > 0)
        act->why = r->alpha == 0
                       ? "no kicked segment of the constant step here (a step law that resolves the motion, alpha > 0, may pass)"
                       : "no kicked segment of the step law's length here (a smaller arc, or a larger alpha, may pass)";
    if (rc) return rc < 0 ? rc : DTH_EREFUSED;
    memcpy(act->d, r->d, ev->N * sizeof *act->d);
    if (rev && act->dlo) memcpy(act->dlo, r->dlo, ev->N * sizeof *act->dlo);
    act->lambda = lam;
    act->what = DTH_REG_REPLACE;
    act->residual = res;
    return DTH_OK;
}

/* Every step is a kicked segment: the ordinary step need not be computed first, once the arc is
 * fixed (before that, a vertex start with no incoming step takes the arc from the ordinary step's
 * lambda, and the ordinary step offered to the hook is turned down). */
static int admit(void *self, const double *za, const double *zb, double lambda)
{
    (void)self, (void)za, (void)zb, (void)lambda;
    return 0;
}

static int replaces_all(const void *self)
{
    const prescribed *r = self;
    return r->arc_fixed;
}

/* The state a checkpoint keeps: arc once fixed, and the last segment (the next solve's seed). */
static const dth_field state_fields[] = {
    {"arc", offsetof(prescribed, arc), DTH_FIELD_F64, DTH_CHECK_NONNEG, 1},
    {"arc_fixed", offsetof(prescribed, arc_fixed), DTH_FIELD_INT, DTH_CHECK_BOOL, 1},
    {"lam_last", offsetof(prescribed, lam_last), DTH_FIELD_F64, DTH_CHECK_FINITE, 1},
    {"mu_last", offsetof(prescribed, mu_last), DTH_FIELD_F64, DTH_CHECK_FINITE, 1},
    {"dlast", offsetof(prescribed, dlast), DTH_FIELD_F64_PTR, DTH_CHECK_FINITE, 0}, /* 2n + 2 doubles */
};

/* After a restore or a rollback: a fixed arc is a law's constant. */
static int state_loaded(void *self)
{
    const prescribed *r = self;
    return r->arc_fixed && !(r->arc > 0) ? -1 : 0;
}

const dth_regularizer_type dth_reg_prescribed = {
DTH_REG_TYPE_HEAD,
    .name = "prescribed",
    .doc = "every step a kicked segment with lambda = arc/|u(zbar)|^alpha at its own midpoint: energy-exact, keeps quadratic invariants, reversible (to round-off; with integrator.reversible = yes each step and the one back from its end meet to 2^-100; fallback steps are not reversible and are counted), smooth through psi = 0; not symplectic at any step",
    .params = params,
    .n_params = sizeof params / sizeof params[0],
    .create = create,
    .destroy = destroy,
    .apply = apply,
    .admit = admit,
    .fields = state_fields,
    .n_fields = sizeof state_fields / sizeof state_fields[0],
    .state_loaded = state_loaded,
    .replaces_all = replaces_all,
};
