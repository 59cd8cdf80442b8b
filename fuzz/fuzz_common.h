/* SPDX-License-Identifier: MIT */
/* Shared helpers of the libFuzzer targets: a per-process scratch file and a hard-failure macro. */
#ifndef DTH_FUZZ_COMMON_H
#define DTH_FUZZ_COMMON_H

#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <unistd.h>

/* An invariant broken: report it and crash so libFuzzer saves the input. */
#define FUZZ_CHECK(cond)                                                                   \
    do {                                                                                   \
        if (!(cond)) {                                                                     \
            fprintf(stderr, "fuzz invariant failed: %s (%s:%d)\n", #cond, __FILE__, __LINE__); \
            abort();                                                                       \
        }                                                                                  \
    } while (0)

/* Write data to this process's scratch file (dth_scene_load reads files only); its path. */
static inline const char *fuzz_scratch(const uint8_t *data, size_t size, char *path, size_t len)
{
    const char *dir = getenv("TMPDIR");
    snprintf(path, len, "%s/dth-fuzz-%ld.ini", dir && dir[0] ? dir : "/tmp", (long)getpid());
    FILE *f = fopen(path, "wb");
    if (!f) return NULL;
    if (size && fwrite(data, 1, size, f) != size) {
        fclose(f);
        return NULL;
    }
    return fclose(f) == 0 ? path : NULL;
}

#endif
