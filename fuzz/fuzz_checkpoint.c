/* SPDX-License-Identifier: MIT */
/*
 * libFuzzer target: what dth run --resume reads. The first input byte chooses: even, the input is a
 * whole checkpoint (dth_checkpoint_verify, dth_checkpoint_restore into a pendulum integrator with
 * and without a regularizer, and dth run's "cli" blob inside it); odd, the rest is a "cli" blob
 * by itself (cli_ckpt_decode: reached directly, past the checkpoint's checksum). Invariants:
 * nothing crashes or reads out of bounds; a refusal says why and leaves the integrator as it was;
 * an accepted blob has every field in range and its paths NUL-terminated and absolute.
 */
#include <math.h>
#include <string.h>
#include "dth/dth.h"
#include "ckpt.h"
#include "fuzz_common.h"

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size);

static void check_blob(const void *p, size_t n)
{
    cli_ckpt c;
    char err[512] = "";
    if (cli_ckpt_decode(p, n, &c, err, sizeof err) == 0) {
        const dth_run_state *S = &c.S;
        FUZZ_CHECK(S->k >= 0 && S->k0 >= 0 && S->k0 <= S->k && S->samples >= 0 && S->events >= 0 && S->j >= 0);
        FUZZ_CHECK(isfinite(S->t) && isfinite(S->t_stop) && isfinite(S->in.lambda) && S->in.iters >= 0);
        FUZZ_CHECK(S->in.flags <= 3 && (int)S->in.branch >= 0 && S->in.branch <= DTH_BRANCH_REG);
        const cli_ckpt_out *o[2] = {&c.out, &c.ev};
        for (int i = 0; i < 2; i++) {
            FUZZ_CHECK(strlen(o[i]->path) <= 4096 && strlen(o[i]->tmp) <= 4096);
            FUZZ_CHECK(!o[i]->path[0] || o[i]->path[0] == '/');
            FUZZ_CHECK(!o[i]->tmp[0] || o[i]->tmp[0] == '/');
        }
        FUZZ_CHECK(c.out.path[0]);
    } else {
        FUZZ_CHECK(err[0] != '\0');
    }
    cli_ckpt_clear(&c);
}

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
    if (size < 1) return 0;
    const uint8_t *p = data + 1;
    size_t n = size - 1;
    if (data[0] & 1) {
        check_blob(p, n);
        return 0;
    }
    char err[512] = "";
    int vr = dth_checkpoint_verify(p, n, err, sizeof err);
    FUZZ_CHECK(vr == DTH_OK || (vr == DTH_EPARSE && err[0]));
    dth_model *m = NULL;
    FUZZ_CHECK(dth_model_new(&dth_model_pendulum, NULL, 0, 1, NULL, &m, NULL, 0) == DTH_OK);
    dth_regularizer *reg = NULL;
    FUZZ_CHECK(dth_regularizer_new(&dth_reg_land, NULL, 0, m, NULL, &reg, NULL, 0) == DTH_OK);
    for (int with_reg = 0; with_reg < 2; with_reg++) {
        dth_options o;
        dth_options_default(&o);
        o.h = 0.05;
        o.regularizer = with_reg ? reg : NULL;
        dth_integrator *it = NULL;
        FUZZ_CHECK(dth_integrator_new(m, &o, &it) == DTH_OK);
        double q = 0.5, pp = 0.1;
        FUZZ_CHECK(dth_integrator_start(it, &q, &pp, 0) == DTH_OK);
        unsigned char before[4096], after[4096];
        size_t lb = 0, la = 0;
        FUZZ_CHECK(dth_checkpoint_save(it, NULL, 0, before, sizeof before, &lb) == DTH_OK);
        err[0] = '\0';
        int rc = dth_checkpoint_restore(it, p, n, err, sizeof err);
        if (rc == DTH_OK) {
            FUZZ_CHECK(vr == DTH_OK);
            const double *z = dth_integrator_vertex(it);
            for (int j = 0; j < 4; j++) FUZZ_CHECK(isfinite(z[j]));
            dth_integrator_step(it, NULL); /* a restored state steps without crashing */
        } else {
            FUZZ_CHECK(err[0] != '\0');
            FUZZ_CHECK(dth_checkpoint_save(it, NULL, 0, after, sizeof after, &la) == DTH_OK);
            FUZZ_CHECK(la == lb && memcmp(before, after, lb) == 0);
        }
        dth_integrator_free(it);
    }
    if (vr == DTH_OK) {
        const void *blob;
        size_t bl;
        if (dth_checkpoint_blob(p, n, "cli", &blob, &bl) == DTH_OK) check_blob(blob, bl);
    }
    dth_regularizer_free(reg);
    dth_model_free(m);
    return 0;
}
