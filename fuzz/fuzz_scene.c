/* SPDX-License-Identifier: MIT */
/*
 * libFuzzer target: scene files. Arbitrary bytes go through dth_scene_load_mem and, when they parse,
 * dth_scene_setup (validation into a run setup). Must never crash; a failure must leave the
 * scene unchanged and give a message; a success must give a consistent setup, and the scene written
 * as text must load back to the same entries.
 */
#include <math.h>
#include <string.h>
#include "dth/dth.h"
#include "fuzz_common.h"

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size);

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
    char err[512];
    dth_scene *s = NULL;
    dth_registry *reg = NULL;
    FUZZ_CHECK(dth_scene_new(NULL, &s) == DTH_OK);
    FUZZ_CHECK(dth_registry_new(NULL, &reg) == DTH_OK);
    FUZZ_CHECK(dth_registry_add_builtin(reg) == DTH_OK);
    err[0] = '\0';
    int rc = dth_scene_load_mem(s, "fuzz.ini", (const char *)data, size, err, sizeof err);
    FUZZ_CHECK(rc == DTH_OK || rc == DTH_EPARSE || rc == DTH_EIO);
    if (rc != DTH_OK) {
        FUZZ_CHECK(err[0] != '\0');
        FUZZ_CHECK(dth_scene_count(s) == 0); /* a failed load leaves the scene unchanged */
    } else {
        fuzz_check_round_trip(s);
        dth_run_setup rs;
        memset(&rs, 0, sizeof rs);
        err[0] = '\0';
        rc = dth_scene_setup(s, reg, &rs, err, sizeof err);
        if (rc == DTH_OK) {
            FUZZ_CHECK(rs.model && rs.n >= 1 && rs.q0 && rs.p0);
            FUZZ_CHECK(dth_model_dof(rs.model) == rs.n);
            FUZZ_CHECK(isfinite(rs.opt.h) && rs.opt.h != 0 && isfinite(rs.t0));
            for (size_t i = 0; i < rs.n; i++) FUZZ_CHECK(isfinite(rs.q0[i]) && isfinite(rs.p0[i]));
            FUZZ_CHECK(rs.every >= 1);
        } else {
            FUZZ_CHECK(err[0] != '\0');
        }
        dth_run_setup_clear(&rs);
    }
    dth_scene_free(s);
    dth_registry_free(reg);
    return 0;
}
