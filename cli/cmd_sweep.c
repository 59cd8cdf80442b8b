/* SPDX-License-Identifier: MIT */
/*
 * dth sweep: an ensemble of trajectories of one scene, one per point of a parameter grid (--vary) or
 * row of a list (--list), each integrated by the run driver (run.h), with one summary row per run:
 * status, steps, end time, energy error, invariant drifts, psi = 0 crossings (paper, section 7),
 * the regularized share, events, and MEGNO / a Lyapunov estimate from the DTH tangent map
 * (chaos.h). OpenMP threads on one machine; with the meson feature mpi, MPI ranks across machines
 * (mpirun -n N dth sweep ...), static or dynamic distribution. Results are stored by run index and
 * written in order, so the output is the same bytes for any number of threads and ranks.
 */
#include <ctype.h>
#include <errno.h>
#include <stddef.h>
#include <stdint.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include "cli.h"
#include "fmt.h"
#ifdef _OPENMP
#include <omp.h>
#endif
#ifdef DTH_HAVE_MPI
#include <mpi.h>
#endif

#define SWEEP_MAX_RUNS 100000000L
#define SWEEP_MAX_KEYS 16
#define SWEEP_MAX_INV 8
#define SWEEP_MEGNO_SHARE 0.5 /* MEGNO and lyapunov only from a window of at least this share of the run */

/* One varied key: section.key, or section.key[i] (element i, 1-based, of a comma-separated list). */
typedef struct vkey {
    char sec[64], key[64];
    int elem;        /* 0: the whole value */
    cli_grid g;      /* --vary: the grid a:b:n */
} vkey;

/* The numbers of one summary row (doubles, so that MPI moves them as one array). */
enum {
    R_STATUS, R_SETUP, R_STEPS, R_T, R_EERR, R_CROSS, R_REG, R_EVENTS, R_MEGNO, R_LYAP, R_MEGT, R_ERRQ, R_ERRP, R_MEM,
    R_NINV, R_INV,
    R_LEN = R_INV + SWEEP_MAX_INV
};

/* The library's heap of one run, counted (--stats: memory per run): every allocation of the scene,
 * the model, the regularizer, the integrator, the driver and MEGNO goes through it. */
typedef struct counter {
    size_t cur, peak;
} counter;

typedef union hdr {
    size_t size;
    max_align_t align;
} hdr;

static void *count_alloc(void *ctx, size_t size)
{
    counter *c = ctx;
    hdr *h = size <= SIZE_MAX - sizeof *h ? malloc(sizeof *h + size) : NULL;
    if (!h) return NULL;
    h->size = size;
    c->cur += size;
    if (c->cur > c->peak) c->peak = c->cur;
    return h + 1;
}

static void count_free(void *ctx, void *p)
{
    if (!p) return;
    hdr *h = (hdr *)p - 1;
    ((counter *)ctx)->cur -= h->size;
    free(h);
}

typedef struct sweep {
    const char *scene_path;
    char *text;              /* the scene file */
    size_t textlen;
    const char **sets;       /* -s overrides, in order */
    int nsets;
    vkey keys[SWEEP_MAX_KEYS];
    int nkeys;
    int is_list;
    char ***list;            /* --list: row r, key j -> the value text */
    const char *list_path;
    long *list_line;         /* --list: row r's line in the file */
    long nruns;
    const dth_registry *reg;
    int megno;               /* follow MEGNO (DTH runs) */
    const char *traj;        /* --trajectories PREFIX, or NULL */
    int traj_width;          /* digits of the run number in trajectory file names */
    double *rec;             /* nruns x R_LEN */
    int ninv;                /* invariants of run 0's model (summary columns) */
    char inv_names[SWEEP_MAX_INV][32];
} sweep;

static void usage_sweep(FILE *f)
{
    fprintf(f,
            "usage: dth sweep SCENE.ini (--vary section.key=a:b:n)... [-s section.key=value]... [-o FILE]\n"
            "       dth sweep SCENE.ini --list FILE [-s section.key=value]... [-o FILE]\n"
            "  --vary K=a:b:n    n values of the scene key K from a to b (n >= 1); several --vary span a grid,\n"
            "                    the first one varying slowest. K is section.key, or section.key[i] for element i\n"
            "                    (1-based) of a list such as initial.q\n"
            "  --list FILE       one run per row of a CSV file: a header of keys K, then their values (verbatim;\n"
            "                    quote a value holding commas: \"0, 0.1\"; lines starting with # are skipped)\n"
            "  -s K=value        override a key of every run (before the varied ones)\n"
            "  -o FILE           the summary CSV (default: standard output)\n"
            "  --trajectories P  also write each run's trajectory to P-RUN.csv (the scene's [output] points, every,\n"
            "                    dt; the columns of dth run without diagnostics), and its [events] to\n"
            "                    P-RUN-events.csv (without it the events are counted only)\n"
            "  --no-megno        skip MEGNO (it costs a tangent map per step)\n"
            "  --no-model-check  skip the check of the model's derivatives at the first run's initial state\n"
            "  --model-lib F:SYM load a model type from a shared object: SYM names its const dth_model_type\n"
            "  --schedule static|dynamic  how MPI ranks share the runs (default dynamic: chunks from a counter)\n"
            "  --chunk N         runs per chunk of the dynamic schedule (default 16)\n"
            "  --stats           print the wall time, runs per second and the library's heap per run to stderr\n"
            "summary columns: run, the varied keys, status (ok or the status name), steps, t (where the run ended),\n"
            "  energy_error (largest |E - E0|/|E0| over the step midpoints; vertices for baseline methods),\n"
            "  NAME_drift per invariant (largest |I - I0| over the vertices relative to the largest |I|, I0 at the\n"
            "  first vertex),\n"
            "  psi_crossings, regularized_share,\n"
            "  events, megno, lyapunov, megno_t (the time MEGNO followed: the indicators end at the first\n"
            "  regularized step, which has no tangent map; see lib/include/dth/chaos.h; megno and lyapunov are\n"
            "  empty when megno_t is under half of the run), err_q, err_p (the estimated global error |dq|, |dp|\n"
            "  where the run ended). Empty: not available.\n"
            "threads: OMP_NUM_THREADS; ranks: mpirun -n N dth sweep ... (meson feature mpi). The output is the same\n"
            "bytes for any number of threads and ranks. Exit 0 when every run could be set up (a trajectory that\n"
            "stops early is a status in its row), 2 for bad input, 1 for a hard error, 128 + signal when\n"
            "interrupted (no summary is written).\n");
}

/* ---------------------------------------------------------------- parsing */

/* "section.key" or "section.key[i]" into k; prints the error. */
static int parse_key(const char *opt, const char *s, size_t len, vkey *k)
{
    memset(k, 0, sizeof *k);
    const char *dot = memchr(s, '.', len), *br = memchr(s, '[', len);
    size_t end = br ? (size_t)(br - s) : len;
    if (!dot || dot == s || (size_t)(dot - s) >= sizeof k->sec || end <= (size_t)(dot - s) + 1 ||
        end - (size_t)(dot - s) - 1 >= sizeof k->key) {
        cli_error("%s: '%.*s' is not section.key or section.key[i]", opt, (int)len, s);
        return -1;
    }
    memcpy(k->sec, s, (size_t)(dot - s));
    memcpy(k->key, dot + 1, end - (size_t)(dot - s) - 1);
    if (br) {
        char *e;
        long i = strtol(br + 1, &e, 10);
        if (e == br + 1 || *e != ']' || (size_t)(e - s) != len - 1 || i < 1 || i > 100000) {
            cli_error("%s: '%.*s': the element index must be a positive integer in [ ]", opt, (int)len, s);
            return -1;
        }
        k->elem = (int)i;
    }
    return 0;
}

/* The varied key k[j] must differ from k[0 .. j-1]: the same key twice (or a whole list and one of
 * its elements) would set it twice, the last value silently winning. Prints "WHERE: WHAT j (KEY) sets
 * what WHAT i (KEY) sets" (where may be NULL) and returns -1. */
static int check_unique(const char *where, const char *what, const vkey *k, int j)
{
    for (int i = 0; i < j; i++) {
        if (strcmp(k[i].sec, k[j].sec) || strcmp(k[i].key, k[j].key)) continue;
        if (k[i].elem && k[j].elem && k[i].elem != k[j].elem) continue; /* two elements of one list */
        char a[160], b[160];
        snprintf(a, sizeof a, k[j].elem ? "%s.%s[%d]" : "%s.%s", k[j].sec, k[j].key, k[j].elem);
        snprintf(b, sizeof b, k[i].elem ? "%s.%s[%d]" : "%s.%s", k[i].sec, k[i].key, k[i].elem);
        cli_error("%s%s%s %d (%s) sets what %s %d (%s) sets: each key may be varied once", where ? where : "",
                  where ? ": " : "", what, j + 1, a, what, i + 1, b);
        return -1;
    }
    return 0;
}

/* --vary K=a:b:n */
static int parse_vary(const char *s, vkey *k)
{
    const char *eq = strchr(s, '=');
    if (!eq || parse_key("--vary", s, (size_t)(eq - s), k)) {
        if (!eq) cli_error("--vary: '%s' is not of the form section.key=a:b:n", s);
        return -1;
    }
    int rc = cli_parse_grid(eq + 1, SWEEP_MAX_RUNS, &k->g);
    if (rc == CLI_GRID_FORM)
        cli_error("--vary: '%s' is not of the form section.key=a:b:n", s);
    else if (rc == CLI_GRID_BOUNDS)
        cli_error("--vary: '%s': the bounds must be finite numbers", s);
    else if (rc)
        cli_error("--vary: '%s': the number of values must be an integer from 1 to %ld", s, SWEEP_MAX_RUNS);
    return rc ? -1 : 0;
}

/* Split one CSV line into fields (double quotes group commas; "" is a quote). Trims spaces outside
 * quotes. Returns the number of fields, -1 on a malformed line; fields are malloc'ed. */
static int split_csv(const char *line, char **out, int max)
{
    int nf = 0;
    const char *p = line;
    for (;;) {
        while (*p == ' ' || *p == '\t') p++;
        size_t cap = strlen(p) + 1, len = 0;
        char *f = malloc(cap);
        if (!f || nf >= max) {
            free(f);
            return -1;
        }
        if (*p == '"') {
            for (p++;; p++) {
                if (!*p) {
                    free(f);
                    return -1;
                }
                if (*p == '"' && p[1] == '"') f[len++] = '"', p++;
                else if (*p == '"') break;
                else f[len++] = *p;
            }
            p++;
            while (*p == ' ' || *p == '\t') p++;
            if (*p && *p != ',') {
                free(f);
                return -1;
            }
        } else {
            while (*p && *p != ',') f[len++] = *p++;
            while (len && (f[len - 1] == ' ' || f[len - 1] == '\t')) len--;
        }
        f[len] = '\0';
        out[nf++] = f;
        if (*p != ',') break;
        p++;
    }
    return nf;
}

static int read_list(sweep *sw, const char *path)
{
    sw->list_path = path;
    FILE *f = fopen(path, "r");
    if (!f) {
        cli_error("cannot read '%s': %s", path, strerror(errno));
        return -1;
    }
    char *line = NULL;
    size_t cap = 0;
    ssize_t got;
    long lineno = 0, rows = 0, rcap = 0;
    int header = 0, rc = 0;
    char *fields[SWEEP_MAX_KEYS + 1];
    while ((got = getline(&line, &cap, f)) > 0) {
        lineno++;
        while (got > 0 && (line[got - 1] == '\n' || line[got - 1] == '\r')) line[--got] = '\0';
        const char *s = line;
        while (isspace((unsigned char)*s)) s++;
        if (!*s || *s == '#') continue;
        int nf = split_csv(line, fields, SWEEP_MAX_KEYS + 1);
        if (nf < 0 || (header && nf != sw->nkeys)) {
            cli_error("%s:%ld: %s", path, lineno,
                      nf < 0 ? "malformed CSV line (or more than 16 columns)" : "not as many values as keys in the header");
            for (int j = 0; j < nf; j++) free(fields[j]);
            rc = -1;
            break;
        }
        if (!header) {
            char where[4200];
            snprintf(where, sizeof where, "%s:%ld", path, lineno);
            for (int j = 0; j < nf && !rc; j++)
                rc = parse_key(path, fields[j], strlen(fields[j]), &sw->keys[j]) ||
                     check_unique(where, "column", sw->keys, j);
            for (int j = 0; j < nf; j++) free(fields[j]);
            if (rc) break;
            sw->nkeys = nf;
            header = 1;
            continue;
        }
        if (rows == rcap) {
            rcap = rcap ? 2 * rcap : 64;
            char ***l = realloc(sw->list, (size_t)rcap * sizeof *l);
            if (l) sw->list = l;
            long *ll = l ? realloc(sw->list_line, (size_t)rcap * sizeof *ll) : NULL;
            if (ll) sw->list_line = ll;
            if (!l || !ll) {
                for (int j = 0; j < nf; j++) free(fields[j]);
                cli_error("out of memory");
                rc = -1;
                break;
            }
        }
        sw->list_line[rows] = lineno;
        sw->list[rows] = malloc((size_t)nf * sizeof **sw->list);
        if (!sw->list[rows]) {
            for (int j = 0; j < nf; j++) free(fields[j]);
            cli_error("out of memory");
            rc = -1;
            break;
        }
        memcpy(sw->list[rows], fields, (size_t)nf * sizeof *fields);
        rows++;
        sw->nruns = rows;
    }
    free(line);
    fclose(f);
    if (!rc && !header) {
        cli_error("%s: no header line of keys", path);
        rc = -1;
    }
    if (!rc && rows == 0) {
        cli_error("%s: no rows", path);
        rc = -1;
    }
    return rc;
}

/* ---------------------------------------------------------------- one run */

/* The value text of key j for run i into buf. */
static void value_text(const sweep *sw, long i, int j, char *buf, size_t cap)
{
    if (sw->is_list) {
        snprintf(buf, cap, "%s", sw->list[i][j]);
        return;
    }
    long stride = 1;
    for (int l = sw->nkeys - 1; l > j; l--) stride *= sw->keys[l].g.n;
    dth_fmt_g17(cli_grid_at(&sw->keys[j].g, (i / stride) % sw->keys[j].g.n), buf);
}

/* Set key k to text v in the scene (element k->elem of its list, or the whole value); `from` names
 * where the value comes from in messages ("--vary K=V", "LIST:LINE"). */
static int set_key(dth_scene *s, const vkey *k, const char *v, const char *from, char *err, size_t errlen)
{
    size_t cap = strlen(v) + 256;
    const char *old = k->elem ? dth_scene_get(s, k->sec, k->key) : NULL;
    if (old) cap += strlen(old);
    char *a = malloc(cap);
    if (!a) return DTH_ENOMEM;
    int rc = DTH_OK;
    if (!k->elem) {
        snprintf(a, cap, "%s.%s=%s", k->sec, k->key, v);
    } else if (!old) {
        snprintf(err, errlen, "%s.%s[%d]: the scene has no %s.%s to take element %d of", k->sec, k->key, k->elem,
                 k->sec, k->key, k->elem);
        rc = DTH_EINVAL;
    } else {
        /* the list with element elem replaced */
        size_t n = (size_t)snprintf(a, cap, "%s.%s=", k->sec, k->key);
        int idx = 1, found = 0;
        for (const char *p = old;; idx++) {
            const char *c = strchr(p, ',');
            size_t l = c ? (size_t)(c - p) : strlen(p);
            if (idx > 1) a[n++] = ',';
            if (idx == k->elem) {
                n += (size_t)snprintf(a + n, cap - n, "%s", v);
                found = 1;
            } else {
                memcpy(a + n, p, l);
                n += l;
            }
            if (!c) break;
            p = c + 1;
        }
        a[n] = '\0';
        if (!found) {
            snprintf(err, errlen, "%s.%s[%d]: the scene's %s.%s has %d value%s", k->sec, k->key, k->elem, k->sec,
                     k->key, idx, CLI_S(idx));
            rc = DTH_EINVAL;
        }
    }
    if (!rc) rc = dth_scene_set_from(s, from, a, err, errlen);
    free(a);
    return rc;
}

/* The scene of run i, set up (alloc: the library's allocator for everything the run owns, or NULL). */
static int run_setup(const sweep *sw, long i, const dth_allocator *alloc, dth_scene **scene, dth_run_setup *rs,
                     char *err, size_t errlen)
{
    char v[1024];
    int rc = dth_scene_new(alloc, scene);
    if (!rc) rc = dth_scene_load_mem(*scene, sw->scene_path, sw->text, sw->textlen, err, errlen);
    for (int j = 0; !rc && j < sw->nsets; j++) rc = dth_scene_set(*scene, sw->sets[j], err, errlen);
    for (int j = 0; !rc && j < sw->nkeys; j++) {
        const vkey *k = &sw->keys[j];
        char from[1200];
        value_text(sw, i, j, v, sizeof v);
        if (sw->is_list) snprintf(from, sizeof from, "%s:%ld", sw->list_path, sw->list_line[i]);
        else if (k->elem) snprintf(from, sizeof from, "--vary %s.%s[%d]=%s", k->sec, k->key, k->elem, v);
        else snprintf(from, sizeof from, "--vary %s.%s=%s", k->sec, k->key, v);
        rc = set_key(*scene, k, v, from, err, errlen);
    }
    if (!rc) rc = dth_scene_setup(*scene, sw->reg, rs, err, errlen);
    if (rc == DTH_ENOMEM) snprintf(err, errlen, "out of memory");
    return rc;
}

/* What the driver's callbacks of one run need. */
typedef struct runctx {
    const sweep *sw;
    const dth_run_setup *rs;
    dth_integrator *it;
    dth_megno *meg;
    int megno_rc;
    size_t n, N, ninv;
    long k_done;           /* steps accounted for */
    double E0, eerr;
    /* per invariant: the first vertex's value, the largest |I - I0| and |I| over the vertices */
    double inv0[SWEEP_MAX_INV], drift[SWEEP_MAX_INV], inv[SWEEP_MAX_INV], inv_max[SWEEP_MAX_INV];
    int inv_ok;
    double t_first;        /* the first vertex's time (MEGNO's window is judged against the run from it) */
    cli_out out, ev;       /* the trajectory file and its events file */
    char *path, *evpath, *line;
    int werr;
} runctx;

static double rel(double x, double x0) { return x0 != 0 ? fabs(x - x0) / fabs(x0) : fabs(x - x0); }

/* Per step: the energy at the step's midpoint (baselines: at the vertex), the invariants at the
 * vertex, MEGNO. Called from the progress callback (before every step but the first) and once after
 * the run. */
static int account(runctx *c)
{
    long k = dth_integrator_steps(c->it);
    if (k == c->k_done) return 0;
    c->k_done = k;
    double H;
    const double *z = dth_integrator_vertex(c->it), *zm = dth_integrator_midpoint(c->it);
    if (!zm) zm = z; /* a baseline has no midpoints */
    if (zm && dth_model_eval(c->rs->model, zm, DTH_EVAL_H, &H, NULL, NULL) == DTH_OK) c->eerr = fmax(c->eerr, rel(H, c->E0));
    if (c->inv_ok && dth_model_invariants(c->rs->model, z, c->inv) == DTH_OK)
        for (size_t j = 0; j < c->ninv; j++) {
            c->drift[j] = fmax(c->drift[j], fabs(c->inv[j] - c->inv0[j]));
            c->inv_max[j] = fmax(c->inv_max[j], fabs(c->inv[j]));
        }
    if (c->meg && !c->megno_rc) c->megno_rc = dth_megno_update(c->meg, c->it);
    return 0;
}

static int on_progress(void *user, const dth_run_state *st)
{
    (void)st;
    if (cli_signal_received()) return DTH_ESTOPPED;
    return account(user);
}

/* A trajectory row: the columns of dth run without diagnostics. */
static int on_sample(void *user, const dth_sample *s)
{
    runctx *c = user;
    const dth_run_setup *rs = c->rs;
    size_t n = c->n, N = c->N;
    const double *z = s->z;
    double Hp;
    if (dth_model_eval(rs->model, z, DTH_EVAL_H, &Hp, NULL, NULL) != DTH_OK) Hp = NAN;
    long k = s->kind == DTH_SAMPLE_TIME || (s->kind == DTH_SAMPLE_END && rs->dt > 0) ? s->index : s->k;
    char *p = c->line;
    p += dth_fmt_long(k, p);
    *p++ = ',';
    p += dth_fmt_g17(z[n], p);
    *p++ = ',';
    p += dth_fmt_g17(s->step->lambda, p);
    for (size_t i = 0; i < n; i++) *p++ = ',', p += dth_fmt_g17(z[i], p);
    for (size_t i = 0; i < n; i++) *p++ = ',', p += dth_fmt_g17(z[n + 1 + i], p);
    *p++ = ',';
    p += dth_fmt_g17(z[N - 1], p);
    *p++ = ',';
    p += dth_fmt_g17(z[N - 1] + Hp, p);
    *p++ = ',';
    p += dth_fmt_g17(Hp, p);
    if (rs->regularizer) *p++ = ',', *p++ = (s->step->flags & DTH_STEP_REGULARIZED) ? '0' : '1';
    if (cli_out_line(&c->out, c->line, (size_t)(p - c->line))) {
        c->werr = 1;
        return DTH_EIO;
    }
    cli_out_maybe_flush(&c->out);
    return 0;
}

/* --trajectories P: run i's trajectory file P-RUN.csv (ev = 0) or its events file P-RUN-events.csv
 * (ev = 1, the name dth run gives the events of -o P-RUN.csv). */
static char *traj_path(const sweep *sw, long i, int ev)
{
    size_t l = strlen(sw->traj) + 40;
    char *p = malloc(l);
    if (p) snprintf(p, l, "%s-%0*ld%s.csv", sw->traj, sw->traj_width, i, ev ? "-events" : "");
    return p;
}

/* An event row (--trajectories with [events]): the columns of dth run's events file. */
static int on_event(void *user, const dth_sample *s)
{
    runctx *c = user;
    const dth_run_setup *rs = c->rs;
    size_t n = c->n, N = c->N;
    const double *z = s->z;
    double Hp;
    if (dth_model_eval(rs->model, z, DTH_EVAL_H, &Hp, NULL, NULL) != DTH_OK) Hp = NAN;
    char *p = c->line;
    p += dth_fmt_long(s->index, p);
    p += (size_t)sprintf(p, ",%s,", rs->event_names[s->event]);
    p += dth_fmt_long(s->direction, p);
    *p++ = ',';
    p += dth_fmt_long(s->k, p);
    *p++ = ',';
    p += dth_fmt_g17(z[n], p);
    for (size_t i = 0; i < n; i++) *p++ = ',', p += dth_fmt_g17(z[i], p);
    for (size_t i = 0; i < n; i++) *p++ = ',', p += dth_fmt_g17(z[n + 1 + i], p);
    *p++ = ',';
    p += dth_fmt_g17(z[N - 1], p);
    *p++ = ',';
    p += dth_fmt_g17(z[N - 1] + Hp, p);
    *p++ = ',';
    p += dth_fmt_g17(Hp, p);
    if (cli_out_line(&c->ev, c->line, (size_t)(p - c->line))) {
        c->werr = 1;
        return DTH_EIO;
    }
    cli_out_maybe_flush(&c->ev);
    return 0;
}

/* The run's integrator (the DTH step or a baseline: dth_options.method), at the initial state; with
 * integrator.h_max or tol, at the first step their pilots choose for this run (control.h). */
static int start_stepper(runctx *c, dth_run_setup *rs)
{
    int rc = dth_run_setup_control(rs, NULL, NULL, 0);
    if (!rc) rc = dth_integrator_new(rs->model, &rs->opt, &c->it);
    if (!rc) rc = dth_integrator_start(c->it, rs->q0, rs->p0, rs->t0);
    return rc;
}

/* The reference energy and invariants, from the started stepper: the energy its midpoints conserve
 * (DTH: -wp; a vertex start's differs from H at the initial state by the offset that encodes the
 * step) or its first vertex's (baselines), and the invariants at the first vertex, where the later
 * vertices are compared (a midpoint start's initial state is a midpoint, half a step off them). */
static int reference_values(runctx *c, const dth_run_setup *rs)
{
    c->E0 = dth_integrator_energy(c->it);
    c->t_first = dth_integrator_vertex(c->it)[rs->n];
    c->ninv = dth_model_n_invariants(rs->model);
    if (c->ninv > SWEEP_MAX_INV) c->ninv = SWEEP_MAX_INV;
    c->inv_ok = c->ninv > 0 && dth_model_invariants(rs->model, dth_integrator_vertex(c->it), c->inv0) == DTH_OK;
    for (size_t j = 0; c->inv_ok && j < c->ninv; j++) c->inv_max[j] = fabs(c->inv0[j]);
    return DTH_OK;
}

/* --trajectories: run i's file P-RUN.csv opened, its header written, the samples asked of the driver. */
static int open_trajectory(runctx *c, long i, dth_run_config *cfg)
{
    const dth_run_setup *rs = c->rs;
    c->path = traj_path(c->sw, i, 0);
    c->evpath = rs->nevents ? traj_path(c->sw, i, 1) : NULL;
    size_t cap = 32 * (c->N + 8) + 16; /* a row of numbers, or an event row with its name */
    for (size_t j = 0; j < rs->nevents; j++) cap = cap > 32 * (c->N + 8) + strlen(rs->event_names[j]) ? cap : cap + 64;
    c->line = malloc(cap);
    if (!c->path || !c->line || (rs->nevents && !c->evpath)) return DTH_ENOMEM;
    if (cli_out_open(&c->out, c->path)) return DTH_EIO;
    if (c->evpath && cli_out_open(&c->ev, c->evpath)) return DTH_EIO;
    char *p = c->line;
    p += sprintf(p, "k,t,lambda");
    for (size_t j = 0; j < rs->n; j++) p += sprintf(p, ",q%zu", j + 1);
    for (size_t j = 0; j < rs->n; j++) p += sprintf(p, ",p%zu", j + 1);
    p += sprintf(p, ",wp,H,E%s", rs->regularizer ? ",ordinary" : "");
    if (cli_out_line(&c->out, c->line, (size_t)(p - c->line))) c->werr = 1;
    if (c->evpath) {
        p = c->line;
        p += sprintf(p, "i,event,direction,k,t");
        for (size_t j = 0; j < rs->n; j++) p += sprintf(p, ",q%zu", j + 1);
        for (size_t j = 0; j < rs->n; j++) p += sprintf(p, ",p%zu", j + 1);
        p += sprintf(p, ",wp,H,E");
        if (cli_out_line(&c->ev, c->line, (size_t)(p - c->line))) c->werr = 1;
        cfg->on_event = on_event;
    }
    cfg->points = rs->points;
    cfg->every = rs->every;
    cfg->dt = rs->dt;
    cfg->sample = on_sample;
    return DTH_OK;
}

/* The summary numbers of a run that ended with status rc in state S. */
static void record(runctx *c, int rc, const dth_run_state *S, double *rec)
{
    rec[R_STATUS] = rc;
    rec[R_STEPS] = (double)S->k;
    rec[R_T] = rc ? S->t : S->t_stop;
    rec[R_EERR] = c->eerr;
    rec[R_CROSS] = (double)S->crossings;
    rec[R_REG] = S->k > 0 ? (double)S->regularized / (double)S->k : 0;
    rec[R_EVENTS] = (double)S->events;
    rec[R_ERRQ] = S->err_q; /* the estimated global error where the run ended (NaN without one) */
    rec[R_ERRP] = S->err_p;
    rec[R_NINV] = c->inv_ok ? (double)c->ninv : 0;
    /* relative to the largest |I| along the run: an invariant whose first value is near 0 (a Runge-Lenz
     * component at an apside) is not divided by that 0 */
    for (size_t j = 0; c->inv_ok && j < c->ninv; j++)
        rec[R_INV + j] = c->inv_max[j] > 0 ? c->drift[j] / c->inv_max[j] : c->drift[j];
    if (c->meg && !c->megno_rc) {
        /* MEGNO over a short window says nothing about the orbit (an integrable pendulum reads > 4
         * over a few steps): the indicators are left empty below half of the run, megno_t says why */
        dth_megno_result m;
        dth_megno_get(c->meg, &m);
        double span = fabs(rec[R_T] - c->t_first);
        rec[R_MEGNO] = m.span >= SWEEP_MEGNO_SHARE * span ? m.megno : NAN;
        rec[R_LYAP] = m.span >= SWEEP_MEGNO_SHARE * span ? m.lyapunov : NAN;
        rec[R_MEGT] = m.span;
    }
}

/* Run i, its summary numbers into rec (R_LEN doubles). */
static void run_one(const sweep *sw, long i, double *rec)
{
    char err[1024];
    dth_scene *scene = NULL;
    dth_run_setup rs;
    memset(&rs, 0, sizeof rs);
    for (int j = 0; j < R_LEN; j++) rec[j] = NAN;
    rec[R_SETUP] = 0;
    counter cnt = {0, 0};
    dth_allocator al = {count_alloc, count_free, &cnt};
    runctx c;
    memset(&c, 0, sizeof c);
    c.out.fd = c.ev.fd = -1;
    c.sw = sw;
    c.rs = &rs;
    dth_run_state S;
    dth_run_state_init(&S);
    int rc = run_setup(sw, i, &al, &scene, &rs, err, sizeof err);
    c.n = rs.n;
    c.N = 2 * rs.n + 2;
    if (!rc) rc = start_stepper(&c, &rs);
    if (rc) {
        rec[R_STATUS] = rc;
        rec[R_SETUP] = 1;
        goto done;
    }
    rc = reference_values(&c, &rs);
    if (!rc && sw->megno && !strcmp(rs.method, "dth")) rc = dth_megno_new(c.it, NULL, &al, &c.meg);
    dth_run_config cfg;
    dth_run_config_from_setup(&cfg, &rs);
    cfg.user = &c;
    cfg.alloc = &al;
    cfg.progress = on_progress;
    cfg.progress_every = 1;
    if (!rc && sw->traj) rc = open_trajectory(&c, i, &cfg);
    if (rc) {
        rec[R_STATUS] = rc;
        goto done;
    }
    rc = c.werr ? DTH_EIO : dth_run(c.it, &cfg, &S);
    if (!c.werr) account(&c); /* the last step: no progress call follows it */
    if (c.werr) rc = DTH_EIO;
    record(&c, rc, &S, rec);
    if (c.out.fd >= 0 || c.out.buf) {
        if (rc == DTH_EIO || cli_out_finish(&c.out)) rec[R_STATUS] = DTH_EIO;
    }
    if (c.ev.fd >= 0 || c.ev.buf) {
        if (rec[R_STATUS] == DTH_EIO || cli_out_finish(&c.ev)) rec[R_STATUS] = DTH_EIO;
    }
done:
    if (c.out.buf) cli_out_abort(&c.out);
    if (c.ev.buf) cli_out_abort(&c.ev);
    free(c.path);
    free(c.evpath);
    free(c.line);
    dth_megno_free(c.meg);
    dth_integrator_free(c.it);
    dth_run_setup_clear(&rs);
    dth_scene_free(scene);
    rec[R_MEM] = (double)cnt.peak;
}

/* ---------------------------------------------------------------- output */

static int write_summary(const sweep *sw, cli_out *o)
{
    size_t cap = 4096;
    for (int j = 0; j < sw->nkeys; j++) cap += 2048;
    char *line = malloc(cap), v[1024];
    if (!line) return -1;
    size_t len = (size_t)snprintf(line, cap, "run");
    for (int j = 0; j < sw->nkeys; j++) {
        const vkey *k = &sw->keys[j];
        len += k->elem ? (size_t)snprintf(line + len, cap - len, ",%s.%s[%d]", k->sec, k->key, k->elem)
                       : (size_t)snprintf(line + len, cap - len, ",%s.%s", k->sec, k->key);
    }
    len += (size_t)snprintf(line + len, cap - len, ",status,steps,t,energy_error");
    for (int j = 0; j < sw->ninv; j++) len += (size_t)snprintf(line + len, cap - len, ",%s_drift", sw->inv_names[j]);
    len += (size_t)snprintf(line + len, cap - len, ",psi_crossings,regularized_share,events,megno,lyapunov,megno_t,err_q,err_p");
    int rc = cli_out_line(o, line, len);
    for (long i = 0; !rc && i < sw->nruns; i++) {
        const double *r = sw->rec + i * R_LEN;
        char *p = line;
        p += dth_fmt_long(i, p);
        for (int j = 0; j < sw->nkeys; j++) {
            value_text(sw, i, j, v, sizeof v);
            *p++ = ',';
            if (strpbrk(v, ",\"")) { /* quote as CSV */
                *p++ = '"';
                for (const char *s = v; *s; s++) {
                    if (*s == '"') *p++ = '"';
                    *p++ = *s;
                }
                *p++ = '"';
            } else {
                p += sprintf(p, "%s", v);
            }
        }
        int st = (int)r[R_STATUS];
        p += sprintf(p, ",%s", st == DTH_OK ? "ok" : dth_status_name(st));
        if (r[R_SETUP] != 0) { /* never ran: the numbers are empty */
            for (int j = 0; j < 11 + sw->ninv; j++) *p++ = ',';
        } else {
            /* one number: empty if not available (NaN) */
#define PUT(x) (*p++ = ',', p += isnan(x) ? 0 : dth_fmt_g17((x), p))
            *p++ = ',';
            p += dth_fmt_long((long)r[R_STEPS], p);
            PUT(r[R_T]);
            PUT(r[R_EERR]);
            for (int j = 0; j < sw->ninv; j++) PUT(j < (int)r[R_NINV] ? r[R_INV + j] : NAN);
            *p++ = ',';
            p += dth_fmt_long((long)r[R_CROSS], p);
            PUT(r[R_REG]);
            *p++ = ',';
            p += dth_fmt_long((long)r[R_EVENTS], p);
            PUT(r[R_MEGNO]);
            PUT(r[R_LYAP]);
            PUT(r[R_MEGT]);
            PUT(r[R_ERRQ]);
            PUT(r[R_ERRP]);
#undef PUT
        }
        rc = cli_out_line(o, line, (size_t)(p - line));
        cli_out_maybe_flush(o);
    }
    free(line);
    return rc;
}

/* ---------------------------------------------------------------- the work, spread over threads and ranks */

/* Runs lo .. hi-1 with OpenMP threads. */
static void run_range(const sweep *sw, long lo, long hi, const long *idx)
{
#ifdef _OPENMP
#pragma omp parallel for schedule(dynamic, 1)
#endif
    for (long j = lo; j < hi; j++) {
        long i = idx ? idx[j] : j;
        if (cli_signal_received()) continue;
        run_one(sw, i, sw->rec + i * R_LEN);
    }
}

#ifdef DTH_HAVE_MPI
/* Launched by mpirun (or another MPI launcher)? */
static int under_mpi(void)
{
    return getenv("OMPI_COMM_WORLD_SIZE") || getenv("PMI_SIZE") || getenv("PMIX_RANK");
}

/* Static schedule: run i on rank i mod size. The indices of this rank's runs into *idx (malloc'd),
 * their number into *mine: 0, or -1 out of memory (nothing run). */
static int mpi_static(sweep *sw, int rank, int size, long **idx, long *mine)
{
    long total = sw->nruns;
    *idx = malloc((size_t)(total / size + 1) * sizeof **idx);
    if (!*idx) return -1;
    for (long i = rank; i < total; i += size) (*idx)[(*mine)++] = i;
    run_range(sw, 0, *mine, *idx);
    return 0;
}

/* Dynamic schedule: chunks of `chunk` runs taken from a counter on rank 0 (MPI_Fetch_and_op) until
 * none is left. As mpi_static; after a failed allocation this rank stops taking chunks, but it still
 * meets the others at the window's collective calls. */
static int mpi_dynamic(sweep *sw, int rank, long chunk, long **idx, long *mine)
{
    long total = sw->nruns, cap = 0;
    int rc = 0;
    MPI_Win win;
    long *next = NULL;
    MPI_Win_allocate(rank == 0 ? (MPI_Aint)sizeof(long) : 0, sizeof(long), MPI_INFO_NULL, MPI_COMM_WORLD, &next,
                     &win);
    if (rank == 0) *next = 0;
    MPI_Barrier(MPI_COMM_WORLD);
    for (;;) {
        long start, inc = chunk;
        MPI_Win_lock(MPI_LOCK_SHARED, 0, 0, win);
        MPI_Fetch_and_op(&inc, &start, MPI_LONG, 0, 0, MPI_SUM, win);
        MPI_Win_unlock(0, win);
        if (start >= total || cli_signal_received()) break;
        long end = start + chunk < total ? start + chunk : total;
        if (*mine + (end - start) > cap) {
            cap = 2 * cap + (end - start) + 64;
            long *t = realloc(*idx, (size_t)cap * sizeof **idx);
            if (!t) {
                rc = -1;
                break;
            }
            *idx = t;
        }
        for (long i = start; i < end; i++) (*idx)[(*mine)++] = i;
        run_range(sw, *mine - (end - start), *mine, *idx);
    }
    MPI_Barrier(MPI_COMM_WORLD);
    MPI_Win_free(&win);
    return rc;
}

/* Pack (index, record) of this rank's runs and gather them on rank 0, which places them by index.
 * Every buffer is allocated, and every rank told whether all were, before the collective calls:
 * 0, -1 (out of memory here) or -2 (on another rank). `ok` is this rank's state so far. */
static int mpi_gather(sweep *sw, int rank, int size, const long *idx, long mine, int ok)
{
    long total = sw->nruns;
    int w = R_LEN + 1, all_ok = 0;
    double *pack = malloc((size_t)(mine ? mine : 1) * (size_t)w * sizeof *pack), *all = NULL;
    int *counts = NULL, *displs = NULL;
    if (rank == 0) {
        counts = malloc((size_t)size * sizeof *counts);
        displs = malloc((size_t)size * sizeof *displs);
        all = malloc((size_t)total * (size_t)w * sizeof *all);
    }
    ok = ok && pack && (rank != 0 || (counts && displs && all));
    MPI_Allreduce(&ok, &all_ok, 1, MPI_INT, MPI_MIN, MPI_COMM_WORLD);
    if (all_ok) {
        for (long j = 0; j < mine; j++) {
            pack[j * w] = (double)idx[j];
            memcpy(pack + j * w + 1, sw->rec + idx[j] * R_LEN, R_LEN * sizeof *pack);
        }
        int cnt = (int)(mine * w);
        MPI_Gather(&cnt, 1, MPI_INT, counts, 1, MPI_INT, 0, MPI_COMM_WORLD);
        if (rank == 0)
            for (int r = 0, off = 0; r < size; r++) displs[r] = off, off += counts[r];
        MPI_Gatherv(pack, cnt, MPI_DOUBLE, all, counts, displs, MPI_DOUBLE, 0, MPI_COMM_WORLD);
        if (rank == 0)
            for (long j = 0; j < total; j++) {
                long i = (long)all[j * w];
                memcpy(sw->rec + i * R_LEN, all + j * w + 1, R_LEN * sizeof *all);
            }
    }
    free(all);
    free(counts);
    free(displs);
    free(pack);
    return all_ok ? 0 : ok ? -2 : -1;
}

/* The name of an MPI thread support level. */
static const char *mpi_level_name(int level)
{
    return level == MPI_THREAD_SINGLE ? "MPI_THREAD_SINGLE" : level == MPI_THREAD_FUNNELED ? "MPI_THREAD_FUNNELED"
           : level == MPI_THREAD_SERIALIZED ? "MPI_THREAD_SERIALIZED" : "MPI_THREAD_MULTIPLE";
}

/*
 * Every rank computes its share of the runs (static or dynamic schedule), then rank 0 gathers the
 * records (index + R_LEN doubles each) and places them by index. 0, -1 (out of memory on this rank)
 * or -2 (on another one): then no rank has the summary.
 */
static int mpi_runs(sweep *sw, int rank, int size, int dynamic, long chunk)
{
    long *idx = NULL, mine = 0;
    int rc = dynamic ? mpi_dynamic(sw, rank, chunk, &idx, &mine) : mpi_static(sw, rank, size, &idx, &mine);
    rc = mpi_gather(sw, rank, size, idx, mine, rc == 0);
    free(idx);
    return rc;
}
#endif

/* ---------------------------------------------------------------- the command */

/* What each step of the command returns to let it go on; else it returns the exit status, having
 * printed why. */
enum { GO_ON = -1 };

/* One dth sweep: its options, the loaded model libraries, the summary's file, the ranks. */
typedef struct sweep_cmd {
    sweep sw;
    const char *out_path, *list_path;
    int dynamic, stats, model_check;
    long chunk;
    cli_modlibs libs;               /* --model-lib, loaded once the registry exists */
    dth_registry *reg;
    cli_out o;                      /* the summary */
    int rank, size, mpi;
    double t_work;                  /* seconds the runs took */
} sweep_cmd;

static void sweep_free(sweep *sw)
{
    free(sw->text);
    free(sw->sets);
    if (sw->list) {
        for (long r = 0; r < sw->nruns; r++) {
            for (int j = 0; sw->list[r] && j < sw->nkeys; j++) free(sw->list[r][j]);
            free(sw->list[r]);
        }
        free(sw->list);
    }
    free(sw->list_line);
    free(sw->rec);
}

static char *read_file(const char *path, size_t *len)
{
    FILE *f = fopen(path, "rb");
    if (!f) return NULL;
    size_t cap = 4096, n = 0;
    char *b = malloc(cap);
    while (b) {
        size_t got = fread(b + n, 1, cap - n, f);
        n += got;
        if (n < cap) break;
        char *t = realloc(b, cap *= 2);
        if (!t) {
            free(b);
            b = NULL;
        }
        b = t;
    }
    fclose(f);
    if (b) *len = n;
    return b;
}

/* The option a (one that takes a value) with its value v. */
static int option_value(sweep_cmd *c, const char *a, const char *v)
{
    sweep *sw = &c->sw;
    if ((!strcmp(a, "-o") || !strcmp(a, "--list")) && !v[0]) {
        cli_error("%s: the file name is empty", a);
        return CLI_USAGE;
    }
    if (!strcmp(a, "-s")) {
        sw->sets[sw->nsets++] = v;
    } else if (!strcmp(a, "-o")) {
        c->out_path = strcmp(v, "-") ? v : NULL;
    } else if (!strcmp(a, "--vary")) {
        if (sw->nkeys >= SWEEP_MAX_KEYS) {
            cli_error("at most %d --vary keys", SWEEP_MAX_KEYS);
            return CLI_USAGE;
        }
        if (parse_vary(v, &sw->keys[sw->nkeys]) || check_unique(NULL, "--vary", sw->keys, sw->nkeys))
            return CLI_USAGE;
        sw->nkeys++;
    } else if (!strcmp(a, "--list")) {
        c->list_path = v;
    } else if (!strcmp(a, "--trajectories")) {
        if (!v[0]) {
            cli_error("--trajectories: the prefix is empty");
            return CLI_USAGE;
        }
        sw->traj = v;
    } else if (!strcmp(a, "--schedule")) {
        if (strcmp(v, "static") && strcmp(v, "dynamic")) {
            cli_error("--schedule: '%s' is not static or dynamic", v);
            return CLI_USAGE;
        }
        c->dynamic = !strcmp(v, "dynamic");
    } else if (!strcmp(a, "--chunk")) {
        char *e;
        errno = 0;
        c->chunk = strtol(v, &e, 10);
        if (errno || e == v || *e || c->chunk < 1) {
            cli_error("--chunk: '%s' is not a positive integer", v);
            return CLI_USAGE;
        }
    } else if (cli_modlib_add(&c->libs, v)) { /* --model-lib FILE:SYMBOL */
        return CLI_USAGE;
    }
    return GO_ON;
}

/* The command line into c: GO_ON, or the exit status (CLI_OK after --help). */
static int parse_args(int argc, char **argv, sweep_cmd *c)
{
    sweep *sw = &c->sw;
    for (int i = 1; i < argc; i++) {
        const char *a = argv[i];
        int st = GO_ON;
        if (!strcmp(a, "-h") || !strcmp(a, "--help")) {
            usage_sweep(stdout);
            return CLI_OK;
        } else if (!strcmp(a, "--no-megno")) {
            sw->megno = 0;
        } else if (!strcmp(a, "--stats")) {
            c->stats = 1;
        } else if (!strcmp(a, "--no-model-check")) {
            c->model_check = 0;
        } else if (!strcmp(a, "-s") || !strcmp(a, "-o") || !strcmp(a, "--vary") || !strcmp(a, "--list") ||
                   !strcmp(a, "--trajectories") || !strcmp(a, "--model-lib") || !strcmp(a, "--schedule") ||
                   !strcmp(a, "--chunk")) {
            if (i + 1 >= argc) {
                cli_error("option %s needs an argument (try dth sweep --help)", a);
                return CLI_USAGE;
            }
            st = option_value(c, a, argv[++i]);
        } else if (a[0] == '-' && a[1]) {
            cli_error("unknown option '%s' (try dth sweep --help)", a);
            return CLI_USAGE;
        } else if (sw->scene_path) {
            cli_error("more than one scene file ('%s' and '%s')", sw->scene_path, a);
            return CLI_USAGE;
        } else {
            sw->scene_path = a;
        }
        if (st != GO_ON) return st;
    }
    if (!sw->scene_path) {
        cli_error("no scene file (usage: dth sweep SCENE.ini --vary section.key=a:b:n ... | --list FILE)");
        return CLI_USAGE;
    }
    if ((sw->nkeys > 0) == (c->list_path != NULL)) {
        cli_error("give the runs by --vary (a grid) or by --list FILE, one of the two (try dth sweep --help)");
        return CLI_USAGE;
    }
    return GO_ON;
}

/* The runs: the rows of --list, or the points of the --vary grid; then the scene file's text. */
static int read_inputs(sweep_cmd *c)
{
    sweep *sw = &c->sw;
    if (c->list_path) {
        sw->is_list = 1;
        if (read_list(sw, c->list_path)) return CLI_USAGE;
    } else {
        sw->nruns = 1;
        for (int j = 0; j < sw->nkeys; j++) {
            if (sw->nruns > SWEEP_MAX_RUNS / sw->keys[j].g.n) {
                cli_error("the grid has more than %ld points", SWEEP_MAX_RUNS);
                return CLI_USAGE;
            }
            sw->nruns *= sw->keys[j].g.n;
        }
    }
    sw->traj_width = 1;
    for (long m = sw->nruns - 1; m >= 10; m /= 10) sw->traj_width++;
    sw->text = read_file(sw->scene_path, &sw->textlen);
    if (!sw->text) {
        cli_error("cannot read '%s': %s", sw->scene_path, strerror(errno));
        return CLI_USAGE;
    }
    return GO_ON;
}

/* The run whose trajectory file (--trajectories P: P-RUN.csv, RUN of traj_width digits) or events
 * file (P-RUN-events.csv) is `path`, or -1: compared by absolute names (the folders may not exist
 * yet: then as given). */
static long traj_run_of(const sweep *sw, const char *path, const char **what)
{
    if (!sw->traj || !path) return -1;
    char *ap = cli_abspath(path), *at = cli_abspath(sw->traj);
    const char *p = ap && at ? ap : path, *t = ap && at ? at : sw->traj;
    size_t tl = strlen(t), pl = strlen(p), w = (size_t)sw->traj_width;
    long run = -1;
    const char *tail = pl >= tl + 1 + w ? p + tl + 1 + w : "";
    if (!strncmp(p, t, tl) && p[tl] == '-' && (!strcmp(tail, ".csv") || !strcmp(tail, "-events.csv"))) {
        *what = !strcmp(tail, ".csv") ? "the trajectory" : "the events file";
        run = 0;
        for (size_t k = 0; k < w && run >= 0; k++)
            run = isdigit((unsigned char)p[tl + 1 + k]) ? 10 * run + (p[tl + 1 + k] - '0') : -1;
        if (run >= sw->nruns) run = -1;
    }
    free(ap);
    free(at);
    return run;
}

/* No output may replace an input: the summary and the trajectories are neither the scene, the list,
 * a --model-lib file, nor (the summary) one of the trajectories. */
static int check_clashes(sweep_cmd *c)
{
    sweep *sw = &c->sw;
    cli_input in[2 + CLI_MAX_MODLIBS];
    char lib[CLI_MAX_MODLIBS][4096];
    size_t n = 0;
    in[n++] = (cli_input){sw->scene_path, "the scene file"};
    in[n++] = (cli_input){c->list_path, "the list (--list)"};
    for (int i = 0; i < c->libs.nargs; i++)
        in[n++] = (cli_input){cli_modlib_file(&c->libs, i, lib[i], sizeof lib[i]), "a model library (--model-lib)"};
    if (cli_check_clash("the summary", c->out_path, in, n)) return CLI_USAGE;
    const char *what = "";
    long run = traj_run_of(sw, c->out_path, &what);
    if (run >= 0) {
        cli_error("refusing to write the summary to '%s': it is %s of run %ld (--trajectories %s)", c->out_path, what,
                  run, sw->traj);
        return CLI_USAGE;
    }
    for (size_t i = 0; i < n; i++)
        if ((run = traj_run_of(sw, in[i].path, &what)) >= 0) {
            cli_error("refusing to write %s of run %ld (--trajectories %s) to '%s': it is %s", what, run, sw->traj,
                      in[i].path, in[i].what);
            return CLI_USAGE;
        }
    return GO_ON;
}

/* The registry: the built-in models and those of --model-lib; the summary records. */
static int load_models(sweep_cmd *c)
{
    sweep *sw = &c->sw;
    if (!(c->reg = cli_registry())) return CLI_FAIL;
    int st = cli_modlib_load(&c->libs, c->reg);
    if (st) return st;
    sw->reg = c->reg;
    sw->rec = calloc((size_t)sw->nruns * R_LEN, sizeof *sw->rec);
    if (!sw->rec) {
        cli_error("out of memory (%ld runs)", sw->nruns);
        return CLI_FAIL;
    }
    return GO_ON;
}

/* How many runs check_first tries before it takes run 0's failure to set up for a bad scene or option. */
#define SWEEP_PROBE_RUNS 100

/* Before the work, serially: the first run that sets up (of the first SWEEP_PROBE_RUNS) names the
 * summary's invariant columns and has its model checked against finite differences (model_check);
 * when none of them sets up, run 0's message is that of a bad scene, key or option (exit 2). A run
 * that cannot start (its values put the model where it fails) is a row of the summary, not the end
 * of the sweep. */
static int check_first(sweep *sw, int model_check)
{
    char err[1024], err0[1024] = "";
    for (long i = 0; i < sw->nruns && i < SWEEP_PROBE_RUNS; i++) {
        dth_scene *scene = NULL;
        dth_run_setup rs;
        memset(&rs, 0, sizeof rs);
        int rc = run_setup(sw, i, NULL, &scene, &rs, err, sizeof err);
        if (rc) {
            dth_scene_free(scene);
            if (rc == DTH_ENOMEM) {
                cli_error("out of memory");
                return CLI_FAIL;
            }
            if (i == 0) snprintf(err0, sizeof err0, "%s", err);
            continue;
        }
        sw->ninv = (int)dth_model_n_invariants(rs.model);
        if (sw->ninv > SWEEP_MAX_INV) sw->ninv = SWEEP_MAX_INV;
        for (int j = 0; j < sw->ninv; j++)
            snprintf(sw->inv_names[j], sizeof sw->inv_names[j], "%s", dth_model_invariant_name(rs.model, (size_t)j));
        if (strcmp(rs.method, "dth")) sw->megno = 0;
        char where[64];
        snprintf(where, sizeof where, "run %ld's initial state", i);
        int st = model_check ? cli_check_model(&rs, sw->scene_path, where, "--no-model-check skips the check") : 0;
        dth_run_setup_clear(&rs);
        dth_scene_free(scene);
        return st ? st : GO_ON;
    }
    cli_error("%s", err0);
    return CLI_USAGE;
}

/* Under an MPI launcher: MPI with this process's rank among size. */
static void mpi_start(sweep_cmd *c, int *argc, char ***argv)
{
    (void)c, (void)argc, (void)argv;
#ifdef DTH_HAVE_MPI
    if (under_mpi()) {
        int prov;
        MPI_Init_thread(argc, argv, MPI_THREAD_FUNNELED, &prov);
        MPI_Comm_rank(MPI_COMM_WORLD, &c->rank);
        MPI_Comm_size(MPI_COMM_WORLD, &c->size);
        c->mpi = 1;
        /* OpenMP threads beside MPI need MPI_THREAD_FUNNELED (MPI is called from the main thread
         * only); below it a rank runs one thread, which writes the same bytes */
        int threads = 1;
#ifdef _OPENMP
        threads = omp_get_max_threads();
#endif
        if (prov < MPI_THREAD_FUNNELED && threads > 1) {
#ifdef _OPENMP
            omp_set_num_threads(1);
#endif
            if (c->rank == 0)
                cli_error("note: the MPI library provides thread support %s, below the MPI_THREAD_FUNNELED that "
                          "%d OpenMP threads per rank need: each rank runs 1 thread", mpi_level_name(prov), threads);
        }
    }
#endif
}

/* The summary's file is opened before the work (rank 0), so an unwritable one fails at once; the
 * trajectories' folders are made. */
static int open_summary(sweep_cmd *c)
{
    int open_ok = 1;
    if (c->rank == 0 && c->out_path) {
        cli_make_parents(c->out_path);
        open_ok = cli_out_open(&c->o, c->out_path) == 0;
    }
#ifdef DTH_HAVE_MPI
    if (c->mpi) MPI_Bcast(&open_ok, 1, MPI_INT, 0, MPI_COMM_WORLD);
#endif
    if (!open_ok) return CLI_USAGE;
    if (c->sw.traj) cli_make_parents(c->sw.traj);
    return GO_ON;
}

/* Every run: on this process's threads, or shared among the ranks and gathered on rank 0. */
static int work(sweep_cmd *c)
{
    cli_catch_signals();
#ifdef DTH_HAVE_MPI
    if (c->mpi) MPI_Barrier(MPI_COMM_WORLD);
#endif
    double t_start = cli_now();
    if (!c->mpi) {
        run_range(&c->sw, 0, c->sw.nruns, NULL);
    }
#ifdef DTH_HAVE_MPI
    else {
        int rc = mpi_runs(&c->sw, c->rank, c->size, c->dynamic, c->chunk);
        if (rc == -1) cli_error("out of memory (rank %d): no summary written", c->rank);
        if (rc) return CLI_FAIL;
    }
#endif
    c->t_work = cli_now() - t_start;
    int sig = cli_signal_received();
    if (sig) {
        cli_error("interrupted (no summary written)");
        return 128 + sig;
    }
    return GO_ON;
}

/* --stats: the wall time, runs per second and the library's heap per run, on stderr. */
static void print_stats(const sweep_cmd *c)
{
    const sweep *sw = &c->sw;
    double mx = 0, sum = 0;
    for (long i = 0; i < sw->nruns; i++) {
        double m = sw->rec[i * R_LEN + R_MEM];
        mx = fmax(mx, m);
        sum += m;
    }
    int threads = 1;
#ifdef _OPENMP
    threads = omp_get_max_threads();
#endif
    fprintf(stderr, "dth sweep: %ld run%s in %.3f s: %.1f runs/s (%d thread%s x %d rank%s, %s); library heap of "
            "one run: peak %.0f bytes (largest), %.0f (mean); summary record %zu bytes per run\n",
            sw->nruns, CLI_S(sw->nruns), c->t_work, (double)sw->nruns / fmax(c->t_work, 1e-9), threads, threads == 1 ? "" : "s",
            c->size, c->size == 1 ? "" : "s", sw->megno ? "MEGNO on" : "MEGNO off", mx, sum / (double)sw->nruns,
            (size_t)R_LEN * sizeof(double));
}

/* The runs that could not be set up (the first one's message: exit 2), stopped early (a note) or
 * failed hard (exit 1), and the exit status. */
static int report_runs(const sweep_cmd *c)
{
    const sweep *sw = &c->sw;
    int status = CLI_OK;
    long bad = -1, hard = 0, stopped = 0;
    for (long i = 0; i < sw->nruns; i++) {
        const double *r = sw->rec + i * R_LEN;
        if (r[R_SETUP] != 0 && bad < 0) bad = i;
        if (r[R_SETUP] == 0 && r[R_STATUS] < 0) hard++;
        if (r[R_SETUP] == 0 && r[R_STATUS] > 0) stopped++;
    }
    if (bad >= 0) {
        char err[1024] = "";
        dth_scene *scene = NULL;
        dth_run_setup rs;
        memset(&rs, 0, sizeof rs);
        if (run_setup(sw, bad, NULL, &scene, &rs, err, sizeof err) == DTH_OK)
            snprintf(err, sizeof err, "%s", dth_strerror((int)sw->rec[bad * R_LEN + R_STATUS]));
        cli_error("run %ld could not start: %s", bad, err);
        dth_run_setup_clear(&rs);
        dth_scene_free(scene);
        status = CLI_USAGE;
    }
    if (stopped) cli_error("note: %ld of %ld trajectories stopped early (their status column)", stopped, sw->nruns);
    if (c->stats) print_stats(c);
    if (hard) {
        cli_error("%ld of %ld runs failed with a hard error (their status column)", hard, sw->nruns);
        status = CLI_FAIL;
    }
    return status;
}

/* Rank 0: the summary written, the runs reported; the exit status. */
static int results(sweep_cmd *c)
{
    if (c->rank != 0) return CLI_OK;
    if (!c->out_path && cli_out_open(&c->o, NULL)) return CLI_FAIL;
    if (write_summary(&c->sw, &c->o)) {
        cli_error("cannot write '%s': %s", c->out_path ? c->out_path : "standard output", strerror(c->o.err));
        return CLI_FAIL;
    }
    if (cli_out_finish(&c->o)) return CLI_FAIL; /* (it said why) */
    return report_runs(c);
}

/* The end of MPI: every rank exits with rank 0's status. */
static int mpi_end(sweep_cmd *c, int status)
{
#ifdef DTH_HAVE_MPI
    if (c->mpi) {
        MPI_Bcast(&status, 1, MPI_INT, 0, MPI_COMM_WORLD);
        MPI_Finalize();
    }
#else
    (void)c;
#endif
    return status;
}

int cli_cmd_sweep(int argc, char **argv)
{
    sweep_cmd c;
    memset(&c, 0, sizeof c);
    c.sw.megno = 1;
    c.dynamic = 1;
    c.chunk = 16;
    c.model_check = 1;
    c.size = 1;
    c.o.fd = -1;
    c.sw.sets = calloc((size_t)argc, sizeof *c.sw.sets);
    if (!c.sw.sets) {
        cli_error("out of memory");
        return CLI_FAIL;
    }
    int st = parse_args(argc, argv, &c);
    if (st == GO_ON) st = read_inputs(&c);
    if (st == GO_ON) st = check_clashes(&c);
    if (st == GO_ON) st = load_models(&c);
    if (st == GO_ON) st = check_first(&c.sw, c.model_check);
    if (st == GO_ON) {
        /* from here on every rank ends through mpi_end */
        mpi_start(&c, &argc, &argv);
        st = open_summary(&c);
        if (st == GO_ON) st = work(&c);
        if (st == GO_ON) st = results(&c);
        st = mpi_end(&c, st);
    }
    if (c.o.buf) cli_out_abort(&c.o);
    sweep_free(&c.sw);
    dth_registry_free(c.reg);
    cli_modlib_close(&c.libs);
    return st;
}
