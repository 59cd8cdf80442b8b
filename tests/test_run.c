/* SPDX-License-Identifier: MIT */
/*
 * The run driver (run.h): dense output reproduces polynomials of its degree and converges at the
 * method's order 2 at fixed times against exact solutions (harmonic, pendulum, Kepler); events
 * are located to round-off and Kepler's pericentre passages land on the exact times; t_end is
 * hit exactly; midpoint samples hold the energy exactly (paper, Theorem "DTH Equations"); a run
 * cut by a checkpoint continues bit for bit; separate integrators in two threads give the same
 * bits as one after the other.
 */
#include <float.h>
#include <math.h>
#include <pthread.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include "cu_main.h"
#include "dth/dth.h"
#include "test_util.h"

#define PI 3.14159265358979323846
#define MAXS 40000

/* ------------------------------------------------------------------ a recorder of samples */

typedef struct rec {
    size_t N;
    long ns;
    double *z;   /* ns * N */
    int *kind;
    long *k;
    long ne;
    double *ze;  /* events */
    int *edir, *eidx;
} rec;

static void rec_init(rec *r, size_t N)
{
    memset(r, 0, sizeof *r);
    r->N = N;
    r->z = calloc((size_t)MAXS * N, sizeof *r->z);
    r->kind = calloc(MAXS, sizeof *r->kind);
    r->k = calloc(MAXS, sizeof *r->k);
    r->ze = calloc((size_t)MAXS * N, sizeof *r->ze);
    r->edir = calloc(MAXS, sizeof *r->edir);
    r->eidx = calloc(MAXS, sizeof *r->eidx);
}

static void rec_free(rec *r)
{
    free(r->z);
    free(r->kind);
    free(r->k);
    free(r->ze);
    free(r->edir);
    free(r->eidx);
}

/* Record s as the next sample (event = 0) or the next event (1). */
static int push(rec *r, int event, const dth_sample *s)
{
    long *i = event ? &r->ne : &r->ns;
    if (*i >= MAXS) return DTH_ENOMEM;
    memcpy((event ? r->ze : r->z) + (size_t)*i * r->N, s->z, r->N * sizeof *r->z);
    if (event) r->edir[*i] = s->direction, r->eidx[*i] = s->event;
    else r->kind[*i] = s->kind, r->k[*i] = s->k;
    ++*i;
    return 0;
}

static int on_sample(void *user, const dth_sample *s) { return push(user, 0, s); }
static int on_event(void *user, const dth_sample *s) { return push(user, 1, s); }

/* A run from t0 = 0 to t_end (steps = 0) or to vertex `steps`, its samples and events recorded in r. */
static dth_run_config config(double t_end, long steps, rec *r)
{
    dth_run_config c;
    dth_run_config_default(&c);
    c.has_t_end = steps == 0;
    c.t_end = steps == 0 ? t_end : 0;
    c.steps = steps;
    c.t0 = 0;
    c.sample = on_sample;
    c.on_event = on_event;
    c.user = r;
    return c;
}

/* Run `it` as c says from a fresh loop state (st). */
static void run(dth_integrator *it, const dth_run_config *c, dth_run_state *st)
{
    dth_run_state_init(st);
    CU_ASSERT_FATAL(dth_run(it, c, st) == DTH_OK);
}

static dth_integrator *start(const dth_model *m, double h, dth_start mode, const double *q0, const double *p0, double t0)
{
    dth_options o;
    dth_options_default(&o);
    o.h = h;
    o.start = mode;
    dth_integrator *it = NULL;
    CU_ASSERT_FATAL(dth_integrator_new(m, &o, &it) == DTH_OK);
    CU_ASSERT_FATAL(dth_integrator_start(it, q0, p0, t0) == DTH_OK);
    return it;
}

/* ------------------------------------------------------------------ dense output alone */

/* The cubic form reproduces cubics, the quartic form (with the midpoint) quartics, exactly up
 * to round-off: the interpolation conditions determine them. */
static void test_dense_polynomials(void)
{
    size_t n = 1, N = 4;
    double ta = 0.3, tb = 0.3 + 0.7;
    double c[N][5];
    for (size_t j = 0; j < N; j++)
        for (int i = 0; i < 5; i++) c[j][i] = sin(1.0 + (double)(7 * j + i)); /* arbitrary coefficients */
    for (int deg = 3; deg <= 4; deg++) {
        double za[4], zb[4], zm[4], ua[4], ub[4], z[4], tm = 0.5 * (ta + tb);
        for (size_t j = 0; j < N; j++) {
            double pa = 0, pb = 0, pm = 0, da = 0, db = 0;
            for (int i = deg; i >= 0; i--) {
                pa = pa * ta + c[j][i];
                pb = pb * tb + c[j][i];
                pm = pm * tm + c[j][i];
            }
            for (int i = deg; i >= 1; i--) {
                da = da * ta + i * c[j][i];
                db = db * tb + i * c[j][i];
            }
            za[j] = pa, zb[j] = pb, zm[j] = pm, ua[j] = da, ub[j] = db;
        }
        za[n] = ta, zb[n] = tb, zm[n] = tm, ua[n] = ub[n] = 1;
        double worst = 0;
        for (int s = 0; s <= 20; s++) {
            double t = ta + (tb - ta) * s / 20.0;
            dth_dense_eval(n, za, zb, deg == 4 ? zm : NULL, ua, ub, t, z);
            CU_ASSERT(z[n] == t);
            for (size_t j = 0; j < N; j++) {
                if (j == n) continue;
                double p = 0;
                for (int i = deg; i >= 0; i--) p = p * t + c[j][i];
                worst = fmax(worst, fabs(z[j] - p));
            }
        }
        CU_ASSERT(worst < 1e-14);
        /* the cubic form does not reproduce a quartic: the test can fail */
        if (deg == 4) {
            dth_dense_eval(n, za, zb, NULL, ua, ub, 0.3 + 0.7 * 0.37, z);
            double p = 0, t = 0.3 + 0.7 * 0.37;
            for (int i = 4; i >= 0; i--) p = p * t + c[0][i];
            CU_ASSERT(fabs(z[0] - p) > 1e-6);
        }
        /* nodes come back bit for bit */
        dth_dense_eval(n, za, zb, zm, ua, ub, ta, z);
        CU_ASSERT(memcmp(z, za, sizeof za) == 0);
        dth_dense_eval(n, za, zb, zm, ua, ub, tb, z);
        CU_ASSERT(memcmp(z, zb, sizeof zb) == 0);
        dth_dense_eval(n, za, zb, zm, ua, ub, tm, z);
        CU_ASSERT(memcmp(z, zm, sizeof zm) == 0);
    }
}

/* ------------------------------------------------------------------ convergence at fixed times */

/* Max error over the output times of the dense output of a run with step h, against the exact
 * solution from the initial condition (a midpoint start: (q0, t0, p0) is the first midpoint). */
static double dense_error(const dth_model *m, const double *q0, const double *p0, double h, const double *times,
                          size_t nt)
{
    size_t n = dth_model_dof(m), N = 2 * n + 2;
    dth_integrator *it = start(m, h, DTH_START_MIDPOINT, q0, p0, 0);
    rec r;
    rec_init(&r, N);
    dth_run_config c = config(times[nt - 1], 0, &r);
    c.points = DTH_POINTS_TIMES;
    c.times = times;
    c.ntimes = nt;
    dth_run_state st;
    run(it, &c, &st);
    CU_ASSERT(r.ns == (long)nt);
    double y0[2 * 3 + 1], y[2 * 3 + 1], err = 0;
    memcpy(y0, q0, n * sizeof *y0);
    y0[n] = 0;
    memcpy(y0 + n + 1, p0, n * sizeof *y0);
    for (long s = 0; s < r.ns && s < (long)nt; s++) {
        const double *z = r.z + (size_t)s * N;
        CU_ASSERT(z[n] == times[s]);
        CU_ASSERT_FATAL(dth_model_exact(m, y0, times[s], y) == DTH_OK);
        for (size_t j = 0; j < 2 * n + 1; j++)
            if (j != n) err = fmax(err, fabs(z[j] - y[j]));
    }
    rec_free(&r);
    dth_integrator_free(it);
    return err;
}

static void check_order(const char *name, const dth_model *m, const double *q0, const double *p0, double h,
                        const double *times, size_t nt)
{
    double e[3];
    for (int i = 0; i < 3; i++) e[i] = dense_error(m, q0, p0, h / (1 << i), times, nt);
    if (getenv("DTH_ORDER_SCAN"))
        for (int i = 0; i < 8; i++) printf("    h = %g: %.4e\n", h / (1 << i), dense_error(m, q0, p0, h / (1 << i), times, nt));
    double o1 = log2(e[0] / e[1]), o2 = log2(e[1] / e[2]);
    printf("  %s: dense output error at fixed times %.3e %.3e %.3e (h = %g / 1, 2, 4): order %.3f %.3f\n", name,
           e[0], e[1], e[2], h, o1, o2);
    CU_ASSERT(o1 > 1.85 && o1 < 2.15);
    CU_ASSERT(o2 > 1.85 && o2 < 2.15);
}

static void test_dense_order(void)
{
    /* times off any step grid, the last one is t_end */
    static const double th[] = {0.0, 0.3731, 1.9123, 4.4047, 7.7777, 10.0};
    dth_model *mh = model(&dth_model_harmonic, &(dth_kv){"omega", "1.3"}, 1, 1);
    double q[3] = {0.8}, p[3] = {-0.25};
    check_order("harmonic", mh, q, p, 0.02, th, 6);
    dth_model_free(mh);
    dth_model *mp = model(&dth_model_pendulum, NULL, 0, 1);
    q[0] = 1.5, p[0] = 0;
    check_order("pendulum", mp, q, p, 0.01, th, 6);
    dth_model_free(mp);
    /* Kepler e = 0.6 from pericentre, over one orbit */
    dth_model *mk = model(&dth_model_kepler, NULL, 0, 2);
    double qk[2] = {0.4, 0}, pk[2] = {0, 2};
    static const double tk[] = {0.0, 0.51, 1.7, 3.14, 4.9, 6.0};
    check_order("kepler e=0.6", mk, qk, pk, 0.00125, tk, 6);
    dth_model_free(mk);
}

/* ------------------------------------------------------------------ t_end, nodes */

static void test_exact_end(void)
{
    dth_model *m = model(&dth_model_pendulum, NULL, 0, 1);
    double q0 = 1, p0 = 0;
    for (int d = 0; d < 2; d++) {
        double h = d ? -0.05 : 0.05, t_end = d ? -3.21 : 7.654321;
        dth_integrator *it = start(m, h, DTH_START_MIDPOINT, &q0, &p0, 0);
        rec r;
        rec_init(&r, 4);
        dth_run_config c = config(t_end, 0, &r);
        dth_run_state st;
        run(it, &c, &st);
        CU_ASSERT(st.stop == DTH_RUN_END);
        /* every vertex before t_end, then the end at exactly t_end */
        CU_ASSERT(r.kind[r.ns - 1] == DTH_SAMPLE_END);
        CU_ASSERT(r.z[(size_t)(r.ns - 1) * 4 + 1] == t_end);
        CU_ASSERT(r.ns == st.k + 1);
        for (long s = 0; s + 1 < r.ns; s++) {
            CU_ASSERT(r.kind[s] == DTH_SAMPLE_VERTEX && r.k[s] == s);
            CU_ASSERT(h * (r.z[(size_t)s * 4 + 1] - t_end) < 0);
        }
        /* the integrator stays at the first vertex beyond t_end */
        CU_ASSERT(h * (dth_integrator_vertex(it)[1] - t_end) > 0);
        rec_free(&r);
        dth_integrator_free(it);
    }
    /* the output time t0 of a midpoint start is the initial condition, bit for bit */
    dth_integrator *it = start(m, 0.05, DTH_START_MIDPOINT, &q0, &p0, 0);
    rec r;
    rec_init(&r, 4);
    dth_run_config c = config(0, 3, &r);
    c.points = DTH_POINTS_TIMES;
    c.dt = 0.03;
    dth_run_state st;
    run(it, &c, &st);
    CU_ASSERT(r.ns == 5); /* 0, 0.03, ..., 0.12 <= t_3 = 0.125 */
    CU_ASSERT(r.z[0] == 1 && r.z[1] == 0 && r.z[2] == 0);
    rec_free(&r);
    dth_integrator_free(it);
    dth_model_free(m);
}

/* ------------------------------------------------------------------ midpoints: exact energy */

static void midpoint_energy(const char *name, const dth_model *m, const double *q0, const double *p0, double h)
{
    size_t n = dth_model_dof(m), N = 2 * n + 2;
    dth_integrator *it = start(m, h, DTH_START_MIDPOINT, q0, p0, 0);
    rec r;
    rec_init(&r, N);
    dth_run_config c = config(0, 2000, &r);
    c.points = DTH_POINTS_MIDPOINTS;
    dth_run_state st;
    run(it, &c, &st);
    CU_ASSERT(r.ns == 2000);
    double E0, E, worst = 0, *y = calloc(N, sizeof *y);
    memcpy(y, q0, n * sizeof *y);
    memcpy(y + n + 1, p0, n * sizeof *y);
    CU_ASSERT_FATAL(dth_model_eval(m, y, DTH_EVAL_H, &E0, NULL, NULL) == DTH_OK);
    /* the first midpoint is the initial condition */
    CU_ASSERT(memcmp(r.z, y, (2 * n + 1) * sizeof *y) == 0);
    for (long s = 0; s < r.ns; s++) {
        const double *z = r.z + (size_t)s * N;
        CU_ASSERT(r.kind[s] == DTH_SAMPLE_MIDPOINT && r.k[s] == s);
        CU_ASSERT_FATAL(dth_model_eval(m, z, DTH_EVAL_H, &E, NULL, NULL) == DTH_OK);
        worst = fmax(worst, fabs(E - E0) / fabs(E0));
    }
    printf("  %s: midpoint rows, max |E - E0| / |E0| = %.2e\n", name, worst);
    CU_ASSERT(worst <= 1e-14);
    free(y);
    rec_free(&r);
    dth_integrator_free(it);
}

static void test_midpoints(void)
{
    dth_model *m = model(&dth_model_pendulum, NULL, 0, 1);
    double q[8] = {1.2}, p[8] = {0.1};
    midpoint_energy("pendulum", m, q, p, 0.05);
    dth_model_free(m);
    m = model(&dth_model_harmonic, &(dth_kv){"omega", "1,1.7320508075688772"}, 1, 2);
    q[0] = 1, q[1] = 0.5, p[0] = 0, p[1] = 0.3;
    midpoint_energy("harmonic", m, q, p, 0.05);
    dth_model_free(m);
    m = model(&dth_model_kepler, NULL, 0, 2);
    q[0] = 0.4, q[1] = 0, p[0] = 0, p[1] = 2;
    midpoint_energy("kepler", m, q, p, 0.01);
    dth_model_free(m);
    dth_kv kv[] = {{"preset", "chain"}, {"size", "4"}, {"dim", "1"}};
    dth_model *mc = model(&dth_model_coupled, kv, 3, 4);
    double qc[4] = {0, 1.2, 2, 3.1}, pc[4] = {0.1, 0, -0.2, 0.1};
    midpoint_energy("coupled chain", mc, qc, pc, 0.05);
    dth_model_free(mc);
}

/* ------------------------------------------------------------------ events */

/* g = q . p = r dr/dt: zero at pericentre (increasing) and apocentre (decreasing). */
static int radial(void *user, size_t n, const double *z, double *g)
{
    (void)user;
    *g = z[0] * z[n + 1] + z[1] * z[n + 2];
    return 0;
}

/* Pericentre (increasing q.p) and apocentre (decreasing) passages of e = 0.6 from apocentre,
 * at t = pi j; returns the largest time error, checks each event. */
static double kepler_events(const dth_model *m, double h)
{
    double q[2] = {-1.6, 0}, p[2] = {0, -0.5};
    dth_integrator *it = start(m, h, DTH_START_MIDPOINT, q, p, 0);
    rec r;
    rec_init(&r, 6);
    dth_event ev[2] = {{radial, NULL, +1, 0}, {radial, NULL, -1, 0}};
    dth_run_config c = config(5.5 * PI, 0, &r);
    c.sample = NULL; /* events only */
    c.events = ev;
    c.nevents = 2;
    dth_run_state st;
    run(it, &c, &st);
    /* pericentres at pi, 3 pi, 5 pi; apocentres at 2 pi, 4 pi (the start, an apocentre, is no crossing) */
    CU_ASSERT_FATAL(r.ne == 5);
    double worst_t = 0, worst_g = 0;
    for (long e = 0; e < r.ne; e++) {
        const double *z = r.ze + (size_t)e * 6;
        double texact = PI * (double)(e + 1);
        int peri = e % 2 == 0;
        CU_ASSERT(r.eidx[e] == (peri ? 0 : 1));
        CU_ASSERT(r.edir[e] == (peri ? 1 : -1));
        worst_t = fmax(worst_t, fabs(z[2] - texact));
        /* located to round-off: |g| within a few ulps of t times |dg/dt| = |p|^2 - 1/r */
        double g, dg = z[4] * z[4] + z[5] * z[5] - 1 / hypot(z[0], z[1]);
        radial(NULL, 2, z, &g);
        worst_g = fmax(worst_g, fabs(g) / (DBL_EPSILON * z[2] * fabs(dg)));
    }
    printf("  kepler e=0.6, h = %g: passages at max |t - t_exact| = %.3e; |q.p| at the events <= %.1f ulp(t) |d(q.p)/dt|\n",
           h, worst_t, worst_g);
    CU_ASSERT(worst_g <= 4);
    rec_free(&r);
    dth_integrator_free(it);
    return worst_t;
}

static void test_events_kepler(void)
{
    dth_model *m = model(&dth_model_kepler, NULL, 0, 2);
    /* event times carry the method's phase error, O(h^2): 5.5e-8 at h = 0.001 after 2.5 orbits (the
     * events themselves are located to round-off, kepler_events); the exact times to 1e-10 take
     * h = 3e-5 (5e-11 by the h^2 law; about 5e5 steps) */
    double e1 = kepler_events(m, 0.001), e2 = kepler_events(m, 0.0005), e3 = kepler_events(m, 3e-5);
    CU_ASSERT(e1 < 1e-7);
    CU_ASSERT(e1 / e2 > 3.8 && e1 / e2 < 4.2);
    CU_ASSERT(e3 <= 1e-10);
    dth_model_free(m);
}

/* A Poincare section of the harmonic oscillator q = cos(w t): q crosses 0 upward at
 * w t = 3 pi / 2 + 2 pi j; a terminal distance event stops the run. */
static void test_events_direction_terminal(void)
{
    dth_model *m = model(&dth_model_harmonic, NULL, 0, 1);
    double q = 1, p = 0;
    dth_integrator *it = start(m, 0.01, DTH_START_MIDPOINT, &q, &p, 0);
    rec r;
    rec_init(&r, 4);
    dth_event_spec cross = {0, 0.0, NULL, 0};
    dth_event ev[1] = {{dth_event_coordinate, &cross, +1, 0}};
    dth_run_config c = config(20, 0, &r);
    c.events = ev;
    c.nevents = 1;
    dth_run_state st;
    run(it, &c, &st);
    CU_ASSERT(r.ne == 3); /* 4.71, 10.99, 17.28 */
    for (long e = 0; e < r.ne; e++) {
        CU_ASSERT(r.edir[e] == 1);
        /* the method's phase error, about h^2 t / 12 for the harmonic oscillator */
        double te = r.ze[(size_t)e * 4 + 1];
        CU_ASSERT(fabs(te - (1.5 * PI + 2 * PI * (double)e)) < 1.2e-5 * te);
        /* q = 0 to round-off in t: |q| within a few ulps of t times |dq/dt| = |p| */
        CU_ASSERT(fabs(r.ze[(size_t)e * 4]) <= 4 * DBL_EPSILON * te * fabs(r.ze[(size_t)e * 4 + 2]));
    }
    dth_integrator_free(it);
    rec_free(&r);
    /* terminal: |q| falls through 0.5 first at t = acos(0.5) = pi/3 */
    it = start(m, 0.01, DTH_START_MIDPOINT, &q, &p, 0);
    rec_init(&r, 4);
    dth_event_spec dist = {0, 0.5, NULL, 0};
    dth_event ev2[1] = {{dth_event_distance, &dist, -1, 1}};
    c.events = ev2;
    run(it, &c, &st);
    CU_ASSERT(st.stop == DTH_RUN_EVENT);
    CU_ASSERT(r.ne == 1);
    CU_ASSERT(fabs(st.t_stop - PI / 3) < 1e-4);
    CU_ASSERT(r.kind[r.ns - 1] == DTH_SAMPLE_END);
    CU_ASSERT(r.z[(size_t)(r.ns - 1) * 4 + 1] == st.t_stop);
    CU_ASSERT(r.ze[1] == st.t_stop);
    dth_integrator_free(it);
    rec_free(&r);
    dth_model_free(m);
}

/* ------------------------------------------------------------------ resume bit for bit */

typedef struct saver {
    rec *r;
    int keep;          /* keep the latest checkpoint: the integrator's (buf, len) and the loop state */
    void *buf;
    size_t len;
    dth_run_state st;
    dth_integrator *it;
} saver;

static int save_ckpt(void *user, const dth_run_state *st)
{
    saver *s = user;
    if (!s->keep) return 0;
    free(s->buf);
    dth_checkpoint_save(s->it, NULL, 0, NULL, 0, &s->len);
    s->buf = malloc(s->len);
    dth_checkpoint_save(s->it, NULL, 0, s->buf, s->len, &s->len);
    s->st = *st;
    return 0;
}

static int saver_sample(void *user, const dth_sample *s) { return on_sample(((saver *)user)->r, s); }
static int saver_event(void *user, const dth_sample *s) { return on_event(((saver *)user)->r, s); }

static void run_pendulum(dth_points pts, double t_end, saver *sv, dth_integrator *it, dth_run_state *st)
{
    static dth_event_spec sec = {2, 0.0, NULL, 0}; /* p = 0 */
    static dth_event ev[1] = {{dth_event_coordinate, &sec, 0, 0}};
    dth_run_config c = config(t_end, 0, sv->r);
    c.points = pts;
    c.dt = 0.07;
    c.events = ev;
    c.nevents = 1;
    c.sample = saver_sample;
    c.on_event = saver_event;
    c.checkpoint = save_ckpt;
    c.checkpoint_every = 1;
    c.user = sv;
    sv->it = it;
    CU_ASSERT_FATAL(dth_run(it, &c, st) == DTH_OK);
}

static void test_resume(void)
{
    dth_model *m = model(&dth_model_pendulum, NULL, 0, 1);
    double q = 1, p = 0;
    for (int pts = 0; pts < 3; pts++) {
        /* the reference, uninterrupted */
        rec ref, part;
        rec_init(&ref, 4);
        rec_init(&part, 4);
        saver s1 = {.r = &ref};
        dth_integrator *it = start(m, 0.05, DTH_START_MIDPOINT, &q, &p, 0);
        dth_run_state st;
        dth_run_state_init(&st);
        run_pendulum((dth_points)pts, 9, &s1, it, &st);
        dth_integrator_free(it);
        /* to t = 4 (its final checkpoint is kept), then from the checkpoint to 9 */
        saver s2 = {.r = &part, .keep = 1};
        it = start(m, 0.05, DTH_START_MIDPOINT, &q, &p, 0);
        dth_run_state_init(&st);
        run_pendulum((dth_points)pts, 4, &s2, it, &st);
        CU_ASSERT_FATAL(s2.buf != NULL);
        CU_ASSERT(s2.st.k == st.k); /* the final checkpoint */
        long keep = part.ns - (part.kind[part.ns - 1] == DTH_SAMPLE_END ? 1 : 0), keep_e = part.ne;
        dth_integrator_free(it);
        dth_integrator *it2 = start(m, 0.05, DTH_START_MIDPOINT, &q, &p, 0);
        char err[256];
        CU_ASSERT_FATAL(dth_checkpoint_restore(it2, s2.buf, s2.len, err, sizeof err) == DTH_OK);
        part.ns = keep;
        dth_run_state st2 = s2.st;
        s2.keep = 0;
        run_pendulum((dth_points)pts, 9, &s2, it2, &st2);
        dth_integrator_free(it2);
        free(s2.buf);
        CU_ASSERT(part.ns == ref.ns);
        CU_ASSERT(part.ne == ref.ne);
        CU_ASSERT(keep_e > 0 && keep_e < ref.ne);
        /* bit for bit, but for samples in the segment cut by the first t_end, which are rebuilt
         * from the midpoint (round-off) */
        double worst = 0;
        long differ = 0;
        for (long i = 0; i < ref.ns && i < part.ns; i++)
            for (size_t j = 0; j < 4; j++) {
                double a = ref.z[(size_t)i * 4 + j], b = part.z[(size_t)i * 4 + j];
                if (a != b) {
                    differ++;
                    worst = fmax(worst, fabs(a - b));
                }
            }
        for (long i = 0; i < ref.ne && i < part.ne; i++)
            for (size_t j = 0; j < 4; j++) {
                double a = ref.ze[(size_t)i * 4 + j], b = part.ze[(size_t)i * 4 + j];
                if (a != b) {
                    differ++;
                    worst = fmax(worst, fabs(a - b));
                }
            }
        printf("  resume (points %d): %ld samples, %ld events, %ld values differ (max %.1e)\n", pts, ref.ns, ref.ne,
               differ, worst);
        CU_ASSERT(worst < 1e-14);
        CU_ASSERT(differ <= 4 * 4);
        rec_free(&ref);
        rec_free(&part);
    }
    dth_model_free(m);
}

/* ------------------------------------------------------------------ threads */

typedef struct job {
    const dth_model_type *type;
    double h;
    double out[6];
    long k;
} job;

static void *thread_run(void *arg)
{
    job *j = arg;
    dth_model *m = NULL;
    char err[128];
    if (dth_model_new(j->type, NULL, 0, 2, NULL, &m, err, sizeof err)) return NULL;
    dth_options o;
    dth_options_default(&o);
    o.h = j->h;
    dth_integrator *it = NULL;
    double q[2] = {0.4, 0}, p[2] = {0, 2};
    if (dth_integrator_new(m, &o, &it) == DTH_OK && dth_integrator_start(it, q, p, 0) == DTH_OK) {
        dth_run_config c;
        dth_run_config_default(&c);
        c.has_t_end = 1;
        c.t_end = 25;
        dth_run_state st;
        dth_run_state_init(&st);
        if (dth_run(it, &c, &st) == DTH_OK) {
            memcpy(j->out, dth_integrator_vertex(it), sizeof j->out);
            j->k = st.k;
        }
    }
    dth_integrator_free(it);
    dth_model_free(m);
    return NULL;
}

static void test_threads(void)
{
    job a = {&dth_model_kepler, 0.002, {0}, 0}, b = {&dth_model_kepler, 0.003, {0}, 0};
    job a1 = a, b1 = b;
    thread_run(&a1);
    thread_run(&b1);
    pthread_t ta, tb;
    CU_ASSERT_FATAL(pthread_create(&ta, NULL, thread_run, &a) == 0);
    CU_ASSERT_FATAL(pthread_create(&tb, NULL, thread_run, &b) == 0);
    pthread_join(ta, NULL);
    pthread_join(tb, NULL);
    CU_ASSERT(a.k > 1000 && b.k > 1000); /* both jobs ran (zeroed outputs would compare equal) */
    CU_ASSERT(a.k == a1.k && b.k == b1.k);
    CU_ASSERT(memcmp(a.out, a1.out, sizeof a.out) == 0);
    CU_ASSERT(memcmp(b.out, b1.out, sizeof b.out) == 0);
}

/* ------------------------------------------------------------------ what dth_run refuses */

static int count_sample(void *user, const dth_sample *s)
{
    (void)s;
    ++*(long *)user;
    return 0;
}

/* dth_run_check's rules (one place; dth_run calls it on every call): each refused with DTH_EINVAL and
 * a message naming the setting, before any sample; a step holding more output times than
 * DTH_RUN_MAX_SAMPLES_PER_STEP stops the run (DTH_RUN_SAMPLES) instead of filling memory. */
static void test_refusals(void)
{
    dth_model *m = model(&dth_model_pendulum, NULL, 0, 1);
    double q0 = 1, p0 = 0;
    dth_integrator *it = start(m, 0.05, DTH_START_MIDPOINT, &q0, &p0, 0);
    long count = 0;
    char err[256];
    dth_run_state st;
    dth_run_config c;
    dth_run_config_default(&c);
    c.sample = count_sample;
    c.user = &count;
    c.has_t_end = 1;
    c.t_end = 5;
    c.points = DTH_POINTS_TIMES;
    /* a configuration of another layout (not filled by dth_run_config_default) */
    c.size = sizeof c - 8;
    dth_run_state_init(&st);
    CU_ASSERT(dth_run_check(it, &c, &st, err, sizeof err) == DTH_EINVAL);
    CU_ASSERT(strstr(err, "dth_run_config.size") != NULL);
    CU_ASSERT(dth_run(it, &c, &st) == DTH_EINVAL);
    c.size = sizeof c;
    static const struct {
        double times[3];
        const char *says;
    } bad[] = {{{1, NAN, 3}, "times[1]"}, {{5, 1, 3}, "times[1] = 1 lies before times[0] = 5"},
               {{1, 3, INFINITY}, "times[2]"}};
    for (size_t i = 0; i < sizeof bad / sizeof *bad; i++) {
        c.times = bad[i].times;
        c.ntimes = 3;
        dth_run_state_init(&st);
        CU_ASSERT(dth_run_check(it, &c, &st, err, sizeof err) == DTH_EINVAL);
        CU_ASSERT(strstr(err, bad[i].says) != NULL);
        CU_ASSERT(dth_run(it, &c, &st) == DTH_EINVAL);
        CU_ASSERT(count == 0 && dth_integrator_steps(it) == 0);
    }
    /* equal times are fine */
    double eq[3] = {1, 1, 3};
    c.times = eq;
    dth_run_state_init(&st);
    CU_ASSERT(dth_run_check(it, &c, &st, err, sizeof err) == DTH_OK);
    /* a dt asking for more than 1e6 rows per step of 0.05, known before the run */
    c.times = NULL;
    c.ntimes = 0;
    c.dt = 1e-300;
    CU_ASSERT(dth_run(it, &c, &st) == DTH_EINVAL);
    CU_ASSERT(dth_run_check(it, &c, &st, err, sizeof err) == DTH_EINVAL && strstr(err, "rows per step"));
    c.dt = 0.05 / 1e6; /* exactly the bound: accepted */
    CU_ASSERT(dth_run_check(it, &c, &st, err, sizeof err) == DTH_OK);
    /* negative steps */
    c.points = DTH_POINTS_VERTICES;
    c.has_t_end = 0;
    c.steps = -5;
    CU_ASSERT(dth_run(it, &c, &st) == DTH_EINVAL);
    CU_ASSERT(dth_run_check(it, &c, &st, err, sizeof err) == DTH_EINVAL && strstr(err, "steps = -5"));
    CU_ASSERT(count == 0);
    /* t_end behind: at the start, and on a later call behind where the first one ended */
    c.has_t_end = 1;
    c.t_end = -1;
    CU_ASSERT(dth_run(it, &c, &st) == DTH_EINVAL);
    c.t_end = 2;
    CU_ASSERT_FATAL(dth_run(it, &c, &st) == DTH_OK);
    CU_ASSERT(count > 0 && st.t_stop == 2);
    long k = st.k, before = count;
    c.t_end = 1;
    CU_ASSERT(dth_run(it, &c, &st) == DTH_EINVAL);
    CU_ASSERT(dth_run_check(it, &c, &st, err, sizeof err) == DTH_EINVAL && strstr(err, "where the run stands"));
    CU_ASSERT(st.k == k && count == before && st.t_stop == 2);
    c.has_t_end = 0;
    c.steps = k - 1;
    CU_ASSERT(dth_run(it, &c, &st) == DTH_EINVAL);
    c.steps = k; /* where it stands: nothing to do */
    CU_ASSERT(dth_run(it, &c, &st) == DTH_OK);
    dth_integrator_free(it);

    /* a list of times cannot be judged before the run: the driver stops inside the first step */
    it = start(m, 0.05, DTH_START_VERTEX, &q0, &p0, 0);
    size_t nt = 3 * (size_t)DTH_RUN_MAX_SAMPLES_PER_STEP / 2;
    double *tt = malloc(nt * sizeof *tt);
    CU_ASSERT_FATAL(tt != NULL);
    for (size_t i = 0; i < nt; i++) tt[i] = 0.01 * (double)i / (double)nt;
    dth_run_config_default(&c);
    c.sample = count_sample;
    c.user = &count;
    c.has_t_end = 1;
    c.t_end = 1;
    c.t0 = 0;
    c.points = DTH_POINTS_TIMES;
    c.times = tt;
    c.ntimes = nt;
    count = 0;
    dth_run_state_init(&st);
    CU_ASSERT(dth_run_check(it, &c, &st, err, sizeof err) == DTH_OK);
    CU_ASSERT(dth_run(it, &c, &st) == DTH_EINVAL);
    CU_ASSERT(st.stop == DTH_RUN_SAMPLES);
    CU_ASSERT(count == DTH_RUN_MAX_SAMPLES_PER_STEP);
    CU_ASSERT(st.k == 1);
    free(tt);
    dth_integrator_free(it);
    dth_model_free(m);
}

static CU_TestInfo run_tests[] = {
    {"dense output reproduces cubics (quartics with the midpoint)", test_dense_polynomials},
    {"dense output converges at order 2 at fixed times", test_dense_order},
    {"t_end is hit exactly; t0 of a midpoint start is the initial condition", test_exact_end},
    {"midpoint samples hold the energy to 1e-14 on every model", test_midpoints},
    {"Kepler pericentre and apocentre events", test_events_kepler},
    {"event direction and terminal events", test_events_direction_terminal},
    {"a run resumed from its checkpoint gives the same samples and events", test_resume},
    {"separate integrators in two threads: the same bits", test_threads},
    {"bad configurations refused with a message; a step with too many output times stops", test_refusals},
    CU_TEST_INFO_NULL};

CU_SuiteInfo dth_test_suites[] = {{"run", NULL, NULL, NULL, NULL, run_tests}, CU_SUITE_INFO_NULL};
