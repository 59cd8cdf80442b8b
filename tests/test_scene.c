/* SPDX-License-Identifier: MIT */
/*
 * Scene files: loading, overrides, validation into a run setup, and that every bad input gives
 * the right status and a one-line message naming the file:line (or the override) and the key.
 */
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>
#include "cu_main.h"
#include "dth/dth.h"
#include "dth_internal.h" /* dth__parse_list */

/* A scene file with the given text; path receives its name (remove it with unlink). */
static void write_scene(const char *text, char *path, size_t len)
{
    snprintf(path, len, "/tmp/dth_test_scene_XXXXXX");
    int fd = mkstemp(path);
    CU_ASSERT_FATAL(fd >= 0);
    FILE *f = fdopen(fd, "w");
    CU_ASSERT_FATAL(f != NULL);
    fputs(text, f);
    fclose(f);
}

static dth_registry *registry(void)
{
    dth_registry *r = NULL;
    CU_ASSERT_FATAL(dth_registry_new(NULL, &r) == DTH_OK);
    CU_ASSERT_FATAL(dth_registry_add_builtin(r) == DTH_OK);
    return r;
}

static const char *good_pendulum =
    "; a comment\n"
    "[model]\n"
    "name = pendulum\n"
    "omega2 = 2\n"
    "[initial]\n"
    "q = 1\n"
    "p = -0.5\n"
    "t = 3\n"
    "[integrator]\n"
    "method = dth\n"
    "start = vertex\n"
    "h = -0.05\n"
    "t_end = 1\n"
    "max_iter = 12\n"
    "K = 0.5\n"
    "[regularize]\n"
    "method = none\n"
    "[output]\n"
    "file = out.csv\n"
    "every = 3\n"
    "diagnostics = yes\n";

static void test_good_scene(void)
{
    char path[64], err[512];
    write_scene(good_pendulum, path, sizeof path);
    dth_registry *reg = registry();
    dth_scene *s;
    CU_ASSERT_FATAL(dth_scene_new(NULL, &s) == DTH_OK);
    CU_ASSERT_FATAL(dth_scene_load(s, path, err, sizeof err) == DTH_OK);
    CU_ASSERT_STRING_EQUAL(dth_scene_get(s, "model", "omega2"), "2");
    CU_ASSERT_PTR_NULL(dth_scene_get(s, "model", "nothing"));
    char where[128];
    snprintf(where, sizeof where, "%s:12", path);
    CU_ASSERT_STRING_EQUAL(dth_scene_origin(s, "integrator", "h"), where);
    CU_ASSERT_EQUAL(dth_scene_count(s), 15);

    dth_run_setup rs;
    int rc = dth_scene_setup(s, reg, &rs, err, sizeof err);
    CU_ASSERT_EQUAL_FATAL(rc, DTH_OK);
    CU_ASSERT_EQUAL(rs.n, 1);
    CU_ASSERT_EQUAL(dth_model_dof(rs.model), 1);
    CU_ASSERT_STRING_EQUAL(dth_model_get_type(rs.model)->name, "pendulum");
    CU_ASSERT_EQUAL(rs.q0[0], 1.0);
    CU_ASSERT_EQUAL(rs.p0[0], -0.5);
    CU_ASSERT_EQUAL(rs.t0, 3.0);
    CU_ASSERT_EQUAL(rs.opt.h, -0.05);
    CU_ASSERT_EQUAL(rs.opt.start, DTH_START_VERTEX);
    CU_ASSERT_EQUAL(rs.opt.max_iter, 12);
    CU_ASSERT_EQUAL(rs.opt.K, 0.5);
    CU_ASSERT_EQUAL(rs.opt.has_wp, 0);
    CU_ASSERT_EQUAL(rs.has_t_end, 1);
    CU_ASSERT_EQUAL(rs.t_end, 1.0);
    CU_ASSERT_STRING_EQUAL(rs.method, "dth");
    CU_ASSERT_STRING_EQUAL(rs.regularize, "none");
    CU_ASSERT_STRING_EQUAL(rs.out_file, "out.csv");
    CU_ASSERT_EQUAL(rs.every, 3);
    CU_ASSERT_EQUAL(rs.dt, 0.0);
    CU_ASSERT_EQUAL(rs.diagnostics, 1);
    /* the model got omega2 = 2: H = p^2/2 - 2 cos q */
    double y[3] = {0, 0, 1}, H;
    CU_ASSERT_EQUAL(dth_model_eval(rs.model, y, DTH_EVAL_H, &H, NULL, NULL), DTH_OK);
    CU_ASSERT_DOUBLE_EQUAL(H, 0.5 - 2.0, 1e-15);
    dth_run_setup_clear(&rs);
    dth_run_setup_clear(&rs); /* safe twice */
    dth_scene_free(s);
    dth_registry_free(reg);
    unlink(path);
}

static void test_defaults_and_harmonic(void)
{
    char path[64], err[512];
    write_scene("[model]\nname=harmonic\nomega=1,2\n[initial]\nq=1, 2\np=3,4\n[integrator]\nh=0.1\nsteps=7\n",
                path, sizeof path);
    dth_registry *reg = registry();
    dth_scene *s;
    dth_run_setup rs;
    CU_ASSERT_FATAL(dth_scene_new(NULL, &s) == DTH_OK);
    CU_ASSERT_FATAL(dth_scene_load(s, path, err, sizeof err) == DTH_OK);
    CU_ASSERT_EQUAL_FATAL(dth_scene_setup(s, reg, &rs, err, sizeof err), DTH_OK);
    CU_ASSERT_EQUAL(rs.n, 2);
    CU_ASSERT_EQUAL(rs.q0[1], 2.0);
    CU_ASSERT_EQUAL(rs.p0[0], 3.0);
    CU_ASSERT_EQUAL(rs.p0[1], 4.0);
    CU_ASSERT_EQUAL(rs.t0, 0.0);
    CU_ASSERT_EQUAL(rs.opt.start, DTH_START_MIDPOINT);
    CU_ASSERT_EQUAL(rs.opt.max_iter, 30);
    CU_ASSERT_EQUAL(rs.has_t_end, 0);
    CU_ASSERT_EQUAL(rs.steps, 7);
    CU_ASSERT_EQUAL(rs.every, 1);
    CU_ASSERT_EQUAL(rs.diagnostics, 0);
    CU_ASSERT_PTR_NULL(rs.out_file);
    dth_run_setup_clear(&rs);
    dth_scene_free(s);
    dth_registry_free(reg);
    unlink(path);
}

static void test_overrides(void)
{
    char path[64], err[512];
    write_scene(good_pendulum, path, sizeof path);
    dth_registry *reg = registry();
    dth_scene *s;
    dth_run_setup rs;
    CU_ASSERT_FATAL(dth_scene_new(NULL, &s) == DTH_OK);
    CU_ASSERT_FATAL(dth_scene_load(s, path, err, sizeof err) == DTH_OK);
    CU_ASSERT_EQUAL(dth_scene_set(s, " integrator . h = 0.25 ", err, sizeof err), DTH_OK);
    CU_ASSERT_STRING_EQUAL(dth_scene_get(s, "integrator", "h"), "0.25");
    CU_ASSERT_STRING_EQUAL(dth_scene_origin(s, "integrator", "h"), "-s  integrator . h = 0.25 ");
    /* an override of steps replaces the file's t_end; q moves to the front of nothing */
    CU_ASSERT_EQUAL(dth_scene_set(s, "integrator.steps=5", err, sizeof err), DTH_OK);
    CU_ASSERT_EQUAL(dth_scene_set(s, "initial.q=0.5", err, sizeof err), DTH_OK);
    CU_ASSERT_EQUAL(dth_scene_set(s, "output.file=", err, sizeof err), DTH_OK);
    CU_ASSERT_STRING_EQUAL(dth_scene_get(s, "output", "file"), "");
    CU_ASSERT_EQUAL(dth_scene_set(s, "output.file=x.csv", err, sizeof err), DTH_OK);
    CU_ASSERT_EQUAL_FATAL(dth_scene_setup(s, reg, &rs, err, sizeof err), DTH_OK);
    CU_ASSERT_EQUAL(rs.opt.h, 0.25);
    CU_ASSERT_EQUAL(rs.has_t_end, 0);
    CU_ASSERT_EQUAL(rs.steps, 5);
    CU_ASSERT_EQUAL(rs.q0[0], 0.5);
    CU_ASSERT_STRING_EQUAL(rs.out_file, "x.csv");
    dth_run_setup_clear(&rs);

    /* both run lengths as overrides: an error naming the override */
    CU_ASSERT_EQUAL(dth_scene_set(s, "integrator.t_end=9", err, sizeof err), DTH_OK);
    CU_ASSERT_EQUAL(dth_scene_setup(s, reg, &rs, err, sizeof err), DTH_EINVAL);
    CU_ASSERT_PTR_NOT_NULL(strstr(err, "-s integrator."));
    CU_ASSERT_PTR_NOT_NULL(strstr(err, "not both"));

    /* malformed overrides */
    static const char *badset[] = {"integratorh=1", "integrator.h", "=1", ".h=1", "integrator.=1", " .=", ""};
    size_t before = dth_scene_count(s);
    for (size_t i = 0; i < sizeof badset / sizeof badset[0]; i++) {
        err[0] = '\0';
        CU_ASSERT_EQUAL(dth_scene_set(s, badset[i], err, sizeof err), DTH_EPARSE);
        char want[64];
        snprintf(want, sizeof want, "-s %s:", badset[i]);
        CU_ASSERT_PTR_NOT_NULL(strstr(err, want));
        CU_ASSERT_PTR_NOT_NULL(strstr(err, "section.key=value"));
    }
    CU_ASSERT_EQUAL(dth_scene_count(s), before);
    dth_scene_free(s);
    dth_registry_free(reg);
    unlink(path);
}

static void test_load_errors(void)
{
    char path[64], err[512], want[128];
    dth_scene *s;
    CU_ASSERT_FATAL(dth_scene_new(NULL, &s) == DTH_OK);
    /* missing file: DTH_EIO naming the file */
    CU_ASSERT_EQUAL(dth_scene_load(s, "/nonexistent/x.ini", err, sizeof err), DTH_EIO);
    CU_ASSERT_PTR_NOT_NULL(strstr(err, "/nonexistent/x.ini"));
    /* syntax error on line 3; the scene stays unchanged (no partial load) */
    write_scene("[model]\nname = pendulum\nthis line has no equals sign\nomega2 = 1\n", path, sizeof path);
    CU_ASSERT_EQUAL(dth_scene_load(s, path, err, sizeof err), DTH_EPARSE);
    snprintf(want, sizeof want, "%s:3:", path);
    CU_ASSERT_PTR_NOT_NULL(strstr(err, want));
    CU_ASSERT_EQUAL(dth_scene_count(s), 0);
    unlink(path);
    /* a line longer than inih's buffer is refused, not split */
    char text[600];
    snprintf(text, sizeof text, "[model]\nname = pendulum\n[initial]\nq = 1%0300d\n", 0);
    write_scene(text, path, sizeof path);
    CU_ASSERT_EQUAL(dth_scene_load(s, path, err, sizeof err), DTH_EPARSE);
    snprintf(want, sizeof want, "%s:4:", path);
    CU_ASSERT_PTR_NOT_NULL(strstr(err, want));
    CU_ASSERT_PTR_NOT_NULL(strstr(err, "too long") || strstr(err, "longer"));
    CU_ASSERT_EQUAL(dth_scene_count(s), 0);
    unlink(path);
    /* later values replace earlier ones, with their line */
    write_scene("[integrator]\nh = 1\nh = 2\n", path, sizeof path);
    CU_ASSERT_EQUAL(dth_scene_load(s, path, err, sizeof err), DTH_OK);
    CU_ASSERT_STRING_EQUAL(dth_scene_get(s, "integrator", "h"), "2");
    snprintf(want, sizeof want, "%s:3", path);
    CU_ASSERT_STRING_EQUAL(dth_scene_origin(s, "integrator", "h"), want);
    CU_ASSERT_EQUAL(dth_scene_count(s), 1);
    const char *sec, *key, *val, *org;
    CU_ASSERT_EQUAL(dth_scene_entry(s, 0, &sec, &key, &val, &org), DTH_OK);
    CU_ASSERT_STRING_EQUAL(sec, "integrator");
    CU_ASSERT_STRING_EQUAL(key, "h");
    CU_ASSERT_EQUAL(dth_scene_entry(s, 1, &sec, &key, &val, &org), DTH_EINVAL);
    unlink(path);
    dth_scene_free(s);
}

/* One bad scene: its text, the line to name (0: the file without a line), substrings. */
typedef struct bad_case {
    const char *text;
    int line;
    const char *want1, *want2;
} bad_case;

#define BASE_PEND "[model]\nname = pendulum\n[initial]\nq = 1\np = 0\n[integrator]\nh = 0.1\n"
/*                 1       2               3         4     5     6            7  -> next line is 8 */

static const bad_case bad_cases[] = {
    {BASE_PEND "steps = 10\nhh = 1\n", 9, "integrator.hh", "unknown key"},
    {BASE_PEND "steps = 10\n[model]\nfoo = 1\n", 10, "model.foo", "omega2"},
    {BASE_PEND "steps = 10\n[model]\nomega2 = -1\n", 10, "model.omega2", "> 0"},
    {"[model]\nname = pendulu\n[initial]\nq=1\np=0\n[integrator]\nh=1\nsteps=1\n", 2, "pendulu", "pendulum, harmonic"},
    {BASE_PEND "steps = 10\n[initial]\nq = 0.0.5\n", 10, "initial.q", "0.0.5"},
    {BASE_PEND "steps = 10\n[initial]\nt = nan\n", 10, "initial.t", "nan"},
    {BASE_PEND "steps = 10\n[initial]\np = inf\n", 10, "initial.p", "inf"},
    {BASE_PEND "steps = 10\n[initial]\np = 1, 2\n", 10, "initial.p", "2 values"},
    {BASE_PEND "steps = 10\n[initial]\nq = 1, 2\np = 0, 0\n", 10, "initial.q", "pendulum"},
    {"[model]\nname = harmonic\nomega = 1, 2, 3\n[initial]\nq = 1, 2\np = 0, 0\n[integrator]\nh=1\nsteps=1\n", 3, "model.omega", "3 values, expected 1 or 2"}, /* q sets n = 2 */
    {"[model]\nname = harmonic\nn = 2\nomega = 1, 2, 3\n[initial]\nq = 1, 2\np = 0, 0\n[integrator]\nh=1\nsteps=1\n", 4, "model.omega", "3 values"},
    {BASE_PEND "steps = 10\n[integrator]\nh = 0\n", 10, "integrator.h", "nonzero"},
    {BASE_PEND "steps = 10\n[integrator]\nh = 1e400\n", 10, "integrator.h", "1e400"},
    {BASE_PEND "steps = 10\n[integrator]\nmethod = rk5\n", 10, "integrator.method", "unknown method 'rk5' (available: dth, midpoint"},
    {BASE_PEND "steps = 10\n[integrator]\nstart = middle\n", 10, "integrator.start", "middle"},
    {BASE_PEND "steps = -1\n", 8, "integrator.steps", "-1"},
    {BASE_PEND "steps = 1.5\n", 8, "integrator.steps", "1.5"},
    {BASE_PEND "steps = 1e20\n", 8, "integrator.steps", "'1e20' is too large"},
    {BASE_PEND "steps = 99999999999999999999\n", 8, "integrator.steps", "too large"},
    {BASE_PEND "steps = 10\nmax_iter = 1e9\n", 9, "integrator.max_iter", "'1e9' is too large (an integer from 1 to 100000)"},
    {BASE_PEND "steps = 10\n[initial]\nt = 1e300\n", 10, "initial.t", "t + h == t"},
    {BASE_PEND "t_end = 1e300\nh = 1e-300\n", 8, "integrator.t_end", "cannot be reached"},
    {"[model]\nname = kepler\n[initial]\nq = 0, 0\np = 0, 1\n[integrator]\nh = 0.1\nsteps = 1\n", 4, "initial.q",
     "r = 0 is singular (q1 = 0, q2 = 0)"},
    {"[model]\nname = coupled\npreset = chain\nsize = 3\ndim = 2\n[initial]\nq = 0,0, 1,0, 1,0\np = 0,0, 0,0, 0,0\n"
     "[integrator]\nh = 0.1\nsteps = 1\n", 7, "initial.q", "particles 2 and 3 are at the same point"},
    {BASE_PEND "steps = 10\nt_end = 3\n", 9, "integrator.t_end", "not both"},
    {BASE_PEND "t_end = -3\n", 8, "integrator.t_end", "behind"},
    {BASE_PEND "steps = 10\nmax_iter = 0\n", 9, "integrator.max_iter", "0"},
    {BASE_PEND "steps = 10\nK = -1\n", 9, "integrator.K", "-1"},
    {BASE_PEND "steps = 10\n[initial]\nwp = 1\n", 10, "initial.wp", "start=vertex"},
    {BASE_PEND "steps = 10\n[initial]\nx = 1\n", 10, "initial.x", "unknown key"},
    {BASE_PEND "steps = 10\n[regularize]\nmethod = tunnel\n", 10, "regularize.method", "tunnel"},
    {BASE_PEND "steps = 10\n[regularize]\neps = 1\n", 10, "regularize.eps", "'land' has no parameter"},
    {BASE_PEND "steps = 10\n[regularize]\nmethod = none\neps = 1\n", 11, "regularize.eps", "no parameters"},
    {BASE_PEND "steps = 10\n[output]\nevery = 0\n", 10, "output.every", "0"},
    {BASE_PEND "steps = 10\n[output]\ndt = -1\n", 10, "output.dt", "-1"},
    {BASE_PEND "steps = 10\n[output]\ndt = 1e-12\n", 10, "output.dt", "rows per step"},
    {BASE_PEND "steps = 10\n[output]\ndt = 0.5\nevery = 2\n", 10, "output.dt", "every"},
    {BASE_PEND "steps = 10\n[output]\ndiagnostics = maybe\n", 10, "output.diagnostics", "maybe"},
    {BASE_PEND "steps = 10\n[output]\nfile =\n", 10, "output.file", "empty"},
    {BASE_PEND "steps = 10\n[outptu]\nfile = x\n", 10, "[outptu]", "unknown section"},
    {"h = 1\n" BASE_PEND "steps = 10\n", 1, "'h'", "outside"},
    {"[initial]\nq=1\np=0\n[integrator]\nh=1\nsteps=1\n", 0, "missing [model] name", "pendulum"},
    {"[model]\nname=pendulum\n[initial]\np=0\n[integrator]\nh=1\nsteps=1\n", 0, "missing [initial] q", "q="},
    {"[model]\nname=pendulum\n[initial]\nq=0\np=0\n[integrator]\nsteps=1\n", 0, "missing [integrator] h", "h="},
    {BASE_PEND, 0, "steps= or t_end=", "missing"},
};

static void test_bad_inputs(void)
{
    dth_registry *reg = registry();
    for (size_t i = 0; i < sizeof bad_cases / sizeof bad_cases[0]; i++) {
        const bad_case *b = &bad_cases[i];
        char path[64], err[512], want[128];
        write_scene(b->text, path, sizeof path);
        dth_scene *s;
        CU_ASSERT_FATAL(dth_scene_new(NULL, &s) == DTH_OK);
        CU_ASSERT_EQUAL_FATAL(dth_scene_load(s, path, err, sizeof err), DTH_OK);
        /* a failed setup leaves the caller's struct untouched */
        dth_run_setup rs, orig;
        memset(&rs, 0xA5, sizeof rs);
        orig = rs;
        err[0] = '\0';
        int rc = dth_scene_setup(s, reg, &rs, err, sizeof err);
        CU_ASSERT_EQUAL(rc, DTH_EINVAL);
        CU_ASSERT(memcmp(&rs, &orig, sizeof rs) == 0);
        if (b->line) snprintf(want, sizeof want, "%s:%d: ", path, b->line);
        else snprintf(want, sizeof want, "%s: ", path);
        int ok = strncmp(err, want, strlen(want)) == 0 && strstr(err, b->want1) && strstr(err, b->want2) &&
                 !strchr(err, '\n');
        if (!ok) fprintf(stderr, "\ncase %zu: got \"%s\", want prefix \"%s\" and \"%s\", \"%s\"\n", i, err, want,
                         b->want1, b->want2);
        CU_ASSERT(ok);
        if (rc == DTH_OK) dth_run_setup_clear(&rs);
        dth_scene_free(s);
        unlink(path);
    }
    dth_registry_free(reg);
}

/* Errors in overrides name the override instead of a line. */
static void test_bad_override_values(void)
{
    char path[64], err[512];
    write_scene(BASE_PEND "steps = 10\n", path, sizeof path);
    dth_registry *reg = registry();
    dth_scene *s;
    dth_run_setup rs;
    CU_ASSERT_FATAL(dth_scene_new(NULL, &s) == DTH_OK);
    CU_ASSERT_FATAL(dth_scene_load(s, path, err, sizeof err) == DTH_OK);
    CU_ASSERT_EQUAL_FATAL(dth_scene_setup(s, reg, &rs, err, sizeof err), DTH_OK);
    dth_run_setup_clear(&rs);
    CU_ASSERT_EQUAL(dth_scene_set(s, "integrator.h=abc", err, sizeof err), DTH_OK);
    CU_ASSERT_EQUAL(dth_scene_setup(s, reg, &rs, err, sizeof err), DTH_EINVAL);
    CU_ASSERT_PTR_NOT_NULL(strstr(err, "-s integrator.h=abc: integrator.h: 'abc'"));
    CU_ASSERT_EQUAL(dth_scene_set(s, "integrator.h=0.5", err, sizeof err), DTH_OK);
    CU_ASSERT_EQUAL(dth_scene_set(s, "model.name=nosuch", err, sizeof err), DTH_OK);
    CU_ASSERT_EQUAL(dth_scene_setup(s, reg, &rs, err, sizeof err), DTH_EINVAL);
    CU_ASSERT_PTR_NOT_NULL(strstr(err, "-s model.name=nosuch: model.name: unknown model 'nosuch'"));
    dth_scene_free(s);
    dth_registry_free(reg);
    unlink(path);
}

/* Indented lines continue a key's list (long q= and p= lists for many degrees of freedom). */
static void test_continuation(void)
{
    char path[64], err[512];
    write_scene("[model]\nname=harmonic\nomega=1,\n  2, 3\n[initial]\nq=1, 2,\n  3\np=4,\n\t5,\n\t6\n"
                "[integrator]\nh=0.1\nsteps=1\n", path, sizeof path);
    dth_registry *reg = registry();
    dth_scene *s;
    dth_run_setup rs;
    CU_ASSERT_FATAL(dth_scene_new(NULL, &s) == DTH_OK);
    CU_ASSERT_FATAL(dth_scene_load(s, path, err, sizeof err) == DTH_OK);
    CU_ASSERT_STRING_EQUAL(dth_scene_get(s, "initial", "q"), "1, 2,3");
    CU_ASSERT_EQUAL_FATAL(dth_scene_setup(s, reg, &rs, err, sizeof err), DTH_OK);
    CU_ASSERT_EQUAL(rs.n, 3);
    CU_ASSERT_EQUAL(rs.q0[2], 3.0);
    CU_ASSERT_EQUAL(rs.p0[0], 4.0);
    CU_ASSERT_EQUAL(rs.p0[2], 6.0);
    CU_ASSERT_EQUAL(dth_model_dof(rs.model), 3);
    dth_run_setup_clear(&rs);
    dth_scene_free(s);
    dth_registry_free(reg);
    unlink(path);
}

/* Loading from memory is loading from a file: same entries, same FILE:LINE messages. */
static void test_load_mem(void)
{
    char err[512];
    static const char text[] = "[model]\nname=pendulum\n[initial]\nq=0.5\np=0\n[integrator]\nh=0.1\nsteps=3\n";
    dth_registry *reg = registry();
    dth_scene *s;
    dth_run_setup rs;
    CU_ASSERT_FATAL(dth_scene_new(NULL, &s) == DTH_OK);
    CU_ASSERT_EQUAL_FATAL(dth_scene_load_mem(s, "mem.ini", text, sizeof text - 1, err, sizeof err), DTH_OK);
    CU_ASSERT_STRING_EQUAL(dth_scene_origin(s, "integrator", "steps"), "mem.ini:8");
    CU_ASSERT_EQUAL_FATAL(dth_scene_setup(s, reg, &rs, err, sizeof err), DTH_OK);
    CU_ASSERT_EQUAL(rs.q0[0], 0.5);
    CU_ASSERT_EQUAL(rs.steps, 3);
    dth_run_setup_clear(&rs);
    static const char bad[] = "[model]\nname=pendulum\nthis is not ini\n";
    CU_ASSERT_EQUAL(dth_scene_load_mem(s, "bad.ini", bad, sizeof bad - 1, err, sizeof err), DTH_EPARSE);
    CU_ASSERT_PTR_NOT_NULL(strstr(err, "bad.ini:3"));
    CU_ASSERT_EQUAL(dth_scene_load_mem(s, "empty.ini", NULL, 0, err, sizeof err), DTH_OK);
    CU_ASSERT_EQUAL(dth_scene_load_mem(s, "x", NULL, 5, err, sizeof err), DTH_EINVAL);
    dth_scene_free(s);
    dth_registry_free(reg);
}

/* ---- the scene as text: dth_scene_text reads back to the same entries, by construction ---- */

static unsigned long long rng = 0x243F6A8885A308D3ull;
static unsigned rnd(unsigned n)
{
    rng = rng * 6364136223846793005ull + 1442695040888963407ull;
    return (unsigned)(rng >> 33) % n;
}

/* Random text over an alphabet with every character the layout must respect. */
static void random_text(char *out, size_t len, const char *alpha)
{
    size_t na = strlen(alpha);
    for (size_t i = 0; i < len; i++) out[i] = alpha[rnd((unsigned)na)];
    out[len] = '\0';
}

/* Two scenes hold the same sections, keys and values (the text groups keys by section). */
static int same_entries(const dth_scene *a, const dth_scene *b)
{
    if (dth_scene_count(a) != dth_scene_count(b)) return 0;
    for (size_t i = 0; i < dth_scene_count(a); i++) {
        const char *s1, *k1, *v1, *v2;
        dth_scene_entry(a, i, &s1, &k1, &v1, NULL);
        v2 = dth_scene_get(b, s1, k1);
        if (!v2 || strcmp(v1, v2)) return 0;
    }
    return 1;
}

static int round_trips(const dth_scene *s, long *failed)
{
    char *text = NULL, err[512];
    size_t len;
    CU_ASSERT_FATAL(dth_scene_text(s, NULL, NULL, &text, &len) == DTH_OK);
    CU_ASSERT(strlen(text) == len);
    dth_scene *b;
    CU_ASSERT_FATAL(dth_scene_new(NULL, &b) == DTH_OK);
    int rc = dth_scene_load_mem(b, "saved.ini", text, len, err, sizeof err);
    int ok = rc == DTH_OK && same_entries(s, b);
    if (!ok && (*failed)++ < 3) {
        fprintf(stderr, "\nround trip failed (%s):\n%s\n", rc ? err : "entries differ", text);
        for (size_t i = 0; i < dth_scene_count(s); i++) {
            const char *s1, *k1, *v1;
            dth_scene_entry(s, i, &s1, &k1, &v1, NULL);
            fprintf(stderr, "  [%s] <%s> = <%s>\n", s1, k1, v1);
        }
    }
    dth_scene_free(b);
    dth_free(NULL, text);
    return ok;
}

static int skip_steps(void *ctx, const char *section, const char *key)
{
    (void)ctx;
    return strcmp(section, "integrator") || strcmp(key, "steps");
}

static void test_text_round_trip(void)
{
    /* overrides: whatever dth_scene_set accepts is written so that it loads back the same */
    static const char alpha[] = "12,,, ;#[]=:ab\t.e-";
    long accepted = 0, refused = 0, failed = 0;
    char err[512];
    for (int trial = 0; trial < 3000; trial++) {
        dth_scene *s;
        CU_ASSERT_FATAL(dth_scene_new(NULL, &s) == DTH_OK);
        for (int k = 0; k < 3; k++) {
            char sec[8], key[8], val[700], as[800];
            random_text(sec, 1 + rnd(3), "abc]; ");
            random_text(key, 1 + rnd(3), "xyz=:;#[ ");
            random_text(val, rnd(trial % 5 == 0 ? 650 : 40), alpha);
            snprintf(as, sizeof as, "%s.%s=%s", sec, key, val);
            int rc = dth_scene_set(s, as, err, sizeof err);
            CU_ASSERT(rc == DTH_OK || rc == DTH_EPARSE);
            if (rc == DTH_OK) accepted++;
            else {
                refused++;
                int named = strstr(err, "a scene file cannot hold") || strstr(err, "expected section.key=value");
                if (!named) fprintf(stderr, "\nunexpected message: %s\n", err);
                CU_ASSERT(named);
            }
        }
        CU_ASSERT(round_trips(s, &failed));
        dth_scene_free(s);
    }
    printf("  [overrides: %ld accepted, %ld refused]\n", accepted, refused);
    CU_ASSERT(accepted > 1000 && refused > 1000);
    /* files: whatever the loader reads is written so that it loads back the same (long lists over
     * continuation lines, lines up to the limit, comments, blank continuation candidates) */
    long loaded = 0;
    for (int trial = 0; trial < 3000; trial++) {
        char text[4096];
        size_t n = 0;
        n += (size_t)sprintf(text + n, "[s%u]\n", rnd(3));
        for (int line = 0; line < 12; line++) {
            char body[260];
            random_text(body, rnd(5) ? rnd(60) : 150 + rnd(60), "1234,,, ;#ab");
            switch (rnd(5)) {
            case 0: n += (size_t)sprintf(text + n, "; %s\n", body); break;
            case 1: n += (size_t)sprintf(text + n, "  %s\n", body); break;       /* continuation */
            case 2: n += (size_t)sprintf(text + n, "\t%s\n", body); break;
            default: n += (size_t)sprintf(text + n, "k%u = %s\n", rnd(4), body); break;
            }
        }
        dth_scene *s;
        CU_ASSERT_FATAL(dth_scene_new(NULL, &s) == DTH_OK);
        if (dth_scene_load_mem(s, "r.ini", text, n, err, sizeof err) == DTH_OK) {
            loaded++;
            long f0 = failed;
            CU_ASSERT(round_trips(s, &failed));
            if (failed != f0 && failed <= 3) fprintf(stderr, "from the file:\n%.*s\n", (int)n, text);
        }
        dth_scene_free(s);
    }
    printf("  [files: %ld of 3000 loaded]\n", loaded);
    CU_ASSERT(loaded > 300);
    CU_ASSERT(failed == 0);
    /* the writer's own layout: a long list over lines of at most 197 characters */
    dth_scene *s;
    CU_ASSERT_FATAL(dth_scene_new(NULL, &s) == DTH_OK);
    char big[20000] = "initial.q=";
    for (int i = 0; i < 3000; i++) snprintf(big + strlen(big), sizeof big - strlen(big), "%d,", i);
    CU_ASSERT(dth_scene_set(s, big, err, sizeof err) == DTH_OK);
    char *text;
    size_t len;
    CU_ASSERT_FATAL(dth_scene_text(s, NULL, NULL, &text, &len) == DTH_OK);
    size_t lines = 0, longest = 0;
    for (char *p = text, *e; *p; p = e + 1) {
        e = strchr(p, '\n');
        CU_ASSERT_FATAL(e != NULL);
        longest = (size_t)(e - p) > longest ? (size_t)(e - p) : longest;
        lines++;
    }
    CU_ASSERT(longest <= 197 && longest >= 190);
    CU_ASSERT(lines > 70);
    dth_free(NULL, text);
    /* keep() leaves keys out */
    CU_ASSERT(dth_scene_set(s, "integrator.steps=5", err, sizeof err) == DTH_OK);
    CU_ASSERT_FATAL(dth_scene_text(s, skip_steps, NULL, &text, &len) == DTH_OK);
    CU_ASSERT(strstr(text, "steps") == NULL && strstr(text, "q=0,1,2") != NULL);
    dth_free(NULL, text);
    /* what no file can hold, named */
    const char *bad[] = {"a.b=x ;y", "a.b:c=1", "a].b=1", "a.;b=1", "a.b=1\n2", "a.b=\x01", NULL};
    for (int i = 0; bad[i]; i++) {
        CU_ASSERT(dth_scene_set(s, bad[i], err, sizeof err) == DTH_EPARSE);
        CU_ASSERT(strstr(err, "a scene file cannot hold") != NULL);
    }
    char longval[400] = "a.b=";
    memset(longval + 4, '7', 300);
    longval[304] = '\0';
    CU_ASSERT(dth_scene_set(s, longval, err, sizeof err) == DTH_EPARSE);
    CU_ASSERT(strstr(err, "197") != NULL);
    dth_scene_free(s);
}

/* A NUL byte hides the rest of its line from a C-string reader: refused, naming the line; a line
 * of exactly 197 characters loads, one of 198 is refused (also with CR LF line ends). */
static void test_nul_and_line_limit(void)
{
    dth_scene *s;
    char err[512];
    CU_ASSERT_FATAL(dth_scene_new(NULL, &s) == DTH_OK);
    static const char nul[] = "[model]\nname = pendulum\nomega2 = 1\0 ; hidden\n";
    CU_ASSERT(dth_scene_load_mem(s, "nul.ini", nul, sizeof nul - 1, err, sizeof err) == DTH_EPARSE);
    CU_ASSERT(strstr(err, "nul.ini:3") != NULL && strstr(err, "NUL") != NULL);
    CU_ASSERT(dth_scene_count(s) == 0);
    for (int crlf = 0; crlf < 2; crlf++)
        for (int extra = 0; extra < 2; extra++) {
            char text[400];
            int n = snprintf(text, sizeof text, "[a]\nk = %0*d%s", 197 - 4 + extra, 0, crlf ? "\r\n" : "\n");
            int rc = dth_scene_load_mem(s, "l.ini", text, (size_t)n, err, sizeof err);
            CU_ASSERT(rc == (extra ? DTH_EPARSE : DTH_OK));
            if (extra) CU_ASSERT(strstr(err, "l.ini:2: line longer than 197") != NULL);
        }
    dth_scene_free(s);
}

/* dth_scene_set_from (issue 25): the caller names the override's source, in messages and in
 * dth_scene_origin; it is an override all the same (one of steps/t_end replaces a file's other). */
static void test_set_from_vary(void)
{
    dth_registry *reg = registry();
    dth_scene *s;
    char err[512] = "";
    CU_ASSERT_FATAL(dth_scene_new(NULL, &s) == DTH_OK);
    const char *text = BASE_PEND "t_end = 5\n";
    CU_ASSERT_FATAL(dth_scene_load_mem(s, "f.ini", text, strlen(text), err, sizeof err) == DTH_OK);
    CU_ASSERT(dth_scene_set_from(s, "--vary integrator.hh=1", "integrator.hh=1", err, sizeof err) == DTH_OK);
    CU_ASSERT_STRING_EQUAL(dth_scene_origin(s, "integrator", "hh"), "--vary integrator.hh=1");
    dth_run_setup rs;
    CU_ASSERT_EQUAL(dth_scene_setup(s, reg, &rs, err, sizeof err), DTH_EINVAL);
    CU_ASSERT(strncmp(err, "--vary integrator.hh=1: integrator.hh: unknown key", 50) == 0);
    CU_ASSERT(dth_scene_set_from(s, "list.csv:3", "integratorhh=1", err, sizeof err) == DTH_EPARSE);
    CU_ASSERT_STRING_EQUAL(err, "list.csv:3: expected section.key=value");
    CU_ASSERT(dth_scene_set(s, "integrator.hh=2", err, sizeof err) == DTH_OK); /* the -s form as before */
    CU_ASSERT_STRING_EQUAL(dth_scene_origin(s, "integrator", "hh"), "-s integrator.hh=2");
    dth_scene_free(s);
    /* steps from the caller replaces the file's t_end, as a -s does */
    CU_ASSERT_FATAL(dth_scene_new(NULL, &s) == DTH_OK);
    CU_ASSERT_FATAL(dth_scene_load_mem(s, "f.ini", text, strlen(text), err, sizeof err) == DTH_OK);
    CU_ASSERT(dth_scene_set_from(s, "row 3", "integrator.steps=7", err, sizeof err) == DTH_OK);
    CU_ASSERT_EQUAL_FATAL(dth_scene_setup(s, reg, &rs, err, sizeof err), DTH_OK);
    CU_ASSERT(!rs.has_t_end && rs.steps == 7);
    dth_run_setup_clear(&rs);
    dth_scene_free(s);
    dth_registry_free(reg);
}

/* A number may be as long as a line allows (issue 24): 190 digits in a list (as a file line, and as
 * an override) read as the number they spell; one digit more than a line holds is a line error. */
static void test_long_number(void)
{
    dth_registry *reg = registry();
    char num[200], text[600], set[240], err[512];
    snprintf(num, sizeof num, "0.5%0187d", 1); /* 0.5000...0001: 190 characters */
    CU_ASSERT_FATAL(strlen(num) == 190);
    for (int via_set = 0; via_set < 2; via_set++) {
        snprintf(text, sizeof text, "[model]\nname = harmonic\n[initial]\nq = %s,\n  %s\np = 0, 0\n"
                 "[integrator]\nh = 0.1\nsteps = 3\n", via_set ? "1" : num, via_set ? "2" : num);
        dth_scene *s;
        dth_run_setup rs;
        CU_ASSERT_FATAL(dth_scene_new(NULL, &s) == DTH_OK);
        CU_ASSERT_FATAL(dth_scene_load_mem(s, "long.ini", text, strlen(text), err, sizeof err) == DTH_OK);
        snprintf(set, sizeof set, "initial.q = %s, 2", num);
        if (via_set) CU_ASSERT_FATAL(dth_scene_set(s, set, err, sizeof err) == DTH_OK);
        int rc = dth_scene_setup(s, reg, &rs, err, sizeof err);
        CU_ASSERT_EQUAL(rc, DTH_OK);
        if (rc) {
            printf("  %s\n", err);
        } else {
            CU_ASSERT(rs.n == 2 && rs.q0[0] == 0.5 && rs.q0[1] == (via_set ? 2 : 0.5));
            dth_run_setup_clear(&rs);
        }
        dth_scene_free(s);
    }
    double x[2];
    size_t n;
    CU_ASSERT(dth__parse_list(num, x, 2, &n) == 0 && n == 1 && x[0] == 0.5);
    CU_ASSERT(dth__parse_list("1, 2x", x, 2, &n) != 0);  /* still whole items only */
    CU_ASSERT(dth__parse_list("1,,2", x, 2, &n) != 0);
    CU_ASSERT(dth__parse_list(" 1 , 2 ", x, 2, &n) == 0 && n == 2 && x[1] == 2);
    dth_registry_free(reg);
}

/* Without [regularize] method=, DTH runs get the default regularizer `land` (a new scene crosses
 * psi = 0) and the baselines none; method = none keeps raw DTH; the retired `smooth` is named as such. */
static void test_default_regularizer(void)
{
    dth_registry *reg = registry();
    struct {
        const char *text, *want;
        int has;
    } c[] = {
        {BASE_PEND "steps = 10\n", "land", 1},
        {BASE_PEND "method = gauss4\nsteps = 10\n", "none", 0},
        {BASE_PEND "steps = 10\n[regularize]\nmethod = none\n", "none", 0},
        {BASE_PEND "steps = 10\n[regularize]\nkappa = 0.02\n", "land", 1},
    };
    for (size_t i = 0; i < sizeof c / sizeof c[0]; i++) {
        char path[64], err[512];
        write_scene(c[i].text, path, sizeof path);
        dth_scene *s;
        CU_ASSERT_FATAL(dth_scene_new(NULL, &s) == DTH_OK);
        CU_ASSERT_FATAL(dth_scene_load(s, path, err, sizeof err) == DTH_OK);
        dth_run_setup rs;
        CU_ASSERT_EQUAL_FATAL(dth_scene_setup(s, reg, &rs, err, sizeof err), DTH_OK);
        CU_ASSERT_STRING_EQUAL(rs.regularize, c[i].want);
        CU_ASSERT_EQUAL(rs.regularizer != NULL, c[i].has);
        CU_ASSERT(rs.opt.regularizer == rs.regularizer);
        dth_run_setup_clear(&rs);
        dth_scene_free(s);
        unlink(path);
    }
    char path[64], err[512];
    write_scene(BASE_PEND "steps = 10\n[regularize]\nmethod = smooth\n", path, sizeof path);
    dth_scene *s;
    CU_ASSERT_FATAL(dth_scene_new(NULL, &s) == DTH_OK);
    CU_ASSERT_FATAL(dth_scene_load(s, path, err, sizeof err) == DTH_OK);
    dth_run_setup rs;
    CU_ASSERT_EQUAL(dth_scene_setup(s, reg, &rs, err, sizeof err), DTH_EINVAL);
    CU_ASSERT(strstr(err, "regularizer 'smooth' was retired") != NULL);
    CU_ASSERT(strstr(err, "available: land, none, prescribed") != NULL);
    dth_scene_free(s);
    unlink(path);
    dth_registry_free(reg);
}

/* A program's own registry holding a model but no regularizer: the default regularizer (smooth, for
 * DTH) cannot be found, which is a message naming it and the fix, not a crash; none (the fix, and a
 * baseline's default) needs no registered type. */
static void test_registry_without_regularizers(void)
{
    dth_registry *reg = NULL;
    CU_ASSERT_FATAL(dth_registry_new(NULL, &reg) == DTH_OK);
    CU_ASSERT_FATAL(dth_registry_add_model(reg, &dth_model_harmonic) == DTH_OK);
    static const char *base = "[model]\nname = harmonic\n[initial]\nq = 1\np = 0\n[integrator]\nh = 0.1\nsteps = 3\n";
    char err[512] = "";
    dth_scene *s;
    dth_run_setup rs;
    memset(&rs, 0, sizeof rs);
    CU_ASSERT_FATAL(dth_scene_new(NULL, &s) == DTH_OK);
    CU_ASSERT_FATAL(dth_scene_load_mem(s, "own.ini", base, strlen(base), err, sizeof err) == DTH_OK);
    CU_ASSERT_EQUAL(dth_scene_setup(s, reg, &rs, err, sizeof err), DTH_EINVAL);
    CU_ASSERT(strstr(err, "own.ini: [regularize]: the default regularizer 'land' is not in the registry") != NULL);
    CU_ASSERT(strstr(err, "method = none") != NULL);
    CU_ASSERT(rs.model == NULL); /* untouched on failure */
    /* the fix the message names, and a baseline (default none) */
    const char *fixes[] = {"regularize.method=none", "integrator.method=rk4"};
    for (int i = 0; i < 2; i++) {
        dth_scene *t;
        CU_ASSERT_FATAL(dth_scene_new(NULL, &t) == DTH_OK);
        CU_ASSERT_FATAL(dth_scene_load_mem(t, "own.ini", base, strlen(base), err, sizeof err) == DTH_OK);
        CU_ASSERT_FATAL(dth_scene_set(t, fixes[i], err, sizeof err) == DTH_OK);
        CU_ASSERT_EQUAL_FATAL(dth_scene_setup(t, reg, &rs, err, sizeof err), DTH_OK);
        CU_ASSERT_STRING_EQUAL(rs.regularize, "none");
        CU_ASSERT(rs.regularizer == NULL);
        dth_run_setup_clear(&rs);
        dth_scene_free(t);
    }
    dth_scene_free(s);
    dth_registry_free(reg);
}

/* The default regularizer (no method= line) refusing a parameter whose name its message does not
 * quote: an error naming the override, not a NULL entry (found by fuzz_override). Also the new
 * [output] points and [events] keys: resolved, and bad values named. */
static void test_default_regularizer_bad_key_and_events(void)
{
    dth_registry *reg = registry();
    char path[64], err[512];
    write_scene(BASE_PEND "steps = 10\n", path, sizeof path);
    struct {
        const char *override, *want; /* want NULL: accepted */
    } c[] = {
        {"regularize.ste'p=1", "regularize.ste'p"},
        {"output.points=midpoints", NULL},
        {"events.section=p1", NULL},
        {"events.section=p2", "the model has 1 degree of freedom"},
        {"events.distance_dofs=", "needs [events] distance="},
        {"events.time=1,nan", "not a comma-separated list"},
        {"events.frobnicate=1", "unknown key (known in [events]"},
    };
    for (size_t i = 0; i < sizeof c / sizeof c[0]; i++) {
        dth_scene *s;
        CU_ASSERT_FATAL(dth_scene_new(NULL, &s) == DTH_OK);
        CU_ASSERT_FATAL(dth_scene_load(s, path, err, sizeof err) == DTH_OK);
        CU_ASSERT_FATAL(dth_scene_set(s, c[i].override, err, sizeof err) == DTH_OK);
        dth_run_setup rs;
        memset(&rs, 0, sizeof rs);
        err[0] = '\0';
        int rc = dth_scene_setup(s, reg, &rs, err, sizeof err);
        if (c[i].want) {
            CU_ASSERT_EQUAL(rc, DTH_EINVAL);
            CU_ASSERT(strstr(err, c[i].want) != NULL);
            if (!strstr(err, c[i].want)) printf("  %s: %s\n", c[i].override, err);
        } else {
            CU_ASSERT_EQUAL(rc, DTH_OK);
            if (!rc && strstr(c[i].override, "points")) CU_ASSERT(rs.points == DTH_POINTS_MIDPOINTS);
            if (!rc && strstr(c[i].override, "section")) CU_ASSERT(rs.nevents == 1 && rs.event_specs[0].index == 2);
            dth_run_setup_clear(&rs);
        }
        dth_scene_free(s);
    }
    unlink(path);
    dth_registry_free(reg);
}

/* An override named by its caller (dth_scene_set_from: a binding's set=): messages and the origin name
 * it, and it is an override like -s (steps= replaces the file's t_end=). */
static void test_set_from(void)
{
    char path[64], err[512];
    write_scene(good_pendulum, path, sizeof path);
    dth_registry *reg = registry();
    dth_scene *s;
    dth_run_setup rs;
    CU_ASSERT_FATAL(dth_scene_new(NULL, &s) == DTH_OK);
    CU_ASSERT_FATAL(dth_scene_load(s, path, err, sizeof err) == DTH_OK);
    CU_ASSERT_EQUAL(dth_scene_set_from(s, "set={'integrator.hh': 1}", "integrator.hh=1", err, sizeof err), DTH_OK);
    CU_ASSERT_STRING_EQUAL(dth_scene_origin(s, "integrator", "hh"), "set={'integrator.hh': 1}");
    CU_ASSERT_EQUAL(dth_scene_setup(s, reg, &rs, err, sizeof err), DTH_EINVAL);
    CU_ASSERT(strncmp(err, "set={'integrator.hh': 1}: integrator.hh: unknown key", 51) == 0);
    CU_ASSERT(strstr(err, "-s") == NULL);
    dth_scene_free(s);
    CU_ASSERT_FATAL(dth_scene_new(NULL, &s) == DTH_OK);
    CU_ASSERT_FATAL(dth_scene_load(s, path, err, sizeof err) == DTH_OK);
    CU_ASSERT_EQUAL(dth_scene_set_from(s, "set={'integrator.steps': 5}", "integrator.steps=5", err, sizeof err), DTH_OK);
    CU_ASSERT_EQUAL_FATAL(dth_scene_setup(s, reg, &rs, err, sizeof err), DTH_OK);
    CU_ASSERT(rs.has_t_end == 0 && rs.steps == 5);
    dth_run_setup_clear(&rs);
    /* refusals name it too */
    CU_ASSERT_EQUAL(dth_scene_set_from(s, "set={'model.name': ...}", "model.name=pendulum\nomega2 = 4", err, sizeof err),
                    DTH_EPARSE);
    CU_ASSERT(strncmp(err, "set={'model.name': ...}: a scene file cannot hold this (a control character)", 70) == 0);
    CU_ASSERT_EQUAL(dth_scene_set_from(s, "set=[('x', 1)]", "x=1", err, sizeof err), DTH_EPARSE);
    CU_ASSERT_PTR_NOT_NULL(strstr(err, "set=[('x', 1)]: expected section.key=value"));
    /* what a scene file holds, checked alone (a caller writing scene text) */
    CU_ASSERT_EQUAL(dth_scene_check_entry("model", "name", "pendulum", err, sizeof err), DTH_OK);
    CU_ASSERT_EQUAL(dth_scene_check_entry("model", "name", "pendulum\nomega2 = 4", err, sizeof err), DTH_EPARSE);
    CU_ASSERT_PTR_NOT_NULL(strstr(err, "model.name: a scene file cannot hold this (a control character)"));
    CU_ASSERT_EQUAL(dth_scene_check_entry("model]\n[x", "name", "p", err, sizeof err), DTH_EPARSE);
    CU_ASSERT_EQUAL(dth_scene_check_entry("model", "a=b", "p", err, sizeof err), DTH_EPARSE);
    CU_ASSERT_EQUAL(dth_scene_check_entry("model", "name", "p ; c", err, sizeof err), DTH_EPARSE);
    dth_scene_free(s);
    dth_registry_free(reg);
    unlink(path);
}

/* What a resume may change (one rule for dth run --resume and the Python package): the run's length
 * and the file names; with DTH_RESUME_ROWS also every and diagnostics; anything else is named. */
static void test_resume_rule(void)
{
    static const char text[] = "[model]\nname=pendulum\n[initial]\nq=1\np=0\n[integrator]\nh=0.05\nsteps=100\n"
                               "[output]\nfile=o.csv\n";
    char err[512];
    dth_scene *saved, *now;
    CU_ASSERT_FATAL(dth_scene_new(NULL, &saved) == DTH_OK && dth_scene_new(NULL, &now) == DTH_OK);
    CU_ASSERT_FATAL(dth_scene_load_mem(saved, "s.ini", text, strlen(text), err, sizeof err) == DTH_OK);
    CU_ASSERT_FATAL(dth_scene_load_mem(now, "s.ini", text, strlen(text), err, sizeof err) == DTH_OK);
    const char *ok[] = {"integrator.steps=500", "integrator.t_end=9", "output.file=b.csv", "events.file=e.csv", NULL};
    for (int i = 0; ok[i]; i++) CU_ASSERT(dth_scene_set(now, ok[i], err, sizeof err) == DTH_OK);
    CU_ASSERT(dth_scene_resume_check(saved, now, 0, "--resume", err, sizeof err) == DTH_OK);
    CU_ASSERT(dth_scene_set_from(now, "set={'output.every': 5}", "output.every=5", err, sizeof err) == DTH_OK);
    CU_ASSERT(dth_scene_resume_check(saved, now, 0, "--resume", err, sizeof err) == DTH_EINVAL);
    CU_ASSERT(strncmp(err, "set={'output.every': 5}: output.every = '5' would change the checkpointed run", 70) == 0);
    CU_ASSERT(dth_scene_resume_check(saved, now, DTH_RESUME_ROWS, NULL, err, sizeof err) == DTH_OK);
    CU_ASSERT(dth_scene_set_from(now, "set={'model.omega2': 1.1}", "model.omega2=1.1", err, sizeof err) == DTH_OK);
    CU_ASSERT(dth_scene_resume_check(saved, now, DTH_RESUME_ROWS, NULL, err, sizeof err) == DTH_EINVAL);
    CU_ASSERT_PTR_NOT_NULL(strstr(err, "set={'model.omega2': 1.1}: model.omega2 = '1.1' would change the checkpointed "
                                       "run (it ran without it)"));
    CU_ASSERT_PTR_NOT_NULL(strstr(err, "output.file, output.every, output.diagnostics and events.file"));
    /* a key the resumed scene lacks is named by `what` */
    dth_scene_free(now);
    CU_ASSERT_FATAL(dth_scene_new(NULL, &now) == DTH_OK);
    CU_ASSERT(dth_scene_resume_check(saved, now, 0, "--resume", err, sizeof err) == DTH_EINVAL);
    CU_ASSERT(strncmp(err, "--resume: model.name = (unset) would change", 40) == 0);
    const char *fixed[][2] = {{"model", "omega2"}, {"initial", "q"}, {"integrator", "h"}, {"integrator", "method"},
                              {"regularize", "method"}, {"output", "dt"}, {"output", "points"}, {"events", "section"}};
    for (size_t i = 0; i < sizeof fixed / sizeof *fixed; i++)
        CU_ASSERT(!dth_scene_resume_may_change(fixed[i][0], fixed[i][1], DTH_RESUME_ROWS));
    CU_ASSERT(dth_scene_resume_may_change("output", "every", DTH_RESUME_ROWS));
    CU_ASSERT(!dth_scene_resume_may_change("output", "every", 0));
    dth_scene_free(saved);
    dth_scene_free(now);
}

static CU_TestInfo scene_tests[] = {
    {"scene text from memory", test_load_mem},
    {"indented lines continue a list", test_continuation},
    {"good scene: every key reaches the run setup", test_good_scene},
    {"defaults, a 2-D harmonic oscillator", test_defaults_and_harmonic},
    {"overrides replace values and name themselves", test_overrides},
    {"load errors: missing file, syntax, long line; no partial load", test_load_errors},
    {"bad inputs: status, FILE:LINE, key; output untouched", test_bad_inputs},
    {"bad override values name the override", test_bad_override_values},
    {"dth_scene_text loads back to the same entries (random overrides and files)", test_text_round_trip},
    {"a NUL byte is refused; the 197-character line limit, exactly", test_nul_and_line_limit},
    {"a number as long as a line", test_long_number},
    {"overrides named by their caller: --vary, list rows (dth_scene_set_from)", test_set_from_vary},
    {"default regularizer: land for DTH, none for baselines", test_default_regularizer},
    {"a registry without regularizers: a message, not a crash", test_registry_without_regularizers},
    {"the default regularizer refusing a key; [output] points and [events]", test_default_regularizer_bad_key_and_events},
    {"an override named by its caller (dth_scene_set_from); dth_scene_check_entry", test_set_from},
    {"what a resume may change (dth_scene_resume_check)", test_resume_rule},
    CU_TEST_INFO_NULL,
};

CU_SuiteInfo dth_test_suites[] = {
    {.pName = "scene", .pTests = scene_tests},
    CU_SUITE_INFO_NULL,
};
