/* SPDX-License-Identifier: MIT */
/*
 * dth run's checkpoints: the library saves the integrator and the run driver's loop state
 * (dth_checkpoint_write_file_run); the "cli" blob next to them holds what only dth run knows, each
 * output's progress (absolute paths, the bytes already final and their hash) and the scene's hash,
 * as a record of the library's field codec (dth_fields_encode) validated field by field when read;
 * the scene is saved as text that loads back (dth_scene_text); a resume may change only the run's
 * length and the output names, and the rows it continues must be the ones this run would write.
 */
#include <errno.h>
#include <fcntl.h>
#include <limits.h>
#include <stdarg.h>
#include <math.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>
#include "ckpt.h"

static const unsigned char MAGIC[8] = {'D', 'T', 'H', 'R', 'U', 'N', 'C', 'K'};
/* 4: the run driver's state in the library's checkpoint, this blob a record of the field codec;
 * 3: named fields of its own codec; 1, 2: a copy of a C struct with fixed path buffers */
enum { VERSION = 4, HEAD = 12 };

/* The one table: every field of the blob and where it lives in a cli_ckpt. */
#define OUT_FIELDS(o) \
    {#o ".path", offsetof(cli_ckpt, o.path), DTH_FIELD_STR, DTH_CHECK_ANY, 1}, \
    {#o ".tmp", offsetof(cli_ckpt, o.tmp), DTH_FIELD_STR, DTH_CHECK_ANY, 1}, \
    {#o ".bytes", offsetof(cli_ckpt, o.bytes), DTH_FIELD_U64, DTH_CHECK_ANY, 1}, \
    {#o ".hash", offsetof(cli_ckpt, o.hash), DTH_FIELD_U64, DTH_CHECK_ANY, 1}
static const dth_field fields[] = {
    {"scene.hash", offsetof(cli_ckpt, scene_hash), DTH_FIELD_U64, DTH_CHECK_ANY, 1},
    OUT_FIELDS(out),
    OUT_FIELDS(ev),
};
enum { NFIELDS = sizeof fields / sizeof fields[0] };
_Static_assert(sizeof(unsigned long long) == 8, "the U64 fields");

int cli_ckpt_encode(const cli_ckpt *c, unsigned char **blob, size_t *len)
{
    size_t rl;
    if (dth_fields_encode(fields, NFIELDS, c, NULL, 0, &rl)) return -1;
    unsigned char *b = malloc(HEAD + rl);
    if (!b) return -1;
    memcpy(b, MAGIC, sizeof MAGIC);
    for (int i = 0; i < 4; i++) b[8 + i] = (unsigned char)((unsigned)VERSION >> (8 * i));
    if (dth_fields_encode(fields, NFIELDS, c, b + HEAD, rl, &rl)) {
        free(b);
        return -1;
    }
    *blob = b;
    *len = HEAD + rl;
    return 0;
}

void cli_ckpt_clear(cli_ckpt *c)
{
    dth_free(NULL, c->out.path);
    dth_free(NULL, c->out.tmp);
    dth_free(NULL, c->ev.path);
    dth_free(NULL, c->ev.tmp);
    memset(c, 0, sizeof *c);
}

static int fail(char *err, size_t errlen, const char *fmt, ...) __attribute__((format(printf, 3, 4)));
static int fail(char *err, size_t errlen, const char *fmt, ...)
{
    if (err && errlen) {
        va_list ap;
        va_start(ap, fmt);
        vsnprintf(err, errlen, fmt, ap);
        va_end(ap);
    }
    return -1;
}

/* What holds together: absolute paths, a byte count only with a file, an output file. */
static int outputs_valid(const cli_ckpt *c, char *err, size_t errlen)
{
    const cli_ckpt_out *o[2] = {&c->out, &c->ev};
    for (int i = 0; i < 2; i++) {
        const char *what = i ? "events" : "output";
        if ((o[i]->path[0] && o[i]->path[0] != '/') || (o[i]->tmp[0] && o[i]->tmp[0] != '/'))
            return fail(err, errlen, "field '%s.%s' is not an absolute path", i ? "ev" : "out",
                        o[i]->path[0] && o[i]->path[0] != '/' ? "path" : "tmp");
        if (!o[i]->path[0] && (o[i]->bytes || o[i]->tmp[0]))
            return fail(err, errlen, "the run state names no %s file but counts its bytes", what);
        if (o[i]->bytes > ((unsigned long long)1 << 62))
            return fail(err, errlen, "the run state's %s byte count is out of range", what);
    }
    if (!c->out.path[0]) return fail(err, errlen, "the run state names no output file");
    return 0;
}

int cli_ckpt_decode(const void *blob, size_t len, cli_ckpt *c, char *err, size_t errlen)
{
    memset(c, 0, sizeof *c);
    const unsigned char *b = blob;
    if (!blob || len < HEAD || memcmp(b, MAGIC, sizeof MAGIC))
        return fail(err, errlen, "not a checkpoint of dth run (no run state)");
    unsigned ver = 0;
    for (int i = 3; i >= 0; i--) ver = (ver << 8) | b[8 + i];
    if (ver != VERSION)
        return fail(err, errlen, "a checkpoint of another version of dth run (its run state has layout %u, this "
                                 "dth reads %d only): finish it with the dth that wrote it", ver, VERSION);
    char msg[400];
    int rc = dth_fields_decode(fields, NFIELDS, c, b + HEAD, len - HEAD, NULL, msg, sizeof msg);
    if (rc) {
        memset(c, 0, sizeof *c);
        return fail(err, errlen, "%s", rc == DTH_ENOMEM ? "out of memory" : msg);
    }
    if (outputs_valid(c, err, errlen)) {
        cli_ckpt_clear(c);
        return -1;
    }
    return 0;
}

/* ---- the rows a resume continues: the header this run writes, one line per sample ---- */

int cli_ckpt_check_rows(const cli_ckpt_out *o, int ev, const char *from, const char *header, size_t hlen, long rows,
                        char *err, size_t errlen)
{
    const char *f = ev ? "ev.bytes" : "out.bytes";
    if (o->bytes < hlen + 1)
        return fail(err, errlen, "field '%s' counts %llu bytes of '%s', fewer than its header line of %zu", f, o->bytes,
                    from, hlen + 1);
    int fd = open(from, O_RDONLY | O_CLOEXEC);
    if (fd < 0) return fail(err, errlen, "cannot read '%s': %s", from, strerror(errno));
    char chunk[1 << 16];
    unsigned long long at = 0, lines = 0;
    int rc = 0, last = 0;
    while (!rc && at < o->bytes) {
        size_t want = o->bytes - at < sizeof chunk ? (size_t)(o->bytes - at) : sizeof chunk;
        ssize_t r = read(fd, chunk, want);
        if (r < 0 && errno == EINTR) continue;
        if (r <= 0) {
            rc = fail(err, errlen, "'%s' is shorter than the %llu bytes field '%s' counts", from, o->bytes, f);
            break;
        }
        for (size_t i = 0; i < (size_t)r; i++) {
            if (at + i < hlen + 1 && chunk[i] != (at + i < hlen ? header[at + i] : '\n'))
                rc = fail(err, errlen, "'%s' does not begin with the header line this scene writes (its columns "
                          "differ from the resumed run's)", from);
            if (chunk[i] == '\n') lines++;
        }
        last = chunk[r - 1];
        at += (unsigned long long)r;
    }
    close(fd);
    if (!rc && last != '\n')
        rc = fail(err, errlen, "the %llu bytes of '%s' field '%s' counts end inside a row", o->bytes, from, f);
    if (!rc && lines != 1 + (unsigned long long)rows)
        rc = fail(err, errlen, "the %llu bytes of '%s' field '%s' counts hold %llu rows, field '%s' of the run state %ld",
                  o->bytes, from, f, lines - 1, ev ? "events" : "samples", rows);
    return rc;
}

/* ---- files */

/* Keep an entry in the saved scene? Of steps= and t_end=, only the one in force (one may come
 * from the file and the other from an override that won). */
static int keep_entry(void *ctx, const char *sec, const char *key)
{
    int has_t_end = *(const int *)ctx;
    if (strcmp(sec, "integrator")) return 1;
    return has_t_end ? strcmp(key, "steps") != 0 : strcmp(key, "t_end") != 0;
}

/* An output's progress with absolute paths (NULL out: none). */
static int out_state(const cli_out *o, cli_ckpt_out *s)
{
    memset(s, 0, sizeof *s);
    s->path = o && o->path ? cli_abspath(o->path) : strdup("");
    s->tmp = o && o->tmp ? cli_abspath(o->tmp) : strdup("");
    if (o) {
        s->bytes = o->written;
        s->hash = o->hash;
    }
    return s->path && s->tmp ? 0 : -1;
}

int cli_ckpt_write(const char *path, const dth_integrator *it, const dth_scene *scene, int has_t_end,
                   const dth_run_state *S, const cli_out *out, const cli_out *ev, char *err, size_t errlen)
{
    char *text = NULL;
    size_t tlen = 0, blen = 0;
    unsigned char *blob = NULL;
    cli_ckpt c;
    memset(&c, 0, sizeof c);
    int rc = dth_scene_text(scene, keep_entry, &has_t_end, &text, &tlen);
    if (!rc && (out_state(out, &c.out) || out_state(ev, &c.ev))) rc = DTH_ENOMEM;
    if (!rc) {
        c.scene_hash = cli_fnv1a(CLI_FNV_OFFSET, text, tlen);
        if (cli_ckpt_encode(&c, &blob, &blen)) rc = DTH_ENOMEM;
    }
    if (!rc) {
        dth_blob blobs[] = {{"scene", text, tlen}, {"cli", blob, blen}};
        rc = dth_checkpoint_write_file_run(it, S, blobs, 2, path, err, errlen);
    } else if (err && errlen) {
        snprintf(err, errlen, "cannot write checkpoint '%s': %s", path, dth_strerror(rc));
    }
    free(blob);
    dth_free(NULL, text);
    cli_ckpt_clear(&c);
    return rc;
}

int cli_ckpt_read(const char *path, void **buf, size_t *len, const char **scene, size_t *scene_len, cli_ckpt *c,
                  char *err, size_t errlen)
{
    const void *cb;
    size_t cblen;
    char msg[512];
    memset(c, 0, sizeof *c);
    int rc = dth_checkpoint_read_file(path, NULL, buf, len, err, errlen);
    if (rc) return rc;
    const void *text;
    if (dth_checkpoint_blob(*buf, *len, "scene", &text, scene_len) || dth_checkpoint_blob(*buf, *len, "cli", &cb, &cblen)) {
        snprintf(err, errlen, "%s: not a checkpoint of dth run (no scene or run state)", path);
        rc = DTH_EPARSE;
    } else if (cli_ckpt_decode(cb, cblen, c, msg, sizeof msg)) {
        snprintf(err, errlen, "%s: %s", path, msg);
        rc = DTH_EPARSE;
    } else if ((rc = dth_checkpoint_run_state(*buf, *len, &c->S, msg, sizeof msg)) != 0) {
        snprintf(err, errlen, "%s: %s", path, msg);
    } else if (c->scene_hash != cli_fnv1a(CLI_FNV_OFFSET, text, *scene_len)) {
        snprintf(err, errlen, "%s: its scene does not match its run state", path);
        rc = DTH_EPARSE;
    }
    if (rc) {
        cli_ckpt_clear(c);
        dth_free(NULL, *buf);
        *buf = NULL;
        return rc;
    }
    *scene = text;
    return 0;
}

/* ---- what a resume may change: the library's rule (scene.h) */

int cli_ckpt_check_scene(const dth_scene *saved, const dth_scene *now, char *err, size_t errlen)
{
    return dth_scene_resume_check(saved, now, 0, "--resume", err, errlen) ? -1 : 0;
}

int cli_ckpt_check_length(const cli_ckpt *c, const dth_run_setup *rs, char *err, size_t errlen)
{
    const dth_run_state *S = &c->S;
    if (!S->started) return 0;
    if (!rs->has_t_end && rs->steps < S->k) {
        snprintf(err, errlen, "integrator.steps = %ld lies behind the checkpoint, taken at step %ld (a resume can only "
                 "go on)", rs->steps, S->k);
        return -1;
    }
    double dir = rs->opt.h > 0 ? 1.0 : -1.0;
    if (rs->has_t_end && dir * (rs->t_end - S->t_stop) < 0) {
        snprintf(err, errlen, "integrator.t_end = %.17g lies behind the checkpoint, whose rows reach t = %.17g (a "
                 "resume can only go on)", rs->t_end, S->t_stop);
        return -1;
    }
    return 0;
}
