/* SPDX-License-Identifier: MIT */
/*
 * Checkpoints of an integrator (the state of the step of the paper's Theorem "DTH Equations" plus
 * its predictor), the regularizer's state and the run driver's: a versioned, checksummed format,
 * little-endian by construction (wire.h) with a byte-order mark, written and verified here, restored
 * by restore.c; crash-safe files (temporary file, fsync, rename).
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
#include "ckpt_format.h"
#include "run_fields.h"
#include "tempfile.h"

static const unsigned char MAGIC[8] = {'D', 'T', 'H', 'C', 'K', 'P', 'T', 0};

/* ---- the run state's field table, from its list (run_fields.h) ---- */

#define RUN_ENTRY(name, kind, check, doc) DTH__FIELD(dth_run_state, name, kind, check),
#define STEP_ENTRY(name, kind, check, doc)                                                                             \
    {"in." #name, offsetof(dth_run_state, in) + offsetof(dth_step_info, name), DTH__K_##kind, DTH__C_##check, 0},
#define RUN_FLAT(name, kind, check, doc) RUN_FLAT_##kind(name, kind, check)
#define RUN_FLAT_INT(name, kind, check) RUN_ENTRY(name, kind, check, "")
#define RUN_FLAT_LONG(name, kind, check) RUN_ENTRY(name, kind, check, "")
#define RUN_FLAT_F64(name, kind, check) RUN_ENTRY(name, kind, check, "")
#define RUN_FLAT_STEP(name, kind, check) DTH__STEP_INFO_FIELDS(STEP_ENTRY)
static const dth_field run_fields[] = {DTH__RUN_FIELDS(RUN_FLAT)};
#undef RUN_ENTRY
#undef STEP_ENTRY
_Static_assert(sizeof run_fields / sizeof run_fields[0] <= DTH__MAX_FIELDS, "the run state's fields");

const dth_field *dth__run_fields(size_t *n)
{
    *n = sizeof run_fields / sizeof run_fields[0];
    return run_fields;
}

void dth__run_section(const dth_run_state *run, dth__section *out)
{
    *out = (dth__section){"run", run_fields, sizeof run_fields / sizeof run_fields[0], (void *)(uintptr_t)run, 0};
}

/* ---- the state part: the method, the model, the options, the stepper's sections, the
 * regularizer's, the run's ---- */

/* The error estimate's shadow trajectory (estimate.h): its position decides every later estimate, and
 * with it the run's stop on its error (run.h, stop_error). */
#define EST_ENTRY(name, kind, check, doc) DTH__FIELD(dth__estimate, name, kind, check),
static const dth_field est_fields[] = {DTH__ESTIMATE_FIELDS(EST_ENTRY)};
#undef EST_ENTRY

size_t dth__ckpt_sections(const dth_integrator *it, dth__section *sec, void *scratch)
{
    size_t k = 0;
    if (it->type->options_section) it->type->options_section(it->state, &sec[k++], scratch);
    else sec[k++] = (dth__section){"options", NULL, 0, scratch, 0};
    k += it->type->sections(it->state, sec + k);
    if (it->est.on)
        sec[k++] = (dth__section){"estimate", est_fields, sizeof est_fields / sizeof est_fields[0],
                                  (void *)(uintptr_t)&it->est, it->N};
    return k;
}

struct dth_regularizer *dth__ckpt_reg(const dth_integrator *it)
{
    return it->type->regularizer ? it->type->regularizer(it->state) : NULL;
}

const char *dth__ckpt_reg_name(const dth_integrator *it)
{
    struct dth_regularizer *r = dth__ckpt_reg(it);
    return r ? dth_regularizer_get_type(r)->name : "";
}

void dth__ckpt_reg_section(const dth_integrator *it, dth__section *out)
{
    struct dth_regularizer *r = dth__ckpt_reg(it);
    size_t n;
    const dth_field *f = dth__reg_fields(r, &n);
    *out = (dth__section){"regularizer", f, n, dth__reg_self(r), r ? dth__reg_veclen(r) : it->N};
}

void dth__put_section(dth__wr *w, const dth__section *sec)
{
    dth__put_str(w, sec->name);
    dth__put_u64(w, sec->veclen);
    dth__put_u32(w, (uint32_t)sec->nfields);
    for (size_t i = 0; i < sec->nfields; i++) dth__put_field(w, &sec->fields[i], sec->base, sec->veclen);
}

static void put_state(dth__wr *w, const dth_integrator *it, const dth_run_state *run)
{
    dth__section sec[DTH__CKPT_MAX_SECTIONS], rs;
    double scratch[8];
    size_t ns = dth__ckpt_sections(it, sec, scratch);
    dth__put_str(w, it->type->name);
    dth__put_str(w, dth_model_get_type(it->model)->name);
    dth__put_u64(w, it->n);
    dth__put_u32(w, (uint32_t)ns);
    for (size_t i = 0; i < ns; i++) dth__put_section(w, &sec[i]);
    /* the regularizer's own state: its type's field list */
    dth__put_str(w, dth__ckpt_reg_name(it));
    dth__ckpt_reg_section(it, &rs);
    dth__put_section(w, &rs);
    /* the run driver's state, if given */
    dth__put_u32(w, run != NULL);
    if (run) {
        dth__run_section(run, &rs);
        dth__put_section(w, &rs);
    }
}

int dth_checkpoint_save_run(const dth_integrator *it, const dth_run_state *run, const dth_blob *blobs, size_t nblobs,
                            void *buf, size_t cap, size_t *len)
{
    if (len) *len = 0;
    if (!it || !len || (nblobs && !blobs) || !it->type->sections) return DTH_EINVAL;
    for (size_t i = 0; i < nblobs; i++) {
        if (!blobs[i].name || !blobs[i].name[0] || strlen(blobs[i].name) > DTH__CKPT_MAX_NAME ||
            (blobs[i].size && !blobs[i].data))
            return DTH_EINVAL;
        for (size_t j = 0; j < i; j++)
            if (strcmp(blobs[i].name, blobs[j].name) == 0) return DTH_EINVAL;
    }
    /* pass 1 sizes, pass 2 writes */
    dth__wr w = {NULL, 0, 0};
    for (int pass = 0; pass < 2; pass++) {
        w.len = 0;
        dth__put_bytes(&w, MAGIC, sizeof MAGIC);
        dth__put_u32(&w, DTH_CHECKPOINT_VERSION);
        dth__put_u32(&w, DTH__CKPT_BOM);
        dth__put_u64(&w, (uint64_t)*len);
        put_state(&w, it, run);
        dth__put_u32(&w, (uint32_t)nblobs);
        for (size_t i = 0; i < nblobs; i++) {
            dth__put_str(&w, blobs[i].name);
            dth__put_u64(&w, blobs[i].size);
            dth__put_bytes(&w, blobs[i].data, blobs[i].size);
        }
        if (pass == 0) {
            *len = w.len + DTH__CKPT_TRAILER;
            if (!buf || cap < *len) return buf ? DTH_EINVAL : DTH_OK;
            w.buf = buf;
            w.cap = cap;
        }
    }
    dth__put_u64(&w, dth__fnv1a(DTH__FNV_OFFSET, buf, w.len));
    return DTH_OK;
}

int dth_checkpoint_save(const dth_integrator *it, const dth_blob *blobs, size_t nblobs, void *buf, size_t cap,
                        size_t *len)
{
    return dth_checkpoint_save_run(it, NULL, blobs, nblobs, buf, cap, len);
}

/* ---- reading: the header, the structure ---- */

/* Parsed header; the state and blobs are read by the callers with `r` positioned after it. */
static int open_checked(dth__rd *r, const void *buf, size_t len, char *err, size_t errlen)
{
    *r = (dth__rd){buf, len, 0, 0};
    if (!buf || len < DTH__CKPT_HEADER + DTH__CKPT_TRAILER) {
        dth__set_err(err, errlen, "checkpoint truncated (%zu bytes)", len);
        return DTH_EPARSE;
    }
    const unsigned char *p = buf;
    if (memcmp(p, MAGIC, sizeof MAGIC) != 0) {
        dth__set_err(err, errlen, "not a dth checkpoint (bad magic)");
        return DTH_EPARSE;
    }
    dth__get_bytes(r, sizeof MAGIC);
    uint32_t ver = dth__get_u32(r), bom = dth__get_u32(r);
    uint64_t total = dth__get_u64(r);
    /* the byte order first: a big-endian writer's version and length read as nonsense here (its
     * mark reads 0x04030201: the mark's bytes are 01 02 03 04) */
    if (bom == 0x04030201u) {
        dth__set_err(err, errlen, "checkpoint written in big-endian byte order (byte-order mark 0x%08x): dth "
                     "checkpoints are little-endian, and this one was written by a program that copied its host's "
                     "bytes", (unsigned)bom);
        return DTH_EPARSE;
    }
    if (ver != DTH_CHECKPOINT_VERSION) {
        dth__set_err(err, errlen, "checkpoint format version %u, this library reads version %d only%s", (unsigned)ver,
                     DTH_CHECKPOINT_VERSION,
                     ver < DTH_CHECKPOINT_VERSION ? " (written by an older dth: resume it with that version)" : "");
        return DTH_EPARSE;
    }
    if (bom != DTH__CKPT_BOM) {
        dth__set_err(err, errlen, "checkpoint byte-order mark is 0x%08x, not the little-endian 0x%08x", (unsigned)bom,
                     (unsigned)DTH__CKPT_BOM);
        return DTH_EPARSE;
    }
    if (total != len) {
        dth__set_err(err, errlen, "checkpoint is %zu bytes, its header says %llu (truncated or extended)", len,
                     (unsigned long long)total);
        return DTH_EPARSE;
    }
    dth__rd t = {p + len - DTH__CKPT_TRAILER, DTH__CKPT_TRAILER, 0, 0};
    if (dth__get_u64(&t) != dth__fnv1a(DTH__FNV_OFFSET, p, len - DTH__CKPT_TRAILER)) {
        dth__set_err(err, errlen, "checkpoint checksum mismatch (corrupted)");
        return DTH_EPARSE;
    }
    r->len = len - DTH__CKPT_TRAILER; /* the body ends at the checksum */
    return DTH_OK;
}

/* Skip one section's fields, checking their structure (names, types, counts; values unchecked). */
static int skip_section(dth__rd *r)
{
    size_t nl;
    dth__get_str(r, DTH__CKPT_MAX_NAME, &nl);
    uint64_t veclen = dth__get_u64(r);
    uint32_t nf = dth__get_u32(r);
    if (r->bad || nf > DTH__MAX_FIELDS || veclen > ((uint64_t)1 << 44)) return DTH_EPARSE;
    for (uint32_t i = 0; i < nf && !r->bad; i++) {
        size_t fl;
        dth__get_str(r, DTH__CKPT_MAX_NAME, &fl);
        uint32_t type = dth__get_u32(r);
        uint64_t count = dth__get_u64(r);
        if (r->bad || (type != DTH__T_F64 && type != DTH__T_I64) || count > (r->len - r->pos) / 8) return DTH_EPARSE;
        dth__get_bytes(r, (size_t)count * 8);
    }
    return r->bad ? DTH_EPARSE : DTH_OK;
}

static int read_state(dth__rd *r, dth__ckpt *s, char *err, size_t errlen)
{
    s->method = dth__get_str(r, DTH__CKPT_MAX_NAME, &s->method_len);
    s->name = dth__get_str(r, DTH__CKPT_MAX_NAME, &s->name_len);
    s->n = dth__get_u64(r);
    s->nsec = dth__get_u32(r);
    s->pos_sec = r->pos;
    if (r->bad || s->n == 0 || s->n > DTH__MAX_DOF || s->nsec > DTH__CKPT_MAX_SECTIONS) {
        dth__set_err(err, errlen, "checkpoint state header is invalid");
        return DTH_EPARSE;
    }
    for (uint32_t i = 0; i < s->nsec; i++)
        if (skip_section(r)) {
            dth__set_err(err, errlen, "checkpoint state section %u is malformed", (unsigned)i);
            return DTH_EPARSE;
        }
    s->reg = dth__get_str(r, DTH__CKPT_MAX_NAME, &s->reg_name_len);
    s->pos_reg = r->pos;
    if (r->bad || skip_section(r)) {
        dth__set_err(err, errlen, "checkpoint regularizer state is malformed");
        return DTH_EPARSE;
    }
    uint32_t has_run = dth__get_u32(r);
    s->pos_run = r->pos;
    if (r->bad || has_run > 1 || (has_run && skip_section(r))) {
        dth__set_err(err, errlen, "checkpoint run state is malformed");
        return DTH_EPARSE;
    }
    s->has_run = (int)has_run;
    return DTH_OK;
}

/* Skip the blobs, checking their structure; with `name`, stop at that blob. */
static int scan_blobs(dth__rd *r, const char *name, const void **data, size_t *size)
{
    uint32_t nb = dth__get_u32(r);
    for (uint32_t i = 0; i < nb && !r->bad; i++) {
        size_t nl;
        const char *nm = dth__get_str(r, DTH__CKPT_MAX_NAME, &nl);
        uint64_t sz = dth__get_u64(r);
        if (r->bad || nl == 0 || sz > r->len - r->pos) {
            r->bad = 1;
            break;
        }
        const unsigned char *p = dth__get_bytes(r, (size_t)sz);
        if (name && strlen(name) == nl && memcmp(nm, name, nl) == 0) {
            *data = p;
            *size = (size_t)sz;
            return DTH_OK;
        }
    }
    if (r->bad || r->pos != r->len) return DTH_EPARSE;
    return name ? DTH_ENOTFOUND : DTH_OK;
}

int dth__ckpt_verify(const void *buf, size_t len, dth__rd *r, dth__ckpt *s, char *err, size_t errlen)
{
    int rc = open_checked(r, buf, len, err, errlen);
    if (!rc) rc = read_state(r, s, err, errlen);
    if (rc) return rc;
    dth__rd b = *r;
    if (scan_blobs(&b, NULL, NULL, NULL) != DTH_OK) {
        dth__set_err(err, errlen, "checkpoint blobs are malformed");
        return DTH_EPARSE;
    }
    return DTH_OK;
}

int dth_checkpoint_verify(const void *buf, size_t len, char *err, size_t errlen)
{
    dth__rd r;
    dth__ckpt s;
    return dth__ckpt_verify(buf, len, &r, &s, err, errlen);
}

int dth_checkpoint_blob(const void *buf, size_t len, const char *name, const void **data, size_t *size)
{
    if (!name || !data || !size) return DTH_EINVAL;
    dth__rd r;
    dth__ckpt s;
    int rc = dth__ckpt_verify(buf, len, &r, &s, NULL, 0);
    if (rc) return rc;
    return scan_blobs(&r, name, data, size);
}

int dth_checkpoint_model_name(const void *buf, size_t len, char *name, size_t namelen)
{
    if (!name || !namelen) return DTH_EINVAL;
    dth__rd r;
    dth__ckpt s;
    int rc = dth__ckpt_verify(buf, len, &r, &s, NULL, 0);
    if (rc) return rc;
    if (s.name_len >= namelen) return DTH_EINVAL;
    memcpy(name, s.name, s.name_len);
    name[s.name_len] = '\0';
    return DTH_OK;
}

/* ---- files ---- */

int dth_checkpoint_write_file_run(const dth_integrator *it, const dth_run_state *run, const dth_blob *blobs,
                                  size_t nblobs, const char *path, char *err, size_t errlen)
{
    if (!it || !path || !path[0]) return DTH_EINVAL;
    size_t len;
    int rc = dth_checkpoint_save_run(it, run, blobs, nblobs, NULL, 0, &len);
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
    rc = dth_checkpoint_save_run(it, run, blobs, nblobs, buf, len, &len);
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

int dth_checkpoint_write_file(const dth_integrator *it, const dth_blob *blobs, size_t nblobs, const char *path, char *err,
                              size_t errlen)
{
    return dth_checkpoint_write_file_run(it, NULL, blobs, nblobs, path, err, errlen);
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
