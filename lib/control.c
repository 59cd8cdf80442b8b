/* SPDX-License-Identifier: MIT */
/*
 * Step control by the run's constant (control.h; issue 26 item 1, docs/theory.md "What h fixes"): the
 * first step of a DTH run chosen by silent pilot integrations so that every step stays below h_max
 * (the step law l^6 sqrt(psi^4 + (psi' l)^4) = C inverted over the pilots' midpoints) or the estimated
 * global error at t_end below tol (est ~ C^(1/3)).
 *
 * Everything is computed in logarithms of C: C = h^6 psi^2 spans hundreds of decades between models.
 */
#include <math.h>
#include <stdio.h>
#include <string.h>
#include "dth/control.h"
#include "dth/scene.h"
#include "dth_internal.h"

enum { NSUB = 16 };                 /* Hermite points per segment between two midpoints */
static const double MARGIN = 0.98;  /* h_m = MARGIN h_max: the step the calibration aims at */
static const double EXCURSION = 1.02; /* a pass restarts at a step above EXCURSION h_max */
static const double GUARD = 1.05;   /* the run stops at a step above GUARD h_max */
static const double BLOWN = 0.1;    /* tol: a pilot whose estimate passes BLOWN max |q| stops: orbit-sized */

void dth_control_default(dth_control *c)
{
    if (!c) return;
    memset(c, 0, sizeof *c);
    c->size = sizeof *c;
    c->pilot = NAN;
    c->max_passes = 8;
    c->max_pilots = 8;
}

/* ln c(psi, psi'; h) = ln(h^6 sqrt(psi^4 + (psi' h)^4)) without overflow; -INFINITY where both vanish. */
static double log_c(double psi, double dpsi, double h)
{
    double a = fabs(psi), b = fabs(dpsi) * h, s = fmax(a, b);
    if (!(s > 0)) return -INFINITY;
    if (isinf(s)) return INFINITY;
    a /= s;
    b /= s;
    return 6 * log(h) + 2 * log(s) + 0.5 * log(a * a * a * a + b * b * b * b);
}

/* ln l(z; C) from ln C: F(x) = ln c(psi, psi'; e^x) - ln C is increasing and convex in x = ln l, so
 * Newton from an upper bound (l^6 psi^2 <= C and l^8 psi'^2 <= C) comes down to the root monotonically. */
static double log_law(double lnC, double psi, double dpsi)
{
    double x1 = psi != 0 ? (lnC - 2 * log(fabs(psi))) / 6 : INFINITY;
    double x2 = dpsi != 0 ? (lnC - 2 * log(fabs(dpsi))) / 8 : INFINITY;
    double x = fmin(x1, x2);
    if (!isfinite(x)) return x;
    for (int i = 0; i < 100; i++) {
        double l = exp(x), a = fabs(psi), b = fabs(dpsi) * l, s = fmax(a, b);
        double a4 = pow(a / s, 4), b4 = pow(b / s, 4);
        double F = log_c(psi, dpsi, l) - lnC, dF = 6 + 2 * b4 / (a4 + b4);
        double xn = x - F / dF;
        if (!(xn <= x) || x - xn <= 1e-15 * fmax(1, fabs(x))) return fmin(x, xn);
        x = xn;
    }
    return x;
}

double dth_control_law(double C, double psi, double dpsi)
{
    if (!(C > 0) || !isfinite(C) || !isfinite(psi) || !isfinite(dpsi)) return NAN;
    if (psi == 0 && dpsi == 0) return INFINITY;
    return exp(log_law(log(C), psi, dpsi));
}

/* ---------------------------------------------------------------- the pilots */

typedef struct ctx {
    const dth_model *model;
    dth_options opt;        /* the caller's, copied; h and estimate set per pilot */
    const double *q0, *p0;
    double t0, t_end, t_pilot, dir;
    size_t n;
    double psi0, dpsi0;     /* at the initial state (a midpoint start's first midpoint) */
    double hm;              /* h_max: MARGIN h_max */
    double lc_min;          /* h_max: ln of the least c(z; hm) over the midpoints seen so far (Hermite) */
    double *work;           /* dth_model_psi's */
    void *reg_state;        /* the regularizer's state before the calibration (NULL: none saved) */
    size_t reg_len;
    int passes;
    long steps;
    char fail_msg[200];     /* the integrator's message of the last step that failed in a pilot */
} ctx;

/* What one pilot saw. */
typedef struct pass_out {
    long steps;
    int status;          /* DTH_OK, or a failed step's */
    double t_fail;       /* its vertex time (NaN) */
    double t_last;       /* the last vertex's time */
    double lam_max;
    int excursion;       /* h_max: the pass stopped at the end of its first excursion */
    double t_exc;        /* the excursion's first step (its vertex time) */
    double err_q, q_max; /* tol: the estimate at the last vertex, the largest |q| at the vertices */
    int blown;           /* tol: the pilot stopped where its estimate passed a tenth of the largest |q| */
} pass_out;

/* The least ln c(z; hm) on the segment between two midpoints a and b (times ta, tb) by the cubic
 * Hermite of (psi, psi') at its ends, NSUB - 1 interior points and b itself. */
static double hermite_min(double ta, double pa, double da, double tb, double pb, double db, double hm)
{
    double dt = tb - ta, m = log_c(pb, db, hm);
    if (!(dt != 0)) return m;
    for (int i = 1; i < NSUB; i++) {
        double s = (double)i / NSUB, s2 = s * s, om = 1 - s;
        double h00 = (1 + 2 * s) * om * om, h10 = s * om * om, h01 = s2 * (3 - 2 * s), h11 = s2 * (s - 1);
        double d00 = 6 * s2 - 6 * s, d10 = 3 * s2 - 4 * s + 1, d01 = -6 * s2 + 6 * s, d11 = 3 * s2 - 2 * s;
        double P = h00 * pa + h10 * dt * da + h01 * pb + h11 * dt * db;
        double D = (d00 * pa + d10 * dt * da + d01 * pb + d11 * dt * db) / dt;
        m = fmin(m, log_c(P, D, hm));
    }
    return m;
}

static void reg_restore(ctx *c)
{
    if (c->reg_state) dth__reg_load_state(c->opt.regularizer, c->reg_state, c->reg_len);
}

/* One silent pilot from (q0, p0, t0) with the first step h0 to t_pilot. psi: track the least c over the
 * midpoints (h_max) and stop at the end of the first excursion; est: carry the error estimate (tol). */
static int pass(ctx *c, double h0, int psi, int est, pass_out *o, char *err, size_t errlen)
{
    memset(o, 0, sizeof *o);
    o->t_fail = o->t_exc = NAN;
    o->err_q = NAN;
    dth_options opt = c->opt;
    opt.h = c->dir * fabs(h0);
    opt.estimate = est;
    reg_restore(c);
    dth_integrator *it = NULL;
    int rc = dth_integrator_new(c->model, &opt, &it);
    if (!rc) rc = dth_integrator_start(it, c->q0, c->p0, c->t0);
    if (rc) {
        dth__set_err(err, errlen, "a pilot with the first step %.6g could not start: %s", h0,
                     it ? dth_integrator_errmsg(it) : dth_strerror(rc));
        dth_integrator_free(it);
        return rc;
    }
    size_t n = c->n;
    double h_max = c->hm / MARGIN, tp = 0, pp = 0, dp = 0, ep;
    int have_prev = 0, in_exc = 0;
    const double *z = dth_integrator_vertex(it);
    o->t_last = z[n];
    while (c->dir * (z[n] - c->t_pilot) < 0) {
        dth_step_info info;
        rc = dth_integrator_step(it, &info);
        if (rc) { /* the run would meet it too: the calibration takes a smaller constant */
            o->status = rc;
            o->t_fail = z[n];
            snprintf(c->fail_msg, sizeof c->fail_msg, "%s", dth_integrator_errmsg(it));
            break;
        }
        o->steps++;
        z = dth_integrator_vertex(it);
        o->t_last = z[n];
        double lam = fabs(info.lambda);
        o->lam_max = fmax(o->lam_max, lam);
        double qq = 0;
        for (size_t i = 0; i < n; i++) qq += z[i] * z[i];
        o->q_max = fmax(o->q_max, sqrt(qq));
        if (est && dth_integrator_error(it, &o->err_q, &ep) == DTH_OK && o->err_q > BLOWN * o->q_max) {
            o->blown = 1; /* an orbit-sized error: far too coarse, and such a pilot can wander anywhere */
            break;
        }
        if (psi) {
            const double *m = dth_integrator_midpoint(it);
            double ps, dps;
            if (!m || (rc = dth_model_psi(c->model, m, &ps, &dps, c->work)) != DTH_OK) {
                o->status = m ? rc : DTH_EMODEL;
                o->t_fail = z[n];
                break;
            }
            double lc = have_prev ? hermite_min(tp, pp, dp, m[n], ps, dps, c->hm) : log_c(ps, dps, c->hm);
            c->lc_min = fmin(c->lc_min, lc);
            tp = m[n];
            pp = ps;
            dp = dps;
            have_prev = 1;
            if (!in_exc && lam > EXCURSION * h_max) {
                in_exc = 1;
                o->t_exc = z[n] - c->dir * lam;
            } else if (in_exc && lam <= h_max) {
                o->excursion = 1; /* followed to its end */
                break;
            }
        }
    }
    if (psi && in_exc) o->excursion = 1; /* still in it at the pilots' end, or where a step failed */
    if (est && dth_integrator_error(it, &o->err_q, &ep) != DTH_OK) o->err_q = NAN;
    dth_integrator_free(it);
    c->passes++;
    c->steps += o->steps;
    return DTH_OK;
}

/* ln C at the initial state for a first step h. */
static double log_C_of(const ctx *c, double h) { return log_c(c->psi0, c->dpsi0, fabs(h)); }
static double step_of(const ctx *c, double lnC) { return exp(log_law(lnC, c->psi0, c->dpsi0)); }

/* h_max: passes until one reaches the pilots' end without an excursion. *lnC: the constant to run with. */
static int calibrate_hmax(ctx *c, const dth_control *ctl, dth_control_report *r, double *lnC, double *h, char *err,
                          size_t errlen)
{
    double h0 = ctl->h_max; /* opt->h gives the direction only */
    double lC = log_C_of(c, h0), l_bad = INFINITY;
    int nfail = 0;
    c->lc_min = INFINITY;
    r->hmax_settled = 0;
    for (int p = 0; p < ctl->max_passes; p++) {
        pass_out o;
        int rc = pass(c, h0, 1, 0, &o, err, errlen);
        if (rc) return rc;
        r->t_excursion = o.excursion ? o.t_exc : r->t_excursion;
        r->pilot_status = o.status;
        r->t_failed = o.t_fail;
        int failed = o.status != DTH_OK;
        if (!o.excursion && !failed) { /* this pass is the run */
            r->hmax_settled = 1;
            break;
        }
        r->hmax_restarts++;
        if (failed) l_bad = fmin(l_bad, lC);
        if (c->lc_min == -INFINITY || isnan(c->lc_min)) {
            dth__set_err(err, errlen, "integrator.h_max: psi and psi' vanish together on the pilot (t near %.6g): no step "
                                      "law to calibrate", o.t_last);
            return DTH_EDOMAIN;
        }
        /* the law binds where it finds a smaller constant than the pass ran with; where it explains less than
         * the excursion (a crossing's step, which the regularizer takes and the law only approximates), the
         * excursion's largest step is brought to h_m as the steps at psi = 0 scale, C^(1/8); a step that failed
         * where the law sees nothing: half the steps, then a quarter, ...; and never again a constant as large
         * as one whose pass failed */
        double lnew = c->lc_min, ratio = o.lam_max / c->hm;
        if (o.excursion && ratio > 1 && !((lC - lnew) / 6 >= log(ratio)))
            lnew = fmin(lnew, lC - 8 * log(ratio)); /* the law explains less than the excursion */
        if (!(lnew < lC - 1e-9)) lnew = lC - 6 * log(2.0) * ++nfail; /* steps / 2, / 4, ... */
        else nfail = 0;
        lnew = fmin(lnew, l_bad - 6 * log(2.0));
        lC = lnew;
        h0 = step_of(c, lC);
    }
    *lnC = lC;
    *h = h0;
    return DTH_OK;
}

/* tol: pilots until one runs to its end with an estimate in [tol, 64 tol], then the constant for tol / 2
 * (*lnC; *lpilot: the last pilot's, whose estimate r->est is). */
static int calibrate_tol(ctx *c, const dth_control *ctl, dth_control_report *r, double lC, double *lnC, double *lpilot,
                         char *err, size_t errlen)
{
    double span = c->dir * (c->t_end - c->t0), e = NAN, tol = ctl->tol, l_bad = INFINITY, l_e = lC;
    const double HALF = 6 * log(2.0); /* C / 64: half the steps */
    for (int p = 0; p < ctl->max_pilots; p++) {
        pass_out o;
        int rc = pass(c, step_of(c, lC), 0, 1, &o, err, errlen);
        if (rc) return rc;
        r->pilot_status = o.status; /* a failed step: the pilot ends there, its estimate is extrapolated */
        r->t_failed = o.t_fail;
        int failed = o.status != DTH_OK;
        if (failed) l_bad = fmin(l_bad, lC);
        double ran = c->dir * (o.t_last - c->t0), cap = BLOWN * o.q_max;
        double ep = o.err_q * (c->dir * (o.t_last - c->t_end) < 0 && ran > 0 ? span / ran : 1.0);
        int coarse = o.blown || !(ep < cap);
        if (coarse) ep = cap; /* orbit-sized, or no estimate (NaN): far too coarse */
        if (o.steps > 0 && ep > 0) { /* the estimate the final choice scales */
            e = ep;
            l_e = lC;
            r->extrapolated = c->dir * (o.t_last - c->t_end) < 0;
        }
        if (!failed && !coarse && ep >= tol && ep <= 64 * tol) break;
        if (p + 1 == ctl->max_pilots) break;
        if (failed && (coarse || o.steps == 0)) lC -= 2 * HALF;                  /* a quarter of the steps */
        else if (coarse) lC += fmin(3 * log(16 * tol / ep), -3 * HALF);          /* at least 8 times the steps */
        else if (ep > 0) lC += fmin(3 * log(16 * tol / ep), 3 * HALF); /* at most 8 times fewer steps per pilot */
        else lC += 3 * HALF;                                                     /* an estimate of 0: coarser */
        lC = fmin(lC, l_bad - HALF);
    }
    if (!(e > 0)) {
        dth__set_err(err, errlen, "integrator.tol: no pilot gave an error estimate (the last: %s at t = %.6g%s%s)",
                     r->pilot_status ? dth_strerror(r->pilot_status) : "an estimate of 0", r->t_failed,
                     c->fail_msg[0] ? ": " : "", c->fail_msg);
        return r->pilot_status ? r->pilot_status : DTH_EDOMAIN;
    }
    r->est = e;
    *lpilot = l_e;
    *lnC = fmin(l_e + 3 * log(tol / (2 * e)), l_bad - HALF);
    return DTH_OK;
}

static int check_args(const dth_model *model, const dth_options *opt, const double *q0, const double *p0, double t0,
                      double t_end, const dth_control *ctl, const dth_control_report *rep, char *err, size_t errlen)
{
    if (!model || !opt || !q0 || !p0 || !ctl || !rep) {
        dth__set_err(err, errlen, "invalid arguments to dth_control_calibrate (NULL)");
        return DTH_EINVAL;
    }
    if (ctl->size != sizeof *ctl || rep->size != sizeof *rep) {
        dth__set_err(err, errlen, "dth_control has size %zu and dth_control_report %zu, this library's %zu and %zu "
                                  "(dth_control_default; a program built against another dth?)",
                     ctl->size, rep->size, sizeof *ctl, sizeof *rep);
        return DTH_EINVAL;
    }
    if (!(ctl->h_max >= 0) || !isfinite(ctl->h_max) || !(ctl->tol >= 0) || !isfinite(ctl->tol)) {
        dth__set_err(err, errlen, "integrator.h_max = %g, integrator.tol = %g: each must be finite and >= 0 (0: not "
                                  "asked for)", ctl->h_max, ctl->tol);
        return DTH_EINVAL;
    }
    if (ctl->h_max == 0 && ctl->tol == 0) {
        dth__set_err(err, errlen, "nothing to calibrate: neither integrator.h_max nor integrator.tol is set");
        return DTH_EINVAL;
    }
    if ((ctl->h_max > 0 && ctl->max_passes < 1) || (ctl->tol > 0 && ctl->max_pilots < 1)) {
        dth__set_err(err, errlen, "max_passes = %d, max_pilots = %d: at least one pilot", ctl->max_passes,
                     ctl->max_pilots);
        return DTH_EINVAL;
    }
    double dir = opt->h < 0 ? -1 : 1, tp = isnan(ctl->pilot) ? t_end : ctl->pilot;
    if (!isfinite(t0) || !isfinite(t_end) || !(dir * (t_end - t0) > 0)) {
        dth__set_err(err, errlen, "integrator.h_max and integrator.tol need a t_end ahead of t = %g in the direction of "
                                  "h (t_end = %g)", t0, t_end);
        return DTH_EINVAL;
    }
    if (!isfinite(tp) || !(dir * (tp - t0) > 0) || dir * (tp - t_end) > 0) {
        dth__set_err(err, errlen, "integrator.pilot = %g: the pilots' end must lie after t = %g and not beyond t_end = %g",
                     tp, t0, t_end);
        return DTH_EINVAL;
    }
    if (opt->start == DTH_START_VERTEX && opt->has_wp) {
        dth__set_err(err, errlen, "integrator.h_max and integrator.tol choose the first step, which the explicit "
                                  "initial.wp of a vertex start fixes: leave one out");
        return DTH_EINVAL;
    }
    return DTH_OK;
}

int dth_control_calibrate(const dth_model *model, const dth_options *opt, const double *q0, const double *p0,
                          double t0, double t_end, const dth_control *ctl, dth_control_report *rep, char *err,
                          size_t errlen)
{
    if (err && errlen) err[0] = '\0';
    int rc = check_args(model, opt, q0, p0, t0, t_end, ctl, rep, err, errlen);
    if (rc) return rc;
    ctx c;
    memset(&c, 0, sizeof c);
    c.model = model;
    c.opt = *opt;
    if ((rc = dth_options_check(model, &c.opt, err, errlen)) != DTH_OK) return rc;
    if (strcmp(c.opt.method, "dth")) {
        dth__set_err(err, errlen, "integrator.h_max and integrator.tol choose the constant of a DTH run; method '%s' "
                                  "takes the fixed step h", c.opt.method);
        return DTH_EUNSUPPORTED;
    }
    c.q0 = q0;
    c.p0 = p0;
    c.t0 = t0;
    c.t_end = t_end;
    c.t_pilot = isnan(ctl->pilot) ? t_end : ctl->pilot;
    c.dir = opt->h < 0 ? -1 : 1;
    c.n = dth_model_dof(model);
    c.hm = MARGIN * ctl->h_max;
    size_t n = c.n, nw = dth_model_work_size(model);
    c.work = dth_calloc(opt->alloc, nw + 2 * n + 2, sizeof *c.work);
    c.reg_len = dth__reg_state_size(opt->regularizer);
    c.reg_state = c.reg_len ? dth_calloc(opt->alloc, c.reg_len, 1) : NULL;
    if (!c.work || (c.reg_len && !c.reg_state)) {
        dth_free(opt->alloc, c.work);
        dth_free(opt->alloc, c.reg_state);
        return DTH_ENOMEM;
    }
    if (c.reg_state) dth__reg_save_state(opt->regularizer, c.reg_state);
    /* psi and psi' at the initial state as a midpoint (wp = -H_phys; psi does not depend on wp) */
    double *y = c.work + nw;
    memcpy(y, q0, n * sizeof *y);
    y[n] = t0;
    memcpy(y + n + 1, p0, n * sizeof *y);
    y[2 * n + 1] = 0;
    rc = dth_model_psi(model, y, &c.psi0, &c.dpsi0, c.work);
    if (!rc && c.psi0 == 0 && c.dpsi0 == 0) {
        dth__set_err(err, errlen, "psi and psi' both vanish at the initial state (an equilibrium?): no step law to "
                                  "calibrate");
        rc = DTH_EDOMAIN;
    } else if (rc) {
        dth__set_err(err, errlen, "the model failed at the initial state: %s", dth_strerror(rc));
    }
    dth_control_report r;
    memset(&r, 0, sizeof r);
    r.size = sizeof r;
    r.C_hmax = r.C_tol = INFINITY;
    r.est = r.est_pred = r.t_excursion = r.t_failed = NAN;
    r.t_pilot = c.t_pilot;
    double lC = INFINITY, lH = INFINITY, lT = INFINITY, hH = NAN;
    if (!rc && ctl->h_max > 0 && (rc = calibrate_hmax(&c, ctl, &r, &lH, &hH, err, errlen)) == DTH_OK) lC = lH;
    if (!rc && ctl->tol > 0) {
        double start = fmin(lC, log_C_of(&c, opt->h)), lpilot;
        if ((rc = calibrate_tol(&c, ctl, &r, start, &lT, &lpilot, err, errlen)) == DTH_OK) {
            lC = fmin(lC, lT);
            r.est_pred = r.est * exp((lC - lpilot) / 3);
        }
    }
    reg_restore(&c);
    dth_free(opt->alloc, c.work);
    dth_free(opt->alloc, c.reg_state);
    if (rc) return rc;
    double h0 = lC == lH ? hH : step_of(&c, lC); /* h_max binds: its last pass's step itself */
    if (!(h0 > 0) || !isfinite(h0) || t0 + c.dir * h0 == t0) {
        dth__set_err(err, errlen, "the calibrated first step %g cannot advance t = %g", h0, t0);
        return DTH_ESTEPSIZE;
    }
    r.h0 = c.dir * h0;
    r.C = exp(lC);
    r.C_hmax = exp(lH);
    r.C_tol = exp(lT);
    r.step_max = ctl->h_max > 0 ? GUARD * ctl->h_max : 0;
    r.passes = c.passes;
    r.steps = c.steps;
    *rep = r;
    return DTH_OK;
}

int dth_run_setup_control(dth_run_setup *rs, dth_control_report *rep, char *err, size_t errlen)
{
    if (err && errlen) err[0] = '\0';
    if (!rs || (rep && rep->size != sizeof *rep)) {
        dth__set_err(err, errlen, "invalid arguments to dth_run_setup_control (NULL, or a report of another size)");
        return DTH_EINVAL;
    }
    if (!(rs->h_max > 0) && !(rs->tol > 0)) {
        if (rep) {
            memset(rep, 0, sizeof *rep);
            rep->size = sizeof *rep;
            rep->h0 = rs->opt.h;
            rep->C_hmax = rep->C_tol = INFINITY;
            rep->est = rep->est_pred = rep->t_excursion = rep->t_failed = rep->t_pilot = NAN;
        }
        return DTH_OK;
    }
    if (!rs->has_t_end) {
        dth__set_err(err, errlen, "integrator.h_max and integrator.tol need integrator.t_end");
        return DTH_EINVAL;
    }
    dth_control ctl;
    dth_control_default(&ctl);
    ctl.h_max = rs->h_max;
    ctl.tol = rs->tol;
    ctl.pilot = rs->pilot;
    dth_options o = rs->opt;
    if (rs->h_asked != 0 && isfinite(rs->h_asked)) o.h = rs->h_asked;
    dth_control_report r = {.size = sizeof r};
    int rc = dth_control_calibrate(rs->model, &o, rs->q0, rs->p0, rs->t0, rs->t_end, &ctl, &r, err, errlen);
    if (rc) return rc;
    rs->opt.h = r.h0;
    rs->step_max = r.step_max;
    if (rep) *rep = r;
    return DTH_OK;
}
