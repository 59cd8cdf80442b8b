/* SPDX-License-Identifier: MIT */
/*
 * The field codec: the members of a struct, by their field list (dth/fields.h, fields.h), as named,
 * typed, little-endian values (wire.h), and each restored value checked against its field's check;
 * the checkpoint's sections (checkpoint.c) and the public records of dth_fields_encode / decode.
 */
#include <limits.h>
#include <math.h>
#include <stdio.h>
#include <string.h>
#include "dth/checkpoint.h"
#include "dth/run.h"
#include "dth_internal.h"
#include "fields.h"

enum { MAX_NAME = 64, MAX_WIRE_NAME = 255 };

size_t dth__field_size(const dth_field *f)
{
    switch (f->kind) {
    case DTH__K_F64: return (f->count ? f->count : 1) * sizeof(double);
    case DTH__K_INT: return sizeof(int);
    case DTH__K_UINT: return sizeof(unsigned);
    case DTH__K_LONG: return sizeof(long);
    case DTH__K_U64: return sizeof(unsigned long long);
    case DTH__K_VEC: return sizeof(double *);
    case DTH__K_STR: return sizeof(char *);
    default: return 0;
    }
}

int dth__field_wire(int kind)
{
    return kind == DTH__K_F64 || kind == DTH__K_VEC ? DTH__T_F64 : kind == DTH__K_STR ? DTH__T_STR : DTH__T_I64;
}

uint64_t dth__field_count(const dth_field *f, size_t veclen)
{
    if (f->kind == DTH__K_VEC) return f->count ? f->count : veclen;
    if (f->kind == DTH__K_F64) return f->count ? f->count : 1;
    return 1;
}

/* ---- values and their checks ---- */

static int check_f64(int check, double x)
{
    switch (check) {
    case DTH__C_ANY: return 1;
    case DTH__C_NONNEG: return isfinite(x) && x >= 0;
    case DTH__C_POSITIVE: return isfinite(x) && x > 0;
    case DTH__C_NONZERO: return isfinite(x) && x != 0;
    case DTH__C_UNIT: return x == 1.0 || x == -1.0;
    case DTH__C_STEP: return isfinite(x);
    case DTH__C_HSTEP: return isfinite(x) && x != 0;
    case DTH__C_TIME: return isfinite(x);
    case DTH__C_RATIO: return x == 0 || x >= 1; /* a ratio of finite steps may overflow */
    case DTH__C_MAG: return x >= 0;
    case DTH__C_ERR: return isnan(x) || x >= 0;
    case DTH__C_RESID: return isnan(x) || (isfinite(x) && x >= 0);
    default: return isfinite(x);
    }
}

static int check_i64(const dth_field *f, int64_t x)
{
    if (f->kind == DTH__K_U64) return 1;
    if (f->kind == DTH__K_INT && (x < INT_MIN || x > INT_MAX)) return 0;
    if (f->kind == DTH__K_UINT && (x < 0 || (uint64_t)x > UINT_MAX)) return 0;
    if (f->kind == DTH__K_LONG && (x < LONG_MIN || x > LONG_MAX)) return 0;
    switch (f->check) {
    case DTH__C_NONNEG: return x >= 0;
    case DTH__C_POSITIVE: return x > 0;
    case DTH__C_BOOL: return x == 0 || x == 1;
    case DTH__C_COUNT: return x >= 0 && x <= DTH__MAX_COUNT;
    case DTH__C_SIGN: return x >= -1 && x <= 1;
    case DTH__C_NHIST: return x >= 0 && x <= 3;
    case DTH__C_PSISTEP: return x >= -2 && x <= DTH__MAX_COUNT;
    case DTH__C_BRANCH: return x >= DTH_BRANCH_NONE && x <= DTH_BRANCH_REG;
    case DTH__C_FLAGS: return x >= 0 && x <= (DTH_STEP_REGULARIZED | DTH_STEP_CROSSING | DTH_STEP_NONREVERSIBLE);
    case DTH__C_STOP: return x >= DTH_RUN_RUNNING && x <= DTH_RUN_SAMPLES;
    default: return 1;
    }
}

/* What a check asks for, for the message. */
static const char *check_doc(int check)
{
    switch (check) {
    case DTH__C_FINITE: return "a finite number";
    case DTH__C_NONNEG: return "a number >= 0";
    case DTH__C_POSITIVE: return "a number > 0";
    case DTH__C_BOOL: return "0 or 1";
    case DTH__C_COUNT: return "a count from 0 to 2^53";
    case DTH__C_NONZERO: return "a finite nonzero number";
    case DTH__C_UNIT: return "+1 or -1";
    case DTH__C_SIGN: return "-1, 0 or 1";
    case DTH__C_NHIST: return "0 to 3";
    case DTH__C_PSISTEP: return "a step count from -2 to 2^53";
    case DTH__C_STEP: return "a finite step";
    case DTH__C_HSTEP: return "a finite nonzero step";
    case DTH__C_TIME: return "a finite time";
    case DTH__C_RATIO: return "0, or a ratio >= 1";
    case DTH__C_MAG: return "a size >= 0";
    case DTH__C_ERR: return "a size >= 0 (or NaN)";
    case DTH__C_RESID: return "a residual >= 0 (or NaN)";
    case DTH__C_BRANCH: return "a dth_branch (0 to 5)";
    case DTH__C_FLAGS: return "DTH_STEP_* flags (0 to 31)";
    case DTH__C_STOP: return "a dth_run_stop (0 to 5)";
    default: return "a value in the range of its type";
    }
}

/* ---- writing ---- */

void dth__put_field(dth__wr *w, const dth_field *f, const void *base, size_t veclen)
{
    const char *p = (const char *)base + f->offset;
    dth__put_str(w, f->name);
    dth__put_u32(w, (uint32_t)dth__field_wire(f->kind));
    uint64_t count = dth__field_count(f, veclen);
    switch (f->kind) {
    case DTH__K_VEC:
    case DTH__K_F64: {
        const double *v = (const double *)(const void *)p;
        if (f->kind == DTH__K_VEC) memcpy(&v, p, sizeof v);
        dth__put_u64(w, count);
        for (uint64_t i = 0; i < count; i++) {
            double x;
            memcpy(&x, (const char *)v + i * sizeof x, sizeof x);
            dth__put_f64(w, x);
        }
        return;
    }
    case DTH__K_STR: {
        const char *s;
        memcpy(&s, p, sizeof s);
        if (!s) s = "";
        size_t n = strlen(s);
        dth__put_u64(w, n);
        dth__put_bytes(w, s, n);
        return;
    }
    default: break;
    }
    int64_t x = 0;
    if (f->kind == DTH__K_INT) {
        int v;
        memcpy(&v, p, sizeof v);
        x = v;
    } else if (f->kind == DTH__K_UINT) {
        unsigned v;
        memcpy(&v, p, sizeof v);
        x = (int64_t)v;
    } else if (f->kind == DTH__K_LONG) {
        long v;
        memcpy(&v, p, sizeof v);
        x = v;
    } else {
        unsigned long long v;
        memcpy(&v, p, sizeof v);
        x = (int64_t)(uint64_t)v;
    }
    dth__put_u64(w, 1);
    dth__put_u64(w, (uint64_t)x);
}

/* ---- reading ---- */

/* A refused value: its field, the value, what the check asks for. */
static int refuse_value(const dth_field *f, uint32_t type, uint64_t v, int vec, char *err, size_t errlen)
{
    double x;
    memcpy(&x, &v, sizeof x);
    if (type == DTH__T_F64)
        dth__set_err(err, errlen, "field '%s' holds %.17g%s, not %s", f->name, x,
                     vec ? " (in one of its components)" : "", check_doc(f->check));
    else
        dth__set_err(err, errlen, "field '%s' holds %lld, not %s", f->name, (long long)(int64_t)v,
                     check_doc(f->check));
    return DTH_EPARSE;
}

int dth__get_field(dth__rd *r, const dth_field *f, size_t veclen, size_t *pos, char *err, size_t errlen)
{
    size_t nl;
    const char *nm = dth__get_str(r, MAX_WIRE_NAME, &nl);
    uint32_t type = dth__get_u32(r);
    uint64_t count = dth__get_u64(r);
    if (r->bad) {
        dth__set_err(err, errlen, "truncated in field '%s'", f->name);
        return DTH_EPARSE;
    }
    if (nl != strlen(f->name) || memcmp(nm, f->name, nl) != 0) {
        dth__set_err(err, errlen, "field '%.*s' where this library expects '%s'", (int)nl, nm, f->name);
        return DTH_EPARSE;
    }
    int want_type = dth__field_wire(f->kind);
    uint64_t want = dth__field_count(f, veclen);
    if (type != (uint32_t)want_type || (f->kind != DTH__K_STR && count != want) ||
        (f->kind == DTH__K_STR && count > DTH_FIELD_STR_MAX)) {
        if (f->kind == DTH__K_STR && type == DTH__T_STR)
            dth__set_err(err, errlen, "field '%s' is longer than %d bytes", f->name, DTH_FIELD_STR_MAX);
        else
            dth__set_err(err, errlen, "field '%s' has type %u and %llu values (expected %d and %llu)",
                         f->name, (unsigned)type, (unsigned long long)count, want_type, (unsigned long long)want);
        return DTH_EPARSE;
    }
    *pos = r->pos;
    if (f->kind == DTH__K_STR) {
        const unsigned char *s = dth__get_bytes(r, (size_t)count);
        if (s && memchr(s, '\0', (size_t)count)) {
            dth__set_err(err, errlen, "field '%s' holds a NUL byte", f->name);
            return DTH_EPARSE;
        }
    }
    for (uint64_t i = 0; f->kind != DTH__K_STR && i < count && !r->bad; i++) {
        uint64_t v = dth__get_u64(r);
        int ok;
        if (type == DTH__T_F64) {
            double x;
            memcpy(&x, &v, sizeof x);
            ok = check_f64(f->check, x);
        } else {
            ok = check_i64(f, (int64_t)v);
        }
        if (!r->bad && !ok) return refuse_value(f, type, v, count > 1, err, errlen);
    }
    if (r->bad) {
        dth__set_err(err, errlen, "truncated in field '%s'", f->name);
        return DTH_EPARSE;
    }
    return DTH_OK;
}

void dth__load_field(const dth__rd *r, size_t pos, const dth_field *f, void *base, size_t veclen)
{
    dth__rd v = {r->p, r->len, pos, 0};
    char *p = (char *)base + f->offset;
    uint64_t count = dth__field_count(f, veclen);
    if (f->kind == DTH__K_VEC || f->kind == DTH__K_F64) {
        char *dst = p;
        if (f->kind == DTH__K_VEC) memcpy(&dst, p, sizeof dst);
        for (uint64_t j = 0; j < count; j++) {
            double x = dth__get_f64(&v);
            memcpy(dst + j * sizeof x, &x, sizeof x);
        }
        return;
    }
    int64_t x = (int64_t)dth__get_u64(&v);
    if (f->kind == DTH__K_INT) {
        int y = (int)x;
        memcpy(p, &y, sizeof y);
    } else if (f->kind == DTH__K_UINT) {
        unsigned y = (unsigned)x;
        memcpy(p, &y, sizeof y);
    } else if (f->kind == DTH__K_LONG) {
        long y = (long)x;
        memcpy(p, &y, sizeof y);
    } else if (f->kind == DTH__K_U64) {
        unsigned long long y = (unsigned long long)(uint64_t)x;
        memcpy(p, &y, sizeof y);
    }
}

/* ---- tables ---- */

static int valid_name(const char *s)
{
    size_t n = s ? strlen(s) : 0;
    if (n == 0 || n > MAX_NAME) return 0;
    for (size_t i = 0; i < n; i++)
        if (!((s[i] >= 'a' && s[i] <= 'z') || (s[i] >= 'A' && s[i] <= 'Z') || (s[i] >= '0' && s[i] <= '9') ||
              s[i] == '_' || s[i] == '.'))
            return 0;
    return 1;
}

int dth__fields_valid(const dth_field *f, size_t nf, int reg, char *err, size_t errlen)
{
    if (nf && !f) {
        dth__set_err(err, errlen, "a field list of %zu entries is NULL", nf);
        return DTH_EINVAL;
    }
    if (nf > DTH__MAX_FIELDS) {
        dth__set_err(err, errlen, "a field list of %zu entries (at most %d)", nf, DTH__MAX_FIELDS);
        return DTH_EINVAL;
    }
    for (size_t i = 0; i < nf; i++) {
        const char *why = NULL;
        int k = f[i].kind;
        if (!valid_name(f[i].name)) why = "its name is empty, longer than 64 bytes or not [A-Za-z0-9_.]";
        else if (k < DTH_FIELD_F64 || k > (reg ? DTH_FIELD_LONG : DTH_FIELD_STR))
            why = reg ? "its kind is not F64, F64_PTR, INT or LONG" : "its kind is not a dth_field_kind";
        else if (f[i].check < DTH_CHECK_ANY || f[i].check > DTH_CHECK_COUNT) why = "its check is not a dth_field_check";
        else if (k != DTH_FIELD_F64 && k != DTH_FIELD_F64_PTR && f[i].count > 1) why = "only doubles have a count";
        else if (k == DTH_FIELD_F64 && f[i].count > ((size_t)1 << 20)) why = "its count is beyond 2^20";
        else if (k == DTH_FIELD_F64_PTR && !reg && f[i].count == 0) why = "a pointer field needs a count here";
        for (size_t j = 0; !why && j < i; j++)
            if (strcmp(f[i].name, f[j].name) == 0) why = "its name appears twice";
        if (why) {
            dth__set_err(err, errlen, "field %zu ('%s') of the list: %s", i, f[i].name ? f[i].name : "(null)", why);
            return DTH_EINVAL;
        }
    }
    return DTH_OK;
}

/* ---- records (public) ---- */

int dth_fields_encode(const dth_field *fields, size_t nfields, const void *base, void *buf, size_t cap,
                      size_t *len)
{
    if (len) *len = 0;
    if (!len || !base || dth__fields_valid(fields, nfields, 0, NULL, 0)) return DTH_EINVAL;
    for (size_t i = 0; i < nfields; i++)
        if (fields[i].kind == DTH__K_STR) {
            const char *s;
            memcpy(&s, (const char *)base + fields[i].offset, sizeof s);
            if (s && strlen(s) > DTH_FIELD_STR_MAX) return DTH_EINVAL;
        }
    dth__wr w = {NULL, 0, 0};
    for (int pass = 0; pass < 2; pass++) {
        w.len = 0;
        dth__put_u32(&w, (uint32_t)nfields);
        for (size_t i = 0; i < nfields; i++) dth__put_field(&w, &fields[i], base, 0);
        if (pass == 0) {
            *len = w.len;
            if (!buf || cap < w.len) return buf ? DTH_EINVAL : DTH_OK;
            w = (dth__wr){buf, cap, 0};
        }
    }
    return DTH_OK;
}

int dth_fields_decode(const dth_field *fields, size_t nfields, void *base, const void *buf, size_t len,
                      const dth_allocator *alloc, char *err, size_t errlen)
{
    if (!base || (len && !buf)) return DTH_EINVAL;
    if (dth__fields_valid(fields, nfields, 0, err, errlen)) return DTH_EINVAL;
    dth__rd r = {buf, len, 0, 0};
    size_t pos[DTH__MAX_FIELDS];
    uint32_t n = dth__get_u32(&r);
    if (r.bad || n != nfields) {
        dth__set_err(err, errlen, r.bad ? "record truncated" : "record of %u fields, this program reads %zu",
                     (unsigned)n, nfields);
        return DTH_EPARSE;
    }
    for (size_t i = 0; i < nfields; i++) {
        int rc = dth__get_field(&r, &fields[i], 0, &pos[i], err, errlen);
        if (rc) return rc;
    }
    if (r.pos != r.len) {
        dth__set_err(err, errlen, "record has %zu trailing bytes", r.len - r.pos);
        return DTH_EPARSE;
    }
    /* every value is valid: the strings first (they may fail), then everything into base */
    char *strs[DTH__MAX_FIELDS] = {0};
    for (size_t i = 0; i < nfields; i++) {
        if (fields[i].kind != DTH__K_STR) continue;
        dth__rd s = {r.p, r.len, pos[i] - 8, 0};
        size_t sl = (size_t)dth__get_u64(&s);
        strs[i] = dth_calloc(alloc, sl + 1, 1);
        if (!strs[i]) {
            for (size_t j = 0; j < i; j++) dth_free(alloc, strs[j]);
            dth__set_err(err, errlen, "out of memory reading field '%s'", fields[i].name);
            return DTH_ENOMEM;
        }
        if (sl) memcpy(strs[i], r.p + pos[i], sl);
    }
    for (size_t i = 0; i < nfields; i++) {
        if (fields[i].kind == DTH__K_STR) memcpy((char *)base + fields[i].offset, &strs[i], sizeof strs[i]);
        else dth__load_field(&r, pos[i], &fields[i], base, 0);
    }
    return DTH_OK;
}
