/* SPDX-License-Identifier: MIT */
/*
 * A checkpoint walked by its documented layout (docs/checkpoint.md), independently of the library:
 * every section and field visited, a field's values found by section and name, a value patched
 * and the FNV-1a 64 checksum recomputed (crafted checkpoints that pass the checksum).
 */
#ifndef DTH_TEST_CKPT_WALK_H
#define DTH_TEST_CKPT_WALK_H

#include <stdint.h>
#include <string.h>

static inline uint64_t walk_le(const unsigned char *p, int n)
{
    uint64_t v = 0;
    for (int i = n - 1; i >= 0; i--) v = (v << 8) | p[i];
    return v;
}

static inline void walk_put_le(unsigned char *p, uint64_t v, int n)
{
    for (int i = 0; i < n; i++) p[i] = (unsigned char)(v >> (8 * i));
}

/* One field seen by the walk: its section, name (not NUL-terminated), type, count, values' offset. */
typedef struct walk_field {
    const char *sec, *name;
    size_t sec_len, name_len;
    uint64_t veclen;
    uint32_t type;
    uint64_t count;
    size_t values;
} walk_field;

typedef void (*walk_fn)(void *ctx, const walk_field *f);

/* One section at *pos: its fields to fn; 0, or -1 if it runs past len. */
static inline int walk_section(const unsigned char *b, size_t len, size_t *pos, walk_fn fn, void *ctx)
{
    size_t p = *pos;
    if (p + 4 > len) return -1;
    walk_field f = {0};
    f.sec_len = (size_t)walk_le(b + p, 4);
    f.sec = (const char *)b + p + 4;
    p += 4 + f.sec_len;
    if (p + 12 > len) return -1;
    f.veclen = walk_le(b + p, 8);
    uint64_t nf = walk_le(b + p + 8, 4);
    p += 12;
    for (uint64_t i = 0; i < nf; i++) {
        if (p + 4 > len) return -1;
        f.name_len = (size_t)walk_le(b + p, 4);
        f.name = (const char *)b + p + 4;
        p += 4 + f.name_len;
        if (p + 12 > len) return -1;
        f.type = (uint32_t)walk_le(b + p, 4);
        f.count = walk_le(b + p + 4, 8);
        p += 12;
        f.values = p;
        p += (size_t)(f.type == 3 ? f.count : 8 * f.count);
        if (p > len) return -1;
        if (fn) fn(ctx, &f);
    }
    *pos = p;
    return 0;
}

/* The whole state part: header, method, model, n, the sections, the regularizer's name and section,
 * the run flag and section. Returns the offset of the blob count, 0 if the walk fails. */
static inline size_t walk_state(const unsigned char *b, size_t len, walk_fn fn, void *ctx)
{
    size_t pos = 24;
    for (int s = 0; s < 2; s++) { /* method, model */
        if (pos + 4 > len) return 0;
        pos += 4 + (size_t)walk_le(b + pos, 4);
    }
    pos += 8; /* n */
    if (pos + 4 > len) return 0;
    uint64_t nsec = walk_le(b + pos, 4);
    pos += 4;
    for (uint64_t i = 0; i < nsec; i++)
        if (walk_section(b, len, &pos, fn, ctx)) return 0;
    if (pos + 4 > len) return 0;
    pos += 4 + (size_t)walk_le(b + pos, 4); /* the regularizer's name */
    if (walk_section(b, len, &pos, fn, ctx) || pos + 4 > len) return 0;
    uint64_t has_run = walk_le(b + pos, 4);
    pos += 4;
    if (has_run && walk_section(b, len, &pos, fn, ctx)) return 0;
    return pos;
}

typedef struct walk_find {
    const char *sec, *name;
    walk_field hit;
    int found;
} walk_find;

static inline void walk_find_fn(void *ctx, const walk_field *f)
{
    walk_find *w = ctx;
    if (!w->found && f->sec_len == strlen(w->sec) && !memcmp(f->sec, w->sec, f->sec_len) &&
        f->name_len == strlen(w->name) && !memcmp(f->name, w->name, f->name_len)) {
        w->hit = *f;
        w->found = 1;
    }
}

/* The field `name` of section `sec`: 1 and *f, or 0. */
static inline int walk_find_field(const unsigned char *b, size_t len, const char *sec, const char *name, walk_field *f)
{
    walk_find w = {sec, name, {0}, 0};
    walk_state(b, len, walk_find_fn, &w);
    if (w.found) *f = w.hit;
    return w.found;
}

/* FNV-1a 64, written out again here so tests can forge well-checksummed content. */
static inline uint64_t walk_fnv(const unsigned char *p, size_t n)
{
    uint64_t h = 14695981039346656037ULL;
    for (size_t i = 0; i < n; i++) h = (h ^ p[i]) * 1099511628211ULL;
    return h;
}

static inline void walk_reseal(unsigned char *b, size_t len) { walk_put_le(b + len - 8, walk_fnv(b, len - 8), 8); }

#endif
