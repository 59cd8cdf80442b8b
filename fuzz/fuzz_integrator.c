/* SPDX-License-Identifier: MIT */
/*
 * libFuzzer target: arbitrary numbers (NaN, Inf, huge, denormal: raw IEEE-754 bit patterns from
 * the input) as model parameters, options and initial conditions, then a few DTH steps (paper,
 * Theorem "DTH Equations") with a regularizer attached (none, land or prescribed: the byte after
 * the initial conditions), then a few more through the run driver dth_run (the next byte: how many,
 * which samples), whose checkpoint callback saves the integrator and the run state and restores
 * them into a second integrator. Invariants: nothing crashes; a call that returns DTH_OK leaves a
 * finite state; a failed step leaves the vertex and the step count bit for bit unchanged; every
 * state the library reaches restores (the checkpoint's checks are what the integrator accepts: any
 * finite step or time, a norm that overflowed) and saves back to the same bytes.
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

/* The model `which` with the input's parameters (NULL if they are refused). */
static dth_model *make_model(src *s, unsigned which, unsigned flags)
{
    /* parameters as text: %.17g of raw doubles gives "nan", "inf", "1e+308", "4.9e-324"... */
    char v[4][64];
    for (int i = 0; i < 4; i++) snprintf(v[i], sizeof v[i], "%.17g", num(s));
    char size_txt[8], dim_txt[8], n_txt[8];
    snprintf(size_txt, sizeof size_txt, "%u", 2 + (flags >> 4) % 3);
    snprintf(dim_txt, sizeof dim_txt, "%u", 1 + (flags >> 2) % 3);
    snprintf(n_txt, sizeof n_txt, "%u", 1 + (flags >> 4) % 3);
    const dth_model_type *type;
    dth_kv kv[6];
    size_t nkv = 0;
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
    int rc = dth_model_new(type, kv, nkv, 0, NULL, &m, err, sizeof err);
    FUZZ_CHECK(rc == DTH_OK || rc == DTH_EINVAL);
    if (!rc && dth_model_dof(m) > MAXN) {
        dth_model_free(m);
        return NULL;
    }
    return rc ? NULL : m;
}

/* A few steps by hand: a failed one leaves the state as it was. */
static void steps_by_hand(dth_integrator *it, size_t N, unsigned nsteps)
{
    double before[MAXD];
    for (unsigned k = 0; k < nsteps; k++) {
        long steps = dth_integrator_steps(it);
        memcpy(before, dth_integrator_vertex(it), N * sizeof *before);
        dth_step_info info;
        int rc = dth_integrator_step(it, &info);
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

/* The run driver's checkpoints: each saved with the run state and restored into a second
 * integrator with its own regularizer, which must save back to the same bytes. */
typedef struct shadow {
    dth_integrator *it, *copy;
    long samples;
    unsigned char buf[16384], back[16384];
} shadow;

/* Samples are counted; output times far denser than the steps stop the run. */
static int on_sample(void *user, const dth_sample *s)
{
    shadow *sh = user;
    (void)s;
    return ++sh->samples > 2000;
}

static int on_checkpoint(void *user, const dth_run_state *st)
{
    shadow *sh = user;
    size_t len = 0, len2 = 0;
    if (dth_checkpoint_save_run(sh->it, st, NULL, 0, sh->buf, sizeof sh->buf, &len) != DTH_OK) return 0; /* too large */
    char err[512] = "";
    dth_run_state got;
    int rc = dth_checkpoint_restore_run(sh->copy, &got, sh->buf, len, err, sizeof err);
    if (rc != DTH_OK) { /* the checks are what the library accepts: a state it reached restores */
        fprintf(stderr, "a state the library reached is refused: %s\n", err);
        FUZZ_CHECK(rc == DTH_OK);
    }
    FUZZ_CHECK(memcmp(&got, st, sizeof got) == 0);
    FUZZ_CHECK(dth_checkpoint_save_run(sh->copy, &got, NULL, 0, sh->back, sizeof sh->back, &len2) == DTH_OK);
    FUZZ_CHECK(len2 == len && memcmp(sh->buf, sh->back, len) == 0);
    return 0;
}

/* A few steps through dth_run: `drive` says how many and which samples. */
static void drive_run(dth_integrator *it, dth_integrator *copy, double h, unsigned drive)
{
    static shadow sh;
    sh.it = it;
    sh.copy = copy;
    sh.samples = 0;
    dth_run_config c;
    dth_run_config_default(&c);
    c.steps = dth_integrator_steps(it) + 1 + (long)(drive % 4);
    c.points = (dth_points)((drive >> 2) % 3);
    if (c.points == DTH_POINTS_MIDPOINTS && !dth_integrator_midpoint(it) && dth_integrator_steps(it) > 0)
        c.points = DTH_POINTS_VERTICES; /* a baseline */
    c.dt = fabs(h) * 0.37;
    if (!(c.dt > 0) || !isfinite(c.dt) || c.dt < 1e-300) c.points = DTH_POINTS_VERTICES;
    c.sample = on_sample;
    c.checkpoint = on_checkpoint;
    c.checkpoint_every = 1;
    c.user = &sh;
    dth_run_state st;
    dth_run_state_init(&st);
    int rc = dth_run(it, &c, &st);
    FUZZ_CHECK(strcmp(dth_status_name(rc), "DTH_UNKNOWN") != 0);
}

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
    src s = {data, size, 0};
    unsigned which = byte(&s) % 4, flags = byte(&s), max_iter = 1 + byte(&s) % 40, nsteps = 1 + byte(&s) % 8;
    dth_model *m = make_model(&s, which, flags);
    if (!m) return 0;
    size_t n = dth_model_dof(m), N = 2 * n + 2;
    dth_options o;
    dth_options_default(&o);
    o.h = num(&s);
    o.K = num(&s);
    o.start = (flags & 1) ? DTH_START_VERTEX : DTH_START_MIDPOINT;
    o.has_wp = (flags & 2) != 0;
    o.wp = num(&s);
    o.max_iter = (int)max_iter;
    double q0[MAXN], p0[MAXN], t0 = num(&s);
    for (size_t i = 0; i < n; i++) {
        q0[i] = num(&s);
        p0[i] = num(&s);
    }
    /* the regularizer (and a second instance for the restored copy), the driver's steps */
    static const dth_regularizer_type *const regs[3] = {NULL, &dth_reg_land, &dth_reg_prescribed};
    const dth_regularizer_type *rt = regs[byte(&s) % 3];
    unsigned drive = byte(&s);
    dth_regularizer *reg = NULL, *reg2 = NULL;
    if (rt && (dth_regularizer_new(rt, NULL, 0, m, NULL, &reg, NULL, 0) != DTH_OK ||
               dth_regularizer_new(rt, NULL, 0, m, NULL, &reg2, NULL, 0) != DTH_OK))
        FUZZ_CHECK(0);
    o.regularizer = reg;
    dth_integrator *it = NULL, *copy = NULL;
    int rc = dth_integrator_new(m, &o, &it);
    if (!rc) {
        o.regularizer = reg2;
        FUZZ_CHECK(dth_integrator_new(m, &o, &copy) == DTH_OK);
    }
    FUZZ_CHECK(rc == DTH_OK || rc == DTH_EINVAL);
    if (!isfinite(o.h) || o.h == 0 || !isfinite(o.K) || (o.has_wp && !isfinite(o.wp))) FUZZ_CHECK(rc == DTH_EINVAL);
    if (!rc) {
        rc = dth_integrator_start(it, q0, p0, t0);
        if (!all_finite(q0, n) || !all_finite(p0, n) || !isfinite(t0)) FUZZ_CHECK(rc != DTH_OK);
        if (rc == DTH_OK) {
            FUZZ_CHECK(all_finite(dth_integrator_vertex(it), N));
            steps_by_hand(it, N, nsteps);
            drive_run(it, copy, o.h, drive);
        }
    }
    dth_integrator_free(it);
    dth_integrator_free(copy);
    dth_regularizer_free(reg);
    dth_regularizer_free(reg2);
    dth_model_free(m);
    return 0;
}
