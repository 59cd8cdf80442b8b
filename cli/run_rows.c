/* SPDX-License-Identifier: MIT */
/*
 * dth run's rows: the column names and kinds of the trajectory and events tables, one row per
 * sample of the run driver (state, energy, diagnostics psi, psi', region and branch), formatted
 * as CSV or appended to an HDF5 table; the output files opened (HDF5 with the scene and provenance
 * as attributes), finished, or removed after a failure.
 */
#include <math.h>
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include "fmt.h"
#include "run_out.h"

/* How a column is printed in CSV (HDF5 stores every column as a double: codes for the names). */
enum { COL_DBL = 0, COL_INT, COL_REGION, COL_BRANCH, COL_EVENT };

static void put(run_out *r, const char *fmt, ...) __attribute__((format(printf, 2, 3)));
static void put(run_out *r, const char *fmt, ...)
{
    va_list ap;
    va_start(ap, fmt);
    int w = vsnprintf(r->line + r->len, r->linecap - r->len, fmt, ap);
    va_end(ap);
    if (w > 0) r->len += (size_t)w;
    if (r->len >= r->linecap) r->len = r->linecap - 1; /* cannot happen: linecap is sized for the row */
}

/* Column names of the trajectory (ev = 0) or the events table (ev = 1), comma-separated, in r->line. */
static void column_names(run_out *r, int ev)
{
    r->len = 0;
    put(r, ev ? "i,event,direction,k,t" : "k,t,lambda");
    for (size_t i = 0; i < r->n; i++) put(r, ",q%zu", i + 1);
    for (size_t i = 0; i < r->n; i++) put(r, ",p%zu", i + 1);
    put(r, ",wp,H,E");
    if (!ev && r->rs->regularizer) put(r, ",ordinary"); /* 1: an ordinary (symplectic) DTH step, 0: a regularizer's */
    if (!ev && r->rs->diagnostics) {
        for (size_t i = 0; i < r->ninv; i++) put(r, ",%s", dth_model_invariant_name(r->model, i));
        put(r, ",psi,dpsi,region,iters,branch");
    }
    if (!ev && r->leg) put(r, ",leg");
}

/* The kind of each column: how the CSV prints its value. */
static void column_kinds(run_out *r, int ev, unsigned char *kind, size_t *ncol)
{
    size_t c = 0, n = r->n;
    if (ev) {
        kind[c++] = COL_INT, kind[c++] = COL_EVENT, kind[c++] = COL_INT, kind[c++] = COL_INT;
    } else {
        kind[c++] = COL_INT;
    }
    kind[c++] = COL_DBL; /* t */
    if (!ev) kind[c++] = COL_DBL; /* lambda */
    for (size_t i = 0; i < 2 * n + 3; i++) kind[c++] = COL_DBL; /* q, p, wp, H, E */
    if (!ev && r->rs->regularizer) kind[c++] = COL_INT;   /* ordinary */
    if (!ev && r->rs->diagnostics) {
        for (size_t i = 0; i < r->ninv + 2; i++) kind[c++] = COL_DBL;
        kind[c++] = COL_REGION, kind[c++] = COL_INT, kind[c++] = COL_BRANCH;
    }
    if (!ev && r->leg) kind[c++] = COL_INT;
    *ncol = c;
}

/* Write the values v (columns of the given kinds) as one CSV line, or one HDF5 row. */
static int emit_row(run_out *r, int ev, const double *v)
{
    if (r->h5) return h5_row(ev ? r->h5ev : r->h5traj, v) ? -1 : 0;
    const unsigned char *kind = ev ? r->ekind : r->kind;
    size_t ncol = ev ? r->encol : r->ncol;
    char *p = r->line;
    for (size_t c = 0; c < ncol; c++) {
        if (c) *p++ = ',';
        switch (kind[c]) {
        case COL_INT: p += dth_fmt_long((long)v[c], p); break;
        case COL_DBL: p += dth_fmt_g17(v[c], p); break;
        default: {
            const char *s = kind[c] == COL_REGION ? dth_region_name((dth_region)v[c])
                            : kind[c] == COL_BRANCH ? dth_branch_name((dth_branch)v[c])
                                                    : r->rs->event_names[(size_t)v[c]];
            size_t l = strlen(s);
            memcpy(p, s, l);
            p += l;
        }
        }
    }
    return cli_out_line(ev ? &r->ev : &r->out, r->line, (size_t)(p - r->line));
}

static int header(run_out *r)
{
    column_names(r, 0);
    return r->h5 ? 0 : cli_out_line(&r->out, r->line, r->len);
}

/* The columns q, p, wp, H, E of the extended state z into v; returns how many. */
static size_t state_columns(const run_out *r, const double *z, double *v)
{
    size_t n = r->n, N = r->N, c = 0;
    double Hp;
    if (dth_model_eval(r->model, z, DTH_EVAL_H, &Hp, NULL, NULL) != DTH_OK) Hp = NAN;
    for (size_t i = 0; i < n; i++) v[c++] = z[i];
    for (size_t i = 0; i < n; i++) v[c++] = z[n + 1 + i];
    v[c++] = z[N - 1];
    v[c++] = z[N - 1] + Hp;
    v[c++] = Hp;
    return c;
}

/*
 * One row at the point z. `in` is the step that arrived there (or the step whose segment holds
 * it); lambda_root a known root of the step constraint at z (for the local K estimate) and K a
 * fixed K (> 0) or 0.
 */
static int row(run_out *r, long k, const double *z, const dth_step_info *in, double lambda_root, double K)
{
    size_t c = 0;
    double *v = r->vals;
    v[c++] = (double)k;
    v[c++] = z[r->n];
    v[c++] = in->lambda;
    c += state_columns(r, z, v + c);
    if (r->rs->regularizer) v[c++] = (in->flags & DTH_STEP_REGULARIZED) ? 0 : 1;
    if (r->rs->diagnostics) {
        if (r->ninv && dth_model_invariants(r->model, z, r->inv) != DTH_OK)
            for (size_t i = 0; i < r->ninv; i++) r->inv[i] = NAN;
        for (size_t i = 0; i < r->ninv; i++) v[c++] = r->inv[i];
        dth_diag d;
        if (dth_diagnose(r->model, z, lambda_root, K, &d, r->work) != DTH_OK) {
            d.psi = d.dpsi = NAN;
            d.region = DTH_REGION_NONE;
        }
        v[c++] = d.psi;
        v[c++] = d.dpsi;
        v[c++] = (double)d.region;
        v[c++] = (double)in->iters;
        v[c++] = (double)in->branch;
    }
    if (r->leg) v[c++] = r->leg;
    return emit_row(r, 0, v);
}

/* K that a vertex's diagnostics use: for rows interpolated inside its outgoing segment, the step
 * k (z its start, lambda_out its length); computed once for all the rows of one step. */
static double vertex_K(run_out *r, long k, const double *z, double lambda_out)
{
    if (!r->vk_set || r->vk_k != k || r->vk_leg != r->leg) {
        dth_diag d;
        r->vk = dth_diagnose(r->model, z, lambda_out, r->rs->opt.K, &d, r->work) != DTH_OK ? 0 : d.K;
        r->vk_set = 1;
        r->vk_k = k;
        r->vk_leg = r->leg;
    }
    return r->vk;
}

/* The driver's sample callback: one row per sample. */
int run_on_sample(void *user, const dth_sample *s)
{
    run_out *r = user;
    /* a stop request, also between the samples of one step (dense output can hold many) */
    if ((r->sig = cli_signal_received()) != 0) return DTH_ESTOPPED;
    if (r->check_wp && s->k == 0) {
        double lam = s->kind == DTH_SAMPLE_VERTEX ? s->lambda_out : s->za ? s->step->lambda : 0;
        if (lam != 0) {
            r->check_wp = 0;
            if (fabs(lam / r->rs->opt.h - 1) > 0.1)
                cli_error("warning: the explicit [initial] wp encodes a first step of %.6g, not h = %.6g (without wp a "
                          "vertex start solves for the wp whose first step is h)", lam, r->rs->opt.h);
        }
    }
    long k = s->kind == DTH_SAMPLE_TIME || (s->kind == DTH_SAMPLE_END && r->rs->dt > 0) ? s->index : s->k;
    double lambda_root = 0, K = r->rs->opt.K;
    if (s->kind == DTH_SAMPLE_VERTEX) lambda_root = s->lambda_out;
    else if (!s->za) lambda_root = -s->step->lambda; /* the end is the last vertex itself */
    else if (s->kind != DTH_SAMPLE_MIDPOINT && r->rs->diagnostics) K = vertex_K(r, s->k, s->za, s->step->lambda);
    else if (s->kind == DTH_SAMPLE_MIDPOINT) lambda_root = 0;
    if (row(r, k, s->z, s->step, lambda_root, K)) return DTH_EIO;
    if (!r->h5) cli_out_maybe_flush(&r->out);
    return 0;
}

/* The driver's event callback: one row per located event in the events table. */
int run_on_event(void *user, const dth_sample *s)
{
    run_out *r = user;
    size_t c = 0;
    double *v = r->vals;
    v[c++] = (double)s->index;
    v[c++] = (double)s->event;
    v[c++] = s->direction;
    v[c++] = (double)s->k;
    v[c++] = s->z[r->n];
    state_columns(r, s->z, v + c);
    if (emit_row(r, 1, v)) return DTH_EIO;
    if (!r->h5) cli_out_maybe_flush(&r->ev);
    return 0;
}

static int ev_header(run_out *r)
{
    column_names(r, 1);
    return r->h5 ? 0 : cli_out_line(&r->ev, r->line, r->len);
}

int run_headers(run_out *r) { return header(r) || (r->has_ev && ev_header(r)); }

/* ---------------------------------------------------------------- setup and output files */

int run_rows_init(run_out *r, const dth_run_setup *rs, int leg)
{
    r->rs = rs;
    r->model = rs->model;
    r->n = rs->n;
    r->N = 2 * rs->n + 2;
    r->leg = leg;
    r->ninv = dth_model_n_invariants(rs->model);
    r->linecap = 32 * (r->N + r->ninv + 8) + 64;
    for (size_t i = 0; i < r->ninv; i++) r->linecap += strlen(dth_model_invariant_name(rs->model, i)) + 1;
    r->line = malloc(r->linecap);
    r->inv = calloc(r->ninv + 1, sizeof *r->inv);
    r->work = calloc(dth_model_work_size(rs->model), sizeof *r->work);
    size_t maxcol = 2 * r->N + r->ninv + 16;
    r->vals = calloc(maxcol, sizeof *r->vals);
    r->kind = calloc(maxcol, 1);
    r->ekind = calloc(maxcol, 1);
    if (!r->line || !r->inv || !r->work || !r->vals || !r->kind || !r->ekind) return -1;
    column_kinds(r, 0, r->kind, &r->ncol);
    column_kinds(r, 1, r->ekind, &r->encol);
    return 0;
}

/* "dth VERSION; command: dth ARGS..." (malloc'd; NULL: out of memory). */
static char *provenance(int argc, char **argv)
{
    size_t cl = 64;
    for (int i = 0; i < argc; i++) cl += strlen(argv[i]) + 1;
    char *prov = malloc(cl);
    if (prov) {
        size_t k = (size_t)snprintf(prov, cl, "dth %s; command: dth", DTH_VERSION_STRING);
        for (int i = 0; i < argc; i++) k += (size_t)snprintf(prov + k, cl - k, " %s", argv[i]);
    }
    return prov;
}

/* The table /events and its attribute event_codes ("0 NAME, 1 NAME, ..."). 0 or -1. */
static int h5_events(run_out *r)
{
    const dth_run_setup *rs = r->rs;
    size_t nl = 8;
    for (size_t i = 0; i < rs->nevents; i++) nl += strlen(rs->event_names[i]) + 8;
    char *names = malloc(nl);
    if (!names) return -1;
    size_t k = 0;
    for (size_t i = 0; i < rs->nevents; i++)
        k += (size_t)snprintf(names + k, nl - k, "%s%zu %s", i ? ", " : "", i, rs->event_names[i]);
    column_names(r, 1);
    int hrc = h5_attr(r->h5, "event_codes", names) || !(r->h5ev = h5_table(r->h5, "events", r->encol, r->line));
    free(names);
    return hrc ? -1 : 0;
}

int run_h5_open(run_out *r, const char *path, int argc, char **argv)
{
    char herr[1200];
    size_t tl;
    char *text = NULL;
    if (dth_scene_text(r->scene, NULL, NULL, &text, &tl)) text = NULL;
    r->h5 = text ? h5_open(path, herr, sizeof herr) : NULL;
    if (!r->h5) {
        cli_error("%s", text ? herr : "out of memory");
        free(text);
        return CLI_USAGE;
    }
    /* provenance: the version and the command line; the scene as run */
    char *prov = provenance(argc, argv);
    column_names(r, 0);
    int hrc = !prov || h5_attr(r->h5, "scene", text) || h5_attr(r->h5, "provenance", prov) ||
              h5_attr(r->h5, "region_codes", "0 -, 1 I, 2 II, 3 III") ||
              h5_attr(r->h5, "branch_codes", "0 -, 1 minus, 2 plus, 3 ghost, 4 exact, 5 reg") ||
              !(r->h5traj = h5_table(r->h5, "trajectory", r->ncol, r->line));
    free(text);
    free(prov);
    if (!hrc && r->rs->nevents) hrc = h5_events(r);
    if (hrc) {
        cli_error("cannot write '%s': HDF5 error", path);
        h5_abort(r->h5);
        r->h5 = NULL;
        return CLI_FAIL;
    }
    return 0; /* rows go to HDF5; standard output stays empty */
}

int run_outputs_finish(run_out *r)
{
    if (!r->h5) return cli_out_finish(&r->out) || (r->has_ev && cli_out_finish(&r->ev)) ? -1 : 0;
    char herr[1200];
    int hrc = h5_finish(r->h5, herr, sizeof herr);
    r->h5 = NULL;
    if (hrc) cli_error("%s", herr);
    return hrc ? -1 : 0;
}

void run_outputs_failed(run_out *r, const char *path, const char *ev_path)
{
    if (r->h5) {
        cli_error("cannot write '%s' (HDF5)", path);
        h5_abort(r->h5);
        r->h5 = NULL;
    } else if (r->out.failed) cli_error("cannot write '%s': %s", path ? path : "standard output", strerror(r->out.err));
    else if (r->ev.failed) cli_error("cannot write '%s': %s", ev_path, strerror(r->ev.err));
}

void run_out_free(run_out *r)
{
    if (r->h5) h5_abort(r->h5);
    if (r->out.fd >= 0 && r->out.buf) cli_out_abort(&r->out);
    if (r->ev.fd >= 0 && r->ev.buf) cli_out_abort(&r->ev);
    free(r->vals);
    free(r->kind);
    free(r->ekind);
    free(r->line);
    free(r->inv);
    free(r->work);
}
