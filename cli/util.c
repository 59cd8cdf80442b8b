/* SPDX-License-Identifier: MIT */
/* Helpers shared by the dth subcommands: error lines, the model registry, crash-safe output. */
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

/* An absolute form of path without symbolic links in its folder: realpath of the folder + name. */
static char *canon(const char *path)
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
    char *ca = canon(a), *cb = canon(b);
    int same = ca && cb && !strcmp(ca, cb);
    free(ca);
    free(cb);
    return same;
}

/* ---------------------------------------------------------------- crash-safe output */

enum { OUT_CAP = 1 << 16 };

static int write_all(int fd, const char *p, size_t n)
{
    while (n) {
        ssize_t w = write(fd, p, n);
        if (w < 0) {
            if (errno == EINTR) continue;
            return -1;
        }
        p += w;
        n -= (size_t)w;
    }
    return 0;
}

static int flush(cli_out *o)
{
    if (o->failed) return -1;
    if (o->len && write_all(o->fd, o->buf, o->len)) {
        o->failed = 1;
        o->err = errno;
        return -1;
    }
    o->written += o->len;
    o->len = 0;
    o->last_flush = cli_now();
    return 0;
}

int cli_out_open(cli_out *o, const char *path)
{
    memset(o, 0, sizeof *o);
    o->fd = STDOUT_FILENO;
    o->cap = OUT_CAP;
    o->buf = malloc(o->cap);
    if (!o->buf) {
        cli_error("out of memory");
        return -1;
    }
    o->last_flush = cli_now();
    if (!path) return 0;
    struct stat st;
    int exists = stat(path, &st) == 0;
    if (exists && S_ISDIR(st.st_mode)) {
        cli_error("cannot write '%s': %s", path, strerror(EISDIR));
        cli_out_abort(o);
        return -1;
    }
    o->path = malloc(strlen(path) + 1);
    if (!o->path) {
        cli_error("out of memory");
        cli_out_abort(o);
        return -1;
    }
    strcpy(o->path, path);
    if (exists && !S_ISREG(st.st_mode)) {
        /* a device or pipe: write to it directly; renaming onto it would replace the node */
        o->fd = open(path, O_WRONLY | O_CLOEXEC);
        if (o->fd < 0) {
            cli_error("cannot write '%s': %s", path, strerror(errno));
            cli_out_abort(o);
            return -1;
        }
        o->direct = 1;
        return 0;
    }
    size_t len = strlen(path) + 32;
    o->tmp = malloc(len);
    if (!o->tmp) {
        cli_error("out of memory");
        cli_out_abort(o);
        return -1;
    }
    snprintf(o->tmp, len, "%s.tmp.%ld", path, (long)getpid());
    o->fd = open(o->tmp, O_WRONLY | O_CREAT | O_EXCL | O_CLOEXEC, 0666);
    if (o->fd < 0) {
        cli_error("cannot write '%s': %s", path, strerror(errno));
        free(o->tmp);
        o->tmp = NULL; /* nothing was created: nothing to remove */
        cli_out_abort(o);
        return -1;
    }
    return 0;
}

int cli_out_line(cli_out *o, const char *line, size_t len)
{
    if (o->failed) return -1;
    if (o->len + len + 1 > o->cap && flush(o)) return -1;
    if (len + 1 > o->cap) { /* a line longer than the buffer: write it whole, directly */
        if (write_all(o->fd, line, len) || write_all(o->fd, "\n", 1)) {
            o->failed = 1;
            o->err = errno;
            return -1;
        }
        o->written += len + 1;
        return 0;
    }
    memcpy(o->buf + o->len, line, len);
    o->buf[o->len + len] = '\n';
    o->len += len + 1;
    return 0;
}

int cli_out_sync(cli_out *o)
{
    if (flush(o)) return -1;
    if (o->path && !o->direct && fsync(o->fd) && errno != EINVAL) {
        o->failed = 1;
        o->err = errno;
        return -1;
    }
    return 0;
}

int cli_out_copy_prefix(cli_out *o, const char *src, unsigned long long bytes)
{
    int fd = open(src, O_RDONLY | O_CLOEXEC);
    if (fd < 0) return -1;
    char chunk[1 << 16];
    unsigned long long left = bytes;
    int rc = 0;
    while (left && !rc) {
        ssize_t r = read(fd, chunk, left < sizeof chunk ? (size_t)left : sizeof chunk);
        if (r < 0 && errno == EINTR) continue;
        if (r <= 0) {
            rc = -1; /* shorter than the checkpoint says: truncated or replaced */
            break;
        }
        if (flush(o) || write_all(o->fd, chunk, (size_t)r)) {
            o->failed = 1;
            o->err = errno;
            rc = -1;
        } else {
            o->written += (size_t)r;
            left -= (unsigned long long)r;
        }
    }
    close(fd);
    return rc;
}

void cli_out_maybe_flush(cli_out *o)
{
    if (o->len && cli_now() - o->last_flush >= 0.5) flush(o);
}

int cli_out_finish(cli_out *o)
{
    int rc = flush(o);
    const char *what = o->path ? o->path : "standard output";
    if (o->direct) {
        if (close(o->fd) && !rc) {
            rc = -1;
            o->err = errno;
        }
        o->fd = -1;
    } else if (!rc && o->path) {
        /* the data reach the disk before the name does, so FILE is never a torn file */
        if (fsync(o->fd) && errno != EINVAL) {
            rc = -1;
            o->err = errno;
        }
        if (close(o->fd) && !rc) {
            rc = -1;
            o->err = errno;
        }
        o->fd = -1;
        if (!rc && rename(o->tmp, o->path)) {
            rc = -1;
            o->err = errno;
        }
    }
    if (rc) {
        cli_error("cannot write '%s': %s", what, strerror(o->err));
        cli_out_abort(o);
        return -1;
    }
    free(o->path);
    free(o->tmp);
    free(o->buf);
    memset(o, 0, sizeof *o);
    o->fd = -1;
    return 0;
}

void cli_out_abort(cli_out *o)
{
    if (o->tmp || o->direct) {
        if (o->fd >= 0) close(o->fd);
        if (o->tmp) unlink(o->tmp);
    }
    free(o->path);
    free(o->tmp);
    free(o->buf);
    memset(o, 0, sizeof *o);
    o->fd = -1;
}

const char *cli_stop_hint(const char *regularizer, int status, double h, const dth_model *m, const double *z,
                          double lambda, char *buf, size_t len)
{
    buf[0] = '\0';
    int branch = status == DTH_EFOLD || status == DTH_EGHOST || status == DTH_ENEGOFFSET || status == DTH_ENOROOT ||
                 status == DTH_ENOCONV || status == DTH_ESINGULAR;
    if (!branch && status != DTH_EREFUSED) return buf;
    if (!strcmp(regularizer, "none")) {
        snprintf(buf, len, "; to carry the run across psi = 0 and folds: -s regularize.method=smooth");
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
    snprintf(buf, len, "; a smaller step may pass: -s integrator.h=%.6g", h / 4);
    return buf;
}
