/* SPDX-License-Identifier: MIT */
/*
 * The DTH step's policy stage (policy.h): the branch test, which keeps Newton's root only where it
 * is safely the physical one and else takes the physical root of the full search (paper, Theorems
 * EU_1-EU_3, the ghost roots of section 6), and the regularizer hook, which replaces a step where
 * psi changes sign or no physical root lies ahead (section 7). Decisions only: the stepper commits.
 */
#include <float.h>
#include <math.h>
#include <stdarg.h>
#include <stdio.h>
#include <string.h>
#include "dth_internal.h"
#include "policy.h"

/* The cheap test accepts a Newton root only with s <= S_CHEAP, safely below the paper's 6/5
 * (Theorem EU_2 (vi)); between the two the full search decides (branch.c classifies by 6/5). */
#define S_CHEAP 1.0
#define S_FOLD 1.2 /* the paper's 6/5: beyond it a root is the ghost */

static void say(dth__policy *p, const char *fmt, ...) __attribute__((format(printf, 2, 3)));
static void say(dth__policy *p, const char *fmt, ...)
{
    va_list ap;
    va_start(ap, fmt);
    vsnprintf(p->err, p->errlen, fmt, ap);
    va_end(ap);
}

void dth__policy_reset(dth__policy *p)
{
    p->st.psi_known = 0;
    p->st.psi_prev = 0;
    p->st.psi_step = -2;
}

int dth__policy_init(dth__policy *p, const dth_model *model, const dth_options *o, dth__polish_fn polish, void *ctx,
                     char *err, size_t errlen)
{
    memset(p, 0, sizeof *p);
    p->alloc = o->alloc;
    p->err = err;
    p->errlen = errlen;
    p->N = 2 * dth_model_dof(model) + 2;
    p->reg = o->regularizer;
    dth__policy_reset(p);
    size_t N = p->N;
    p->finish = (int)o->finish;
    p->work = dth_calloc(p->alloc, dth_model_work_size(model) + 5 * N, sizeof(double));
    if (!p->work) return DTH_ENOMEM;
    p->cand = p->work + dth_model_work_size(model);
    p->dd = p->cand + N;
    p->ad = p->dd + N; /* and the jump and the offset's low part after it */
    p->regsnap_len = dth__reg_state_size(p->reg);
    if (p->regsnap_len && !(p->regsnap = dth_calloc(p->alloc, p->regsnap_len, 1))) return DTH_ENOMEM;
    if (!o->branch_check || dth__model_banded(model)) return DTH_OK;
    dth_root_options ro;
    dth_root_options_default(&ro);
    ro.K = o->K;
    ro.max_iter = o->max_iter > 30 ? o->max_iter : 30;
    return dth__rootfinder_new(model, &ro, p->alloc, polish, ctx, &p->rf);
}

void dth__policy_free(dth__policy *p)
{
    dth_rootfinder_free(p->rf);
    dth_free(p->alloc, p->work);
    dth_free(p->alloc, p->regsnap);
    memset(p, 0, sizeof *p);
}

void dth__policy_begin(dth__policy *p)
{
    if (p->regsnap_len) dth__reg_save_state(p->reg, p->regsnap);
}

void dth__policy_rollback(dth__policy *p, const dth__policy_state *saved)
{
    p->st = *saved;
    if (p->regsnap_len) dth__reg_load_state(p->reg, p->regsnap, p->regsnap_len);
}

/* ------------------------------------------------------------------------ the branch test */

int dth__policy_branch(dth__policy *p, const dth__view *v, dth__decision *dec)
{
    dth_rootfinder *rf = p->rf;
    int rc = v->status;
    memset(dec, 0, sizeof *dec);
    dec->branch = DTH_BRANCH_NONE;
    p->psi_a = p->dpsi_a = NAN;
    if (!rf) {
        /* no branch check: Newton's root as it is, if it goes the right way */
        if (rc) return rc;
        if (!(v->lambda * v->dir > 0)) {
            say(p, "Newton found lambda = %.17g, against the direction of travel", v->lambda);
            return DTH_ENOROOT;
        }
        dec->branch = v->lambda > 0 ? DTH_BRANCH_PLUS : DTH_BRANCH_MINUS;
        return DTH_OK;
    }
    if (rc < 0) return rc;
    size_t N = v->N;
    double H, psi, dpsi, pabs;
    int vr = dth__rootfinder_vertex(rf, v->z, v->zlo, &H, &psi, &dpsi, &pabs);
    if (vr) return rc ? rc : vr;
    p->psi_a = psi; /* for the regularizer's observe (policy.h) */
    p->dpsi_a = dpsi;
    /* the vertex offset H_k as the step reads it: the direct value wp + H_phys carries eps S, as
     * large as the offset itself at tiny steps, where its sign, which the cheap test reads, is noise */
    if (!isnan(v->hk)) H = v->hk;
    int pz = fabs(psi) <= 32 * DBL_EPSILON * pabs;
    long prev_ok = p->st.psi_step == v->steps - 1 && v->have_prev;
    /* cheap test: a root ahead, safely physical (Theorem EU_2: s well below 6/5, H/psi > 0), no
     * sign change of psi since the last vertex, and a step that continues the last one */
    if (!rc && v->lambda * v->dir > 0 && !pz && H * psi > 0) {
        double s = -(dpsi / psi) * v->lambda;
        double ratio = v->have_prev && v->lam != 0 ? v->lambda / v->lam : 1.0;
        int same_sign = !prev_ok || (p->st.psi_prev > 0) == (psi > 0);
        if (s <= S_CHEAP && same_sign && ratio >= 0.5 && ratio <= 2.0) {
            dec->branch = v->lambda > 0 ? DTH_BRANCH_PLUS : DTH_BRANCH_MINUS;
            p->st.psi_prev = psi;
            p->st.psi_step = v->steps;
            return DTH_OK;
        }
    }
    /* With a regularizer, a vertex approaching psi = 0 whose cubic model has no root with s <= 1 ahead
     * is decided without the full search (docs/regularization.md, "land"): Newton's root if it is the
     * cubic model's nearest (within 10 %) and physical (s <= 6/5, H/psi > 0), else the fold the full
     * search would find; the regularizer replaces the step then. */
    if (p->reg && !pz && psi * dpsi * v->dir < 0) {
        double cr = dth_cubic_root(H, psi, dpsi, v->dir);
        if (cr == 0 || -(dpsi / psi) * cr > S_CHEAP) {
            if (!rc && v->lambda * v->dir > 0 && H * psi > 0 && -(dpsi / psi) * v->lambda <= S_FOLD && cr != 0 &&
                fabs(cr - v->lambda) <= 0.1 * fabs(v->lambda)) {
                dec->branch = v->lambda > 0 ? DTH_BRANCH_PLUS : DTH_BRANCH_MINUS;
                p->st.psi_prev = psi;
                p->st.psi_step = v->steps;
                return DTH_OK;
            }
            say(p, "no physical root ahead of the vertex approaching psi = 0 (H = %.3g, psi = %.3g, psi' = %.3g: the "
                   "cubic model's root %s)", H, psi, dpsi, cr == 0 ? "is missing" : "lies beyond s = 1");
            return DTH_EFOLD;
        }
    }
    /* the full search on [-L, L] around the expected step */
    double lref = fmax(fabs(v->lam), fabs(v->lam_hint));
    if (!rc && isfinite(v->lambda)) lref = fmax(lref, 0.5 * fabs(v->lambda));
    dth_root_set set;
    double L = 8 * lref;
    const double *zr = dth__rootfinder_point(rf); /* z + zlo rounded, as the search starts from */
    int fr = dth_find_roots(rf, zr, L, &set);
    if (fr) return rc ? rc : fr;
    const dth_root *phys = NULL, *dbl = NULL, *ghost = NULL;
    for (size_t i = 0; i < set.count; i++) {
        const dth_root *r = &set.root[i];
        if (!(r->lambda * v->dir > 0)) continue;
        if (r->flags & DTH_ROOT_DOUBLE) {
            if (!dbl || fabs(r->lambda) < fabs(dbl->lambda)) dbl = r;
        } else if (r->cls == DTH_BRANCH_GHOST) {
            if (!ghost || fabs(r->lambda) < fabs(ghost->lambda)) ghost = r;
        } else if (r->cls == DTH_BRANCH_PLUS || r->cls == DTH_BRANCH_MINUS) {
            phys = r;
        }
    }
    if (phys && (!dbl || fabs(phys->lambda) < fabs(dbl->lambda))) {
        /* take it: the step's own Newton from the root's midpoint (refactors for the tangent map) */
        const double *rz = dth__rootfinder_root_mid(rf, (size_t)(phys - set.root));
        for (size_t j = 0; j < N; j++) p->dd[j] = rz[j] - v->z[j];
        dec->verdict = DTH__RESEED;
        dec->lambda = phys->lambda;
        dec->d = p->dd;
        dec->branch = phys->cls;
        dec->psi = psi;
        return DTH_OK;
    }
    int st;
    double rho = pz ? 0 : H / psi;
    int toward_fold = !pz && -(dpsi / psi) * v->dir > 0; /* travelling toward positive s */
    if (dbl) st = DTH_EFOLD;
    else if (!pz && rho < 0) st = ghost ? DTH_EGHOST : DTH_ENEGOFFSET;
    else if (!pz && rho > 0 && toward_fold) st = DTH_EFOLD;
    else if (ghost) st = DTH_EGHOST;
    else st = DTH_ENOROOT;
    /* After a failed Newton, claim "no physical root" only from a complete scan ahead; else (or
     * for a bare DTH_ENOROOT) Newton's own status says more. */
    int complete = v->dir > 0 ? set.hi >= L * (1 - 1e-12) : set.lo <= -L * (1 - 1e-12);
    if (rc > 0 && (st == DTH_ENOROOT || !complete)) return rc;
    say(p, "no physical root ahead of the vertex (H = %.3g, psi = %.3g, psi' = %.3g, %zu roots in [%.3g, %.3g])", H,
        psi, dpsi, set.count, set.lo, set.hi);
    return st;
}

/* ------------------------------------------------------------------------ the regularizer */

int dth__policy_replaces_all(const dth__policy *p)
{
    return dth__reg_replaces_all(p->reg);
}

static int psi_sign_at(dth__policy *p, const dth_model *m, const double *z, int *sign)
{
    double psi;
    int rc = dth_model_psi(m, z, &psi, NULL, p->work);
    if (rc) return rc;
    *sign = psi > 0 ? 1 : (psi < 0 ? -1 : 0);
    return DTH_OK;
}

/* The sign of psi at the current vertex, computed once and then carried from step to step. */
static int known_psi_sign(dth__policy *p, const dth__view *v)
{
    if (p->st.psi_known) return DTH_OK;
    int r = psi_sign_at(p, v->model, v->z, &p->st.psi_sign);
    if (!r) p->st.psi_known = 1;
    return r;
}

/* The event the hook sees at the vertex (plain: the ordinary step's outcome). */
static dth_reg_event reg_event(const dth__policy *p, const dth__view *v, int rc, int plain_ok, int sb)
{
    dth_reg_event ev = {v->model, v->N, v->z, v->zlo, v->lam, v->dir, p->st.psi_sign, rc, plain_ok ? v->d : NULL,
                        plain_ok ? v->lambda : 0.0, plain_ok ? sb : 0, v->have_prev ? v->dprev : NULL, 0, p->finish,
                        v->lam_hint};
    return ev;
}

static int reg_apply(dth__policy *p, const dth_reg_event *ev, dth_reg_action *act, dth__decision *dec)
{
    memset(p->ad, 0, 3 * p->N * sizeof *p->ad); /* the offset, the jump, the offset's low part */
    *act = (dth_reg_action){DTH_REG_KEEP, 0.0, p->ad, 0.0, 0, NULL, p->ad + p->N, 0, 0.0, p->ad + 2 * p->N};
    int r = dth_regularizer_apply(p->reg, ev, act);
    dec->iters += act->iters;
    if (!r && act->what != DTH_REG_KEEP && act->what != DTH_REG_REPLACE) {
        act->why = "it answered an unknown action";
        r = DTH_EREFUSED;
    }
    if (r)
        say(p, "regularizer '%s' stopped the run: %s", dth_regularizer_get_type(p->reg)->name,
            act->why ? act->why : dth_strerror(r));
    return r;
}

/* The hook's answer as a decision: its segment, or the candidate (plain_ok). Every check of the
 * segment, and the sign of psi at the new vertex, before the stepper touches the state. */
static int reg_finish(dth__policy *p, const dth__view *v, const dth_reg_action *act, int rc, int plain_ok,
                      dth__decision *dec, int *psi_sign_new)
{
    size_t N = p->N;
    int replace = act->what == DTH_REG_REPLACE;
    if (!replace && !plain_ok) return rc;
    const double *dk = replace ? p->ad : v->d;
    double lam = replace ? act->lambda : v->lambda;
    const char *name = dth_regularizer_get_type(p->reg)->name;
    if (replace && (!(lam * v->dir > 0) || !isfinite(lam))) {
        say(p, "regularizer '%s' answered a step %.17g against the direction of travel", name, lam);
        return DTH_EREFUSED;
    }
    const double *jp = replace ? act->jump : NULL;
    /* the offset's low part: read only under the reversible finish (regularize.h) */
    const double *lp = replace && p->finish == DTH_FINISH_REVERSIBLE ? act->dlo : NULL;
    int jumped = 0, low = 0;
    for (size_t j = 0; j < N; j++) {
        double jj = jp ? jp[j] : 0, lj = lp ? lp[j] : 0;
        if (replace && (!isfinite(dk[j]) || !isfinite(jj) || (v->auton && j == N - 1 && (dk[j] != 0 || lj != 0)) ||
                        (j == N - 1 && jj != 0) || !(fabs(lj) <= fabs(dk[j])))) {
            say(p, "regularizer '%s' answered a non-finite offset, one that changes wp, or a low part above it", name);
            return DTH_EREFUSED;
        }
        jumped |= jj != 0;
        low |= lj != 0;
        p->cand[j] = v->z[j] + (v->zlo[j] + (2 * dk[j] + jj));
    }
    int sb, r = psi_sign_at(p, v->model, p->cand, &sb);
    if (r) return r;
    dec->verdict = replace ? DTH__REPLACE : DTH__TAKE;
    dec->lambda = lam;
    dec->d = dk;
    if (replace) {
        dec->residual = act->residual;
        dec->branch = DTH_BRANCH_REG;
        dec->flags |= DTH_STEP_REGULARIZED | (jumped ? DTH_STEP_RESET : 0u);
        dec->jump = jumped ? jp : NULL;
        dec->dlo = low ? lp : NULL;
        dec->fresh = act->fresh != 0;
        dec->dt = isfinite(act->dt) ? act->dt : 0;
    }
    if (sb != p->st.psi_sign) dec->flags |= DTH_STEP_CROSSING;
    *psi_sign_new = sb;
    return DTH_OK;
}

/* The regularizer's look at an ordinary step it lets through (its observe callback): a clock correction. */
static int observe(dth__policy *p, const dth__view *v, dth__decision *dec)
{
    if (!dth_regularizer_get_type(p->reg)->observe) return DTH_OK;
    size_t N = p->N;
    for (size_t j = 0; j < N; j++) p->cand[j] = v->z[j] + (2 * v->d[j] + v->zlo[j]); /* the end vertex */
    double *zbar = p->dd;
    for (size_t j = 0; j < N; j++) zbar[j] = v->z[j] + (v->d[j] + v->zlo[j]);
    dth_reg_step st = {v->model, N, v->z, zbar, p->cand, v->lambda, v->dir, p->psi_a, p->dpsi_a};
    double dt = 0;
    int r = dth__reg_observe(p->reg, &st, &dt);
    if (r) {
        say(p, "regularizer '%s' stopped the run: %s", dth_regularizer_get_type(p->reg)->name, dth_strerror(r));
        return r;
    }
    dec->dt = isfinite(dt) ? dt : 0;
    return DTH_OK;
}

int dth__policy_pre(dth__policy *p, const dth__view *v, dth__decision *dec, int *psi_sign_new)
{
    memset(dec, 0, sizeof *dec);
    int r0 = known_psi_sign(p, v);
    if (r0) return r0;
    dth_reg_event ev = reg_event(p, v, DTH_EUNSUPPORTED, 0, 0);
    ev.plain_pending = 1;
    dth_reg_action act;
    int r = reg_apply(p, &ev, &act, dec);
    if (r) return r;
    if (act.what == DTH_REG_KEEP) {
        /* compute the ordinary step; dth__policy_cross then takes it. Its failure, if any, writes
         * the message afresh */
        p->err[0] = '\0';
        dec->verdict = DTH__PLAIN;
        return DTH_OK;
    }
    return reg_finish(p, v, &act, DTH_EUNSUPPORTED, 0, dec, psi_sign_new);
}

int dth__policy_cross(dth__policy *p, const dth__view *v, int pre, dth__decision *dec, int *psi_sign_new)
{
    size_t N = p->N;
    int rc = v->status;
    memset(dec, 0, sizeof *dec);
    if (rc < 0) return rc;
    int plain_ok = rc == DTH_OK && v->lambda * v->dir > 0;
    if (rc == DTH_OK && !plain_ok) {
        say(p, "Newton found lambda = %.17g, against the direction of travel", v->lambda);
        rc = DTH_ENOROOT;
    }
    int r0 = known_psi_sign(p, v);
    if (r0) return r0;
    int sa = p->st.psi_sign, sb = 0;
    dth_reg_action act;
    if (pre) {
        /* the hook was asked before the ordinary step (dth__policy_pre) and kept it */
        act = (dth_reg_action){DTH_REG_KEEP, 0.0, p->ad, 0.0, 0, NULL, p->ad + p->N, 0, 0.0, p->ad + 2 * p->N};
        if (!plain_ok) {
            /* say that the hook had no step of its own here */
            const char *name = dth_regularizer_get_type(p->reg)->name;
            if (!p->err[0]) say(p, "%s", dth_strerror(rc));
            size_t len = strlen(p->err);
            snprintf(p->err + len, p->errlen - len, " (regularizer '%s' had no step here and kept the ordinary one)", name);
        } else if (!p->err[0]) {
            say(p, "no error");
        }
        dec->asked = 1;
        int r = reg_finish(p, v, &act, rc, plain_ok, dec, psi_sign_new);
        /* the step back from its end is the hook's again, not this step's reverse */
        if (!r) dec->flags |= DTH_STEP_ONEWAY;
        return r;
    }
    if (plain_ok) {
        for (size_t j = 0; j < N; j++) p->cand[j] = v->z[j] + (2 * v->d[j] + v->zlo[j]);
        int r = psi_sign_at(p, v->model, p->cand, &sb);
        if (r) return r;
        int admit = 1;
        if (sb == sa && dth_regularizer_get_type(p->reg)->admit) {
            admit = dth__reg_admit(p->reg, v->z, p->cand, v->lambda);
            if (admit < 0) return DTH_EMODEL;
        }
        if (sb == sa && admit) {
            dec->verdict = DTH__TAKE;
            dec->lambda = v->lambda;
            dec->d = v->d;
            *psi_sign_new = sb;
            return observe(p, v, dec);
        }
    }
    /* the ordinary step failed or crossed psi = 0: ask the regularizer */
    dth_reg_event ev = reg_event(p, v, rc, plain_ok, sb);
    dec->asked = 1;
    int r = reg_apply(p, &ev, &act, dec);
    if (r) return r;
    r = reg_finish(p, v, &act, rc, plain_ok, dec, psi_sign_new);
    /* kept by a hook that replaces every step from now on (prescribed, its arc just fixed): as above */
    if (!r && act.what == DTH_REG_KEEP && dth__reg_replaces_all(p->reg)) dec->flags |= DTH_STEP_ONEWAY;
    return r;
}

void dth__policy_took(dth__policy *p, double psi, long steps)
{
    p->st.psi_prev = psi;
    p->st.psi_step = steps;
}

void dth__policy_commit(dth__policy *p, int psi_sign_new)
{
    p->st.psi_sign = psi_sign_new;
    p->st.psi_known = 1;
}
