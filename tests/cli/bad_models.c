/* SPDX-License-Identifier: MIT */
/*
 * Misbehaving user models for the CLI's tests (a plugin: dth run / dth sweep --model-lib), each an
 * oscillator H = p^2/2 + k q^2/2 (1 degree of freedom, parameter k) with one fault:
 *   test_null_self     create succeeds but leaves *self NULL (its eval needs the state)
 *   test_null_invname  an invariant "E" whose name callback returns NULL
 *   test_hard_fail     eval fails hard (returns -1) where |q| > qmax (default: never)
 *   test_third_fail    the third-derivative callback fails hard (dth_model_check cannot run)
 */
#include <math.h>
#include <dth/dth.h>

/* the exported tables (declared here: -Wmissing-variable-declarations) */
extern const dth_model_type test_null_self, test_null_invname, test_hard_fail, test_third_fail;

typedef struct osc {
    double k, qmax;
} osc;

static const dth_param_spec params[] = {
    {"k", "1", "spring constant"},
    {"qmax", "inf", "test_hard_fail: eval fails hard where |q| > qmax"},
};

static int create(const dth_model_args *args, void **self, dth_model_info *info)
{
    double k, qmax;
    int rc = dth_args_double(args, "k", 1.0, &k);
    const char *qm = dth_args_get(args, "qmax");
    qmax = INFINITY;
    if (!rc && qm && dth_parse_double(qm, &qmax)) rc = dth_args_error(args, "model.qmax: not a number");
    if (rc) return rc;
    osc *m = dth_calloc(args->alloc, 1, sizeof *m);
    if (!m) return DTH_ENOMEM;
    m->k = k;
    m->qmax = qmax;
    *self = m;
    *info = (dth_model_info){.n = 1, .autonomous = 1, .separable = 1, .hess_kind = DTH_HESS_DENSE};
    return DTH_OK;
}

/* the fault: success without an instance */
static int create_null(const dth_model_args *args, void **self, dth_model_info *info)
{
    (void)args;
    *self = NULL;
    *info = (dth_model_info){.n = 1, .autonomous = 1, .separable = 1, .hess_kind = DTH_HESS_DENSE};
    return DTH_OK;
}

static void destroy(void *self, const dth_allocator *alloc) { dth_free(alloc, self); }

/* y = (q, t, p) */
static int eval(const void *self, const double *y, unsigned what, double *H, double *g, double *h)
{
    const osc *m = self;
    double q = y[0], p = y[2];
    if (fabs(q) > m->qmax) return -1;
    if (what & DTH_EVAL_H) *H = 0.5 * p * p + 0.5 * m->k * q * q;
    if (what & DTH_EVAL_GRAD) g[0] = m->k * q, g[1] = 0, g[2] = p;
    if (what & DTH_EVAL_HESS) {
        for (int i = 0; i < 9; i++) h[i] = 0;
        h[0] = m->k;
        h[8] = 1;
    }
    return 0;
}

static int third_fail(const void *self, const double *y, const double *u, double *d3)
{
    (void)self, (void)y, (void)u, (void)d3;
    return -1;
}

static size_t one(const void *self) { return (void)self, 1; }
static const char *null_name(const void *self, size_t i) { return (void)self, (void)i, (const char *)0; }
static int energy(const void *self, const double *y, double *out) { return eval(self, y, DTH_EVAL_H, out, 0, 0); }

const dth_model_type test_null_self = {DTH_MODEL_TYPE_HEAD, .name = "null-self", .doc = "create leaves *self NULL", .params = params,
                                      .n_params = 2, .create = create_null, .destroy = destroy, .eval = eval};
const dth_model_type test_null_invname = {DTH_MODEL_TYPE_HEAD, .name = "null-invname", .doc = "an invariant without a name", .params = params,
                                         .n_params = 2, .create = create, .destroy = destroy, .eval = eval,
                                         .n_invariants = one, .invariant_name = null_name, .invariants = energy};
const dth_model_type test_hard_fail = {DTH_MODEL_TYPE_HEAD, .name = "hard-fail", .doc = "eval fails hard where |q| > qmax", .params = params,
                                      .n_params = 2, .create = create, .destroy = destroy, .eval = eval};
const dth_model_type test_third_fail = {DTH_MODEL_TYPE_HEAD, .name = "third-fail", .doc = "the third derivative fails hard", .params = params,
                                       .n_params = 2, .create = create, .destroy = destroy, .eval = eval,
                                       .third = third_fail};
