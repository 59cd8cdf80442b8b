/* SPDX-License-Identifier: MIT */
/*
 * Bad input gets a clear error and loses nothing: a failed step leaves the integrator's whole
 * state bit for bit as it was (for every failure status we can provoke: DTH_ENOCONV, DTH_EDOMAIN
 * from a model returning NaN or leaving its domain, DTH_ESINGULAR, and the raw DTH termination
 * of the rotating pendulum, paper section 5), and every model rejects bad parameters with a
 * message naming the key.
 */
#include <math.h>
#include <stdio.h>
#include <string.h>
#include "cu_main.h"
#include "dth/dth.h"
#include "integrator_impl.h"

/* ---- a bitwise snapshot of everything a step may change ---- */

enum { MAXN = 16 };

typedef struct snap {
    double z[MAXN], zlo[MAXN], zbar[MAXN], dprev[MAXN], dprev2[MAXN], dprev3[MAXN];
    double lam, lam2, lam3, lam_hint, dir, h;
    int nhist, have_prev, have_mid, pending_exact, fact_valid;
    long steps;
} snap;

static void take(const dth_integrator *it, snap *s)
{
    memset(s, 0, sizeof *s);
    size_t N = it->N, m = (size_t)it->m;
    CU_ASSERT_FATAL(N <= MAXN && m <= MAXN);
    memcpy(s->z, it->z, N * sizeof *s->z);
    memcpy(s->zlo, it->zlo, N * sizeof *s->zlo);
    memcpy(s->zbar, it->zbar, N * sizeof *s->zbar);
    memcpy(s->dprev, it->dprev, N * sizeof *s->dprev);
    memcpy(s->dprev2, it->dprev2, N * sizeof *s->dprev2);
    memcpy(s->dprev3, it->dprev3, N * sizeof *s->dprev3);
    s->lam = it->lam;
    s->lam2 = it->lam2;
    s->lam3 = it->lam3;
    s->nhist = it->nhist;
    s->lam_hint = it->lam_hint;
    s->dir = it->dir;
    s->h = it->opt.h;
    s->have_prev = it->have_prev;
    s->have_mid = it->have_mid;
    s->pending_exact = it->pending_exact;
    s->fact_valid = it->fact_valid;
    s->steps = it->steps;
}

/* Bitwise equality (memcmp: -0.0 vs 0.0 and NaN payloads count as changes). */
static int same(const snap *a, const snap *b) { return memcmp(a, b, sizeof *a) == 0; }

/* Step until the first failure (at most `max` steps); check the state it leaves. */
static int step_until_failure(dth_integrator *it, long max, long *at)
{
    snap before, after;
    for (long k = 0; k < max; k++) {
        take(it, &before);
        dth_step_info info;
        int rc = dth_integrator_step(it, &info);
        if (rc == DTH_OK) continue;
        take(it, &after);
        CU_ASSERT(same(&before, &after));
        /* The public view agrees, and a retry fails the same way (nothing was half-committed). */
        CU_ASSERT(dth_integrator_steps(it) == before.steps);
        CU_ASSERT(dth_integrator_step(it, &info) == rc);
        take(it, &after);
        CU_ASSERT(same(&before, &after));
        CU_ASSERT(strcmp(dth_integrator_errmsg(it), "no error") != 0);
        *at = k;
        return rc;
    }
    *at = max;
    return DTH_OK;
}

static dth_model *new_model(const dth_model_type *t, const dth_kv *kv, size_t nkv, size_t n)
{
    dth_model *m = NULL;
    char err[256];
    int rc = dth_model_new(t, kv, nkv, n, NULL, &m, err, sizeof err);
    if (rc) fprintf(stderr, "dth_model_new(%s): %s\n", t->name, err);
    CU_ASSERT_FATAL(rc == DTH_OK);
    return m;
}

static dth_integrator *new_integrator(const dth_model *m, double h, dth_start start, int max_iter)
{
    dth_options o;
    dth_options_default(&o);
    o.h = h;
    o.start = start;
    o.max_iter = max_iter;
    dth_integrator *it = NULL;
    CU_ASSERT_FATAL(dth_integrator_new(m, &o, &it) == DTH_OK);
    return it;
}

/* ---- DTH_ENOCONV: one Newton iteration is never enough from a vertex start ---- */

static void test_enoconv(void)
{
    dth_model *m = new_model(&dth_model_pendulum, NULL, 0, 1);
    dth_integrator *it = new_integrator(m, 0.1, DTH_START_VERTEX, 1);
    double q = 0.8, p = 0.3;
    CU_ASSERT_FATAL(dth_integrator_start(it, &q, &p, 0) == DTH_OK);
    long at;
    CU_ASSERT(step_until_failure(it, 5, &at) == DTH_ENOCONV);
    CU_ASSERT(at == 0);
    dth_integrator_free(it);
    /* and after a good history (the exact first step of a midpoint start needs no Newton) */
    it = new_integrator(m, 0.1, DTH_START_MIDPOINT, 1);
    CU_ASSERT_FATAL(dth_integrator_start(it, &q, &p, 0) == DTH_OK);
    CU_ASSERT(step_until_failure(it, 5, &at) == DTH_ENOCONV);
    CU_ASSERT(at == 1);
    dth_integrator_free(it);
    dth_model_free(m);
}

/* ---- DTH_EDOMAIN: an oscillator defined only for q < 0.5, as NaN or as "outside" ---- */

typedef struct wall {
    int nan_mode; /* 1: return NaN outside; 0: return > 0 (outside the domain) */
} wall;

static int wall_create(const dth_model_args *a, void **self, dth_model_info *info)
{
    wall *w = dth_calloc(a->alloc, 1, sizeof *w);
    if (!w) return DTH_ENOMEM;
    w->nan_mode = a->nkv > 0;
    *self = w;
    *info = (dth_model_info){.n = 1, .autonomous = 1, .separable = 1};
    return DTH_OK;
}

static void wall_destroy(void *self, const dth_allocator *al) { dth_free(al, self); }

static int wall_eval(const void *self, const double *y, unsigned what, double *H, double *g, double *h)
{
    const wall *w = self;
    double q = y[0], p = y[2], bad = q >= 0.5 ? NAN : 0.0;
    if (q >= 0.5 && !w->nan_mode) return 1;
    if (what & DTH_EVAL_H) *H = 0.5 * (p * p + q * q) + bad;
    if (what & DTH_EVAL_GRAD) {
        g[0] = q + bad;
        g[1] = 0;
        g[2] = p;
    }
    if (what & DTH_EVAL_HESS) {
        for (int i = 0; i < 9; i++) h[i] = 0;
        h[0] = 1 + bad;
        h[8] = 1;
    }
    return 0;
}

static const dth_param_spec wall_params[] = {{"nan", NULL, "return NaN outside (any value)"}};
static const dth_model_type wall_type = {
    .name = "wall", .doc = "oscillator defined for q < 0.5", .params = wall_params, .n_params = 1,
    .create = wall_create, .destroy = wall_destroy, .eval = wall_eval,
};

static void test_edomain(void)
{
    static const dth_kv nan_kv[] = {{"nan", "1"}};
    for (int mode = 0; mode < 2; mode++) {
        dth_model *m = new_model(&wall_type, nan_kv, (size_t)mode, 1);
        for (int start = 0; start < 2; start++) {
            dth_integrator *it = new_integrator(m, 0.05, start ? DTH_START_VERTEX : DTH_START_MIDPOINT, 30);
            double q = 0, p = 1;
            CU_ASSERT_FATAL(dth_integrator_start(it, &q, &p, 0) == DTH_OK);
            long at;
            int rc = step_until_failure(it, 200, &at);
            CU_ASSERT(rc == DTH_EDOMAIN);
            CU_ASSERT(at > 3 && at < 200); /* q reaches 0.5 at t = asin(0.5) = 0.52, step ~10 */
            /* the last accepted midpoint is inside the domain (vertices may lie outside) */
            CU_ASSERT(dth_integrator_midpoint(it) && dth_integrator_midpoint(it)[0] < 0.5);
            dth_integrator_free(it);
        }
        /* the start itself outside the domain: refused, nothing placed */
        dth_integrator *it = new_integrator(m, 0.05, DTH_START_MIDPOINT, 30);
        double q = 0.7, p = 0;
        CU_ASSERT(dth_integrator_start(it, &q, &p, 0) == DTH_EDOMAIN);
        CU_ASSERT(dth_integrator_steps(it) == 0);
        CU_ASSERT(dth_integrator_midpoint(it) == NULL);
        dth_integrator_free(it);
        dth_model_free(m);
    }
}

/* ---- DTH_ESINGULAR: H_phys = 0 makes the bordering row grad H^T vanish ---- */

static int flat_create(const dth_model_args *a, void **self, dth_model_info *info)
{
    (void)a;
    *self = NULL;
    *info = (dth_model_info){.n = 1, .autonomous = 1, .separable = 1};
    return DTH_OK;
}

static int flat_eval(const void *self, const double *y, unsigned what, double *H, double *g, double *h)
{
    if (what & DTH_EVAL_H) *H = 0;
    if (what & DTH_EVAL_GRAD) g[0] = g[1] = g[2] = 0;
    if (what & DTH_EVAL_HESS)
        for (int i = 0; i < 9; i++) h[i] = 0;
    return 0;
}

static const dth_model_type flat_type = {.name = "flat", .doc = "H_phys = 0", .create = flat_create,
                                         .eval = flat_eval};

static void test_esingular(void)
{
    dth_model *m = new_model(&flat_type, NULL, 0, 1);
    {
        /* no vertex offset gives a first step of h here: the vertex start is refused, naming h */
        dth_integrator *it = new_integrator(m, 0.1, DTH_START_VERTEX, 30);
        double q = 0.3, p = -0.2;
        CU_ASSERT_EQUAL(dth_integrator_start(it, &q, &p, 1.0), DTH_ENOROOT);
        CU_ASSERT_PTR_NOT_NULL(strstr(dth_integrator_errmsg(it), "h = 0.1"));
        dth_integrator_free(it);
    }
    for (int start = 0; start < 2; start++) {
        dth_integrator *it = new_integrator(m, 0.1, DTH_START_MIDPOINT, 30);
        if (start) {
            /* a vertex start with an explicit wp */
            dth_integrator_free(it);
            dth_options o;
            dth_options_default(&o);
            o.h = 0.1;
            o.start = DTH_START_VERTEX;
            o.has_wp = 1;
            o.wp = 0.25;
            CU_ASSERT_FATAL(dth_integrator_new(m, &o, &it) == DTH_OK);
        }
        double q = 0.3, p = -0.2;
        CU_ASSERT_FATAL(dth_integrator_start(it, &q, &p, 1.0) == DTH_OK);
        long at;
        CU_ASSERT(step_until_failure(it, 3, &at) == DTH_ESINGULAR);
        /* a midpoint start's first step solves the equations exactly (lambda = h) without a
         * factorization; the first Newton step is singular */
        CU_ASSERT(at == (start ? 0 : 1));
        dth_integrator_free(it);
    }
    dth_model_free(m);
}

/* ---- the rotating pendulum terminates (raw DTH, no regularizer): a recoverable status ---- */

static void test_rotating_pendulum_termination(void)
{
    dth_model *m = new_model(&dth_model_pendulum, NULL, 0, 1);
    dth_integrator *it = new_integrator(m, 0.05, DTH_START_VERTEX, 30);
    double q = 0, p = 2.2;
    CU_ASSERT_FATAL(dth_integrator_start(it, &q, &p, 0) == DTH_OK);
    long at;
    int rc = step_until_failure(it, 5000, &at);
    printf("  [rotating pendulum: %s after %ld steps, t = %.6g]\n", dth_status_name(rc), at,
           dth_integrator_vertex(it)[1]);
    CU_ASSERT(rc > 0); /* recoverable: the caller may regularize */
    CU_ASSERT(at < 5000);
    for (size_t j = 0; j < 4; j++) CU_ASSERT(isfinite(dth_integrator_vertex(it)[j]));
    dth_integrator_free(it);
    dth_model_free(m);
}

/* ---- parameter validation: messages name the key ---- */

static void expect_rejected2(const dth_model_type *t, const char *key, const char *value, const char *key2,
                             const char *value2, size_t n_hint, const char *must_name)
{
    dth_kv kv[] = {{key, value}, {key2, value2}};
    dth_model *m = (dth_model *)kv;
    char err[256] = "";
    int rc = dth_model_new(t, kv, key2 ? 2 : 1, n_hint, NULL, &m, err, sizeof err);
    if (rc != DTH_EINVAL || !strstr(err, must_name))
        fprintf(stderr, "model '%s' %s=%s: %s, message '%s'\n", t->name, key, value, dth_status_name(rc), err);
    CU_ASSERT(rc == DTH_EINVAL);
    CU_ASSERT(m == NULL);
    CU_ASSERT(strstr(err, must_name) != NULL);
    if (rc == DTH_OK) dth_model_free(m);
}

static void expect_rejected(const dth_model_type *t, const char *key, const char *value, size_t n_hint,
                            const char *must_name)
{
    expect_rejected2(t, key, value, NULL, NULL, n_hint, must_name);
}

static void test_param_messages(void)
{
    const dth_model_type *P = &dth_model_pendulum, *Hm = &dth_model_harmonic;
    expect_rejected(P, "omega2", "0", 1, "omega2");
    expect_rejected(P, "omega2", "-1", 1, "omega2");
    expect_rejected(P, "omega2", "nan", 1, "omega2");
    expect_rejected(P, "omega2", "inf", 1, "omega2");
    expect_rejected(P, "omega2", "1e400", 1, "omega2");
    expect_rejected(P, "omega2", "1.5x", 1, "omega2");
    expect_rejected(P, "omega2", "", 1, "omega2");
    expect_rejected(P, "omgea2", "1", 1, "omgea2");
    expect_rejected(Hm, "mass", "-1", 2, "mass");
    expect_rejected(Hm, "mass", "1,0", 2, "mass");
    expect_rejected2(Hm, "n", "3", "mass", "1,2", 3, "mass");
    /* with 3 q values n = 3, so the 2-value mass list is the odd one out; without a hint the
     * mass list sets n = 2 and the omega list is */
    expect_rejected2(Hm, "mass", "1,2", "omega", "1,2,3", 3, "mass");
    expect_rejected2(Hm, "mass", "1,2", "omega", "1,2,3", 0, "omega");
    expect_rejected(Hm, "mass", "1,,2", 3, "mass");
    expect_rejected(Hm, "mass", "1,nan", 2, "mass");
    expect_rejected(Hm, "omega", "0", 1, "omega");
    expect_rejected(Hm, "omega", "1,-2", 2, "omega");
    expect_rejected(Hm, "omega", "abc", 2, "omega");
    expect_rejected(Hm, "n", "1.5", 1, "'n'");
    expect_rejected(Hm, "n", "-2", 1, "'n'");
    expect_rejected(Hm, "n", "1e9", 1, "'n'");
    expect_rejected(Hm, "massx", "1", 1, "massx");
    /* Every registered model: starting from a configuration that builds, a numeric key given
     * a non-number, "1.5x", is rejected naming the key; an unknown key likewise. */
    static const dth_kv coupled_kv[] = {{"preset", "chain"}, {"size", "4"}, {"dim", "2"}, {"L", "0.5"}};
    dth_registry *r;
    CU_ASSERT_FATAL(dth_registry_new(NULL, &r) == DTH_OK);
    CU_ASSERT_FATAL(dth_registry_add_builtin(r) == DTH_OK);
    for (size_t i = 0; i < dth_registry_model_count(r); i++) {
        const dth_model_type *t = dth_registry_model_at(r, i);
        const dth_kv *base = strcmp(t->name, "coupled") == 0 ? coupled_kv : NULL;
        size_t nbase = base ? 4 : 0;
        dth_model *m = NULL;
        size_t nh = 1;
        while (nh <= 8 && dth_model_new(t, base, nbase, nh, NULL, &m, NULL, 0) != DTH_OK) nh++;
        CU_ASSERT_FATAL(nh <= 8);
        dth_model_free(m);
        for (size_t k = 0; k <= t->n_params; k++) {
            const char *key = k < t->n_params ? t->params[k].key : "no_such_key";
            const char *val = k < t->n_params ? "1.5x" : "1";
            if (strchr(key, '*')) continue;
            dth_kv kv[8];
            size_t nkv = 0, j;
            for (j = 0; j < nbase; j++) kv[nkv++] = base[j];
            for (j = 0; j < nkv && strcmp(kv[j].key, key) != 0; j++) {}
            kv[j] = (dth_kv){key, val};
            if (j == nkv) nkv++;
            char err[256] = "";
            m = NULL;
            int rc = dth_model_new(t, kv, nkv, nh, NULL, &m, err, sizeof err);
            if (rc != DTH_EINVAL || !strstr(err, key))
                fprintf(stderr, "model '%s' %s=%s: %s, message '%s'\n", t->name, key, val, dth_status_name(rc), err);
            CU_ASSERT(rc == DTH_EINVAL);
            CU_ASSERT(m == NULL);
            CU_ASSERT(strstr(err, key) != NULL);
            dth_model_free(m);
        }
    }
    dth_registry_free(r);
}

/* ---- regressions found by fuzz/fuzz_integrator: DTH_OK must never leave a non-finite state ---- */

static int finite_vec(const double *x, size_t n)
{
    for (size_t i = 0; i < n; i++)
        if (!isfinite(x[i])) return 0;
    return 1;
}

/* Midpoint start with h |J grad H| beyond DBL_MAX: z_0 = zbar_0 - (h/2) J grad H overflows. */
static void test_fuzz_start_overflow(void)
{
    static const dth_kv kv[] = {{"n", "1"}, {"mass", "9.8931899965962e-309"}, {"omega", "3.6455616209129865e-304"}};
    dth_model *m = new_model(&dth_model_harmonic, kv, 3, 1);
    dth_integrator *it = new_integrator(m, -3.2007034655896856e+231, DTH_START_MIDPOINT, 30);
    double q = 0.5, p = 0.5;
    int rc = dth_integrator_start(it, &q, &p, 0.5);
    if (rc == DTH_OK) CU_ASSERT(finite_vec(dth_integrator_vertex(it), 4));
    if (rc == DTH_OK && dth_integrator_step(it, NULL) == DTH_OK) CU_ASSERT(finite_vec(dth_integrator_vertex(it), 4));
    dth_integrator_free(it);
    dth_model_free(m);
}

/* A step whose new vertex z + 2 (zbar - z) overflows although the midpoint is finite. */
static void test_fuzz_step_overflow(void)
{
    static const dth_kv kv[] = {{"preset", "chain"}, {"size", "2"}, {"dim", "1"}, {"k", "3.43519951892224e-310"},
                                {"L", "3.2194903e-317"}, {"mass", "1.836709924525607e-39"}};
    dth_model *m = new_model(&dth_model_coupled, kv, 6, 2);
    size_t N = 2 * dth_model_dof(m) + 2;
    CU_ASSERT_FATAL(N == 6);
    dth_options o;
    dth_options_default(&o);
    o.h = -1.0565892344930458e+270;
    o.K = 3.919106652168698e+202;
    o.max_iter = 1;
    dth_integrator *it = NULL;
    CU_ASSERT_FATAL(dth_integrator_new(m, &o, &it) == DTH_OK);
    double q[2] = {6.507473426500481e-307, 0.5}, p[2] = {0.5, 0.5};
    int rc = dth_integrator_start(it, q, p, -2.723462048819236e+154);
    int ok = rc != DTH_OK || finite_vec(dth_integrator_vertex(it), N);
    for (int k = 0; rc == DTH_OK && k < 5; k++) {
        rc = dth_integrator_step(it, NULL);
        if (rc == DTH_OK && !finite_vec(dth_integrator_vertex(it), N)) ok = 0;
    }
    CU_ASSERT(ok);
    dth_integrator_free(it);
    dth_model_free(m);
}

static CU_TestInfo failstate_tests[] = {
    {"DTH_ENOCONV (max_iter = 1) leaves the state untouched", test_enoconv},
    {"DTH_EDOMAIN (NaN / outside the domain) leaves the state untouched", test_edomain},
    {"DTH_ESINGULAR (H_phys = 0) leaves the state untouched", test_esingular},
    {"rotating pendulum termination: recoverable status, state untouched", test_rotating_pendulum_termination},
    {"bad model parameters: DTH_EINVAL naming the key", test_param_messages},
    {"fuzz regression: midpoint start overflow gives no DTH_OK with a non-finite vertex", test_fuzz_start_overflow},
    {"fuzz regression: a step whose vertex overflows is not DTH_OK", test_fuzz_step_overflow},
    CU_TEST_INFO_NULL,
};

CU_SuiteInfo dth_test_suites[] = {
    {.pName = "failstate", .pTests = failstate_tests},
    CU_SUITE_INFO_NULL,
};
