/* SPDX-License-Identifier: MIT */
/*
 * dth run: integrate a scene with the DTH step (paper, Theorem "DTH Equations") and write the
 * vertices z_k, or the piecewise-linear trajectory resampled at uniform times, as CSV, with
 * optional per-vertex diagnostics psi, psi' and the region of section 5.
 */
#include <math.h>
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>
#include "cli.h"
#include "dth_internal.h" /* dth__model_self: the invariants callback needs the model's state */

typedef struct run {
    const dth_run_setup *rs;
    const dth_model *model;
    const dth_model_type *type;
    size_t n, N, ninv;
    double *inv, *work, *zi;
    char *line;
    size_t linecap, len;
    cli_out out;
    int leg;          /* --roundtrip: 1 forward, 2 return (a `leg` column); 0: no column */
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
        for (size_t i = 0; i < r->ninv; i++) put(r, ",%s", r->type->invariant_name(dth__model_self(r->model), i));
        put(r, ",psi,dpsi,region,iters");
    }
    if (r->leg) put(r, ",leg");
    return cli_out_line(&r->out, r->line, r->len);
}

/*
 * One row at the point z: a vertex, or an interpolated point. lambda_root is a known root of the
 * step constraint at z (for the local K estimate) and K a fixed K (> 0) or 0.
 */
static int row(run *r, long k, const double *z, double lambda, int iters, double lambda_root, double K)
{
    size_t n = r->n, N = r->N;
    double Hp, H = NAN;
    if (dth_model_eval(r->model, z, DTH_EVAL_H, &Hp, NULL, NULL) == DTH_OK) H = z[N - 1] + Hp;
    r->len = 0;
    put(r, "%ld,%.17g,%.17g", k, z[n], lambda);
    for (size_t i = 0; i < n; i++) put(r, ",%.17g", z[i]);
    for (size_t i = 0; i < n; i++) put(r, ",%.17g", z[n + 1 + i]);
    put(r, ",%.17g,%.17g", z[N - 1], H);
    if (r->rs->diagnostics) {
        if (r->ninv && r->type->invariants(dth__model_self(r->model), z, r->inv) != 0)
            for (size_t i = 0; i < r->ninv; i++) r->inv[i] = NAN;
        for (size_t i = 0; i < r->ninv; i++) put(r, ",%.17g", r->inv[i]);
        dth_diag d;
        if (dth_diagnose(r->model, z, lambda_root, K, &d, r->work) == DTH_OK)
            put(r, ",%.17g,%.17g,%s,%d", d.psi, d.dpsi, dth_region_name(d.region), iters);
        else
            put(r, ",nan,nan,-,%d", iters);
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

static void usage_run(FILE *f)
{
    fprintf(f, "usage: dth run SCENE.ini [-s section.key=value]... [-o FILE] [--roundtrip]\n"
               "  -s section.key=value  override a scene key (applied after the file, in order)\n"
               "  -o FILE               write the CSV to FILE ('-': standard output); wins over [output] file=\n"
               "  --roundtrip           after the run, reverse and take as many steps back; rows get a column\n"
               "                        leg (1 forward, 2 back) and stderr the distance to the start\n");
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
    const char *scene_path = NULL, *out_opt = NULL;
    char err[1024];
    int roundtrip = 0;
    for (int i = 1; i < argc; i++) {
        const char *a = argv[i];
        if (!strcmp(a, "-h") || !strcmp(a, "--help")) {
            usage_run(stdout);
            return CLI_OK;
        } else if (!strcmp(a, "-s") || !strcmp(a, "-o")) {
            if (i + 1 >= argc) {
                cli_error("option %s needs an argument (try dth run --help)", a);
                return CLI_USAGE;
            }
            if (a[1] == 'o') out_opt = argv[i + 1];
            i++;
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
    if (!scene_path) {
        cli_error("no scene file (usage: dth run SCENE.ini [-s section.key=value]... [-o FILE])");
        return CLI_USAGE;
    }

    /* ---- input: everything is validated before any output is created */
    int status = CLI_USAGE;
    dth_registry *reg = cli_registry();
    dth_scene *scene = NULL;
    dth_run_setup rs;
    memset(&rs, 0, sizeof rs);
    dth_integrator *it = NULL;
    run r;
    memset(&r, 0, sizeof r);
    r.out.fd = -1;
    double *zprev = NULL, *zstart = NULL;
    if (!reg) return CLI_FAIL;
    int rc = dth_scene_new(NULL, &scene);
    if (!rc) rc = dth_scene_load(scene, scene_path, err, sizeof err);
    for (int i = 1; !rc && i < argc; i++) {
        if (!strcmp(argv[i], "-o")) i++;
        else if (!strcmp(argv[i], "-s")) rc = dth_scene_set(scene, argv[++i], err, sizeof err);
    }
    if (!rc) rc = dth_scene_setup(scene, reg, &rs, err, sizeof err);
    if (rc) {
        cli_error("%s", rc == DTH_ENOMEM ? "out of memory" : err);
        status = rc == DTH_ENOMEM ? CLI_FAIL : CLI_USAGE;
        goto done;
    }
    if (roundtrip && rs.dt > 0) {
        cli_error("--roundtrip writes vertices: it cannot be combined with [output] dt > 0");
        goto done;
    }
    rc = dth_integrator_new(rs.model, &rs.opt, &it);
    if (!rc) rc = dth_integrator_start(it, rs.q0, rs.p0, rs.t0);
    if (rc) {
        cli_error("%s: cannot start at the initial state: %s (%s)", scene_path, dth_strerror(rc),
                  it ? dth_integrator_errmsg(it) : "creating the integrator");
        status = rc < 0 && rc != DTH_EINVAL ? CLI_FAIL : CLI_USAGE;
        goto done;
    }

    r.rs = &rs;
    r.model = rs.model;
    r.type = dth_model_get_type(rs.model);
    r.n = rs.n;
    r.N = 2 * rs.n + 2;
    r.ninv = r.type->n_invariants && r.type->invariants && r.type->invariant_name
                 ? r.type->n_invariants(dth__model_self(rs.model)) : 0;
    r.linecap = 32 * (r.N + r.ninv + 8) + 64;
    for (size_t i = 0; i < r.ninv; i++) r.linecap += strlen(r.type->invariant_name(dth__model_self(rs.model), i)) + 1;
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
    if (cli_out_open(&r.out, path)) goto done; /* CLI_USAGE: the output cannot be written */
    cli_catch_signals();

    /* ---- the run: rows lag one step behind so each vertex knows its outgoing step */
    size_t n = r.n, N = r.N;
    double dir = rs.opt.h > 0 ? 1.0 : -1.0;
    const int tty = isatty(STDERR_FILENO);
    double t_start = cli_now(), last_progress = t_start;
    memcpy(zprev, dth_integrator_vertex(it), N * sizeof *zprev);
    memcpy(zstart, zprev, N * sizeof *zstart);
    const double t_first = zprev[n];
    long k = 0, rows = 0, j = 0; /* vertex index; output rows; next dense-output sample */
    double lam_in = 0;
    int iters_in = 0, werr = 0, sig = 0;
    rc = DTH_OK;
    werr = header(&r);
    for (;;) {
        int final = rs.has_t_end ? dir * (zprev[n] - rs.t_end) >= 0 : k >= rs.steps;
        if (final || werr) break;
        if ((sig = cli_signal_received()) != 0) break;
        dth_step_info info;
        rc = dth_integrator_step(it, &info);
        if (rc) break;
        const double *z = dth_integrator_vertex(it);
        if (rs.dt > 0) {
            /* samples t0 + j dt inside the segment zprev -> z, never beyond t_end */
            double K = rs.diagnostics ? vertex_K(&r, zprev, info.lambda) : 0;
            for (;; j++) {
                double t = rs.t0 + dir * (double)j * rs.dt;
                if (dir * (t - z[n]) > 0) break;
                if (rs.has_t_end && dir * (t - rs.t_end) > 1e-9 * rs.dt) break;
                dth_interpolate(n, zprev, z, t, r.zi);
                if ((werr = row(&r, rows++, r.zi, info.lambda, info.iters, 0, K)) != 0) break;
            }
        } else if (k % rs.every == 0) {
            werr = row(&r, k, zprev, lam_in, iters_in, info.lambda, rs.opt.K);
            rows++;
        }
        memcpy(zprev, z, N * sizeof *zprev);
        k++;
        lam_in = info.lambda;
        iters_in = info.iters;
        cli_out_maybe_flush(&r.out);
        progress(rs.has_t_end ? (zprev[n] - t_first) / (rs.t_end - t_first) : (double)k / (double)rs.steps, tty,
                 &last_progress);
    }
    /* the last vertex is always written (in dense mode: when it is itself a sample time) */
    if (!werr && rs.dt <= 0) {
        werr = row(&r, k, zprev, lam_in, iters_in, -lam_in, rs.opt.K);
        rows++;
    } else if (!werr && zprev[n] == rs.t0 + dir * (double)j * rs.dt && k == 0) {
        werr = row(&r, rows++, zprev, lam_in, iters_in, 0, rs.opt.K);
    }
    /* --roundtrip: reverse in place and take as many steps back (paper, time reversibility) */
    if (roundtrip && !werr && !sig && rc == DTH_OK) {
        long k1 = k;
        dth_integrator_reverse(it);
        r.leg = 2;
        for (long kb = 1; kb <= k1 && !werr; kb++) {
            if ((sig = cli_signal_received()) != 0) break;
            dth_step_info info;
            rc = dth_integrator_step(it, &info);
            if (rc) break;
            k++;
            if (kb % rs.every == 0 || kb == k1) {
                werr = row(&r, k, dth_integrator_vertex(it), info.lambda, info.iters, -info.lambda, rs.opt.K);
                rows++;
            }
            cli_out_maybe_flush(&r.out);
        }
        memcpy(zprev, dth_integrator_vertex(it), N * sizeof *zprev);
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
    if (sig) {
        cli_error("interrupted at k=%ld, t=%.17g (the rows so far are kept)", k, zprev[n]);
        status = 128 + sig;
    } else if (rc > 0) {
        cli_error("stopped at k=%ld, t=%.17g: %s (%s)", k, zprev[n], dth_strerror(rc), dth_integrator_errmsg(it));
        status = CLI_STOPPED;
    } else if (rc < 0) {
        cli_error("error at k=%ld, t=%.17g: %s (%s)", k, zprev[n], dth_strerror(rc), dth_integrator_errmsg(it));
        status = CLI_FAIL;
    } else {
        status = CLI_OK;
        if (tty)
            fprintf(stderr, "dth: %ld steps to t = %.6g, %ld rows to %s in %.3g s\n", k, zprev[n], rows,
                    path ? path : "standard output", cli_now() - t_start);
    }
done:
    if (r.out.fd >= 0 && r.out.buf) cli_out_abort(&r.out);
    free(r.line);
    free(r.inv);
    free(r.work);
    free(r.zi);
    free(zprev);
    free(zstart);
    dth_integrator_free(it);
    dth_run_setup_clear(&rs);
    dth_scene_free(scene);
    dth_registry_free(reg);
    return status;
}
