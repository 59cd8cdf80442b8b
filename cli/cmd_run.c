/* SPDX-License-Identifier: MIT */
/*
 * dth run: integrate a scene with the DTH step (paper, Theorem "DTH Equations"), or a fixed-step
 * baseline method, through the library's run driver (run.h), and write its samples (vertices,
 * midpoints or output times) as CSV, with optional diagnostics psi, psi', the region of section 5
 * and the branch taken. This file handles the command line (the rows: run_rows.c); it also
 * checkpoints runs and resumes them bit for bit (but for the step an earlier t_end cut: run.h;
 * run_resume.c).
 */
#include <math.h>
#include <stdarg.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>
#include "ckpt.h"
#include "run_out.h"

/* ---------------------------------------------------------------- progress and stop requests */

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

/* ---------------------------------------------------------------- the command */

void cli_usage_run(FILE *f)
{
    fprintf(f, "usage: dth run SCENE.ini [-s section.key=value]... [-o FILE] [--events FILE] [--roundtrip]\n"
               "                [--progress[=SECONDS]] [--no-model-check]\n"
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
               "  --checkpoint FILE     save the full state to FILE (crash-safely) every N steps (default\n"
               "                        1000) and when the run ends; the CSV is flushed to disk first\n"
               "  --checkpoint-every N  the N of --checkpoint: steps between checkpoints (an integer >= 1)\n"
               "  --resume CHECKPOINT   continue a checkpointed run: the scene comes from the checkpoint,\n"
               "                        -s may change steps/t_end (counted from the original start); the\n"
               "                        output is the rows the run had written plus the rest, bit for bit\n"
               "                        (rows on the step an earlier t_end cut are rebuilt from its midpoint\n"
               "                        and match a run made at once only to round-off)\n");
}

/* The command, with room in `sets` for the -s overrides (argc entries). */
static int run_cmd(int argc, char **argv, const char **sets)
{
    const char *scene_path = NULL, *out_opt = NULL, *ckpt_path = NULL, *resume_path = NULL, *ev_opt = NULL;
    long ckpt_every = 1000;
    char err[1024];
    int roundtrip = 0, want_progress = 0, model_check = 1, nsets = 0;
    double progress_s = 5;
    for (int i = 1; i < argc; i++) {
        const char *a = argv[i];
        if (!strcmp(a, "-h") || !strcmp(a, "--help")) {
            cli_usage_run(stdout);
            return CLI_OK;
        } else if (!strcmp(a, "-s") || !strcmp(a, "-o") || !strcmp(a, "--checkpoint") ||
                   !strcmp(a, "--checkpoint-every") || !strcmp(a, "--resume") || !strcmp(a, "--events")) {
            if (i + 1 >= argc) {
                cli_error("option %s needs an argument (try dth run --help)", a);
                return CLI_USAGE;
            }
            const char *v = argv[++i];
            if (!strcmp(a, "-s")) sets[nsets++] = v;
            else if (!strcmp(a, "-o")) out_opt = v;
            else if (!strcmp(a, "--checkpoint")) ckpt_path = v;
            else if (!strcmp(a, "--resume")) resume_path = v;
            else if (!strcmp(a, "--events")) ev_opt = v;
            else if (!strcmp(a, "--checkpoint-every")) {
                char *end;
                ckpt_every = strtol(v, &end, 10);
                if (*end || end == v || ckpt_every < 1) {
                    cli_error("--checkpoint-every: '%s' is not an integer >= 1", v);
                    return CLI_USAGE;
                }
            }
        } else if (!strcmp(a, "--roundtrip")) {
            roundtrip = 1;
        } else if (!strcmp(a, "--no-model-check")) {
            model_check = 0;
        } else if (!strcmp(a, "--progress") || !strncmp(a, "--progress=", 11)) {
            want_progress = 1;
            if (a[10] == '=') {
                char *end;
                progress_s = strtod(a + 11, &end);
                if (*end || end == a + 11 || !(progress_s > 0) || !isfinite(progress_s)) {
                    cli_error("--progress=SECONDS: '%s' is not a number > 0", a + 11);
                    return CLI_USAGE;
                }
            }
        } else if (a[0] == '-' && a[1]) {
            cli_error("unknown option '%s' (try dth run --help)", a);
            return CLI_USAGE;
        } else if (scene_path) {
            cli_error("more than one scene file ('%s' and '%s')", scene_path, a);
            return CLI_USAGE;
        } else {
            scene_path = a;
        }
    }
    if (!scene_path && !resume_path) {
        cli_error("no scene file (usage: dth run SCENE.ini [-s section.key=value]... [-o FILE])");
        return CLI_USAGE;
    }
    if (scene_path && resume_path) {
        cli_error("--resume takes the scene from the checkpoint: give no scene file");
        return CLI_USAGE;
    }
    if (roundtrip && (ckpt_path || resume_path)) {
        cli_error("--roundtrip cannot be combined with --checkpoint or --resume");
        return CLI_USAGE;
    }

    /* ---- input: everything is validated before any output is created */
    int status = CLI_USAGE;
    dth_registry *reg = cli_registry();
    dth_scene *scene = NULL;
    dth_run_setup rs;
    memset(&rs, 0, sizeof rs);
    dth_integrator *it = NULL;
    dth_fixed *fx = NULL;
    run_out r;
    memset(&r, 0, sizeof r);
    r.out.fd = -1;
    r.ev.fd = -1;
    double *zstart = NULL;
    char *ev_path = NULL;
    void *ck = NULL;
    size_t cklen = 0;
    cli_ckpt ckc; /* --resume: the checkpoint's run state (cli/ckpt.c) */
    memset(&ckc, 0, sizeof ckc);
    dth_scene *saved = NULL; /* the scene as the checkpointed run had it */
    if (!reg) return CLI_FAIL;
    int rc = dth_scene_new(NULL, &scene);
    if (!rc && resume_path) {
        const char *text;
        size_t tlen;
        rc = cli_ckpt_read(resume_path, &ck, &cklen, &text, &tlen, &ckc, err, sizeof err);
        if (!rc) {
            char name[1100];
            snprintf(name, sizeof name, "%s(scene)", resume_path);
            rc = dth_scene_load_mem(scene, name, text, tlen, err, sizeof err);
            if (!rc) rc = dth_scene_new(NULL, &saved);
            if (!rc) rc = dth_scene_load_mem(saved, name, text, tlen, err, sizeof err);
        }
    } else if (!rc) {
        rc = dth_scene_load(scene, scene_path, err, sizeof err);
    }
    for (int i = 0; !rc && i < nsets; i++) rc = dth_scene_set(scene, sets[i], err, sizeof err);
    /* a resume continues the checkpointed run: only its length and the output names may change */
    if (!rc && saved && cli_ckpt_check_scene(saved, scene, err, sizeof err)) rc = DTH_EINVAL;
    if (!rc) rc = dth_scene_setup(scene, reg, &rs, err, sizeof err);
    if (!rc && resume_path && cli_ckpt_check_length(&ckc, &rs, err, sizeof err)) rc = DTH_EINVAL;
    if (rc) {
        cli_error("%s", rc == DTH_ENOMEM ? "out of memory" : err);
        status = rc == DTH_ENOMEM ? CLI_FAIL : CLI_USAGE;
        goto done;
    }
    if (!scene_path) scene_path = resume_path;
    if (roundtrip && rs.dt > 0) {
        cli_error("--roundtrip writes vertices: it cannot be combined with [output] dt > 0");
        goto done;
    }
    int is_dth = strcmp(rs.method, "dth") == 0;
    if (!is_dth && (ckpt_path || resume_path)) {
        cli_error("checkpoints are written for method = dth only (this scene uses '%s')", rs.method);
        goto done;
    }
    if (!is_dth && strcmp(rs.regularize, "none")) {
        cli_error("[regularize] applies to method = dth only (this scene uses '%s')", rs.method);
        goto done;
    }

    /* the model's derivatives against finite differences at the initial state, once (dth_model_check;
     * its memory grows as (2n+1)^2: skipped above 200 degrees of freedom) */
    if (model_check && rs.n <= 200) {
        double *y = calloc(2 * rs.n + 1, sizeof *y);
        if (!y) {
            cli_error("out of memory");
            status = CLI_FAIL;
            goto done;
        }
        memcpy(y, rs.q0, rs.n * sizeof *y);
        y[rs.n] = rs.t0;
        memcpy(y + rs.n + 1, rs.p0, rs.n * sizeof *y);
        dth_model_check_report rep;
        rc = dth_model_check(rs.model, y, &rep);
        free(y);
        if (rc == DTH_OK && !rep.pass) {
            cli_error("%s: model '%s' fails its derivative check at the initial state: %s (--no-model-check runs "
                      "it anyway)", scene_path, dth_model_get_type(rs.model)->name, rep.message);
            goto done;
        }
    }

    r.rs = &rs;
    r.model = rs.model;
    r.n = rs.n;
    r.N = 2 * rs.n + 2;
    r.scene = scene;
    r.ckpt_path = ckpt_path;
    if (is_dth) {
        rc = dth_integrator_new(rs.model, &rs.opt, &it);
        if (!rc && resume_path) rc = dth_checkpoint_restore(it, ck, cklen, err, sizeof err);
        else if (!rc) rc = dth_integrator_start(it, rs.q0, rs.p0, rs.t0);
        if (rc && resume_path && it) {
            cli_error("%s", err);
            goto done;
        }
    } else {
        rc = dth_fixed_check(rs.model, rs.method, err, sizeof err);
        if (rc) {
            cli_error("%s: method '%s': %s", scene_path, rs.method, err);
            goto done;
        }
        rc = dth_fixed_new(rs.model, rs.method, rs.opt.h, NULL, &fx);
        if (!rc) rc = dth_fixed_start(fx, rs.q0, rs.p0, rs.t0);
    }
    if (rc) {
        /* a start the step size spoils (a first vertex that overflows, no offset that gives h): name h */
        char hh[96] = "";
        if (rc > 0 && !resume_path) snprintf(hh, sizeof hh, "; integrator.h = %.6g may be too large for this model", rs.opt.h);
        cli_error("%s: cannot start at the initial state: %s (%s)%s", scene_path, dth_strerror(rc),
                  it ? dth_integrator_errmsg(it) : fx ? dth_fixed_errmsg(fx) : "creating the integrator", hh);
        status = rc < 0 && rc != DTH_EINVAL ? CLI_FAIL : CLI_USAGE;
        goto done;
    }
    r.it = it;

    r.ninv = dth_model_n_invariants(rs.model);
    r.linecap = 32 * (r.N + r.ninv + 8) + 64;
    for (size_t i = 0; i < r.ninv; i++) r.linecap += strlen(dth_model_invariant_name(rs.model, i)) + 1;
    r.line = malloc(r.linecap);
    r.inv = calloc(r.ninv + 1, sizeof *r.inv);
    r.work = calloc(dth_model_work_size(rs.model), sizeof *r.work);
    zstart = calloc(r.N, sizeof *zstart);
    r.leg = roundtrip;
    size_t maxcol = 2 * r.N + r.ninv + 16;
    r.vals = calloc(maxcol, sizeof *r.vals);
    r.kind = calloc(maxcol, 1);
    r.ekind = calloc(maxcol, 1);
    if (!r.line || !r.inv || !r.work || !zstart || !r.vals || !r.kind || !r.ekind) {
        cli_error("out of memory");
        status = CLI_FAIL;
        goto done;
    }
    const char *path = out_opt ? (strcmp(out_opt, "-") ? out_opt : NULL) : rs.out_file;
    if (!out_opt && !rs.out_file && resume_path && ckc.out.path[0]) path = ckc.out.path;
    if (ckpt_path && !path) {
        cli_error("--checkpoint needs an output file (-o FILE or [output] file=): standard output cannot be resumed");
        goto done;
    }
    run_column_kinds(&r, 0, r.kind, &r.ncol);
    run_column_kinds(&r, 1, r.ekind, &r.encol);
    size_t plen = path ? strlen(path) : 0;
    int is_h5 = path && ((plen > 3 && !strcmp(path + plen - 3, ".h5")) || (plen > 5 && !strcmp(path + plen - 5, ".hdf5")));
    if (is_h5 && (ckpt_path || resume_path)) {
        cli_error("checkpoints cover CSV output only (the output '%s' is HDF5)", path);
        goto done;
    }
    if (is_h5 && (ev_opt || rs.events_file)) {
        cli_error("with HDF5 output the events are the table /events of '%s': give no events file", path);
        goto done;
    }
    r.has_ev = rs.nevents > 0 && !is_h5;
    if (r.has_ev) {
        const char *ep = ev_opt ? ev_opt : rs.events_file;
        if (ep) {
            ev_path = strdup(ep);
        } else if (path) {
            /* OUT.csv -> OUT-events.csv */
            size_t l = strlen(path);
            ev_path = malloc(l + 16);
            if (ev_path) {
                memcpy(ev_path, path, l + 1);
                if (l > 4 && !strcmp(path + l - 4, ".csv")) ev_path[l - 4] = '\0';
                strcat(ev_path, "-events.csv");
            }
        } else {
            cli_error("the scene has [events] and the trajectory goes to standard output: give the events file "
                      "([events] file= or --events FILE)");
            goto done;
        }
        if (!ev_path) {
            cli_error("out of memory");
            status = CLI_FAIL;
            goto done;
        }
    }
    /* an output that would overwrite an input (a resume may write its checkpoint over the one it
     * read: that is whole in memory, and a checkpoint is replaced atomically) */
    const char *outs[2] = {path, ev_path}, *scene_file = resume_path ? NULL : scene_path;
    for (int i = 0; i < 2; i++) {
        if (!outs[i]) continue;
        const char *clash = cli_same_file(outs[i], scene_file) ? "the scene file"
                            : cli_same_file(outs[i], ckpt_path) ? "the checkpoint file"
                            : resume_path && cli_same_file(outs[i], resume_path) ? "the checkpoint file" : NULL;
        if (i == 1 && !clash && cli_same_file(ev_path, path)) clash = "the trajectory's output";
        if (clash) {
            cli_error("refusing to write %s '%s': it is %s", i ? "events to" : "the output to", outs[i], clash);
            goto done;
        }
    }
    if (ckpt_path && cli_same_file(ckpt_path, scene_file)) {
        cli_error("refusing to write the checkpoint to '%s': it is the scene file", ckpt_path);
        goto done;
    }
    if (path) cli_make_parents(path);
    if (ev_path) cli_make_parents(ev_path);
    if (is_h5) {
        char herr[1200];
        size_t tl;
        char *text = NULL;
        if (dth_scene_text(scene, NULL, NULL, &text, &tl)) text = NULL;
        r.h5 = text ? h5_open(path, herr, sizeof herr) : NULL;
        if (!r.h5) {
            cli_error("%s", text ? herr : "out of memory");
            free(text);
            goto done;
        }
        /* provenance: the version and the command line; the scene as run_out */
        size_t cl = 64;
        for (int i = 0; i < argc; i++) cl += strlen(argv[i]) + 1;
        char *prov = malloc(cl);
        if (prov) {
            size_t k = (size_t)snprintf(prov, cl, "dth %s; command: dth", DTH_VERSION_STRING);
            for (int i = 0; i < argc; i++) k += (size_t)snprintf(prov + k, cl - k, " %s", argv[i]);
        }
        run_column_names(&r, 0);
        int hrc = !prov || h5_attr(r.h5, "scene", text) || h5_attr(r.h5, "provenance", prov) ||
                  h5_attr(r.h5, "region_codes", "0 -, 1 I, 2 II, 3 III") ||
                  h5_attr(r.h5, "branch_codes", "0 -, 1 minus, 2 plus, 3 ghost, 4 exact, 5 reg") ||
                  !(r.h5traj = h5_table(r.h5, "trajectory", r.ncol, r.line));
        free(text);
        free(prov);
        if (!hrc && rs.nevents) {
            size_t nl = 8;
            for (size_t i = 0; i < rs.nevents; i++) nl += strlen(rs.event_names[i]) + 8;
            char *names = malloc(nl);
            hrc = !names;
            if (names) {
                size_t k = 0;
                for (size_t i = 0; i < rs.nevents; i++)
                    k += (size_t)snprintf(names + k, nl - k, "%s%zu %s", i ? ", " : "", i, rs.event_names[i]);
                run_column_names(&r, 1);
                hrc = h5_attr(r.h5, "event_codes", names) || !(r.h5ev = h5_table(r.h5, "events", r.encol, r.line));
                free(names);
            }
        }
        if (hrc) {
            cli_error("cannot write '%s': HDF5 error", path);
            h5_abort(r.h5);
            r.h5 = NULL;
            status = CLI_FAIL;
            goto done;
        }
        /* rows go to HDF5; standard output stays empty */
    } else if (cli_out_open(&r.out, path)) {
        goto done; /* CLI_USAGE: the output cannot be written */
    }
    if (r.has_ev && cli_out_open(&r.ev, ev_path)) goto done;
    if (resume_path && run_resume_prefix(&r, &ckc, resume_path, ev_path)) {
        status = r.out.failed || r.ev.failed ? CLI_FAIL : CLI_USAGE;
        goto done;
    }
    cli_catch_signals();

    /* ---- tiny steps: warn when h is below the conditioning limit of the step (methods.h) */
    size_t n = r.n, N = r.N;
    if (it) memcpy(zstart, dth_integrator_vertex(it), N * sizeof *zstart);
    else {
        memcpy(zstart, dth_fixed_state(fx), (N - 1) * sizeof *zstart);
    }
    double hmin;
    if (is_dth && !resume_path && dth_step_floor(rs.model, zstart, 1e-6, &hmin, r.work) == DTH_OK && fabs(rs.opt.h) < hmin)
        cli_error("warning: |h| = %.3g is below the conditioning limit %.3g at the start: the step size is "
                  "known only to about 1e-6 relative or worse (docs/performance.md)", fabs(rs.opt.h), hmin);

    /* ---- a vertex start: the energy the run conserves (every midpoint's) against the initial
     * state's; an explicit wp: the first step it encodes against h (checked at the first sample) */
    if (is_dth && !resume_path && rs.opt.start == DTH_START_VERTEX) {
        double H0, E = dth_integrator_energy(it);
        if (!dth_model_eval(rs.model, zstart, DTH_EVAL_H, &H0, NULL, NULL) && fabs(E - H0) > 0.01 * fabs(H0))
            cli_error("warning: a vertex start conserves the energy %.10g at every midpoint; the initial state has "
                      "%.10g (%.3g %% apart: the vertex lies off the energy surface by the offset that encodes the "
                      "step; a midpoint start conserves the initial energy)",
                      E, H0, 100 * fabs(E - H0) / fabs(H0));
        r.check_wp = rs.opt.has_wp;
    }

    /* ---- the run (run.h) */
    dth_run_config cfg;
    dth_run_config_from_setup(&cfg, &rs);
    cfg.points = rs.points;
    cfg.on_event = run_on_event;
    cfg.every = rs.every;
    cfg.dt = rs.dt;
    cfg.sample = run_on_sample;
    cfg.user = &r;
    cfg.checkpoint = ckpt_path ? run_on_checkpoint : NULL;
    cfg.checkpoint_every = ckpt_every;
    cfg.progress = on_progress;
    cfg.progress_every = 1;
    r.progress = want_progress ? 2 : isatty(STDERR_FILENO) ? 1 : 0;
    r.progress_s = progress_s;
    r.t_start = r.last_progress = cli_now();
    dth_run_state S;
    dth_run_state_init(&S);
    if (resume_path) S = ckc.S;
    r.k_begin = S.k;
    r.t_begin = zstart[n];
    int werr = 0;
    if (!resume_path && (run_header(&r) || (r.has_ev && run_ev_header(&r)))) werr = 1;
    /* the checkpoint path is tried before the first step: a checkpoint of the start (or of the
     * resumed state), so a run never learns only at its first checkpoint that it cannot write one */
    if (!werr && ckpt_path && run_on_checkpoint(&r, &S)) {
        if (!r.out.failed && !r.ev.failed) {
            r.out.keep = r.ev.keep = 0;
            cli_out_abort(&r.out);
            if (r.has_ev) cli_out_abort(&r.ev);
            goto done; /* CLI_USAGE: like an output that cannot be written */
        }
        werr = 1;
    }
    /* temporaries of runs that were killed: once this run's own checkpoint stands (a resume's rows
     * are in this run's temporary), or at once without checkpoints */
    if (!werr && (ckpt_path || !resume_path)) run_clean_stale(path, ev_path, ckpt_path, resume_path ? &ckc : NULL);
    rc = werr ? DTH_OK : it ? dth_run(it, &cfg, &S) : dth_run_fixed(fx, &cfg, &S);
    if (rc == DTH_EIO && S.stop == DTH_RUN_CALLBACK) werr = 1;
    /* --roundtrip: reverse in place and take as many steps back (paper, time reversibility) */
    if (roundtrip && !werr && rc == DTH_OK) {
        long k1 = S.k;
        if (it) dth_integrator_reverse(it);
        else dth_fixed_set_h(fx, -rs.opt.h);
        r.leg = 2;
        cfg.has_t_end = 0;
        cfg.steps = 2 * k1;
        S.k0 = k1;
        S.t_stop = S.t;
        rc = it ? dth_run(it, &cfg, &S) : dth_run_fixed(fx, &cfg, &S);
        if (rc == DTH_EIO && S.stop == DTH_RUN_CALLBACK) werr = 1;
        if (!rc) {
            const double *z = it ? dth_integrator_vertex(it) : dth_fixed_state(fx);
            double e = 0, sc = 0;
            for (size_t i = 0; i < (it ? N : N - 1); i++) {
                e = fmax(e, fabs(z[i] - zstart[i]));
                sc = fmax(sc, fabs(zstart[i]));
            }
            fprintf(stderr, "dth: round trip of 2 x %ld steps: max |z - z_0| = %.3g (relative %.3g)\n", k1, e,
                    sc > 0 ? e / sc : e);
        }
    }
    int sig = r.sig && rc == DTH_ESTOPPED && !r.too_many ? r.sig : 0;
    if (r.progress == 1) fprintf(stderr, "\r%20s\r", "");
    if (werr) {
        if (r.h5) {
            cli_error("cannot write '%s' (HDF5)", path);
            h5_abort(r.h5);
            r.h5 = NULL;
        } else if (r.out.failed) cli_error("cannot write '%s': %s", path ? path : "standard output", strerror(r.out.err));
        else if (r.ev.failed) cli_error("cannot write '%s': %s", ev_path, strerror(r.ev.err));
        /* what the last good checkpoint needs stays (its temporaries are kept): fix the cause, then resume */
        if (r.ckpt_written)
            cli_error("the checkpoint '%s' of step %ld and the rows it needs are kept: dth run --resume %s continues "
                      "the run once the cause is fixed", ckpt_path, r.ckpt_k, ckpt_path);
        status = CLI_FAIL;
        goto done;
    }
    if (r.h5) {
        char herr[1200];
        int hrc = h5_finish(r.h5, herr, sizeof herr);
        r.h5 = NULL;
        if (hrc) {
            cli_error("%s", herr);
            status = CLI_FAIL;
            goto done;
        }
    } else if (cli_out_finish(&r.out) || (r.has_ev && cli_out_finish(&r.ev))) {
        status = CLI_FAIL;
        goto done;
    }
    if (resume_path && !ckpt_path) run_clean_stale(path, ev_path, NULL, &ckc); /* the resumed run's files are complete */
    /* how the run ended: always when it could not go on, else for regularized runs and on a tty */
    char crossing[160] = "";
    if (S.crossings || S.regularized)
        snprintf(crossing, sizeof crossing, "; %ld psi = 0 crossings, %ld regularized steps, largest step ratio "
                 "at a crossing %.3g", S.crossings, S.regularized, S.max_ratio);
    const char *emsg = it ? dth_integrator_errmsg(it) : dth_fixed_errmsg(fx);
    if (r.too_many) {
        cli_error("stopped at k=%ld, t=%.17g: output.dt = %.3g asks for more than %d rows within one step (a larger "
                  "output.dt, or output.points = vertices; the rows so far are kept)", S.k, S.t, rs.dt,
                  MAX_SAMPLES_PER_STEP);
        status = CLI_USAGE;
    } else if (sig) {
        cli_error("interrupted at k=%ld, t=%.17g (the rows so far are kept)%s", S.k, S.t, crossing);
        status = 128 + sig;
    } else if (rc > 0) {
        char hint[256];
        if (S.k - r.k_begin <= 1 && !resume_path) /* the first solved step failed: the step size is the key to change */
            snprintf(hint, sizeof hint, "; the first step failed: a smaller step may pass: -s integrator.h=%.6g",
                     rs.opt.h / 4);
        else if (is_dth)
            cli_stop_hint(rs.regularize, rc, rs.opt.h, rs.model, dth_integrator_vertex(it), dth_integrator_lambda(it),
                          hint, sizeof hint);
        else
            hint[0] = '\0';
        cli_error("stopped at k=%ld, t=%.17g: %s (%s)%s%s", S.k, S.t, dth_strerror(rc), emsg, crossing, hint);
        status = CLI_STOPPED;
    } else if (rc < 0) {
        cli_error("error at k=%ld, t=%.17g: %s (%s)", S.k, S.t, dth_strerror(rc), emsg);
        status = CLI_FAIL;
    } else {
        status = CLI_OK;
        if (r.progress == 1 || S.regularized)
            fprintf(stderr, "dth: %ld steps to t = %.17g, %ld rows to %s%s\n", S.k, S.t_stop, S.samples,
                    path ? path : "standard output", crossing);
        if (r.has_ev && (r.progress == 1 || S.stop == DTH_RUN_EVENT))
            fprintf(stderr, "dth: %ld events to %s%s\n", S.events, ev_path,
                    S.stop == DTH_RUN_EVENT ? " (the run ended at a terminal event)" : "");
    }
done:
    if (r.h5) h5_abort(r.h5);
    if (r.out.fd >= 0 && r.out.buf) cli_out_abort(&r.out);
    if (r.ev.fd >= 0 && r.ev.buf) cli_out_abort(&r.ev);
    free(ev_path);
    free(r.vals);
    free(r.kind);
    free(r.ekind);
    free(r.line);
    free(r.inv);
    free(r.work);
    free(zstart);
    dth_free(NULL, ck);
    cli_ckpt_clear(&ckc);
    dth_scene_free(saved);
    dth_integrator_free(it);
    dth_fixed_free(fx);
    dth_run_setup_clear(&rs);
    dth_scene_free(scene);
    dth_registry_free(reg);
    return status;
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
