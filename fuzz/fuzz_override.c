/* SPDX-License-Identifier: MIT */
/*
 * libFuzzer target: "-s section.key=value" overrides. The input is split at newlines into
 * overrides applied with dth_scene_set on top of a valid pendulum scene, then validated with
 * dth_scene_setup. Must never crash; a refused override leaves the scene unchanged; what is accepted
 * can be written as scene text that loads back to the same entries.
 */
#include <math.h>
#include <string.h>
#include "dth/dth.h"
#include "fuzz_common.h"

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size);

static const char base[] = "[model]\nname = pendulum\n[initial]\nq = 1\np = 0\n"
                           "[integrator]\nh = 0.05\nsteps = 10\n";

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
    char err[512];
    if (size > 4096) return 0;
    dth_scene *s = NULL;
    dth_registry *reg = NULL;
    FUZZ_CHECK(dth_scene_new(NULL, &s) == DTH_OK);
    FUZZ_CHECK(dth_registry_new(NULL, &reg) == DTH_OK);
    FUZZ_CHECK(dth_registry_add_builtin(reg) == DTH_OK);
    FUZZ_CHECK(dth_scene_load_mem(s, "base.ini", base, sizeof base - 1, err, sizeof err) == DTH_OK);
    char *buf = malloc(size + 1);
    FUZZ_CHECK(buf != NULL);
    memcpy(buf, data, size);
    buf[size] = '\0';
    for (char *line = buf, *next; line; line = next) {
        next = strchr(line, '\n');
        if (next) *next++ = '\0';
        size_t before = dth_scene_count(s);
        err[0] = '\0';
        int rc = dth_scene_set(s, line, err, sizeof err);
        FUZZ_CHECK(rc == DTH_OK || rc == DTH_EPARSE);
        if (rc != DTH_OK) {
            FUZZ_CHECK(err[0] != '\0');
            FUZZ_CHECK(dth_scene_count(s) == before);
        }
    }
    free(buf);
    fuzz_check_round_trip(s);
    dth_run_setup rs;
    memset(&rs, 0, sizeof rs);
    err[0] = '\0';
    int rc = dth_scene_setup(s, reg, &rs, err, sizeof err);
    if (rc == DTH_OK) {
        FUZZ_CHECK(rs.model && rs.n >= 1 && isfinite(rs.opt.h) && rs.opt.h != 0);
        for (size_t i = 0; i < rs.n; i++) FUZZ_CHECK(isfinite(rs.q0[i]) && isfinite(rs.p0[i]));
    } else {
        FUZZ_CHECK(err[0] != '\0');
    }
    dth_run_setup_clear(&rs);
    dth_scene_free(s);
    dth_registry_free(reg);
    return 0;
}
