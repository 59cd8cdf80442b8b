/* SPDX-License-Identifier: MIT */
/*
 * Benchmark (not a test): what losing symplecticity costs (issue 11, item 5; paper, section 7, the
 * regularization of DTH across psi = 0). Raw DTH ("none"), the regularizers "land" and "prescribed"
 * (alpha = 0: a constant step) and the baselines gauss4, midpoint and midpoint-proj of lib/methods.c, on
 * non-integrable systems with two or more degrees of freedom over long times, at matched mean step:
 * land runs first with the nominal first step h; prescribed and the fixed-step methods then take the
 * constant step T / (land's steps), so every method advances the same time in about as many steps;
 * none starts like land (it takes the same steps until land replaces a crossing step).
 *   A. FPUT beta chain (16 masses, fixed ends) started in its lowest mode: mode-1 energy over time,
 *      its first recurrence and when the recurrence breaks down, the spectral entropy of the
 *      time-averaged mode energies; and whether psi changes sign on such chains at all (it cannot for
 *      beta >= 0: the potential is convex, so psi = p^T V'' p + |grad V|^2 > 0).
 *   B. Poincare sections of regular orbits, located by cubic Hermite interpolation between states:
 *      Henon-Heiles at E = 1/12 and 1/6 (y = 0, py > 0) and two coupled rotating pendula (psi changes
 *      sign along it, so land replaces steps; section q2 = 0 mod 2 pi, p2 > 0): the distance of
 *      the section points from a reference curve (gauss4 at a small step), early against late.
 *   C. A 2-D chain of 3 masses through psi = 0: energy and angular momentum Lz.
 * Prints markdown tables (wall times are of the stepping calls only, measured side by side in this
 * run: use ratios) and writes CSV files for scripts/plot-symplectic.sh.
 * Usage: bench_symplectic [scale] [--out DIR] [--only PARTS] [--land KEY=VALUE]   (scale 1: the figures
 * of docs/regularization.md, about 7 minutes; 0.01: a smoke run of a few seconds; DIR defaults to
 * bench-out; PARTS: letters of A, B, C, default all; --land: a parameter of land's, e.g. clock=no)
 */
#include <errno.h>
#include <float.h>
#include <limits.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include "bench_common.h"
#include "symp_models.h"

#define PI 3.14159265358979323846
enum { MAXN = 32 };

static const char *const methods[] = {"none", "land", "prescribed", "gauss4", "midpoint", "midpoint-proj"};
static dth_kv land_kv[1]; /* --land KEY=VALUE */
static size_t land_nkv;
enum { NMETH = sizeof methods / sizeof methods[0] };

/* ---- one run of one method: DTH (with a regularizer) or a fixed-step baseline ---- */

typedef struct runner {
    const char *method;
    const dth_model *m;
    dth_regularizer *reg;
    dth_integrator *it;
    size_t n;
    double h;                     /* nominal step: DTH's first step, the fixed step otherwise */
    long steps, regularized, crossings;
    int status;
    char why[320];
    double E0, emid, evert; /* initial energy; largest |dE|/|E| at DTH midpoints and at the states */
    double secs;            /* wall time inside the stepping calls */
    double t_end;           /* time reached (set by runner_close) */
    int dth;                /* a DTH integrator (regularized steps, midpoints) */
} runner;

static int is_dth(const char *method)
{
    return !strcmp(method, "none") || !strcmp(method, "land") || !strcmp(method, "prescribed");
}

static double energy(const dth_model *m, const double *y)
{
    double H = NAN;
    dth_model_eval(m, y, DTH_EVAL_H, &H, NULL, NULL);
    return H;
}

static int runner_open(runner *r, const dth_model *m, const char *method, double h, const double *q0, const double *p0)
{
    memset(r, 0, sizeof *r);
    r->method = method;
    r->m = m;
    r->n = dth_model_dof(m);
    r->h = h;
    r->dth = is_dth(method);
    char err[256] = "";
    int rc;
    if (is_dth(method)) {
        const dth_regularizer_type *ty = !strcmp(method, "none")     ? &dth_reg_none
                                         : !strcmp(method, "land") ? &dth_reg_land
                                                                     : &dth_reg_prescribed;
        dth_kv kv[] = {{"alpha", "0"}};
        if (ty == &dth_reg_land) rc = dth_regularizer_new(ty, land_kv, land_nkv, m, NULL, &r->reg, err, sizeof err);
        else rc = dth_regularizer_new(ty, kv, ty == &dth_reg_prescribed, m, NULL, &r->reg, err, sizeof err);
        if (!rc) {
            dth_options o;
            dth_options_default(&o);
            o.h = h;
            o.start = DTH_START_MIDPOINT;
            o.regularizer = r->reg;
            if (ty == &dth_reg_prescribed) o.branch_check = 0; /* it computes no ordinary step */
            rc = dth_integrator_new(m, &o, &r->it);
            if (!rc) rc = dth_integrator_start(r->it, q0, p0, 0.0);
        }
    } else {
        rc = bench_baseline(m, method, h, q0, p0, &r->it);
    }
    double y0[2 * MAXN + 1] = {0};
    memcpy(y0, q0, r->n * sizeof *y0);
    memcpy(y0 + r->n + 1, p0, r->n * sizeof *y0);
    r->E0 = energy(m, y0);
    if (rc) {
        snprintf(r->why, sizeof r->why, "cannot start: %s %s", dth_status_name(rc), err);
        r->status = rc;
    }
    return rc;
}

static const double *runner_y(const runner *r)
{
    return dth_integrator_vertex(r->it);
}

static void runner_close(runner *r)
{
    if (r->it) r->t_end = runner_y(r)[r->n];
    dth_integrator_free(r->it);
    dth_regularizer_free(r->reg);
    r->it = NULL;
    r->reg = NULL;
}

/* One step; on failure the status and message are kept (the first failure ends the run). */
static int runner_step(runner *r)
{
    if (r->status) return r->status;
    int rc;
    double t0 = bench_now();
    dth_step_info inf;
    rc = dth_integrator_step(r->it, &inf);
    r->secs += bench_now() - t0;
    if (!rc) {
        if (inf.flags & DTH_STEP_REGULARIZED) r->regularized++;
        if (inf.flags & DTH_STEP_CROSSING) r->crossings++;
    }
    if (rc) {
        r->status = rc;
        snprintf(r->why, sizeof r->why, "%s at step %ld from t = %.10g: %s", dth_status_name(rc), r->steps + 1, runner_y(r)[r->n],
                 dth_integrator_errmsg(r->it));
        return rc;
    }
    r->steps++;
    /* energy: DTH's midpoints carry -wp exactly; its vertices carry the O(h^2) offset psi lambda^2/8 */
    const double *y = runner_y(r);
    r->evert = fmax(r->evert, fabs(energy(r->m, y) - r->E0) / fabs(r->E0));
    if (r->dth) { /* baselines have no midpoint (dth_integrator_midpoint: NULL) */
        const double *zb = dth_integrator_midpoint(r->it);
        r->emid = fmax(r->emid, fabs(zb[2 * r->n + 1] + energy(r->m, zb)) / fabs(r->E0));
    }
    return 0;
}

static const char *st(const runner *r) { return r->status ? dth_status_name(r->status) : "ok"; }

static const char *range(const double *v, char *buf, size_t len)
{
    if (!(v[0] <= v[1])) return "-";
    snprintf(buf, len, "[%.3g, %.3g]", v[0], v[1]);
    return buf;
}

/* "12.3 %" of the steps regularized, or "-" for a method without regularizer steps */
static const char *share(const runner *r, char *buf, size_t len)
{
    if (!r->dth) return "-";
    snprintf(buf, len, "%ld (%.1f %%)", r->regularized, r->steps ? 100.0 * (double)r->regularized / (double)r->steps : 0.0);
    return buf;
}

static const char *emid(const runner *r, char *buf, size_t len)
{
    if (!r->dth) return "-";
    snprintf(buf, len, "%.1e", r->emid);
    return buf;
}

/* failures, listed at the end with what reproduces them */
static char failures[16][512];
static int nfail;

static void note_failure(const runner *r, const char *system, const double *q0, const double *p0)
{
    if (!r->status || nfail >= 16) return;
    char qs[200] = "", ps[200] = "";
    size_t n = r->n < 6 ? r->n : 6;
    for (size_t i = 0; i < n; i++) {
        snprintf(qs + strlen(qs), sizeof qs - strlen(qs), "%s%.10g", i ? ", " : "", q0[i]);
        snprintf(ps + strlen(ps), sizeof ps - strlen(ps), "%s%.10g", i ? ", " : "", p0[i]);
    }
    snprintf(failures[nfail++], sizeof failures[0], "%s, %s, q0 = (%s%s), p0 = (%s%s), h = %.10g, midpoint start: %s", system, r->method, qs,
             r->n > 6 ? ", ..." : "", ps, r->n > 6 ? ", ..." : "", r->h, r->why);
}

static FILE *open_csv(const char *dir, const char *name, const char *header)
{
    char path[1024];
    snprintf(path, sizeof path, "%s/%s", dir, name);
    FILE *f = fopen(path, "w");
    if (!f) {
        fprintf(stderr, "cannot write %s\n", path);
        exit(1);
    }
    fprintf(f, "%s\n", header);
    return f;
}

/* ======================= A. FPUT chain ======================= */

typedef struct modes {
    size_t N;
    double S[MAXN * MAXN], w[MAXN];
} modes;

/* normal modes of the fixed-end chain: Q_k = sqrt(2/(N+1)) sum_j q_j sin(j k pi/(N+1)), w_k = 2 sin(k pi/(2(N+1))) */
static void modes_init(modes *md, size_t N)
{
    md->N = N;
    double c = sqrt(2.0 / (double)(N + 1));
    for (size_t k = 1; k <= N; k++) {
        md->w[k - 1] = 2 * sin((double)k * PI / (double)(2 * (N + 1)));
        for (size_t j = 1; j <= N; j++) md->S[(k - 1) * N + j - 1] = c * sin((double)(j * k) * PI / (double)(N + 1));
    }
}

/* harmonic mode energies E_k = (P_k^2 + w_k^2 Q_k^2)/2 */
static void mode_energies(const modes *md, const double *y, double *E)
{
    size_t N = md->N;
    const double *q = y, *p = y + N + 1;
    for (size_t k = 0; k < N; k++) {
        double Q = 0, P = 0;
        for (size_t j = 0; j < N; j++) {
            Q += md->S[k * N + j] * q[j];
            P += md->S[k * N + j] * p[j];
        }
        E[k] = 0.5 * (P * P + md->w[k] * md->w[k] * Q * Q);
    }
}

/* exp(spectral entropy) / N of the distribution E_k / sum E: 1/N for one mode, 1 at equipartition */
static double eta_of(const double *E, size_t N)
{
    double tot = 0, S = 0;
    for (size_t k = 0; k < N; k++) tot += E[k];
    for (size_t k = 0; k < N; k++) {
        double e = E[k] / tot;
        if (e > 0) S -= e * log(e);
    }
    return exp(S) / (double)N;
}

typedef struct fput_out {
    runner r;
    double t_rec, e1_rec, e1_min; /* first recurrence: time and height of e1's first return peak, the minimum before */
    int npeaks;                   /* returns of e1 above the threshold */
    double t_break;               /* first time e1 < 0.4: the end of the regular recurrence (its minima stay near 0.47 at E = 0.5) */
    double yend[2 * MAXN + 1];    /* the last state */
    double e1_bar, eta_bar;       /* second half: time average of e1; eta of the time-averaged mode energies */
    double Ebar[MAXN];
    double psi_min, psi_max;
} fput_out;

/* Run to time T, sampling every dts; e1 = E_1 / E. Rows of `csv`: case, method, t, e1, eta. */
static void fput_run(fput_out *o, const dth_model *m, const modes *md, const char *method, double h, const double *q0,
                     const double *p0, double T, double dts, const char *label, FILE *csv)
{
    memset(o, 0, sizeof *o);
    size_t N = md->N;
    runner *r = &o->r;
    runner_open(r, m, method, h, q0, p0);
    double E = r->E0, ts = 0, Ek[MAXN], work[4096], thr = 0.6;
    int state = 0, nlate = 0;
    double peak = 0, tpeak = 0;
    o->e1_min = INFINITY;
    o->t_rec = o->e1_rec = o->t_break = NAN;
    o->psi_min = INFINITY;
    o->psi_max = -INFINITY;
    const double *y = runner_y(r);
    for (;;) {
        if (y[N] >= ts) {
            mode_energies(md, y, Ek);
            double e1 = Ek[0] / E;
            if (csv) fprintf(csv, "%s,%s,%.6g,%.6e,%.6e\n", label, method, y[N], e1, eta_of(Ek, N));
            double psi;
            if (!dth_model_psi(m, y, &psi, NULL, work)) {
                o->psi_min = fmin(o->psi_min, psi);
                o->psi_max = fmax(o->psi_max, psi);
            }
            if (e1 < 0.4 && !isfinite(o->t_break)) o->t_break = y[N];
            /* recurrence: e1 falls below thr (state 1), comes back above it (state 2: a peak) */
            if (state == 0 && e1 < thr) state = 1;
            if (state == 1) {
                if (o->npeaks == 0) o->e1_min = fmin(o->e1_min, e1);
                if (e1 >= thr) state = 2, peak = e1, tpeak = y[N];
            } else if (state == 2) {
                if (e1 > peak) peak = e1, tpeak = y[N];
                if (e1 < thr) {
                    if (o->npeaks++ == 0) o->t_rec = tpeak, o->e1_rec = peak;
                    state = 1;
                }
            }
            if (y[N] >= T / 2) {
                for (size_t k = 0; k < N; k++) o->Ebar[k] += Ek[k];
                o->e1_bar += e1;
                nlate++;
            }
            ts += dts;
        }
        if (y[N] >= T || runner_step(r)) break;
        y = runner_y(r);
    }
    memcpy(o->yend, y, (2 * N + 1) * sizeof *y);
    if (nlate) {
        for (size_t k = 0; k < N; k++) o->Ebar[k] /= nlate;
        o->e1_bar /= nlate;
        o->eta_bar = eta_of(o->Ebar, N);
    }
    runner_close(r);
}

/* Does psi change sign on an FPUT chain? land alone, for a range of energies. */
static void part_fput_psi(double scale)
{
    struct {
        const char *alpha, *beta;
        double E;
    } cs[] = {{"0", "1", 0.5}, {"0", "1", 2}, {"0", "1", 8}, {"0", "1", 32}, {"2", "1.1", 0.5}, {"2", "1.1", 2}, {"2", "1.1", 8}};
    const size_t N = 16;
    double T = fmax(1000 * scale, 50);
    printf("### Does psi change sign on the chain? land alone, N = %zu, first step h = 0.1, all energy in mode 1, T = %.0f\n\n", N, T);
    printf("| alpha | beta | E | steps | end | regularized steps | psi crossings | psi range (sampled) |\n|---|---|---|---|---|---|---|---|\n");
    modes md;
    modes_init(&md, N);
    for (size_t c = 0; c < sizeof cs / sizeof cs[0]; c++) {
        dth_kv kv[] = {{"N", "16"}, {"beta", cs[c].beta}, {"alpha", cs[c].alpha}};
        dth_model *m;
        char err[256];
        if (dth_model_new(&fput_type, kv, 3, N, NULL, &m, err, sizeof err)) {
            fprintf(stderr, "fput: %s\n", err);
            exit(1);
        }
        double q0[MAXN], p0[MAXN] = {0}, A = sqrt(2 * cs[c].E) / md.w[0];
        for (int it = 0; it < 100; it++) {
            double y[2 * MAXN + 1] = {0};
            for (size_t j = 0; j < N; j++) y[j] = A * md.S[j];
            A *= sqrt(cs[c].E / energy(m, y));
        }
        for (size_t j = 0; j < N; j++) q0[j] = A * md.S[j];
        fput_out *o = malloc(sizeof *o);
        if (!o) exit(1);
        fput_run(o, m, &md, "land", 0.1, q0, p0, T, 0.5, "", NULL);
        char b1[64];
        printf("| %s | %s | %g | %ld | %s | %s | %ld | [%.3g, %.3g] |\n", cs[c].alpha, cs[c].beta, cs[c].E, o->r.steps, st(&o->r), share(&o->r, b1, sizeof b1),
               o->r.crossings, o->psi_min, o->psi_max);
        note_failure(&o->r, "FPUT chain (psi survey)", q0, p0);
        free(o);
        dth_model_free(m);
    }
    printf("\n");
}

static void part_fput(double scale, const char *dir)
{
    const size_t N = 16;
    const double beta = 1, h = 0.1;
    const double Es[] = {0.5, 2};
    const double Ts[] = {50000, 20000};
    char ns[16], bs[32];
    snprintf(ns, sizeof ns, "%zu", N);
    snprintf(bs, sizeof bs, "%g", beta);
    dth_kv kv[] = {{"N", ns}, {"beta", bs}, {"alpha", "0"}};
    dth_model *m;
    char err[256];
    if (dth_model_new(&fput_type, kv, 3, N, NULL, &m, err, sizeof err)) {
        fprintf(stderr, "fput: %s\n", err);
        exit(1);
    }
    modes md;
    modes_init(&md, N);
    FILE *ts = open_csv(dir, "fput_e1.csv", "case,method,t,e1,eta");
    FILE *ms = open_csv(dir, "fput_modes.csv", "case,method,k,Ebar_over_E");
    printf("## A. FPUT beta chain: N = %zu masses, fixed ends, beta = %g, all energy in mode 1 (q = A sin(j pi/(N+1)), p = 0)\n\n", N, beta);
    printf("e1 = E_1/E (harmonic energy of mode 1), sampled every T1/4; a recurrence is a return of e1 above 0.6 after it fell below;\n");
    printf("eta = exp(spectral entropy)/N of the mode energies time-averaged over [T/2, T] (1/N = one mode, 1 = equipartition).\n");
    printf("Step: land's first step h = %g; prescribed and the fixed-step methods at land's mean step; 'none, h/2': raw DTH at half the step (the spread a step change alone causes).\n\n", h);
    for (size_t c = 0; c < sizeof Es / sizeof Es[0]; c++) {
        double E = Es[c], T = Ts[c] * scale;
        if (T < 200) T = 200;
        /* amplitude of mode 1 whose energy (quartic term included) is E */
        double q0[MAXN], p0[MAXN] = {0}, A = sqrt(2 * E) / md.w[0];
        for (int it = 0; it < 100; it++) {
            double y[2 * MAXN + 1] = {0};
            for (size_t j = 0; j < N; j++) y[j] = q0[j] = A * md.S[j];
            A *= sqrt(E / energy(m, y));
        }
        for (size_t j = 0; j < N; j++) q0[j] = A * md.S[j];
        double T1 = 2 * PI / md.w[0], dts = T1 / 4;
        char label[64];
        snprintf(label, sizeof label, "E%g", E);
        printf("### E = %g (E/N = %.4g), T = %.0f (%.0f periods of mode 1)\n\n", E, E / (double)N, T, T / T1);
        printf("| method | mean step | steps | end | t reached | land: regularized steps | psi crossings | psi range (sampled) | first recurrence t | its e1 peak | e1 min before | e1 < 0.4 first at t | mean e1, 2nd half | eta, 2nd half | max dE/E midpoints | max dE/E states | step time s | time / gauss4 |\n");
        printf("|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|\n");
        static fput_out out[NMETH + 1];
        double hbar = h;
        const char *names[NMETH + 1];
        /* land first: its mean step is the others' step */
        int order[NMETH] = {1, 0, 2, 3, 4, 5};
        for (int i = 0; i < NMETH; i++) {
            int k = order[i];
            names[k] = methods[k];
            double hk = (k == 0 || k == 1) ? h : hbar;
            fput_run(&out[k], m, &md, methods[k], hk, q0, p0, T, dts, label, ts);
            if (k) note_failure(&out[k].r, "FPUT beta chain", q0, p0);
            if (k == 1 && out[k].r.steps > 0) hbar = out[k].r.t_end / (double)out[k].r.steps;
        }
        fput_run(&out[NMETH], m, &md, "none", h / 2, q0, p0, T, dts, label, NULL);
        names[NMETH] = "none, h/2";
        double tg = out[3].r.secs;
        for (int k = 0; k <= NMETH; k++) {
            const fput_out *o = &out[k];
            const runner *r = &o->r;
            char b1[64], b2[64], trec[32] = "-", erec[32] = "-", emin[32] = "-", tb[32] = "-";
            if (isfinite(o->t_rec)) {
                snprintf(trec, sizeof trec, "%.0f", o->t_rec);
                snprintf(erec, sizeof erec, "%.3f", o->e1_rec);
            }
            if (isfinite(o->e1_min)) snprintf(emin, sizeof emin, "%.3f", o->e1_min);
            if (isfinite(o->t_break)) snprintf(tb, sizeof tb, "%.0f", o->t_break);
            printf("| %s | %.4f | %ld | %s | %.0f | %s | %ld | [%.3g, %.3g] | %s | %s | %s | %s | %.3f | %.3f | %s | %.1e | %.2f | %.2f |\n", names[k],
                   r->steps ? r->t_end / (double)r->steps : NAN, r->steps, st(r), r->t_end, share(r, b1, sizeof b1),
                   r->crossings, o->psi_min, o->psi_max, trec, erec, emin, tb, o->e1_bar, o->eta_bar, emid(r, b2, sizeof b2),
                   r->evert, r->secs, tg > 0 ? r->secs / tg : NAN);
            if (k < NMETH)
                for (size_t j = 0; j < N; j++) fprintf(ms, "%s,%s,%zu,%.6e\n", label, names[k], j + 1, o->Ebar[j] / E);
        }
        printf("\nland's last state equals none's bit for bit: %s\n\n", memcmp(out[0].yend, out[1].yend, (2 * N + 1) * sizeof(double)) ? "no" : "yes");
        fflush(stdout);
    }
    fclose(ts);
    fclose(ms);
    dth_model_free(m);
    part_fput_psi(scale);
}

/* ======================= B. Poincare sections ======================= */

typedef struct orbit {
    const char *name, *label;
    const dth_model_type *type;
    dth_kv kv[1];
    size_t nkv;
    double q0[2], p0[2];
    double h;    /* land's first step */
    int wrap;    /* 0: section q2 = 0 upward; 1: q2 = 2 pi k upward, q1 taken mod 2 pi */
} orbit;

/* Does the step q2: a -> b cross a section level upward? Its level in *L. */
static int crosses(const orbit *o, double a, double b, double *L)
{
    if (!o->wrap) {
        *L = 0;
        return a < 0 && b >= 0;
    }
    double ka = floor(a / (2 * PI)), kb = floor(b / (2 * PI));
    *L = 2 * PI * kb;
    return kb > ka;
}

/* The section point between the states ya and yb (y = (q1, q2, t, p1, p2), unit masses): cubic Hermite
 * interpolation in t with the vector field at both ends, q2(s) = L solved by bisection. */
static int section_point(const dth_model *m, const double *ya, const double *yb, double L, double *x, double *px, double *t)
{
    double ga[5], gb[5];
    if (dth_model_eval(m, ya, DTH_EVAL_GRAD, NULL, ga, NULL) || dth_model_eval(m, yb, DTH_EVAL_GRAD, NULL, gb, NULL)) return -1;
    double dt = yb[2] - ya[2], lo = 0, hi = 1, s = 0.5;
    /* d/dt of (q1, q2, p1): (p1, p2, -dH/dq1) */
    double fa[3] = {ga[3], ga[4], -ga[0]}, fb[3] = {gb[3], gb[4], -gb[0]};
    double h00, h10, h01, h11;
    for (int k = 0; k < 80; k++) {
        s = 0.5 * (lo + hi);
        h00 = (1 + 2 * s) * (1 - s) * (1 - s), h10 = s * (1 - s) * (1 - s), h01 = s * s * (3 - 2 * s), h11 = s * s * (s - 1);
        double q2 = h00 * ya[1] + h10 * dt * fa[1] + h01 * yb[1] + h11 * dt * fb[1];
        if (q2 < L) lo = s;
        else hi = s;
    }
    h00 = (1 + 2 * s) * (1 - s) * (1 - s), h10 = s * (1 - s) * (1 - s), h01 = s * s * (3 - 2 * s), h11 = s * s * (s - 1);
    *x = h00 * ya[0] + h10 * dt * fa[0] + h01 * yb[0] + h11 * dt * fb[0];
    *px = h00 * ya[3] + h10 * dt * fa[2] + h01 * yb[3] + h11 * dt * fb[2];
    *t = ya[2] + s * dt;
    return 0;
}

typedef struct pts {
    double *x, *p, *t;
    size_t n, cap;
} pts;

static void pts_add(pts *s, double x, double p, double t)
{
    if (s->n == s->cap) {
        s->cap = s->cap ? 2 * s->cap : 1024;
        s->x = realloc(s->x, s->cap * sizeof *s->x);
        s->p = realloc(s->p, s->cap * sizeof *s->p);
        s->t = realloc(s->t, s->cap * sizeof *s->t);
        if (!s->x || !s->p || !s->t) {
            fprintf(stderr, "out of memory\n");
            exit(1);
        }
    }
    s->x[s->n] = x, s->p[s->n] = p, s->t[s->n] = t;
    s->n++;
}

static void pts_free(pts *s)
{
    free(s->x);
    free(s->p);
    free(s->t);
    memset(s, 0, sizeof *s);
}

/* Run `method` to time T (or `steps` steps if T is infinite), collecting section points. */
static void section_run(runner *r, pts *out, const orbit *o, const dth_model *m, const char *method, double h, double T, long steps,
                        double *psi_range)
{
    runner_open(r, m, method, h, o->q0, o->p0);
    double ya[5], work[256];
    psi_range[0] = INFINITY;
    psi_range[1] = -INFINITY;
    if (r->status) return;
    memcpy(ya, runner_y(r), sizeof ya);
    while (r->steps < steps && ya[2] < T && !runner_step(r)) {
        const double *y = runner_y(r);
        double L;
        if (crosses(o, ya[1], y[1], &L)) {
            double x, px, t;
            if (!section_point(m, ya, y, L, &x, &px, &t)) {
                if (o->wrap) x -= 2 * PI * floor(x / (2 * PI));
                pts_add(out, x, px, t);
            }
        }
        if ((r->steps & 15) == 0) {
            double psi;
            if (!dth_model_psi(m, y, &psi, NULL, work)) {
                psi_range[0] = fmin(psi_range[0], psi);
                psi_range[1] = fmax(psi_range[1], psi);
            }
        }
        memcpy(ya, y, sizeof ya);
    }
    runner_close(r);
}

/* Distance of (x, p) from the reference curve: the two nearest reference points span the local
 * tangent (the reference is dense: its spacing is far below the curve's radius of curvature), and the
 * distance is to that line (to the nearest point if they coincide). x periodic with period 2 pi if wrap. */
static double curve_distance(const pts *ref, int wrap, double x, double p)
{
    double d1 = INFINITY, d2 = INFINITY;
    double ax = 0, ap = 0, bx = 0, bp = 0;
    for (size_t i = 0; i < ref->n; i++) {
        double dx = ref->x[i] - x, dp = ref->p[i] - p;
        if (wrap) dx -= 2 * PI * floor(dx / (2 * PI) + 0.5);
        double d = dx * dx + dp * dp;
        if (d < d1) {
            d2 = d1, bx = ax, bp = ap;
            d1 = d, ax = dx, ap = dp;
        } else if (d < d2) {
            d2 = d, bx = dx, bp = dp;
        }
    }
    double tx = bx - ax, tp = bp - ap, tt = tx * tx + tp * tp;
    if (!(tt > 0) || !isfinite(d2)) return sqrt(d1);
    /* |cross(a, t)| / |t|: distance from the origin (the point) to the line through a and b */
    return fabs(ax * tp - ap * tx) / sqrt(tt);
}

static int cmp_d(const void *a, const void *b) { return bench_cmp_double(a, b); }

/* median and max of d[i0 .. i1) (sorted copy in buf) */
static void stats(const double *d, size_t i0, size_t i1, double *buf, double *med, double *mx)
{
    size_t n = i1 > i0 ? i1 - i0 : 0;
    if (!n) {
        *med = *mx = NAN;
        return;
    }
    memcpy(buf, d + i0, n * sizeof *buf);
    qsort(buf, n, sizeof *buf, cmp_d);
    *med = buf[n / 2];
    *mx = buf[n - 1];
}

static void part_sections(double scale, const char *dir)
{
    orbit orbits[] = {
        {"Henon-Heiles E = 1/12, x0 = 0.3, px0 = 0", "hh12", &hh_type, {{NULL, NULL}}, 0, {0.3, 0}, {0, 0}, 0.05, 0},
        {"Henon-Heiles E = 1/6, x0 = 0.2, px0 = 0.25", "hh6", &hh_type, {{NULL, NULL}}, 0, {0.2, 0}, {0.25, 0}, 0.05, 0},
        {"coupled rotors eps = 0.1, q0 = (0, 0), p0 = (2.5, 4.05)", "rotors", &rotors_type, {{"eps", "0.1"}}, 1, {0, 0}, {2.5, 4.05}, 0.05, 1},
    };
    /* y = 0, px and py from the energy (V(x, 0) = x^2/2) */
    orbits[0].p0[1] = sqrt(2.0 / 12 - 0.3 * 0.3);
    orbits[1].p0[1] = sqrt(2.0 / 6 - 0.2 * 0.2 - 0.25 * 0.25);
    long steps = (long)(1e6 * scale);
    if (steps < 2000) steps = 2000;
    const double href = 0.02;
    double Tref = fmax(20000 * scale, 1000);
    FILE *sec = open_csv(dir, "section_points.csv", "orbit,method,t,x,px,dist");
    FILE *bins = open_csv(dir, "section_dist.csv", "orbit,method,t,median,max");
    printf("## B. Poincare sections of regular orbits\n\n");
    printf("Section points located by cubic Hermite interpolation in t between consecutive states (the vector field at both ends; linear\n");
    printf("interpolation would add an O(h^2) scatter of its own). Distance: from each section point to the reference curve (gauss4, h = %g,\n", href);
    printf("t in [0, %.0f]), measured to the line through the two nearest reference points. Early / late: the first / last 10 %% of the\n", Tref);
    printf("section points. land runs %ld steps from its first step h; the others run to the time it reached, none from the same first\n", steps);
    printf("step, prescribed and the fixed-step methods at land's mean step.\n\n");
    for (size_t c = 0; c < sizeof orbits / sizeof orbits[0]; c++) {
        const orbit *o = &orbits[c];
        dth_model *m;
        char err[256];
        if (dth_model_new(o->type, o->nkv ? o->kv : NULL, o->nkv, 2, NULL, &m, err, sizeof err)) {
            fprintf(stderr, "%s: %s\n", o->name, err);
            exit(1);
        }
        runner rr[NMETH], rref;
        pts P[NMETH], ref = {0};
        double psi[NMETH][2], psiref[2];
        memset(P, 0, sizeof P);
        section_run(&rr[1], &P[1], o, m, "land", o->h, INFINITY, steps, psi[1]);
        note_failure(&rr[1], o->name, o->q0, o->p0);
        double T = rr[1].t_end, hbar = rr[1].steps ? T / (double)rr[1].steps : o->h;
        for (int k = 0; k < NMETH; k++) {
            if (k == 1) continue;
            section_run(&rr[k], &P[k], o, m, methods[k], k == 0 ? o->h : hbar, T, LONG_MAX, psi[k]);
            if (k) note_failure(&rr[k], o->name, o->q0, o->p0);
        }
        section_run(&rref, &ref, o, m, "gauss4", href, Tref, LONG_MAX, psiref);
        for (size_t i = 0; i < ref.n; i++) fprintf(sec, "%s,reference,%.8g,%.10g,%.10g,0\n", o->label, ref.t[i], ref.x[i], ref.p[i]);
        printf("### %s: T = %.0f, %zu reference points\n\n", o->name, T, ref.n);
        printf("| method | mean step | steps | end | t reached | land: regularized steps | psi crossings | psi range (sampled) | section points | distance early: median / max | late: median / max | late / early (median) | max dE/E midpoints | max dE/E states | step time s | time / gauss4 |\n");
        printf("|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|\n");
        for (int k = 0; k < NMETH; k++) {
            const runner *r = &rr[k];
            size_t n = P[k].n;
            double *d = malloc((n ? n : 1) * sizeof *d), *buf = malloc((n ? n : 1) * sizeof *buf);
            if (!d || !buf) exit(1);
            for (size_t i = 0; i < n; i++) {
                d[i] = curve_distance(&ref, o->wrap, P[k].x[i], P[k].p[i]);
                fprintf(sec, "%s,%s,%.8g,%.10g,%.10g,%.4e\n", o->label, methods[k], P[k].t[i], P[k].x[i], P[k].p[i], d[i]);
            }
            /* 40 bins in time: median and max distance */
            for (int b = 0; b < 40 && n; b++) {
                size_t i0 = 0, i1;
                while (i0 < n && P[k].t[i0] < T * b / 40) i0++;
                for (i1 = i0; i1 < n && P[k].t[i1] < T * (b + 1) / 40; i1++) {}
                double med, mx;
                stats(d, i0, i1, buf, &med, &mx);
                if (i1 > i0) fprintf(bins, "%s,%s,%.8g,%.4e,%.4e\n", o->label, methods[k], T * (b + 0.5) / 40, med, mx);
            }
            size_t w = n / 10;
            double em, ex, lm, lx;
            stats(d, 0, w, buf, &em, &ex);
            stats(d, n - w, n, buf, &lm, &lx);
            char b1[64], b2[64], de[64] = "-", dl[64] = "-", dr[32] = "-";
            if (w) {
                snprintf(de, sizeof de, "%.2e / %.2e", em, ex);
                snprintf(dl, sizeof dl, "%.2e / %.2e", lm, lx);
                snprintf(dr, sizeof dr, "%.2f", lm / em);
            }
            char b3[64];
            printf("| %s | %.4f | %ld | %s | %.4g | %s | %ld | %s | %zu | %s | %s | %s | %s | %.1e | %.2f | %.2f |\n", methods[k],
                   r->steps ? r->t_end / (double)r->steps : NAN, r->steps, st(r), r->t_end, share(r, b1, sizeof b1), r->crossings, range(psi[k], b3, sizeof b3),
                   n, de, dl, dr, emid(r, b2, sizeof b2), r->evert, r->secs, rr[3].secs > 0 ? r->secs / rr[3].secs : NAN);
            free(d);
            free(buf);
        }
        int same = P[0].n == P[1].n && rr[0].steps == rr[1].steps && !memcmp(P[0].x, P[1].x, P[0].n * sizeof(double)) &&
                   !memcmp(P[0].p, P[1].p, P[0].n * sizeof(double)) && !memcmp(P[0].t, P[1].t, P[0].n * sizeof(double));
        printf("\nland's section points equal none's bit for bit: %s\n\n", same ? "yes" : "no");
        fflush(stdout);
        for (int k = 0; k < NMETH; k++) pts_free(&P[k]);
        pts_free(&ref);
        dth_model_free(m);
    }
    fclose(sec);
    fclose(bins);
}

/* ======================= C. 2-D chain through psi = 0 ======================= */

static void part_chain(double scale)
{
    dth_kv kv[] = {{"preset", "chain"}, {"size", "3"}, {"dim", "2"}, {"L", "1"}};
    dth_model *m;
    char err[256];
    if (dth_model_new(&dth_model_coupled, kv, 4, 6, NULL, &m, err, sizeof err)) {
        fprintf(stderr, "chain: %s\n", err);
        exit(1);
    }
    const double q0[6] = {0, 0, 0.5, 0, 1.0, 0}, p0[6] = {0, 1, 0, -2, 0, 1.5}, h = 0.02;
    double T = fmax(2000 * scale, 20);
    printf("## C. 2-D chain of 3 unit masses, springs k = 1, L = 1 (the coupled model), started compressed (spacing 0.5) with transverse momenta\n\n");
    printf("q0 = (0,0, 0.5,0, 1,0), p0 = (0,1, 0,-2, 0,1.5) (scenes/coupled-chain3-prescribed.ini), T = %.0f. Lz = 0.5 (its drift is measured from the\n", T);
    printf("first state: DTH's first vertex carries an O(h^2) offset from the midpoint (q0, p0)); Px = 0 and Py = 0.5 are linear, kept by every method.\n");
    printf("Step as in B: land from h = %g, the others at its mean step.\n\n", h);
    printf("| method | mean step | steps | end | t reached | land: regularized steps | psi crossings | max dE/E midpoints | max dE/E states | max dLz/Lz | step time s | time / gauss4 |\n");
    printf("|---|---|---|---|---|---|---|---|---|---|---|---|\n");
    runner rr[NMETH];
    double dL[NMETH];
    double hbar = h;
    int order[NMETH] = {1, 0, 2, 3, 4, 5};
    for (int i = 0; i < NMETH; i++) {
        int k = order[i];
        runner *r = &rr[k];
        runner_open(r, m, methods[k], k <= 1 ? h : hbar, q0, p0);
        /* drift from the first state (DTH: the vertex z_0 of the midpoint start, whose Lz differs from the
         * midpoint's by O(h^2)) */
        double I[3], L0 = NAN;
        if (!r->status && !dth_model_invariants(m, runner_y(r), I)) L0 = I[2];
        dL[k] = 0;
        while (!r->status && runner_y(r)[6] < T && !runner_step(r))
            if (!dth_model_invariants(m, runner_y(r), I)) dL[k] = fmax(dL[k], fabs(I[2] - L0) / L0);
        runner_close(r);
        if (k) note_failure(r, "2-D chain of 3", q0, p0);
        if (k == 1 && r->steps) hbar = r->t_end / (double)r->steps;
    }
    for (int k = 0; k < NMETH; k++) {
        const runner *r = &rr[k];
        char b1[64], b2[64];
        printf("| %s | %.4f | %ld | %s | %.1f | %s | %ld | %s | %.1e | %.1e | %.2f | %.2f |\n", methods[k], r->steps ? r->t_end / (double)r->steps : NAN,
               r->steps, st(r), r->t_end, share(r, b1, sizeof b1), r->crossings, emid(r, b2, sizeof b2), r->evert, dL[k], r->secs,
               rr[3].secs > 0 ? r->secs / rr[3].secs : NAN);
    }
    printf("\n");
    dth_model_free(m);
}

/* The user models' derivatives (gradient, Hessian, third, band) against finite differences, and
 * their hdiff against two evaluations: a model bug would invalidate every table. */
static void check_models(void)
{
    const dth_model_type *types[] = {&fput_type, &hh_type, &rotors_type};
    const char *names[] = {"fput (N = 16, alpha = 0.3, beta = 1)", "henon-heiles", "rotors (eps = 0.1)"};
    dth_kv fkv[] = {{"N", "16"}, {"alpha", "0.3"}, {"beta", "1"}};
    printf("Model checks (dth_model_check at one point; hdiff against H(y1) - H(y0)):\n\n");
    for (int c = 0; c < 3; c++) {
        dth_model *m;
        char err[256];
        size_t n = c ? 2 : 16;
        if (dth_model_new(types[c], c == 0 ? fkv : NULL, c == 0 ? 3 : 0, n, NULL, &m, err, sizeof err)) {
            fprintf(stderr, "%s: %s\n", names[c], err);
            exit(1);
        }
        double y[2 * MAXN + 1], y1[2 * MAXN + 1];
        for (size_t i = 0; i < 2 * n + 1; i++) {
            y[i] = 0.3 * sin(1.3 * (double)i + 0.2);
            y1[i] = y[i] + 1e-3 * cos((double)i);
        }
        dth_model_check_report rep;
        double H0, H1, dH = NAN;
        dth_model_eval(m, y, DTH_EVAL_H, &H0, NULL, NULL);
        dth_model_eval(m, y1, DTH_EVAL_H, &H1, NULL, NULL);
        /* the bench's own instance state for hdiff (the library keeps its instance opaque) */
        fput fs = {16, 0.3, 1};
        rotors rs = {0.1};
        const void *self = c == 0 ? (const void *)&fs : c == 2 ? (const void *)&rs : NULL;
        types[c]->hdiff(self, y1, y, &dH);
        if (dth_model_check(m, y, &rep)) exit(1);
        double hd = fabs(dH - (H1 - H0)) / fabs(H1 - H0);
        printf("- %s: gradient %.1e, Hessian %.1e, third %.1e, band %.1e, hdiff %.1e\n", names[c], rep.grad_err, rep.hess_err, rep.third_err,
               rep.band_err, hd);
        if (rep.grad_err > 1e-5 || rep.hess_err > 1e-5 || rep.third_err > 1e-5 || rep.band_err > 1e-12 || hd > 1e-9) {
            fprintf(stderr, "%s: a derivative does not match its differences\n", names[c]);
            exit(1);
        }
        dth_model_free(m);
    }
    printf("\n");
}

int main(int argc, char **argv)
{
    double scale = 1;
    const char *dir = "bench-out", *only = "ABC";
    for (int i = 1; i < argc; i++) {
        if (!strcmp(argv[i], "--out") && i + 1 < argc) dir = argv[++i];
        else if (!strcmp(argv[i], "--only") && i + 1 < argc) only = argv[++i];
        else if (!strcmp(argv[i], "--land") && i + 1 < argc && strchr(argv[i + 1], '=')) {
            static char key[64];
            const char *kv = argv[++i], *eq = strchr(kv, '=');
            snprintf(key, sizeof key, "%.*s", (int)(eq - kv), kv);
            land_kv[0] = (dth_kv){key, eq + 1};
            land_nkv = 1;
        } else scale = atof(argv[i]);
    }
    if (!(scale > 0)) {
        fprintf(stderr, "usage: bench_symplectic [scale > 0] [--out DIR] [--only PARTS (letters of A, B, C)] [--land KEY=VALUE]\n");
        return 2;
    }
    if (mkdir(dir, 0777) && errno != EEXIST) {
        fprintf(stderr, "cannot create %s\n", dir);
        return 1;
    }
    printf("# bench_symplectic %g: what losing symplecticity costs\n\n", scale);
    if (land_nkv) printf("land's parameter: %s = %s\n\n", land_kv[0].key, land_kv[0].value);
    check_models();
    if (strchr(only, 'A')) part_fput(scale, dir);
    if (strchr(only, 'B')) part_sections(scale, dir);
    if (strchr(only, 'C')) part_chain(scale);
    printf("## Failures (other than raw DTH's stops)\n\n");
    if (!nfail) printf("none\n");
    for (int i = 0; i < nfail; i++) printf("- %s\n", failures[i]);
    return 0;
}
