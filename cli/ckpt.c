/* SPDX-License-Identifier: MIT */
/*
 * dth run's checkpoints: the "cli" blob next to the integrator's state (dth/checkpoint.h) holds
 * the run driver's loop state (dth/run.h) and each output's progress (absolute paths, the bytes
 * already final and their hash), written field by field from one table and validated field by
 * field when read; the scene is saved as text that loads back (dth_scene_text); a resume may
 * change only the run's length and the output names.
 */
#include <limits.h>
#include <stdarg.h>
#include <math.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include "ckpt.h"

static const unsigned char MAGIC[8] = {'D', 'T', 'H', 'R', 'U', 'N', 'C', 'K'};
enum { VERSION = 3 }; /* 3: named fields (1, 2: a copy of a C struct with fixed path buffers) */
enum { T_I64 = 1, T_F64 = 2, T_STR = 3 };
enum { M_INT, M_UINT, M_LONG, M_U64, M_DBL, M_STR };
enum { C_NONE, C_FINITE, C_NONNEG, C_FINITE_OR_NAN, C_PATH };
enum { MAX_STR = 4096, MAX_NAME = 32, MAX_FIELDS = 64 };

typedef struct fld {
    const char *name;
    int mem;        /* the member's C type */
    void *p;        /* the member */
    long long lo, hi; /* integer range */
    int check;      /* doubles, strings */
} fld;

/* The one table: every field of the blob and where it lives in c. */
static size_t fields(cli_ckpt *c, fld *f)
{
    dth_run_state *S = &c->S;
    size_t k = 0;
#define I(nm, m, ptr, lo, hi) f[k++] = (fld){nm, m, ptr, lo, hi, C_NONE}
#define D(nm, ptr, chk) f[k++] = (fld){nm, M_DBL, ptr, 0, 0, chk}
#define S_(nm, ptr) f[k++] = (fld){nm, M_STR, ptr, 0, 0, C_PATH}
    I("run.started", M_INT, &S->started, 0, 1);
    I("run.pending", M_INT, &S->pending, 0, 1);
    I("run.k", M_LONG, &S->k, 0, LONG_MAX);
    I("run.k0", M_LONG, &S->k0, 0, LONG_MAX);
    I("run.samples", M_LONG, &S->samples, 0, LONG_MAX);
    I("run.events", M_LONG, &S->events, 0, LONG_MAX);
    I("run.j", M_LONG, &S->j, 0, LONG_MAX);
    D("run.t", &S->t, C_FINITE);
    D("run.t_first", &S->t_first, C_FINITE);
    D("run.in.lambda", &S->in.lambda, C_FINITE);
    I("run.in.iters", M_INT, &S->in.iters, 0, INT_MAX);
    D("run.in.residual", &S->in.residual, C_FINITE_OR_NAN);
    I("run.in.branch", M_INT, &S->in.branch, DTH_BRANCH_NONE, DTH_BRANCH_REG);
    I("run.in.flags", M_UINT, &S->in.flags, 0, DTH_STEP_REGULARIZED | DTH_STEP_CROSSING | DTH_STEP_NONREVERSIBLE);
    I("run.in.proj_iters", M_INT, &S->in.proj_iters, 0, INT_MAX);
    D("run.in.lerr", &S->in.lerr, C_FINITE_OR_NAN);
    I("run.crossings", M_LONG, &S->crossings, 0, LONG_MAX);
    I("run.regularized", M_LONG, &S->regularized, 0, LONG_MAX);
    D("run.max_ratio", &S->max_ratio, C_NONNEG);
    I("run.prev_crossing", M_INT, &S->prev_crossing, 0, 1);
    I("run.stop", M_INT, &S->stop, DTH_RUN_RUNNING, DTH_RUN_FAILED);
    D("run.t_stop", &S->t_stop, C_FINITE);
    D("run.err_q", &S->err_q, C_FINITE_OR_NAN);
    D("run.err_p", &S->err_p, C_FINITE_OR_NAN);
    D("run.q_max", &S->q_max, C_NONNEG);
    D("run.p_max", &S->p_max, C_NONNEG);
    D("run.lam_max", &S->lam_max, C_NONNEG);
    D("run.t_lam_max", &S->t_lam_max, C_FINITE);
    I("run.nonreversible", M_LONG, &S->nonreversible, 0, LONG_MAX);
    D("run.e_err", &S->e_err, C_NONNEG);
    D("run.e_scale", &S->e_scale, C_NONNEG);
    I("scene.hash", M_U64, &c->scene_hash, 0, 0);
    S_("out.path", &c->out.path);
    S_("out.tmp", &c->out.tmp);
    I("out.bytes", M_U64, &c->out.bytes, 0, 0);
    I("out.hash", M_U64, &c->out.hash, 0, 0);
    S_("ev.path", &c->ev.path);
    S_("ev.tmp", &c->ev.tmp);
    I("ev.bytes", M_U64, &c->ev.bytes, 0, 0);
    I("ev.hash", M_U64, &c->ev.hash, 0, 0);
#undef I
#undef D
#undef S_
    return k;
}
/* A field added to the driver's state must be added to the table: the last member is e_scale. */
_Static_assert(offsetof(dth_run_state, e_scale) + sizeof(double) == sizeof(dth_run_state),
               "dth_run_state changed: update the field table of cli/ckpt.c");

static int wire_type(int mem) { return mem == M_DBL ? T_F64 : mem == M_STR ? T_STR : T_I64; }

/* ---- bytes */

typedef struct wbuf {
    unsigned char *p;
    size_t len, cap;
    int bad;
} wbuf;

static void put(wbuf *w, const void *src, size_t n)
{
    if (w->bad) return;
    if (w->len + n > w->cap) {
        size_t cap = w->cap ? 2 * w->cap : 512;
        while (cap < w->len + n) cap *= 2;
        unsigned char *q = realloc(w->p, cap);
        if (!q) {
            w->bad = 1;
            return;
        }
        w->p = q;
        w->cap = cap;
    }
    memcpy(w->p + w->len, src, n);
    w->len += n;
}

static void put_le(wbuf *w, uint64_t v, int n)
{
    unsigned char b[8];
    for (int i = 0; i < n; i++) b[i] = (unsigned char)(v >> (8 * i));
    put(w, b, (size_t)n);
}

int cli_ckpt_encode(const cli_ckpt *c, unsigned char **blob, size_t *len)
{
    fld f[MAX_FIELDS];
    cli_ckpt copy = *c; /* the table points into a cli_ckpt */
    size_t nf = fields(&copy, f);
    wbuf w = {0};
    put(&w, MAGIC, sizeof MAGIC);
    put_le(&w, VERSION, 4);
    put_le(&w, nf, 4);
    for (size_t i = 0; i < nf; i++) {
        size_t nl = strlen(f[i].name);
        put_le(&w, (uint64_t)wire_type(f[i].mem), 1);
        put_le(&w, nl, 1);
        put(&w, f[i].name, nl);
        switch (f[i].mem) {
        case M_INT: put_le(&w, (uint64_t)(int64_t)*(int *)f[i].p, 8); break;
        case M_UINT: put_le(&w, *(unsigned *)f[i].p, 8); break;
        case M_LONG: put_le(&w, (uint64_t)(int64_t)*(long *)f[i].p, 8); break;
        case M_U64: put_le(&w, *(unsigned long long *)f[i].p, 8); break;
        case M_DBL: {
            uint64_t v;
            memcpy(&v, f[i].p, 8);
            put_le(&w, v, 8);
            break;
        }
        default: {
            const char *s = *(char **)f[i].p ? *(char **)f[i].p : "";
            size_t sl = strlen(s);
            if (sl > MAX_STR) w.bad = 1;
            put_le(&w, sl, 4);
            put(&w, s, sl);
        }
        }
    }
    if (w.bad) {
        free(w.p);
        return -1;
    }
    *blob = w.p;
    *len = w.len;
    return 0;
}

typedef struct rbuf {
    const unsigned char *p;
    size_t len, pos;
} rbuf;

static int get(rbuf *r, void *dst, size_t n)
{
    if (n > r->len - r->pos) return -1;
    if (dst) memcpy(dst, r->p + r->pos, n);
    r->pos += n;
    return 0;
}

static int get_le(rbuf *r, int n, uint64_t *v)
{
    unsigned char b[8];
    if (get(r, b, (size_t)n)) return -1;
    *v = 0;
    for (int i = n - 1; i >= 0; i--) *v = (*v << 8) | b[i];
    return 0;
}

void cli_ckpt_clear(cli_ckpt *c)
{
    free(c->out.path);
    free(c->out.tmp);
    free(c->ev.path);
    free(c->ev.tmp);
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

int cli_ckpt_decode(const void *blob, size_t len, cli_ckpt *c, char *err, size_t errlen)
{
    memset(c, 0, sizeof *c);
    rbuf r = {blob, len, 0};
    unsigned char magic[8];
    uint64_t ver = 0, nf = 0;
    if (!blob || get(&r, magic, 8) || memcmp(magic, MAGIC, 8))
        return fail(err, errlen, "not a checkpoint of dth run (no run state)");
    if (get_le(&r, 4, &ver) || ver != VERSION)
        return fail(err, errlen, "a checkpoint of another version of dth run (its run state has layout %llu, this "
                                 "dth reads %d only): finish it with the dth that wrote it", (unsigned long long)ver, VERSION);
    fld f[MAX_FIELDS];
    size_t want = fields(c, f);
    int seen[MAX_FIELDS] = {0};
    if (get_le(&r, 4, &nf) || nf != want)
        return fail(err, errlen, "the run state has %llu fields, this dth %zu", (unsigned long long)nf, want);
    for (uint64_t i = 0; i < nf; i++) {
        uint64_t type, nl;
        char name[MAX_NAME + 1];
        if (get_le(&r, 1, &type) || get_le(&r, 1, &nl) || nl == 0 || nl > MAX_NAME || get(&r, name, (size_t)nl))
            goto truncated;
        name[nl] = '\0';
        if (memchr(name, '\0', (size_t)nl)) return fail(err, errlen, "a field name holds a NUL byte");
        size_t k = 0;
        while (k < want && strcmp(f[k].name, name)) k++;
        if (k == want) return fail(err, errlen, "unknown field '%s' in the run state", name);
        if (seen[k]++) return fail(err, errlen, "field '%s' appears twice in the run state", name);
        if (type != (uint64_t)wire_type(f[k].mem)) return fail(err, errlen, "field '%s' has the wrong type", name);
        if (f[k].mem == M_STR) {
            uint64_t sl;
            if (get_le(&r, 4, &sl)) goto truncated;
            if (sl > MAX_STR) return fail(err, errlen, "field '%s' is longer than 4096 bytes", name);
            if (sl > r.len - r.pos) goto truncated;
            const unsigned char *sp = r.p + r.pos;
            if (memchr(sp, '\0', (size_t)sl)) return fail(err, errlen, "field '%s' holds a NUL byte", name);
            if (sl && sp[0] != '/') return fail(err, errlen, "field '%s' is not an absolute path", name);
            char *s = malloc((size_t)sl + 1);
            if (!s) return fail(err, errlen, "out of memory");
            memcpy(s, sp, (size_t)sl);
            s[sl] = '\0';
            r.pos += (size_t)sl;
            *(char **)f[k].p = s;
            continue;
        }
        uint64_t v;
        if (get_le(&r, 8, &v)) goto truncated;
        if (f[k].mem == M_DBL) {
            double x;
            memcpy(&x, &v, sizeof x);
            int ok = f[k].check == C_FINITE ? isfinite(x)
                     : f[k].check == C_NONNEG ? isfinite(x) && x >= 0
                     : f[k].check == C_FINITE_OR_NAN ? !isinf(x) : 1;
            if (!ok) return fail(err, errlen, "field '%s' holds an invalid value", name);
            *(double *)f[k].p = x;
        } else if (f[k].mem == M_U64) {
            *(unsigned long long *)f[k].p = v;
        } else {
            long long x = (long long)(int64_t)v;
            if (x < f[k].lo || x > f[k].hi) return fail(err, errlen, "field '%s' is out of range", name);
            if (f[k].mem == M_INT) *(int *)f[k].p = (int)x;
            else if (f[k].mem == M_UINT) *(unsigned *)f[k].p = (unsigned)x;
            else *(long *)f[k].p = (long)x;
        }
    }
    if (r.pos != r.len) return fail(err, errlen, "the run state has trailing bytes");
    for (size_t k = 0; k < want; k++)
        if (!seen[k]) return fail(err, errlen, "field '%s' is missing from the run state", f[k].name);
    /* what holds together */
    const cli_ckpt_out *o[2] = {&c->out, &c->ev};
    for (int i = 0; i < 2; i++) {
        if (!o[i]->path[0] && (o[i]->bytes || o[i]->tmp[0]))
            return fail(err, errlen, "the run state names no %s file but counts its bytes", i ? "events" : "output");
        if (o[i]->bytes > ((unsigned long long)1 << 62))
            return fail(err, errlen, "the run state's %s byte count is out of range", i ? "events" : "output");
    }
    if (!c->out.path[0]) return fail(err, errlen, "the run state names no output file");
    if (c->S.k0 > c->S.k) return fail(err, errlen, "field '%s' exceeds field '%s'", "run.k0", "run.k");
    if (!c->S.started && (c->S.k || c->S.samples || c->S.events || c->S.j))
        return fail(err, errlen, "the run state has counts but no start");
    return 0;
truncated:
    return fail(err, errlen, "the run state is truncated");
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
    c.S = *S;
    int rc = dth_scene_text(scene, keep_entry, &has_t_end, &text, &tlen);
    if (!rc && (out_state(out, &c.out) || out_state(ev, &c.ev))) rc = DTH_ENOMEM;
    if (!rc) {
        c.scene_hash = cli_fnv1a(CLI_FNV_OFFSET, text, tlen);
        if (cli_ckpt_encode(&c, &blob, &blen)) rc = DTH_ENOMEM;
    }
    if (!rc) {
        dth_blob blobs[] = {{"scene", text, tlen}, {"cli", blob, blen}};
        rc = dth_checkpoint_write_file(it, blobs, 2, path, err, errlen);
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
