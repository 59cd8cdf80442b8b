/* SPDX-License-Identifier: MIT */
/*
 * Output formats of dth run's tables (the trajectory and the events): each is one file with one
 * entry of this type (CSV: csvout.c, HDF5: h5out.c) listed in run_rows.c's table, and chosen by
 * the output file's name. Adding a format touches nothing else.
 */
#ifndef DTH_CLI_OUTFMT_H
#define DTH_CLI_OUTFMT_H

struct run_out;

typedef struct out_format {
    const char *name;          /* in messages: "CSV", "HDF5" */
    const char *const *ext;    /* the file name endings that choose it (NULL-terminated) */
    int events_in_file;        /* 1: the events are the table /events of the output, not a file of their own */
    int resumable;             /* 1: checkpoints can continue it (its bytes so far are hashed and copied) */
    /* Open the output path (NULL: standard output) and, when r->has_ev, the events file ev_path;
     * argc/argv: the command line (provenance). 0, or the exit status (printed). */
    int (*open)(struct run_out *r, const char *path, const char *ev_path, int argc, char **argv);
    /* The tables' headers, for a fresh run (a resume copies them with its rows). 0 or -1. */
    int (*header)(struct run_out *r);
    /* One row of the trajectory (ev = 0) or the events table (ev = 1): a value per column of the
     * kinds r->kind / r->ekind (run_out.h). 0 or -1. */
    int (*row)(struct run_out *r, int ev, const double *v);
    /* Put the finished output in place. 0, or -1 (printed). */
    int (*finish)(struct run_out *r);
    /* Report the output that failed to be written (path NULL: standard output) and drop it. */
    void (*failed)(struct run_out *r, const char *path, const char *ev_path);
    /* Remove what is not finished (except temporaries a checkpoint keeps) and release the format's state. */
    void (*release)(struct run_out *r);
} out_format;

extern const out_format cli_format_csv;  /* csvout.c */
extern const out_format cli_format_hdf5; /* h5out.c */

#endif
