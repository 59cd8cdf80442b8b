/* SPDX-License-Identifier: MIT */
/*
 * dth run's checkpoint blob (cli/ckpt.c): a record of the library's field codec holding what only
 * dth run knows (the scene's hash, the outputs' progress; the run driver's state is the library's
 * section "run"). Every field written is read back; a truncated, extended or crafted blob
 * (relative paths, NUL bytes, renamed fields, byte counts without a file, another version) is
 * refused with a message naming the field, never read out of bounds; the rows a resume continues
 * must be this run's header and one row per sample; what a resume may change of the scene and of
 * the run's length.
 */
#include <math.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>
#include "cu_main.h"
#include "ckpt.h"

static cli_ckpt sample(void)
{
    cli_ckpt c;
    memset(&c, 0, sizeof c);
    dth_run_state *S = &c.S; /* not in the blob: for the length checks */
    S->started = 1;
    S->k = 1234;
    S->t = 61.25;
    S->t_stop = 61.2;
    c.scene_hash = 0x0123456789abcdefULL;
    c.out = (cli_ckpt_out){strdup("/data/run/o.csv"), strdup("/data/run/o.csv.tmp.77.AbCdEf"), 123456, 0xfeedULL};
    c.ev = (cli_ckpt_out){strdup(""), strdup(""), 0, CLI_FNV_OFFSET};
    return c;
}

static int same(const cli_ckpt *a, const cli_ckpt *b)
{
    return a->scene_hash == b->scene_hash && !strcmp(a->out.path, b->out.path) && !strcmp(a->out.tmp, b->out.tmp) &&
           a->out.bytes == b->out.bytes && a->out.hash == b->out.hash && !strcmp(a->ev.path, b->ev.path) &&
           !strcmp(a->ev.tmp, b->ev.tmp) && a->ev.bytes == b->ev.bytes && a->ev.hash == b->ev.hash;
}

static uint64_t le(const unsigned char *p, int n)
{
    uint64_t v = 0;
    for (int i = n - 1; i >= 0; i--) v = (v << 8) | p[i];
    return v;
}

/* Offset of field `name`'s u64 count in a blob (magic, u32 version, u32 count, then fields: u32
 * name length, name, u32 type, u64 count, values; a string's values are its bytes); 0 if absent. */
static size_t field_at(const unsigned char *b, size_t len, const char *name)
{
    size_t pos = 16;
    for (uint64_t i = 0, n = le(b + 12, 4); i < n && pos + 4 <= len; i++) {
        size_t nl = (size_t)le(b + pos, 4);
        if (pos + 4 + nl + 12 > len) return 0;
        int hit = nl == strlen(name) && !memcmp(b + pos + 4, name, nl);
        pos += 4 + nl + 4;
        if (hit) return pos;
        uint64_t type = le(b + pos - 4, 4), count = le(b + pos, 8);
        pos += 8 + (type == 3 ? count : 8 * count);
    }
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
    CU_ASSERT(memcmp(b, "DTHRUNCK", 8) == 0 && le(b + 8, 4) == 4 && le(b + 12, 4) == 9);
    CU_ASSERT_FATAL(cli_ckpt_decode(b, len, &d, err, sizeof err) == 0);
    CU_ASSERT(same(&c, &d));
    CU_ASSERT(d.S.started == 0 && d.S.k == 0); /* the run state is not the blob's */
    cli_ckpt_clear(&d);
    free(b);
    cli_ckpt_clear(&c);
}

/* Any truncation or extension, and any flipped bit: refused with a message, or read within range. */
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
                if ((d.out.path[0] && d.out.path[0] != '/') || strlen(d.out.path) > 4096 || !d.out.path[0] ||
                    d.out.bytes > ((unsigned long long)1 << 62) || (!d.ev.path[0] && d.ev.bytes))
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
    /* numbers */
    size_t at = field_at(b, len, "out.bytes");
    CU_ASSERT_FATAL(at != 0);
    memcpy(x, b, len);
    put64(x + at + 8, (uint64_t)1 << 63);
    CU_ASSERT(cli_ckpt_decode(x, len, &d, err, sizeof err) != 0 && strstr(err, "byte count") != NULL);
    cli_ckpt_clear(&d);
    at = field_at(b, len, "ev.bytes");
    CU_ASSERT_FATAL(at != 0);
    memcpy(x, b, len);
    put64(x + at + 8, 7);
    CU_ASSERT(cli_ckpt_decode(x, len, &d, err, sizeof err) != 0 && strstr(err, "counts its bytes") != NULL);
    cli_ckpt_clear(&d);
    /* strings: a NUL inside, a relative path, a length past the end or beyond 4096 */
    at = field_at(b, len, "out.path"); /* u64 length, then the bytes */
    CU_ASSERT_FATAL(at != 0);
    memcpy(x, b, len);
    x[at + 8 + 3] = '\0';
    CU_ASSERT(cli_ckpt_decode(x, len, &d, err, sizeof err) != 0 && strstr(err, "NUL") && strstr(err, "'out.path'"));
    cli_ckpt_clear(&d);
    memcpy(x, b, len);
    x[at + 8] = 'd';
    CU_ASSERT(cli_ckpt_decode(x, len, &d, err, sizeof err) != 0 && strstr(err, "absolute") != NULL);
    cli_ckpt_clear(&d);
    memcpy(x, b, len);
    put64(x + at, 0xffff);
    CU_ASSERT(cli_ckpt_decode(x, len, &d, err, sizeof err) != 0 && strstr(err, "longer than 4096") != NULL);
    cli_ckpt_clear(&d);
    memcpy(x, b, len);
    put64(x + at, 4080); /* past the end */
    CU_ASSERT(cli_ckpt_decode(x, len, &d, err, sizeof err) != 0 && strstr(err, "truncated") != NULL);
    cli_ckpt_clear(&d);
    /* names: another name in the place of a field; a field missing (the count says one less);
     * another version */
    size_t name = field_at(b, len, "out.tmp") - 4 - 7;
    memcpy(x, b, len);
    x[name + 4] = 'T';
    CU_ASSERT(cli_ckpt_decode(x, len, &d, err, sizeof err) != 0 && strstr(err, "'out.Tmp'") && strstr(err, "'out.tmp'"));
    cli_ckpt_clear(&d);
    memcpy(x, b, len);
    x[12]--; /* one field fewer than this dth writes */
    CU_ASSERT(cli_ckpt_decode(x, len, &d, err, sizeof err) != 0 && strstr(err, "fields") != NULL);
    cli_ckpt_clear(&d);
    memcpy(x, b, len);
    x[8] = 3;
    CU_ASSERT(cli_ckpt_decode(x, len, &d, err, sizeof err) != 0 && strstr(err, "another version") != NULL);
    cli_ckpt_clear(&d);
    free(x);
    free(b);
    cli_ckpt_clear(&c);
}

/* The rows a resume continues: the header this run writes, one line per sample, whole lines. */
static void test_rows(void)
{
    char path[] = "/tmp/dth_clickpt_XXXXXX";
    int fd = mkstemp(path);
    CU_ASSERT_FATAL(fd >= 0);
    const char *text = "k,t,q1\n0,0,1\n1,0.1,0.9\n2,0.2,0.8\n";
    size_t tl = strlen(text);
    CU_ASSERT_FATAL(write(fd, text, tl) == (ssize_t)tl);
    close(fd);
    cli_ckpt_out o = {path, "", tl, 0};
    char err[400] = "";
    CU_ASSERT(cli_ckpt_check_rows(&o, 0, path, "k,t,q1", 6, 3, err, sizeof err) == 0);
    o.bytes = 7; /* the header alone (a run's first checkpoint) */
    CU_ASSERT(cli_ckpt_check_rows(&o, 0, path, "k,t,q1", 6, 0, err, sizeof err) == 0);
    struct {
        unsigned long long bytes;
        const char *header;
        long rows;
        const char *says;
    } bad[] = {
        {0, "k,t,q1", 0, "'out.bytes' counts 0 bytes"},       /* issue 24: out.bytes = 0 resumed */
        {6, "k,t,q1", 0, "fewer than its header line"},
        {tl, "k,t,q1,psi,dpsi", 3, "does not begin with the header"}, /* other columns (diagnostics = yes) */
        {tl, "k,t,q2", 3, "does not begin with the header"},
        {tl, "k,t,q1", 5, "hold 3 rows, field 'samples' of the run state 5"},
        {tl - 3, "k,t,q1", 2, "end inside a row"},
        {tl + 10, "k,t,q1", 3, "shorter than"},
    };
    for (size_t i = 0; i < sizeof bad / sizeof bad[0]; i++) {
        o.bytes = bad[i].bytes;
        err[0] = '\0';
        int rc = cli_ckpt_check_rows(&o, 0, path, bad[i].header, strlen(bad[i].header), bad[i].rows, err, sizeof err);
        if (rc == 0 || !strstr(err, bad[i].says)) printf("  [case %zu: '%s']\n", i, err);
        CU_ASSERT(rc != 0 && strstr(err, bad[i].says) != NULL && strstr(err, path) != NULL);
    }
    remove(path);
    CU_ASSERT(cli_ckpt_check_rows(&o, 0, path, "k", 1, 0, err, sizeof err) != 0 && strstr(err, "cannot read") != NULL);
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
    {"the rows a resume continues: this run's header, one per sample, whole lines", test_rows},
    {"a resume may change only the length and the output names", test_what_may_change},
    CU_TEST_INFO_NULL,
};

CU_SuiteInfo dth_test_suites[] = {
    {.pName = "clickpt", .pTests = clickpt_tests},
    CU_SUITE_INFO_NULL,
};
