/* SPDX-License-Identifier: MIT */
/*
 * Work-precision benchmark (not a test): DTH (paper, Theorem "DTH Equations") against the
 * fixed-step baselines of lib/methods.c and GSL's odeiv2 steppers, driven from the same model
 * vtable. For each scene, method and step (or tolerance): median CPU time, global error at the
 * end against the exact solution, largest energy error, largest invariant error. Writes CSV
 * files for scripts/plot-wp.sh and prints headline ratios, each measured side by side here.
 * Usage: bench_wp [--full] [--out DIR]   (quick mode by default: a few seconds)
 */
#include <errno.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <time.h>
#include <gsl/gsl_errno.h>
#include <gsl/gsl_odeiv2.h>
#include "dth/dth.h"
#include "bench_common.h"

enum { MAXN = 256, MAXREC = 2048 };

static double cpu_now(void)
{
    struct timespec ts;
    clock_gettime(CLOCK_PROCESS_CPUTIME_ID, &ts);
    return (double)ts.tv_sec + 1e-9 * (double)ts.tv_nsec;
}

static int cmp_double(const void *a, const void *b)
{
    double x = *(const double *)a, y = *(const double *)b;
    return (x > y) - (x < y);
}

/* ---- scenes ---- */

typedef struct scene {
    const char *name, *model;
    dth_kv kv[4];
    size_t nkv;
    size_t n;
    double q0[MAXN], p0[MAXN];
    double T;
    double h[8];   /* step sweep (fixed-step methods and DTH's first step) */
    double tol[8]; /* GSL tolerance sweep */
    int full_only;
    const char *reg;   /* DTH regularizer across psi = 0 (NULL: raw DTH) and its parameters */
    dth_kv rkv[2];
    size_t nrkv;
    dth_model *m;
} scene;

/* ---- GSL adapter: the same right-hand side from the model vtable, state (q, p) ---- */

typedef struct gsl_ctx {
    const dth_model *m;
    size_t n;
    double y[2 * MAXN + 1], g[2 * MAXN + 1];
    double hess[(2 * MAXN + 1) * (2 * MAXN + 1)];
} gsl_ctx;

static void to_full(size_t n, const double *x, double t, double *y)
{
    memcpy(y, x, n * sizeof *x);
    y[n] = t;
    memcpy(y + n + 1, x + n, n * sizeof *x);
}

static int gsl_f(double t, const double x[], double dxdt[], void *params)
{
    gsl_ctx *c = params;
    size_t n = c->n;
    to_full(n, x, t, c->y);
    if (dth_model_eval(c->m, c->y, DTH_EVAL_GRAD, NULL, c->g, NULL)) return GSL_EBADFUNC;
    for (size_t i = 0; i < n; i++) {
        dxdt[i] = c->g[n + 1 + i];
        dxdt[n + i] = -c->g[i];
    }
    return GSL_SUCCESS;
}

static int gsl_jac(double t, const double x[], double *dfdy, double dfdt[], void *params)
{
    gsl_ctx *c = params;
    size_t n = c->n, d = 2 * n + 1, m = 2 * n;
    to_full(n, x, t, c->y);
    if (dth_model_eval(c->m, c->y, DTH_EVAL_GRAD | DTH_EVAL_HESS, NULL, c->g, c->hess)) return GSL_EBADFUNC;
    const double *Hs = c->hess;
    for (size_t i = 0; i < n; i++) {
        for (size_t k = 0; k < n; k++) {
            dfdy[i * m + k] = Hs[(n + 1 + i) * d + k];
            dfdy[i * m + n + k] = Hs[(n + 1 + i) * d + n + 1 + k];
            dfdy[(n + i) * m + k] = -Hs[i * d + k];
            dfdy[(n + i) * m + n + k] = -Hs[i * d + n + 1 + k];
        }
        dfdt[i] = Hs[(n + 1 + i) * d + n];
        dfdt[n + i] = -Hs[i * d + n];
    }
    return GSL_SUCCESS;
}

static const gsl_odeiv2_step_type *gsl_type(const char *name)
{
    if (!strcmp(name, "gsl-rk2imp")) return gsl_odeiv2_step_rk2imp;
    if (!strcmp(name, "gsl-rk4imp")) return gsl_odeiv2_step_rk4imp;
    if (!strcmp(name, "gsl-rk8pd")) return gsl_odeiv2_step_rk8pd;
    return NULL;
}

/* ---- one run ---- */

typedef struct record {
    const char *scene, *method;
    double param;       /* h, or the GSL tolerance */
    long steps;
    double cpu;         /* median CPU seconds of the bare run */
    double gerr;        /* global error at the last state against the reference at its time */
    double eerr;        /* largest |H - E0|: DTH at midpoints, others at their states */
    double eerr_vertex; /* DTH: largest |H - E0| at vertices (the O(h^2) offset); others = eerr */
    double ierr;        /* largest invariant deviation */
    int status;
} record;

typedef struct tracker {
    const scene *s;
    double E0, I0[16], Ibuf[16];
    size_t ni;
    record *r;
    FILE *ts;     /* time series of the energy error, or NULL */
    long ts_every;
} tracker;

static double energy(const dth_model *m, const double *y)
{
    double H = NAN;
    dth_model_eval(m, y, DTH_EVAL_H, &H, NULL, NULL);
    return H;
}

static void track(tracker *tk, const double *y, long k, int vertex_only)
{
    const dth_model *m = tk->s->m;
    double dE = fabs(energy(m, y) - tk->E0);
    if (vertex_only) {
        tk->r->eerr_vertex = fmax(tk->r->eerr_vertex, dE);
    } else {
        tk->r->eerr = fmax(tk->r->eerr, dE);
        tk->r->eerr_vertex = fmax(tk->r->eerr_vertex, dE);
        if (tk->ts && tk->ts_every > 0 && k % tk->ts_every == 0)
            fprintf(tk->ts, "%s,%s,%.10g,%.6e\n", tk->s->name, tk->r->method, y[tk->s->n], dE);
    }
}

/* The model's own state for its optional callbacks. */
static const void *self_of(const dth_model *m);

static void track_inv(tracker *tk, const double *y)
{
    if (!tk->ni) return;
    const dth_model_type *ty = dth_model_get_type(tk->s->m);
    if (ty->invariants(self_of(tk->s->m), y, tk->Ibuf)) return;
    for (size_t i = 0; i < tk->ni; i++) tk->r->ierr = fmax(tk->r->ierr, fabs(tk->Ibuf[i] - tk->I0[i]));
}

/* Reference solution at time t: the model's exact solution, else GSL rk8pd at tolerance 1e-13. */
static int reference(const scene *s, double t, double *y)
{
    const dth_model_type *ty = dth_model_get_type(s->m);
    size_t n = s->n;
    double y0[2 * MAXN + 1];
    double x[2 * MAXN];
    memcpy(x, s->q0, n * sizeof *x);
    memcpy(x + n, s->p0, n * sizeof *x);
    to_full(n, x, 0, y0);
    if (ty->exact) return ty->exact(self_of(s->m), y0, t, y);
    static gsl_ctx c; /* bench program: fine outside the library */
    c.m = s->m;
    c.n = n;
    gsl_odeiv2_system sys = {gsl_f, gsl_jac, 2 * n, &c};
    gsl_odeiv2_driver *dr = gsl_odeiv2_driver_alloc_y_new(&sys, gsl_odeiv2_step_rk8pd, 1e-3, 1e-13, 1e-13);
    double tt = 0;
    int rc = gsl_odeiv2_driver_apply(dr, &tt, t, x);
    gsl_odeiv2_driver_free(dr);
    to_full(n, x, t, y);
    return rc;
}

static double state_error(const scene *s, const double *y)
{
    double ye[2 * MAXN + 1], e = 0;
    size_t n = s->n;
    if (reference(s, y[n], ye)) return NAN;
    for (size_t j = 0; j < 2 * n + 1; j++)
        if (j != n) e = fmax(e, fabs(y[j] - ye[j]));
    return e;
}

/*
 * Run `method` on scene s to time T with step (or tolerance) `param`. diag: track errors into r
 * (and the time series if tk->ts); otherwise just integrate (the timed run). Returns the status.
 */
static int run(const scene *s, const char *method, double param, double T, int diag, tracker *tk, long *steps_out,
               double *y_end)
{
    size_t n = s->n, d = 2 * n + 1;
    int rc = DTH_OK;
    long k = 0;
    if (!strcmp(method, "dth")) {
        dth_options o;
        dth_options_default(&o);
        o.h = param;
        dth_regularizer *rg = NULL;
        if (s->reg) { /* a fresh instance per run: it fixes its constants at its first step */
            const dth_regularizer_type *rt = !strcmp(s->reg, "prescribed") ? &dth_reg_prescribed : NULL;
            if (!rt || dth_regularizer_new(rt, s->rkv, s->nrkv, s->m, NULL, &rg, NULL, 0)) return DTH_EINVAL;
            o.regularizer = rg;
            o.branch_check = 0; /* every ordinary step is replaced: no root search for it */
        }
        dth_integrator *it;
        if (dth_integrator_new(s->m, &o, &it) || dth_integrator_start(it, s->q0, s->p0, 0)) return DTH_EINVAL;
        const double *z = dth_integrator_vertex(it);
        while (z[n] < T * (1 - 1e-12)) {
            dth_step_info inf;
            rc = dth_integrator_step(it, &inf);
            if (rc) break;
            k++;
            if (diag) {
                track(tk, dth_integrator_midpoint(it), k, 0);
                track(tk, z, k, 1);
                track_inv(tk, z);
                if (tk->ts && tk->ts_every < 0) fprintf(tk->ts, "%s,%.10g,%.10g\n", s->name, z[n], inf.lambda);
            }
        }
        memcpy(y_end, z, d * sizeof *z);
        dth_integrator_free(it);
        dth_regularizer_free(rg);
    } else if (gsl_type(method)) {
        static gsl_ctx c;
        c.m = s->m;
        c.n = n;
        gsl_odeiv2_system sys = {gsl_f, gsl_jac, 2 * n, &c};
        /* the implicit steppers need a driver attached (their Newton uses its limits) */
        gsl_odeiv2_driver *dr = gsl_odeiv2_driver_alloc_y_new(&sys, gsl_type(method), 1e-3, param, param);
        gsl_odeiv2_step *st = dr->s;
        gsl_odeiv2_control *ct = dr->c;
        gsl_odeiv2_evolve *ev = dr->e;
        double x[2 * MAXN], t = 0, h = 1e-3, y[2 * MAXN + 1];
        memcpy(x, s->q0, n * sizeof *x);
        memcpy(x + n, s->p0, n * sizeof *x);
        while (t < T) {
            if (gsl_odeiv2_evolve_apply(ev, ct, st, &sys, &t, T, &h, x) != GSL_SUCCESS) {
                rc = DTH_ENOCONV;
                break;
            }
            k++;
            if (diag) {
                to_full(n, x, t, y);
                track(tk, y, k, 0);
                track_inv(tk, y);
            }
        }
        to_full(n, x, t, y_end);
        gsl_odeiv2_driver_free(dr);
    } else {
        long N = lround(T / param);
        dth_integrator *f = NULL;
        rc = bench_baseline(s->m, method, T / (double)N, s->q0, s->p0, &f);
        if (rc && f) dth_integrator_free(f);
        if (rc) return rc;
        for (k = 0; !rc && k < N;) {
            rc = dth_integrator_step(f, NULL);
            if (rc) break;
            k++;
            if (diag) {
                track(tk, dth_integrator_vertex(f), k, 0);
                track_inv(tk, dth_integrator_vertex(f));
            }
        }
        memcpy(y_end, dth_integrator_vertex(f), d * sizeof *y_end);
        dth_integrator_free(f);
    }
    *steps_out = k;
    return rc;
}

/* Measure one (scene, method, param): a diagnostic run, then the median of timed bare runs. */
static void measure(scene *s, const char *method, double param, int reps, record *r, FILE *ts, long ts_every,
                    double T)
{
    tracker tk = {.s = s, .r = r, .ts = ts, .ts_every = ts_every};
    double y[2 * MAXN + 1], x[2 * MAXN];
    memset(r, 0, sizeof *r);
    r->scene = s->name;
    r->method = method;
    r->param = param;
    memcpy(x, s->q0, s->n * sizeof *x);
    memcpy(x + s->n, s->p0, s->n * sizeof *x);
    to_full(s->n, x, 0, y);
    tk.E0 = energy(s->m, y);
    const dth_model_type *ty = dth_model_get_type(s->m);
    if (ty->invariants && ty->n_invariants) {
        tk.ni = ty->n_invariants(self_of(s->m));
        if (tk.ni > 16) tk.ni = 16;
        ty->invariants(self_of(s->m), y, tk.I0);
    }
    r->status = run(s, method, param, T, 1, &tk, &r->steps, y);
    r->gerr = state_error(s, y);
    double t[16];
    long k;
    if (reps > 16) reps = 16;
    for (int i = 0; i < reps; i++) {
        double t0 = cpu_now();
        run(s, method, param, T, 0, NULL, &k, y);
        t[i] = cpu_now() - t0;
    }
    qsort(t, (size_t)reps, sizeof *t, cmp_double);
    r->cpu = t[reps / 2];
}

/* ---- the model's self pointer: dth__model_self is internal; reach it through a tiny shim ---- */
const void *dth__model_self(const dth_model *m);
static const void *self_of(const dth_model *m) { return dth__model_self(m); }

/* ---- headline helpers ---- */

/* log-log interpolation of y at x over the records of (scene, method) sorted by x; NAN outside. */
static double interp(const record *R, size_t nr, const char *sname, const char *method, double xq, int xkind,
                     int ykind)
{
    double xs[64], ys[64];
    size_t m = 0;
    for (size_t i = 0; i < nr && m < 64; i++) {
        if (strcmp(R[i].scene, sname) || strcmp(R[i].method, method) || R[i].status) continue;
        double xv = xkind == 0 ? R[i].gerr : R[i].cpu;
        double yv = ykind == 0 ? R[i].cpu : R[i].eerr;
        if (!(xv > 0) || !(yv > 0)) continue;
        xs[m] = log(xv);
        ys[m] = log(yv);
        m++;
    }
    double lx = log(xq);
    for (size_t i = 0; i < m; i++)
        for (size_t j = 0; j < m; j++) {
            if (i == j) continue;
            double a = xs[i], b = xs[j];
            if (!(a <= lx && lx <= b)) continue;
            int closest = 1; /* neighbours: no other x strictly between */
            for (size_t l = 0; l < m; l++)
                if (xs[l] > a && xs[l] < b) closest = 0;
            if (!closest) continue;
            double w = b > a ? (lx - a) / (b - a) : 0;
            return exp(ys[i] + w * (ys[j] - ys[i]));
        }
    return NAN;
}

static int mkdir_p(const char *dir)
{
    if (mkdir(dir, 0777) && errno != EEXIST) return -1;
    return 0;
}

static const char *const methods_all[] = {"dth", "midpoint", "gauss4", "rk4", "verlet", "midpoint-proj",
                                          "gsl-rk2imp", "gsl-rk4imp", "gsl-rk8pd"};
enum { NMETH = sizeof methods_all / sizeof methods_all[0] };

static int is_gsl(const char *m) { return gsl_type(m) != NULL; }

int main(int argc, char **argv)
{
    int full = 0;
    const char *out = "bench-out";
    for (int i = 1; i < argc; i++) {
        if (!strcmp(argv[i], "--full")) full = 1;
        else if (!strcmp(argv[i], "--out") && i + 1 < argc) out = argv[++i];
        else {
            fprintf(stderr, "usage: %s [--full] [--out DIR]\n", argv[0]);
            return 2;
        }
    }
    gsl_set_error_handler_off();
    if (mkdir_p(out)) {
        fprintf(stderr, "cannot create %s\n", out);
        return 1;
    }
    dth_registry *reg;
    if (dth_registry_new(NULL, &reg) || dth_registry_add_builtin(reg)) return 1;
    int reps = full ? 5 : 3;
    double amp = 1.0;
    static scene scenes[] = {
        {.name = "pendulum", .model = "pendulum", .n = 1, .T = 20,
         .h = {0.2, 0.1, 0.05, 0.025, 0.0125}, .tol = {1e-4, 1e-6, 1e-8, 1e-10}},
        {.name = "harmonic", .model = "harmonic", .n = 1, .q0 = {1}, .T = 20,
         .h = {0.2, 0.1, 0.05, 0.025, 0.0125}, .tol = {1e-4, 1e-6, 1e-8, 1e-10}},
        {.name = "kepler06", .model = "kepler", .n = 2, .q0 = {0.4, 0}, .T = 100,
         .h = {0.04, 0.02, 0.01, 0.005, 0.0025}, .tol = {1e-6, 1e-8, 1e-10, 1e-12}},
        {.name = "kepler09", .model = "kepler", .n = 2, .q0 = {0.1, 0}, .T = 100,
         .h = {0.01, 0.005, 0.0025}, .tol = {1e-8, 1e-10, 1e-12},
         .reg = "prescribed", .rkv = {{"alpha", "0.75"}}, .nrkv = 1},
        {.name = "pendrot", .model = "pendulum", .n = 1, .T = 20,
         .h = {0.2, 0.1, 0.05, 0.025, 0.0125}, .tol = {1e-4, 1e-6, 1e-8, 1e-10},
         .reg = "prescribed", .rkv = {{"alpha", "0"}}, .nrkv = 1},
        {.name = "chain100", .model = "coupled", .kv = {{"preset", "chain"}, {"size", "100"}, {"dim", "1"}}, .nkv = 3,
         .n = 100, .T = 5, .h = {0.1, 0.05, 0.025}, .tol = {1e-6, 1e-8, 1e-10}, .full_only = 1},
    };
    enum { NSCENE = sizeof scenes / sizeof scenes[0] };
    scenes[0].p0[0] = 2 * sin(amp / 2);
    scenes[2].p0[1] = 2.0;                 /* e = 0.6, a = 1 from pericentre */
    scenes[3].p0[1] = sqrt(1.9 / 0.1);     /* e = 0.9 */
    scenes[4].p0[0] = 2.2;                  /* rotating pendulum: psi = 0 twice per revolution */
    for (size_t i = 0; i < 100; i++) scenes[5].q0[i] = (double)i + 0.1 * sin(2 * 3.14159265358979323846 * (double)i / 100);

    char path[1024];
    snprintf(path, sizeof path, "%s/wp.csv", out);
    FILE *wp = fopen(path, "w");
    snprintf(path, sizeof path, "%s/energy_time.csv", out);
    FILE *et = fopen(path, "w");
    snprintf(path, sizeof path, "%s/steps.csv", out);
    FILE *sc = fopen(path, "w");
    if (!wp || !et || !sc) {
        fprintf(stderr, "cannot write into %s\n", out);
        return 1;
    }
    fprintf(wp, "scene,method,param,steps,cpu_s,global_err,energy_err,energy_err_vertex,inv_err,status\n");
    fprintf(et, "scene,method,t,energy_err\n");
    fprintf(sc, "scene,t,lambda\n");

    static record R[MAXREC];
    size_t nr = 0;
    printf("dth work-precision benchmark (%s mode); CPU seconds are medians of %d runs\n", full ? "full" : "quick", reps);
    printf("%-9s %-13s %9s %8s %10s %10s %10s %10s %10s %s\n", "scene", "method", "h/tol", "steps", "cpu_s",
           "glob_err", "E_err", "E_err_vtx", "inv_err", "status");
    for (size_t si = 0; si < NSCENE; si++) {
        scene *s = &scenes[si];
        const dth_model_type *ty = dth_registry_find_model(reg, s->model);
        if (!ty) {
            printf("%-9s (model '%s' not built: skipped)\n", s->name, s->model);
            continue;
        }
        if (s->full_only && !full) {
            printf("%-9s (--full only)\n", s->name);
            continue;
        }
        char err[256];
        if (dth_model_new(ty, s->kv, s->nkv, s->n, NULL, &s->m, err, sizeof err)) {
            printf("%-9s cannot create model: %s\n", s->name, err);
            continue;
        }
        for (size_t mi = 0; mi < NMETH; mi++) {
            const char *meth = methods_all[mi];
            if (strcmp(meth, "dth") && !is_gsl(meth) && bench_method_check(s->m, meth)) continue;
            if (s->n >= 50 && (!strcmp(meth, "gauss4") || !strcmp(meth, "gsl-rk4imp") || !strcmp(meth, "gsl-rk2imp")))
                continue; /* dense stage systems of size >= 200: minutes, not seconds */
            const double *par = is_gsl(meth) ? s->tol : s->h;
            for (int pi = 0; pi < 8 && par[pi] > 0 && nr < MAXREC; pi++) {
                /* rk2imp at tight tolerances takes ~1e5-1e6 steps: --full only */
                if (!full && !strcmp(meth, "gsl-rk2imp") && par[pi] < 1e-9) continue;
                record *r = &R[nr++];
                measure(s, meth, par[pi], reps, r, NULL, 1, s->T);
                fprintf(wp, "%s,%s,%.6g,%ld,%.6e,%.6e,%.6e,%.6e,%.6e,%s\n", r->scene, r->method, r->param, r->steps,
                        r->cpu, r->gerr, r->eerr, r->eerr_vertex, r->ierr, dth_status_name(r->status));
                printf("%-9s %-13s %9.3g %8ld %10.3e %10.3e %10.3e %10.3e %10.3e %s\n", r->scene, r->method, r->param,
                       r->steps, r->cpu, r->gerr, r->eerr, r->eerr_vertex, r->ierr,
                       r->status ? dth_status_name(r->status) : "");
            }
        }
    }
    printf("DTH on kepler09 and pendrot (the rotating pendulum) runs with the 'prescribed' regularizer across psi = 0\n");

    /* ---- time series: energy error against time, DTH step size against time ---- */
    scene *kep = &scenes[2], *pen = &scenes[0], *k9 = &scenes[3];
    double Tlong = full ? 10000 : 1000;
    const char *ts_methods[] = {"dth", "midpoint", "gauss4", "rk4", "verlet", "midpoint-proj"};
    for (size_t i = 0; kep->m && i < sizeof ts_methods / sizeof ts_methods[0]; i++) {
        record r;
        measure(kep, ts_methods[i], 0.01, 1, &r, et, full ? 1000 : 100, Tlong);
        printf("long run kepler06 T=%g h=0.01 %-13s max energy error %.3e, cpu %.2f s %s\n", Tlong, ts_methods[i],
               r.eerr, r.cpu, r.status ? dth_status_name(r.status) : "");
    }
    for (int which = 0; which < 3; which++) {
        scene *s = which == 0 ? pen : which == 1 ? kep : k9;
        if (!s->m) continue;
        record r;
        tracker tk = {.s = s, .r = &r, .ts = sc, .ts_every = -1};
        double y[2 * MAXN + 1];
        long k;
        memset(&r, 0, sizeof r);
        r.method = "dth";
        int rc = run(s, "dth", which == 0 ? 0.1 : 0.01, which == 0 ? 20 : 20, 1, &tk, &k, y);
        if (rc) printf("step-size series %s: DTH stopped at t = %.6g after %ld steps: %s\n", s->name, y[s->n], k,
                       dth_strerror(rc));
    }

    /* ---- headline ratios ---- */
    printf("\nheadline ratios (each from quantities measured side by side in this run)\n");
    /* (a) DTH cost per step / GSL rk2imp cost per step, fixed h (step + its error estimate for GSL) */
    for (int which = 0; which < 2; which++) {
        scene *s = which == 0 ? pen : kep;
        if (!s->m) continue;
        double h = 0.01, T = which == 0 ? 20 : 10, td[7], tg[7];
        long nd = 0, ng = 0;
        for (int rep = 0; rep < 7; rep++) {
            double y[2 * MAXN + 1], t0 = cpu_now();
            run(s, "dth", h, T, 0, NULL, &nd, y);
            td[rep] = cpu_now() - t0;
            static gsl_ctx c;
            c.m = s->m;
            c.n = s->n;
            gsl_odeiv2_system sys = {gsl_f, gsl_jac, 2 * s->n, &c};
            gsl_odeiv2_driver *dr = gsl_odeiv2_driver_alloc_y_new(&sys, gsl_odeiv2_step_rk2imp, h, 1e-6, 1e-6);
            gsl_odeiv2_step *st = dr->s;
            double x[2 * MAXN], xe[2 * MAXN], t = 0;
            memcpy(x, s->q0, s->n * sizeof *x);
            memcpy(x + s->n, s->p0, s->n * sizeof *x);
            t0 = cpu_now();
            for (ng = 0; t < T - 0.5 * h; ng++, t += h)
                if (gsl_odeiv2_step_apply(st, t, h, x, xe, NULL, NULL, &sys)) break;
            tg[rep] = cpu_now() - t0;
            gsl_odeiv2_driver_free(dr);
        }
        qsort(td, 7, sizeof *td, cmp_double);
        qsort(tg, 7, sizeof *tg, cmp_double);
        double cd = td[3] / (double)nd, cg = tg[3] / (double)ng;
        printf("(a) %-9s DTH %.3g us/step, GSL rk2imp %.3g us/step (fixed h = %g, incl. its step-doubling "
               "error estimate): ratio %.3f (target <= 2: %s)\n",
               s->name, 1e6 * cd, 1e6 * cg, h, cd / cg, cd / cg <= 2 ? "met" : "NOT met");
    }
    /* (b) Kepler e = 0.6, equal global error: DTH CPU / implicit midpoint CPU, at each DTH point */
    {
        double rs[16];
        int m = 0;
        for (size_t i = 0; i < nr; i++) {
            if (strcmp(R[i].scene, "kepler06") || strcmp(R[i].method, "dth") || R[i].status) continue;
            double tm = interp(R, nr, "kepler06", "midpoint", R[i].gerr, 0, 0);
            if (isfinite(tm) && m < 16) {
                rs[m++] = R[i].cpu / tm;
                printf("(b) kepler06 global error %.3g: DTH %.3g s, midpoint (interpolated) %.3g s, ratio %.3f\n",
                       R[i].gerr, R[i].cpu, tm, R[i].cpu / tm);
            }
        }
        if (m) {
            qsort(rs, (size_t)m, sizeof *rs, cmp_double);
            double med = rs[m / 2];
            printf("(b) median ratio DTH/midpoint at equal global error: %.3f (target <= 3: %s)\n", med,
                   med <= 3 ? "met" : "NOT met");
        } else {
            printf("(b) no overlap of error ranges: not measured\n");
        }
    }
    /* (c) equal CPU time: DTH energy error / best non-SEM energy error */
    for (int which = 0; which < 2; which++) {
        const char *sn = which == 0 ? "kepler06" : "pendulum";
        double worst = 0, worst_proj = 0;
        int m = 0;
        const char *rivals[] = {"midpoint", "gauss4", "rk4", "verlet", "gsl-rk2imp", "gsl-rk4imp", "gsl-rk8pd"};
        for (size_t i = 0; i < nr; i++) {
            if (strcmp(R[i].scene, sn) || strcmp(R[i].method, "dth") || R[i].status) continue;
            double best = INFINITY;
            const char *bm = "-";
            for (size_t j = 0; j < sizeof rivals / sizeof rivals[0]; j++) {
                double e = interp(R, nr, sn, rivals[j], R[i].cpu, 1, 1);
                if (e < best) {
                    best = e;
                    bm = rivals[j];
                }
            }
            double ep = interp(R, nr, sn, "midpoint-proj", R[i].cpu, 1, 1);
            double ed = fmax(R[i].eerr, 1e-300);
            if (isfinite(best)) {
                printf("(c) %-9s cpu %.3g s: DTH energy error %.3g (at midpoints), best non-SEM %s %.3g: ratio %.3g;"
                       " midpoint-proj %.3g\n", sn, R[i].cpu, R[i].eerr, bm, best, ed / best, ep);
                worst = fmax(worst, ed / best);
                if (isfinite(ep)) worst_proj = fmax(worst_proj, ed / ep);
                m++;
            }
        }
        if (m)
            printf("(c) %-9s largest ratio over the DTH points: %.3g (target <= 1e-4: %s); against midpoint-proj: %.3g\n",
                   sn, worst, worst <= 1e-4 ? "met" : "NOT met", worst_proj);
        else
            printf("(c) %-9s no CPU overlap: not measured\n", sn);
    }

    /* ---- long runs (--full): energy error bounded, no growth ---- */
    if (full) {
        struct { scene *s; double h; long steps; } L[] = {{pen, 0.1, 10000000L}, {kep, 0.01, 1000000L}};
        for (int i = 0; i < 2; i++) {
            scene *s = L[i].s;
            if (!s->m) continue;
            dth_options o;
            dth_options_default(&o);
            o.h = L[i].h;
            dth_integrator *it;
            if (dth_integrator_new(s->m, &o, &it) || dth_integrator_start(it, s->q0, s->p0, 0)) continue;
            double x[2 * MAXN], y[2 * MAXN + 1];
            memcpy(x, s->q0, s->n * sizeof *x);
            memcpy(x + s->n, s->p0, s->n * sizeof *x);
            to_full(s->n, x, 0, y);
            double E0 = energy(s->m, y), emax = 0;
            struct timespec w0, w1;
            clock_gettime(CLOCK_MONOTONIC, &w0);
            long k, dec = 1000;
            int rc = 0;
            printf("long run %s DTH h=%g, %ld steps: max |E(midpoint) - E0| up to step", s->name, L[i].h, L[i].steps);
            for (k = 1; k <= L[i].steps; k++) {
                rc = dth_integrator_step(it, NULL);
                if (rc) break;
                if ((k & 63) == 0) emax = fmax(emax, fabs(energy(s->m, dth_integrator_midpoint(it)) - E0));
                if (k == dec) {
                    printf(" %ld: %.2e;", k, emax);
                    dec *= 10;
                }
            }
            clock_gettime(CLOCK_MONOTONIC, &w1);
            printf(" t_end = %.6g, wall %.1f s%s%s\n", dth_integrator_vertex(it)[s->n],
                   (double)(w1.tv_sec - w0.tv_sec) + 1e-9 * (double)(w1.tv_nsec - w0.tv_nsec),
                   rc ? ", stopped: " : "", rc ? dth_strerror(rc) : "");
            dth_integrator_free(it);
        }
    }
    fclose(wp);
    fclose(et);
    fclose(sc);
    for (size_t si = 0; si < NSCENE; si++) dth_model_free(scenes[si].m);
    dth_registry_free(reg);
    printf("CSV written to %s/ (wp.csv, energy_time.csv, steps.csv); plots: scripts/plot-wp.sh %s\n", out, out);
    return 0;
}
