/* SPDX-License-Identifier: MIT */
/*
 * Field lists and their codec (dth/fields.h): the public records of dth_fields_encode / decode, by
 * name, type and count, little-endian, each restored value checked by its field's check.
 */
#include <math.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include "cu_main.h"
#include "dth/dth.h"
#include "failing_alloc.h"

/* ---- the public field codec ---- */

typedef struct rec {
    double x, arr[3];
    double *vec;
    int i;
    long l;
    unsigned long long u;
    char *s;
} rec;

static void test_fields_codec(void)
{
    double v[4] = {1, -2, 3.5, 1e-300}, w[4] = {0};
    rec a = {0.25, {1, 2, 3}, v, -7, 1L << 40, 0xfedcba9876543210ULL, "/a/path"}, b = {0}, c;
    const dth_field fl[] = {
        {"x", offsetof(rec, x), DTH_FIELD_F64, DTH_CHECK_FINITE, 1},
        {"arr", offsetof(rec, arr), DTH_FIELD_F64, DTH_CHECK_POSITIVE, 3},
        {"vec", offsetof(rec, vec), DTH_FIELD_F64_PTR, DTH_CHECK_FINITE, 4},
        {"i", offsetof(rec, i), DTH_FIELD_INT, DTH_CHECK_ANY, 1},
        {"l", offsetof(rec, l), DTH_FIELD_LONG, DTH_CHECK_COUNT, 1},
        {"u", offsetof(rec, u), DTH_FIELD_U64, DTH_CHECK_ANY, 1},
        {"s", offsetof(rec, s), DTH_FIELD_STR, DTH_CHECK_ANY, 1},
    };
    size_t n = sizeof fl / sizeof fl[0], len;
    unsigned char buf[512];
    CU_ASSERT_FATAL(dth_fields_encode(fl, n, &a, NULL, 0, &len) == DTH_OK && len <= sizeof buf);
    CU_ASSERT(dth_fields_encode(fl, n, &a, buf, len - 1, &len) == DTH_EINVAL);
    CU_ASSERT_FATAL(dth_fields_encode(fl, n, &a, buf, sizeof buf, &len) == DTH_OK);
    b.vec = w;
    char err[300] = "";
    CU_ASSERT_FATAL(dth_fields_decode(fl, n, &b, buf, len, NULL, err, sizeof err) == DTH_OK);
    CU_ASSERT(b.x == a.x && !memcmp(b.arr, a.arr, sizeof a.arr) && !memcmp(w, v, sizeof v) && b.i == a.i && b.l == a.l &&
              b.u == a.u && b.s && !strcmp(b.s, a.s));
    dth_free(NULL, b.s);
    /* every truncation, trailing bytes, a value its check refuses: a message, base untouched */
    long wrong = 0;
    c = b;
    for (size_t l = 0; l < len; l++)
        if (dth_fields_decode(fl, n, &c, buf, l, NULL, err, sizeof err) != DTH_EPARSE || memcmp(&c, &b, sizeof c)) wrong++;
    CU_ASSERT(wrong == 0);
    CU_ASSERT(dth_fields_decode(fl, n, &c, buf, len + 1, NULL, err, sizeof err) == DTH_EPARSE && strstr(err, "trailing"));
    a.arr[1] = 0;
    CU_ASSERT_FATAL(dth_fields_encode(fl, n, &a, buf, sizeof buf, &len) == DTH_OK);
    CU_ASSERT(dth_fields_decode(fl, n, &c, buf, len, NULL, err, sizeof err) == DTH_EPARSE && strstr(err, "'arr'") &&
              strstr(err, "one of its components") && !memcmp(&c, &b, sizeof c));
    a.arr[1] = 2;
    a.l = -1;
    CU_ASSERT_FATAL(dth_fields_encode(fl, n, &a, buf, sizeof buf, &len) == DTH_OK);
    CU_ASSERT(dth_fields_decode(fl, n, &c, buf, len, NULL, err, sizeof err) == DTH_EPARSE && strstr(err, "'l' holds -1"));
    a.l = 3;
    /* a string: too long, or holding a NUL */
    static char longs[DTH_FIELD_STR_MAX + 2];
    memset(longs, 'x', sizeof longs - 1);
    a.s = longs;
    CU_ASSERT(dth_fields_encode(fl, n, &a, NULL, 0, &len) == DTH_EINVAL);
    a.s = "abc";
    CU_ASSERT_FATAL(dth_fields_encode(fl, n, &a, buf, sizeof buf, &len) == DTH_OK);
    buf[len - 2] = '\0';
    CU_ASSERT(dth_fields_decode(fl, n, &c, buf, len, NULL, err, sizeof err) == DTH_EPARSE && strstr(err, "NUL"));
    /* out of memory for the string: nothing leaked, base untouched */
    buf[len - 2] = 'b';
    failing_alloc fa;
    dth_allocator al = failing_alloc_make(&fa, 1);
    CU_ASSERT(dth_fields_decode(fl, n, &c, buf, len, &al, err, sizeof err) == DTH_ENOMEM && fa.live == 0);
    CU_ASSERT(!memcmp(&c, &b, sizeof c));
    /* a list without a count for its pointer is refused */
    dth_field nocount = fl[2];
    nocount.count = 0;
    CU_ASSERT(dth_fields_encode(&nocount, 1, &a, NULL, 0, &len) == DTH_EINVAL);
}

static CU_TestInfo fields_tests[] = {
    {"the public field codec: round trip, truncation, checks, strings, memory", test_fields_codec},
    CU_TEST_INFO_NULL,
};

CU_SuiteInfo dth_test_suites[] = {
    {.pName = "ckpt_fields", .pTests = fields_tests},
    CU_SUITE_INFO_NULL,
};
