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
#include <stdint.h>
#include <stdio.h>
#include <string.h>
#include <unistd.h>
#include "dth/checkpoint.h"
#include "dth_internal.h"
#include "integrator_impl.h"

static const unsigned char MAGIC[8] = {'D', 'T', 'H', 'C', 'K', 'P', 'T', 0};
enum { HEADER = 8 + 4 + 4 + 8, TRAILER = 8, MAX_NAME = 255 };

/* FNV-1a 64 */
static uint64_t fnv1a(const unsigned char *p, size_t n)
{
    uint64_t h = 14695981039346656037ULL;
    for (size_t i = 0; i < n; i++) {
        h ^= p[i];
        h *= 1099511628211ULL;
    }
    return h;
}

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

/* ---- the state section ---- */

static void put_state(wr *w, const dth_integrator *it)
{
    size_t N = it->N, m = (size_t)it->m;
    put_str(w, dth_model_get_type(it->model)->name);
    put_u64(w, it->n);
    put_u32(w, (uint32_t)m);
    put_u32(w, (uint32_t)it->auton);
    put_f64s(w, it->z, N);
    put_f64s(w, it->zlo, N);
    put_f64s(w, it->zbar, N);
    put_f64s(w, it->dprev, N);
    put_f64s(w, it->dprev2, N);
    put_f64s(w, it->dprev3, N);
    put_f64(w, it->lam);
    put_f64(w, it->lam2);
    put_f64(w, it->lam3);
    put_u32(w, (uint32_t)it->nhist);
    put_f64(w, it->rho);
    put_f64(w, it->lam_hint);
    put_f64(w, it->dir);
    put_f64(w, it->opt.h);
    put_u32(w, (uint32_t)it->have_prev);
    put_u32(w, (uint32_t)it->have_mid);
    put_u32(w, (uint32_t)it->pending_exact);
    put_u32(w, (uint32_t)it->fact_valid);
    put_u64(w, (uint64_t)it->steps);
    put_u32(w, (uint32_t)it->psi_known);
    put_u32(w, (uint32_t)(it->psi_sign + 1)); /* -1, 0, 1 stored as 0, 1, 2 */
    /* the regularizer's own state (a constant fixed at its first step, seeds), as its bytes */
    size_t rl = dth__reg_state_size(it->reg);
    put_u64(w, rl);
    if (rl && w->buf && w->len + rl <= w->cap) dth__reg_save_state(it->reg, w->buf + w->len);
    w->len += rl;
}

int dth_checkpoint_save(const dth_integrator *it, const dth_blob *blobs, size_t nblobs, void *buf,
                        size_t cap, size_t *len)
{
    if (len) *len = 0;
    if (!it || !len || (nblobs && !blobs)) return DTH_EINVAL;
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
    put_u64(&w, fnv1a(buf, w.len));
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
        dth__set_err(err, errlen, "checkpoint format version %u, this library reads version %d", (unsigned)ver,
                DTH_CHECKPOINT_VERSION);
        return DTH_EPARSE;
    }
    if (total != len) {
        dth__set_err(err, errlen, "checkpoint is %zu bytes, its header says %llu (truncated or extended)", len,
                (unsigned long long)total);
        return DTH_EPARSE;
    }
    rd t = {p + len - TRAILER, TRAILER, 0, 0};
    if (get_u64(&t) != fnv1a(p, len - TRAILER)) {
        dth__set_err(err, errlen, "checkpoint checksum mismatch (corrupted)");
        return DTH_EPARSE;
    }
    r->len = len - TRAILER; /* the body ends at the checksum */
    return DTH_OK;
}

/* The state, validated, as read (pointers into the buffer are kept as a reader position). */
typedef struct st {
    const char *name;
    size_t name_len;
    uint64_t n;
    uint32_t m, auton, have_prev, have_mid, pending_exact, fact_valid, psi_known, psi_sign, nhist;
    double lam, lam2, lam3, rho, lam_hint, dir, h;
    uint64_t steps;
    size_t pos_z;         /* reader position of the vectors */
    uint64_t reg_len;     /* bytes of regularizer state */
    size_t pos_reg;
} st;

static int read_state(rd *r, st *s, char *err, size_t errlen)
{
    s->name = get_str(r, &s->name_len);
    s->n = get_u64(r);
    s->m = get_u32(r);
    s->auton = get_u32(r);
    if (r->bad || s->n == 0 || s->n > (1u << 20) || s->m > 2 * s->n + 3 || s->auton > 1) {
        dth__set_err(err, errlen, "checkpoint state header is invalid");
        return DTH_EPARSE;
    }
    size_t N = 2 * (size_t)s->n + 2;
    s->pos_z = r->pos;
    for (size_t i = 0; i < 6 * N; i++) {
        double x = get_f64(r);
        if (!isfinite(x)) r->bad = 1;
    }
    s->lam = get_f64(r);
    s->lam2 = get_f64(r);
    s->lam3 = get_f64(r);
    s->nhist = get_u32(r);
    s->rho = get_f64(r);
    s->lam_hint = get_f64(r);
    s->dir = get_f64(r);
    s->h = get_f64(r);
    s->have_prev = get_u32(r);
    s->have_mid = get_u32(r);
    s->pending_exact = get_u32(r);
    s->fact_valid = get_u32(r);
    s->steps = get_u64(r);
    s->psi_known = get_u32(r);
    s->psi_sign = get_u32(r);
    if (r->bad || s->psi_known > 1 || s->psi_sign > 2 || s->nhist > 3 || !isfinite(s->lam) || !isfinite(s->lam2) ||
        !isfinite(s->lam3) || !isfinite(s->rho) || !isfinite(s->lam_hint) ||
        !(s->dir == 1.0 || s->dir == -1.0) || !isfinite(s->h) || s->h == 0 || s->have_prev > 1 ||
        s->have_mid > 1 || s->pending_exact > 1 || s->fact_valid > 1 || s->steps > (uint64_t)LONG_MAX) {
        dth__set_err(err, errlen, "checkpoint state is invalid (non-finite value or bad flag)");
        return DTH_EPARSE;
    }
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

int dth_checkpoint_restore(dth_integrator *it, const void *buf, size_t len, char *err, size_t errlen)
{
    if (!it) return DTH_EINVAL;
    rd r;
    st s;
    int rc = verify(buf, len, &r, &s, err, errlen);
    if (rc) return rc;
    const char *mname = dth_model_get_type(it->model)->name;
    if (strlen(mname) != s.name_len || memcmp(mname, s.name, s.name_len) != 0 || s.n != it->n ||
        s.m != (uint32_t)it->m || s.auton != (uint32_t)it->auton) {
        dth__set_err(err, errlen, "checkpoint of model '%.*s' with %llu degrees of freedom does not fit model '%s' with %zu",
                (int)s.name_len, s.name, (unsigned long long)s.n, mname, it->n);
        return DTH_EINVAL;
    }
    if (s.reg_len != dth__reg_state_size(it->reg)) {
        dth__set_err(err, errlen, "checkpoint holds %llu bytes of regularizer state, this integrator's regularizer %zu",
                     (unsigned long long)s.reg_len, dth__reg_state_size(it->reg));
        return DTH_EINVAL;
    }
    /* the regularizer checks its bytes first: nothing is changed if it rejects them */
    if (s.reg_len && dth__reg_load_state(it->reg, (const unsigned char *)r.p + s.pos_reg, (size_t)s.reg_len)) {
        dth__set_err(err, errlen, "checkpoint regularizer state is rejected by the regularizer");
        return DTH_EPARSE;
    }
    /* everything is valid: commit */
    size_t N = it->N;
    rd v = {r.p, r.len, s.pos_z, 0};
    double *vec[] = {it->z, it->zlo, it->zbar, it->dprev, it->dprev2, it->dprev3};
    for (int k = 0; k < 6; k++)
        for (size_t j = 0; j < N; j++) vec[k][j] = get_f64(&v);
    it->lam = s.lam;
    it->lam2 = s.lam2;
    it->lam3 = s.lam3;
    it->nhist = (int)s.nhist;
    it->rho = s.rho;
    it->lam_hint = s.lam_hint;
    it->dir = s.dir;
    it->opt.h = s.h;
    it->have_prev = (int)s.have_prev;
    it->have_mid = (int)s.have_mid;
    it->pending_exact = (int)s.pending_exact;
    it->fact_valid = (int)s.fact_valid;
    it->steps = (long)s.steps;
    it->psi_known = (int)s.psi_known;
    it->psi_sign = (int)s.psi_sign - 1;
    snprintf(it->errmsg, sizeof it->errmsg, "no error");
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
    size_t plen = strlen(path);
    char *tmp = dth_calloc(it->alloc, plen + 5, 1);
    unsigned char *buf = dth_calloc(it->alloc, len, 1);
    if (!tmp || !buf) {
        dth_free(it->alloc, tmp);
        dth_free(it->alloc, buf);
        dth__set_err(err, errlen, "out of memory writing checkpoint '%s'", path);
        return DTH_ENOMEM;
    }
    memcpy(tmp, path, plen);
    memcpy(tmp + plen, ".tmp", 5);
    rc = dth_checkpoint_save(it, blobs, nblobs, buf, len, &len);
    FILE *f = rc ? NULL : fopen(tmp, "wb");
    if (!rc && !f) {
        dth__set_err(err, errlen, "cannot create '%s': %s", tmp, strerror(errno));
        rc = DTH_EIO;
    }
    if (f) {
        int ok = fwrite(buf, 1, len, f) == len && fflush(f) == 0 && fsync(fileno(f)) == 0;
        int e = errno;
        if (fclose(f) != 0 && ok) {
            ok = 0;
            e = errno;
        }
        if (ok && rename(tmp, path) != 0) {
            ok = 0;
            e = errno;
        }
        if (!ok) {
            dth__set_err(err, errlen, "cannot write checkpoint '%s': %s", path, strerror(e));
            remove(tmp);
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
        int fd = open(tmp, O_RDONLY);
        if (fd >= 0) {
            fsync(fd);
            close(fd);
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
