/* SPDX-License-Identifier: MIT */
/*
 * dth run: integrate a scene with the DTH step (paper, Theorem "DTH Equations"), or a fixed-step
 * baseline method, and write the vertices z_k (or the piecewise-linear trajectory resampled at
 * uniform times) as CSV, with optional per-vertex diagnostics psi, psi', the region of section 5
 * and the branch taken. Also checkpoints and resumes runs bit for bit.
 */
#include <math.h>
#include <stdarg.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>
#include "cli.h"

/* ---------------------------------------------------------------- the stepper */

/*
 * One interface over the DTH integrator and the fixed-step baselines. For a baseline the CSV's
 * wp column holds -H_phys at the start, so its H column shows the energy error.
 */
typedef struct stepper {
    dth_integrator *it; /* method = dth */
    dth_fixed *fx;      /* a baseline */
    double *z;          /* baseline: its state as an extended vector (q, t, p, wp) */
    size_t N;
    double wp;
    double h;           /* baseline: its step (exact, not a difference of times) */
} stepper;

typedef struct step_rec {
    double lambda;
    int iters;
    dth_branch branch;
    unsigned flags;
} step_rec;

static const double *st_vertex(const stepper *s)
{
    if (s->it) return dth_integrator_vertex(s->it);
    memcpy(s->z, dth_fixed_state(s->fx), (s->N - 1) * sizeof *s->z);
    s->z[s->N - 1] = s->wp;
    return s->z;
}

static int st_step(stepper *s, step_rec *rec)
{
    memset(rec, 0, sizeof *rec);
    if (s->it) {
        dth_step_info info;
        int rc = dth_integrator_step(s->it, &info);
        rec->lambda = info.lambda;
        rec->iters = info.iters;
        rec->branch = info.branch;
        rec->flags = info.flags;
        return rc;
    }
    dth_fixed_info info;
    int rc = dth_fixed_step(s->fx, &info);
    rec->lambda = s->h;
    rec->iters = info.iters;
    return rc;
}

static const char *st_errmsg(const stepper *s)
{
    return s->it ? dth_integrator_errmsg(s->it) : dth_fixed_errmsg(s->fx);
}

/* ---------------------------------------------------------------- rows */

typedef struct run {
    const dth_run_setup *rs;
    const dth_model *model;
    size_t n, N, ninv;
    double *inv, *work, *zi;
    char *line;
    size_t linecap, len;
    cli_out out;
    int leg; /* --roundtrip: 1 forward, 2 return (a `leg` column); 0: no column */
} run;

static void put(run *r, const char *fmt, ...) __attribute__((format(printf, 2, 3)));
static void put(run *r, const char *fmt, ...)
{
    va_list ap;
    va_start(ap, fmt);
    int w = vsnprintf(r->line + r->len, r->linecap - r->len, fmt, ap);
    va_end(ap);
    if (w > 0) r->len += (size_t)w;
    if (r->len >= r->linecap) r->len = r->linecap - 1; /* cannot happen: linecap is sized for the row */
}

static int header(run *r)
{
    r->len = 0;
    put(r, "k,t,lambda");
    for (size_t i = 0; i < r->n; i++) put(r, ",q%zu", i + 1);
    for (size_t i = 0; i < r->n; i++) put(r, ",p%zu", i + 1);
    put(r, ",wp,H");
    if (r->rs->diagnostics) {
        for (size_t i = 0; i < r->ninv; i++) put(r, ",%s", dth_model_invariant_name(r->model, i));
        put(r, ",psi,dpsi,region,iters,branch");
    }
    if (r->leg) put(r, ",leg");
    return cli_out_line(&r->out, r->line, r->len);
}

/*
 * One row at the point z: a vertex, or an interpolated point. `in` is the step that arrived
 * there; lambda_root a known root of the step constraint at z (for the local K estimate) and K
 * a fixed K (> 0) or 0.
 */
static int row(run *r, long k, const double *z, const step_rec *in, double lambda_root, double K)
{
    size_t n = r->n, N = r->N;
    double Hp, H = NAN;
    if (dth_model_eval(r->model, z, DTH_EVAL_H, &Hp, NULL, NULL) == DTH_OK) H = z[N - 1] + Hp;
    r->len = 0;
    put(r, "%ld,%.17g,%.17g", k, z[n], in->lambda);
    for (size_t i = 0; i < n; i++) put(r, ",%.17g", z[i]);
    for (size_t i = 0; i < n; i++) put(r, ",%.17g", z[n + 1 + i]);
    put(r, ",%.17g,%.17g", z[N - 1], H);
    if (r->rs->diagnostics) {
        if (r->ninv && dth_model_invariants(r->model, z, r->inv) != DTH_OK)
            for (size_t i = 0; i < r->ninv; i++) r->inv[i] = NAN;
        for (size_t i = 0; i < r->ninv; i++) put(r, ",%.17g", r->inv[i]);
        dth_diag d;
        if (dth_diagnose(r->model, z, lambda_root, K, &d, r->work) == DTH_OK)
            put(r, ",%.17g,%.17g,%s,%d,%s", d.psi, d.dpsi, dth_region_name(d.region), in->iters,
                dth_branch_name(in->branch));
        else
            put(r, ",nan,nan,-,%d,%s", in->iters, dth_branch_name(in->branch));
    }
    if (r->leg) put(r, ",%d", r->leg);
    return cli_out_line(&r->out, r->line, r->len);
}

/* K that a vertex's diagnostics use: for rows interpolated inside its outgoing segment. */
static double vertex_K(run *r, const double *z, double lambda_out)
{
    dth_diag d;
    if (dth_diagnose(r->model, z, lambda_out, r->rs->opt.K, &d, r->work) != DTH_OK) return 0;
    return d.K;
}

/* ---------------------------------------------------------------- run state and statistics */

/* Everything the loop carries from one step to the next: what a checkpoint must hold. */
typedef struct loop {
    long k, rows, j;      /* vertex index; output rows; next dense-output sample */
    step_rec in;          /* the step that arrived at the current vertex */
    long crossings;       /* steps flagged as crossing psi = 0 */
    long regularized;     /* steps a regularizer replaced or fixed up */
    double max_ratio;     /* largest ratio of consecutive steps around a crossing */
    int prev_crossing;    /* the step that arrived was a crossing */
} loop;

static void account(loop *L, const step_rec *s)
{
    int cross = (s->flags & DTH_STEP_CROSSING) != 0;
    if (cross) L->crossings++;
    if (s->flags & DTH_STEP_REGULARIZED) L->regularized++;
    if ((cross || L->prev_crossing) && L->in.lambda != 0 && s->lambda != 0) {
        double q = fabs(s->lambda / L->in.lambda);
        L->max_ratio = fmax(L->max_ratio, fmax(q, 1 / q));
    }
    L->prev_crossing = cross;
}

/* ---------------------------------------------------------------- checkpoints */

/* The "cli" blob: the loop state, the output file's progress and the vertex the rows lag on. */
typedef struct ckpt_cli {
    uint32_t version;     /* of this blob's layout */
    uint32_t dense;       /* dt > 0 */
    loop L;
    uint64_t csv_bytes;   /* bytes of CSV that belong to rows already final */
    char out_path[1024];  /* where the checkpointed run writes: final name ... */
    char out_tmp[1100];   /* ... and its temporary name while running ("" if none) */
} ckpt_cli;

enum { CKPT_CLI_VERSION = 1 };

/* Keep an entry in the saved scene? Of steps= and t_end=, only the one in force (one may come
 * from the file and the other from an override that won). */
static int saved(const char *sec, const char *key, int has_t_end)
{
    if (strcmp(sec, "integrator")) return 1;
    return has_t_end ? strcmp(key, "steps") != 0 : strcmp(key, "t_end") != 0;
}

/* The scene as INI text (long values split at commas over continuation lines). */
static char *scene_text(const dth_scene *s, int has_t_end, size_t *len)
{
    size_t cap = 256, n = 0;
    for (size_t i = 0; i < dth_scene_count(s); i++) {
        const char *sec, *key, *val, *org;
        dth_scene_entry(s, i, &sec, &key, &val, &org);
        cap += strlen(sec) + strlen(key) + 2 * strlen(val) + 64;
    }
    char *t = malloc(cap);
    if (!t) return NULL;
    const char *cur = "";
    for (size_t pass = 0; pass < dth_scene_count(s); pass++) {
        const char *sec, *key, *val, *org;
        dth_scene_entry(s, pass, &sec, &key, &val, &org);
        /* entries of one section are written together under one header */
        int seen = 0;
        for (size_t i = 0; i < pass; i++) {
            const char *s2, *k2, *v2, *o2;
            dth_scene_entry(s, i, &s2, &k2, &v2, &o2);
            if (!strcmp(s2, sec)) seen = 1;
        }
        if (seen) continue;
        cur = sec;
        n += (size_t)snprintf(t + n, cap - n, "[%s]\n", cur);
        for (size_t i = pass; i < dth_scene_count(s); i++) {
            dth_scene_entry(s, i, &sec, &key, &val, &org);
            if (strcmp(sec, cur) || !saved(sec, key, has_t_end)) continue;
            n += (size_t)snprintf(t + n, cap - n, "%s = ", key);
            size_t col = strlen(key) + 3;
            for (const char *v = val; *v;) {
                const char *c = strchr(v, ',');
                size_t l = c ? (size_t)(c - v) + 1 : strlen(v);
                if (col + l > 150 && col > 8) {
                    n += (size_t)snprintf(t + n, cap - n, "\n    ");
                    col = 4;
                    while (*v == ' ') v++, l--;
                }
                memcpy(t + n, v, l);
                n += l;
                col += l;
                v += l;
            }
            t[n++] = '\n';
        }
    }
    t[n] = '\0';
    *len = n;
    return t;
}

static int write_checkpoint(const char *path, const dth_integrator *it, const dth_scene *scene,
                            const dth_run_setup *rs, const loop *L, cli_out *o)
{
    if (cli_out_sync(o)) return -1;
    ckpt_cli c;
    memset(&c, 0, sizeof c);
    c.version = CKPT_CLI_VERSION;
    c.dense = rs->dt > 0;
    c.L = *L;
    c.csv_bytes = o->written;
    if (o->path) snprintf(c.out_path, sizeof c.out_path, "%s", o->path);
    if (o->tmp) snprintf(c.out_tmp, sizeof c.out_tmp, "%s", o->tmp);
    size_t tlen;
    char *text = scene_text(scene, rs->has_t_end, &tlen);
    if (!text) return -1;
    dth_blob blobs[] = {{"scene", text, tlen}, {"cli", &c, sizeof c}};
    char err[256];
    int rc = dth_checkpoint_write_file(it, blobs, 2, path, err, sizeof err);
    free(text);
    if (rc) cli_error("%s", err);
    return rc ? -1 : 0;
}

/* ---------------------------------------------------------------- the command */

static void usage_run(FILE *f)
{
    fprintf(f, "usage: dth run SCENE.ini [-s section.key=value]... [-o FILE] [--roundtrip]\n"
               "                [--checkpoint FILE [--checkpoint-every N]]\n"
               "       dth run --resume CHECKPOINT [-s section.key=value]... [-o FILE] [--checkpoint ...]\n"
               "  -s section.key=value  override a scene key (applied after the file, in order)\n"
               "  -o FILE               write the CSV to FILE ('-': standard output); wins over [output] file=\n"
               "  --roundtrip           after the run, reverse and take as many steps back; rows get a column\n"
               "                        leg (1 forward, 2 back) and stderr the distance to the start\n"
               "  --checkpoint FILE     save the full state to FILE (crash-safely) every N steps (default\n"
               "                        1000) and when the run ends; the CSV is flushed to disk first\n"
               "  --resume CHECKPOINT   continue a checkpointed run: the scene comes from the checkpoint,\n"
               "                        -s may change steps/t_end (counted from the original start); the\n"
               "                        output is the rows the run had written plus the rest, bit for bit\n");
}

static void progress(double frac, int on, double *last)
{
    if (!on) return;
    double now = cli_now();
    if (now - *last < 0.25) return;
    *last = now;
    fprintf(stderr, "\rdth run: %3.0f%%", 100 * fmin(fmax(frac, 0), 1));
}

int cli_cmd_run(int argc, char **argv)
{
    const char *scene_path = NULL, *out_opt = NULL, *ckpt_path = NULL, *resume_path = NULL;
    long ckpt_every = 1000;
    char err[1024];
    int roundtrip = 0;
    for (int i = 1; i < argc; i++) {
        const char *a = argv[i];
        if (!strcmp(a, "-h") || !strcmp(a, "--help")) {
            usage_run(stdout);
            return CLI_OK;
        } else if (!strcmp(a, "-s") || !strcmp(a, "-o") || !strcmp(a, "--checkpoint") ||
                   !strcmp(a, "--checkpoint-every") || !strcmp(a, "--resume")) {
            if (i + 1 >= argc) {
                cli_error("option %s needs an argument (try dth run --help)", a);
                return CLI_USAGE;
            }
            const char *v = argv[++i];
            if (!strcmp(a, "-o")) out_opt = v;
            else if (!strcmp(a, "--checkpoint")) ckpt_path = v;
            else if (!strcmp(a, "--resume")) resume_path = v;
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
    stepper st;
    memset(&st, 0, sizeof st);
    run r;
    memset(&r, 0, sizeof r);
    r.out.fd = -1;
    double *zprev = NULL, *zstart = NULL;
    void *ck = NULL;
    size_t cklen = 0;
    const ckpt_cli *ckc = NULL;
    ckpt_cli ckc_copy; /* blobs sit unaligned in the checkpoint buffer */
    if (!reg) return CLI_FAIL;
    int rc = dth_scene_new(NULL, &scene);
    if (!rc && resume_path) {
        const void *text, *cb;
        size_t tlen, cblen;
        rc = dth_checkpoint_read_file(resume_path, NULL, &ck, &cklen, err, sizeof err);
        if (!rc && (dth_checkpoint_blob(ck, cklen, "scene", &text, &tlen) ||
                    dth_checkpoint_blob(ck, cklen, "cli", &cb, &cblen) || cblen != sizeof ckc_copy ||
                    (memcpy(&ckc_copy, cb, sizeof ckc_copy), ckc_copy.version != CKPT_CLI_VERSION))) {
            snprintf(err, sizeof err, "%s: not a checkpoint of dth run (no scene or loop state)", resume_path);
            rc = DTH_EPARSE;
        }
        if (!rc) {
            ckc = &ckc_copy;
            char name[1100];
            snprintf(name, sizeof name, "%s(scene)", resume_path);
            rc = dth_scene_load_mem(scene, name, text, tlen, err, sizeof err);
        }
    } else if (!rc) {
        rc = dth_scene_load(scene, scene_path, err, sizeof err);
    }
    for (int i = 1; !rc && i < argc; i++) {
        if (!strcmp(argv[i], "-o") || !strcmp(argv[i], "--checkpoint") || !strcmp(argv[i], "--resume") ||
            !strcmp(argv[i], "--checkpoint-every"))
            i++;
        else if (!strcmp(argv[i], "-s"))
            rc = dth_scene_set(scene, argv[++i], err, sizeof err);
    }
    if (!rc) rc = dth_scene_setup(scene, reg, &rs, err, sizeof err);
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
    if (ckc && ckc->dense != (rs.dt > 0)) {
        cli_error("%s: the checkpointed run %s resample ([output] dt); keep it as it was", resume_path,
                  ckc->dense ? "did" : "did not");
        goto done;
    }

    r.rs = &rs;
    r.model = rs.model;
    r.n = rs.n;
    r.N = 2 * rs.n + 2;
    st.N = r.N;
    if (is_dth) {
        rc = dth_integrator_new(rs.model, &rs.opt, &st.it);
        if (!rc && ck) rc = dth_checkpoint_restore(st.it, ck, cklen, err, sizeof err);
        else if (!rc) rc = dth_integrator_start(st.it, rs.q0, rs.p0, rs.t0);
        if (rc && ck && st.it) {
            cli_error("%s", err);
            goto done;
        }
    } else {
        rc = dth_fixed_check(rs.model, rs.method, err, sizeof err);
        if (rc) {
            cli_error("%s: method '%s': %s", scene_path, rs.method, err);
            goto done;
        }
        st.z = calloc(r.N, sizeof *st.z);
        st.h = rs.opt.h;
        rc = st.z ? dth_fixed_new(rs.model, rs.method, st.h, NULL, &st.fx) : DTH_ENOMEM;
        if (!rc) rc = dth_fixed_start(st.fx, rs.q0, rs.p0, rs.t0);
        if (!rc) {
            double H;
            rc = dth_model_eval(rs.model, dth_fixed_state(st.fx), DTH_EVAL_H, &H, NULL, NULL);
            st.wp = -H;
        }
    }
    if (rc) {
        cli_error("%s: cannot start at the initial state: %s (%s)", scene_path, dth_strerror(rc),
                  st.it || st.fx ? st_errmsg(&st) : "creating the integrator");
        status = rc < 0 && rc != DTH_EINVAL ? CLI_FAIL : CLI_USAGE;
        goto done;
    }

    r.ninv = dth_model_n_invariants(rs.model);
    r.linecap = 32 * (r.N + r.ninv + 8) + 64;
    for (size_t i = 0; i < r.ninv; i++) r.linecap += strlen(dth_model_invariant_name(rs.model, i)) + 1;
    r.line = malloc(r.linecap);
    r.inv = calloc(r.ninv + 1, sizeof *r.inv);
    r.work = calloc(dth_model_work_size(rs.model), sizeof *r.work);
    r.zi = calloc(r.N, sizeof *r.zi);
    zprev = calloc(r.N, sizeof *zprev);
    zstart = calloc(r.N, sizeof *zstart);
    r.leg = roundtrip;
    if (!r.line || !r.inv || !r.work || !r.zi || !zprev || !zstart) {
        cli_error("out of memory");
        status = CLI_FAIL;
        goto done;
    }
    const char *path = out_opt ? (strcmp(out_opt, "-") ? out_opt : NULL) : rs.out_file;
    if (!out_opt && !rs.out_file && ckc && ckc->out_path[0]) path = ckc->out_path;
    if (ckpt_path && !path) {
        cli_error("--checkpoint needs an output file (-o FILE or [output] file=): standard output cannot be resumed");
        goto done;
    }
    if (cli_out_open(&r.out, path)) goto done; /* CLI_USAGE: the output cannot be written */
    if (ckc) {
        /* the rows the checkpointed run had made final: from its temporary file if it was
         * killed, else from the file it finished */
        const char *src = ckc->out_tmp[0] && access(ckc->out_tmp, R_OK) == 0 ? ckc->out_tmp : ckc->out_path;
        if (!src[0] || cli_out_copy_prefix(&r.out, src, ckc->csv_bytes)) {
            cli_error("%s: the checkpointed run's output '%s' is missing or shorter than its %llu bytes",
                      resume_path, src[0] ? src : "(standard output)", (unsigned long long)ckc->csv_bytes);
            cli_out_abort(&r.out);
            goto done;
        }
    }
    cli_catch_signals();

    /* ---- tiny steps: warn when h is below the conditioning limit of the step (methods.h) */
    size_t n = r.n, N = r.N;
    memcpy(zprev, st_vertex(&st), N * sizeof *zprev);
    memcpy(zstart, zprev, N * sizeof *zstart);
    double hmin;
    if (is_dth && !ck && dth_step_floor(rs.model, zprev, 1e-6, &hmin, r.work) == DTH_OK && fabs(rs.opt.h) < hmin)
        cli_error("warning: |h| = %.3g is below the conditioning limit %.3g at the start: the step size is "
                  "known only to about 1e-6 relative or worse (docs/performance.md)", fabs(rs.opt.h), hmin);

    /* ---- a vertex start: the energy the run conserves (every midpoint's) against the initial
     * state's; an explicit wp: the first step it encodes against h */
    if (is_dth && !ck && rs.opt.start == DTH_START_VERTEX) {
        double H0, E = dth_integrator_energy(st.it);
        if (!dth_model_eval(rs.model, zprev, DTH_EVAL_H, &H0, NULL, NULL) && fabs(E - H0) > 0.01 * fabs(H0))
            cli_error("warning: a vertex start conserves the energy %.10g at every midpoint; the initial state has "
                      "%.10g (%.3g %% apart: the vertex lies off the energy surface by the offset that encodes the "
                      "step; a midpoint start conserves the initial energy)",
                      E, H0, 100 * fabs(E - H0) / fabs(H0));
    }

    /* ---- the run: rows lag one step behind so each vertex knows its outgoing step */
    double dir = rs.opt.h > 0 ? 1.0 : -1.0;
    const int tty = isatty(STDERR_FILENO);
    double t_start = cli_now(), last_progress = t_start;
    const double t_first = ck ? rs.t0 : zprev[n];
    loop L;
    memset(&L, 0, sizeof L);
    if (ckc) L = ckc->L;
    int werr = 0, sig = 0;
    rc = DTH_OK;
    if (!ckc) werr = header(&r);
    long since_ckpt = 0;
    for (;;) {
        int final = rs.has_t_end ? dir * (zprev[n] - rs.t_end) >= 0 : L.k >= rs.steps;
        if (final || werr) break;
        if ((sig = cli_signal_received()) != 0) break;
        if (ckpt_path && since_ckpt >= ckpt_every) {
            if (write_checkpoint(ckpt_path, st.it, scene, &rs, &L, &r.out)) {
                werr = 1;
                break;
            }
            since_ckpt = 0;
        }
        step_rec s;
        rc = st_step(&st, &s);
        if (rc) break;
        if (is_dth && !ck && L.k == 0 && rs.opt.has_wp && fabs(s.lambda / rs.opt.h - 1) > 0.1)
            cli_error("warning: the explicit [initial] wp encodes a first step of %.6g, not h = %.6g (without wp a vertex "
                      "start solves for the wp whose first step is h)", s.lambda, rs.opt.h);
        account(&L, &s);
        const double *z = st_vertex(&st);
        if (rs.dt > 0) {
            /* samples t0 + j dt inside the segment zprev -> z, never beyond t_end */
            double K = rs.diagnostics ? vertex_K(&r, zprev, s.lambda) : 0;
            for (;; L.j++) {
                double t = rs.t0 + dir * (double)L.j * rs.dt;
                if (dir * (t - z[n]) > 0) break;
                if (rs.has_t_end && dir * (t - rs.t_end) > 1e-9 * rs.dt) break;
                dth_interpolate(n, zprev, z, t, r.zi);
                if ((werr = row(&r, L.rows++, r.zi, &s, 0, K)) != 0) break;
            }
        } else if (L.k % rs.every == 0) {
            werr = row(&r, L.k, zprev, &L.in, s.lambda, rs.opt.K);
            L.rows++;
        }
        memcpy(zprev, z, N * sizeof *zprev);
        L.k++;
        L.in = s;
        since_ckpt++;
        cli_out_maybe_flush(&r.out);
        progress(rs.has_t_end ? (zprev[n] - t_first) / (rs.t_end - t_first) : (double)L.k / (double)rs.steps, tty,
                 &last_progress);
    }
    /* the state at the last vertex, before its (final) row: what a resumed run continues from */
    if (ckpt_path && !werr && write_checkpoint(ckpt_path, st.it, scene, &rs, &L, &r.out)) werr = 1;
    /* the last vertex is always written (in dense mode: when it is itself a sample time) */
    if (!werr && rs.dt <= 0) {
        werr = row(&r, L.k, zprev, &L.in, -L.in.lambda, rs.opt.K);
        L.rows++;
    } else if (!werr && zprev[n] == rs.t0 + dir * (double)L.j * rs.dt && L.k == 0) {
        werr = row(&r, L.rows++, zprev, &L.in, 0, rs.opt.K);
    }
    /* --roundtrip: reverse in place and take as many steps back (paper, time reversibility) */
    if (roundtrip && !werr && !sig && rc == DTH_OK) {
        long k1 = L.k;
        if (st.it) dth_integrator_reverse(st.it);
        else dth_fixed_set_h(st.fx, st.h = -rs.opt.h);
        r.leg = 2;
        for (long kb = 1; kb <= k1 && !werr; kb++) {
            if ((sig = cli_signal_received()) != 0) break;
            step_rec s;
            rc = st_step(&st, &s);
            if (rc) break;
            account(&L, &s);
            L.in = s;
            L.k++;
            if (kb % rs.every == 0 || kb == k1) {
                werr = row(&r, L.k, st_vertex(&st), &s, -s.lambda, rs.opt.K);
                L.rows++;
            }
            cli_out_maybe_flush(&r.out);
        }
        memcpy(zprev, st_vertex(&st), N * sizeof *zprev);
        if (!rc && !sig) {
            double e = 0, sc = 0;
            for (size_t i = 0; i < N; i++) {
                e = fmax(e, fabs(zprev[i] - zstart[i]));
                sc = fmax(sc, fabs(zstart[i]));
            }
            fprintf(stderr, "dth: round trip of 2 x %ld steps: max |z - z_0| = %.3g (relative %.3g)\n", k1, e,
                    sc > 0 ? e / sc : e);
        }
    }
    if (tty) fprintf(stderr, "\r%20s\r", "");
    if (werr) {
        cli_error("cannot write '%s': %s", path ? path : "standard output", strerror(r.out.err));
        cli_out_abort(&r.out);
        status = CLI_FAIL;
        goto done;
    }
    if (cli_out_finish(&r.out)) {
        status = CLI_FAIL;
        goto done;
    }
    /* how the run ended: always when it could not go on, else for regularized runs and on a tty */
    char crossing[160] = "";
    if (L.crossings || L.regularized)
        snprintf(crossing, sizeof crossing, "; %ld psi = 0 crossings, %ld regularized steps, largest step ratio "
                 "at a crossing %.3g", L.crossings, L.regularized, L.max_ratio);
    if (sig) {
        cli_error("interrupted at k=%ld, t=%.17g (the rows so far are kept)%s", L.k, zprev[n], crossing);
        status = 128 + sig;
    } else if (rc > 0) {
        char hint[128];
        cli_error("stopped at k=%ld, t=%.17g: %s (%s)%s%s", L.k, zprev[n], dth_strerror(rc), st_errmsg(&st), crossing,
                  is_dth ? cli_stop_hint(rs.regularize, rc, rs.opt.h, hint, sizeof hint) : "");
        status = CLI_STOPPED;
    } else if (rc < 0) {
        cli_error("error at k=%ld, t=%.17g: %s (%s)", L.k, zprev[n], dth_strerror(rc), st_errmsg(&st));
        status = CLI_FAIL;
    } else {
        status = CLI_OK;
        if (tty || L.regularized)
            fprintf(stderr, "dth: %ld steps to t = %.17g, %ld rows to %s%s\n", L.k, zprev[n], L.rows,
                    path ? path : "standard output", crossing);
    }
done:
    if (r.out.fd >= 0 && r.out.buf) cli_out_abort(&r.out);
    free(r.line);
    free(r.inv);
    free(r.work);
    free(r.zi);
    free(zprev);
    free(zstart);
    free(st.z);
    free(ck);
    dth_integrator_free(st.it);
    dth_fixed_free(st.fx);
    dth_run_setup_clear(&rs);
    dth_scene_free(scene);
    dth_registry_free(reg);
    return status;
}
