/* SPDX-License-Identifier: MIT */
/* dth run's internals: the state the run driver's callbacks share; rows (run_rows.c), resume (run_resume.c). */
#ifndef DTH_CLI_RUN_OUT_H
#define DTH_CLI_RUN_OUT_H

#include <stddef.h>
#include "cli.h"
#include "ckpt.h"
#include "outfmt.h"

/* How a column's values are written: numbers, or codes (CSV prints their names, run_code_name). */
enum { COL_DBL = 0, COL_INT, COL_REGION, COL_BRANCH, COL_EVENT };

/* One dth run: its scene and setup, the outputs (a format of outfmt.h; events), checkpoint and
 * progress state; the `user` of the run driver's callbacks. */
typedef struct run_out {
    const dth_run_setup *rs;
    const dth_model *model;
    size_t n, N, ninv;
    double *inv, *work;
    char *line;
    size_t linecap, len;
    const out_format *fmt; /* the output's format (outfmt.h) and its state */
    void *fmt_state;
    cli_out out;           /* CSV: the trajectory's file (also what checkpoints record) */
    int leg; /* --roundtrip: 1 forward, 2 return (a `leg` column); 0: no column */
    /* checkpoints and progress */
    const char *ckpt_path;
    const dth_scene *scene;
    dth_integrator *it;
    int progress;          /* 1: '\r' percentage on a terminal; 2: a line every few seconds */
    double t_start, last_progress, t_begin, progress_s;
    long k_begin;
    int sig;
    int ckpt_written, ckpt_failed; /* a checkpoint was written (at step ckpt_k); one failed */
    long ckpt_k;
    cli_out ev;            /* CSV: the events' file ([events]) */
    const char *out_origin, *ev_origin; /* where the scene set the output's, the events' name ("FILE:LINE:
                                           output.file"; NULL: the command line), for messages */
    int has_ev;
    double *vals;          /* one row's values */
    unsigned char *kind, *ekind; /* column kinds of the trajectory and events tables */
    size_t ncol, encol;
    int check_wp;          /* an explicit wp: compare the first step it encodes with h */
    int vk_set, vk_leg;    /* vertex_K's last value vk: of the step vk_k of leg vk_leg */
    long vk_k;
    double vk;
} run_out;

/* (run_rows.c) The row buffers and column kinds of the run rs; leg 1 adds the column leg
 * (--roundtrip). 0, or -1: out of memory. */
int run_rows_init(run_out *r, const dth_run_setup *rs, int leg);
/* The format of the output path, by its name's ending (CSV for other names and standard output). */
const out_format *run_format_for(const char *path);
/* The column names of the trajectory (ev = 0) or the events table (ev = 1), comma-separated (in
 * r->line, valid until the next row). */
const char *run_columns(run_out *r, int ev);
/* The name of code v in a column of kind COL_REGION, COL_BRANCH or COL_EVENT, and how many codes
 * the kind has (0 .. count-1). */
const char *run_code_name(const run_out *r, int kind, long v);
size_t run_code_count(const run_out *r, int kind);
/* The tables' headers (r->fmt's). 0 or -1. */
int run_headers(run_out *r);
/* The header line (without its newline) of the trajectory (ev = 0) or the events table, in r->line. */
void run_header_line(run_out *r, int ev, const char **line, size_t *len);
/* The driver's sample callback: one row per sample. */
int run_on_sample(void *user, const dth_sample *s);
/* The driver's event callback: one row per located event in the events table. */
int run_on_event(void *user, const dth_sample *s);
/* Open the outputs in r->fmt (path NULL: standard output; the events file ev_path when r->has_ev;
 * argc/argv for provenance): 0, or the exit status (printed). */
int run_outputs_open(run_out *r, const char *path, const char *ev_path, int argc, char **argv);
/* Put the finished outputs in place. 0, or -1 (printed). */
int run_outputs_finish(run_out *r);
/* Report the output that failed to be written (path: the trajectory's, NULL for standard output),
 * dropping what the format cannot keep. */
void run_outputs_failed(run_out *r, const char *path, const char *ev_path);
/* Remove the outputs not finished (but temporaries a checkpoint keeps) and free the buffers. */
void run_out_free(run_out *r);

/* (run_resume.c) The driver's checkpoint callback: a checkpoint (cli/ckpt.c) every checkpoint_every
 * steps and at the end, after the rows so far are on disk. From the first one on, the temporaries
 * it names are kept if the run fails. */
int run_on_checkpoint(void *user, const dth_run_state *st);
/* Remove the temporaries that killed runs left next to the outputs and the checkpoint, and next to
 * the checkpoint a resume read and the outputs it names (resume_path and c may be NULL). */
void run_clean_stale(const char *path, const char *ev_path, const char *ckpt_path, const char *resume_path,
                     const cli_ckpt *c);
/* The rows the checkpointed run c had made final, into the new outputs: from its temporary file if
 * it was killed (or failed), else from the file it finished; the bytes must hash as recorded and
 * be this run's header and one row per sample (event) of the run state. 0 or -1 (printed). */
int run_resume_prefix(run_out *r, const cli_ckpt *c, const char *ckpt, const char *ev_path);
/* The checkpoint of the start (or of the resumed state), written before the first step so a run
 * never learns only at its first checkpoint that it cannot write one: 0; 1: an output could not be
 * written; -1: the checkpoint could not (the outputs are removed: like an output that cannot be
 * written). */
int run_first_checkpoint(run_out *r, const dth_run_state *S);

/* What --resume reads: the checkpoint of a dth run. */
typedef struct run_resume {
    void *buf;        /* the checkpoint's bytes (for dth_checkpoint_restore) */
    size_t len;
    cli_ckpt c;       /* its "cli" blob: the run driver's state, the outputs' progress (cli/ckpt.c) */
    dth_scene *saved; /* the scene as the checkpointed run had it */
} run_resume;
/* Read the checkpoint `path`; load its scene into `scene` and into res->saved. 0, or a dth
 * status with the reason in err. Free with run_resume_clear (also after a failure). */
int run_resume_load(run_resume *res, const char *path, dth_scene *scene, char *err, size_t errlen);
void run_resume_clear(run_resume *res);

#endif
