/* SPDX-License-Identifier: MIT */
/*
 * dth run's rows: the column names and kinds of the trajectory and events tables, one row per
 * sample of the run driver (state, energy, diagnostics psi, psi', region and branch) handed to the
 * output format (outfmt.h: the table of formats is here; each writes, finishes or removes its files).
 */
#include <math.h>
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include "run_out.h"

/* The output formats; the first is the default (standard output, names no other format claims). */
static const out_format *const formats[] = {&cli_format_csv, &cli_format_hdf5};

const out_format *run_format_for(const char *path)
{
    size_t plen = path ? strlen(path) : 0;
    for (size_t i = 0; path && i < sizeof formats / sizeof *formats; i++)
        for (const char *const *e = formats[i]->ext; *e; e++) {
            size_t el = strlen(*e);
            if (plen > el && !strcmp(path + plen - el, *e)) return formats[i];
        }
    return formats[0];
}

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

const char *run_columns(run_out *r, int ev)
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
        /* 1: the step that arrived is its own reverse, 0: not (DTH_STEP_NONREVERSIBLE: a regularizer's offset
         * reset or clock correction, or an ordinary step kept by one that replaces every step) */
        if (r->rs->regularizer) put(r, ",reversible");
        if (r->rs->opt.estimate) put(r, ",err_q,err_p"); /* the estimated global error at the row */
    }
    if (!ev && r->leg) put(r, ",leg");
    return r->line;
}

const char *run_code_name(const run_out *r, int kind, long v)
{
    if (kind == COL_REGION) return dth_region_name((dth_region)v);
    if (kind == COL_BRANCH) return dth_branch_name((dth_branch)v);
    return r->rs->event_names[(size_t)v];
}

size_t run_code_count(const run_out *r, int kind)
{
    return kind == COL_REGION ? DTH_REGION_III + 1 : kind == COL_BRANCH ? DTH_BRANCH_REG + 1 : r->rs->nevents;
}

/* The kind of each column: a number, or a code the format may print by name. */
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
        if (r->rs->regularizer) kind[c++] = COL_INT; /* reversible */
        if (r->rs->opt.estimate) kind[c++] = COL_DBL, kind[c++] = COL_DBL;
    }
    if (!ev && r->leg) kind[c++] = COL_INT;
    *ncol = c;
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
 * fixed K (> 0) or 0; err the estimated global error |dq|, |dp| there (NaN without an estimate).
 */
static int row(run_out *r, long k, const double *z, const dth_step_info *in, double lambda_root, double K,
               const double err[2])
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
        if (r->rs->regularizer) v[c++] = (in->flags & DTH_STEP_NONREVERSIBLE) ? 0 : 1;
        if (r->rs->opt.estimate) v[c++] = err[0], v[c++] = err[1];
    }
    if (r->leg) v[c++] = r->leg;
    return r->fmt->row(r, 0, v);
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
    const double err[2] = {s->err_q, s->err_p};
    return row(r, k, s->z, s->step, lambda_root, K, err) ? DTH_EIO : 0;
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
    return r->fmt->row(r, 1, v) ? DTH_EIO : 0;
}

int run_headers(run_out *r) { return r->fmt->header(r); }

void run_header_line(run_out *r, int ev, const char **line, size_t *len)
{
    *line = run_columns(r, ev);
    *len = strlen(*line);
}

/* ---------------------------------------------------------------- setup and output files */

int run_rows_init(run_out *r, const dth_run_setup *rs, int leg)
{
    r->rs = rs;
    r->model = rs->model;
    r->n = rs->n;
    r->N = 2 * rs->n + 2;
    r->leg = leg;
    r->ninv = dth_model_n_invariants(rs->model);
    r->linecap = 32 * (r->N + r->ninv + 10) + 64; /* every column at most 25 characters, 2 n + ninv + 16 of them */
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

int run_outputs_open(run_out *r, const char *path, const char *ev_path, int argc, char **argv)
{
    return r->fmt->open(r, path, ev_path, argc, argv);
}

int run_outputs_finish(run_out *r) { return r->fmt->finish(r); }

void run_outputs_failed(run_out *r, const char *path, const char *ev_path) { r->fmt->failed(r, path, ev_path); }

void run_out_free(run_out *r)
{
    if (r->fmt) r->fmt->release(r);
    free(r->vals);
    free(r->kind);
    free(r->ekind);
    free(r->line);
    free(r->inv);
    free(r->work);
}
