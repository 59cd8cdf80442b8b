/* SPDX-License-Identifier: MIT */
/* dth run's internals: the state the run driver's callbacks share; rows (run_rows.c), resume (run_resume.c). */
#ifndef DTH_CLI_RUN_OUT_H
#define DTH_CLI_RUN_OUT_H

#include <stddef.h>
#include "cli.h"
#include "ckpt.h"
#include "h5out.h"

/* At most this many rows within one step (output.dt far below the step: a full disk, not a trajectory). */
enum { MAX_SAMPLES_PER_STEP = 1000000 };

/* One dth run: its scene and setup, the outputs (CSV or HDF5, events), checkpoint and progress
 * state; the `user` of the run driver's callbacks. */
typedef struct run_out {
    const dth_run_setup *rs;
    const dth_model *model;
    size_t n, N, ninv;
    double *inv, *work;
    char *line;
    size_t linecap, len;
    cli_out out;
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
    long step_k, step_samples; /* samples within the current step (bounded) */
    int too_many;
    cli_out ev;            /* event rows ([events]) */
    int has_ev;
    double *vals;          /* one row's values */
    unsigned char *kind, *ekind; /* column kinds of the trajectory and events tables */
    size_t ncol, encol;
    h5file *h5;            /* HDF5 output instead of CSV */
    h5table *h5traj, *h5ev;
    int check_wp;          /* an explicit wp: compare the first step it encodes with h */
    int vk_set, vk_leg;    /* vertex_K's last value vk: of the step vk_k of leg vk_leg */
    long vk_k;
    double vk;
} run_out;

/* Column names of the trajectory (ev = 0) or the events table (ev = 1), comma-separated, in r->line. */
void run_column_names(run_out *r, int ev);
/* The kind of each column: how the CSV prints its value. */
void run_column_kinds(run_out *r, int ev, unsigned char *kind, size_t *ncol);
/* The header line of the trajectory's CSV and of the events' (nothing for HDF5). 0 or -1. */
int run_header(run_out *r);
int run_ev_header(run_out *r);
/* The driver's sample callback: one row per sample. */
int run_on_sample(void *user, const dth_sample *s);
/* The driver's event callback: one row per located event in the events table. */
int run_on_event(void *user, const dth_sample *s);

/* (run_resume.c) The driver's checkpoint callback: a checkpoint (cli/ckpt.c) every checkpoint_every
 * steps and at the end, after the rows so far are on disk. From the first one on, the temporaries
 * it names are kept if the run fails. */
int run_on_checkpoint(void *user, const dth_run_state *st);
/* Remove the temporaries that killed runs left next to the outputs and the checkpoint, and next to
 * the outputs a resumed checkpoint names (c may be NULL). */
void run_clean_stale(const char *path, const char *ev_path, const char *ckpt_path, const cli_ckpt *c);
/* The rows the checkpointed run c had made final, into the new outputs: from its temporary file if
 * it was killed (or failed), else from the file it finished; the bytes must hash as recorded. 0 or
 * -1 (printed). */
int run_resume_prefix(run_out *r, const cli_ckpt *c, const char *ckpt, const char *ev_path);

#endif
