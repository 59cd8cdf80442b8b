/* SPDX-License-Identifier: MIT */
/*
 * Bad input gets a clear error and loses nothing: a failed step leaves the integrator's whole
 * state bit for bit as it was (for every failure status we can provoke: DTH_ENOCONV, DTH_EDOMAIN
 * from a model returning NaN or leaving its domain, DTH_ESINGULAR, and the raw DTH termination
 * of the rotating pendulum, paper section 5), and every model rejects bad parameters with a
 * message naming the key.
 */
#include <math.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include "cu_main.h"
#include "dth/dth.h"
#include "test_util.h"

/* ---- the whole serialised state (dth_checkpoint_save: every field of the step state, the
 * options, the regularizer's own state), compared bitwise ---- */

enum { SNAPMAX = 1 << 16 };

typedef struct snap {
    size_t len;
    unsigned char b[SNAPMAX];
} snap;

static void take(const dth_integrator *it, snap *s)
{
    CU_ASSERT_FATAL(dth_checkpoint_save(it, NULL, 0, s->b, sizeof s->b, &s->len) == DTH_OK);
}

static int same(const snap *a, const snap *b) { return a->len == b->len && memcmp(a->b, b->b, a->len) == 0; }

/* Step until the first failure (at most `max` steps); check the state it leaves. */
static int step_until_failure(dth_integrator *it, long max, long *at)
{
    static snap before, after;
    for (long k = 0; k < max; k++) {
        take(it, &before);
        long steps_before = dth_integrator_steps(it);
        dth_step_info info;
        int rc = dth_integrator_step(it, &info);
        if (rc == DTH_OK) continue;
        take(it, &after);
        CU_ASSERT(same(&before, &after));
        /* The public view agrees, and a retry fails the same way (nothing was half-committed). */
        CU_ASSERT(dth_integrator_steps(it) == steps_before);
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
    dth_model *m = model(&dth_model_pendulum, NULL, 0, 1);
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
DTH_MODEL_TYPE_HEAD,
    .name = "wall", .doc = "oscillator defined for q < 0.5", .params = wall_params, .n_params = 1,
    .create = wall_create, .destroy = wall_destroy, .eval = wall_eval,
};

static void test_edomain(void)
{
    static const dth_kv nan_kv[] = {{"nan", "1"}};
    for (int mode = 0; mode < 2; mode++) {
        dth_model *m = model(&wall_type, nan_kv, (size_t)mode, 1);
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

/* Stateless, autonomous, separable, one degree of freedom (flat and fickle below). */
static int one_dof_create(const dth_model_args *a, void **self, dth_model_info *info)
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

static const dth_model_type flat_type = {DTH_MODEL_TYPE_HEAD, .name = "flat", .doc = "H_phys = 0", .create = one_dof_create,
                                         .eval = flat_eval};

static void test_esingular(void)
{
    dth_model *m = model(&flat_type, NULL, 0, 1);
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
    dth_model *m = model(&dth_model_pendulum, NULL, 0, 1);
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

/* ---- with a regularizer attached: its own state and a multi-part commit are undone too ---- */

static dth_integrator *new_integrator_reg(const dth_model *m, double h, dth_start start, dth_regularizer *reg)
{
    dth_options o;
    dth_options_default(&o);
    o.h = h;
    o.start = start;
    o.regularizer = reg;
    dth_integrator *it = NULL;
    CU_ASSERT_FATAL(dth_integrator_new(m, &o, &it) == DTH_OK);
    return it;
}

/* The shipped regularizers where they stop: prescribed on Kepler e = 0.9 without its fallback (no
 * kicked segment of the constant step at pericentre) and with it (the ordinary step it falls back
 * to fails too, after the hook dropped its seed: the seed comes back), raw DTH's own statuses under
 * none, and prescribed on the pendulum with a step too large for a kicked segment. */
static void test_shipped_regularizers(void)
{
    dth_model *kep = model(&dth_model_kepler, NULL, 0, 2), *pen = model(&dth_model_pendulum, NULL, 0, 1);
    static const dth_kv nofb[] = {{"fallback", "no"}};
    struct {
        const dth_model *m;
        const dth_regularizer_type *t;
        const dth_kv *kv;
        size_t nkv;
        double q[2], p[2], h;
        long max;
    } cases[] = {
        {kep, &dth_reg_prescribed, nofb, 1, {-1.9, 0}, {0, -0.22941573387056177}, 0.05, 2000},
        {kep, &dth_reg_prescribed, NULL, 0, {-1.9, 0}, {0, -0.22941573387056177}, 0.05, 2000}, /* fallback */
        {pen, &dth_reg_none, NULL, 0, {0, 0}, {2.2, 0}, 0.05, 2000},
        {pen, &dth_reg_prescribed, nofb, 1, {0, 0}, {2.2, 0}, 2.5, 2000},
    };
    for (size_t c = 0; c < sizeof cases / sizeof cases[0]; c++) {
        dth_regularizer *reg = NULL;
        char err[256] = "";
        CU_ASSERT_FATAL(dth_regularizer_new(cases[c].t, cases[c].kv, cases[c].nkv, cases[c].m, NULL, &reg, err,
                                            sizeof err) == DTH_OK);
        dth_integrator *it = new_integrator_reg(cases[c].m, cases[c].h, DTH_START_MIDPOINT, reg);
        CU_ASSERT_FATAL(dth_integrator_start(it, cases[c].q, cases[c].p, 0) == DTH_OK);
        long at;
        int rc = step_until_failure(it, cases[c].max, &at);
        printf("  [%s with %s: %s after %ld steps: %s]\n", dth_model_get_type(cases[c].m)->name, cases[c].t->name,
               dth_status_name(rc), at, dth_integrator_errmsg(it));
        CU_ASSERT(rc > 0);
        dth_integrator_free(it);
        dth_regularizer_free(reg);
    }
    dth_model_free(kep);
    dth_model_free(pen);
}

/* A harmonic oscillator whose energy alone (DTH_EVAL_H by itself) cannot be evaluated for
 * 0.25 < q < 0.35 while its derivatives can: a failure the integrator meets only after it has
 * committed a regularizer's segment (the carried vertex offset evaluated afresh). */
static int fickle_eval(const void *self, const double *y, unsigned what, double *H, double *g, double *h)
{
    (void)self;
    double q = y[0], p = y[2];
    if (what == DTH_EVAL_H && q > 0.25 && q < 0.35) return 1;
    if (what & DTH_EVAL_H) *H = 0.5 * (p * p + q * q);
    if (what & DTH_EVAL_GRAD) {
        g[0] = q;
        g[1] = 0;
        g[2] = p;
    }
    if (what & DTH_EVAL_HESS) {
        for (int i = 0; i < 9; i++) h[i] = 0;
        h[0] = h[8] = 1;
    }
    return 0;
}

static const dth_model_type fickle_type = {DTH_MODEL_TYPE_HEAD, .name = "fickle", .doc = "oscillator, H alone fails at 0.25 < q < 0.35",
                                           .create = one_dof_create, .eval = fickle_eval};

/* A regularizer that replaces every step and counts its calls (state a checkpoint keeps). Its
 * action, by mode: 0 a segment to q = 0.3, where the energy alone fails (after the commit);
 * 1 a NaN lambda; 2 an unknown action; 3 an offset that changes wp. */
typedef struct tricky {
    int mode;
    double calls;
} tricky;

static int tricky_create(const dth_reg_args *a, void **self)
{
    tricky *t = dth_calloc(a->alloc, 1, sizeof *t);
    if (!t) return DTH_ENOMEM;
    t->mode = a->nkv ? atoi(a->kv[0].value) : 0;
    *self = t;
    return DTH_OK;
}

static void tricky_destroy(void *self, const dth_allocator *al) { dth_free(al, self); }

static int tricky_apply(void *self, const dth_reg_event *ev, dth_reg_action *act)
{
    tricky *t = self;
    size_t N = ev->N;
    t->calls++;
    act->what = DTH_REG_REPLACE;
    act->lambda = 0.1 * ev->dir;
    act->d[1] = 0.05 * ev->dir; /* t advances by lambda / 2 */
    switch (t->mode) {
    case 0: act->d[0] = 0.5 * (0.3 - ev->z[0]); break; /* the new vertex at q = 0.3 */
    case 1: act->lambda = NAN; break;
    case 2: act->what = 5u; break;
    default: act->d[N - 1] = 1e-3; break;
    }
    return DTH_OK;
}

static int tricky_all(const void *self)
{
    (void)self;
    return 1;
}
static const dth_field tricky_fields[] = {{"calls", offsetof(tricky, calls), DTH_FIELD_F64, DTH_CHECK_NONNEG, 1}};

static const dth_param_spec tricky_params[] = {{"mode", "0", "which bad action"}};
static const dth_regularizer_type tricky_type = {
DTH_REG_TYPE_HEAD,
    .name = "tricky", .doc = "test", .params = tricky_params, .n_params = 1, .create = tricky_create,
    .destroy = tricky_destroy, .apply = tricky_apply, .fields = tricky_fields, .n_fields = 1,
    .replaces_all = tricky_all,
};

static void test_regularizer_failures(void)
{
    dth_model *m = model(&fickle_type, NULL, 0, 1);
    const char *modes[] = {"0", "1", "2", "3"};
    const int want[] = {DTH_EDOMAIN, DTH_EREFUSED, DTH_EREFUSED, DTH_EREFUSED};
    const char *says[] = {"", "against the direction", "unknown action", "changes wp"};
    for (int mode = 0; mode < 4; mode++) {
        dth_kv kv = {"mode", modes[mode]};
        dth_regularizer *reg = NULL;
        CU_ASSERT_FATAL(dth_regularizer_new(&tricky_type, &kv, 1, m, NULL, &reg, NULL, 0) == DTH_OK);
        dth_integrator *it = new_integrator_reg(m, 0.1, DTH_START_VERTEX, reg);
        double q = 0, p = 1;
        CU_ASSERT_FATAL(dth_integrator_start(it, &q, &p, 0) == DTH_OK);
        long at;
        int rc = step_until_failure(it, 3, &at);
        CU_ASSERT(rc == want[mode]);
        CU_ASSERT(at == 0);
        const char *msg = dth_integrator_errmsg(it);
        if (rc == DTH_EREFUSED) CU_ASSERT(strstr(msg, "tricky") != NULL && strstr(msg, says[mode]) != NULL);
        printf("  [mode %d: %s: %s]\n", mode, dth_status_name(rc), msg);
        dth_integrator_free(it);
        dth_regularizer_free(reg);
    }
    dth_model_free(m);
}

/* ---- absurd sizes: refused with a status, never a crash (sizes must not overflow) ---- */

static size_t big_n;
static int big_create(const dth_model_args *a, void **self, dth_model_info *info)
{
    (void)a;
    *self = NULL;
    *info = (dth_model_info){.n = big_n, .autonomous = 1};
    return DTH_OK;
}
static int big_eval(const void *self, const double *y, unsigned what, double *H, double *g, double *h)
{
    (void)self, (void)y, (void)what, (void)H, (void)g, (void)h;
    return 0;
}
static const dth_model_type big_type = {DTH_MODEL_TYPE_HEAD, .name = "big", .doc = "n from a global", .create = big_create,
                                        .eval = big_eval};

static void test_absurd_sizes(void)
{
    const size_t ns[] = {(size_t)1 << 62, SIZE_MAX, SIZE_MAX / 2 + 1, ((size_t)1 << 40) + 1};
    for (size_t i = 0; i < sizeof ns / sizeof ns[0]; i++) {
        big_n = ns[i];
        dth_model *m = (dth_model *)&big_n;
        char err[256] = "";
        CU_ASSERT(dth_model_new(&big_type, NULL, 0, 0, NULL, &m, err, sizeof err) == DTH_EINVAL);
        CU_ASSERT(m == NULL);
        CU_ASSERT(strstr(err, "degrees of freedom") != NULL);
    }
    /* within the model's limit, the dense step matrix is still too large: refused up front */
    const size_t ok[] = {(size_t)1 << 40, (size_t)1 << 30, 40000};
    for (size_t i = 0; i < sizeof ok / sizeof ok[0]; i++) {
        big_n = ok[i];
        dth_model *m = NULL;
        CU_ASSERT_FATAL(dth_model_new(&big_type, NULL, 0, 0, NULL, &m, NULL, 0) == DTH_OK);
        dth_options o;
        dth_options_default(&o);
        dth_integrator *it = (dth_integrator *)&big_n;
        CU_ASSERT(dth_integrator_new(m, &o, &it) == DTH_EUNSUPPORTED);
        CU_ASSERT(it == NULL);
        dth_model_free(m);
    }
}

/* ---- a starting state outside the domain: the reason names the coordinate ---- */

static void test_domain_check(void)
{
    static const dth_kv nan_kv[] = {{"nan", "1"}};
    dth_model *w = model(&wall_type, NULL, 0, 1), *wn = model(&wall_type, nan_kv, 1, 1);
    char why[200];
    double in[3] = {0.2, 0, 1}, out[3] = {0.7, 0, 1}, inf[3] = {0.2, INFINITY, 1};
    CU_ASSERT(dth_model_domain_check(w, in, why, sizeof why) == DTH_OK && why[0] == '\0');
    CU_ASSERT(dth_model_domain_check(w, out, why, sizeof why) == DTH_EDOMAIN);
    CU_ASSERT(strstr(why, "outside the model's domain") != NULL);
    CU_ASSERT(dth_model_domain_check(wn, out, why, sizeof why) == DTH_EDOMAIN);
    CU_ASSERT(strstr(why, "H is not finite") != NULL);
    CU_ASSERT(dth_model_domain_check(w, inf, why, sizeof why) == DTH_EDOMAIN);
    CU_ASSERT(strstr(why, "t = inf") != NULL);
    dth_model *k = model(&dth_model_kepler, NULL, 0, 2);
    double y[5] = {0, 0, 0, 0.5, 0.5};
    CU_ASSERT(dth_model_domain_check(k, y, why, sizeof why) == DTH_EDOMAIN);
    CU_ASSERT(strstr(why, "q1 = 0, q2 = 0") != NULL);
    /* the library refuses a start whose time steps of h cannot advance */
    dth_integrator *it = new_integrator(k, 0.05, DTH_START_MIDPOINT, 30);
    double q[2] = {1, 0}, p[2] = {0, 1};
    CU_ASSERT(dth_integrator_start(it, q, p, 1e300) == DTH_EINVAL);
    CU_ASSERT(strstr(dth_integrator_errmsg(it), "t + h == t") != NULL);
    CU_ASSERT(dth_integrator_start(it, q, p, 1e14) == DTH_OK);
    dth_integrator_free(it);
    dth_model_free(w);
    dth_model_free(wn);
    dth_model_free(k);
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
    dth_model *m = model(&dth_model_harmonic, kv, 3, 1);
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
    dth_model *m = model(&dth_model_coupled, kv, 6, 2);
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
    {"shipped regularizers where they stop: whole serialised state untouched", test_shipped_regularizers},
    {"a regularizer's bad actions and a failure after its commit: state and its own state untouched",
     test_regularizer_failures},
    {"absurd model sizes (n = 2^62, SIZE_MAX, 2^40): refused, no overflow", test_absurd_sizes},
    {"a state outside the domain: the reason names the coordinate", test_domain_check},
    {"bad model parameters: DTH_EINVAL naming the key", test_param_messages},
    {"fuzz regression: midpoint start overflow gives no DTH_OK with a non-finite vertex", test_fuzz_start_overflow},
    {"fuzz regression: a step whose vertex overflows is not DTH_OK", test_fuzz_step_overflow},
    CU_TEST_INFO_NULL,
};

CU_SuiteInfo dth_test_suites[] = {
    {.pName = "failstate", .pTests = failstate_tests},
    CU_SUITE_INFO_NULL,
};
