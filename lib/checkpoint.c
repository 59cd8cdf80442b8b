/* SPDX-License-Identifier: MIT */
/*
 * Checkpoint and restart of the DTH integrator (the state of the step of the paper's Theorem
 * "DTH Equations" plus its predictor): a versioned, checksummed, endian-fixed byte format, and
 * crash-safe files (temporary file, fsync, rename).
 */
#include <errno.h>
#include <fcntl.h>
#include <limits.h>
#include <math.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <unistd.h>
#include "dth/checkpoint.h"
#include "dth_internal.h"
#include "stepper.h"
#include "tempfile.h"

static const unsigned char MAGIC[8] = {'D', 'T', 'H', 'C', 'K', 'P', 'T', 0};
enum { HEADER = 8 + 4 + 4 + 8, TRAILER = 8, MAX_NAME = 255 };

/* ---- writer: counts only when buf is NULL or full ---- */

typedef struct wr {
    unsigned char *buf;
    size_t cap, len;
} wr;

static void put_bytes(wr *w, const void *p, size_t n)
{
    if (w->buf && w->len + n <= w->cap && n) memcpy(w->buf + w->len, p, n);
    w->len += n;
}

static void put_u64(wr *w, uint64_t v)
{
    unsigned char b[8];
    for (int i = 0; i < 8; i++) b[i] = (unsigned char)(v >> (8 * i));
    put_bytes(w, b, 8);
}

static void put_u32(wr *w, uint32_t v)
{
    unsigned char b[4];
    for (int i = 0; i < 4; i++) b[i] = (unsigned char)(v >> (8 * i));
    put_bytes(w, b, 4);
}

static void put_f64(wr *w, double x)
{
    uint64_t v;
    memcpy(&v, &x, sizeof v);
    put_u64(w, v);
}

static void put_f64s(wr *w, const double *x, size_t n)
{
    for (size_t i = 0; i < n; i++) put_f64(w, x[i]);
}

static void put_str(wr *w, const char *s)
{
    size_t n = strlen(s);
    put_u32(w, (uint32_t)n);
    put_bytes(w, s, n);
}

/* ---- reader: every get fails (and stays failed) past the end ---- */

typedef struct rd {
    const unsigned char *p;
    size_t len, pos;
    int bad;
} rd;

static const unsigned char *get_bytes(rd *r, size_t n)
{
    if (r->bad || n > r->len - r->pos) {
        r->bad = 1;
        return NULL;
    }
    const unsigned char *p = r->p + r->pos;
    r->pos += n;
    return p;
}

static uint64_t get_u64(rd *r)
{
    const unsigned char *b = get_bytes(r, 8);
    uint64_t v = 0;
    if (b)
        for (int i = 7; i >= 0; i--) v = (v << 8) | b[i];
    return v;
}

static uint32_t get_u32(rd *r)
{
    const unsigned char *b = get_bytes(r, 4);
    uint32_t v = 0;
    if (b)
        for (int i = 3; i >= 0; i--) v = (v << 8) | b[i];
    return v;
}

static double get_f64(rd *r)
{
    uint64_t v = get_u64(r);
    double x;
    memcpy(&x, &v, sizeof x);
    return x;
}

/* A length-prefixed string: pointer into the buffer and length (not NUL-terminated). */
static const char *get_str(rd *r, size_t *n)
{
    uint32_t l = get_u32(r);
    if (l > MAX_NAME) r->bad = 1;
    *n = l;
    return (const char *)get_bytes(r, l);
}

/* ---- fields: the stepper's state sections (stepper.h), the options that change the steps ---- */

enum { T_F64 = 1, T_I64 = 2 }; /* how a field's values are written */

static int wire_type(int kind) { return kind == DTH__K_VEC || kind == DTH__K_F64 ? T_F64 : T_I64; }

/* One field: name, wire type, count, values. */
static void put_field(wr *w, const dth__field *f, const void *base, size_t veclen)
{
    const char *p = (const char *)base + f->off;
    put_str(w, f->name);
    put_u32(w, (uint32_t)wire_type(f->kind));
    switch (f->kind) {
    case DTH__K_VEC: {
        const double *v;
        memcpy(&v, p, sizeof v);
        put_u64(w, veclen);
        put_f64s(w, v, veclen);
        break;
    }
    case DTH__K_F64: {
        double x;
        memcpy(&x, p, sizeof x);
        put_u64(w, 1);
        put_f64(w, x);
        break;
    }
    case DTH__K_INT: {
        int x;
        memcpy(&x, p, sizeof x);
        put_u64(w, 1);
        put_u64(w, (uint64_t)(int64_t)x);
        break;
    }
    default: {
        long x;
        memcpy(&x, p, sizeof x);
        put_u64(w, 1);
        put_u64(w, (uint64_t)(int64_t)x);
        break;
    }
    }
}

static void put_section(wr *w, const dth__section *sec)
{
    put_str(w, sec->name);
    put_u64(w, sec->veclen);
    put_u32(w, (uint32_t)sec->nfields);
    for (size_t i = 0; i < sec->nfields; i++) put_field(w, &sec->fields[i], sec->base, sec->veclen);
}

static int check_f64(int check, double x)
{
    switch (check) {
    case DTH__C_ANY: return 1;
    case DTH__C_NONZERO: return isfinite(x) && x != 0;
    case DTH__C_UNIT: return x == 1.0 || x == -1.0;
    default: return isfinite(x);
    }
}

static int check_i64(int kind, int check, int64_t x)
{
    if (kind == DTH__K_INT && (x < INT_MIN || x > INT_MAX)) return 0;
    if (kind == DTH__K_LONG && (x < LONG_MIN || x > LONG_MAX)) return 0;
    switch (check) {
    case DTH__C_BOOL: return x == 0 || x == 1;
    case DTH__C_SIGN: return x >= -1 && x <= 1;
    case DTH__C_NHIST: return x >= 0 && x <= 3;
    case DTH__C_COUNT: return x >= 0;
    case DTH__C_PSISTEP: return x >= -2;
    default: return 1;
    }
}

/* Read and validate the field the library expects next; *pos: reader position of its values. */
static int get_field(rd *r, const dth__field *f, size_t veclen, size_t *pos, char *err, size_t errlen)
{
    size_t nl;
    const char *nm = get_str(r, &nl);
    uint32_t type = get_u32(r);
    uint64_t count = get_u64(r);
    if (r->bad) {
        dth__set_err(err, errlen, "checkpoint truncated in field '%s'", f->name);
        return DTH_EPARSE;
    }
    if (nl != strlen(f->name) || memcmp(nm, f->name, nl) != 0) {
        dth__set_err(err, errlen, "checkpoint field '%.*s' where this library expects '%s'", (int)nl, nm, f->name);
        return DTH_EPARSE;
    }
    uint64_t want = f->kind == DTH__K_VEC ? veclen : 1;
    if (type != (uint32_t)wire_type(f->kind) || count != want) {
        dth__set_err(err, errlen, "checkpoint field '%s' has type %u and %llu values (expected %d and %llu)", f->name,
                     (unsigned)type, (unsigned long long)count, wire_type(f->kind), (unsigned long long)want);
        return DTH_EPARSE;
    }
    *pos = r->pos;
    for (uint64_t i = 0; i < count && !r->bad; i++) {
        uint64_t v = get_u64(r);
        int ok;
        if (type == T_F64) {
            double x;
            memcpy(&x, &v, sizeof x);
            ok = check_f64(f->check, x);
        } else {
            ok = check_i64(f->kind, f->check, (int64_t)v);
        }
        if (!r->bad && !ok) {
            dth__set_err(err, errlen, "checkpoint field '%s' holds an invalid value%s", f->name,
                         count > 1 ? " (in one of its components)" : "");
            return DTH_EPARSE;
        }
    }
    if (r->bad) {
        dth__set_err(err, errlen, "checkpoint truncated in field '%s'", f->name);
        return DTH_EPARSE;
    }
    return DTH_OK;
}

/* Store a validated field's values (at reader position pos) into base. */
static void load_field(const rd *r, size_t pos, const dth__field *f, void *base, size_t veclen)
{
    rd v = {r->p, r->len, pos, 0};
    char *p = (char *)base + f->off;
    if (f->kind == DTH__K_VEC) {
        double *dst;
        memcpy(&dst, p, sizeof dst);
        for (size_t j = 0; j < veclen; j++) dst[j] = get_f64(&v);
    } else if (f->kind == DTH__K_F64) {
        double x = get_f64(&v);
        memcpy(p, &x, sizeof x);
    } else if (f->kind == DTH__K_INT) {
        int x = (int)(int64_t)get_u64(&v);
        memcpy(p, &x, sizeof x);
    } else {
        long x = (long)(int64_t)get_u64(&v);
        memcpy(p, &x, sizeof x);
    }
}

/* ---- the state part: the method, the model, the options and the stepper's sections ---- */

/* The options section and the state sections of `it` (sections[0] is the options), their count. */
#define ESTIMATE_ENTRY(name, kind, check, doc) DTH__FIELD(dth__estimate, name, kind, check),
static const dth__field estimate_fields[] = {DTH__ESTIMATE_FIELDS(ESTIMATE_ENTRY)};
#undef ESTIMATE_ENTRY

/* The options, the stepper's sections and, with an error estimate, its shadow (the estimate a
 * resumed run prints and stops by must go on from where it was). */
static size_t sections_of(const dth_integrator *it, dth__section *sec, void *scratch)
{
    size_t k = 0;
    if (it->type->options_section) it->type->options_section(it->state, &sec[k++], scratch);
    else sec[k++] = (dth__section){"options", NULL, 0, scratch, 0};
    k += it->type->sections(it->state, sec + k);
    if (it->est.on)
        sec[k++] = (dth__section){"estimate", estimate_fields, sizeof estimate_fields / sizeof estimate_fields[0],
                                  (void *)&it->est, it->est.N};
    return k;
}

static const char *reg_name(const dth_integrator *it)
{
    struct dth_regularizer *r = it->type->regularizer ? it->type->regularizer(it->state) : NULL;
    return r ? dth_regularizer_get_type(r)->name : "";
}

static struct dth_regularizer *reg_of(const dth_integrator *it)
{
    return it->type->regularizer ? it->type->regularizer(it->state) : NULL;
}

static void put_state(wr *w, const dth_integrator *it)
{
    dth__section sec[DTH__MAX_SECTIONS + 2];
    double scratch[8];
    size_t ns = sections_of(it, sec, scratch);
    put_str(w, it->type->name);
    put_str(w, dth_model_get_type(it->model)->name);
    put_u64(w, it->n);
    put_u32(w, (uint32_t)ns);
    for (size_t i = 0; i < ns; i++) put_section(w, &sec[i]);
    /* the regularizer's own state (a constant fixed at its first step, seeds), as its bytes */
    struct dth_regularizer *reg = reg_of(it);
    put_str(w, reg_name(it));
    size_t rl = dth__reg_state_size(reg);
    put_u64(w, rl);
    if (rl && w->buf && w->len + rl <= w->cap) dth__reg_save_state(reg, w->buf + w->len);
    w->len += rl;
}

int dth_checkpoint_save(const dth_integrator *it, const dth_blob *blobs, size_t nblobs, void *buf,
                        size_t cap, size_t *len)
{
    if (len) *len = 0;
    if (!it || !len || (nblobs && !blobs) || !it->type->sections) return DTH_EINVAL;
    for (size_t i = 0; i < nblobs; i++) {
        if (!blobs[i].name || !blobs[i].name[0] || strlen(blobs[i].name) > MAX_NAME ||
            (blobs[i].size && !blobs[i].data))
            return DTH_EINVAL;
        for (size_t j = 0; j < i; j++)
            if (strcmp(blobs[i].name, blobs[j].name) == 0) return DTH_EINVAL;
    }
    /* pass 1 sizes, pass 2 writes */
    wr w = {NULL, 0, 0};
    for (int pass = 0; pass < 2; pass++) {
        w.len = 0;
        put_bytes(&w, MAGIC, sizeof MAGIC);
        put_u32(&w, DTH_CHECKPOINT_VERSION);
        put_u32(&w, 0);
        put_u64(&w, (uint64_t)*len);
        put_state(&w, it);
        put_u32(&w, (uint32_t)nblobs);
        for (size_t i = 0; i < nblobs; i++) {
            put_str(&w, blobs[i].name);
            put_u64(&w, blobs[i].size);
            put_bytes(&w, blobs[i].data, blobs[i].size);
        }
        if (pass == 0) {
            *len = w.len + TRAILER;
            if (!buf || cap < *len) return buf ? DTH_EINVAL : DTH_OK;
            w.buf = buf;
            w.cap = cap;
        }
    }
    put_u64(&w, dth__fnv1a(DTH__FNV_OFFSET, buf, w.len));
    return DTH_OK;
}

/* Parsed header; the state and blobs are read by the callers with `r` positioned after it. */
static int open_checked(rd *r, const void *buf, size_t len, char *err, size_t errlen)
{
    *r = (rd){buf, len, 0, 0};
    if (!buf || len < HEADER + TRAILER) {
        dth__set_err(err, errlen, "checkpoint truncated (%zu bytes)", len);
        return DTH_EPARSE;
    }
    const unsigned char *p = buf;
    if (memcmp(p, MAGIC, sizeof MAGIC) != 0) {
        dth__set_err(err, errlen, "not a dth checkpoint (bad magic)");
        return DTH_EPARSE;
    }
    get_bytes(r, sizeof MAGIC);
    uint32_t ver = get_u32(r);
    get_u32(r);
    uint64_t total = get_u64(r);
    if (ver != DTH_CHECKPOINT_VERSION) {
        dth__set_err(err, errlen, "checkpoint format version %u, this library reads version %d only%s", (unsigned)ver,
                     DTH_CHECKPOINT_VERSION,
                     ver < DTH_CHECKPOINT_VERSION ? " (written by an older dth: resume it with that version)" : "");
        return DTH_EPARSE;
    }
    if (total != len) {
        dth__set_err(err, errlen, "checkpoint is %zu bytes, its header says %llu (truncated or extended)", len,
                (unsigned long long)total);
        return DTH_EPARSE;
    }
    rd t = {p + len - TRAILER, TRAILER, 0, 0};
    if (get_u64(&t) != dth__fnv1a(DTH__FNV_OFFSET, p, len - TRAILER)) {
        dth__set_err(err, errlen, "checkpoint checksum mismatch (corrupted)");
        return DTH_EPARSE;
    }
    r->len = len - TRAILER; /* the body ends at the checksum */
    return DTH_OK;
}

/* The state, as read (values stay in the buffer: reader positions). */
enum { MAX_FIELDS = 64 };
typedef struct st {
    const char *method, *name;
    size_t method_len, name_len;
    uint64_t n;
    uint32_t nsec;
    size_t pos_sec;       /* reader position of the first section */
    const char *reg;      /* regularizer type name */
    size_t reg_name_len;
    uint64_t reg_len;     /* bytes of regularizer state */
    size_t pos_reg;
} st;

/* Skip one section's fields, checking their structure (names, types, counts; values unchecked). */
static int skip_section(rd *r)
{
    size_t nl;
    get_str(r, &nl);
    uint64_t veclen = get_u64(r);
    uint32_t nf = get_u32(r);
    if (r->bad || nf > MAX_FIELDS || veclen > ((uint64_t)1 << 44)) return DTH_EPARSE;
    for (uint32_t i = 0; i < nf && !r->bad; i++) {
        size_t fl;
        get_str(r, &fl);
        uint32_t type = get_u32(r);
        uint64_t count = get_u64(r);
        if (r->bad || (type != T_F64 && type != T_I64) || (count != 1 && count != veclen) ||
            count > (r->len - r->pos) / 8)
            return DTH_EPARSE;
        get_bytes(r, (size_t)count * 8);
    }
    return r->bad ? DTH_EPARSE : DTH_OK;
}

static int read_state(rd *r, st *s, char *err, size_t errlen)
{
    s->method = get_str(r, &s->method_len);
    s->name = get_str(r, &s->name_len);
    s->n = get_u64(r);
    s->nsec = get_u32(r);
    s->pos_sec = r->pos;
    if (r->bad || s->n == 0 || s->n > DTH__MAX_DOF || s->nsec > DTH__MAX_SECTIONS + 2) {
        dth__set_err(err, errlen, "checkpoint state header is invalid");
        return DTH_EPARSE;
    }
    for (uint32_t i = 0; i < s->nsec; i++)
        if (skip_section(r)) {
            dth__set_err(err, errlen, "checkpoint state section %u is malformed", (unsigned)i);
            return DTH_EPARSE;
        }
    s->reg = get_str(r, &s->reg_name_len);
    s->reg_len = get_u64(r);
    s->pos_reg = r->pos;
    if (!r->bad && s->reg_len > r->len - r->pos) r->bad = 1;
    if (!r->bad) get_bytes(r, s->reg_len);
    if (r->bad) {
        dth__set_err(err, errlen, "checkpoint regularizer state is invalid");
        return DTH_EPARSE;
    }
    return DTH_OK;
}

/* Skip the blobs, checking their structure; with `name`, stop at that blob. */
static int scan_blobs(rd *r, const char *name, const void **data, size_t *size)
{
    uint32_t nb = get_u32(r);
    for (uint32_t i = 0; i < nb && !r->bad; i++) {
        size_t nl;
        const char *nm = get_str(r, &nl);
        uint64_t sz = get_u64(r);
        if (r->bad || nl == 0 || sz > r->len - r->pos) {
            r->bad = 1;
            break;
        }
        const unsigned char *p = get_bytes(r, (size_t)sz);
        if (name && strlen(name) == nl && memcmp(nm, name, nl) == 0) {
            *data = p;
            *size = (size_t)sz;
            return DTH_OK;
        }
    }
    if (r->bad || r->pos != r->len) return DTH_EPARSE;
    return name ? DTH_ENOTFOUND : DTH_OK;
}

static int verify(const void *buf, size_t len, rd *r, st *s, char *err, size_t errlen)
{
    int rc = open_checked(r, buf, len, err, errlen);
    if (!rc) rc = read_state(r, s, err, errlen);
    if (rc) return rc;
    rd b = *r;
    if (scan_blobs(&b, NULL, NULL, NULL) != DTH_OK) {
        dth__set_err(err, errlen, "checkpoint blobs are malformed");
        return DTH_EPARSE;
    }
    return DTH_OK;
}

int dth_checkpoint_verify(const void *buf, size_t len, char *err, size_t errlen)
{
    rd r;
    st s;
    return verify(buf, len, &r, &s, err, errlen);
}

static int same_str(const char *a, const char *b, size_t blen) { return strlen(a) == blen && memcmp(a, b, blen) == 0; }

/* Read the saved section that must match `want` (its name, veclen and fields), validating every
 * value; pos gets each field's reader position. */
static int read_section(rd *r, const dth__section *want, size_t *pos, char *err, size_t errlen)
{
    size_t nl;
    const char *nm = get_str(r, &nl);
    uint64_t veclen = get_u64(r);
    uint32_t nf = get_u32(r);
    if (r->bad || !same_str(want->name, nm, nl) || veclen != want->veclen || nf != want->nfields) {
        dth__set_err(err, errlen, "checkpoint section '%.*s' (%u fields of %llu) where this library expects '%s' (%zu of %zu)",
                     (int)nl, nm ? nm : "", (unsigned)nf, (unsigned long long)veclen, want->name, want->nfields,
                     want->veclen);
        return DTH_EPARSE;
    }
    for (size_t i = 0; i < want->nfields; i++) {
        int rc = get_field(r, &want->fields[i], want->veclen, &pos[i], err, errlen);
        if (rc) return rc;
    }
    return DTH_OK;
}

/* The saved options equal the integrator's (they change the steps). */
static int same_options(const rd *r, const dth__section *o, const size_t *pos, char *err, size_t errlen)
{
    double saved[8];
    dth__section sv = *o;
    sv.base = saved;
    for (size_t i = 0; i < o->nfields; i++) {
        const dth__field *f = &o->fields[i];
        load_field(r, pos[i], f, saved, 0);
        const char *a = (const char *)o->base + f->off, *b = (const char *)(void *)saved + f->off;
        if (memcmp(a, b, f->kind == DTH__K_F64 ? sizeof(double) : sizeof(long)) == 0) continue;
        if (f->kind == DTH__K_F64)
            dth__set_err(err, errlen, "checkpoint was written with option %s = %.17g, this integrator has %.17g", f->name,
                         *(const double *)(const void *)b, *(const double *)(const void *)a);
        else
            dth__set_err(err, errlen, "checkpoint was written with option %s = %ld, this integrator has %ld", f->name,
                         *(const long *)(const void *)b, *(const long *)(const void *)a);
        return DTH_EINVAL;
    }
    (void)sv;
    return DTH_OK;
}

int dth_checkpoint_restore(dth_integrator *it, const void *buf, size_t len, char *err, size_t errlen)
{
    if (!it) return DTH_EINVAL;
    if (!it->type->sections) {
        dth__set_err(err, errlen, "method '%s' has no checkpoints", it->type->name);
        return DTH_EUNSUPPORTED;
    }
    rd r;
    st s;
    int rc = verify(buf, len, &r, &s, err, errlen);
    if (rc) return rc;
    const char *mname = dth_model_get_type(it->model)->name;
    if (!same_str(it->type->name, s.method, s.method_len)) {
        dth__set_err(err, errlen, "checkpoint of method '%.*s', this integrator steps with '%s'", (int)s.method_len, s.method,
                     it->type->name);
        return DTH_EINVAL;
    }
    if (!same_str(mname, s.name, s.name_len) || s.n != it->n) {
        dth__set_err(err, errlen, "checkpoint of model '%.*s' with %llu degrees of freedom does not fit model '%s' with %zu",
                (int)s.name_len, s.name, (unsigned long long)s.n, mname, it->n);
        return DTH_EINVAL;
    }
    dth__section sec[DTH__MAX_SECTIONS + 2];
    double scratch[8];
    size_t ns = sections_of(it, sec, scratch);
    if (s.nsec != ns) {
        dth__set_err(err, errlen, "checkpoint has %u state sections, this integrator %zu", (unsigned)s.nsec, ns);
        return DTH_EPARSE;
    }
    size_t pos[DTH__MAX_SECTIONS + 2][MAX_FIELDS];
    rd q = {r.p, r.len, s.pos_sec, 0};
    for (size_t i = 0; i < ns; i++) {
        if (sec[i].nfields > MAX_FIELDS) return DTH_EINVAL;
        rc = read_section(&q, &sec[i], pos[i], err, errlen);
        if (rc) return rc;
    }
    rc = same_options(&q, &sec[0], pos[0], err, errlen);
    if (rc) return rc;
    struct dth_regularizer *reg = reg_of(it);
    const char *rname = reg_name(it);
    if (!same_str(rname, s.reg, s.reg_name_len)) {
        dth__set_err(err, errlen, "checkpoint was written with %s%.*s%s, this integrator has %s%s%s",
                     s.reg_name_len ? "regularizer '" : "no regularizer", (int)s.reg_name_len, s.reg,
                     s.reg_name_len ? "'" : "", rname[0] ? "regularizer '" : "none", rname, rname[0] ? "'" : "");
        return DTH_EINVAL;
    }
    if (s.reg_len != dth__reg_state_size(reg)) {
        dth__set_err(err, errlen, "checkpoint holds %llu bytes of state of regularizer '%s', this one %zu",
                     (unsigned long long)s.reg_len, rname, dth__reg_state_size(reg));
        return DTH_EINVAL;
    }
    /* the regularizer checks its bytes first: nothing is changed if it rejects them */
    if (s.reg_len && dth__reg_load_state(reg, (const unsigned char *)r.p + s.pos_reg, (size_t)s.reg_len)) {
        dth__set_err(err, errlen, "checkpoint regularizer state is rejected by the regularizer");
        return DTH_EPARSE;
    }
    /* everything is valid: commit */
    for (size_t i = 1; i < ns; i++)
        for (size_t f = 0; f < sec[i].nfields; f++) load_field(&q, pos[i][f], &sec[i].fields[f], sec[i].base, sec[i].veclen);
    if (it->type->restored) it->type->restored(it->state);
    return DTH_OK;
}

int dth_checkpoint_blob(const void *buf, size_t len, const char *name, const void **data, size_t *size)
{
    if (!name || !data || !size) return DTH_EINVAL;
    rd r;
    st s;
    int rc = verify(buf, len, &r, &s, NULL, 0);
    if (rc) return rc;
    return scan_blobs(&r, name, data, size);
}

int dth_checkpoint_model_name(const void *buf, size_t len, char *name, size_t namelen)
{
    if (!name || !namelen) return DTH_EINVAL;
    rd r;
    st s;
    int rc = verify(buf, len, &r, &s, NULL, 0);
    if (rc) return rc;
    if (s.name_len >= namelen) return DTH_EINVAL;
    memcpy(name, s.name, s.name_len);
    name[s.name_len] = '\0';
    return DTH_OK;
}

int dth_checkpoint_write_file(const dth_integrator *it, const dth_blob *blobs, size_t nblobs,
                              const char *path, char *err, size_t errlen)
{
    if (!it || !path || !path[0]) return DTH_EINVAL;
    size_t len;
    int rc = dth_checkpoint_save(it, blobs, nblobs, NULL, 0, &len);
    if (rc) return rc;
    /* a temporary of its own (path.tmp.PID.XXXXXX: two writers of one path cannot collide; a
     * killed writer's is recognised by its PID), fsync, rename over path, fsync the folder */
    size_t plen = strlen(path), tcap = plen + 48;
    char *tmp = dth_calloc(it->alloc, tcap, 1);
    unsigned char *buf = dth_calloc(it->alloc, len, 1);
    if (!tmp || !buf) {
        dth_free(it->alloc, tmp);
        dth_free(it->alloc, buf);
        dth__set_err(err, errlen, "out of memory writing checkpoint '%s'", path);
        return DTH_ENOMEM;
    }
    rc = dth_checkpoint_save(it, blobs, nblobs, buf, len, &len);
    int fd = rc ? -1 : dth__open_unique_temp(path, tmp, tcap);
    if (!rc && fd < 0) {
        dth__set_err(err, errlen, "cannot write checkpoint '%s': %s", path, strerror(errno));
        rc = DTH_EIO;
    }
    if (fd >= 0) {
        int ok = 1, e = 0;
        for (size_t done = 0; ok && done < len;) {
            ssize_t w = write(fd, buf + done, len - done);
            if (w < 0 && errno == EINTR) continue;
            if (w <= 0) ok = 0, e = w < 0 ? errno : EIO;
            else done += (size_t)w;
        }
        if (ok && fsync(fd) != 0) ok = 0, e = errno;
        if (close(fd) != 0 && ok) ok = 0, e = errno;
        if (ok && rename(tmp, path) != 0) ok = 0, e = errno;
        if (!ok) {
            dth__set_err(err, errlen, "cannot write checkpoint '%s': %s", path, strerror(e));
            unlink(tmp);
            rc = DTH_EIO;
        }
    }
    if (!rc) {
        /* make the rename itself durable: fsync the directory (best effort) */
        const char *slash = strrchr(path, '/');
        if (slash) {
            size_t dl = slash == path ? 1 : (size_t)(slash - path);
            memcpy(tmp, path, dl);
            tmp[dl] = '\0';
        } else {
            memcpy(tmp, ".", 2);
        }
        int dfd = open(tmp, O_RDONLY);
        if (dfd >= 0) {
            fsync(dfd);
            close(dfd);
        }
    }
    dth_free(it->alloc, tmp);
    dth_free(it->alloc, buf);
    return rc;
}

int dth_checkpoint_read_file(const char *path, const dth_allocator *alloc, void **buf, size_t *len,
                             char *err, size_t errlen)
{
    if (!path || !buf || !len) return DTH_EINVAL;
    *buf = NULL;
    *len = 0;
    FILE *f = fopen(path, "rb");
    if (!f) {
        dth__set_err(err, errlen, "cannot open checkpoint '%s': %s", path, strerror(errno));
        return DTH_EIO;
    }
    /* a regular file only (a folder opens, and its size says nothing); no larger than a
     * checkpoint can sensibly be */
    struct stat sb;
    if (fstat(fileno(f), &sb) != 0 || !S_ISREG(sb.st_mode)) {
        dth__set_err(err, errlen, "cannot read checkpoint '%s': %s", path,
                     S_ISDIR(sb.st_mode) ? strerror(EISDIR) : "not a regular file");
        fclose(f);
        return DTH_EIO;
    }
    long size = -1;
    if (fseek(f, 0, SEEK_END) == 0) size = ftell(f);
    if (size < 0 || fseek(f, 0, SEEK_SET) != 0) {
        dth__set_err(err, errlen, "cannot read checkpoint '%s': %s", path, strerror(errno));
        fclose(f);
        return DTH_EIO;
    }
    unsigned char *b = dth_calloc(alloc, (size_t)size, 1);
    if (!b) {
        fclose(f);
        dth__set_err(err, errlen, "out of memory reading checkpoint '%s'", path);
        return DTH_ENOMEM;
    }
    size_t got = fread(b, 1, (size_t)size, f);
    int ioerr = ferror(f);
    fclose(f);
    if (ioerr || got != (size_t)size) {
        dth_free(alloc, b);
        dth__set_err(err, errlen, "cannot read checkpoint '%s'", path);
        return DTH_EIO;
    }
    char msg[160] = "";
    int rc = dth_checkpoint_verify(b, got, msg, sizeof msg);
    if (rc) {
        dth_free(alloc, b);
        dth__set_err(err, errlen, "%s: %s", path, msg);
        return rc;
    }
    *buf = b;
    *len = got;
    return DTH_OK;
}
