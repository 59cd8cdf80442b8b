/* SPDX-License-Identifier: MIT */
/*
 * Fast "%.17g": 17 significant digits, correctly rounded (ties to even), in printf's %g layout,
 * byte for byte what glibc's snprintf("%.17g") writes, so every value reads back bit for bit
 * with strtod (17 digits identify a double). Exact integer arithmetic on 128 bits covers
 * decimal exponents -16..43 (almost every value a run writes); other values, NaN and Inf go to
 * snprintf. tests/test_fmt.c compares the two on millions of doubles; bench/bench_csv times them.
 */
#include <math.h>
#include <stdint.h>
#include <stdio.h>
#include <string.h>
#include "fmt.h"

__extension__ typedef unsigned __int128 u128;

static const uint64_t P10_17 = 100000000000000000ull, P10_16 = 10000000000000000ull;

/* 5^k for k <= 27 (fits 64 bits) */
static const uint64_t P5[28] = {
    1ull, 5ull, 25ull, 125ull, 625ull, 3125ull, 15625ull, 78125ull, 390625ull, 1953125ull, 9765625ull,
    48828125ull, 244140625ull, 1220703125ull, 6103515625ull, 30517578125ull, 152587890625ull, 762939453125ull,
    3814697265625ull, 19073486328125ull, 95367431640625ull, 476837158203125ull, 2384185791015625ull,
    11920928955078125ull, 59604644775390625ull, 298023223876953125ull, 1490116119384765625ull,
    7450580596923828125ull};

static uint64_t pow5(int k) { return P5[k]; }

/*
 * D = round(x 10^s), x = m 2^e (m < 2^53), rounded to nearest, ties to even, for the decimal
 * scale s = 16 - X. Returns 0 if the exact arithmetic does not fit (then the caller falls back),
 * else 1 with *D (which may be outside [1e16, 1e17) if X was estimated wrong).
 */
static int scaled(uint64_t m, int e, int s, uint64_t *D)
{
    u128 q, rem, half;
    if (s >= 0) {
        if (s > 32) return 0;
        u128 a = (u128)m * pow5(s > 27 ? 27 : s);
        if (s > 27) a *= pow5(s - 27);
        int sh = e + s;
        if (sh >= 0) {
            if (sh > 10) return 0; /* would exceed 1e17 anyway */
            *D = (uint64_t)(a << sh);
            return 1;
        }
        sh = -sh;
        if (sh >= 127) return 0;
        q = a >> sh;
        rem = a - (q << sh);
        half = (u128)1 << (sh - 1);
        if (rem > half || (rem == half && (q & 1))) q++;
        if (q >> 64) return 0;
        *D = (uint64_t)q;
        return 1;
    }
    int t = -s;
    if (t > 27) return 0;
    int sh = e - t; /* x 10^s = m 2^(e - t) / 5^t */
    if (sh < 0 || sh > 74) return 0;
    u128 num = (u128)m << sh;
    uint64_t d5 = pow5(t);
    q = num / d5;
    rem = num - q * d5;
    /* compare 2 rem with d5 */
    u128 twice = rem * 2;
    if (twice > d5 || (twice == d5 && (q & 1))) q++;
    if (q >> 64) return 0;
    *D = (uint64_t)q;
    return 1;
}

size_t dth_fmt_g17(double x, char *out)
{
    if (!isfinite(x) || x == 0) {
        if (x == 0) {
            if (signbit(x)) {
                memcpy(out, "-0", 3);
                return 2;
            }
            memcpy(out, "0", 2);
            return 1;
        }
        return (size_t)snprintf(out, 32, "%.17g", x);
    }
    char *p = out;
    uint64_t bits;
    memcpy(&bits, &x, sizeof bits);
    int be = (int)((bits >> 52) & 0x7ff);
    if (be == 0) return (size_t)snprintf(out, 32, "%.17g", x); /* subnormal: not on the fast path */
    uint64_t m = (bits & ((1ull << 52) - 1)) | (1ull << 52); /* x = m 2^e, 2^52 <= m < 2^53 */
    int e = be - 1075, e2 = e + 53;
    /* X = floor(log10(|x|)), estimated from the binary exponent (floor((e2 - 1) log10 2), exact
     * for |e2| < 1650) and corrected below */
    int X = (int)(((long)(e2 - 1) * 78913L) >> 18);
    uint64_t D = 0;
    int ok = 0;
    for (int tries = 0; tries < 3; tries++) {
        if (!scaled(m, e, 16 - X, &D)) break;
        if (D < P10_16) {
            X--;
            continue;
        }
        if (D >= P10_17) {
            /* either a wrong estimate or rounding carried to 1e17: redo one scale up */
            uint64_t D2;
            if (!scaled(m, e, 15 - X, &D2)) break;
            if (D2 >= P10_16 && D2 < P10_17) {
                D = D2;
                X++;
                ok = 1;
                break;
            }
            X++;
            continue;
        }
        ok = 1;
        break;
    }
    if (!ok) return (size_t)snprintf(out, 32, "%.17g", x);
    char dig[17];
    for (int i = 16; i >= 0; i--) {
        dig[i] = (char)('0' + D % 10);
        D /= 10;
    }
    int nd = 17;
    while (nd > 1 && dig[nd - 1] == '0') nd--;
    if (x < 0) *p++ = '-';
    if (X < -4 || X >= 17) {
        *p++ = dig[0];
        if (nd > 1) {
            *p++ = '.';
            memcpy(p, dig + 1, (size_t)nd - 1);
            p += nd - 1;
        }
        *p++ = 'e';
        int ex = X;
        *p++ = ex < 0 ? '-' : '+';
        if (ex < 0) ex = -ex;
        if (ex >= 100) {
            *p++ = (char)('0' + ex / 100);
            ex %= 100;
        }
        *p++ = (char)('0' + ex / 10);
        *p++ = (char)('0' + ex % 10);
    } else if (X >= 0) {
        int ip = X + 1; /* digits before the point */
        for (int i = 0; i < ip; i++) *p++ = i < nd ? dig[i] : '0';
        if (nd > ip) {
            *p++ = '.';
            memcpy(p, dig + ip, (size_t)(nd - ip));
            p += nd - ip;
        }
    } else {
        *p++ = '0';
        *p++ = '.';
        for (int i = 0; i < -X - 1; i++) *p++ = '0';
        memcpy(p, dig, (size_t)nd);
        p += nd;
    }
    *p = '\0';
    return (size_t)(p - out);
}

size_t dth_fmt_long(long v, char *out)
{
    char tmp[24];
    int n = 0;
    unsigned long u = v < 0 ? 0ul - (unsigned long)v : (unsigned long)v;
    do {
        tmp[n++] = (char)('0' + u % 10);
        u /= 10;
    } while (u);
    char *p = out;
    if (v < 0) *p++ = '-';
    while (n) *p++ = tmp[--n];
    *p = '\0';
    return (size_t)(p - out);
}
