/* SPDX-License-Identifier: MIT */
/*
 * dth run's checkpoint blob (cli/ckpt.c): every field written is read back; a truncated, extended
 * or crafted blob (negative counts, unterminated or relative paths, NUL bytes, unknown, repeated or
 * missing fields, another version) is refused with a message naming the field, never read out of
 * bounds; what a resume may change of the scene and of the run's length.
 */
#include <math.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include "cu_main.h"
#include "ckpt.h"

static cli_ckpt sample(void)
{
    cli_ckpt c;
    memset(&c, 0, sizeof c);
    dth_run_state *S = &c.S;
    S->started = 1;
    S->pending = 1;
    S->k = 1234;
    S->k0 = 7;
    S->samples = 1200;
    S->events = 3;
    S->j = 99;
    S->t = 61.25;
    S->t_first = -0.025;
    S->in = (dth_step_info){0.05000000000000071, 2, 1e-17, DTH_BRANCH_PLUS, DTH_STEP_CROSSING, 0, 0.5e-9};
    S->crossings = 5;
    S->regularized = 4;
    S->nonreversible = 2;
    S->max_ratio = 1.24;
    S->prev_crossing = 1;
    S->stop = DTH_RUN_RUNNING;
    S->t_stop = 61.2;
    S->in.proj_iters = 3;
    c.scene_hash = 0x0123456789abcdefULL;
    c.out = (cli_ckpt_out){strdup("/data/run/o.csv"), strdup("/data/run/o.csv.tmp.77.AbCdEf"), 123456, 0xfeedULL};
    c.ev = (cli_ckpt_out){strdup(""), strdup(""), 0, CLI_FNV_OFFSET};
    return c;
}

static int same(const cli_ckpt *a, const cli_ckpt *b)
{
    return memcmp(&a->S, &b->S, sizeof a->S) == 0 && a->scene_hash == b->scene_hash && !strcmp(a->out.path, b->out.path) &&
           !strcmp(a->out.tmp, b->out.tmp) && a->out.bytes == b->out.bytes && a->out.hash == b->out.hash &&
           !strcmp(a->ev.path, b->ev.path) && !strcmp(a->ev.tmp, b->ev.tmp) && a->ev.bytes == b->ev.bytes &&
           a->ev.hash == b->ev.hash;
}

/* Offset of the value of field `name` in a blob (after: u8 type, u8 name length, name). */
static size_t value_at(const unsigned char *b, size_t len, const char *name)
{
    size_t nl = strlen(name);
    for (size_t i = 16; i + 2 + nl <= len; i++)
        if (b[i + 1] == nl && memcmp(b + i + 2, name, nl) == 0 && b[i] >= 1 && b[i] <= 3) return i + 2 + nl;
    return 0;
}

static void put64(unsigned char *p, uint64_t v)
{
    for (int i = 0; i < 8; i++) p[i] = (unsigned char)(v >> (8 * i));
}

static void test_round_trip(void)
{
    cli_ckpt c = sample(), d;
    unsigned char *b;
    size_t len;
    char err[256];
    CU_ASSERT_FATAL(cli_ckpt_encode(&c, &b, &len) == 0);
    CU_ASSERT_FATAL(cli_ckpt_decode(b, len, &d, err, sizeof err) == 0);
    CU_ASSERT(same(&c, &d));
    cli_ckpt_clear(&d);
    /* a NaN residual (no ordinary step yet) is kept */
    c.S.in.residual = NAN;
    free(b);
    CU_ASSERT_FATAL(cli_ckpt_encode(&c, &b, &len) == 0);
    CU_ASSERT(cli_ckpt_decode(b, len, &d, err, sizeof err) == 0 && isnan(d.S.in.residual));
    cli_ckpt_clear(&d);
    free(b);
    cli_ckpt_clear(&c);
}

/* Any truncation or extension, and any flipped byte: refused with a message, or read within range. */
static void test_damaged(void)
{
    cli_ckpt c = sample(), d;
    unsigned char *b;
    size_t len;
    char err[256];
    CU_ASSERT_FATAL(cli_ckpt_encode(&c, &b, &len) == 0);
    unsigned char *x = malloc(len + 8);
    CU_ASSERT_FATAL(x != NULL);
    long wrong = 0, accepted = 0;
    for (size_t l = 0; l < len; l++) {
        err[0] = '\0';
        if (cli_ckpt_decode(b, l, &d, err, sizeof err) == 0 || !err[0]) wrong++;
        cli_ckpt_clear(&d);
    }
    memcpy(x, b, len);
    x[len] = 0;
    if (cli_ckpt_decode(x, len + 1, &d, err, sizeof err) == 0) wrong++;
    cli_ckpt_clear(&d);
    for (size_t i = 0; i < len; i++)
        for (int bit = 0; bit < 8; bit++) {
            memcpy(x, b, len);
            x[i] ^= (unsigned char)(1u << bit);
            err[0] = '\0';
            if (cli_ckpt_decode(x, len, &d, err, sizeof err) == 0) {
                accepted++; /* a value changed within its range: the library's checksum guards the bytes */
                if (d.S.k < 0 || d.S.k0 > d.S.k || d.S.samples < 0 || !isfinite(d.S.t) || d.S.in.branch > DTH_BRANCH_REG ||
                    d.S.in.flags > 31 || (d.out.path[0] && d.out.path[0] != '/') || strlen(d.out.path) > 4096)
                    wrong++;
            } else if (!err[0]) {
                wrong++;
            }
            cli_ckpt_clear(&d);
        }
    printf("  [%zu bytes: every truncation refused; %ld of %zu single-bit flips read back within range]\n", len, accepted,
           8 * len);
    CU_ASSERT(wrong == 0);
    free(x);
    free(b);
    cli_ckpt_clear(&c);
}

/* Crafted content, one field at a time: the message names what is wrong. */
static void test_crafted(void)
{
    cli_ckpt c = sample(), d;
    unsigned char *b;
    size_t len;
    char err[256];
    CU_ASSERT_FATAL(cli_ckpt_encode(&c, &b, &len) == 0);
    unsigned char *x = malloc(len + 8192);
    CU_ASSERT_FATAL(x != NULL);
    struct {
        const char *field;
        uint64_t v;
        const char *says;
    } bad[] = {
        {"run.k", (uint64_t)-1, "'run.k' is out of range"},
        {"run.k0", 5000, "exceeds"},
        {"run.samples", (uint64_t)-5, "'run.samples' is out of range"},
        {"run.in.branch", 9, "'run.in.branch' is out of range"},
        {"run.in.flags", 32, "'run.in.flags'"},
        {"run.stop", 7, "'run.stop'"},
        {"run.started", 2, "'run.started'"},
        {"run.t", 0x7ff0000000000000ULL, "'run.t' holds an invalid value"},
        {"run.max_ratio", 0xbff0000000000000ULL, "'run.max_ratio'"},
        {"out.bytes", (uint64_t)1 << 63, "byte count"},
    };
    for (size_t i = 0; i < sizeof bad / sizeof bad[0]; i++) {
        memcpy(x, b, len);
        size_t at = value_at(x, len, bad[i].field);
        CU_ASSERT_FATAL(at != 0);
        put64(x + at, bad[i].v);
        err[0] = '\0';
        int rc = cli_ckpt_decode(x, len, &d, err, sizeof err);
        if (rc == 0 || !strstr(err, bad[i].says)) printf("  [%s: '%s']\n", bad[i].field, err);
        CU_ASSERT(rc != 0 && strstr(err, bad[i].says) != NULL);
        cli_ckpt_clear(&d);
    }
    /* strings: a NUL inside, a relative path, a length past the end or beyond 4096 */
    size_t at = value_at(b, len, "out.path"); /* u32 length, then the bytes */
    CU_ASSERT_FATAL(at != 0);
    memcpy(x, b, len);
    x[at + 4 + 3] = '\0';
    CU_ASSERT(cli_ckpt_decode(x, len, &d, err, sizeof err) != 0 && strstr(err, "NUL") != NULL);
    cli_ckpt_clear(&d);
    memcpy(x, b, len);
    x[at + 4] = 'd';
    CU_ASSERT(cli_ckpt_decode(x, len, &d, err, sizeof err) != 0 && strstr(err, "absolute") != NULL);
    cli_ckpt_clear(&d);
    memcpy(x, b, len);
    x[at] = 0xff, x[at + 1] = 0xff, x[at + 2] = 0, x[at + 3] = 0;
    CU_ASSERT(cli_ckpt_decode(x, len, &d, err, sizeof err) != 0 && strstr(err, "longer than 4096") != NULL);
    cli_ckpt_clear(&d);
    memcpy(x, b, len);
    x[at] = 0xf0, x[at + 1] = 0x0f, x[at + 2] = 0, x[at + 3] = 0; /* 4080 bytes: past the end */
    CU_ASSERT(cli_ckpt_decode(x, len, &d, err, sizeof err) != 0 && strstr(err, "truncated") != NULL);
    cli_ckpt_clear(&d);
    /* names: unknown, repeated; a field missing (the count says one less); another version */
    size_t kname = value_at(b, len, "run.k") - 5;
    memcpy(x, b, len);
    x[kname + 4] = 'K';
    CU_ASSERT(cli_ckpt_decode(x, len, &d, err, sizeof err) != 0 && strstr(err, "unknown field 'run.K'") != NULL);
    cli_ckpt_clear(&d);
    memcpy(x, b, len);
    x[12]--; /* one field fewer than this dth writes */
    CU_ASSERT(cli_ckpt_decode(x, len, &d, err, sizeof err) != 0 && strstr(err, "fields") != NULL);
    cli_ckpt_clear(&d);
    memcpy(x, b, len);
    x[8] = 2;
    CU_ASSERT(cli_ckpt_decode(x, len, &d, err, sizeof err) != 0 && strstr(err, "another version") != NULL);
    cli_ckpt_clear(&d);
    /* a blob whose field run.k appears twice (run.samples renamed) */
    size_t sname = value_at(b, len, "run.samples") - 11;
    memcpy(x, b, len);
    x[sname - 1] = 5;
    memcpy(x + sname, "run.k", 5);
    memmove(x + sname + 5, x + sname + 11, len - sname - 11);
    CU_ASSERT(cli_ckpt_decode(x, len - 6, &d, err, sizeof err) != 0 && strstr(err, "'run.k' appears twice") != NULL);
    cli_ckpt_clear(&d);
    free(x);
    free(b);
    cli_ckpt_clear(&c);
}

static dth_scene *scene_of(const char *text)
{
    dth_scene *s = NULL;
    char err[256];
    CU_ASSERT_FATAL(dth_scene_new(NULL, &s) == DTH_OK);
    CU_ASSERT_FATAL(dth_scene_load_mem(s, "s.ini", text, strlen(text), err, sizeof err) == DTH_OK);
    return s;
}

/* What a resume may change: the run's length and the output names; anything else is named. */
static void test_what_may_change(void)
{
    static const char text[] = "[model]\nname=pendulum\n[initial]\nq=1\np=0\n[integrator]\nh=0.05\nsteps=100\n"
                               "[output]\nfile=o.csv\n";
    dth_scene *saved = scene_of(text), *now = scene_of(text);
    char err[512];
    const char *ok[] = {"integrator.steps=500", "integrator.t_end=9", "output.file=b.csv", "events.file=e.csv",
                        "model.name=pendulum", NULL};
    for (int i = 0; ok[i]; i++) CU_ASSERT(dth_scene_set(now, ok[i], err, sizeof err) == DTH_OK);
    CU_ASSERT(cli_ckpt_check_scene(saved, now, err, sizeof err) == 0);
    const char *no[] = {"model.omega2=2", "output.diagnostics=yes", "integrator.h=0.1", "initial.q=0.5",
                        "regularize.method=prescribed", "output.dt=0.1", NULL};
    for (int i = 0; no[i]; i++) {
        dth_scene *s = scene_of(text);
        CU_ASSERT(dth_scene_set(s, no[i], err, sizeof err) == DTH_OK);
        err[0] = '\0';
        CU_ASSERT(cli_ckpt_check_scene(saved, s, err, sizeof err) != 0);
        char want[64];
        snprintf(want, sizeof want, "-s %s: ", no[i]);
        CU_ASSERT(strncmp(err, want, strlen(want)) == 0 && strstr(err, "would change the checkpointed run"));
        dth_scene_free(s);
    }
    /* the length: not behind what was written */
    cli_ckpt c = sample();
    dth_run_setup rs;
    memset(&rs, 0, sizeof rs);
    rs.opt.h = 0.05;
    rs.steps = 1234;
    CU_ASSERT(cli_ckpt_check_length(&c, &rs, err, sizeof err) == 0);
    rs.steps = 1233;
    CU_ASSERT(cli_ckpt_check_length(&c, &rs, err, sizeof err) != 0 && strstr(err, "integrator.steps = 1233"));
    rs.has_t_end = 1;
    rs.t_end = 61.2;
    CU_ASSERT(cli_ckpt_check_length(&c, &rs, err, sizeof err) == 0);
    rs.t_end = 61.1;
    CU_ASSERT(cli_ckpt_check_length(&c, &rs, err, sizeof err) != 0 && strstr(err, "t_end = 61.1"));
    cli_ckpt_clear(&c);
    dth_scene_free(saved);
    dth_scene_free(now);
}

static CU_TestInfo clickpt_tests[] = {
    {"every field written is read back", test_round_trip},
    {"truncated, extended, bit-flipped blobs: refused or within range", test_damaged},
    {"crafted fields refused, naming them", test_crafted},
    {"a resume may change only the length and the output names", test_what_may_change},
    CU_TEST_INFO_NULL,
};

CU_SuiteInfo dth_test_suites[] = {
    {.pName = "clickpt", .pTests = clickpt_tests},
    CU_SUITE_INFO_NULL,
};
