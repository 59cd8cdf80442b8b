/* SPDX-License-Identifier: MIT */
/*
 * The run driver (run.h): the loop over steps with samples at vertices, midpoints (where the
 * paper's energy constraint H(zbar) = 0 holds) or output times, dense output of the method's
 * order, events located on it, an exact end at t_end, checkpoint and progress callbacks.
 */
#include <math.h>
#include <string.h>
#include "dth/run.h"
#include "dth_internal.h"
#include "dth/scene.h"

void dth_run_state_init(dth_run_state *st)
{
    if (st) memset(st, 0, sizeof *st);
}

void dth_run_config_default(dth_run_config *cfg)
{
    if (!cfg) return;
    memset(cfg, 0, sizeof *cfg);
    cfg->size = sizeof *cfg;
    cfg->t0 = NAN;
    cfg->points = DTH_POINTS_VERTICES;
    cfg->every = 1;
    cfg->stop_error = 0.25;
    cfg->step_ratio = 16;
}

void dth_run_config_from_setup(dth_run_config *cfg, const dth_run_setup *rs)
{
    if (!cfg) return;
    dth_run_config_default(cfg);
    if (!rs) return;
    cfg->has_t_end = rs->has_t_end;
    cfg->t_end = rs->t_end;
    cfg->steps = rs->steps;
    cfg->t0 = rs->t0;
    cfg->events = rs->events;
    cfg->nevents = rs->nevents;
    cfg->stop_error = rs->stop_error;
    cfg->step_ratio = rs->warn_ratio;
    cfg->step_max = rs->step_max;
}

/* ---------------------------------------------------------------- dense output */

int dth_flow(const dth_model *model, const double *z, double *u, double *work)
{
    size_t n = dth_model_dof(model), N = 2 * n + 2;
    int rc = dth_model_eval(model, z, DTH_EVAL_GRAD, NULL, work, NULL);
    if (rc) return rc;
    for (size_t i = 0; i < n; i++) {
        u[i] = work[n + 1 + i];
        u[n + 1 + i] = -work[i];
    }
    u[n] = 1;
    u[N - 1] = -work[n];
    return DTH_OK;
}

void dth_dense_eval(size_t n, const double *za, const double *zb, const double *zm, const double *ua,
                    const double *ub, double t, double *z)
{
    size_t N = 2 * n + 2;
    double ta = za[n], tb = zb[n], h = tb - ta;
    const double *node = t == ta ? za : t == tb ? zb : zm && t == zm[n] ? zm : NULL;
    if (node || h == 0) {
        memcpy(z, node ? node : za, N * sizeof *z);
        z[n] = t;
        return;
    }
    double th = (t - ta) / h, om = 1 - th;
    /* cubic Hermite basis on [0, 1] */
    double h00 = (1 + 2 * th) * om * om, h01 = th * th * (3 - 2 * th);
    double h10 = th * om * om, h11 = -th * th * om;
    double w = 16 * th * th * om * om; /* theta^2 (1 - theta)^2, scaled to 1 at theta = 1/2 */
    for (size_t j = 0; j < N; j++) {
        double c = h00 * za[j] + h01 * zb[j] + h * (h10 * ua[j] + h11 * ub[j]);
        if (zm) c += w * (zm[j] - 0.5 * (za[j] + zb[j]) - 0.125 * h * (ua[j] - ub[j]));
        z[j] = c;
    }
    z[n] = t;
}

/* ---------------------------------------------------------------- built-in events */

int dth_event_coordinate(void *user, size_t n, const double *z, double *g)
{
    const dth_event_spec *e = user;
    if (!e || e->index >= 2 * n + 2) return DTH_EINVAL;
    *g = z[e->index] - e->value;
    return DTH_OK;
}

int dth_event_time(void *user, size_t n, const double *z, double *g)
{
    const dth_event_spec *e = user;
    if (!e) return DTH_EINVAL;
    *g = z[n] - e->value;
    return DTH_OK;
}

int dth_event_distance(void *user, size_t n, const double *z, double *g)
{
    const dth_event_spec *e = user;
    if (!e) return DTH_EINVAL;
    size_t m = e->dofs ? e->ndofs : n;
    double s = 0;
    for (size_t i = 0; i < m; i++) {
        size_t d = e->dofs ? e->dofs[i] : i;
        if (d >= n) return DTH_EINVAL;
        s += z[d] * z[d];
    }
    *g = sqrt(s) - e->value;
    return DTH_OK;
}

/* ---------------------------------------------------------------- the driver */

typedef struct drv {
    const dth_run_config *cfg;
    dth_run_state *st;
    dth_integrator *it;
    const dth_model *model;
    size_t n, N;
    double dir;
    int wp_fixed;         /* the method carries wp unchanged (a baseline): its flow is 0 */
    double *za, *zb, *zm; /* the last step's vertices and midpoint */
    double *ua, *ub;      /* flows at za, zb */
    int dense5;           /* order 4: the quintic Hermite, with aa, ab = J H_zz u at za, zb (dense.c) */
    int order4;           /* order 4: its band steps arm the stop rule (runaway) */
    double *aa, *ab, *work5;
    double *zi, *zr;      /* scratch points */
    double *work;         /* 2n+1 */
    double *ga, *gb;      /* event functions at za, zb */
    double *glo, *ghi, *tev;
    int *dev;
    int ua_ok, ub_ok, use_mid, have_seg;
    dth_step_info seg;    /* the step za -> zb */
    long kseg;            /* index of za */
    int cb_failed;        /* a sample or checkpoint callback failed: no final checkpoint */
    int too_many;         /* a step held more than DTH_RUN_MAX_SAMPLES_PER_STEP output times */
    int cb;               /* the status in hand came from a sample, event or checkpoint callback */
    int lo_closed;        /* the first segment's window includes its lower end (a fresh run) */
    int ended_by;         /* dth_run_stop of the loop's end */
    int stop_event;       /* the terminal event that ended it, -1: none */
    double t_stop;        /* its time, NaN: none */
} drv;

static void vertex_now(drv *d, double *z) { memcpy(z, dth_integrator_vertex(d->it), d->N * sizeof *z); }

static int flow(drv *d, const double *z, double *u)
{
    int rc = dth_flow(d->model, z, u, d->work);
    if (!rc && d->wp_fixed) u[d->N - 1] = 0; /* a baseline carries wp unchanged */
    return rc;
}

/* Make sure the flows at both ends of the current segment are known. */
static int seg_flows(drv *d)
{
    int rc = DTH_OK;
    if (d->dense5) {
        if (!d->ua_ok && (rc = dth__flow2(d->model, d->za, d->ua, d->aa, d->work5)) == DTH_OK) d->ua_ok = 1;
        if (!rc && !d->ub_ok && (rc = dth__flow2(d->model, d->zb, d->ub, d->ab, d->work5)) == DTH_OK) d->ub_ok = 1;
        return rc;
    }
    if (!d->ua_ok && (rc = flow(d, d->za, d->ua)) == DTH_OK) d->ua_ok = 1;
    if (!rc && !d->ub_ok && (rc = flow(d, d->zb, d->ub)) == DTH_OK) d->ub_ok = 1;
    return rc;
}

static void dense(drv *d, double t, double *z)
{
    if (d->dense5) dth__dense_eval5(d->n, d->za, d->zb, d->ua, d->ub, d->aa, d->ab, t, z);
    else dth_dense_eval(d->n, d->za, d->zb, d->use_mid ? d->zm : NULL, d->ua, d->ub, t, z);
}

/* The estimated error at the sample's point (NaN without an estimate). */
static void sample_err(drv *d, dth_sample *s)
{
    if (dth_integrator_error_at(d->it, s->z, &s->err_q, &s->err_p) != DTH_OK) s->err_q = s->err_p = NAN;
}

static int emit(drv *d, dth_sample *s)
{
    if (!d->cfg->sample) return 0;
    sample_err(d, s);
    s->index = d->st->samples++;
    int rc = d->cfg->sample(d->cfg->user, s);
    if (rc) d->cb_failed = 1;
    return rc;
}

static int ev_eval(drv *d, size_t e, const double *z, double *g)
{
    const dth_event *ev = &d->cfg->events[e];
    int rc = ev->g(ev->user, d->n, z, g);
    if (rc) d->cb_failed = 1;
    return rc;
}

/* dir-aware comparisons of times */
static int before(const drv *d, double a, double b) { return d->dir * (a - b) < 0; }

/*
 * Locate the zero of event e on the segment between times lo and hi where g goes from glo to
 * ghi (signs differ, or ghi == 0): bracketing with Illinois steps, bisection when they stall,
 * until lo and hi are adjacent doubles. The crossing time (the side where g has crossed) goes to
 * *t.
 */
static int locate(drv *d, size_t e, double lo, double glo, double hi, double ghi, double *t)
{
    int side = 0, rc;
    for (int it = 0; it < 400 && ghi != 0; it++) {
        if (nextafter(lo, hi) == hi) break;
        double c = (it % 4 == 3) ? lo + 0.5 * (hi - lo) : (lo * ghi - hi * glo) / (ghi - glo);
        if (!(d->dir * (c - lo) > 0 && d->dir * (hi - c) > 0)) c = lo + 0.5 * (hi - lo);
        if (!(d->dir * (c - lo) > 0 && d->dir * (hi - c) > 0)) break;
        dense(d, c, d->zr);
        double gc;
        if ((rc = ev_eval(d, e, d->zr, &gc)) != 0) return rc;
        if (gc == 0) {
            hi = c;
            break;
        }
        if ((gc > 0) == (ghi > 0)) {
            hi = c;
            ghi = gc;
            if (side == -1) glo *= 0.5;
            side = -1;
        } else {
            lo = c;
            glo = gc;
            if (side == 1) ghi *= 0.5;
            side = 1;
        }
    }
    *t = hi;
    return DTH_OK;
}

/* Does a sign change from a to b count for this event? */
static int crosses(const dth_event *ev, double a, double b, int *direction)
{
    int up = a < 0 && b >= 0, down = a > 0 && b <= 0;
    *direction = up ? 1 : down ? -1 : 0;
    if (!up && !down) return 0;
    return ev->direction == 0 || ev->direction == *direction;
}

/*
 * Hand out everything the segment za -> zb holds in the time window (lo, hi]: events, the
 * pending vertex za, its midpoint, output times. *stop_t gets the time of a terminal event (and
 * *stop_e its index), else stays NAN. `final`: the segment is the last one (hi may cut it).
 */
static int segment(drv *d, double lo, double hi, int lo_closed, double *stop_t, int *stop_e)
{
    const dth_run_config *cfg = d->cfg;
    dth_run_state *st = d->st;
    size_t n = d->n;
    int rc;
    double ta = d->za[n], tb = d->zb[n];
    *stop_t = NAN;
    *stop_e = -1;
    /* ---- events: the first terminal one cuts the window */
    if (cfg->nevents && before(d, lo, hi)) {
        int need_dense = 0;
        for (size_t e = 0; e < cfg->nevents; e++) {
            d->glo[e] = d->ga[e];
            d->ghi[e] = d->gb[e];
            d->tev[e] = NAN;
        }
        if (lo != ta || hi != tb) need_dense = 1;
        /* a sign change anywhere on the segment's vertices, or a window that cuts it */
        int any = 0;
        for (size_t e = 0; e < cfg->nevents; e++)
            if ((d->ga[e] < 0) != (d->gb[e] < 0) || (d->ga[e] > 0) != (d->gb[e] > 0)) any = 1;
        if (any || need_dense) {
            if ((rc = seg_flows(d)) != 0) return rc;
            if (lo != ta) {
                dense(d, lo, d->zi);
                for (size_t e = 0; e < cfg->nevents; e++)
                    if ((rc = ev_eval(d, e, d->zi, &d->glo[e])) != 0) return rc;
            }
            if (hi != tb) {
                dense(d, hi, d->zi);
                for (size_t e = 0; e < cfg->nevents; e++)
                    if ((rc = ev_eval(d, e, d->zi, &d->ghi[e])) != 0) return rc;
            }
            for (size_t e = 0; e < cfg->nevents; e++) {
                int dirn;
                if (!crosses(&cfg->events[e], d->glo[e], d->ghi[e], &dirn)) continue;
                if ((rc = locate(d, e, lo, d->glo[e], hi, d->ghi[e], &d->tev[e])) != 0) return rc;
                d->dev[e] = dirn;
            }
            /* hand them out in time order; a terminal one ends the window */
            for (;;) {
                long best = -1;
                for (size_t e = 0; e < cfg->nevents; e++)
                    if (!isnan(d->tev[e]) && (best < 0 || before(d, d->tev[e], d->tev[best]))) best = (long)e;
                if (best < 0) break;
                double te = d->tev[best];
                d->tev[best] = NAN;
                if (!isnan(*stop_t) && before(d, *stop_t, te)) continue;
                dense(d, te, d->zi);
                dth_sample s = {DTH_SAMPLE_EVENT, st->events++, d->kseg, d->zi, &d->seg, 0, d->za, d->zb, (int)best,
                                d->dev[best], NAN, NAN};
                if (cfg->on_event) {
                    sample_err(d, &s);
                    if ((rc = cfg->on_event(cfg->user, &s)) != 0) {
                        d->cb_failed = 1;
                        return rc;
                    }
                }
                if (cfg->events[best].terminal && isnan(*stop_t)) {
                    *stop_t = te;
                    *stop_e = (int)best;
                }
            }
        }
    }
    double top = isnan(*stop_t) ? hi : *stop_t;
    /* ---- the pending vertex za (its outgoing step is now known) */
    if (cfg->points == DTH_POINTS_VERTICES && st->pending) {
        if ((d->kseg - st->k0) % cfg->every == 0) {
            dth_sample s = {DTH_SAMPLE_VERTEX, 0, d->kseg, d->za, &st->in, d->seg.lambda, NULL, NULL, -1, 0, NAN, NAN};
            if ((rc = emit(d, &s)) != 0) return rc;
        }
        st->pending = 0;
    }
    /* ---- the midpoint */
    if (cfg->points == DTH_POINTS_MIDPOINTS && d->use_mid && (d->kseg - st->k0) % cfg->every == 0) {
        double tm = d->zm[n];
        if (!before(d, top, tm) && (lo_closed ? !before(d, tm, lo) : before(d, lo, tm))) {
            dth_sample s = {DTH_SAMPLE_MIDPOINT, 0, d->kseg, d->zm, &d->seg, 0, d->za, d->zb, -1, 0, NAN, NAN};
            if ((rc = emit(d, &s)) != 0) return rc;
        }
    }
    /* ---- output times up to the top of the window */
    if (cfg->points == DTH_POINTS_TIMES) {
        for (long count = 0;; count++) {
            if (count >= DTH_RUN_MAX_SAMPLES_PER_STEP) { /* run.h: a step holds too many */
                d->too_many = 1;
                return DTH_EINVAL;
            }
            double t;
            if (cfg->times) {
                if ((size_t)st->j >= cfg->ntimes) break;
                t = cfg->times[st->j];
            } else {
                t = st->t_first + d->dir * (double)st->j * cfg->dt;
            }
            if (before(d, top, t)) break;
            if (before(d, t, ta)) { /* behind the segment: only an unordered list gets here */
                st->j++;
                continue;
            }
            if ((rc = seg_flows(d)) != 0) return rc;
            dense(d, t, d->zi);
            dth_sample s = {DTH_SAMPLE_TIME, 0, d->kseg, d->zi, &d->seg, 0, d->za, d->zb, -1, 0, NAN, NAN};
            st->j++;
            if ((rc = emit(d, &s)) != 0) return rc;
        }
    }
    return DTH_OK;
}

static void account(dth_run_state *st, const dth_step_info *s)
{
    int cross = (s->flags & DTH_STEP_CROSSING) != 0;
    if (cross) st->crossings++;
    if (s->flags & DTH_STEP_REGULARIZED) st->regularized++;
    if (s->flags & DTH_STEP_NONREVERSIBLE) st->nonreversible++;
    if ((cross || st->prev_crossing) && st->in.lambda != 0 && s->lambda != 0) {
        double q = fabs(s->lambda / st->in.lambda);
        st->max_ratio = fmax(st->max_ratio, fmax(q, 1 / q));
    }
    st->prev_crossing = cross;
}

/* The new vertex's share of the run's statistics: the largest step and |q|, |p|, and the error
 * estimate there. */
static void account_vertex(drv *d, const dth_step_info *s)
{
    dth_run_state *st = d->st;
    size_t n = d->n;
    double a = 0, b = 0;
    for (size_t i = 0; i < n; i++) {
        a += d->zb[i] * d->zb[i];
        b += d->zb[n + 1 + i] * d->zb[n + 1 + i];
    }
    st->q_max = fmax(st->q_max, sqrt(a));
    st->p_max = fmax(st->p_max, sqrt(b));
    if (s && fabs(s->lambda) > st->lam_max) {
        st->lam_max = fabs(s->lambda);
        st->t_lam_max = d->zb[n];
    }
    if (dth_integrator_error(d->it, &st->err_q, &st->err_p) != DTH_OK) st->err_q = st->err_p = NAN;
    if (d->wp_fixed && d->cfg->stop_error > 0) { /* a baseline: its energy error (wp = -H_phys(z_0)) */
        double H;
        if (dth_model_eval(d->model, d->zb, DTH_EVAL_H | DTH_EVAL_GRAD, &H, d->zr, NULL) != DTH_OK) return;
        st->e_err = fabs(d->zb[d->N - 1] + H);
        if (!s) {
            double sc = fabs(H);
            for (size_t j = 0; j + 1 < d->N; j++)
                if (j != n) sc += fabs(d->zb[j] * d->zr[j]);
            st->e_scale = sc;
        }
    }
}

/* run.h; the one rule dth run's warning reads too */
double dth_run_step_limit(const dth_integrator *it, double step_ratio)
{
    if (!it) return NAN;
    if (!(step_ratio > 0)) return INFINITY;
    const char *m = dth_integrator_method(it);
    int order4 = m && !strcmp(m, "dth") && dth_integrator_order(it) == 4;
    return (order4 ? pow(step_ratio, 1.5) : step_ratio) * fabs(dth__integrator_h(it));
}

/* The stop rule of the error estimate (dth_run_config.stop_error): the steps ran away from h and
 * the error is a sizeable part of the orbit; or a fixed-step baseline's energy error is (its own
 * estimate cannot see it: the shadow takes the same steps with a method of the same kind). Order 4's
 * band steps (prescribed-step compositions around psi = 0) are not solved for either: a run they
 * carried (more than half of at least 10 steps) arms the rule as run-away steps do (Kepler e = 0.9
 * from its pericentre at h = 0.01: the band never exits, steps near h, the error orbit-sized). */
static int runaway(const drv *d)
{
    const dth_run_state *st = d->st;
    double f = d->cfg->stop_error;
    if (!(f > 0)) return 0;
    if (d->wp_fixed) return st->e_err > f * st->e_scale;
    int banded = d->order4 && st->k >= 10 && 2 * st->regularized > st->k;
    return d->cfg->step_ratio > 0 && (st->lam_max > dth_run_step_limit(d->it, d->cfg->step_ratio) || banded) &&
           (st->err_q > f * st->q_max || st->err_p > f * st->p_max);
}

/* The local error estimate of the segment za -> zb: the defect of its cubic Hermite interpolant at
 * the middle, (2/3) lambda |P'(1/2) - f(P(1/2))| over q (3 flows: both ends' and the middle's). */
static int local_error(drv *d, double *lerr)
{
    size_t n = d->n, N = d->N;
    int rc = seg_flows(d);
    if (rc) return rc;
    double h = d->zb[n] - d->za[n], *pm = d->zi, *um = d->zr;
    for (size_t j = 0; j < N; j++) pm[j] = 0.5 * (d->za[j] + d->zb[j]) + h * (d->ua[j] - d->ub[j]) / 8;
    if ((rc = flow(d, pm, um)) != 0) return rc;
    double s = 0;
    for (size_t i = 0; i < n; i++) {
        double dp = 1.5 * (d->zb[i] - d->za[i]) / h - 0.25 * (d->ua[i] + d->ub[i]) - um[i];
        s += dp * dp;
    }
    *lerr = (2.0 / 3.0) * fabs(h) * sqrt(s);
    return DTH_OK;
}

static void swap(double **a, double **b)
{
    double *t = *a;
    *a = *b;
    *b = t;
}

/* Make za -> zb (the step `info` leaving vertex k, with midpoint mid, NULL if none) the current
 * segment. Returns the top of its window: zb's time, or t_end if that comes first. */
static double open_segment(drv *d, const dth_step_info *info, long k, const double *mid)
{
    d->use_mid = mid != NULL;
    if (mid) memcpy(d->zm, mid, d->N * sizeof *d->zm);
    d->seg = *info;
    d->kseg = k;
    d->have_seg = 1;
    double hi = d->zb[d->n];
    return d->cfg->has_t_end && before(d, d->cfg->t_end, hi) ? d->cfg->t_end : hi;
}

/* The start of a call: the run's first vertex (a fresh state), the events there, and for a resumed
 * run whose last segment was cut (by t_end or a terminal event) the rest of that segment, rebuilt from
 * the midpoint (round-off of z_(k-1) = 2 zbar - z_k). A callback's failure sets d->cb. */
static int drive_begin(drv *d)
{
    const dth_run_config *cfg = d->cfg;
    dth_run_state *st = d->st;
    size_t n = d->n, N = d->N;
    int rc = DTH_OK;
    vertex_now(d, d->zb);
    if (!st->started) {
        memset(st, 0, sizeof *st);
        st->started = 1;
        st->pending = 1;
        st->t_first = isnan(cfg->t0) ? d->zb[n] : cfg->t0;
        if (cfg->times)
            while ((size_t)st->j < cfg->ntimes && before(d, cfg->times[st->j], st->t_first)) st->j++;
        st->t_stop = st->t_first; /* the window of reported times starts here (inclusive) */
        account_vertex(d, NULL);
    }
    st->t = d->zb[n];
    st->stop = DTH_RUN_RUNNING;
    d->lo_closed = st->samples == 0 && st->events == 0 && st->k == 0;
    d->cb = 1;
    for (size_t e = 0; e < cfg->nevents; e++)
        if ((rc = ev_eval(d, e, d->zb, &d->gb[e])) != 0) return rc;
    /* a resumed run whose last segment was cut (by t_end or a terminal event): the rest of it, on the
     * segment rebuilt from the midpoint (round-off of z_(k-1) = 2 zbar - z_k), or from the vertex
     * before (order 4 keeps it) */
    const double *mid = dth_integrator_midpoint(d->it), *prev = dth__integrator_prev_vertex(d->it);
    if ((mid || prev) && st->k > 0 && before(d, st->t_stop, st->t)) {
        for (size_t j = 0; j < N; j++) d->za[j] = prev ? prev[j] : 2 * mid[j] - d->zb[j];
        d->ua_ok = d->ub_ok = 0;
        double hi = open_segment(d, &st->in, st->k - 1, mid), stop_t;
        for (size_t e = 0; e < cfg->nevents; e++)
            if ((rc = ev_eval(d, e, d->za, &d->ga[e])) != 0) return rc;
        int pend = st->pending, stop_e;
        st->pending = 0; /* za's own sample went out before */
        if (before(d, st->t_stop, hi) && (rc = segment(d, st->t_stop, hi, 0, &stop_t, &stop_e)) != 0) return rc;
        st->pending = pend;
        st->t_stop = hi;
    }
    d->cb = 0;
    return DTH_OK;
}

/* One step and its segment's samples and events. 0: go on (d->ended_by = DTH_RUN_EVENT: a terminal
 * event ended the run); else the step's status (d->ended_by says why), or a callback's (d->cb). */
static int drive_step(drv *d)
{
    const dth_run_config *cfg = d->cfg;
    dth_run_state *st = d->st;
    dth_step_info info;
    int rc = dth_integrator_step(d->it, &info);
    if (rc) {
        d->ended_by = DTH_RUN_FAILED;
        return rc;
    }
    account(st, &info);
    /* the new segment: za <- zb, zb <- the new vertex */
    swap(&d->za, &d->zb);
    swap(&d->ua, &d->ub);
    swap(&d->aa, &d->ab);
    swap(&d->ga, &d->gb);
    d->ua_ok = d->ub_ok;
    d->ub_ok = 0;
    vertex_now(d, d->zb);
    /* a regularizer's segment has its midpoint too (z_k + d) */
    double hi = open_segment(d, &info, st->k, dth_integrator_midpoint(d->it));
    if (cfg->local_error && local_error(d, &info.lerr) == DTH_OK) d->seg.lerr = info.lerr;
    account_vertex(d, &info);
    d->cb = 1;
    for (size_t e = 0; e < cfg->nevents; e++)
        if ((rc = ev_eval(d, e, d->zb, &d->gb[e])) != 0) return rc;
    rc = segment(d, st->t_stop, hi, d->lo_closed, &d->t_stop, &d->stop_event);
    d->lo_closed = 0;
    /* the step is taken whatever the samples said: the state moves on */
    st->in = info;
    st->k++;
    st->t = d->zb[d->n];
    st->pending = 1;
    st->t_stop = isnan(d->t_stop) ? hi : d->t_stop;
    if (rc) return rc;
    d->cb = 0;
    if (!isnan(d->t_stop)) {
        d->ended_by = DTH_RUN_EVENT; /* a terminal event: the loop's end */
        return DTH_OK;
    }
    if (cfg->step_max > 0 && fabs(info.lambda) > cfg->step_max) { /* run.h: the step bound */
        d->ended_by = DTH_RUN_FAILED;
        return DTH_ESTEPSIZE;
    }
    if (runaway(d)) {
        d->ended_by = DTH_RUN_FAILED;
        return DTH_EACCURACY;
    }
    return DTH_OK;
}

/* The steps until the run's end, a stop request, a failed step or a terminal event (d->ended_by);
 * checkpoints and progress between them. */
static int drive_steps(drv *d)
{
    const dth_run_config *cfg = d->cfg;
    dth_run_state *st = d->st;
    long since_ckpt = 0, since_prog = 0;
    d->ended_by = DTH_RUN_END;
    d->stop_event = -1;
    d->t_stop = NAN;
    for (;;) {
        int done = cfg->has_t_end ? !before(d, st->t, cfg->t_end) : st->k >= cfg->steps;
        if (done) return DTH_OK;
        if (cfg->checkpoint && cfg->checkpoint_every > 0 && since_ckpt >= cfg->checkpoint_every) {
            int rc = cfg->checkpoint(cfg->user, st);
            if (rc) {
                d->cb_failed = d->cb = 1;
                return rc;
            }
            since_ckpt = 0;
        }
        if (cfg->progress && cfg->progress_every > 0 && since_prog >= cfg->progress_every) {
            since_prog = 0;
            int rc = cfg->progress(cfg->user, st);
            if (rc) {
                d->ended_by = DTH_RUN_CALLBACK;
                return rc;
            }
        }
        int rc = drive_step(d);
        if (rc || d->ended_by == DTH_RUN_EVENT) return rc;
        since_ckpt++;
        since_prog++;
    }
}

/* The end of a call: the final checkpoint (the integrator at its vertex, whose sample is still
 * pending), and the last sample (the vertex where a step failed, or the end sample). */
static int drive_end(drv *d, int step_rc)
{
    const dth_run_config *cfg = d->cfg;
    dth_run_state *st = d->st;
    int rc;
    d->cb = 1;
    if (cfg->checkpoint && (rc = cfg->checkpoint(cfg->user, st)) != 0) {
        d->cb_failed = 1;
        return rc;
    }
    if (step_rc) {
        st->stop = d->ended_by;
        if (cfg->points == DTH_POINTS_VERTICES && st->pending) {
            dth_sample s = {DTH_SAMPLE_END, 0, st->k, d->zb, &st->in, 0, NULL, NULL, -1, 0, NAN, NAN};
            st->pending = 0;
            st->t_stop = st->t;
            if ((rc = emit(d, &s)) != 0) return rc;
        }
        d->cb = 0;
        return step_rc;
    }
    int end_sample = cfg->points == DTH_POINTS_VERTICES ||
                     (cfg->points == DTH_POINTS_TIMES && (cfg->has_t_end || d->ended_by == DTH_RUN_EVENT));
    st->t_stop = d->ended_by == DTH_RUN_EVENT ? d->t_stop : cfg->has_t_end ? cfg->t_end : st->t;
    if (end_sample) {
        double te = st->t_stop;
        dth_sample s = {DTH_SAMPLE_END, 0, st->k, d->zb, &st->in, 0, NULL, NULL, d->stop_event, 0, NAN, NAN};
        int already = cfg->points == DTH_POINTS_TIMES && st->samples > 0 && st->j > 0 &&
                      (cfg->times ? cfg->times[st->j - 1] : st->t_first + d->dir * (double)(st->j - 1) * cfg->dt) == te;
        if (te != st->t) {
            if (!d->have_seg) { /* nothing to interpolate on (cannot happen after a step) */
                already = 1;
            } else {
                if ((rc = seg_flows(d)) != 0) return rc;
                dense(d, te, d->zi);
                s.z = d->zi;
                s.step = &d->seg;
                s.za = d->za;
                s.zb = d->zb;
            }
        } else {
            st->pending = 0; /* the end is the vertex itself */
        }
        if (!already && (rc = emit(d, &s)) != 0) return rc;
    }
    st->stop = d->ended_by;
    d->cb = 0;
    return DTH_OK;
}

static int drive(drv *d)
{
    int rc = drive_begin(d);
    if (!rc) rc = drive_steps(d);
    if (!d->cb) rc = drive_end(d, rc);
    if (rc && d->cb) d->st->stop = d->too_many ? DTH_RUN_SAMPLES : DTH_RUN_CALLBACK;
    return rc;
}

int dth_run(dth_integrator *it, const dth_run_config *cfg, dth_run_state *st)
{
    int rc = dth_run_check(it, cfg, st, NULL, 0); /* every rule on cfg (run_check.c) */
    if (rc) return rc;
    drv d;
    memset(&d, 0, sizeof d);
    d.cfg = cfg;
    d.st = st;
    d.it = it;
    d.model = dth_integrator_model(it);
    d.wp_fixed = dth__integrator_wp_fixed(it);
    d.n = dth_model_dof(d.model);
    d.N = 2 * d.n + 2;
    size_t N = d.N, ne = cfg->nevents;
    d.dir = dth_integrator_direction(it);
    d.dense5 = dth__integrator_dense5(it);
    d.order4 = dth_integrator_order(it) == 4 && !d.wp_fixed;
    size_t n5 = d.dense5 ? 2 * N + dth__flow2_work_size(d.model) : 0;
    size_t nd = 7 * N + (2 * d.n + 1) + 5 * ne + 1 + n5;
    double *blk = dth_calloc(cfg->alloc, nd, sizeof *blk);
    int *dev = dth_calloc(cfg->alloc, ne + 1, sizeof *dev);
    if (!blk || !dev) {
        dth_free(cfg->alloc, blk);
        dth_free(cfg->alloc, dev);
        return DTH_ENOMEM;
    }
    double *p = blk;
    d.za = p, p += N;
    d.zb = p, p += N;
    d.zm = p, p += N;
    d.ua = p, p += N;
    d.ub = p, p += N;
    d.zi = p, p += N;
    d.zr = p, p += N;
    d.work = p, p += 2 * d.n + 1;
    d.ga = p, p += ne;
    d.gb = p, p += ne;
    d.glo = p, p += ne;
    d.ghi = p, p += ne;
    d.tev = p, p += ne + 1;
    if (d.dense5) {
        d.aa = p, p += N;
        d.ab = p, p += N;
        d.work5 = p;
    }
    d.dev = dev;
    rc = drive(&d);
    dth_free(cfg->alloc, blk);
    dth_free(cfg->alloc, dev);
    return rc;
}
