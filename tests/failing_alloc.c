/* SPDX-License-Identifier: MIT */
/* A dth_allocator for tests that fails on the k-th allocation and counts live blocks (leak check). */
#include <stdlib.h>
#include "failing_alloc.h"

static void *fa_alloc(void *ctx, size_t size)
{
    failing_alloc *fa = ctx;
    fa->count++;
    if (fa->fail_at > 0 && fa->count == fa->fail_at) {
        fa->failed++;
        return NULL;
    }
    void *p = malloc(size);
    if (p) fa->live++;
    return p;
}

static void fa_free(void *ctx, void *ptr)
{
    failing_alloc *fa = ctx;
    if (!ptr) return;
    fa->live--;
    free(ptr);
}

dth_allocator failing_alloc_make(failing_alloc *fa, long fail_at)
{
    fa->fail_at = fail_at;
    fa->count = 0;
    fa->live = 0;
    fa->failed = 0;
    return (dth_allocator){.alloc = fa_alloc, .free = fa_free, .ctx = fa};
}
