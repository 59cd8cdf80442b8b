/* SPDX-License-Identifier: MIT */
/* Shared helper of the libFuzzer targets: a hard-failure macro. */
#ifndef DTH_FUZZ_COMMON_H
#define DTH_FUZZ_COMMON_H

#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>

/* An invariant broken: report it and crash so libFuzzer saves the input. */
#define FUZZ_CHECK(cond)                                                                   \
    do {                                                                                   \
        if (!(cond)) {                                                                     \
            fprintf(stderr, "fuzz invariant failed: %s (%s:%d)\n", #cond, __FILE__, __LINE__); \
            abort();                                                                       \
        }                                                                                  \
    } while (0)

#endif
