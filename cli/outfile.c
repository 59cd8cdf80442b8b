/* SPDX-License-Identifier: MIT */
/*
 * dth's output files, written crash-safely: a temporary of the run's own (FILE.tmp.PID.XXXXXX),
 * whole lines, fsync and rename at the end; a running hash of the bytes written (a checkpoint
 * records it, a resume checks the prefix it copies against it); temporaries a checkpoint still
 * needs are kept on failure, and those of dead runs are cleaned.
 */
#define _XOPEN_SOURCE 700 /* kill */
#include <dirent.h>
#include <errno.h>
#include <fcntl.h>
#include <signal.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <unistd.h>
#include "cli.h"
#include "tempfile.h" /* lib/: the temporaries' names and the hash, as the library's checkpoints have them */

enum { OUT_CAP = 1 << 16 };

unsigned long long cli_fnv1a(unsigned long long h, const void *p, size_t n) { return dth__fnv1a(h, p, n); }

static int write_all(int fd, const char *p, size_t n)
{
    while (n) {
        ssize_t w = write(fd, p, n);
        if (w < 0) {
            if (errno == EINTR) continue;
            return -1;
        }
        if (w == 0) {
            errno = EIO;
            return -1;
        }
        p += w;
        n -= (size_t)w;
    }
    return 0;
}

/* Hand bytes to the file: counted and hashed only once written. */
static int put_bytes(cli_out *o, const char *p, size_t n)
{
    if (write_all(o->fd, p, n)) {
        o->failed = 1;
        o->err = errno;
        return -1;
    }
    o->hash = cli_fnv1a(o->hash, p, n);
    o->written += n;
    return 0;
}

static int flush(cli_out *o)
{
    if (o->failed) return -1;
    if (o->len && put_bytes(o, o->buf, o->len)) return -1;
    o->len = 0;
    o->last_flush = cli_now();
    return 0;
}

int cli_out_open(cli_out *o, const char *path) { return cli_out_open_from(o, path, NULL); }

int cli_out_open_from(cli_out *o, const char *path, const char *origin)
{
    const char *pre = origin ? origin : "", *sep = origin ? ": " : "";
    memset(o, 0, sizeof *o);
    o->fd = STDOUT_FILENO;
    o->cap = OUT_CAP;
    o->hash = CLI_FNV_OFFSET;
    o->buf = malloc(o->cap);
    if (!o->buf) {
        cli_error("out of memory");
        return -1;
    }
    o->last_flush = cli_now();
    if (!path) return 0;
    if (!path[0]) { /* its temporary would be ".tmp.PID.XXXXXX" in the working folder, renamed onto nothing */
        cli_error("%s%scannot write '': the file name is empty", pre, sep);
        cli_out_abort(o);
        return -1;
    }
    struct stat st;
    int exists = stat(path, &st) == 0;
    if (exists && S_ISDIR(st.st_mode)) {
        cli_error("%s%scannot write '%s': %s", pre, sep, path, strerror(EISDIR));
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
            cli_error("%s%scannot write '%s': %s", pre, sep, path, strerror(errno));
            cli_out_abort(o);
            return -1;
        }
        o->direct = 1;
        return 0;
    }
    /* a temporary of this run's own: the PID says whose it is (cli_clean_stale), the random part
     * makes it unique (a reused PID, two runs of one output) */
    size_t len = strlen(path) + 48;
    o->tmp = malloc(len);
    if (!o->tmp) {
        cli_error("out of memory");
        cli_out_abort(o);
        return -1;
    }
    o->fd = dth__open_unique_temp(path, o->tmp, len);
    if (o->fd < 0) {
        cli_error("%s%scannot write '%s': %s", pre, sep, path, strerror(errno));
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
    if (len + 1 > o->cap) /* a line longer than the buffer: write it whole, directly */
        return put_bytes(o, line, len) || put_bytes(o, "\n", 1) ? -1 : 0;
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

int cli_out_copy_prefix(cli_out *o, const char *src, unsigned long long bytes, unsigned long long hash)
{
    int fd = open(src, O_RDONLY | O_CLOEXEC);
    if (fd < 0) return CLI_PREFIX_SHORT;
    char chunk[1 << 16];
    unsigned long long left = bytes, h = CLI_FNV_OFFSET;
    int rc = flush(o) ? CLI_PREFIX_WRITE : 0;
    /* check the whole prefix before writing any of it: a changed file is refused untouched */
    while (left && !rc) {
        ssize_t r = read(fd, chunk, left < sizeof chunk ? (size_t)left : sizeof chunk);
        if (r < 0 && errno == EINTR) continue;
        if (r <= 0) rc = CLI_PREFIX_SHORT; /* shorter than the checkpoint says: truncated or replaced */
        else {
            h = cli_fnv1a(h, chunk, (size_t)r);
            left -= (unsigned long long)r;
        }
    }
    if (!rc && h != hash) rc = CLI_PREFIX_CHANGED;
    if (!rc && lseek(fd, 0, SEEK_SET) != 0) rc = CLI_PREFIX_SHORT;
    for (left = bytes; left && !rc;) {
        ssize_t r = read(fd, chunk, left < sizeof chunk ? (size_t)left : sizeof chunk);
        if (r < 0 && errno == EINTR) continue;
        if (r <= 0) rc = CLI_PREFIX_SHORT;
        else if (put_bytes(o, chunk, (size_t)r)) rc = CLI_PREFIX_WRITE;
        else left -= (unsigned long long)r;
    }
    if (!rc && o->hash != hash) rc = CLI_PREFIX_CHANGED; /* it changed while copied */
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
    } else if (!rc && fflush(stdout)) {
        rc = -1;
        o->err = errno;
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

void cli_out_keep(cli_out *o) { o->keep = 1; }

void cli_out_abort(cli_out *o)
{
    if (o->tmp || o->direct) {
        if (o->fd >= 0) close(o->fd);
        /* a temporary a checkpoint refers to is the resume's input: it stays */
        if (o->tmp && !o->keep) unlink(o->tmp);
    }
    free(o->path);
    free(o->tmp);
    free(o->buf);
    memset(o, 0, sizeof *o);
    o->fd = -1;
}

/* ---------------------------------------------------------------- stale temporaries */

/* "PID" or "PID.XXXXXX" (six characters of mkstemp): the writer's PID, else -1. */
static long temp_owner(const char *tail)
{
    char *end;
    long pid = strtol(tail, &end, 10);
    if (end == tail || pid <= 0) return -1;
    if (*end == '\0') return pid; /* the form of dth before unique temporaries */
    if (*end != '.' || strlen(end + 1) != 6) return -1;
    return pid;
}

int cli_clean_stale(const char *path, const char *except)
{
    if (!path) return 0;
    const char *slash = strrchr(path, '/');
    const char *base = slash ? slash + 1 : path;
    size_t dl = slash ? (size_t)(slash - path) : 0, bl = strlen(base);
    char *dir = malloc(dl + 2);
    if (!dir) return 0;
    if (slash) {
        memcpy(dir, path, dl ? dl : 1);
        dir[dl ? dl : 1] = '\0';
    } else {
        strcpy(dir, ".");
    }
    DIR *d = opendir(dir);
    int removed = 0;
    for (struct dirent *e; d && (e = readdir(d));) {
        const char *nm = e->d_name;
        if (strncmp(nm, base, bl) || strncmp(nm + bl, ".tmp.", 5)) continue;
        long pid = temp_owner(nm + bl + 5);
        /* only a dead writer's (kill(pid, 0) fails with ESRCH), never this process's */
        if (pid < 0 || pid == (long)getpid() || kill((pid_t)pid, 0) == 0 || errno != ESRCH) continue;
        size_t fl = strlen(dir) + strlen(nm) + 2;
        char *full = malloc(fl);
        if (!full) break;
        snprintf(full, fl, "%s/%s", dir, nm);
        if (!(except && cli_same_file(full, except)) && unlink(full) == 0) removed++;
        free(full);
    }
    if (d) closedir(d);
    free(dir);
    return removed;
}
