/* SPDX-License-Identifier: MIT */
/* A dth_allocator for tests that fails on the k-th allocation and counts live blocks (leak check). */
#ifndef DTH_FAILING_ALLOC_H
#define DTH_FAILING_ALLOC_H

#include <stddef.h>
#include "dth/model.h"

/** State of a failing allocator. Zero-initialize, then set fail_at. */
typedef struct failing_alloc {
    long fail_at; /**< 1-based index of the allocation that fails; 0: never fail */
    long count;   /**< allocations attempted so far (including the failed one) */
    long live;    /**< blocks allocated and not yet freed */
    long failed;  /**< allocations refused */
} failing_alloc;

/** A dth_allocator bound to `fa` (reset its counters, keep fail_at). */
dth_allocator failing_alloc_make(failing_alloc *fa, long fail_at);

#endif
