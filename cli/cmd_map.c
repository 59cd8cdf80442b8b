/* SPDX-License-Identifier: MIT */
/*
 * dth map: a phase-plane well-posedness map like the paper's Figure 1 (section 1): at every point
 * of a (q_i, p_i) grid taken as a vertex, psi, psi' = [psi, H], the region of section 5 and the
 * classified roots of the step constraint (Theorems EU_1-EU_3 and "ghost"; lib/branch.c), plus the
 * scene's own DTH trajectory to draw on top (scripts/plot-map.sh renders both).
 */
#include <errno.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include "cli.h"
#ifdef _OPENMP
#include <omp.h>
#endif

/* Most grid points one map computes (the results are held in memory until written in grid order). */
#define MAP_MAX_POINTS 4000000L
/* Most steps of the overlaid trajectory. */
#define MAP_MAX_STEPS 1000000L

/* What one grid point gives. */
typedef struct cell {
    double psi, dpsi;             /* at the vertex (NaN if the model cannot be evaluated there) */
    double lam[3];                /* lambda-, lambda+, nearest ghost; NaN where absent */
    int status;                   /* of the root search (DTH_OK: region and nroots are valid) */
    int region;                   /* dth_region */
    int nroots;
} cell;

/* Read-only description of the map, shared by all threads. */
typedef struct map {
    const dth_model *model;
    size_t n, dof;                /* degrees of freedom; the one mapped (0-based) */
    const double *q0, *p0;        /* the other degrees of freedom stay at these */
    double t0, h, L, K;
    cli_grid q, p;
} map;

/* One thread's workspace: root finders are not shared between threads. */
typedef struct worker {
    dth_rootfinder *rf;
    double *z, *work;
} worker;

static void usage_map(FILE *f)
{
    fprintf(f,
            "usage: dth map SCENE.ini --q a:b:n --p c:d:m [--dof i] [--range L] [--out PREFIX]\n"
            "               [-s section.key=value]...\n"
            "  --q a:b:n     n grid values of q_i from a to b (n >= 1)\n"
            "  --p c:d:m     m grid values of p_i from c to d\n"
            "  --dof i       the degree of freedom mapped (1..n, default 1); the others stay at the scene's\n"
            "                initial values\n"
            "  --range L     search roots in [-L, L] (default 16 |h|)\n"
            "  --out PREFIX  write PREFIX.csv (the map) and PREFIX-traj.csv (the scene's trajectory);\n"
            "                default out/map\n"
            "  each grid point is a vertex with the offset a vertex start with the scene's h gives\n"
            "  (wp = -H_phys + psi h^2/8); PREFIX.csv has one row per point, q-major:\n"
            "    q,p,psi,dpsi,region,nroots,lambda_minus,lambda_plus,lambda_ghost\n"
            "  (empty fields: no such root; lambda_ghost is the ghost nearest 0)\n"
            "  PREFIX-traj.csv: k,t,q,p,lambda,end (end, on the last row: t_end, steps, limit or the\n"
            "  status that stopped the trajectory)\n"
            "  render with scripts/plot-map.sh\n");
}

/* "a:b:n" into ax; prints the error. */
static int parse_axis(const char *opt, const char *s, cli_grid *ax)
{
    int rc = cli_parse_grid(s, MAP_MAX_POINTS, ax);
    if (rc == CLI_GRID_FORM)
        cli_error("%s: '%s' is not of the form a:b:n", opt, s);
    else if (rc == CLI_GRID_BOUNDS)
        cli_error("%s: '%s': the bounds must be finite numbers", opt, s);
    else if (rc)
        cli_error("%s: '%s': the number of points must be an integer from 1 to %ld", opt, s, MAP_MAX_POINTS);
    return rc ? -1 : 0;
}

static void worker_free(worker *w)
{
    dth_rootfinder_free(w->rf);
    free(w->z);
    free(w->work);
    memset(w, 0, sizeof *w);
}

static int worker_new(const map *mp, worker *w)
{
    memset(w, 0, sizeof *w);
    dth_root_options ro;
    dth_root_options_default(&ro);
    ro.K = mp->K;
    int rc = dth_rootfinder_new(mp->model, &ro, NULL, &w->rf);
    if (rc) return rc;
    w->z = calloc(2 * mp->n + 2, sizeof *w->z);
    w->work = calloc(dth_model_work_size(mp->model) + 1, sizeof *w->work);
    if (!w->z || !w->work) {
        worker_free(w);
        return DTH_ENOMEM;
    }
    return DTH_OK;
}

/*
 * The point (q, p) as a vertex: its offset is what a vertex start would give (as in
 * dth_integrator_start: wp = -H_phys + psi h^2/8, the same arithmetic), then every root of g.
 */
static void map_point(const map *mp, worker *w, double q, double p, cell *c)
{
    size_t n = mp->n, N = 2 * n + 2;
    double *z = w->z, Hp, psi = NAN, dpsi = NAN;
    memcpy(z, mp->q0, n * sizeof *z);
    z[n] = mp->t0;
    memcpy(z + n + 1, mp->p0, n * sizeof *z);
    z[mp->dof] = q;
    z[n + 1 + mp->dof] = p;
    c->lam[0] = c->lam[1] = c->lam[2] = NAN;
    c->region = DTH_REGION_NONE;
    c->nroots = 0;
    int rc = dth_model_eval(mp->model, z, DTH_EVAL_H, &Hp, NULL, NULL);
    if (!rc) rc = dth_model_psi(mp->model, z, &psi, &dpsi, w->work);
    c->psi = psi;
    c->dpsi = dpsi;
    if (rc) {
        c->status = rc;
        return;
    }
    z[N - 1] = -Hp + psi * mp->h * mp->h / 8;
    dth_root_set s;
    rc = dth_find_roots(w->rf, z, mp->L, &s);
    c->status = rc;
    if (rc) return;
    /* psi and psi' as the search computed them: they decide the region and the classes */
    c->psi = s.vertex.psi;
    c->dpsi = s.vertex.dpsi;
    c->region = (int)s.vertex.region;
    c->nroots = (int)s.count;
    for (size_t i = 0; i < s.count; i++) {
        const dth_root *r = &s.root[i];
        if (r->cls == DTH_BRANCH_MINUS) c->lam[0] = r->lambda;
        else if (r->cls == DTH_BRANCH_PLUS) c->lam[1] = r->lambda;
        else if (r->cls == DTH_BRANCH_GHOST && !(fabs(r->lambda) >= fabs(c->lam[2]))) c->lam[2] = r->lambda;
    }
}

/* Append ",%.17g", or "," alone for NaN (an absent value). */
static size_t put_num(char *line, size_t len, size_t cap, double x)
{
    int w = isnan(x) ? snprintf(line + len, cap - len, ",") : snprintf(line + len, cap - len, ",%.17g", x);
    return w > 0 && len + (size_t)w < cap ? len + (size_t)w : cap - 1;
}

static int write_map(cli_out *o, const map *mp, const cell *cells)
{
    char line[512];
    const char *hdr = "q,p,psi,dpsi,region,nroots,lambda_minus,lambda_plus,lambda_ghost";
    if (cli_out_line(o, hdr, strlen(hdr))) return -1;
    for (long i = 0; i < mp->q.n; i++)
        for (long j = 0; j < mp->p.n; j++) {
            const cell *c = &cells[i * mp->p.n + j];
            size_t len = (size_t)snprintf(line, sizeof line, "%.17g", cli_grid_at(&mp->q, i));
            len = put_num(line, len, sizeof line, cli_grid_at(&mp->p, j));
            len = put_num(line, len, sizeof line, c->psi);
            len = put_num(line, len, sizeof line, c->dpsi);
            if (c->status == DTH_OK)
                len += (size_t)snprintf(line + len, sizeof line - len, ",%s,%d", dth_region_name((dth_region)c->region),
                                        c->nroots);
            else
                len += (size_t)snprintf(line + len, sizeof line - len, ",,");
            for (int k = 0; k < 3; k++) len = put_num(line, len, sizeof line, c->lam[k]);
            if (cli_out_line(o, line, len)) return -1;
            cli_out_maybe_flush(o);
        }
    return 0;
}

/*
 * The scene's trajectory (its own start, h, steps or t_end, branch policy and regularizer), projected
 * on the mapped (q_i, p_i). *stop receives the status that ended it (DTH_OK: it ran to the end),
 * *kstop and *tstop the last vertex written.
 */
static int write_traj(cli_out *o, const dth_run_setup *rs, size_t dof, int *stop, long *kstop, double *tstop)
{
    size_t n = rs->n;
    dth_integrator *it = NULL;
    char line[256];
    const char *hdr = "k,t,q,p,lambda,end";
    *kstop = 0;
    *tstop = rs->t0;
    if (cli_out_line(o, hdr, strlen(hdr))) return -1;
    int rc = dth_integrator_new(rs->model, &rs->opt, &it);
    if (!rc) rc = dth_integrator_start(it, rs->q0, rs->p0, rs->t0);
    *stop = rc;
    if (rc) {
        dth_integrator_free(it);
        return 0;
    }
    double dir = rs->opt.h > 0 ? 1.0 : -1.0, lam = 0;
    int wrc = 0;
    for (long k = 0;; k++) {
        const double *z = dth_integrator_vertex(it);
        double t = z[n], q = z[dof], p = z[n + 1 + dof]; /* before the step moves the vertex */
        const char *end = NULL;
        if (rs->has_t_end ? dir * (t - rs->t_end) >= 0 : k >= rs->steps) end = rs->has_t_end ? "t_end" : "steps";
        else if (k >= MAP_MAX_STEPS) end = "limit";
        dth_step_info info;
        if (!end && (rc = dth_integrator_step(it, &info)) != DTH_OK) end = dth_status_name(rc);
        int len = snprintf(line, sizeof line, "%ld,%.17g,%.17g,%.17g,%.17g,%s", k, t, q, p, lam, end ? end : "");
        *kstop = k;
        *tstop = t;
        if ((wrc = cli_out_line(o, line, (size_t)len)) != 0 || end || cli_signal_received()) break;
        lam = info.lambda;
        cli_out_maybe_flush(o);
    }
    *stop = rc;
    dth_integrator_free(it);
    return wrc;
}


/* What each step of the command returns to let it go on; else it returns the exit status, having
 * printed why. */
enum { GO_ON = -1 };

/* One dth map: its options, the scene, the results and the two outputs. */
typedef struct map_cmd {
    const char *scene_path, *prefix, *qspec, *pspec;
    double L;
    long dof1;
    cli_grid qa, pa;
    dth_registry *reg;
    dth_scene *scene;
    dth_run_setup rs;
    map mp;
    long total;
    cell *cells;
    char *path_map, *path_traj;
    cli_out om, ot;
} map_cmd;

/* The option a (one that takes a value) with its value v (-s is applied with the scene). */
static int option_value(map_cmd *c, const char *a, const char *v)
{
    if (!strcmp(a, "--range") && (dth_parse_double(v, &c->L) || !(c->L > 0))) {
        cli_error("--range: '%s' is not a positive number", v);
        return CLI_USAGE;
    } else if (!strcmp(a, "--out")) {
        if (!v[0]) {
            cli_error("--out: the prefix is empty");
            return CLI_USAGE;
        }
        c->prefix = v;
    } else if (!strcmp(a, "--q")) {
        if (parse_axis(a, v, &c->qa)) return CLI_USAGE;
        c->qspec = v;
    } else if (!strcmp(a, "--p")) {
        if (parse_axis(a, v, &c->pa)) return CLI_USAGE;
        c->pspec = v;
    } else if (!strcmp(a, "--dof")) {
        char *end;
        errno = 0;
        c->dof1 = strtol(v, &end, 10);
        if (errno || end == v || *end || c->dof1 < 1) {
            cli_error("--dof: '%s' is not a positive integer", v);
            return CLI_USAGE;
        }
    }
    return GO_ON;
}

/* The command line into c: GO_ON, or the exit status (CLI_OK after --help). */
static int parse_args(int argc, char **argv, map_cmd *c)
{
    for (int i = 1; i < argc; i++) {
        const char *a = argv[i];
        int st = GO_ON;
        if (!strcmp(a, "-h") || !strcmp(a, "--help")) {
            usage_map(stdout);
            return CLI_OK;
        } else if (!strcmp(a, "-s") || !strcmp(a, "--range") || !strcmp(a, "--out") || !strcmp(a, "--q") ||
                   !strcmp(a, "--p") || !strcmp(a, "--dof")) {
            if (i + 1 >= argc) {
                cli_error("option %s needs an argument (try dth map --help)", a);
                return CLI_USAGE;
            }
            st = option_value(c, a, argv[++i]);
        } else if (a[0] == '-' && a[1]) {
            cli_error("unknown option '%s' (try dth map --help)", a);
            return CLI_USAGE;
        } else if (c->scene_path) {
            cli_error("more than one scene file ('%s' and '%s')", c->scene_path, a);
            return CLI_USAGE;
        } else {
            c->scene_path = a;
        }
        if (st != GO_ON) return st;
    }
    if (!c->scene_path) {
        cli_error("no scene file (usage: dth map SCENE.ini --q a:b:n --p c:d:m [--range L] [--out PREFIX])");
        return CLI_USAGE;
    }
    if (!c->qspec || !c->pspec) {
        cli_error("the grid needs both --q a:b:n and --p c:d:m (try dth map --help)");
        return CLI_USAGE;
    }
    if (c->qa.n * c->pa.n > MAP_MAX_POINTS) {
        cli_error("the grid has %ld x %ld points, more than %ld", c->qa.n, c->pa.n, MAP_MAX_POINTS);
        return CLI_USAGE;
    }
    return GO_ON;
}

/* The scene with the -s overrides, set up; the map's description. */
static int load_scene(map_cmd *c, int argc, char **argv)
{
    char err[1024];
    if (!(c->reg = cli_registry())) return CLI_FAIL;
    int rc = dth_scene_new(NULL, &c->scene);
    if (!rc) rc = dth_scene_load(c->scene, c->scene_path, err, sizeof err);
    for (int i = 1; !rc && i < argc; i++) {
        if (!strcmp(argv[i], "-s")) rc = dth_scene_set(c->scene, argv[++i], err, sizeof err);
        else if (argv[i][0] == '-' && argv[i][1] && strcmp(argv[i], "-h")) i++;
    }
    if (!rc) rc = dth_scene_setup(c->scene, c->reg, &c->rs, err, sizeof err);
    if (rc) {
        cli_error("%s", rc == DTH_ENOMEM ? "out of memory" : err);
        return rc == DTH_ENOMEM ? CLI_FAIL : CLI_USAGE;
    }
    const dth_run_setup *rs = &c->rs;
    if ((size_t)c->dof1 > rs->n) {
        cli_error("--dof %ld: the model of '%s' has %zu degree%s of freedom", c->dof1, c->scene_path, rs->n,
                  rs->n == 1 ? "" : "s");
        return CLI_USAGE;
    }
    c->mp = (map){.model = rs->model, .n = rs->n, .dof = (size_t)c->dof1 - 1, .q0 = rs->q0, .p0 = rs->p0,
                  .t0 = rs->t0, .h = rs->opt.h, .L = c->L > 0 ? c->L : 16 * fabs(rs->opt.h), .K = rs->opt.K,
                  .q = c->qa, .p = c->pa};
    c->total = c->qa.n * c->pa.n;
    return GO_ON;
}

/* The results' memory and both outputs (neither may be the scene), opened before the work so an
 * unwritable prefix fails at once. */
static int open_outputs(map_cmd *c)
{
    c->cells = calloc((size_t)c->total, sizeof *c->cells);
    size_t plen = strlen(c->prefix) + 16;
    c->path_map = malloc(plen);
    c->path_traj = malloc(plen);
    if (!c->cells || !c->path_map || !c->path_traj) {
        cli_error("out of memory");
        return CLI_FAIL;
    }
    snprintf(c->path_map, plen, "%s.csv", c->prefix);
    snprintf(c->path_traj, plen, "%s-traj.csv", c->prefix);
    const cli_input scene[] = {{c->scene_path, "the scene file"}};
    if (cli_check_clash("the map", c->path_map, scene, 1) || cli_check_clash("the trajectory", c->path_traj, scene, 1))
        return CLI_USAGE;
    cli_make_parents(c->path_map);
    if (cli_out_open(&c->om, c->path_map)) return CLI_USAGE;
    if (cli_out_open(&c->ot, c->path_traj)) return CLI_USAGE;
    return GO_ON;
}

/* The map: every point independent, results stored by grid index and written in order after the
 * loop, so the output is the same bits for any thread count and schedule. */
static int compute_map(map_cmd *c)
{
    const map *mp = &c->mp;
    long total = c->total, np = c->pa.n;
    cell *cells = c->cells;
    int nomem = 0, sig = 0;
    cli_catch_signals(); /* Ctrl-C: skip the remaining points, remove the temporary files */
#ifdef _OPENMP
#pragma omp parallel reduction(| : nomem)
#endif
    {
        worker w;
        int wrc = worker_new(mp, &w);
        if (wrc) nomem = 1;
#ifdef _OPENMP
#pragma omp for schedule(dynamic, 16)
#endif
        for (long k = 0; k < total; k++) {
            if (wrc || cli_signal_received()) continue;
            map_point(mp, &w, cli_grid_at(&mp->q, k / np), cli_grid_at(&mp->p, k % np), &cells[k]);
        }
        worker_free(&w);
    }
    if ((sig = cli_signal_received()) != 0) {
        cli_error("interrupted (no output written)");
        return 128 + sig;
    }
    if (nomem) {
        cli_error("out of memory (a root finder per thread)");
        return CLI_FAIL;
    }
    return GO_ON;
}

/* The map's rows and the trajectory's, put in place; notes on failed points and a stopped
 * trajectory; the exit status. */
static int write_outputs(map_cmd *c)
{
    long failed = 0;
    for (long k = 0; k < c->total; k++) failed += c->cells[k].status != DTH_OK;
    if (write_map(&c->om, &c->mp, c->cells)) {
        cli_error("cannot write '%s': %s", c->path_map, strerror(c->om.err));
        return CLI_FAIL;
    }
    int stop, sig;
    long ksteps = 0;
    double tstop = c->rs.t0;
    if (write_traj(&c->ot, &c->rs, c->mp.dof, &stop, &ksteps, &tstop)) {
        cli_error("cannot write '%s': %s", c->path_traj, strerror(c->ot.err));
        return CLI_FAIL;
    }
    if ((sig = cli_signal_received()) != 0) {
        cli_error("interrupted (no output written)");
        return 128 + sig;
    }
    if (cli_out_finish(&c->om) || cli_out_finish(&c->ot)) return CLI_FAIL;
    if (failed)
        cli_error("note: the root search failed at %ld of %ld grid points (their region and roots are empty)",
                  failed, c->total);
    if (stop > 0)
        cli_error("note: the trajectory stopped at k=%ld, t=%.17g: %s", ksteps, tstop, dth_strerror(stop));
    if (stop < 0) {
        cli_error("the trajectory failed at k=%ld, t=%.17g: %s", ksteps, tstop, dth_strerror(stop));
        return CLI_FAIL;
    }
    return CLI_OK;
}

int cli_cmd_map(int argc, char **argv)
{
    map_cmd c;
    memset(&c, 0, sizeof c);
    c.prefix = "out/map";
    c.dof1 = 1;
    c.om.fd = c.ot.fd = -1;
    int st = parse_args(argc, argv, &c);
    if (st == GO_ON) st = load_scene(&c, argc, argv);
    if (st == GO_ON) st = open_outputs(&c);
    if (st == GO_ON) st = compute_map(&c);
    if (st == GO_ON) st = write_outputs(&c);
    if (c.om.fd >= 0 && c.om.buf) cli_out_abort(&c.om);
    if (c.ot.fd >= 0 && c.ot.buf) cli_out_abort(&c.ot);
    free(c.cells);
    free(c.path_map);
    free(c.path_traj);
    dth_run_setup_clear(&c.rs);
    dth_scene_free(c.scene);
    dth_registry_free(c.reg);
    return st;
}
