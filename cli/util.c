/* SPDX-License-Identifier: MIT */
/* Helpers shared by the dth subcommands: error lines, the model registry, grids, paths, signals. */
#define _XOPEN_SOURCE 700 /* realpath */
#include <errno.h>
#include <fcntl.h>
#include <math.h>
#include <signal.h>
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <time.h>
#include <unistd.h>
#include "cli.h"

void cli_error(const char *fmt, ...)
{
    va_list ap;
    va_start(ap, fmt);
    fputs("dth: ", stderr);
    vfprintf(stderr, fmt, ap);
    fputc('\n', stderr);
    va_end(ap);
}

int cli_flush_stdout(void)
{
    errno = 0;
    if (fflush(stdout) == 0 && !ferror(stdout)) return CLI_OK;
    cli_error("cannot write 'standard output': %s", strerror(errno ? errno : EIO));
    return CLI_FAIL;
}

dth_registry *cli_registry(void)
{
    dth_registry *r = NULL;
    int rc = dth_registry_new(NULL, &r);
    if (!rc) rc = dth_registry_add_builtin(r);
    if (rc) {
        cli_error("cannot build the model registry: %s", dth_strerror(rc));
        dth_registry_free(r);
        return NULL;
    }
    return r;
}

int cli_parse_grid(const char *s, long max, cli_grid *g)
{
    char buf[256];
    size_t len = strlen(s);
    const char *c1 = strchr(s, ':'), *c2 = c1 ? strchr(c1 + 1, ':') : NULL;
    if (len >= sizeof buf || !c1 || !c2 || strchr(c2 + 1, ':')) return CLI_GRID_FORM;
    memcpy(buf, s, len + 1);
    buf[c1 - s] = buf[c2 - s] = '\0';
    char *end;
    errno = 0;
    long n = strtol(buf + (c2 - s) + 1, &end, 10);
    if (dth_parse_double(buf, &g->a) || dth_parse_double(buf + (c1 - s) + 1, &g->b)) return CLI_GRID_BOUNDS;
    if (errno || end == buf + (c2 - s) + 1 || *end || n < 1 || n > max) return CLI_GRID_COUNT;
    g->n = n;
    return 0;
}

double cli_grid_at(const cli_grid *g, long i)
{
    if (g->n == 1) return g->a;
    return ((double)(g->n - 1 - i) * g->a + (double)i * g->b) / (double)(g->n - 1);
}

double cli_now(void)
{
    struct timespec ts;
    clock_gettime(CLOCK_MONOTONIC, &ts);
    return (double)ts.tv_sec + 1e-9 * (double)ts.tv_nsec;
}

/* The one piece of process state: which stop signal arrived (async-signal-safe by type). */
static volatile sig_atomic_t stop_signal;

static void on_signal(int sig) { stop_signal = sig; }

void cli_catch_signals(void)
{
    struct sigaction sa;
    memset(&sa, 0, sizeof sa);
    sa.sa_handler = on_signal;
    sigemptyset(&sa.sa_mask);
    sigaction(SIGINT, &sa, NULL);
    sigaction(SIGTERM, &sa, NULL);
    sigaction(SIGHUP, &sa, NULL); /* a closed terminal: stop like SIGTERM (rows kept, checkpoint written) */
}

int cli_signal_received(void) { return (int)stop_signal; }

/* ---------------------------------------------------------------- paths */

int cli_make_parents(const char *path)
{
    size_t len = strlen(path);
    char *dir = malloc(len + 1);
    if (!dir) return -1;
    memcpy(dir, path, len + 1);
    char *slash = strrchr(dir, '/');
    int rc = 0;
    if (slash && slash != dir) {
        *slash = '\0';
        /* each prefix in turn, like mkdir -p; an error shows when the file is opened */
        for (char *p = dir + 1; ; p++) {
            if (*p == '/' || *p == '\0') {
                char c = *p;
                *p = '\0';
                if (mkdir(dir, 0777) && errno != EEXIST) rc = -1;
                *p = c;
                if (!c) break;
            }
        }
    }
    free(dir);
    return rc;
}

char *cli_abspath(const char *path)
{
    char *r = realpath(path, NULL);
    if (r) return r;
    const char *slash = strrchr(path, '/');
    const char *base = slash ? slash + 1 : path;
    char *dir;
    if (slash) {
        size_t l = (size_t)(slash - path);
        char *d = malloc(l + 2);
        if (!d) return NULL;
        memcpy(d, path, l);
        d[l] = '\0';
        if (!l) strcpy(d, "/");
        dir = realpath(d, NULL);
        free(d);
    } else {
        dir = realpath(".", NULL);
    }
    if (!dir) return NULL;
    char *out = malloc(strlen(dir) + strlen(base) + 2);
    if (out) sprintf(out, "%s/%s", dir, base);
    free(dir);
    return out;
}

int cli_same_file(const char *a, const char *b)
{
    if (!a || !b) return 0;
    struct stat sa, sb;
    if (stat(a, &sa) == 0 && stat(b, &sb) == 0) return sa.st_dev == sb.st_dev && sa.st_ino == sb.st_ino;
    char *ca = cli_abspath(a), *cb = cli_abspath(b);
    int same = ca && cb && !strcmp(ca, cb);
    free(ca);
    free(cb);
    return same;
}
int cli_check_clash(const char *what, const char *path, const cli_input *in, size_t n)
{
    for (size_t i = 0; path && i < n; i++)
        if (in[i].path && cli_same_file(path, in[i].path)) {
            cli_error("refusing to write %s to '%s': it is %s", what, path, in[i].what);
            return CLI_USAGE;
        }
    return 0;
}

int cli_fastest_rate(const dth_model *m, const double *y, double *omega)
{
    size_t n = dth_model_dof(m), d = 2 * n + 1, k = 2 * n;
    if (n > 200) return -1; /* a dense (2n+1)^2 Hessian */
    double *hess = calloc(d * d + 3 * k, sizeof *hess);
    if (!hess) return -1;
    double *v = hess + d * d, *w = v + k, *x = w + k;
    int rc = dth_model_eval(m, y, DTH_EVAL_HESS, NULL, NULL, hess);
    /* the (q, p) block of H'' (y = (q, t, p): skip row and column n) applied to a (q, p) vector */
#define HQP(i, j) hess[((i) < n ? (i) : (i) + 1) * d + ((j) < n ? (j) : (j) + 1)]
    unsigned long long seed = 88172645463325252ULL; /* a fixed pseudo-random start: every mode in it */
    for (size_t i = 0; i < k; i++) {
        seed ^= seed << 13, seed ^= seed >> 7, seed ^= seed << 17;
        v[i] = (double)(seed >> 11) / 9007199254740992.0 - 0.5;
    }
    double rho = 0;
    for (int it = 0; !rc && it < 100; it++) {
        /* v <- (J H'')^2 v, J (a, b) = (b, -a) on (q, p); rho its growth */
        for (int half = 0; half < 2; half++) {
            double *in = half ? x : v, *out = half ? v : x;
            for (size_t i = 0; i < k; i++) {
                double s = 0;
                for (size_t j = 0; j < k; j++) s += HQP(i, j) * in[j];
                w[i] = s;
            }
            for (size_t i = 0; i < n; i++) out[i] = w[n + i], out[n + i] = -w[i];
        }
        double norm = 0;
        for (size_t i = 0; i < k; i++) norm += v[i] * v[i];
        norm = sqrt(norm);
        if (!(norm > 0) || !isfinite(norm)) break;
        rho = norm;
        for (size_t i = 0; i < k; i++) v[i] /= norm;
    }
#undef HQP
    free(hess);
    if (rc || !(rho > 0)) return -1;
    *omega = sqrt(rho);
    return 0;
}

int cli_check_model(const dth_run_setup *rs, const char *scene_path, const char *where, const char *skip)
{
    if (rs->n > 200) return 0; /* its memory grows as (2n+1)^2 */
    double *y = calloc(2 * rs->n + 1, sizeof *y);
    if (!y) {
        cli_error("out of memory");
        return CLI_FAIL;
    }
    memcpy(y, rs->q0, rs->n * sizeof *y);
    y[rs->n] = rs->t0;
    memcpy(y + rs->n + 1, rs->p0, rs->n * sizeof *y);
    dth_model_check_report rep;
    int rc = dth_model_check(rs->model, y, &rep);
    free(y);
    const char *name = dth_model_get_type(rs->model)->name;
    if (rc != DTH_OK) {
        /* a check that cannot run has not passed */
        cli_error("%s: model '%s': its derivative check cannot run at %s: %s (%s)", scene_path, name, where,
                  dth_strerror(rc), skip);
        return rc > 0 || rc == DTH_EINVAL ? CLI_USAGE : CLI_FAIL;
    }
    if (!rep.pass) {
        cli_error("%s: model '%s' fails its derivative check at %s: %s (%s)", scene_path, name, where, rep.message, skip);
        return CLI_USAGE;
    }
    return 0;
}

const char *cli_stop_hint(const char *regularizer, int status, double h, const dth_model *m, const double *z,
                          double lambda, char *buf, size_t len)
{
    buf[0] = '\0';
    int branch = status == DTH_EFOLD || status == DTH_EGHOST || status == DTH_ENEGOFFSET || status == DTH_ENOROOT ||
                 status == DTH_ENOCONV || status == DTH_ESINGULAR;
    if (!branch && status != DTH_EREFUSED) return buf;
    if (!strcmp(regularizer, "none")) {
        snprintf(buf, len, "; to carry the run across psi = 0 and folds: -s regularize.method=land");
        return buf;
    }
    /* a fold the regularizer could not carry, with the step at the ceiling 6/5 |psi/psi'| */
    double hmax = INFINITY, psi = 0;
    double *work = m ? calloc(dth_model_work_size(m), sizeof *work) : NULL;
    if (work && z && lambda != 0 && !dth_step_ceiling(m, z, &hmax, work) && !dth_model_psi(m, z, &psi, NULL, work) &&
        fabs(lambda) > 0.8 * hmax) {
        snprintf(buf, len, "; the step %.3g is at the ceiling 6/5 |psi/psi'| = %.3g of the physical root here (Theorem "
                           "EU_2): a smaller step passes, e.g. -s integrator.h=%.3g",
                 fabs(lambda), hmax, 0.7 * fabs(h) * hmax / fabs(lambda));
        free(work);
        return buf;
    }
    free(work);
    cli_smaller_step(m, z, h, buf, len);
    return buf;
}

const char *cli_smaller_step(const dth_model *m, const double *z, double h, char *buf, size_t len)
{
    /* below the conditioning limit a smaller step is known less accurately, not better: no advice of h */
    double hmin = 0;
    double *work = m && z ? calloc(dth_model_work_size(m) + 1, sizeof *work) : NULL;
    if (work && dth_step_floor(m, z, 1e-6, &hmin, work) != DTH_OK) hmin = 0;
    free(work);
    if (fabs(h) < hmin)
        snprintf(buf, len, "; no step size helps: |h| = %.3g lies below the conditioning limit %.3g here (psi is "
                           "round-off small, as near an equilibrium) and a smaller step is known less well; a fixed-step "
                           "method integrates it: -s integrator.method=gauss4", fabs(h), hmin);
    else
        snprintf(buf, len, "; a smaller step may pass: -s integrator.h=%.6g", h / 4);
    return buf;
}
