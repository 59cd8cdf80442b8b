/* SPDX-License-Identifier: MIT */
/*
 * Checkpoints that pass the checksum but not reason (issue 24): every crafted value in the table
 * below, patched by section and field name with the FNV-1a recomputed, is refused naming its field
 * and leaves the integrator and the run state untouched; the byte order (a big-endian writer's
 * checkpoint is refused by name); steps and times as the integrator accepts them; a start reversed
 * before its first step; the run driver's state saved and restored by the library; a land run
 * resumed at its crossings bit for bit, its error estimate with it; the run state's field list
 * covers dth_run_state; regularizer tables of the old layout and bad field lists are refused; the
 * public field codec.
 */
#include <math.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include "cu_main.h"
#include "ckpt_walk.h"
#include "dth/dth.h"
#include "failing_alloc.h"
#include "run_fields.h"

/* ---- a run to checkpoint: the pendulum through dth_run, its samples kept ---- */

typedef struct runner {
    dth_model *m;
    dth_regularizer *reg;
    dth_integrator *it;
    dth_run_state st;
    double t[400], q[400];
    long n;
} runner;

static int keep_sample(void *user, const dth_sample *s)
{
    runner *r = user;
    if (r->n < 400) {
        r->t[r->n] = s->z[1];
        r->q[r->n] = s->z[0];
        r->n++;
    }
    return 0;
}

/* A fresh integrator of method `method` (NULL: dth) with regularizer `rt` (NULL: none), started. */
static void runner_new(runner *r, const char *method, const dth_regularizer_type *rt, double p0)
{
    memset(r, 0, sizeof *r);
    CU_ASSERT_FATAL(dth_model_new(&dth_model_pendulum, NULL, 0, 1, NULL, &r->m, NULL, 0) == DTH_OK);
    if (rt) CU_ASSERT_FATAL(dth_regularizer_new(rt, NULL, 0, r->m, NULL, &r->reg, NULL, 0) == DTH_OK);
    dth_options o;
    dth_options_default(&o);
    o.h = 0.05;
    o.method = method;
    o.regularizer = r->reg;
    CU_ASSERT_FATAL(dth_integrator_new(r->m, &o, &r->it) == DTH_OK);
    double q = 1.0;
    CU_ASSERT_FATAL(dth_integrator_start(r->it, &q, &p0, 0) == DTH_OK);
    dth_run_state_init(&r->st);
}

static void runner_run(runner *r, long steps)
{
    dth_run_config c;
    dth_run_config_default(&c);
    c.steps = steps;
    c.sample = keep_sample;
    c.user = r;
    CU_ASSERT_FATAL(dth_run(r->it, &c, &r->st) == DTH_OK);
}

static void runner_free(runner *r)
{
    dth_integrator_free(r->it);
    dth_regularizer_free(r->reg);
    dth_model_free(r->m);
}

static unsigned char *save_run(const dth_integrator *it, const dth_run_state *st, size_t *len)
{
    CU_ASSERT_FATAL(dth_checkpoint_save_run(it, st, NULL, 0, NULL, 0, len) == DTH_OK);
    unsigned char *b = malloc(*len);
    CU_ASSERT_FATAL(b != NULL);
    CU_ASSERT_FATAL(dth_checkpoint_save_run(it, st, NULL, 0, b, *len, len) == DTH_OK);
    return b;
}

/* ---- the crafted values ---- */

enum op { SET_I, SET_F, ADD_I, ADD_F, NEG_F, COPY_F };
typedef struct craft {
    const char *method, *reg; /* NULL: dth; NULL: none */
    const char *sec, *field;
    size_t comp;              /* component of a vector field */
    enum op op;
    int64_t i;                /* SET_I, ADD_I */
    double x;                 /* SET_F, ADD_F */
    const char *from;         /* COPY_F: the field of the same section whose value is copied */
    const char *says;         /* in the refusal */
} craft;

#define I64MAX INT64_C(9223372036854775807)
static const craft crafts[] = {
    /* the DTH step state (issue 24: steps = INT64_MAX overflowed in integrator.c and branch.c) */
    {NULL, NULL, "state", "steps", 0, SET_I, I64MAX, 0, NULL, "'steps'"},
    {NULL, NULL, "state", "steps", 0, SET_I, (INT64_C(1) << 53) + 1, 0, NULL, "'steps'"},
    {NULL, NULL, "state", "steps", 0, SET_I, 2, 0, NULL, "'nhist' = 3 exceeds field 'steps'"},
    {NULL, NULL, "state", "dir", 0, SET_F, 0, -1.0, NULL, "'dir'"},
    {NULL, NULL, "state", "lam_hint", 0, NEG_F, 0, 0, NULL, "'lam_hint'"},
    {NULL, NULL, "state", "lam", 0, SET_F, 0, 0, NULL, "'lam'"},
    {NULL, NULL, "state", "lam", 0, NEG_F, 0, 0, NULL, "'lam'"},
    {NULL, NULL, "state", "lam2", 0, SET_F, 0, 0, NULL, "'lam2'"},
    {NULL, NULL, "state", "lam3", 0, NEG_F, 0, 0, NULL, "'lam3'"},
    {NULL, NULL, "state", "pending_exact", 0, SET_I, 1, 0, NULL, "'pending_exact'"},
    {NULL, NULL, "state", "have_mid", 0, SET_I, 0, 0, NULL, "'have_mid'"},
    {NULL, NULL, "state", "zlo", 1, SET_F, 0, 1e-3, NULL, "'zlo'"},
    {NULL, NULL, "state", "rholo", 0, COPY_F, 0, 0, "rho", "'rholo'"},
    {NULL, NULL, "policy", "psi_step", 0, SET_I, 1000, 0, NULL, "'psi_step'"},
    {NULL, NULL, "policy", "psi_step", 0, SET_I, I64MAX, 0, NULL, "'psi_step'"},
    /* the run driver's state (issue 24: samples = INT64_MAX overflowed in run.c; t_stop = +-1e308) */
    {NULL, NULL, "run", "samples", 0, SET_I, I64MAX, 0, NULL, "'samples'"},
    {NULL, NULL, "run", "k", 0, SET_I, I64MAX, 0, NULL, "'k'"},
    {NULL, NULL, "run", "j", 0, SET_I, I64MAX, 0, NULL, "'j'"},
    {NULL, NULL, "run", "events", 0, SET_I, I64MAX, 0, NULL, "'events'"},
    {NULL, NULL, "run", "t_stop", 0, SET_F, 0, 1e308, NULL, "'t_stop'"},
    {NULL, NULL, "run", "t_stop", 0, SET_F, 0, -1e308, NULL, "'t_stop'"},
    {NULL, NULL, "run", "t_stop", 0, ADD_F, 0, 1.0, NULL, "'t_stop'"},
    {NULL, NULL, "run", "t", 0, ADD_F, 0, 1.0, NULL, "'t'"},
    {NULL, NULL, "run", "t_first", 0, ADD_F, 0, 100.0, NULL, "'t_stop'"},
    {NULL, NULL, "run", "crossings", 0, ADD_I, 1000, 0, NULL, "'crossings'"},
    {NULL, NULL, "run", "regularized", 0, ADD_I, 1000, 0, NULL, "'regularized'"},
    {NULL, NULL, "run", "in.lambda", 0, SET_F, 0, 0, NULL, "'in.lambda'"},
    {NULL, NULL, "run", "in.residual", 0, SET_F, 0, -1.0, NULL, "'in.residual'"},
    {NULL, NULL, "run", "prev_crossing", 0, SET_I, 1, 0, NULL, "'prev_crossing'"},
    {NULL, NULL, "run", "max_ratio", 0, SET_F, 0, 0.5, NULL, "'max_ratio'"},
    {NULL, NULL, "run", "max_ratio", 0, SET_F, 0, 2.0, NULL, "'max_ratio'"},
    /* a regularizer's fields (they were raw host bytes, NaN included) */
    {NULL, "prescribed", "regularizer", "dlast", 0, SET_F, 0, NAN, NULL, "'dlast'"},
    {NULL, "prescribed", "regularizer", "dlast", 3, SET_F, 0, -INFINITY, NULL, "'dlast'"},
    /* a baseline's state */
    {"midpoint", NULL, "state", "E0", 0, ADD_F, 0, 1.0, NULL, "'E0'"},
    {"midpoint", NULL, "state", "steps", 0, SET_I, I64MAX, 0, NULL, "'steps'"},
};
/* Every entry above was restored (or resumed by dth run) without complaint by 7aa2192; these were
 * refused before too (by dth run's blob, by the regularizer's load_state) and still are. */
static const craft kept[] = {
    {NULL, NULL, "run", "k0", 0, ADD_I, 1000, 0, NULL, "'k0'"},
    {NULL, NULL, "run", "started", 0, SET_I, 0, 0, NULL, "has not started"},
    {NULL, "prescribed", "regularizer", "mu_last", 0, SET_F, 0, INFINITY, NULL, "'mu_last'"},
    {NULL, "prescribed", "regularizer", "arc", 0, SET_F, 0, -1.0, NULL, "'arc'"},
    {NULL, "land", "regularizer", "C", 0, SET_F, 0, -1.0, NULL, "'C'"},
    {NULL, "land", "regularizer", "C_fixed", 0, SET_I, 2, 0, NULL, "'C_fixed'"},
    {NULL, "land", "regularizer", "dpsi_prev", 0, SET_F, 0, NAN, NULL, "'dpsi_prev'"},
    /* steps are any finite number (what the integrator accepts), not infinite nor NaN, h not 0 */
    {NULL, NULL, "state", "lam_hint", 0, SET_F, 0, INFINITY, NULL, "'lam_hint'"},
    {NULL, NULL, "state", "h", 0, SET_F, 0, -INFINITY, NULL, "'h'"},
    {NULL, NULL, "state", "h", 0, SET_F, 0, 0, NULL, "'h'"},
    {NULL, NULL, "state", "lam", 0, SET_F, 0, NAN, NULL, "'lam'"},
    {NULL, NULL, "run", "in.lambda", 0, SET_F, 0, INFINITY, NULL, "'in.lambda'"},
    {"gauss4", NULL, "state", "h", 0, SET_F, 0, NAN, NULL, "'h'"},
};
/* The run state's members added since 7aa2192 (dth run's own blob checked them until the run state
 * moved into the library: its ranges are kept) and the regularizer land's rule between its fields. */
static const craft added[] = {
    {NULL, NULL, "run", "max_ratio", 0, SET_F, 0, NAN, NULL, "'max_ratio'"},
    {NULL, NULL, "run", "nonreversible", 0, ADD_I, 1000, 0, NULL, "'nonreversible'"},
    {NULL, NULL, "run", "in.flags", 0, SET_I, 32, 0, NULL, "'in.flags'"},
    {NULL, NULL, "run", "stop", 0, SET_I, 6, 0, NULL, "'stop'"},
    {NULL, NULL, "run", "in.lerr", 0, SET_F, 0, -1.0, NULL, "'in.lerr'"},
    {NULL, NULL, "run", "err_q", 0, SET_F, 0, -1.0, NULL, "'err_q'"},
    {NULL, NULL, "run", "q_max", 0, SET_F, 0, -1.0, NULL, "'q_max'"},
    {NULL, NULL, "run", "e_scale", 0, SET_F, 0, NAN, NULL, "'e_scale'"},
    {NULL, NULL, "run", "t_lam_max", 0, SET_F, 0, INFINITY, NULL, "'t_lam_max'"},
    {NULL, NULL, "run", "e_err", 0, SET_F, 0, -INFINITY, NULL, "'e_err'"},
    {NULL, "land", "regularizer", "acc", 0, SET_F, 0, INFINITY, NULL, "'acc'"},
};

static const dth_regularizer_type *reg_type(const char *name)
{
    if (!name) return NULL;
    return !strcmp(name, "land") ? &dth_reg_land : &dth_reg_prescribed;
}

/* Apply one craft to a copy of the checkpoint b (len bytes) and reseal it: 0, or -1 if the field is
 * not there. */
static int apply_craft(const craft *c, unsigned char *b, size_t len)
{
    walk_field f = {0};
    if (!walk_find_field(b, len, c->sec, c->field, &f) || c->comp >= f.count) return -1;
    unsigned char *v = b + f.values + 8 * c->comp;
    uint64_t bits = walk_le(v, 8);
    double x;
    memcpy(&x, &bits, sizeof x);
    switch (c->op) {
    case SET_I: bits = (uint64_t)c->i; break;
    case ADD_I: bits += (uint64_t)c->i; break;
    case SET_F: x = c->x; break;
    case ADD_F: x += c->x; break;
    case NEG_F: x = -x; break;
    case COPY_F: {
        walk_field g;
        if (!walk_find_field(b, len, c->sec, c->from, &g)) return -1;
        uint64_t gb = walk_le(b + g.values, 8);
        memcpy(&x, &gb, sizeof x);
        break;
    }
    }
    if (c->op != SET_I && c->op != ADD_I) memcpy(&bits, &x, sizeof bits);
    walk_put_le(v, bits, 8);
    walk_reseal(b, len);
    return 0;
}

/* Each crafted value with the checksum recomputed: refused naming its field, nothing changed. The
 * checkpoint is of a run of 30 steps (nhist = 3), its run state at the end. */
static long crafted(const craft *table, size_t n)
{
    long failures = 0;
    for (size_t i = 0; i < n; i++) {
        const craft *c = &table[i];
        runner a, b, ctl;
        double p0 = c->reg && !strcmp(c->reg, "land") ? 2.2 : 0.2;
        runner_new(&a, c->method, reg_type(c->reg), p0);
        runner_new(&b, c->method, reg_type(c->reg), 0.7);
        runner_new(&ctl, c->method, reg_type(c->reg), 0.7);
        runner_run(&a, 30);
        runner_run(&b, 3);
        size_t len, lb, la;
        unsigned char *good = save_run(a.it, &a.st, &len), *bad = malloc(len);
        unsigned char *before = save_run(b.it, &b.st, &lb);
        CU_ASSERT_FATAL(bad != NULL);
        /* the untouched checkpoint restores, as a control */
        memcpy(bad, good, len);
        walk_reseal(bad, len);
        dth_run_state got;
        char err[400] = "";
        int ok = memcmp(bad, good, len) == 0 &&
                 dth_checkpoint_restore_run(ctl.it, &got, bad, len, err, sizeof err) == DTH_OK &&
                 memcmp(&got, &a.st, sizeof got) == 0;
        if (!ok) printf("  [%s.%s: the unpatched checkpoint is refused: %s]\n", c->sec, c->field, err);
        CU_ASSERT(ok);
        runner_free(&ctl);
        CU_ASSERT_FATAL(apply_craft(c, bad, len) == 0);
        got = b.st;
        err[0] = '\0';
        int rc = dth_checkpoint_restore_run(b.it, &got, bad, len, err, sizeof err);
        unsigned char *after = save_run(b.it, &b.st, &la);
        int refused = rc == DTH_EPARSE && strstr(err, c->says) != NULL;
        int untouched = la == lb && memcmp(before, after, lb) == 0 && memcmp(&got, &b.st, sizeof got) == 0;
        if (!refused || !untouched) {
            printf("  [%s%s%s.%s: rc %d, '%s'%s]\n", c->method ? c->method : "", c->reg ? c->reg : "", c->sec, c->field,
                   rc, err, untouched ? "" : ", the integrator changed");
            failures++;
        }
        free(good);
        free(bad);
        free(before);
        free(after);
        runner_free(&a);
        runner_free(&b);
    }
    return failures;
}

static void test_crafted_refused(void)
{
    long failures = crafted(crafts, sizeof crafts / sizeof crafts[0]);
    printf("  [%zu crafted checkpoints, %ld accepted or wrongly refused]\n", sizeof crafts / sizeof crafts[0], failures);
    CU_ASSERT(failures == 0);
    failures = crafted(kept, sizeof kept / sizeof kept[0]);
    CU_ASSERT(failures == 0);
    failures = crafted(added, sizeof added / sizeof added[0]);
    CU_ASSERT(failures == 0);
}

/* Steps are bounded by what the integrator accepts, any finite h: the state of the fuzzer's
 * regression in test_failstate.c (h = -1.06e270 on a chain of near-zero couplings; lam_hint, h and
 * the steps beyond 1e100) checkpoints at each vertex and after each failure, and restores into an
 * integrator made with the same options (the earlier bound |step| <= 1e100 refused it). */
static void test_extreme_steps(void)
{
    static const dth_kv kv[] = {{"preset", "chain"}, {"size", "2"}, {"dim", "1"}, {"k", "3.43519951892224e-310"},
                                {"L", "3.2194903e-317"}, {"mass", "1.836709924525607e-39"}};
    dth_model *m = NULL;
    CU_ASSERT_FATAL(dth_model_new(&dth_model_coupled, kv, 6, 2, NULL, &m, NULL, 0) == DTH_OK);
    dth_options o;
    dth_options_default(&o);
    o.h = -1.0565892344930458e+270;
    o.K = 3.919106652168698e+202;
    o.max_iter = 1;
    dth_integrator *it = NULL, *c = NULL;
    CU_ASSERT_FATAL(dth_integrator_new(m, &o, &it) == DTH_OK && dth_integrator_new(m, &o, &c) == DTH_OK);
    double q[2] = {6.507473426500481e-307, 0.5}, p[2] = {0.5, 0.5};
    CU_ASSERT_FATAL(dth_integrator_start(it, q, p, -2.723462048819236e+154) == DTH_OK);
    long restored = 0, tried = 0;
    for (int k = 0, failed = 0; k < 6 && failed < 2; k++) {
        size_t len, l2;
        unsigned char *b = save_run(it, NULL, &len);
        char err[400] = "";
        tried++;
        int rc = dth_checkpoint_restore(c, b, len, err, sizeof err);
        if (rc) printf("  [h = %g, step %d: %s]\n", o.h, k, err);
        else restored++;
        unsigned char *b2 = save_run(c, NULL, &l2);
        CU_ASSERT(rc != DTH_OK || (l2 == len && memcmp(b, b2, len) == 0)); /* saves back the same bytes */
        free(b);
        free(b2);
        if (failed || dth_integrator_step(it, NULL) != DTH_OK) failed++; /* a failure: its state once more, then stop */
    }
    CU_ASSERT(restored == tried && tried >= 2);
    /* and a run state at a time beyond the old bound 1e300 (a vertex set there, with h = 1e290) */
    dth_model *pend = NULL;
    CU_ASSERT_FATAL(dth_model_new(&dth_model_pendulum, NULL, 0, 1, NULL, &pend, NULL, 0) == DTH_OK);
    dth_integrator_free(c);
    dth_options_default(&o);
    o.h = 1e290;
    CU_ASSERT_FATAL(dth_integrator_new(pend, &o, &c) == DTH_OK);
    double z[4] = {1.0, 1e305, 0.2, 0};
    CU_ASSERT_FATAL(dth_model_eval(pend, z, DTH_EVAL_H, &z[3], NULL, NULL) == DTH_OK);
    z[3] = -z[3];
    CU_ASSERT_FATAL(dth_integrator_set_vertex(c, z, o.h) == DTH_OK);
    dth_run_state st;
    dth_run_state_init(&st);
    st.started = 1;
    st.t = st.t_first = st.t_stop = dth_integrator_vertex(c)[1];
    size_t len;
    unsigned char *b = save_run(c, &st, &len);
    dth_run_state got;
    char err[400] = "";
    CU_ASSERT(dth_checkpoint_restore_run(c, &got, b, len, err, sizeof err) == DTH_OK);
    if (err[0]) printf("  [%s]\n", err);
    CU_ASSERT(memcmp(&got, &st, sizeof st) == 0);
    free(b);
    /* a run whose |q| overflows although q is finite (the pendulum at q = 1e160: found by
     * fuzz_integrator): q_max = +inf is a state the run driver reaches, and restores */
    dth_integrator_free(c);
    dth_options_default(&o);
    o.h = 0.05;
    CU_ASSERT_FATAL(dth_integrator_new(pend, &o, &c) == DTH_OK);
    double qb = 1e160, pb = 0.2;
    CU_ASSERT_FATAL(dth_integrator_start(c, &qb, &pb, 0) == DTH_OK);
    dth_run_config rc;
    dth_run_config_default(&rc);
    rc.steps = 1;
    dth_run_state_init(&st);
    CU_ASSERT_FATAL(dth_run(c, &rc, &st) == DTH_OK);
    CU_ASSERT(st.k == 1 && isinf(st.q_max));
    b = save_run(c, &st, &len);
    err[0] = '\0';
    CU_ASSERT(dth_checkpoint_restore_run(c, &got, b, len, err, sizeof err) == DTH_OK);
    if (err[0]) printf("  [%s]\n", err);
    CU_ASSERT(memcmp(&got, &st, sizeof st) == 0);
    free(b);
    dth_integrator_free(it);
    dth_integrator_free(c);
    dth_model_free(pend);
    dth_model_free(m);
}

/* Reversed before its first step, a midpoint start (its exact first step still pending) goes the
 * other way from its vertex: the step to aim for points backward like the direction and h, so its
 * checkpoint restores (dth__dth_reverse set lam_hint against the direction there) and the restored
 * integrator takes the same backward steps as the one reversed. */
static void start_finish(runner *r, dth_finish finish)
{
    memset(r, 0, sizeof *r);
    CU_ASSERT_FATAL(dth_model_new(&dth_model_pendulum, NULL, 0, 1, NULL, &r->m, NULL, 0) == DTH_OK);
    dth_options o;
    dth_options_default(&o);
    o.h = 0.05;
    o.finish = finish;
    CU_ASSERT_FATAL(dth_integrator_new(r->m, &o, &r->it) == DTH_OK);
    double q = 1.0, p = 0.2;
    CU_ASSERT_FATAL(dth_integrator_start(r->it, &q, &p, 0) == DTH_OK);
}

static void test_reverse_at_start(void)
{
    const dth_finish finishes[] = {DTH_FINISH_PLAIN, DTH_FINISH_COMPENSATED, DTH_FINISH_REVERSIBLE};
    for (int i = 0; i < 3; i++) {
        runner a, b;
        start_finish(&a, finishes[i]);
        start_finish(&b, finishes[i]);
        double t0 = dth_integrator_vertex(a.it)[1];
        dth_integrator_reverse(a.it);
        CU_ASSERT(dth_integrator_direction(a.it) == -1.0);
        size_t len;
        unsigned char *buf = save_run(a.it, NULL, &len);
        char err[400] = "";
        CU_ASSERT(dth_checkpoint_restore(b.it, buf, len, err, sizeof err) == DTH_OK);
        if (err[0]) printf("  [%s]\n", err);
        int same = 1;
        for (int k = 0; k < 5; k++) {
            dth_step_info ia, ib;
            CU_ASSERT(dth_integrator_step(a.it, &ia) == DTH_OK && dth_integrator_step(b.it, &ib) == DTH_OK);
            CU_ASSERT(ia.lambda < 0);
            same &= memcmp(dth_integrator_vertex(a.it), dth_integrator_vertex(b.it), 4 * sizeof(double)) == 0;
        }
        CU_ASSERT(same);
        CU_ASSERT(dth_integrator_vertex(a.it)[1] < t0 - 0.2);
        free(buf);
        runner_free(&a);
        runner_free(&b);
    }
}

/* ---- byte order ---- */

/* Rewrite the checkpoint b as a writer that copies its host's bytes on a big-endian host would
 * have: every number byte-swapped (strings and blob bytes as they are), the checksum too. */
static void swap_at(unsigned char *o, const unsigned char *b, size_t pos, int n)
{
    for (int i = 0; i < n; i++) o[pos + (size_t)i] = b[pos + (size_t)(n - 1 - i)];
}

static size_t swap_str(unsigned char *o, const unsigned char *b, size_t pos)
{
    swap_at(o, b, pos, 4);
    return pos + 4 + (size_t)walk_le(b + pos, 4);
}

static size_t swap_section(unsigned char *o, const unsigned char *b, size_t pos)
{
    pos = swap_str(o, b, pos);
    swap_at(o, b, pos, 8);
    swap_at(o, b, pos + 8, 4);
    uint64_t nf = walk_le(b + pos + 8, 4);
    pos += 12;
    for (uint64_t i = 0; i < nf; i++) {
        pos = swap_str(o, b, pos);
        uint64_t type = walk_le(b + pos, 4), count = walk_le(b + pos + 4, 8);
        swap_at(o, b, pos, 4);
        swap_at(o, b, pos + 4, 8);
        pos += 12;
        for (uint64_t k = 0; type != 3 && k < count; k++) swap_at(o, b, pos + 8 * k, 8);
        pos += type == 3 ? count : 8 * count;
    }
    return pos;
}

static void big_endian(unsigned char *o, const unsigned char *b, size_t len)
{
    memcpy(o, b, len);
    swap_at(o, b, 8, 4);
    swap_at(o, b, 12, 4);
    swap_at(o, b, 16, 8);
    size_t pos = swap_str(o, b, 24);
    pos = swap_str(o, b, pos);
    swap_at(o, b, pos, 8);
    swap_at(o, b, pos + 8, 4);
    uint64_t nsec = walk_le(b + pos + 8, 4);
    pos += 12;
    for (uint64_t i = 0; i < nsec; i++) pos = swap_section(o, b, pos);
    pos = swap_str(o, b, pos);
    pos = swap_section(o, b, pos);
    uint64_t has_run = walk_le(b + pos, 4);
    swap_at(o, b, pos, 4);
    pos += 4;
    if (has_run) pos = swap_section(o, b, pos);
    uint64_t nb = walk_le(b + pos, 4);
    swap_at(o, b, pos, 4);
    pos += 4;
    for (uint64_t i = 0; i < nb; i++) {
        pos = swap_str(o, b, pos);
        uint64_t sz = walk_le(b + pos, 8);
        swap_at(o, b, pos, 8);
        pos += 8 + sz;
    }
    CU_ASSERT(pos + 8 == len);
    uint64_t h = walk_fnv(o, len - 8);
    for (int i = 0; i < 8; i++) o[len - 8 + (size_t)i] = (unsigned char)(h >> (8 * (7 - i)));
}

static void test_byte_order(void)
{
    runner a, b;
    runner_new(&a, NULL, &dth_reg_prescribed, 0.2);
    runner_new(&b, NULL, &dth_reg_prescribed, 0.2);
    runner_run(&a, 10);
    size_t len;
    unsigned char *good = save_run(a.it, &a.st, &len), *bad = malloc(len);
    CU_ASSERT_FATAL(bad != NULL);
    /* every number is little-endian by construction: the header's as documented */
    CU_ASSERT(walk_le(good + 8, 4) == DTH_CHECKPOINT_VERSION && good[12] == 4 && good[13] == 3 && good[14] == 2 &&
              good[15] == 1 && walk_le(good + 16, 8) == len);
    char err[400] = "";
    dth_run_state got;
    /* the whole checkpoint as a big-endian writer would have written it */
    big_endian(bad, good, len);
    CU_ASSERT(dth_checkpoint_verify(bad, len, err, sizeof err) == DTH_EPARSE && strstr(err, "big-endian") != NULL);
    err[0] = '\0';
    CU_ASSERT(dth_checkpoint_restore_run(b.it, &got, bad, len, err, sizeof err) == DTH_EPARSE);
    CU_ASSERT(strstr(err, "big-endian") != NULL);
    printf("  [%s]\n", err);
    /* its byte-order mark alone, the checksum recomputed */
    memcpy(bad, good, len);
    for (int i = 0; i < 4; i++) bad[12 + i] = (unsigned char)(i + 1);
    walk_reseal(bad, len);
    err[0] = '\0';
    CU_ASSERT(dth_checkpoint_restore_run(b.it, &got, bad, len, err, sizeof err) == DTH_EPARSE);
    CU_ASSERT(strstr(err, "big-endian") != NULL);
    /* any other mark is no byte order: it is named, not blamed on big-endian hosts */
    for (int i = 0; i < 4; i++) bad[12 + i] = 0xff;
    walk_reseal(bad, len);
    CU_ASSERT(dth_checkpoint_restore(b.it, bad, len, err, sizeof err) == DTH_EPARSE && strstr(err, "byte-order") != NULL);
    CU_ASSERT(strstr(err, "0xffffffff") != NULL && strstr(err, "big-endian") == NULL);
    for (int i = 0; i < 4; i++) bad[8 + i] = 0xff; /* and a version no writer wrote */
    walk_reseal(bad, len);
    CU_ASSERT(dth_checkpoint_restore(b.it, bad, len, err, sizeof err) == DTH_EPARSE && strstr(err, "version") != NULL);
    CU_ASSERT(strstr(err, "big-endian") == NULL);
    CU_ASSERT(dth_integrator_steps(b.it) == 0);
    /* the regularizer's doubles are little-endian too: the arc's bytes in the file are its value's */
    walk_field f = {0};
    CU_ASSERT_FATAL(walk_find_field(good, len, "regularizer", "arc", &f) && f.type == 1 && f.count == 1);
    uint64_t bits = walk_le(good + f.values, 8);
    double arc;
    memcpy(&arc, &bits, sizeof arc);
    CU_ASSERT(arc > 0 && isfinite(arc));
    free(good);
    free(bad);
    runner_free(&a);
    runner_free(&b);
}

/* ---- the run state: saved and restored by the library, the run continued bit for bit ---- */

static void test_run_state(void)
{
    runner a, b, c;
    runner_new(&a, NULL, &dth_reg_land, 2.2);
    runner_new(&b, NULL, &dth_reg_land, 2.2);
    runner_new(&c, NULL, &dth_reg_land, 2.2);
    runner_run(&a, 120);
    runner_run(&b, 50);
    size_t len;
    unsigned char *buf = save_run(b.it, &b.st, &len);
    dth_run_state alone;
    char err[400] = "";
    CU_ASSERT(dth_checkpoint_run_state(buf, len, &alone, err, sizeof err) == DTH_OK);
    CU_ASSERT(memcmp(&alone, &b.st, sizeof alone) == 0);
    CU_ASSERT(dth_checkpoint_restore_run(c.it, &c.st, buf, len, err, sizeof err) == DTH_OK);
    CU_ASSERT(memcmp(&c.st, &b.st, sizeof c.st) == 0);
    long n0 = b.n;
    c.n = n0;
    memcpy(c.t, b.t, sizeof c.t);
    memcpy(c.q, b.q, sizeof c.q);
    runner_run(&c, 120);
    CU_ASSERT(c.n == a.n && memcmp(c.t, a.t, sizeof c.t) == 0 && memcmp(c.q, a.q, sizeof c.q) == 0);
    CU_ASSERT(memcmp(&c.st, &a.st, sizeof c.st) == 0);
    CU_ASSERT(a.st.crossings > 0); /* the run went through psi = 0 */
    /* a checkpoint without a run state: restore_run says so, restore reads it */
    size_t l2;
    unsigned char *plain = save_run(b.it, NULL, &l2);
    CU_ASSERT(dth_checkpoint_restore_run(c.it, &alone, plain, l2, err, sizeof err) == DTH_ENOTFOUND);
    CU_ASSERT(strstr(err, "no run state") != NULL);
    CU_ASSERT(dth_checkpoint_run_state(plain, l2, &alone, err, sizeof err) == DTH_ENOTFOUND);
    CU_ASSERT(dth_checkpoint_restore(c.it, buf, len, err, sizeof err) == DTH_OK);
    CU_ASSERT(dth_checkpoint_run_state(buf, len, NULL, err, sizeof err) == DTH_EINVAL);
    free(plain);
    free(buf);
    runner_free(&a);
    runner_free(&b);
    runner_free(&c);
}

/* ---- land through psi = 0: a run checkpointed at its crossings resumes bit for bit ---- */

typedef struct srec {
    int kind, event, direction;
    long index, k;
    double z[4], err_q, err_p, lambda;
    unsigned flags;
} srec;

typedef struct trace {
    srec r[4096];
    long n;
    unsigned flags_at[1024]; /* in.flags of the step that arrived at vertex k (checkpoint callback) */
} trace;

static int trace_sample(void *user, const dth_sample *s)
{
    trace *t = user;
    if (t->n < 4096) {
        srec *r = &t->r[t->n++];
        memset(r, 0, sizeof *r); /* padding too: records are compared as bytes */
        r->kind = (int)s->kind;
        r->event = s->event;
        r->direction = s->direction;
        r->index = s->index;
        r->k = s->k;
        memcpy(r->z, s->z, sizeof r->z);
        r->err_q = s->err_q;
        r->err_p = s->err_p;
        r->lambda = s->step->lambda;
        r->flags = s->step->flags;
    }
    return 0;
}

static int trace_flags(void *user, const dth_run_state *st)
{
    trace *t = user;
    if (st->k >= 0 && st->k < 1024) t->flags_at[st->k] = st->in.flags;
    return 0;
}

static int below_p(void *user, size_t n, const double *z, double *g)
{
    (void)user;
    *g = z[n + 1] - 1.9; /* p = 1.9: the rotation slows there, both ways */
    return DTH_OK;
}

/* A land run (estimate and local error on, dense output at times, an event) to vertex `to`, from the
 * run state st (fresh or restored) with integrator x. */
static void land_leg(runner *x, trace *t, long to, int every_step)
{
    static const dth_event ev = {below_p, NULL, 0, 0};
    dth_run_config c;
    dth_run_config_default(&c);
    c.steps = to;
    c.points = DTH_POINTS_TIMES;
    c.dt = 0.0371;
    c.sample = trace_sample;
    c.on_event = trace_sample;
    c.events = &ev;
    c.nevents = 1;
    c.local_error = 1;
    c.user = t;
    if (every_step) {
        c.checkpoint = trace_flags;
        c.checkpoint_every = 1;
    }
    CU_ASSERT_FATAL(dth_run(x->it, &c, &x->st) == DTH_OK);
}

static void land_runner(runner *r)
{
    memset(r, 0, sizeof *r);
    CU_ASSERT_FATAL(dth_model_new(&dth_model_pendulum, NULL, 0, 1, NULL, &r->m, NULL, 0) == DTH_OK);
    CU_ASSERT_FATAL(dth_regularizer_new(&dth_reg_land, NULL, 0, r->m, NULL, &r->reg, NULL, 0) == DTH_OK);
    dth_options o;
    dth_options_default(&o);
    o.h = 0.05;
    o.start = DTH_START_VERTEX;
    o.estimate = 1;
    o.regularizer = r->reg;
    CU_ASSERT_FATAL(dth_integrator_new(r->m, &o, &r->it) == DTH_OK);
    double q = 0, p = 2.2;
    CU_ASSERT_FATAL(dth_integrator_start(r->it, &q, &p, 0) == DTH_OK);
    dth_run_state_init(&r->st);
}

static void test_land_crossings(void)
{
    enum { END = 400 };
    static trace straight, resumed;
    runner a;
    memset(&straight, 0, sizeof straight);
    land_runner(&a);
    land_leg(&a, &straight, END, 1);
    /* the vertices around the replaced (crossing) steps: the one before, the one each lands on, the
     * one after it (the landing's reset vertex and the first ordinary step from it) */
    long at[24];
    size_t nat = 0;
    for (long k = 2; k + 1 < END && nat + 3 <= sizeof at / sizeof at[0]; k++)
        if (straight.flags_at[k] & DTH_STEP_REGULARIZED) {
            CU_ASSERT(straight.flags_at[k] & DTH_STEP_RESET);
            at[nat++] = k - 1, at[nat++] = k, at[nat++] = k + 1;
        }
    CU_ASSERT(nat >= 9); /* three crossings at least */
    CU_ASSERT(a.st.crossings >= 3 && a.st.nonreversible > 0 && a.st.events > 0 && !isnan(a.st.err_q));
    long differ = 0;
    for (size_t i = 0; i < nat; i++) {
        runner b, c;
        memset(&resumed, 0, sizeof resumed);
        land_runner(&b);
        land_runner(&c);
        land_leg(&b, &resumed, at[i], 0);
        size_t len;
        unsigned char *buf = save_run(b.it, &b.st, &len);
        char err[400] = "";
        int rc = dth_checkpoint_restore_run(c.it, &c.st, buf, len, err, sizeof err);
        if (rc) printf("  [vertex %ld: %s]\n", at[i], err);
        CU_ASSERT_FATAL(rc == DTH_OK);
        land_leg(&c, &resumed, END, 0);
        int same = resumed.n == straight.n && memcmp(resumed.r, straight.r, (size_t)straight.n * sizeof(srec)) == 0 &&
                   memcmp(&c.st, &a.st, sizeof c.st) == 0;
        if (!same) {
            printf("  [resumed at vertex %ld (flags %u): differs]\n", at[i], straight.flags_at[at[i]]);
            differ++;
        }
        free(buf);
        runner_free(&b);
        runner_free(&c);
    }
    printf("  [%zu resume points around %zu crossings, %ld samples and events each, %ld differ]\n", nat, nat / 3,
           straight.n, differ);
    CU_ASSERT(differ == 0);
    /* the estimate's shadow goes only into an integrator that estimates: either way round refused,
     * saying so, nothing changed */
    runner plain;
    runner_new(&plain, NULL, &dth_reg_land, 2.2);
    size_t len, lw, lp, lb;
    unsigned char *with = save_run(a.it, &a.st, &len), *without = save_run(plain.it, NULL, &lw);
    unsigned char *before = save_run(plain.it, NULL, &lb);
    char err[400] = "";
    CU_ASSERT(dth_checkpoint_restore(plain.it, with, len, err, sizeof err) == DTH_EINVAL);
    CU_ASSERT(strstr(err, "dth_options.estimate") != NULL);
    unsigned char *after = save_run(plain.it, NULL, &lp);
    CU_ASSERT(lp == lb && memcmp(before, after, lb) == 0);
    err[0] = '\0';
    CU_ASSERT(dth_checkpoint_restore(a.it, without, lw, err, sizeof err) == DTH_EINVAL);
    CU_ASSERT(strstr(err, "dth_options.estimate") != NULL);
    /* a shadow at another time than the vertex's is refused, the integrator left as it was */
    walk_field f = {0};
    CU_ASSERT_FATAL(walk_find_field(with, len, "estimate", "x", &f) && f.count == 4);
    double tx;
    uint64_t bits = walk_le(with + f.values + 8, 8);
    memcpy(&tx, &bits, sizeof tx);
    tx += 0.5;
    memcpy(&bits, &tx, sizeof bits);
    walk_put_le(with + f.values + 8, bits, 8);
    walk_reseal(with, len);
    size_t la0, la1;
    unsigned char *a0 = save_run(a.it, &a.st, &la0);
    dth_run_state got = a.st;
    err[0] = '\0';
    CU_ASSERT(dth_checkpoint_restore_run(a.it, &got, with, len, err, sizeof err) == DTH_EPARSE);
    CU_ASSERT(strstr(err, "'estimate'") && strstr(err, "'x'"));
    unsigned char *a1 = save_run(a.it, &a.st, &la1);
    CU_ASSERT(la0 == la1 && memcmp(a0, a1, la0) == 0 && memcmp(&got, &a.st, sizeof got) == 0);
    free(a0);
    free(a1);
    free(with);
    free(without);
    free(before);
    free(after);
    runner_free(&plain);
    runner_free(&a);
}

/* The run state's field list names every member of dth_run_state and of its dth_step_info, as the
 * public headers declare them (a member that fits the padding moves no offset: this catches it). */
static size_t members(const char *path, const char *open, const char *close, char names[][32], size_t max)
{
    FILE *f = fopen(path, "rb");
    CU_ASSERT_FATAL(f != NULL);
    static char text[1 << 17];
    size_t got = fread(text, 1, sizeof text - 1, f);
    fclose(f);
    text[got] = '\0';
    char *a = strstr(text, open), *e = a ? strstr(a, close) : NULL;
    CU_ASSERT_FATAL(a && e);
    size_t k = 0;
    for (char *p = a + strlen(open); p < e && k < max;) {
        char *semi = strchr(p, ';');
        if (!semi || semi > e) break;
        /* skip a comment line or block between members */
        char *c = strstr(p, "/*");
        if (c && c < semi) {
            char *ce = strstr(c, "*/");
            if (ce && ce < semi) { /* a comment before the declaration: drop it */
                p = ce + 2;
                continue;
            }
        }
        /* each declarator's name ends before a ',' or the ';' ("double err_q, err_p;") */
        for (char *end = p; end <= semi && k < max; end++) {
            if (*end != ',' && end != semi) continue;
            char *q = end;
            while (q > p && q[-1] == ' ') q--;
            char *s = q;
            while (s > p && (s[-1] == '_' || (s[-1] >= 'a' && s[-1] <= 'z') || (s[-1] >= '0' && s[-1] <= '9'))) s--;
            size_t n = (size_t)(q - s);
            if (n && n < 32) {
                memcpy(names[k], s, n);
                names[k++][n] = '\0';
            }
        }
        p = semi + 1;
    }
    return k;
}

static void test_run_fields_cover(void)
{
    const char *root = getenv("DTH_SOURCE_ROOT");
    if (!root) {
        printf("  [DTH_SOURCE_ROOT not set: the headers are not read]\n");
        return;
    }
    char path[4096], run[64][32], step[16][32];
    snprintf(path, sizeof path, "%s/lib/include/dth/run.h", root);
    size_t nr = members(path, "typedef struct dth_run_state {", "} dth_run_state;", run, 64);
    snprintf(path, sizeof path, "%s/lib/include/dth/integrator.h", root);
    size_t ns = members(path, "typedef struct dth_step_info {", "} dth_step_info;", step, 16);
    size_t nf;
    const dth_field *f = dth__run_fields(&nf);
    CU_ASSERT(nr == 25 && ns == 7); /* as the headers stand: the parse itself works */
    CU_ASSERT(nf == nr - 1 + ns);   /* `in` flattened into its members */
    long missing = 0;
    for (size_t i = 0; i < nr + ns; i++) {
        char want[48];
        if (i < nr && !strcmp(run[i], "in")) continue;
        snprintf(want, sizeof want, i < nr ? "%s" : "in.%s", i < nr ? run[i] : step[i - nr]);
        size_t k = 0;
        while (k < nf && strcmp(f[k].name, want)) k++;
        if (k == nf) {
            printf("  [member %s has no field in lib/run_fields.h]\n", want);
            missing++;
        }
    }
    CU_ASSERT(missing == 0);
}

/* ---- regularizer tables: the old layout, bad field lists, state_loaded's veto ---- */

static int none_apply(void *self, const dth_reg_event *ev, dth_reg_action *act)
{
    (void)self, (void)ev;
    act->what = DTH_REG_KEEP;
    return DTH_OK;
}

typedef struct two {
    double a;
    int b;
} two;

static void test_reg_tables(void)
{
    char err[300] = "";
    dth_regularizer_type t = {DTH_REG_TYPE_HEAD, .name = "t", .apply = none_apply};
    CU_ASSERT(dth_regularizer_type_check(&t, err, sizeof err) == DTH_OK);
    /* layout 2 (raw state bytes) is refused by name of the fix */
    t.abi = DTH_ABI_MAGIC | 2u;
    CU_ASSERT(dth_regularizer_type_check(&t, err, sizeof err) == DTH_EINVAL);
    CU_ASSERT(strstr(err, "layout version 2") && strstr(err, "version 3 only") && strstr(err, "rebuild"));
    t.abi = DTH_REG_TYPE_VERSION;
    /* bad field lists, each named */
    dth_field bad[][2] = {
        {{"a", offsetof(two, a), DTH_FIELD_F64, DTH_CHECK_FINITE, 1}, {"a", offsetof(two, b), DTH_FIELD_INT, DTH_CHECK_BOOL, 1}},
        {{"a", offsetof(two, a), DTH_FIELD_STR, DTH_CHECK_ANY, 1}, {"b", offsetof(two, b), DTH_FIELD_INT, DTH_CHECK_BOOL, 1}},
        {{"a", offsetof(two, a), DTH_FIELD_F64, 99, 1}, {"b", offsetof(two, b), DTH_FIELD_INT, DTH_CHECK_BOOL, 1}},
        {{"a b", offsetof(two, a), DTH_FIELD_F64, DTH_CHECK_ANY, 1}, {"b", offsetof(two, b), DTH_FIELD_INT, DTH_CHECK_BOOL, 1}},
        {{"a", offsetof(two, a), DTH_FIELD_F64, DTH_CHECK_ANY, 1}, {"b", offsetof(two, b), DTH_FIELD_INT, DTH_CHECK_BOOL, 3}},
    };
    const char *says[] = {"appears twice", "kind", "check", "name", "count"};
    for (size_t i = 0; i < sizeof bad / sizeof bad[0]; i++) {
        t.fields = bad[i];
        t.n_fields = 2;
        err[0] = '\0';
        CU_ASSERT(dth_regularizer_type_check(&t, err, sizeof err) == DTH_EINVAL && strstr(err, says[i]) != NULL);
    }
    t.fields = NULL;
    CU_ASSERT(dth_regularizer_type_check(&t, err, sizeof err) == DTH_EINVAL && strstr(err, "NULL") != NULL);
    /* state_loaded's veto: land's C marked fixed must be > 0 (a check on its own accepts C = 0), and
     * the clock's accumulator is spent at the first crossing (nonzero only before it) */
    runner a, b;
    runner_new(&a, NULL, &dth_reg_land, 2.2);
    runner_new(&b, NULL, &dth_reg_land, 2.2);
    runner_run(&a, 20);
    size_t len, lb, la;
    unsigned char *buf = save_run(a.it, &a.st, &len), *before = save_run(b.it, NULL, &lb);
    unsigned char *cp = malloc(len);
    CU_ASSERT_FATAL(cp != NULL);
    memcpy(cp, buf, len);
    walk_field f = {0};
    CU_ASSERT_FATAL(walk_find_field(buf, len, "regularizer", "C_fixed", &f) && walk_le(buf + f.values, 8) == 1);
    CU_ASSERT_FATAL(walk_find_field(buf, len, "regularizer", "C", &f));
    walk_put_le(buf + f.values, 0, 8);
    walk_reseal(buf, len);
    CU_ASSERT(dth_checkpoint_restore(b.it, buf, len, err, sizeof err) == DTH_EPARSE);
    CU_ASSERT(strstr(err, "regularizer 'land' refuses its state") != NULL);
    unsigned char *after = save_run(b.it, NULL, &la);
    CU_ASSERT(la == lb && memcmp(before, after, lb) == 0);
    free(after);
    double acc = 1e-3;
    uint64_t accbits;
    memcpy(&accbits, &acc, sizeof accbits);
    CU_ASSERT_FATAL(walk_find_field(cp, len, "regularizer", "crossed", &f));
    walk_put_le(cp + f.values, 1, 8);
    walk_reseal(cp, len);
    CU_ASSERT(dth_checkpoint_restore(b.it, cp, len, err, sizeof err) == DTH_OK); /* crossed, nothing accumulated */
    CU_ASSERT(dth_checkpoint_restore(b.it, before, lb, err, sizeof err) == DTH_OK);
    CU_ASSERT_FATAL(walk_find_field(cp, len, "regularizer", "acc", &f));
    walk_put_le(cp + f.values, accbits, 8);
    walk_reseal(cp, len);
    err[0] = '\0';
    CU_ASSERT(dth_checkpoint_restore(b.it, cp, len, err, sizeof err) == DTH_EPARSE);
    CU_ASSERT(strstr(err, "regularizer 'land' refuses its state") != NULL);
    after = save_run(b.it, NULL, &la);
    CU_ASSERT(la == lb && memcmp(before, after, lb) == 0);
    free(cp);
    free(buf);
    free(before);
    free(after);
    runner_free(&a);
    runner_free(&b);
}

/* ---- the public field codec ---- */

typedef struct rec {
    double x, arr[3];
    double *vec;
    int i;
    long l;
    unsigned long long u;
    char *s;
} rec;

static void test_fields_codec(void)
{
    double v[4] = {1, -2, 3.5, 1e-300}, w[4] = {0};
    rec a = {0.25, {1, 2, 3}, v, -7, 1L << 40, 0xfedcba9876543210ULL, "/a/path"}, b = {0}, c;
    const dth_field fl[] = {
        {"x", offsetof(rec, x), DTH_FIELD_F64, DTH_CHECK_FINITE, 1},
        {"arr", offsetof(rec, arr), DTH_FIELD_F64, DTH_CHECK_POSITIVE, 3},
        {"vec", offsetof(rec, vec), DTH_FIELD_F64_PTR, DTH_CHECK_FINITE, 4},
        {"i", offsetof(rec, i), DTH_FIELD_INT, DTH_CHECK_ANY, 1},
        {"l", offsetof(rec, l), DTH_FIELD_LONG, DTH_CHECK_COUNT, 1},
        {"u", offsetof(rec, u), DTH_FIELD_U64, DTH_CHECK_ANY, 1},
        {"s", offsetof(rec, s), DTH_FIELD_STR, DTH_CHECK_ANY, 1},
    };
    size_t n = sizeof fl / sizeof fl[0], len;
    unsigned char buf[512];
    CU_ASSERT_FATAL(dth_fields_encode(fl, n, &a, NULL, 0, &len) == DTH_OK && len <= sizeof buf);
    CU_ASSERT(dth_fields_encode(fl, n, &a, buf, len - 1, &len) == DTH_EINVAL);
    CU_ASSERT_FATAL(dth_fields_encode(fl, n, &a, buf, sizeof buf, &len) == DTH_OK);
    b.vec = w;
    char err[300] = "";
    CU_ASSERT_FATAL(dth_fields_decode(fl, n, &b, buf, len, NULL, err, sizeof err) == DTH_OK);
    CU_ASSERT(b.x == a.x && !memcmp(b.arr, a.arr, sizeof a.arr) && !memcmp(w, v, sizeof v) && b.i == a.i && b.l == a.l &&
              b.u == a.u && b.s && !strcmp(b.s, a.s));
    dth_free(NULL, b.s);
    /* every truncation, trailing bytes, a value its check refuses: a message, base untouched */
    long wrong = 0;
    c = b;
    for (size_t l = 0; l < len; l++)
        if (dth_fields_decode(fl, n, &c, buf, l, NULL, err, sizeof err) != DTH_EPARSE || memcmp(&c, &b, sizeof c)) wrong++;
    CU_ASSERT(wrong == 0);
    CU_ASSERT(dth_fields_decode(fl, n, &c, buf, len + 1, NULL, err, sizeof err) == DTH_EPARSE && strstr(err, "trailing"));
    a.arr[1] = 0;
    CU_ASSERT_FATAL(dth_fields_encode(fl, n, &a, buf, sizeof buf, &len) == DTH_OK);
    CU_ASSERT(dth_fields_decode(fl, n, &c, buf, len, NULL, err, sizeof err) == DTH_EPARSE && strstr(err, "'arr'") &&
              strstr(err, "one of its components") && !memcmp(&c, &b, sizeof c));
    a.arr[1] = 2;
    a.l = -1;
    CU_ASSERT_FATAL(dth_fields_encode(fl, n, &a, buf, sizeof buf, &len) == DTH_OK);
    CU_ASSERT(dth_fields_decode(fl, n, &c, buf, len, NULL, err, sizeof err) == DTH_EPARSE && strstr(err, "'l' holds -1"));
    a.l = 3;
    /* a string: too long, or holding a NUL */
    static char longs[DTH_FIELD_STR_MAX + 2];
    memset(longs, 'x', sizeof longs - 1);
    a.s = longs;
    CU_ASSERT(dth_fields_encode(fl, n, &a, NULL, 0, &len) == DTH_EINVAL);
    a.s = "abc";
    CU_ASSERT_FATAL(dth_fields_encode(fl, n, &a, buf, sizeof buf, &len) == DTH_OK);
    buf[len - 2] = '\0';
    CU_ASSERT(dth_fields_decode(fl, n, &c, buf, len, NULL, err, sizeof err) == DTH_EPARSE && strstr(err, "NUL"));
    /* out of memory for the string: nothing leaked, base untouched */
    buf[len - 2] = 'b';
    failing_alloc fa;
    dth_allocator al = failing_alloc_make(&fa, 1);
    CU_ASSERT(dth_fields_decode(fl, n, &c, buf, len, &al, err, sizeof err) == DTH_ENOMEM && fa.live == 0);
    CU_ASSERT(!memcmp(&c, &b, sizeof c));
    /* a list without a count for its pointer is refused */
    dth_field nocount = fl[2];
    nocount.count = 0;
    CU_ASSERT(dth_fields_encode(&nocount, 1, &a, NULL, 0, &len) == DTH_EINVAL);
}

static CU_TestInfo fields_tests[] = {
    {"crafted values with the checksum recomputed: refused naming the field, nothing changed", test_crafted_refused},
    {"steps and times: any finite value the integrator accepts restores (h = -1.06e270, t = 1e305, h = 1e290, |q| = inf)",
     test_extreme_steps},
    {"a midpoint start reversed before its first step: its checkpoint restores, its steps go backward",
     test_reverse_at_start},
    {"byte order: little-endian by construction; a big-endian writer's checkpoint refused by name", test_byte_order},
    {"the run driver's state saved and restored by the library; the run continues bit for bit", test_run_state},
    {"land through psi = 0 (estimate, dense output, events): resumed at each crossing, bit for bit; the estimate "
     "only where the integrator estimates",
     test_land_crossings},
    {"the run state's field list names every member of dth_run_state and dth_step_info", test_run_fields_cover},
    {"regularizer tables: layout 2 refused, bad field lists named, state_loaded's veto", test_reg_tables},
    {"the public field codec: round trip, truncation, checks, strings, memory", test_fields_codec},
    CU_TEST_INFO_NULL,
};

CU_SuiteInfo dth_test_suites[] = {
    {.pName = "ckpt_fields", .pTests = fields_tests},
    CU_SUITE_INFO_NULL,
};
