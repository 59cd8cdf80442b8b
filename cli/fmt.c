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
static uint64_t pow5(int k)
{
    uint64_t p = 1;
    while (k-- > 0) p *= 5;
    return p;
}

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
    double a = fabs(x);
    int e2;
    double fr = frexp(a, &e2); /* a = fr 2^e2, fr in [0.5, 1) */
    uint64_t m = (uint64_t)ldexp(fr, 53);
    int e = e2 - 53;
    if (e < -1074) { /* subnormal: not on the fast path */
        return (size_t)snprintf(out, 32, "%.17g", x);
    }
    /* X = floor(log10(a)), estimated from the binary exponent and corrected below */
    int X = (int)floor((double)(e2 - 1) * 0.30102999566398119521);
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
