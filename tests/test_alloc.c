/* SPDX-License-Identifier: MIT */
/*
 * Allocation failure paths: every allocation of dth_model_new (each registered model),
 * dth_integrator_new and the registry is made to fail in turn; each must return DTH_ENOMEM,
 * leave *out NULL and free everything it took. Also: stepping allocates nothing.
 */
#include <stdio.h>
#include <string.h>
#include "cu_main.h"
#include "dth/dth.h"
#include "failing_alloc.h"

/* Parameters for models whose defaults alone do not define an instance (as in test_models). */
static const dth_kv coupled_kv[] = {{"preset", "chain"}, {"size", "4"}, {"dim", "2"}, {"L", "0.5"}};
static const dth_kv harmonic_kv[] = {{"mass", "1,2,3"}, {"omega", "1,0.5,2"}};

/* A parameter set that builds an instance of `t` with plain malloc; 0 if found. */
static int find_config(const dth_model_type *t, const dth_kv **kv, size_t *nkv, size_t *n_hint)
{
    char err[256];
    dth_model *m = NULL;
    const dth_kv *cand[] = {NULL, NULL};
    size_t ncand[] = {0, 0};
    if (strcmp(t->name, "coupled") == 0) {
        cand[0] = coupled_kv;
        ncand[0] = 4;
    } else if (strcmp(t->name, "harmonic") == 0) {
        cand[0] = harmonic_kv;
        ncand[0] = 2;
    }
    for (int c = 0; c < 2; c++)
        for (size_t n = 1; n <= 8; n++) {
            if (dth_model_new(t, cand[c], ncand[c], n, NULL, &m, err, sizeof err) == DTH_OK) {
                dth_model_free(m);
                *kv = cand[c];
                *nkv = ncand[c];
                *n_hint = n;
                return 0;
            }
        }
    return -1;
}

static void model_new_each_failure(const dth_model_type *t)
{
    const dth_kv *kv;
    size_t nkv, nh;
    if (find_config(t, &kv, &nkv, &nh)) {
        fprintf(stderr, "no configuration builds model '%s'\n", t->name);
        CU_FAIL("model without a working configuration");
        return;
    }
    failing_alloc fa;
    dth_allocator al = failing_alloc_make(&fa, 0);
    dth_model *m = NULL;
    char err[256];
    CU_ASSERT_FATAL(dth_model_new(t, kv, nkv, nh, &al, &m, err, sizeof err) == DTH_OK);
    long total = fa.count;
    CU_ASSERT(total >= 1);
    CU_ASSERT(fa.live >= 1);
    dth_model_free(m);
    CU_ASSERT(fa.live == 0);
    for (long k = 1; k <= total; k++) {
        al = failing_alloc_make(&fa, k);
        m = (dth_model *)&fa; /* must be reset to NULL */
        err[0] = '\0';
        int rc = dth_model_new(t, kv, nkv, nh, &al, &m, err, sizeof err);
        if (rc != DTH_ENOMEM || m != NULL || fa.live != 0 || fa.failed != 1)
            fprintf(stderr, "model '%s', failing allocation %ld of %ld: rc %s, live %ld\n", t->name, k,
                    total, dth_status_name(rc), fa.live);
        CU_ASSERT(rc == DTH_ENOMEM);
        CU_ASSERT(m == NULL);
        CU_ASSERT(fa.live == 0);
        CU_ASSERT(fa.failed == 1);
        CU_ASSERT(err[0] != '\0');
        if (rc == DTH_OK) dth_model_free(m);
    }
}

static void test_model_new_enomem(void)
{
    dth_registry *r;
    CU_ASSERT_FATAL(dth_registry_new(NULL, &r) == DTH_OK);
    CU_ASSERT_FATAL(dth_registry_add_builtin(r) == DTH_OK);
    CU_ASSERT(dth_registry_model_count(r) >= 2);
    for (size_t i = 0; i < dth_registry_model_count(r); i++) model_new_each_failure(dth_registry_model_at(r, i));
    dth_registry_free(r);
}

static void integrator_new_each_failure(const dth_model *m)
{
    failing_alloc fa;
    dth_allocator al = failing_alloc_make(&fa, 0);
    dth_options o;
    dth_options_default(&o);
    o.alloc = &al;
    dth_integrator *it = NULL;
    CU_ASSERT_FATAL(dth_integrator_new(m, &o, &it) == DTH_OK);
    long total = fa.count;
    CU_ASSERT(total >= 1);
    /* Start and stepping allocate nothing (engineering rule: no allocation in a step loop). */
    size_t n = dth_model_dof(m);
    double q0[16] = {0}, p0[16] = {0};
    for (size_t i = 0; i < n && i < 16; i++) {
        q0[i] = 0.1 + 0.9 * (double)i;
        p0[i] = 0.2;
    }
    if (n <= 16 && dth_integrator_start(it, q0, p0, 0) == DTH_OK) {
        for (int s = 0; s < 20; s++) dth_integrator_step(it, NULL);
        CU_ASSERT(fa.count == total);
    }
    dth_integrator_free(it);
    CU_ASSERT(fa.live == 0);
    for (long k = 1; k <= total; k++) {
        al = failing_alloc_make(&fa, k);
        it = (dth_integrator *)&fa;
        int rc = dth_integrator_new(m, &o, &it);
        CU_ASSERT(rc == DTH_ENOMEM);
        CU_ASSERT(it == NULL);
        CU_ASSERT(fa.live == 0);
        CU_ASSERT(fa.failed == 1);
        if (rc == DTH_OK) dth_integrator_free(it);
    }
}

static void test_integrator_new_enomem(void)
{
    dth_registry *r;
    CU_ASSERT_FATAL(dth_registry_new(NULL, &r) == DTH_OK);
    CU_ASSERT_FATAL(dth_registry_add_builtin(r) == DTH_OK);
    for (size_t i = 0; i < dth_registry_model_count(r); i++) {
        const dth_model_type *t = dth_registry_model_at(r, i);
        const dth_kv *kv;
        size_t nkv, nh;
        dth_model *m = NULL;
        if (find_config(t, &kv, &nkv, &nh)) continue; /* reported by test_model_new_enomem */
        CU_ASSERT_FATAL(dth_model_new(t, kv, nkv, nh, NULL, &m, NULL, 0) == DTH_OK);
        integrator_new_each_failure(m);
        dth_model_free(m);
    }
    dth_registry_free(r);
}

enum { NFAKE = 20 };

/* Registry: new, then 20 registrations (the table grows past its first capacity). */
static int registry_scenario(const dth_allocator *al, const dth_model_type *fake, int *stage)
{
    dth_registry *r = NULL;
    *stage = 0;
    int rc = dth_registry_new(al, &r);
    if (rc) {
        CU_ASSERT(r == NULL);
        return rc;
    }
    for (int i = 0; i < NFAKE && !rc; i++) {
        size_t before = dth_registry_model_count(r);
        rc = dth_registry_add_model(r, &fake[i]);
        /* a failed add leaves the registry as it was, still usable */
        if (rc) {
            CU_ASSERT(dth_registry_model_count(r) == before);
            for (size_t j = 0; j < before; j++) CU_ASSERT(dth_registry_model_at(r, j) == &fake[j]);
            CU_ASSERT(dth_registry_find_model(r, fake[i].name) == NULL);
        }
        *stage = i + 1;
    }
    if (!rc) {
        CU_ASSERT(dth_registry_model_count(r) == NFAKE);
        CU_ASSERT(dth_registry_find_model(r, "m19") == &fake[19]);
    }
    dth_registry_free(r);
    return rc;
}

static void test_registry_enomem(void)
{
    dth_model_type fake[NFAKE];
    char names[NFAKE][8];
    for (int i = 0; i < NFAKE; i++) {
        fake[i] = dth_model_pendulum;
        snprintf(names[i], sizeof names[i], "m%d", i);
        fake[i].name = names[i];
    }
    failing_alloc fa;
    dth_allocator al = failing_alloc_make(&fa, 0);
    int stage;
    CU_ASSERT_FATAL(registry_scenario(&al, fake, &stage) == DTH_OK);
    long total = fa.count;
    CU_ASSERT(total >= 3); /* the registry, its first table, one growth */
    CU_ASSERT(fa.live == 0);
    for (long k = 1; k <= total; k++) {
        al = failing_alloc_make(&fa, k);
        CU_ASSERT(registry_scenario(&al, fake, &stage) == DTH_ENOMEM);
        CU_ASSERT(fa.live == 0);
        CU_ASSERT(fa.failed == 1);
    }
}

/* scene: new, load (from memory), override, setup into a run setup, clear, free */
static int scene_scenario(const dth_allocator *al, const dth_registry *reg)
{
    static const char text[] = "[model]\nname = harmonic\nomega = 1,\n  2\n[initial]\nq = 1, 0.5\np = 0, 0\n"
                               "[integrator]\nh = 0.1\nsteps = 10\n[regularize]\nmethod = land\nkappa = 0.02\n"
                               "[output]\nfile = out.csv\n";
    char err[256];
    dth_scene *s = NULL;
    int rc = dth_scene_new(al, &s);
    if (rc) {
        CU_ASSERT(s == NULL);
        return rc;
    }
    rc = dth_scene_load_mem(s, "alloc.ini", text, sizeof text - 1, err, sizeof err);
    if (!rc) {
        rc = dth_scene_set(s, "integrator.steps=20", err, sizeof err);
        if (rc) CU_ASSERT_STRING_EQUAL(dth_scene_get(s, "integrator", "steps"), "10"); /* unchanged */
    }
    if (!rc) {
        dth_run_setup rs;
        memset(&rs, 0, sizeof rs);
        rc = dth_scene_setup(s, reg, &rs, err, sizeof err);
        if (!rc) {
            CU_ASSERT(rs.steps == 20 && rs.n == 2 && rs.regularizer != NULL);
            dth_run_setup_clear(&rs);
        } else {
            CU_ASSERT(rs.model == NULL && rs.q0 == NULL); /* untouched on failure */
        }
    }
    dth_scene_free(s);
    return rc;
}

static void test_scene_enomem(void)
{
    dth_registry *reg = NULL;
    CU_ASSERT_FATAL(dth_registry_new(NULL, &reg) == DTH_OK);
    CU_ASSERT_FATAL(dth_registry_add_builtin(reg) == DTH_OK);
    failing_alloc fa;
    dth_allocator al = failing_alloc_make(&fa, 0);
    CU_ASSERT_FATAL(scene_scenario(&al, reg) == DTH_OK);
    long total = fa.count;
    CU_ASSERT(total >= 10);
    CU_ASSERT(fa.live == 0);
    for (long k = 1; k <= total; k++) {
        al = failing_alloc_make(&fa, k);
        int rc = scene_scenario(&al, reg);
        CU_ASSERT(rc == DTH_ENOMEM);
        if (rc != DTH_ENOMEM) printf("  [scene: allocation %ld of %ld failed, status %s]\n", k, total, dth_status_name(rc));
        CU_ASSERT(fa.live == 0);
        CU_ASSERT(fa.failed == 1);
    }
    dth_registry_free(reg);
}

static CU_TestInfo alloc_tests[] = {
    {"scene new/load/set/setup: each allocation fails in turn", test_scene_enomem},
    {"dth_model_new: each allocation fails in turn", test_model_new_enomem},
    {"dth_integrator_new: each allocation fails in turn; steps allocate nothing", test_integrator_new_enomem},
    {"registry: each allocation fails in turn", test_registry_enomem},
    CU_TEST_INFO_NULL,
};

CU_SuiteInfo dth_test_suites[] = {
    {.pName = "alloc", .pTests = alloc_tests},
    CU_SUITE_INFO_NULL,
};
