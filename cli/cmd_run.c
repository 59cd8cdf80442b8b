/* SPDX-License-Identifier: MIT */
/*
 * dth run: integrate a scene with the DTH step (paper, Theorem "DTH Equations"), or a fixed-step
 * baseline method, through the library's run driver (run.h), and write its samples (vertices,
 * midpoints or output times) as CSV or HDF5, with optional diagnostics psi, psi', the region of
 * section 5 and the branch taken. This file is the command: its options, the scene and what is
 * checked before any output is made, the output files, the driver's calls and how the run ended.
 * The rows are run_rows.c's; checkpoints, and resuming them bit for bit (but for the step an
 * earlier t_end cut: run.h), are run_resume.c's.
 */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>
#include "ckpt.h"
#include "run_out.h"

/* ---------------------------------------------------------------- the command line */

void cli_usage_run(FILE *f)
{
    fprintf(f, "usage: dth run SCENE.ini [-s section.key=value]... [-o FILE] [--events FILE] [--roundtrip]\n"
               "                [--progress[=SECONDS]] [--no-model-check] [--model-lib FILE.so:SYMBOL]...\n"
               "                [--checkpoint FILE [--checkpoint-every N]]\n"
               "       dth run --resume CHECKPOINT [-s section.key=value]... [-o FILE] [--checkpoint ...]\n"
               "  -s section.key=value  override a scene key (applied after the file, in order)\n"
               "  -o FILE               write the CSV to FILE ('-': standard output; FILE.h5 or .hdf5: HDF5),\n"
               "                        creating missing folders; wins over [output] file=\n"
               "  --roundtrip           after the run, reverse and take as many steps back; rows get a column\n"
               "                        leg (1 forward, 2 back) and stderr the distance to the start\n"
               "  --progress[=SECONDS]  a progress line on stderr every 5 s (or SECONDS): t, steps/s, ETA\n"
               "                        (without --progress, a terminal shows a percentage; other stderr nothing)\n"
               "  --events FILE         write the [events] rows to FILE (default: OUT-events.csv next to -o OUT.csv)\n"
               "  --no-model-check      skip the check of the model's derivatives at the start\n"
               "  --model-lib F:SYM     load a model type from a shared object: SYM names its const dth_model_type\n"
               "                        (F without a slash: the file F here if there is one, else the library path)\n"
               "  --checkpoint FILE     save the full state to FILE (crash-safely) every N steps (default\n"
               "                        1000) and when the run ends; the CSV is flushed to disk first\n"
               "  --checkpoint-every N  the N of --checkpoint: steps between checkpoints (an integer >= 1)\n"
               "  --resume CHECKPOINT   continue a checkpointed run: the scene comes from the checkpoint,\n"
               "                        -s may change steps/t_end (counted from the original start); the\n"
               "                        output is the rows the run had written plus the rest, bit for bit\n"
               "                        (rows on the step an earlier t_end cut are rebuilt from its midpoint\n"
               "                        and match a run made at once only to round-off)\n"
               "the step: DTH's steps keep lambda^6 psi^2 = C along the run (docs/theory.md), and one key fixes C:\n"
               "  -s integrator.h=H       the first step is H; later steps grow where psi is small (many H on an\n"
               "                          eccentric orbit; a warning above integrator.warn_ratio H)\n"
               "  -s integrator.h_max=X   every step at most X: pilot runs choose C before the first step; a\n"
               "                          step above 1.05 X later stops the run (exit 3, rows kept)\n"
               "  -s integrator.tol=EPS   the estimated position error at t_end about EPS/2: pilot runs with\n"
               "                          the error estimate choose C (an extrapolation is said on stderr)\n"
               "  the end line names the one used and the largest step taken\n");
}

/* dth run's options. */
typedef struct run_opts {
    const char *scene_path, *out_opt, *ckpt_path, *resume_path, *ev_opt;
    const char **sets; /* the -s overrides, in order (room for argc) */
    int nsets;
    long ckpt_every;
    int roundtrip, want_progress, model_check;
    double progress_s;
    cli_modlibs libs;  /* --model-lib */
} run_opts;

/* What one dth run holds (released by job_free), and how its run went. */
typedef struct run_job {
    run_opts o;
    int argc;
    char **argv;
    dth_registry *reg;
    dth_scene *scene;
    dth_run_setup rs;
    int is_dth;           /* method = dth, else a fixed-step baseline (no midpoints, wp carried) */
    dth_integrator *it;
    run_resume res;       /* --resume: the checkpoint read */
    run_out r;            /* rows, outputs, checkpoints: the callbacks' state */
    double *zstart;       /* the first (or the resumed) vertex */
    const char *path;     /* the trajectory's output; NULL: standard output */
    char *ev_path;        /* the events CSV (NULL: none) */
    char origin[2][1100]; /* where the scene named the output and the events file (r.out_origin, r.ev_origin) */
    dth_run_state S;      /* the driver's state */
    double omega;         /* the fastest rate of the linearized flow at the start (0: unknown) */
    dth_control_report ctl; /* integrator.h_max / tol: the calibration (ctl.passes = 0: none) */
    double h_ref;         /* the step the user asked for, which warn_ratio and the messages compare with: h_max
                             with it, h without h_max and tol; 0 with tol alone (the error is the target) */
    int rc, werr;         /* the driver's status; an output could not be written */
} run_job;

/* What each step of run_cmd below returns to let the command go on; else it returns the exit
 * status, having printed why. */
enum { GO_ON = -1 };

/* 1 for the options that take a value. */
static int takes_value(const char *a)
{
    static const char *const opts[] = {"-s", "-o", "--checkpoint", "--checkpoint-every", "--resume", "--events",
                                       "--model-lib"};
    for (size_t i = 0; i < sizeof opts / sizeof *opts; i++)
        if (!strcmp(a, opts[i])) return 1;
    return 0;
}

/* The option a (one that takes a value) with its value v. */
static int option_value(run_opts *o, const char *a, const char *v)
{
    if (strcmp(a, "-s") && !v[0]) { /* a file name: an empty one would be a hidden temporary in . */
        cli_error("%s: the file name is empty", a);
        return CLI_USAGE;
    }
    if (!strcmp(a, "-s")) o->sets[o->nsets++] = v;
    else if (!strcmp(a, "-o")) o->out_opt = v;
    else if (!strcmp(a, "--checkpoint")) o->ckpt_path = v;
    else if (!strcmp(a, "--resume")) o->resume_path = v;
    else if (!strcmp(a, "--events")) o->ev_opt = v;
    else if (!strcmp(a, "--model-lib") && cli_modlib_add(&o->libs, v)) return CLI_USAGE;
    else if (!strcmp(a, "--checkpoint-every")) {
        char *end;
        o->ckpt_every = strtol(v, &end, 10);
        if (*end || end == v || o->ckpt_every < 1) {
            cli_error("--checkpoint-every: '%s' is not an integer >= 1", v);
            return CLI_USAGE;
        }
    }
    return GO_ON;
}

/* --progress or --progress=SECONDS */
static int option_progress(run_opts *o, const char *a)
{
    o->want_progress = 1;
    if (a[10] == '=') {
        char *end;
        o->progress_s = strtod(a + 11, &end);
        if (*end || end == a + 11 || !(o->progress_s > 0) || !isfinite(o->progress_s)) {
            cli_error("--progress=SECONDS: '%s' is not a number > 0", a + 11);
            return CLI_USAGE;
        }
    }
    return GO_ON;
}

/* The combinations the options cannot have. */
static int check_opts(const run_opts *o)
{
    if (!o->scene_path && !o->resume_path) {
        cli_error("no scene file (usage: dth run SCENE.ini [-s section.key=value]... [-o FILE])");
        return CLI_USAGE;
    }
    if (o->scene_path && o->resume_path) {
        cli_error("--resume takes the scene from the checkpoint: give no scene file");
        return CLI_USAGE;
    }
    if (o->roundtrip && (o->ckpt_path || o->resume_path)) {
        cli_error("--roundtrip cannot be combined with --checkpoint or --resume");
        return CLI_USAGE;
    }
    return GO_ON;
}

/* The command line into o: GO_ON, or the exit status (CLI_OK after --help). */
static int parse_args(int argc, char **argv, run_opts *o)
{
    for (int i = 1; i < argc; i++) {
        const char *a = argv[i];
        int st = GO_ON;
        if (!strcmp(a, "-h") || !strcmp(a, "--help")) {
            cli_usage_run(stdout);
            return CLI_OK;
        } else if (takes_value(a)) {
            if (i + 1 >= argc) {
                cli_error("option %s needs an argument (try dth run --help)", a);
                return CLI_USAGE;
            }
            st = option_value(o, a, argv[++i]);
        } else if (!strcmp(a, "--roundtrip")) {
            o->roundtrip = 1;
        } else if (!strcmp(a, "--no-model-check")) {
            o->model_check = 0;
        } else if (!strcmp(a, "--progress") || !strncmp(a, "--progress=", 11)) {
            st = option_progress(o, a);
        } else if (a[0] == '-' && a[1]) {
            cli_error("unknown option '%s' (try dth run --help)", a);
            return CLI_USAGE;
        } else if (o->scene_path) {
            cli_error("more than one scene file ('%s' and '%s')", o->scene_path, a);
            return CLI_USAGE;
        } else {
            o->scene_path = a;
        }
        if (st != GO_ON) return st;
    }
    return check_opts(o);
}

/* ---------------------------------------------------------------- input: validated before any output */

/* The scene (its file, or the checkpoint --resume names) with the -s overrides, and its setup; a
 * resume continues the checkpointed run: only its length and the output names may change. */
static int load_input(run_job *j)
{
    const run_opts *o = &j->o;
    char err[1024];
    int rc = dth_scene_new(NULL, &j->scene);
    if (!rc && o->resume_path) rc = run_resume_load(&j->res, o->resume_path, j->scene, err, sizeof err);
    else if (!rc) rc = dth_scene_load(j->scene, o->scene_path, err, sizeof err);
    for (int i = 0; !rc && i < o->nsets; i++) rc = dth_scene_set(j->scene, o->sets[i], err, sizeof err);
    if (!rc && j->res.saved && cli_ckpt_check_scene(j->res.saved, j->scene, err, sizeof err)) rc = DTH_EINVAL;
    if (!rc) rc = dth_scene_setup(j->scene, j->reg, &j->rs, err, sizeof err);
    if (!rc && o->resume_path && cli_ckpt_check_length(&j->res.c, &j->rs, err, sizeof err)) rc = DTH_EINVAL;
    if (rc) {
        cli_error("%s", rc == DTH_ENOMEM ? "out of memory" : err);
        return rc == DTH_ENOMEM ? CLI_FAIL : CLI_USAGE;
    }
    if (!j->o.scene_path) j->o.scene_path = o->resume_path;
    return GO_ON;
}

/* What the options cannot do with this scene. */
static int check_setup(run_job *j)
{
    const run_opts *o = &j->o;
    const dth_run_setup *rs = &j->rs;
    if (o->roundtrip && rs->dt > 0) {
        cli_error("--roundtrip writes vertices: it cannot be combined with [output] dt > 0");
        return CLI_USAGE;
    }
    j->is_dth = strcmp(rs->method, "dth") == 0; /* (a regularizer with a baseline: refused by dth_scene_setup) */
    return GO_ON;
}

/* The model's derivatives against finite differences at the initial state, once (cli_check_model). */
static int check_model(run_job *j)
{
    if (!j->o.model_check) return GO_ON;
    int st = cli_check_model(&j->rs, j->o.scene_path, "the initial state", "--no-model-check runs it anyway");
    return st ? st : GO_ON;
}

/* integrator.h_max and tol (control.h): the run's constant chosen by pilot runs before the first step,
 * rs.opt.h set to the first step that gives it; said on stderr. A resume continues the checkpointed run's
 * constant (its state holds it): no pilots, the guard of h_max only. */
static int calibrate(run_job *j)
{
    dth_run_setup *rs = &j->rs;
    j->ctl.size = sizeof j->ctl;
    j->h_ref = rs->h_max > 0 ? rs->h_max : rs->tol > 0 ? 0 : rs->h_asked;
    if (!(rs->h_max > 0) && !(rs->tol > 0)) return GO_ON;
    if (j->o.resume_path) return GO_ON;
    int tty = isatty(STDERR_FILENO);
    if (tty) fprintf(stderr, "dth run: calibrating the step (pilot runs)...");
    char err[1024];
    int rc = dth_run_setup_control(rs, &j->ctl, err, sizeof err);
    if (tty) fprintf(stderr, "\r%50s\r", "");
    if (rc) {
        cli_error("%s: %s%s: %s", j->o.scene_path, rs->h_max > 0 ? "integrator.h_max" : "integrator.tol",
                  rs->h_max > 0 && rs->tol > 0 ? " and tol" : "", err);
        return rc < 0 && rc != DTH_EINVAL ? CLI_FAIL : CLI_USAGE;
    }
    /* the calibrated first step goes into the scene a checkpoint records: a resume starts its integrator
     * with it (dth_integrator_h, the reference of integrator.warn_ratio's stop), without pilots */
    char set[80];
    snprintf(set, sizeof set, "integrator.h=%.17g", rs->opt.h);
    if (dth_scene_set_from(j->scene, "the calibration of integrator.h_max / tol", set, err, sizeof err)) {
        cli_error("%s", err);
        return CLI_FAIL;
    }
    const dth_control_report *c = &j->ctl;
    char what[160];
    if (rs->h_max > 0 && rs->tol > 0)
        snprintf(what, sizeof what, "integrator.h_max = %g and tol = %g (%s binds)", rs->h_max, rs->tol,
                 c->C_hmax < c->C_tol ? "h_max" : "tol");
    else if (rs->h_max > 0)
        snprintf(what, sizeof what, "integrator.h_max = %g", rs->h_max);
    else
        snprintf(what, sizeof what, "integrator.tol = %g", rs->tol);
    fprintf(stderr, "dth: %s: first step %.6g (the run's constant lambda^6 psi^2 = %.4g), from %d pilot run%s of %ld "
            "step%s to t = %.10g\n", what, c->h0, c->C, c->passes, CLI_S(c->passes), c->steps, CLI_S(c->steps),
            c->t_pilot);
    if (rs->tol > 0)
        fprintf(stderr, "dth: integrator.tol: the pilots' error estimate at t_end %.3g %s, predicted for the run "
                "%.3g\n", c->est, c->extrapolated ? "is an EXTRAPOLATION (linear in time) from a pilot that ended "
                "before t_end, not a run to it" : "(a pilot run to t_end)", c->est_pred);
    if (rs->h_max > 0 && !c->hmax_settled)
        cli_error("warning: integrator.h_max: after %d passes the pilots still met steps above h_max (the last at t = "
                  "%.6g): the run stops (exit 3) at its first step above %.3g", c->passes, c->t_excursion, c->step_max);
    if (c->pilot_status)
        cli_error("warning: a pilot's step failed at t = %.6g (%s): the calibration used the orbit before it, and the "
                  "run meets that step too", c->t_failed, dth_strerror(c->pilot_status));
    return GO_ON;
}

/* The integrator at the initial state, or at the checkpoint's. */
static int start_integrator(run_job *j)
{
    const dth_run_setup *rs = &j->rs;
    const char *resume_path = j->o.resume_path, *scene_path = j->o.scene_path;
    char err[1024] = "";
    int rc;
    dth_options o = rs->opt;
    rc = dth_options_check(rs->model, &o, err, sizeof err);
    if (rc) {
        cli_error("%s: method '%s': %s", scene_path, rs->method, err);
        return CLI_USAGE;
    }
    rc = dth_integrator_new(rs->model, &rs->opt, &j->it);
    if (!rc && resume_path) rc = dth_checkpoint_restore_run(j->it, &j->res.c.S, j->res.buf, j->res.len, err, sizeof err);
    else if (!rc) rc = dth_integrator_start(j->it, rs->q0, rs->p0, rs->t0);
    if (rc && resume_path && j->it) {
        cli_error("%s", err);
        return CLI_USAGE;
    }
    if (rc) {
        /* a start the step size spoils (a first vertex that overflows, no offset that gives h): name h */
        char hh[96] = "";
        if (rc > 0 && !resume_path) snprintf(hh, sizeof hh, "; integrator.h = %.6g may be too large for this model", rs->opt.h);
        cli_error("%s: cannot start at the initial state: %s (%s)%s", scene_path, dth_strerror(rc),
                  j->it ? dth_integrator_errmsg(j->it) : "creating the integrator", hh);
        return rc < 0 && rc != DTH_EINVAL ? CLI_FAIL : CLI_USAGE;
    }
    return GO_ON;
}

/* The rows' buffers, and what the checkpoint callback needs. */
static int init_rows(run_job *j)
{
    run_out *r = &j->r;
    r->scene = j->scene;
    r->ckpt_path = j->o.ckpt_path;
    r->it = j->it;
    j->zstart = calloc(2 * j->rs.n + 2, sizeof *j->zstart);
    if (run_rows_init(r, &j->rs, j->o.roundtrip) || !j->zstart) {
        cli_error("out of memory");
        return CLI_FAIL;
    }
    return GO_ON;
}

/* ---------------------------------------------------------------- outputs */

/* The events file: --events, [events] file=, or OUT-events.csv next to the output OUT.csv. */
static int events_path(run_job *j)
{
    const char *ep = j->o.ev_opt ? j->o.ev_opt : j->rs.events_file;
    if (ep) {
        j->ev_path = strdup(ep);
    } else if (j->path) {
        /* OUT.csv -> OUT-events.csv */
        size_t l = strlen(j->path);
        j->ev_path = malloc(l + 16);
        if (j->ev_path) {
            memcpy(j->ev_path, j->path, l + 1);
            if (l > 4 && !strcmp(j->path + l - 4, ".csv")) j->ev_path[l - 4] = '\0';
            strcat(j->ev_path, "-events.csv");
        }
    } else {
        cli_error("the scene has [events] and the trajectory goes to standard output: give the events file "
                  "([events] file= or --events FILE)");
        return CLI_USAGE;
    }
    if (!j->ev_path) {
        cli_error("out of memory");
        return CLI_FAIL;
    }
    return GO_ON;
}

/* "FILE:LINE: output.file" (ev = 0) or "...: events.file" (ev = 1): where the scene named the file. */
static const char *scene_origin(run_job *j, int ev)
{
    const char *sec = ev ? "events" : "output", *org = dth_scene_origin(j->scene, sec, "file");
    snprintf(j->origin[ev], sizeof j->origin[ev], "%s: %s.file", org ? org : "the scene", sec);
    return j->origin[ev];
}

/* Where the rows go: -o, else [output] file=, else (a resume) the checkpointed run's output; its
 * format (by the name, outfmt.h); the events file. */
static int choose_outputs(run_job *j)
{
    const run_opts *o = &j->o;
    const dth_run_setup *rs = &j->rs;
    const char *path = o->out_opt ? (strcmp(o->out_opt, "-") ? o->out_opt : NULL) : rs->out_file;
    if (!o->out_opt && !rs->out_file && o->resume_path && j->res.c.out.path[0]) path = j->res.c.out.path;
    j->path = path;
    if (o->ckpt_path && !path) {
        cli_error("--checkpoint needs an output file (-o FILE or [output] file=): standard output cannot be resumed");
        return CLI_USAGE;
    }
    const out_format *fmt = j->r.fmt = run_format_for(path);
    if (!fmt->resumable && (o->ckpt_path || o->resume_path)) {
        cli_error("checkpoints cover CSV output only (the output '%s' is %s)", path, fmt->name);
        return CLI_USAGE;
    }
    if (fmt->events_in_file && (o->ev_opt || rs->events_file)) {
        cli_error("with %s output the events are the table /events of '%s': give no events file", fmt->name, path);
        return CLI_USAGE;
    }
    j->r.has_ev = rs->nevents > 0 && !fmt->events_in_file;
    j->r.out_origin = path && path == rs->out_file ? scene_origin(j, 0) : NULL;
    j->r.ev_origin = j->r.has_ev && !o->ev_opt && rs->events_file ? scene_origin(j, 1) : NULL;
    return j->r.has_ev ? events_path(j) : GO_ON;
}

/* An output that would overwrite an input is refused: the scene, the checkpoint, the trajectory
 * (for the events); on a resume also the checkpointed run's file of the other kind, which the resume
 * reads (its own kind it continues: the rows are copied before the file is replaced). A resume may
 * write its checkpoint over the one it read: that is whole in memory, and replaced atomically. */
static int check_clashes(const run_job *j)
{
    const char *path = j->path, *ev_path = j->ev_path, *ckpt_path = j->o.ckpt_path, *resume_path = j->o.resume_path;
    const char *scene_file = resume_path ? NULL : j->o.scene_path;
    const cli_ckpt *c = resume_path ? &j->res.c : NULL;
    const cli_input out_in[] = {{scene_file, "the scene file"}, {ckpt_path, "the checkpoint file"},
                                {resume_path, "the checkpoint file"},
                                {c && c->ev.path[0] ? c->ev.path : NULL, "the checkpointed run's events file"}};
    const cli_input ev_in[] = {{scene_file, "the scene file"}, {ckpt_path, "the checkpoint file"},
                               {resume_path, "the checkpoint file"}, {path, "the trajectory's output"},
                               {c && c->out.path[0] ? c->out.path : NULL, "the checkpointed run's output"}};
    const cli_input ckpt_in[] = {{scene_file, "the scene file"}};
    int st = cli_check_clash("the output", path, out_in, sizeof out_in / sizeof *out_in);
    if (!st) st = cli_check_clash("events", ev_path, ev_in, sizeof ev_in / sizeof *ev_in);
    if (!st) st = cli_check_clash("the checkpoint", ckpt_path, ckpt_in, 1);
    /* and no output over a model library */
    char lib[4096];
    for (int i = 0; !st && i < j->o.libs.nargs; i++) {
        const cli_input in[] = {{cli_modlib_file(&j->o.libs, i, lib, sizeof lib), "a model library (--model-lib)"}};
        st = cli_check_clash("the output", path, in, 1) || cli_check_clash("events", ev_path, in, 1) ||
             cli_check_clash("the checkpoint", ckpt_path, in, 1) ? CLI_USAGE : 0;
    }
    return st ? st : GO_ON;
}

/* The outputs (with their missing folders), a resume's rows copied in; stop requests caught from
 * here on. */
static int open_outputs(run_job *j)
{
    run_out *r = &j->r;
    if (j->path) cli_make_parents(j->path);
    if (j->ev_path) cli_make_parents(j->ev_path);
    int st = run_outputs_open(r, j->path, j->ev_path, j->argc, j->argv);
    if (st) return st;
    if (j->o.resume_path && run_resume_prefix(r, &j->res.c, j->o.resume_path, j->ev_path))
        return r->out.failed || r->ev.failed ? CLI_FAIL : CLI_USAGE;
    cli_catch_signals();
    return GO_ON;
}

/* ---------------------------------------------------------------- the run */

/* The start vertex into zstart, and warnings about a fresh start: a vertex start's energy (every midpoint's) against the initial state's;
 * an explicit wp: the first step it encodes against h (checked at the first sample). */
static void check_start(run_job *j)
{
    const dth_run_setup *rs = &j->rs;
    double *zstart = j->zstart;
    memcpy(zstart, dth_integrator_vertex(j->it), j->r.N * sizeof *zstart);
    if (j->o.resume_path) return;
    /* the fastest rate at the start, for a warning when the run ends (fast_rate) */
    if (cli_fastest_rate(rs->model, zstart, &j->omega)) j->omega = 0;
    if (!j->is_dth) return;
    if (rs->opt.start == DTH_START_VERTEX && rs->opt.order == 2) { /* order 4: the given state is the vertex */
        double H0, E = dth_integrator_energy(j->it);
        if (!dth_model_eval(rs->model, zstart, DTH_EVAL_H, &H0, NULL, NULL) && fabs(E - H0) > 0.01 * fabs(H0))
            cli_error("warning: a vertex start conserves the energy %.10g at every midpoint; the initial state has "
                      "%.10g (%.3g %% apart: the vertex lies off the energy surface by the offset that encodes the "
                      "step; a midpoint start conserves the initial energy)",
                      E, H0, 100 * fabs(E - H0) / fabs(H0));
        j->r.check_wp = rs->opt.has_wp;
    }
}

/* The driver's progress callback: stop requests, and the progress display on stderr. */
static int on_progress(void *user, const dth_run_state *st)
{
    run_out *r = user;
    if ((r->sig = cli_signal_received()) != 0) return DTH_ESTOPPED;
    if (!r->progress) return 0;
    double now = cli_now();
    if (now - r->last_progress < (r->progress == 1 ? 0.25 : r->progress_s)) return 0;
    r->last_progress = now;
    const dth_run_setup *rs = r->rs;
    double frac = rs->has_t_end ? (st->t - st->t_first) / (rs->t_end - st->t_first) : (double)st->k / (double)rs->steps;
    frac = fmin(fmax(frac, 0), 1);
    if (r->progress == 1) {
        fprintf(stderr, "\rdth run: %3.0f%%", 100 * frac);
        return 0;
    }
    double el = now - r->t_start, rate = (double)(st->k - r->k_begin) / fmax(el, 1e-9);
    double done = rs->has_t_end ? (st->t - r->t_begin) / (rs->t_end - r->t_begin)
                                : (double)(st->k - r->k_begin) / (double)(rs->steps - r->k_begin);
    double eta = done > 0 ? el * (1 - done) / done : NAN;
    fprintf(stderr, "dth run: t = %.9g (%.1f%%), k = %ld, %.3g steps/s, elapsed %.1f s, ETA %.1f s\n", st->t,
            100 * frac, st->k, rate, el, eta);
    return 0;
}

/* The driver's configuration (run.h): the scene's, with dth run's callbacks; the progress display. */
static void configure(run_job *j, dth_run_config *cfg)
{
    const dth_run_setup *rs = &j->rs;
    run_out *r = &j->r;
    dth_run_config_from_setup(cfg, rs);
    cfg->points = rs->points;
    cfg->on_event = run_on_event;
    cfg->every = rs->every;
    cfg->dt = rs->dt;
    cfg->sample = run_on_sample;
    cfg->user = r;
    cfg->checkpoint = j->o.ckpt_path ? run_on_checkpoint : NULL;
    cfg->checkpoint_every = j->o.ckpt_every;
    cfg->progress = on_progress;
    cfg->progress_every = 1;
    r->progress = j->o.want_progress ? 2 : isatty(STDERR_FILENO) ? 1 : 0;
    r->progress_s = j->o.progress_s;
    r->t_start = r->last_progress = cli_now();
}

/* One call of the driver; a callback's write error sets werr. */
static void drive(run_job *j, const dth_run_config *cfg)
{
    j->rc = dth_run(j->it, cfg, &j->S);
    if (j->rc == DTH_EIO && j->S.stop == DTH_RUN_CALLBACK) j->werr = 1;
}

/* --roundtrip: reverse in place and take as many steps back (paper, time reversibility); stderr
 * gets the distance to the start. */
static void roundtrip(run_job *j, dth_run_config *cfg)
{
    long k1 = j->S.k;
    dth_integrator_reverse(j->it);
    j->r.leg = 2;
    cfg->has_t_end = 0;
    cfg->steps = 2 * k1;
    j->S.k0 = k1;
    j->S.t_stop = j->S.t;
    drive(j, cfg);
    if (j->rc) return;
    const double *z = dth_integrator_vertex(j->it), *zstart = j->zstart;
    double e = 0, sc = 0;
    for (size_t i = 0; i < (j->is_dth ? j->r.N : j->r.N - 1); i++) { /* a baseline's wp is a constant */
        e = fmax(e, fabs(z[i] - zstart[i]));
        sc = fmax(sc, fabs(zstart[i]));
    }
    fprintf(stderr, "dth: round trip of 2 x %ld step%s: max |z - z_0| = %.3g (relative %.3g)\n", k1, CLI_S(k1), e,
            sc > 0 ? e / sc : e);
}

/* The headers (not on a resume: they are in the copied rows), the first checkpoint, the run and its
 * way back. GO_ON, or the exit status when the checkpoint cannot be written. */
static int run_all(run_job *j)
{
    const run_opts *o = &j->o;
    run_out *r = &j->r;
    dth_run_config cfg;
    configure(j, &cfg);
    dth_run_state_init(&j->S);
    if (o->resume_path) j->S = j->res.c.S;
    r->k_begin = j->S.k;
    r->t_begin = j->zstart[r->n];
    if (!o->resume_path && run_headers(r)) j->werr = 1;
    if (!j->werr && o->ckpt_path) {
        int c = run_first_checkpoint(r, &j->S);
        if (c < 0) return CLI_USAGE; /* like an output that cannot be written */
        j->werr = c;
    }
    /* temporaries of runs that were killed: once this run's own checkpoint stands (a resume's rows
     * are in this run's temporary), or at once without checkpoints */
    if (!j->werr && (o->ckpt_path || !o->resume_path))
        run_clean_stale(j->path, j->ev_path, o->ckpt_path, o->resume_path, o->resume_path ? &j->res.c : NULL);
    if (j->werr) j->rc = DTH_OK;
    else drive(j, &cfg);
    if (o->roundtrip && !j->werr && j->rc == DTH_OK) roundtrip(j, &cfg);
    return GO_ON;
}

/* After the run: the outputs put in place, or the write error reported (what the last good
 * checkpoint needs stays: its temporaries are kept; fix the cause, then resume). */
static int close_outputs(run_job *j)
{
    run_out *r = &j->r;
    if (r->progress == 1) fprintf(stderr, "\r%20s\r", "");
    if (j->werr) {
        run_outputs_failed(r, j->path, j->ev_path);
        if (r->ckpt_written)
            cli_error("the checkpoint '%s' of step %ld and the rows it needs are kept: dth run --resume %s continues "
                      "the run once the cause is fixed", j->o.ckpt_path, r->ckpt_k, j->o.ckpt_path);
        return CLI_FAIL;
    }
    if (run_outputs_finish(r)) return CLI_FAIL;
    /* the resumed run's files are complete */
    if (j->o.resume_path && !j->o.ckpt_path) run_clean_stale(j->path, j->ev_path, NULL, j->o.resume_path, &j->res.c);
    return GO_ON;
}

/* The key a run that stopped (exit 3) may change: h if the first solved step failed, else a hint
 * of cli_stop_hint. */
static void stop_hint(const run_job *j, char *hint, size_t len)
{
    const dth_run_setup *rs = &j->rs;
    if (j->S.k - j->r.k_begin <= 1 && !j->o.resume_path) {
        char adv[400];
        cli_smaller_step(rs->model, j->it ? dth_integrator_vertex(j->it) : NULL, rs->opt.h, adv, sizeof adv);
        snprintf(hint, len, "; the first step failed: %s", adv + 2); /* (adv: "; advice") */
    } else if (j->is_dth)
        cli_stop_hint(rs->regularize, j->rc, rs->opt.h, rs->model, dth_integrator_vertex(j->it),
                      dth_integrator_lambda(j->it), hint, len);
    else
        hint[0] = '\0';
}

/* A step that cannot follow the fastest motion of the start: omega |h| > 1, fewer than 2 pi steps per
 * period of the fastest oscillation (or more than an e-fold per step of a growing direction). Said
 * when a run ends well (one that stops has its own advice). */
static void fast_rate(const run_job *j)
{
    double h = j->rs.opt.h, om = j->omega;
    if (!(om * fabs(h) > 1)) return;
    cli_error("warning: |h| = %.3g is large for the motion at the start: omega |h| = %.3g > 1, fewer than 2 pi steps per "
              "period of the fastest oscillation (omega = %.3g, the fastest rate of the linearized flow there), whose "
              "phase then errs by more than 7 %% a step; a smaller step, e.g. -s integrator.h=%.3g (omega |h| = 0.5)",
              fabs(h), om * fabs(h), om, copysign(0.5 / om, h));
}

/* A run that was mostly the regularizer's: more than half of at least 10 steps regularized by one
 * that only carries the crossings (land; not one that replaces every step by design, prescribed).
 * Those steps are not symplectic: a warning, with a smaller step. Order 4: its band's steps (symplectic,
 * prescribed), unless integrator.band_time asked for them. */
static void regularized_share(const run_job *j)
{
    const dth_run_state *S = &j->S;
    const dth_regularizer *reg = j->rs.regularizer;
    if (!reg || dth_regularizer_get_type(reg)->replaces_all || S->k < 10 || 2 * S->regularized <= S->k) return;
    if (j->rs.opt.order == 4) { /* its band steps are symplectic, but prescribed: not on the levels */
        if (j->rs.opt.band_time > 0) return; /* a band fixed in phase space: as many as integrator.band_time asks */
        cli_error("warning: %.0f %% of the steps (%ld of %ld) were order 4's band steps around psi = 0 (prescribed-step "
                  "compositions: not solved for, their energy held only to O(tau^4)); a smaller step keeps more of "
                  "the run on composite steps, e.g. -s integrator.h=%.6g",
                  100.0 * (double)S->regularized / (double)S->k, S->regularized, S->k, j->rs.opt.h / 4);
        return;
    }
    cli_error("warning: %.0f %% of the steps (%ld of %ld) were regularized steps of the regularizer '%s', which are not "
              "symplectic: the step is large for this trajectory; a smaller one keeps more of it on ordinary DTH steps, "
              "e.g. -s integrator.h=%.6g", 100.0 * (double)S->regularized / (double)S->k, S->regularized, S->k,
              dth_regularizer_get_type(reg)->name, j->rs.opt.h / 4);
}

/* How the run ended, on stderr (always when it could not go on, else for regularized runs and on
 * a terminal), and the exit status. */
/* The run's error estimate and largest step, for the end line ("" without an estimate). */
static void estimate_note(const run_job *j, char *buf, size_t len)
{
    const dth_run_state *S = &j->S;
    const dth_run_setup *rs = &j->rs;
    buf[0] = '\0';
    int w = 0;
    if (!isnan(S->err_q))
        w = snprintf(buf, len, "; estimated error |dq| %.2g, |dp| %.2g at t = %.10g", S->err_q, S->err_p, S->t);
    if (w < 0 || (size_t)w >= len) return;
    if (rs->h_max > 0 && rs->tol > 0)
        snprintf(buf + w, len - (size_t)w, "; largest step %.3g = %.3g h_max (step control integrator.h_max = %g and "
                 "tol = %g, first step %.3g)", S->lam_max, S->lam_max / rs->h_max, rs->h_max, rs->tol, fabs(rs->opt.h));
    else if (rs->h_max > 0)
        snprintf(buf + w, len - (size_t)w, "; largest step %.3g = %.3g h_max (step control integrator.h_max = %g, "
                 "first step %.3g)", S->lam_max, S->lam_max / rs->h_max, rs->h_max, fabs(rs->opt.h));
    else if (rs->tol > 0)
        snprintf(buf + w, len - (size_t)w, "; largest step %.3g (step control integrator.tol = %g, first step %.3g)",
                 S->lam_max, rs->tol, fabs(rs->opt.h));
    else
        snprintf(buf + w, len - (size_t)w, "; largest step %.3g = %.3g h (step control integrator.h = %g)", S->lam_max,
                 S->lam_max / fabs(rs->opt.h), fabs(rs->opt.h));
}

/* Why a run stopped at the guard of integrator.h_max (DTH_ESTEPSIZE after a step above rs.step_max). */
static void guard_msg(const run_job *j, char *buf, size_t len)
{
    const dth_run_state *S = &j->S;
    const dth_run_setup *rs = &j->rs;
    snprintf(buf, len, "the step lambda = %.4g at t = %.6g exceeds 1.05 integrator.h_max = %.4g: the run's constant "
             "was calibrated by pilots to t = %.6g and this part of the orbit needs a smaller one; fix: pilots over the "
             "whole run (leave integrator.pilot out, or set it to t_end), or a smaller integrator.h_max (e.g. %.3g)",
             S->lam_max, S->t_lam_max, rs->step_max, isnan(rs->pilot) ? rs->t_end : rs->pilot,
             rs->h_max * rs->h_max / S->lam_max);
}

/* Why a run stopped on its error estimate (DTH_EACCURACY), and the fix. */
static void accuracy_msg(const run_job *j, char *buf, size_t len)
{
    const dth_run_state *S = &j->S;
    if (!j->is_dth) { /* a fixed-step baseline: its energy error */
        snprintf(buf, len, "the energy error |H - H0| = %.3g is %.0f %% of the size of the energy's terms %.3g (the run's "
                 "bound integrator.stop_error = %.2g): the fixed step h = %.3g does not resolve the orbit here (a "
                 "near-collision?): a smaller integrator.h, or integrator.method = dth", S->e_err,
                 100 * S->e_err / S->e_scale, S->e_scale, j->rs.stop_error, fabs(j->rs.opt.h));
        return;
    }
    int p = S->err_p / S->p_max > S->err_q / S->q_max;
    if (j->rs.opt.order == 4 && !(S->lam_max > dth_run_step_limit(j->it, j->rs.warn_ratio))) {
        /* the rule armed by order 4's band (run.h, stop_error) */
        snprintf(buf, len, "the estimated error |d%c| = %.3g is %.0f %% of the largest |%c| = %.3g (the run's bound "
                 "integrator.stop_error = %.2g), and %ld of the %ld steps were order 4's band steps around psi = 0 "
                 "(prescribed, not solved for), too large for this orbit: a smaller integrator.h",
                 p ? 'p' : 'q', p ? S->err_p : S->err_q, 100 * (p ? S->err_p / S->p_max : S->err_q / S->q_max),
                 p ? 'p' : 'q', p ? S->p_max : S->q_max, j->rs.stop_error, S->regularized, S->k);
        return;
    }
    snprintf(buf, len, "the estimated error |d%c| = %.3g is %.0f %% of the largest |%c| = %.3g (the run's bound "
             "integrator.stop_error = %.2g): the steps grew to lambda = %.3g = %.3g h (at t = %.6g, more than "
             "integrator.warn_ratio allows), too large for this orbit: a smaller integrator.h (all steps shrink in "
             "proportion)", p ? 'p' : 'q', p ? S->err_p : S->err_q,
             100 * (p ? S->err_p / S->p_max : S->err_q / S->q_max), p ? 'p' : 'q', p ? S->p_max : S->q_max,
             j->rs.stop_error, S->lam_max, S->lam_max / fabs(j->rs.opt.h), S->t_lam_max);
    if (j->rs.tol > 0 || j->rs.h_max > 0) {
        size_t w = strlen(buf);
        if (w < len)
            snprintf(buf + w, len - w, "; with step control (integrator.%s = %g): a smaller one, or integrator.pilot = "
                     "t_end", j->rs.h_max > 0 ? "h_max" : "tol", j->rs.h_max > 0 ? j->rs.h_max : j->rs.tol);
    }
}

/* Whether the run retraces itself, for the end line: the steps that are not their own reverse
 * (dth_run_state.nonreversible; those of both legs with --roundtrip), or that every step is (to about
 * 2^-100 under the reversible finish, else to round-off). "" for a baseline. */
static void reversible_note(const run_job *j, char *buf, size_t len)
{
    long nr = j->S.nonreversible;
    int o4 = j->rs.opt.order == 4; /* its composition is reversible to round-off under either finish */
    buf[0] = '\0';
    if (!j->is_dth) return;
    if (nr > 0)
        snprintf(buf, len, "; %ld non-reversible step%s", nr, CLI_S(nr));
    else if (j->rs.opt.finish == DTH_FINISH_REVERSIBLE && !o4)
        snprintf(buf, len, "; 0 non-reversible steps: exactly reversible (each step its own reverse to 2^-100)");
    else
        snprintf(buf, len, "; 0 non-reversible steps: reversible to round-off%s",
                 o4 ? "" : " (exactly with integrator.reversible = yes)");
}

/* --roundtrip or integrator.reversible = yes with steps that are not their own reverse: the run does
 * not retrace itself (a regularizer's offset resets and clock corrections, order 4's band exits), or
 * need not (ordinary steps kept by one that replaces every step: the way back takes its segment where
 * one exists), and what does. */
static void nonreversible_warning(const run_job *j)
{
    const dth_run_state *S = &j->S;
    int rev = j->rs.opt.finish == DTH_FINISH_REVERSIBLE;
    if (!j->is_dth || S->nonreversible <= 0 || !(j->o.roundtrip || rev)) return;
    const dth_regularizer *reg = j->rs.regularizer;
    const char *name = reg ? dth_regularizer_get_type(reg)->name : "?";
    const char *what = j->o.roundtrip ? "the round trip" : "the run reversed";
    char cause[120];
    if (j->rs.opt.order == 4)
        snprintf(cause, sizeof cause, "order 4's crossing band left there by a projection");
    else
        snprintf(cause, sizeof cause, "regularizer '%s' reset their end vertex or corrected their time", name);
    if (reg && dth_regularizer_get_type(reg)->replaces_all)
        cli_error("warning: %ld of the %ld steps are ordinary steps that regularizer '%s' kept where it found no segment "
                  "of its own (fallback = yes): not reversible, since the way back takes its segment where one exists, "
                  "so %s comes back only where the way back falls back too; fallback = no refuses there instead",
                  S->nonreversible, S->k, name, what);
    else
        cli_error("warning: %ld of the %ld steps are not reversible (%s), so %s does not come back to its start%s; "
                  "%s[regularize] method = prescribed with integrator.reversible = yes retraces a run through psi = 0",
                  S->nonreversible, S->k, cause, what,
                  rev ? " (integrator.reversible = yes makes only the other steps exact)" : "",
                  j->rs.opt.order == 4 ? "integrator.order = 2 with " : "");
}

static int report(const run_job *j)
{
    const run_out *r = &j->r;
    const dth_run_state *S = &j->S;
    int rc = j->rc, sig = r->sig && rc == DTH_ESTOPPED ? r->sig : 0;
    char crossing[160] = "", est[200], revn[100];
    if (S->crossings || S->regularized) {
        /* (the step ratio around a crossing exists only where there was one) */
        /* order 4: the band's steps (symplectic) and its exits (a projection: not symplectic, not reversible) */
        int w = j->rs.opt.order == 4
                    ? snprintf(crossing, sizeof crossing, "; %ld psi = 0 crossing%s, %ld band step%s (%ld band exit%s)",
                               S->crossings, CLI_S(S->crossings), S->regularized, CLI_S(S->regularized),
                               S->nonreversible, CLI_S(S->nonreversible))
                    : snprintf(crossing, sizeof crossing, "; %ld psi = 0 crossing%s, %ld regularized step%s",
                               S->crossings, CLI_S(S->crossings), S->regularized, CLI_S(S->regularized));
        if (S->crossings && w > 0 && (size_t)w < sizeof crossing)
            snprintf(crossing + w, sizeof crossing - (size_t)w, ", largest step ratio at a crossing %.3g", S->max_ratio);
    }
    estimate_note(j, est, sizeof est);
    reversible_note(j, revn, sizeof revn);
    char amsg[512];
    const char *emsg = dth_integrator_errmsg(j->it);
    if (rc == DTH_EACCURACY) {
        accuracy_msg(j, amsg, sizeof amsg);
        emsg = amsg;
    } else if (rc == DTH_ESTEPSIZE && j->rs.step_max > 0 && S->lam_max > j->rs.step_max) {
        guard_msg(j, amsg, sizeof amsg);
        emsg = amsg;
    }
    /* the bound of the library's stop rule (order 4: warn_ratio^(3/2), dth_run_step_limit) against the
     * step the user asked for (h, or h_max; none with tol alone) */
    double wr = j->rs.opt.order == 4 ? pow(j->rs.warn_ratio, 1.5) : j->rs.warn_ratio;
    if (rc >= 0 && wr > 0 && j->h_ref != 0 && S->lam_max > wr * fabs(j->h_ref))
        cli_error("warning: the largest step was lambda = %.3g = %.3g h (at t = %.6g, more than %s = %g h): DTH steps "
                  "follow %s = const along the orbit, and h sets them only at the start (docs/theory.md); the "
                  "estimated error says what they cost; for steps that stay small: -s integrator.h_max=%.3g (every "
                  "step at most that), or -s integrator.tol=EPS (an error at the end)",
                  S->lam_max, S->lam_max / fabs(j->h_ref), S->t_lam_max,
                  j->rs.opt.order == 4 ? "integrator.warn_ratio^(3/2) for order 4" : "integrator.warn_ratio", wr,
                  j->rs.opt.order == 4 ? "tau^2 psi" : "lambda^6 psi^2", fabs(j->h_ref));
    if (S->stop == DTH_RUN_SAMPLES) { /* the library's bound (run.h) */
        cli_error("stopped at k=%ld, t=%.17g: output.dt = %.3g asks for more than %d rows within one step (a larger "
                  "output.dt, or output.points = vertices; the rows so far are kept)", S->k, S->t, j->rs.dt,
                  DTH_RUN_MAX_SAMPLES_PER_STEP);
        return CLI_USAGE;
    } else if (sig) {
        char resume[1200] = "";
        if (r->ckpt_written)
            snprintf(resume, sizeof resume, "; to continue: dth run --resume %s (its checkpoint of step %ld)",
                     j->o.ckpt_path, r->ckpt_k);
        cli_error("interrupted at k=%ld, t=%.17g (the rows so far are kept)%s%s", S->k, S->t, crossing, resume);
        return 128 + sig;
    } else if (rc > 0) {
        char hint[512];
        stop_hint(j, hint, sizeof hint);
        cli_error("stopped at k=%ld, t=%.17g: %s (%s)%s%s%s", S->k, S->t, dth_strerror(rc), emsg, crossing,
                  rc == DTH_EACCURACY ? "" : est, hint);
        return CLI_STOPPED;
    } else if (rc < 0) {
        cli_error("error at k=%ld, t=%.17g: %s (%s)", S->k, S->t, dth_strerror(rc), emsg);
        return CLI_FAIL;
    }
    fast_rate(j);
    regularized_share(j);
    nonreversible_warning(j);
    if (r->progress == 1 || S->regularized || S->nonreversible || j->o.roundtrip ||
        j->rs.opt.finish == DTH_FINISH_REVERSIBLE || j->ctl.passes)
        fprintf(stderr, "dth: %ld step%s to t = %.17g, %ld row%s to %s%s%s%s\n", S->k, CLI_S(S->k), S->t_stop,
                S->samples, CLI_S(S->samples), j->path ? j->path : "standard output", crossing, revn, est);
    if (r->has_ev && (r->progress == 1 || S->stop == DTH_RUN_EVENT))
        fprintf(stderr, "dth: %ld event%s to %s%s\n", S->events, CLI_S(S->events), j->ev_path,
                S->stop == DTH_RUN_EVENT ? " (the run ended at a terminal event)" : "");
    return CLI_OK;
}

static void job_free(run_job *j)
{
    run_out_free(&j->r);
    free(j->ev_path);
    free(j->zstart);
    run_resume_clear(&j->res);
    dth_integrator_free(j->it);
    dth_run_setup_clear(&j->rs);
    dth_scene_free(j->scene);
    dth_registry_free(j->reg);
    cli_modlib_close(&j->o.libs); /* after every model of theirs is freed */
}

/* The command, with room in `sets` for the -s overrides (argc entries). */
static int run_cmd(int argc, char **argv, const char **sets)
{
    run_job j;
    memset(&j, 0, sizeof j);
    j.o.sets = sets;
    j.o.ckpt_every = 1000;
    j.o.model_check = 1;
    j.o.progress_s = 5;
    j.argc = argc;
    j.argv = argv;
    j.r.out.fd = j.r.ev.fd = -1;
    int st = parse_args(argc, argv, &j.o);
    if (st != GO_ON) return st;
    if (!(j.reg = cli_registry())) return CLI_FAIL;
    /* input: everything is validated before any output is created */
    st = cli_modlib_load(&j.o.libs, j.reg);
    st = st ? st : load_input(&j);
    if (st == GO_ON) st = check_setup(&j);
    if (st == GO_ON) st = check_model(&j);
    if (st == GO_ON) st = calibrate(&j);
    if (st == GO_ON) st = start_integrator(&j);
    if (st == GO_ON) st = init_rows(&j);
    if (st == GO_ON) st = choose_outputs(&j);
    if (st == GO_ON) st = check_clashes(&j);
    /* output, then the run (run.h) */
    if (st == GO_ON) st = open_outputs(&j);
    if (st == GO_ON) check_start(&j);
    if (st == GO_ON) st = run_all(&j);
    if (st == GO_ON) st = close_outputs(&j);
    if (st == GO_ON) st = report(&j);
    job_free(&j);
    return st;
}

int cli_cmd_run(int argc, char **argv)
{
    const char **sets = calloc((size_t)argc, sizeof *sets);
    if (!sets) {
        cli_error("out of memory");
        return CLI_FAIL;
    }
    int status = run_cmd(argc, argv, sets);
    free(sets);
    return status;
}
