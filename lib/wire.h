/* SPDX-License-Identifier: MIT */
/*
 * Little-endian bytes by construction: the writer and reader of the checkpoint and field codecs
 * (checkpoint.c, fields.c). Every number is assembled from shifts, never copied from memory, so
 * the bytes do not depend on the host's byte order.
 */
#ifndef DTH_WIRE_H
#define DTH_WIRE_H

#include <stddef.h>
#include <stdint.h>
#include <string.h>

/* A writer: counts only when buf is NULL or full (a first pass sizes the buffer). */
typedef struct dth__wr {
    unsigned char *buf;
    size_t cap, len;
} dth__wr;

static inline void dth__put_bytes(dth__wr *w, const void *p, size_t n)
{
    if (w->buf && n && w->len + n <= w->cap) memcpy(w->buf + w->len, p, n);
    w->len += n;
}

static inline void dth__put_u64(dth__wr *w, uint64_t v)
{
    unsigned char b[8];
    for (int i = 0; i < 8; i++) b[i] = (unsigned char)(v >> (8 * i));
    dth__put_bytes(w, b, 8);
}

static inline void dth__put_u32(dth__wr *w, uint32_t v)
{
    unsigned char b[4];
    for (int i = 0; i < 4; i++) b[i] = (unsigned char)(v >> (8 * i));
    dth__put_bytes(w, b, 4);
}

static inline void dth__put_f64(dth__wr *w, double x)
{
    uint64_t v;
    memcpy(&v, &x, sizeof v); /* the IEEE-754 bit pattern as a number: its bytes follow from put_u64 */
    dth__put_u64(w, v);
}

/* A string: u32 length, the bytes (no NUL). */
static inline void dth__put_str(dth__wr *w, const char *s)
{
    size_t n = strlen(s);
    dth__put_u32(w, (uint32_t)n);
    dth__put_bytes(w, s, n);
}

/* A reader: every get fails (and stays failed) past the end. */
typedef struct dth__rd {
    const unsigned char *p;
    size_t len, pos;
    int bad;
} dth__rd;

static inline const unsigned char *dth__get_bytes(dth__rd *r, size_t n)
{
    if (r->bad || n > r->len - r->pos) {
        r->bad = 1;
        return NULL;
    }
    const unsigned char *p = r->p + r->pos;
    r->pos += n;
    return p;
}

static inline uint64_t dth__get_u64(dth__rd *r)
{
    const unsigned char *b = dth__get_bytes(r, 8);
    uint64_t v = 0;
    if (b)
        for (int i = 7; i >= 0; i--) v = (v << 8) | b[i];
    return v;
}

static inline uint32_t dth__get_u32(dth__rd *r)
{
    const unsigned char *b = dth__get_bytes(r, 4);
    uint32_t v = 0;
    if (b)
        for (int i = 3; i >= 0; i--) v = (v << 8) | b[i];
    return v;
}

static inline double dth__get_f64(dth__rd *r)
{
    uint64_t v = dth__get_u64(r);
    double x;
    memcpy(&x, &v, sizeof x);
    return x;
}

/* A string of at most `max` bytes: pointer into the buffer and length (not NUL-terminated). */
static inline const char *dth__get_str(dth__rd *r, size_t max, size_t *n)
{
    uint32_t l = dth__get_u32(r);
    if (l > max) r->bad = 1;
    *n = l;
    return (const char *)dth__get_bytes(r, l);
}

#endif
