/* SPDX-License-Identifier: MIT */
/* Shared helper of the libFuzzer targets: a hard-failure macro. */
#ifndef DTH_FUZZ_COMMON_H
#define DTH_FUZZ_COMMON_H

#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include "dth/dth.h"

/* An invariant broken: report it and crash so libFuzzer saves the input. */
#define FUZZ_CHECK(cond)                                                                   \
    do {                                                                                   \
        if (!(cond)) {                                                                     \
            fprintf(stderr, "fuzz invariant failed: %s (%s:%d)\n", #cond, __FILE__, __LINE__); \
            abort();                                                                       \
        }                                                                                  \
    } while (0)

/* The scene written as text (dth_scene_text) loads back to the same entries. */
static inline void fuzz_check_round_trip(const dth_scene *s)
{
    char *text = NULL, err[512];
    size_t len = 0;
    FUZZ_CHECK(dth_scene_text(s, NULL, NULL, &text, &len) == DTH_OK);
    dth_scene *b = NULL;
    FUZZ_CHECK(dth_scene_new(NULL, &b) == DTH_OK);
    FUZZ_CHECK(dth_scene_load_mem(b, "saved.ini", text, len, err, sizeof err) == DTH_OK);
    FUZZ_CHECK(dth_scene_count(b) == dth_scene_count(s));
    for (size_t i = 0; i < dth_scene_count(s); i++) {
        const char *sec, *key, *val;
        dth_scene_entry(s, i, &sec, &key, &val, NULL);
        const char *v2 = dth_scene_get(b, sec, key);
        FUZZ_CHECK(v2 && strcmp(v2, val) == 0);
    }
    dth_scene_free(b);
    dth_free(NULL, text);
}

#endif
