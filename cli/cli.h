/* SPDX-License-Identifier: MIT */
/* The dth command-line tool: the subcommand table, exit codes and helpers shared by subcommands. */
#ifndef DTH_CLI_H
#define DTH_CLI_H

#include <stddef.h>
#include <stdio.h>
#include "dth/dth.h"

/* Exit codes (docs/user-guide.md). */
enum {
    CLI_OK = 0,       /* success */
    CLI_FAIL = 1,     /* hard error: a negative dth status, an I/O failure while writing */
    CLI_USAGE = 2,    /* bad command line or bad input (scene, override, unwritable output) */
    CLI_STOPPED = 3   /* the trajectory could not continue; the rows computed so far are kept */
};

/*
 * The subcommands: X(name, usage, summary). Adding one is one line here, a file
 * cli/cmd_<name>.c defining `int cli_cmd_<name>(int argc, char **argv)` (argv[0] is the
 * subcommand's name), and that file in cli/meson.build.
 */
#define CLI_COMMANDS(X)                                                                           \
    X(run, "SCENE.ini [-s section.key=value]... [-o FILE] [options below]",                      \
      "integrate a scene and write its trajectory as CSV (or HDF5: -o FILE.h5)")                  \
    X(models, "", "list the registered models, their parameters and defaults")                  \
    X(regularizers, "", "list the regularizers across psi = 0 ([regularize] method=), with parameters") \
    X(keys, "[--markdown] [SECTION]", "the scene keys: what each accepts, its default and meaning")  \
    X(roots, "SCENE.ini [-s section.key=value]... [--range L]",                                  \
      "every root of the step constraint at the initial vertex, classified (CSV)")               \
    X(map, "SCENE.ini --q a:b:n --p c:d:m [--dof i] [--range L] [--out PREFIX] [-s ...]",      \
      "phase-plane map of psi, [psi, H], regions and roots, plus the scene's trajectory (CSV)")     \
    X(sweep, "SCENE.ini (--vary section.key=a:b:n)... | --list FILE [-s ...] [-o FILE] [options]",  \
      "an ensemble: one run per grid point or list row, a summary row each (MEGNO, drifts); OpenMP, MPI")

#define CLI__DECL(name, usage, summary) int cli_cmd_##name(int argc, char **argv);
CLI_COMMANDS(CLI__DECL)
#undef CLI__DECL

/* The plural ending of a count: "%ld step%s", n, CLI_S(n). */
#define CLI_S(n) ((n) == 1 ? "" : "s")

/* "dth: " + message + newline on stderr. */
void cli_error(const char *fmt, ...) __attribute__((format(printf, 1, 2)));

/* Flush what stdio holds for standard output: CLI_OK, or CLI_FAIL after "cannot write 'standard
 * output': reason" (a full disk, a closed pipe). */
int cli_flush_stdout(void);

/* Print the usage of every subcommand to stdout or stderr. */
void cli_usage(int to_stderr);
/* The options of dth run (its --help; also part of dth --help). */
void cli_usage_run(FILE *f);

/* A registry with every built-in model (NULL after printing an error). */
dth_registry *cli_registry(void);

/*
 * Output of whole lines, written crash-safely (cli/outfile.c). A file is written to a temporary
 * of the run's own, FILE.tmp.PID.XXXXXX in the same directory, and renamed onto FILE by
 * cli_out_finish; lines are buffered and written whole (at most every 0.5 s, or when the buffer
 * fills), so the temporary file always ends at a line boundary. NULL path: standard output. An
 * existing non-regular FILE (a device such as /dev/null, a FIFO) is written in place. The bytes
 * written are counted and hashed (FNV-1a 64), for checkpoints.
 */
typedef struct cli_out {
    int fd;
    char *path, *tmp;     /* NULL for stdout */
    char *buf;
    size_t len, cap;
    double last_flush;    /* monotonic seconds */
    int direct;           /* path is a device or pipe: written in place, no rename */
    int failed;           /* a write failed (errno in err) */
    int err;
    int keep;             /* a checkpoint refers to the temporary: an abort leaves it */
    unsigned long long written; /* bytes handed to the file so far (buffered ones excluded) */
    unsigned long long hash;    /* FNV-1a 64 of those bytes */
} cli_out;

/* FNV-1a 64: the hash of no bytes, and h continued over n more bytes. */
#define CLI_FNV_OFFSET 14695981039346656037ULL
unsigned long long cli_fnv1a(unsigned long long h, const void *p, size_t n);

/* Open; on failure prints "dth: cannot write 'FILE': reason" and returns -1. */
int cli_out_open(cli_out *o, const char *path);
/* The same, naming where the path was set in the message ("ORIGIN: cannot write ..."; NULL: as
 * cli_out_open), such as "scene.ini:11: output.file". */
int cli_out_open_from(cli_out *o, const char *path, const char *origin);
/* Append one line (without its newline; it is added). Returns -1 after a write failure. */
int cli_out_line(cli_out *o, const char *line, size_t len);
/* Write out every buffered line and fsync a file: `written` is then on disk. -1 on failure. */
int cli_out_sync(cli_out *o);
/* cli_out_copy_prefix's failures */
enum { CLI_PREFIX_SHORT = -1, CLI_PREFIX_CHANGED = -2, CLI_PREFIX_WRITE = -3 };
/* Copy the first `bytes` bytes of the file `src` into the output (resuming a run) after checking
 * that they hash to `hash`: 0, CLI_PREFIX_SHORT (src missing or shorter), CLI_PREFIX_CHANGED
 * (other bytes: the file was changed or replaced), CLI_PREFIX_WRITE (writing failed; o->err). */
int cli_out_copy_prefix(cli_out *o, const char *src, unsigned long long bytes, unsigned long long hash);
/* Write out buffered lines if the last flush is older than 0.5 s. */
void cli_out_maybe_flush(cli_out *o);
/* Flush, close and rename into place. Prints an error and returns -1 on failure. */
int cli_out_finish(cli_out *o);
/* A checkpoint refers to the temporary file from now on: cli_out_abort leaves it in place. */
void cli_out_keep(cli_out *o);
/* Close and remove the temporary file (unless kept), releasing everything. */
void cli_out_abort(cli_out *o);
/* Remove the temporaries of `path` (PATH.tmp.PID and PATH.tmp.PID.XXXXXX) whose writer is no
 * longer running, except `except` (may be NULL). Returns how many were removed. */
int cli_clean_stale(const char *path, const char *except);

/* --model-lib FILE:SYMBOL (cli/modlib.c): model types from shared objects, loaded into a registry. */
enum { CLI_MAX_MODLIBS = 16 };
typedef struct cli_modlibs {
    const char *args[CLI_MAX_MODLIBS]; /* the option values */
    int nargs;
    void *h[CLI_MAX_MODLIBS];          /* the loaded objects (dlopen) */
    int n;
} cli_modlibs;
/* Take one option value (checked: FILE:SYMBOL, at most 16). 0, or -1 (printed). */
int cli_modlib_add(cli_modlibs *l, const char *v);
/* The FILE of value i into buf. */
const char *cli_modlib_file(const cli_modlibs *l, int i, char *buf, size_t len);
/* Load every object and register its model table in reg (a FILE without a slash that exists here is
 * ./FILE; else the library path is searched). 0, or the exit status (printed, naming the path tried). */
int cli_modlib_load(cli_modlibs *l, dth_registry *reg);
/* Unload them (after the registry and every model of them is freed). */
void cli_modlib_close(cli_modlibs *l);

/* Create the missing folders of a file's path (mkdir -p of its folder). -1 if one could not be made. */
int cli_make_parents(const char *path);
/* An absolute form of path without symbolic links in its folder (realpath of the folder + the
 * name; malloc'd), NULL if the folder does not exist. */
char *cli_abspath(const char *path);
/* 1 if the two paths name the same file (existing: same inode; else the same absolute path). */
int cli_same_file(const char *a, const char *b);

/* A file a command reads, and what it is in messages ("the scene file"). */
typedef struct cli_input {
    const char *path; /* NULL: none */
    const char *what;
} cli_input;
/* An output must not replace an input: if `path` (may be NULL: standard output) is one of the n
 * inputs, prints "refusing to write WHAT to 'PATH': it is INPUT" and returns CLI_USAGE; else 0. */
int cli_check_clash(const char *what, const char *path, const cli_input *in, size_t n);

/* A grid of n values from a to b, given as "a:b:n" (dth map's axes, dth sweep's --vary). */
typedef struct cli_grid {
    double a, b;
    long n;
} cli_grid;
/* cli_parse_grid's failures: not of the form a:b:n, a or b not a finite number, n not in 1..max */
enum { CLI_GRID_FORM = -1, CLI_GRID_BOUNDS = -2, CLI_GRID_COUNT = -3 };
/* Parse "a:b:n" into g: 0 or a failure above (the caller prints its message). */
int cli_parse_grid(const char *s, long max, cli_grid *g);
/* Grid value i; symmetric in a and b, so a symmetric range has an exact 0 in the middle. */
double cli_grid_at(const cli_grid *g, long i);

/* The model's derivatives against finite differences at the initial state of rs (dth_model_check;
 * skipped above 200 degrees of freedom, its memory growing as (2n+1)^2). A failed verdict, or a check
 * that cannot run (a model error, leaving the domain), is printed naming scene_path, `where` ("the
 * initial state") and `skip` (how to skip the check): then the exit status, else 0. */
int cli_check_model(const dth_run_setup *rs, const char *scene_path, const char *where, const char *skip);

/* The fastest rate of the linearized flow at y = (q, t, p): omega = sqrt(spectral radius of
 * (J H'')^2) over (q, p), by power iteration (for an oscillator its largest angular frequency, for
 * an unstable direction its growth rate). 0, or -1 (above 200 degrees of freedom, a model error). */
int cli_fastest_rate(const dth_model *m, const double *y, double *omega);

/* Seconds on a monotonic clock. */
double cli_now(void);

/**
 * What to do when a DTH run stops with `status` (exit 3): a clause such as "; to carry the run
 * across psi = 0: -s regularize.method=land" naming the scene key to change (empty if none
 * applies). `regularizer` is the run's [regularize] method, h its first step, m / z / lambda the
 * model, the last vertex and the last step (for the step ceiling of a region II fold; may be NULL/0).
 */
const char *cli_stop_hint(const char *regularizer, int status, double h, const dth_model *m, const double *z,
                          double lambda, char *buf, size_t len);

/* The step advice of a stopped run: "; a smaller step may pass: -s integrator.h=H/4", unless |h| lies
 * below the conditioning limit of the vertex z (dth_step_floor at 1e-6: a smaller step is known less
 * well there), which is then said instead, with a fixed-step method to use. Into buf. */
const char *cli_smaller_step(const dth_model *m, const double *z, double h, char *buf, size_t len);

/* Stop requests from SIGINT, SIGTERM and SIGHUP: install the handlers; the signal number or 0. */
void cli_catch_signals(void);
int cli_signal_received(void);

#endif
