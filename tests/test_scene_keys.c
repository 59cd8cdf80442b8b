/* SPDX-License-Identifier: MIT */
/*
 * The scene key table (lib/scene_keys.c): every key's bad value is refused naming FILE:LINE, the key
 * and what the key accepts; the documented defaults are the values a setup starts from; unknown
 * keys and sections name the closest known one; the integrator-level rules (dth_options_check) are
 * reported at the line of the key concerned.
 */
#include <limits.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include "cu_main.h"
#include "dth/dth.h"
#include "scene_keys.h"

static dth_registry *registry(void)
{
    dth_registry *r = NULL;
    CU_ASSERT_FATAL(dth_registry_new(NULL, &r) == DTH_OK);
    CU_ASSERT_FATAL(dth_registry_add_builtin(r) == DTH_OK);
    return r;
}

#define BASE "[model]\nname = pendulum\n[initial]\nq = 1\np = 0\n[integrator]\nh = 0.1\nsteps = 10\n"
/*            1       2               3         4     5     6            7         8 -> next line is 9 */

/* Set up the scene text `text` (called keys.ini) with overrides; the status, the message in err. */
static int setup(const char *text, const char *const *sets, size_t nsets, char *err, size_t len)
{
    dth_registry *reg = registry();
    dth_scene *s = NULL;
    CU_ASSERT_FATAL(dth_scene_new(NULL, &s) == DTH_OK);
    CU_ASSERT_FATAL(dth_scene_load_mem(s, "keys.ini", text, strlen(text), err, len) == DTH_OK);
    for (size_t i = 0; i < nsets; i++) CU_ASSERT_FATAL(dth_scene_set(s, sets[i], err, len) == DTH_OK);
    dth_run_setup rs;
    err[0] = '\0';
    int rc = dth_scene_setup(s, reg, &rs, err, len);
    if (rc == DTH_OK) dth_run_setup_clear(&rs);
    dth_scene_free(s);
    dth_registry_free(reg);
    return rc;
}

/* err starts with `prefix`, holds `needle` (NULL: anything) and is one line; else print why. */
static int says(const char *err, const char *prefix, const char *needle)
{
    int ok = strncmp(err, prefix, strlen(prefix)) == 0 && (!needle || strstr(err, needle)) && !strchr(err, '\n');
    if (!ok) fprintf(stderr, "\n  got \"%s\"\n  want \"%s...%s\"\n", err, prefix, needle ? needle : "");
    return ok;
}

/* A value of the key's form that is wrong for every key of that type. */
static const char *malformed(dth_scene_key_type t)
{
    switch (t) {
    case DTH_SCENE_NUMBER: return "abc";
    case DTH_SCENE_INTEGER: return "1.5";
    case DTH_SCENE_BOOL: return "maybe";
    case DTH_SCENE_CHOICE: return "nosuch";
    case DTH_SCENE_NUMBERS: return "1,x";
    case DTH_SCENE_DOFS: return "0";
    case DTH_SCENE_TEXT: return "";
    case DTH_SCENE_COORDINATE: return "z1";
    }
    return "?";
}

/* The key set to v in its own section at line 10 of BASE: refused there, naming the key, with `want`. */
static void expect_refused(const dth_scene_key_info *in, const char *v, const char *want)
{
    char text[512], err[1024], prefix[160];
    snprintf(text, sizeof text, BASE "[%s]\n%s = %s\n", in->section, in->key, v);
    snprintf(prefix, sizeof prefix, "keys.ini:10: %s.%s: ", in->section, in->key);
    CU_ASSERT_EQUAL(setup(text, NULL, 0, err, sizeof err), DTH_EINVAL);
    CU_ASSERT(says(err, prefix, want));
}

/* Every key of the table: a malformed value, and values just out of its bounds, are refused at the
 * key's line with what the key accepts (the message made from the table entry). */
static void test_every_key_bad_value(void)
{
    CU_ASSERT_FATAL(dth_scene_key_count() > 20);
    CU_ASSERT_PTR_NULL(dth_scene_key_at(dth_scene_key_count()));
    for (size_t i = 0; i < dth_scene_key_count(); i++) {
        const dth_scene_key_info *in = dth_scene_key_at(i);
        const dth__scene_key *k = dth__scene_key_get(i);
        CU_ASSERT_FATAL(in != NULL && k != NULL && &k->info == in);
        CU_ASSERT(dth__scene_section_kind(in->section) == DTH__SECTION_KEYS);
        CU_ASSERT(in->doc && in->doc[0] && !strchr(in->doc, '\n'));
        char what[512], want[600];
        size_t wl = dth_scene_key_describe(i, what, sizeof what);
        CU_ASSERT(wl > 0 && wl == strlen(what));
        const char *v = malformed(in->type);
        if (k->as_name == DTH__NAME_GIVEN) snprintf(want, sizeof want, "unknown method '%s'", v); /* dth_options_check's words */
        else if (in->type == DTH_SCENE_TEXT) snprintf(want, sizeof want, "an empty value is not %s", what);
        else snprintf(want, sizeof want, "'%s' is not %s", v, what);
        expect_refused(in, v, want);
        char out[64];
        if (in->type == DTH_SCENE_NUMBER && k->bound != DTH__ANY) {
            snprintf(out, sizeof out, "%g", k->bound == DTH__GE ? k->lo - 1 : k->lo);
            snprintf(want, sizeof want, "'%s' is not %s", out, what);
            expect_refused(in, out, k->refuse ? k->refuse : want);
        }
        if (in->type == DTH_SCENE_INTEGER) {
            snprintf(out, sizeof out, "%ld", k->ilo - 1);
            snprintf(want, sizeof want, "'%s' is not %s", out, what);
            expect_refused(in, out, want);
            if (k->ihi < LONG_MAX) {
                snprintf(out, sizeof out, "%ld", k->ihi + 1);
                snprintf(want, sizeof want, "'%s' is too large (an integer from %ld to %ld)", out, k->ilo, k->ihi);
                expect_refused(in, out, want);
            }
        }
    }
}

/* The default the guide shows is the value a setup starts from: parsing it changes nothing. */
static void test_documented_defaults(void)
{
    for (size_t i = 0; i < dth_scene_key_count(); i++) {
        const dth__scene_key *k = dth__scene_key_get(i);
        const dth_scene_key_info *in = &k->info;
        if (in->required) CU_ASSERT_STRING_EQUAL(in->def, "");
        /* TEXT and DOFS defaults are words ("standard output", "all"); the others must parse */
        if (!in->def[0] || in->type == DTH_SCENE_TEXT || in->type == DTH_SCENE_DOFS) continue;
        dth_run_setup rs0, rs;
        dth__scene_extra x0, x;
        dth__scene_defaults(&rs0, &x0, NULL);
        dth__scene_defaults(&rs, &x, NULL);
        const dth__scene_target t = {&rs, &x, NULL};
        char msg[256];
        CU_ASSERT_EQUAL_FATAL(dth__scene_key_parse(k, in->def, &t, msg, sizeof msg), DTH_OK);
        const char *a = k->to.base == DTH__IN_SETUP ? (const char *)&rs0 : (const char *)&x0;
        const char *b = k->to.base == DTH__IN_SETUP ? (const char *)&rs : (const char *)&x;
        int same;
        if (k->as_name) {
            const char *sa, *sb;
            memcpy(&sa, a + k->to.off, sizeof sa);
            memcpy(&sb, b + k->to.off, sizeof sb);
            same = strcmp(sa, sb) == 0;
        } else {
            same = memcmp(a + k->to.off, b + k->to.off, k->to.size) == 0;
        }
        if (!same) fprintf(stderr, "\n  %s.%s: default '%s' is not the setup's start\n", in->section, in->key, in->def);
        CU_ASSERT(same);
        dth__scene_extra_clear(&x, NULL);
    }
}

/* Unknown keys and sections name the closest known name, in files and in overrides. */
static void test_did_you_mean(void)
{
    char err[1024];
    CU_ASSERT_EQUAL(setup(BASE "[integrator]\nt_ned = 3\n", NULL, 0, err, sizeof err), DTH_EINVAL);
    CU_ASSERT(says(err, "keys.ini:10: integrator.t_ned: unknown key (known in [integrator]: ", "; did you mean t_end?"));
    const char *set[] = {"integrator.t_ned=3"};
    CU_ASSERT_EQUAL(setup(BASE, set, 1, err, sizeof err), DTH_EINVAL);
    CU_ASSERT(says(err, "-s integrator.t_ned=3: integrator.t_ned: unknown key", "; did you mean t_end?"));
    struct {
        const char *set, *want; /* want NULL: no suggestion */
    } c[] = {
        {"integrator.T_end=3", "did you mean t_end?"},
        {"integrator.linsolver=dense", "did you mean linsolve?"},
        {"events.sectoin_value=1", "did you mean section_value?"},
        {"integrator.every=2", "did you mean output.every?"}, /* the key of another section */
        {"ouptut.file=x", "did you mean [output]?"},
        {"model.omeg2=2", "did you mean omega2?"},
        {"initial.x=1", NULL},       /* one letter is not close to another */
        {"integrator.frobnicate=1", NULL},
    };
    for (size_t i = 0; i < sizeof c / sizeof c[0]; i++) {
        CU_ASSERT_EQUAL(setup(BASE, &c[i].set, 1, err, sizeof err), DTH_EINVAL);
        char prefix[96];
        snprintf(prefix, sizeof prefix, "-s %s: ", c[i].set);
        int ok = c[i].want ? says(err, prefix, c[i].want) : says(err, prefix, "unknown") && !strstr(err, "did you mean");
        CU_ASSERT(ok);
    }
}

#define CHAIN                                                                                               \
    "[model]\nname = coupled\npreset = chain\nsize = 4\ndim = 1\n[initial]\nq = 0, 1.1, 2, 3\np = 0, 0, 0, 0\n" \
    "[integrator]\nh = 0.1\nsteps = 2\n"
/*   1       2              3              4          5         6         7                  8  */
/*   9             10         11 -> next line is 12 */

/* dth_options_check's rules, reported at the line of the key whose value they refuse. */
static void test_options_rules_at_their_line(void)
{
    char err[1024];
    /* a banded solver on a dense model */
    CU_ASSERT_EQUAL(setup(BASE "[integrator]\nlinsolve = banded\n", NULL, 0, err, sizeof err), DTH_EINVAL);
    CU_ASSERT(says(err, "keys.ini:10: integrator.linsolve: ", "banded Hessian"));
    /* the reversible finish on the banded path: named at reversible, wherever linsolve stands */
    CU_ASSERT_EQUAL(setup(CHAIN "reversible = yes\n", NULL, 0, err, sizeof err), DTH_EINVAL);
    CU_ASSERT(says(err, "keys.ini:12: integrator.reversible: ", "reversible finish needs a dense Hessian"));
    CU_ASSERT_EQUAL(setup(CHAIN "reversible = yes\nlinsolve = banded-lu\n", NULL, 0, err, sizeof err), DTH_EINVAL);
    CU_ASSERT(says(err, "keys.ini:12: integrator.reversible: ", "dense Hessian"));
    CU_ASSERT_EQUAL(setup(CHAIN "reversible = yes\nlinsolve = dense\n", NULL, 0, err, sizeof err), DTH_OK);
    /* an unknown method */
    CU_ASSERT_EQUAL(setup(BASE "method = rk5\n", NULL, 0, err, sizeof err), DTH_EINVAL);
    CU_ASSERT(says(err, "keys.ini:9: integrator.method: ", "unknown method 'rk5' (available: dth, midpoint"));
    /* a regularizer with a baseline: the later of the two keys */
    CU_ASSERT_EQUAL(setup(BASE "method = rk4\n[regularize]\nmethod = land\n", NULL, 0, err, sizeof err), DTH_EINVAL);
    CU_ASSERT(says(err, "keys.ini:11: regularize.method: ", "applies to method = dth only"));
    CU_ASSERT_EQUAL(setup(BASE "[regularize]\nmethod = land\n[integrator]\nmethod = rk4\n", NULL, 0, err, sizeof err),
                    DTH_EINVAL);
    CU_ASSERT(says(err, "keys.ini:12: integrator.method: ", "applies to method = dth only"));
    const char *set[] = {"integrator.method=rk4"};
    CU_ASSERT_EQUAL(setup(BASE "[regularize]\nmethod = land\n", set, 1, err, sizeof err), DTH_EINVAL);
    CU_ASSERT(says(err, "-s integrator.method=rk4: integrator.method: ", "method = dth only"));
    /* a baseline alone takes no regularizer (the default) and passes */
    CU_ASSERT_EQUAL(setup(BASE "method = rk4\n", NULL, 0, err, sizeof err), DTH_OK);
}

/* Order 4's keys and rules at their lines: its table and band, midpoint rows, the regularizers it takes
 * (land, the default, switches on its band; none; land's parameters and prescribed are refused). */
static void test_order4_rules(void)
{
    char err[1024];
    CU_ASSERT_EQUAL(setup(BASE "order = 4\n", NULL, 0, err, sizeof err), DTH_OK);
    CU_ASSERT_EQUAL(setup(BASE "order = 4\ntable = yoshida4\nband_time = 0.5\n", NULL, 0, err, sizeof err), DTH_OK);
    CU_ASSERT_EQUAL(setup(BASE "order = 4\n[regularize]\nmethod = none\n", NULL, 0, err, sizeof err), DTH_OK);
    CU_ASSERT_EQUAL(setup(BASE "order = 4\n[regularize]\nmethod = land\n", NULL, 0, err, sizeof err), DTH_OK);
    CU_ASSERT_EQUAL(setup(BASE "order = 6\n", NULL, 0, err, sizeof err), DTH_EINVAL);
    CU_ASSERT(says(err, "keys.ini:9: integrator.order: order = 6: not offered", "order = 4"));
    CU_ASSERT_EQUAL(setup(BASE "order = 3\n", NULL, 0, err, sizeof err), DTH_EINVAL);
    CU_ASSERT(says(err, "keys.ini:9: integrator.order: ", "order 2 or 4"));
    CU_ASSERT_EQUAL(setup(BASE "table = yoshida4\n", NULL, 0, err, sizeof err), DTH_EINVAL);
    CU_ASSERT(says(err, "keys.ini:9: integrator.table: ", "table applies to order = 4 only"));
    CU_ASSERT_EQUAL(setup(BASE "band_time = 0.5\n", NULL, 0, err, sizeof err), DTH_EINVAL);
    CU_ASSERT(says(err, "keys.ini:9: integrator.band_time: ", "band_time applies to order = 4 only"));
    CU_ASSERT_EQUAL(setup(BASE "order = 4\ntable = nope\n", NULL, 0, err, sizeof err), DTH_EINVAL);
    CU_ASSERT(says(err, "keys.ini:10: integrator.table: 'nope' is not one of suzuki4, yoshida4, yoshida6a, kahanli6, "
                        "kahanli8", NULL));
    CU_ASSERT_EQUAL(setup(BASE "order = 4\nmethod = rk4\n", NULL, 0, err, sizeof err), DTH_EINVAL);
    CU_ASSERT(says(err, "keys.ini:10: integrator.method: ", "has an order of its own"));
    CU_ASSERT_EQUAL(setup(BASE "order = 4\n[output]\npoints = midpoints\n", NULL, 0, err, sizeof err), DTH_EINVAL);
    CU_ASSERT(says(err, "keys.ini:11: output.points: ", "midpoints exist for order 2 only"));
    /* prescribed: at the later of the two keys */
    CU_ASSERT_EQUAL(setup(BASE "order = 4\n[regularize]\nmethod = prescribed\n", NULL, 0, err, sizeof err),
                    DTH_EINVAL);
    CU_ASSERT(says(err, "keys.ini:11: regularize.method: order = 4 with regularizer 'prescribed': not supported",
                   "order = 2 for 'prescribed'"));
    CU_ASSERT_EQUAL(setup(BASE "[regularize]\nmethod = prescribed\n[integrator]\norder = 4\n", NULL, 0, err, sizeof err),
                    DTH_EINVAL);
    CU_ASSERT(says(err, "keys.ini:12: integrator.order: order = 4 with regularizer 'prescribed'", NULL));
    CU_ASSERT_EQUAL(setup(BASE "[regularize]\nmethod = prescribed\n", NULL, 0, err, sizeof err), DTH_OK);
    /* land's own parameters are order 2's */
    CU_ASSERT_EQUAL(setup(BASE "order = 4\n[regularize]\nkappa = 0.02\n", NULL, 0, err, sizeof err), DTH_EINVAL);
    CU_ASSERT(says(err, "keys.ini:11: regularize.kappa: the parameters of regularizer 'land' apply to order 2",
                   "integrator.band_time"));
    CU_ASSERT_EQUAL(setup(BASE "[regularize]\nkappa = 0.02\n", NULL, 0, err, sizeof err), DTH_OK);
}

static CU_TestInfo key_tests[] = {
    {"every key: a bad value names FILE:LINE, the key and what it accepts", test_every_key_bad_value},
    {"the documented defaults are the setup's starting values", test_documented_defaults},
    {"unknown keys and sections: did you mean", test_did_you_mean},
    {"dth_options_check's rules at the line of their key", test_options_rules_at_their_line},
    {"order 4's keys and rules at their line", test_order4_rules},
    CU_TEST_INFO_NULL,
};

CU_SuiteInfo dth_test_suites[] = {
    {.pName = "scene keys", .pTests = key_tests},
    CU_SUITE_INFO_NULL,
};
