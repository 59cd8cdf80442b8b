/* SPDX-License-Identifier: MIT */
/* Allocation through an optional caller-supplied allocator (so failure paths can be tested). */
#include <stdint.h>
#include <stdlib.h>
#include <string.h>
#include "dth/model.h"

void *dth_calloc(const dth_allocator *a, size_t n, size_t size)
{
    if (size != 0 && n > SIZE_MAX / size) return NULL;
    size_t bytes = n * size;
    if (bytes == 0) bytes = 1;
    if (!a || !a->alloc) return calloc(1, bytes);
    void *p = a->alloc(a->ctx, bytes);
    if (p) memset(p, 0, bytes);
    return p;
}

void dth_free(const dth_allocator *a, void *ptr)
{
    if (!ptr) return;
    if (!a || !a->alloc) free(ptr);
    else if (a->free) a->free(a->ctx, ptr);
}
