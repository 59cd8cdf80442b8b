/* SPDX-License-Identifier: MIT */
/*
 * The options contract (integrator.h: dth_options_check): each rule refuses with a message naming
 * the option, dth_integrator_new applies the same rules, AUTO resolves as the integrator will, and a
 * struct of another size is refused (a program built against another layout).
 */
#include <stdio.h>
#include <string.h>
#include "cu_main.h"
#include "dth/dth.h"

static dth_model *make(const dth_model_type *t, const dth_kv *kv, size_t nkv)
{
    dth_model *m = NULL;
    char err[256];
    CU_ASSERT_FATAL(dth_model_new(t, kv, nkv, 0, NULL, &m, err, sizeof err) == DTH_OK);
    return m;
}

/* dth_options_check on o refuses with `want` and a message holding `needle`, and so does
 * dth_integrator_new. */
static void refused(const dth_model *m, dth_options o, int want, const char *needle)
{
    char err[512] = "";
    dth_options c = o;
    int rc = dth_options_check(m, &c, err, sizeof err);
    CU_ASSERT(rc == want);
    if (rc != want || !strstr(err, needle)) printf("\n    got %d '%s', want %d with '%s'", rc, err, want, needle);
    CU_ASSERT(strstr(err, needle) != NULL);
    dth_integrator *it = (dth_integrator *)&c; /* a value the call must overwrite with NULL */
    CU_ASSERT(dth_integrator_new(m, &o, &it) == want);
    CU_ASSERT(it == NULL);
}

static void test_rules(void)
{
    dth_model *pend = make(&dth_model_pendulum, NULL, 0);
    dth_options o;
    dth_options_default(&o);
    dth_options b = o;
    b.size = sizeof b - 8;
    refused(pend, b, DTH_EINVAL, "dth_options_default");
    b = o, b.h = 0;
    refused(pend, b, DTH_EINVAL, "h = 0");
    b = o, b.max_iter = 0;
    refused(pend, b, DTH_EINVAL, "max_iter");
    b = o, b.K = -1;
    refused(pend, b, DTH_EINVAL, "K = -1");
    b = o, b.has_wp = 1, b.wp = 1.0 / 0.0;
    refused(pend, b, DTH_EINVAL, "wp");
    b = o, b.start = (dth_start)7;
    refused(pend, b, DTH_EINVAL, "start");
    b = o, b.linsolve = (dth_linsolve)42;
    refused(pend, b, DTH_EINVAL, "linsolve");
    b = o, b.finish = (dth_finish)3;
    refused(pend, b, DTH_EINVAL, "finish");
    b = o, b.method = "no-such-method";
    refused(pend, b, DTH_ENOTFOUND, "no-such-method");
    b = o, b.linsolve = DTH_LINSOLVE_BANDED;
    refused(pend, b, DTH_EUNSUPPORTED, "banded Hessian");
    dth_model_free(pend);
}

static void test_resolve(void)
{
    static const dth_kv chain[] = {{"preset", "chain"}, {"size", "8"}};
    dth_model *pend = make(&dth_model_pendulum, NULL, 0), *ch = make(&dth_model_coupled, chain, 2);
    dth_options o;
    dth_options_default(&o);
    o.method = NULL;
    char err[256];
    dth_options c = o;
    CU_ASSERT(dth_options_check(pend, &c, err, sizeof err) == DTH_OK);
    CU_ASSERT(c.linsolve == DTH_LINSOLVE_SMALL);
    CU_ASSERT(c.method && strcmp(c.method, "dth") == 0);
    c = o;
    CU_ASSERT(dth_options_check(ch, &c, err, sizeof err) == DTH_OK);
    CU_ASSERT(c.linsolve == DTH_LINSOLVE_BANDED);
    /* the reversible finish reads a dense Hessian: refused where AUTO takes the banded path,
     * accepted with linsolve = dense */
    c = o, c.finish = DTH_FINISH_REVERSIBLE;
    refused(ch, c, DTH_EUNSUPPORTED, "linsolve 'dense'");
    c.linsolve = DTH_LINSOLVE_DENSE;
    CU_ASSERT(dth_options_check(ch, &c, err, sizeof err) == DTH_OK);
    dth_linsolve k = DTH_LINSOLVE_AUTO;
    CU_ASSERT(dth_linsolve_from_name("banded-lu", &k) == DTH_OK && k == DTH_LINSOLVE_BANDED_LU);
    CU_ASSERT(dth_linsolve_from_name("nope", &k) == DTH_ENOTFOUND);
    CU_ASSERT_STRING_EQUAL(dth_finish_name(DTH_FINISH_REVERSIBLE), "reversible");
    dth_model_free(pend);
    dth_model_free(ch);
}

static CU_TestInfo tests[] = {
    {"each rule refuses with a message naming the option", test_rules},
    {"AUTO and the method resolve as the integrator's", test_resolve},
    CU_TEST_INFO_NULL,
};

CU_SuiteInfo dth_test_suites[] = {
    {.pName = "options", .pTests = tests},
    CU_SUITE_INFO_NULL,
};
