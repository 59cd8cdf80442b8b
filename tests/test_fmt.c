/* SPDX-License-Identifier: MIT */
/*
 * The CLI's CSV number formatter (cli/fmt.c): byte for byte what snprintf("%.17g") writes, and
 * every written double reads back with strtod to the identical bits, on special values, decade
 * and rounding boundaries, and 3 million random doubles (random bit patterns, random decimals of
 * every scale, short decimals such as 0.05).
 */
#include <float.h>
#include <math.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include "cu_main.h"
#include "fmt.h"

static long mismatches, roundtrip_fails, checked;

static void check(double x)
{
    char a[DTH_FMT_G17_MAX], b[64];
    size_t la = dth_fmt_g17(x, a);
    snprintf(b, sizeof b, "%.17g", x);
    checked++;
    if (strcmp(a, b) || la != strlen(b)) {
        if (mismatches++ < 5) printf("  %s != %s\n", a, b);
    }
    if (isnan(x)) return;
    double y = strtod(a, NULL);
    if (memcmp(&x, &y, sizeof x)) {
        if (roundtrip_fails++ < 5) printf("  %s does not read back\n", a);
    }
}

static uint64_t rng = 0x9E3779B97F4A7C15ull;
static uint64_t next(void)
{
    rng ^= rng << 13;
    rng ^= rng >> 7;
    rng ^= rng << 17;
    return rng;
}

static void test_special(void)
{
    mismatches = roundtrip_fails = checked = 0;
    double sp[] = {0.0, -0.0, 1.0, -1.0, 0.05, 0.1, 0.3, 1e16, 1e17, 9.9999999999999999e16, 1e-4, 9.999999999999999e-5,
                   1e-5, 123456789012345678.0, DBL_MAX, -DBL_MAX, DBL_MIN, DBL_TRUE_MIN, 5e-324, 1e308, 1e-308,
                   INFINITY, -INFINITY, NAN, 0.5, 2.5, 1e22, 1e23, 4.35, 0.1 + 0.2, 1.0 / 3, 2.0 / 3, 3.14159265358979323846};
    for (size_t i = 0; i < sizeof sp / sizeof sp[0]; i++) check(sp[i]);
    /* every power of ten and its neighbours */
    for (int e = -330; e <= 310; e++) {
        char s[16];
        snprintf(s, sizeof s, "1e%d", e);
        double x = strtod(s, NULL);
        check(x);
        check(nextafter(x, 0));
        check(nextafter(x, INFINITY));
        check(-x);
    }
    CU_ASSERT_EQUAL(mismatches, 0);
    CU_ASSERT_EQUAL(roundtrip_fails, 0);
}

static void test_random(void)
{
    mismatches = roundtrip_fails = checked = 0;
    for (long i = 0; i < 3000000; i++) {
        uint64_t u = next();
        double x;
        switch (i % 3) {
        case 0: memcpy(&x, &u, sizeof x); break;                                  /* any bit pattern */
        case 1: x = ldexp((double)(u >> 11), -53) * pow(10, (double)((int)(next() % 70) - 25)); break;
        default: x = (double)(long)(u % 2000001 - 1000000) / pow(10, (double)(next() % 8)); break; /* 0.05 */
        }
        if (next() & 1) x = -x;
        check(x);
    }
    printf("  %ld values: %ld differ from snprintf, %ld do not read back\n", checked, mismatches, roundtrip_fails);
    CU_ASSERT_EQUAL(mismatches, 0);
    CU_ASSERT_EQUAL(roundtrip_fails, 0);
}

static void test_long(void)
{
    long v[] = {0, 1, -1, 9, 10, 123456789, -987654321, 2147483648L, -9223372036854775807L - 1, 9223372036854775807L};
    for (size_t i = 0; i < sizeof v / sizeof v[0]; i++) {
        char a[32], b[32];
        dth_fmt_long(v[i], a);
        snprintf(b, sizeof b, "%ld", v[i]);
        CU_ASSERT_STRING_EQUAL(a, b);
    }
}

static CU_TestInfo fmt_tests[] = {
    {"special values and every decade read back bit for bit, as %.17g", test_special},
    {"3 million random doubles: the bytes of %.17g, read back bit for bit", test_random},
    {"integers as %ld", test_long},
    CU_TEST_INFO_NULL};

CU_SuiteInfo dth_test_suites[] = {{"fmt", NULL, NULL, NULL, NULL, fmt_tests}, CU_SUITE_INFO_NULL};
