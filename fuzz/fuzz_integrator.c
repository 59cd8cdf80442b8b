/* SPDX-License-Identifier: MIT */
/*
 * libFuzzer target: arbitrary numbers (NaN, Inf, huge, denormal: raw IEEE-754 bit patterns from
 * the input) as model parameters, options and initial conditions, then a few DTH steps (paper,
 * Theorem "DTH Equations"). Invariants: nothing crashes; a call that returns DTH_OK leaves a
 * finite state; a failed step leaves the vertex and the step count bit for bit unchanged.
 */
#include <math.h>
#include <string.h>
#include "dth/dth.h"
#include "fuzz_common.h"

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size);

typedef struct src {
    const uint8_t *p;
    size_t n, pos;
} src;

static unsigned byte(src *s) { return s->pos < s->n ? s->p[s->pos++] : 0u; }

static double num(src *s)
{
    if (s->pos + 8 > s->n) {
        s->pos = s->n;
        return 0.5;
    }
    double x;
    memcpy(&x, s->p + s->pos, 8);
    s->pos += 8;
    return x;
}

static int all_finite(const double *x, size_t n)
{
    for (size_t i = 0; i < n; i++)
        if (!isfinite(x[i])) return 0;
    return 1;
}

enum { MAXN = 16, MAXD = 2 * MAXN + 2 };

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
    src s = {data, size, 0};
    unsigned which = byte(&s) % 4, flags = byte(&s), max_iter = 1 + byte(&s) % 40, nsteps = 1 + byte(&s) % 8;
    /* parameters as text: %.17g of raw doubles gives "nan", "inf", "1e+308", "4.9e-324"... */
    char v[4][64];
    for (int i = 0; i < 4; i++) snprintf(v[i], sizeof v[i], "%.17g", num(&s));
    char size_txt[8], dim_txt[8], n_txt[8];
    snprintf(size_txt, sizeof size_txt, "%u", 2 + (flags >> 4) % 3);
    snprintf(dim_txt, sizeof dim_txt, "%u", 1 + (flags >> 2) % 3);
    snprintf(n_txt, sizeof n_txt, "%u", 1 + (flags >> 4) % 3);
    const dth_model_type *type;
    dth_kv kv[6];
    size_t nkv = 0, n_hint = 0;
    switch (which) {
    case 0:
        type = &dth_model_pendulum;
        kv[nkv++] = (dth_kv){"omega2", v[0]};
        break;
    case 1:
        type = &dth_model_harmonic;
        kv[nkv++] = (dth_kv){"n", n_txt};
        kv[nkv++] = (dth_kv){"mass", v[0]};
        kv[nkv++] = (dth_kv){"omega", v[1]};
        break;
    case 2:
        type = &dth_model_kepler;
        kv[nkv++] = (dth_kv){"mu", v[0]};
        kv[nkv++] = (dth_kv){"dim", (flags & 4) ? "3" : "2"};
        break;
    default:
        type = &dth_model_coupled;
        kv[nkv++] = (dth_kv){"preset", (flags & 64) ? "ring" : "chain"};
        kv[nkv++] = (dth_kv){"size", size_txt};
        kv[nkv++] = (dth_kv){"dim", dim_txt};
        kv[nkv++] = (dth_kv){"k", v[0]};
        kv[nkv++] = (dth_kv){"L", v[1]};
        kv[nkv++] = (dth_kv){"mass", v[2]};
        break;
    }
    dth_model *m = NULL;
    char err[256];
    int rc = dth_model_new(type, kv, nkv, n_hint, NULL, &m, err, sizeof err);
    FUZZ_CHECK(rc == DTH_OK || rc == DTH_EINVAL);
    if (rc) return 0;
    size_t n = dth_model_dof(m), N = 2 * n + 2;
    if (n > MAXN) {
        dth_model_free(m);
        return 0;
    }
    dth_options o;
    dth_options_default(&o);
    o.h = num(&s);
    o.K = num(&s);
    o.start = (flags & 1) ? DTH_START_VERTEX : DTH_START_MIDPOINT;
    o.has_wp = (flags & 2) != 0;
    o.wp = num(&s);
    o.max_iter = (int)max_iter;
    dth_integrator *it = NULL;
    rc = dth_integrator_new(m, &o, &it);
    FUZZ_CHECK(rc == DTH_OK || rc == DTH_EINVAL);
    if (!isfinite(o.h) || o.h == 0 || !isfinite(o.K) || (o.has_wp && !isfinite(o.wp))) FUZZ_CHECK(rc == DTH_EINVAL);
    if (rc) {
        dth_model_free(m);
        return 0;
    }
    double q0[MAXN], p0[MAXN], t0 = num(&s);
    for (size_t i = 0; i < n; i++) {
        q0[i] = num(&s);
        p0[i] = num(&s);
    }
    rc = dth_integrator_start(it, q0, p0, t0);
    if (!all_finite(q0, n) || !all_finite(p0, n) || !isfinite(t0)) FUZZ_CHECK(rc != DTH_OK);
    if (rc == DTH_OK) {
        FUZZ_CHECK(all_finite(dth_integrator_vertex(it), N));
        double before[MAXD];
        for (unsigned k = 0; k < nsteps; k++) {
            long steps = dth_integrator_steps(it);
            memcpy(before, dth_integrator_vertex(it), N * sizeof *before);
            dth_step_info info;
            rc = dth_integrator_step(it, &info);
            if (rc == DTH_OK) {
                FUZZ_CHECK(all_finite(dth_integrator_vertex(it), N));
                FUZZ_CHECK(dth_integrator_midpoint(it) && all_finite(dth_integrator_midpoint(it), N));
                FUZZ_CHECK(isfinite(info.lambda) && info.lambda != 0);
                FUZZ_CHECK(dth_integrator_steps(it) == steps + 1);
            } else {
                FUZZ_CHECK(memcmp(before, dth_integrator_vertex(it), N * sizeof *before) == 0);
                FUZZ_CHECK(dth_integrator_steps(it) == steps);
                FUZZ_CHECK(strcmp(dth_status_name(rc), "DTH_UNKNOWN") != 0);
                break;
            }
        }
    }
    dth_integrator_free(it);
    dth_model_free(m);
    return 0;
}
