/* SPDX-License-Identifier: MIT */
/*
 * Determinism: the same model and start give bit-identical trajectories run after run, whatever
 * ran before, with any allocator, and with two integrators interleaved step by step (no hidden
 * or shared state). Across builds (-O0 / -O2, gcc / clang) see scripts/ci-determinism.sh.
 */
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include "cu_main.h"
#include "dth/dth.h"
#include "failing_alloc.h"

enum { STEPS = 150, MAXD = 64 };

static const dth_kv coupled_kv[] = {{"preset", "chain"}, {"size", "4"}, {"dim", "2"}, {"L", "0.5"}};

static dth_model *make_model(const dth_model_type *t, const dth_allocator *al)
{
    dth_model *m = NULL;
    if (strcmp(t->name, "coupled") == 0 && dth_model_new(t, coupled_kv, 4, 8, al, &m, NULL, 0) == DTH_OK)
        return m;
    for (size_t n = 2; n >= 1; n--)
        if (dth_model_new(t, NULL, 0, n, al, &m, NULL, 0) == DTH_OK) return m;
    return NULL;
}

typedef struct traj {
    double z[STEPS][MAXD];
    double lam[STEPS];
    int rc[STEPS];
} traj;

static dth_integrator *start(const dth_model *m, const dth_allocator *al, dth_start st)
{
    dth_options o;
    dth_options_default(&o);
    o.h = 0.04;
    o.start = st;
    o.alloc = al;
    dth_integrator *it = NULL;
    CU_ASSERT_FATAL(dth_integrator_new(m, &o, &it) == DTH_OK);
    size_t n = dth_model_dof(m);
    double q[31], p[31];
    for (size_t i = 0; i < n; i++) {
        q[i] = 0.35 + 0.9 * (double)i;
        p[i] = i % 2 ? -0.3 : 0.4;
    }
    CU_ASSERT_FATAL(dth_integrator_start(it, q, p, 0.0) == DTH_OK);
    return it;
}

static void one_step(dth_integrator *it, traj *t, int k)
{
    dth_step_info info;
    t->rc[k] = dth_integrator_step(it, &info);
    t->lam[k] = info.lambda;
    memcpy(t->z[k], dth_integrator_vertex(it), dth_integrator_dim(it) * sizeof(double));
}

static void run(const dth_model *m, const dth_allocator *al, dth_start st, traj *t)
{
    memset(t, 0, sizeof *t);
    dth_integrator *it = start(m, al, st);
    for (int k = 0; k < STEPS; k++) one_step(it, t, k);
    dth_integrator_free(it);
}

static void test_repeatable(void)
{
    traj *a = calloc(1, sizeof *a), *b = calloc(1, sizeof *b), *c = calloc(1, sizeof *c), *d = calloc(1, sizeof *d);
    CU_ASSERT_FATAL(a && b && c && d);
    dth_registry *reg;
    CU_ASSERT_FATAL(dth_registry_new(NULL, &reg) == DTH_OK);
    CU_ASSERT_FATAL(dth_registry_add_builtin(reg) == DTH_OK);
    failing_alloc fa;
    dth_allocator al = failing_alloc_make(&fa, 0);
    for (size_t i = 0; i < dth_registry_model_count(reg); i++) {
        const dth_model_type *type = dth_registry_model_at(reg, i);
        dth_model *m = make_model(type, NULL), *m2 = make_model(type, &al);
        CU_ASSERT_FATAL(m != NULL && m2 != NULL);
        CU_ASSERT_FATAL(2 * dth_model_dof(m) + 2 <= MAXD);
        for (int s = 0; s < 2; s++) {
            dth_start st = s ? DTH_START_VERTEX : DTH_START_MIDPOINT;
            run(m, NULL, st, a);
            run(m, NULL, st, b);   /* again, after a run: nothing carried over */
            run(m2, &al, st, c);   /* another instance, another allocator */
            /* two integrators interleaved step by step on one model */
            memset(d, 0, sizeof *d);
            memset(b, 0, sizeof *b);
            dth_integrator *x = start(m, NULL, st), *y = start(m, NULL, st);
            for (int k = 0; k < STEPS; k++) {
                one_step(x, d, k);
                one_step(y, b, k);
            }
            dth_integrator_free(x);
            dth_integrator_free(y);
            int ok = memcmp(a, c, sizeof *a) == 0 && memcmp(a, d, sizeof *a) == 0 && memcmp(a, b, sizeof *a) == 0;
            if (!ok) printf("  [%s start %d: runs differ]\n", type->name, s);
            CU_ASSERT(ok);
            int steps_ok = 0;
            for (int k = 0; k < STEPS; k++) steps_ok += a->rc[k] == DTH_OK;
            CU_ASSERT(steps_ok >= 10); /* the comparison covers real steps */
        }
        dth_model_free(m);
        dth_model_free(m2);
    }
    CU_ASSERT(fa.live == 0);
    dth_registry_free(reg);
    free(a);
    free(b);
    free(c);
    free(d);
}

static CU_TestInfo determinism_tests[] = {
    {"bit-identical runs: repeated, other allocator, interleaved integrators", test_repeatable},
    CU_TEST_INFO_NULL,
};

CU_SuiteInfo dth_test_suites[] = {
    {.pName = "determinism", .pTests = determinism_tests},
    CU_SUITE_INFO_NULL,
};
