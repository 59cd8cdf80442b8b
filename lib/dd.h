/* SPDX-License-Identifier: MIT */
/*
 * Double-double kernels: error-free sums and products, and the deterministic coarsening of a
 * point that the reversible finish reads the model at (docs/theory.md, "A step that is its own
 * reverse"). Header-only: the step's small paths inline them.
 */
#ifndef DTH_DD_H
#define DTH_DD_H

#include <math.h>
#include <stddef.h>
#include <stdint.h>
#include <string.h>

/* Error-free sum: s + e == a + b exactly (Knuth's TwoSum). */
static inline double two_sum(double a, double b, double *e)
{
    double s = a + b, bb = s - a;
    *e = (a - (s - bb)) + (b - bb);
    return s;
}

/* The rounding error of the product p = a b, exactly (Dekker: no fma call; |a|, |b| < 2^995). */
static inline double prod_err(double a, double b, double p)
{
    double ca = 134217729.0 * a, ah = ca - (ca - a), al = a - ah;
    double cb = 134217729.0 * b, bh = cb - (cb - b), bl = b - bh;
    return ((ah * bh - p) + ah * bl + al * bh) + al * bl;
}

/*
 * c = v coarsened over y = (q, t, p) (d = 2n + 1 entries): each entry rounded to the nearest
 * multiple of 2^(e - COARSE_BITS), e the binary exponent of its block's largest magnitude (the q
 * block, t, the p block), so that a coarse cell spans 2^(52 - COARSE_BITS) ulps of the block's
 * scale also for an entry near zero. A deterministic, odd function of v. Where the model is read:
 * rho_from_mid_n, coarse_n (dth_kernels.h).
 */
enum { COARSE_BITS = 28 };

/* v rounded to the nearest multiple of 2^qe (ties to even: an odd function of v) by adding and
 * subtracting 1.5 2^(qe + 52); v itself where that constant is not a normal double or v is not
 * finite. Deterministic, no library call; |v| < 2^(qe + 51) here (coarsen_y). */
static inline double round_to(double v, int qe)
{
    int ce = qe + 52;
    if (ce < -1022 || ce > 1023 || !isfinite(v)) return v;
    uint64_t b = (uint64_t)(ce + 1023) << 52;
    double C;
    memcpy(&C, &b, sizeof C);
    C *= 1.5;
    return (v + C) - C;
}

/* The binary exponent of the largest |v[j]| over j = a, a + 1, ..., b - 1 (bit patterns compared
 * as integers: no library call), -1075 if all are zero; NaN and Inf give 1024. */
static inline int max_expo(const double *v, size_t a, size_t b)
{
    uint64_t m = 0;
    for (size_t j = a; j < b; j++) {
        uint64_t u;
        memcpy(&u, &v[j], sizeof u);
        u &= ~((uint64_t)1 << 63);
        if (u > m) m = u;
    }
    int e = (int)(m >> 52);
    return e == 0 ? (m == 0 ? -1075 : -1023) : e - 1023;
}

static inline void coarsen_y(size_t n, const double *v, double *c)
{
    int eq = max_expo(v, 0, n) - COARSE_BITS, et = max_expo(v, n, n + 1) - COARSE_BITS;
    int ep = max_expo(v, n + 1, 2 * n + 1) - COARSE_BITS;
    for (size_t i = 0; i < n; i++) {
        c[i] = round_to(v[i], eq);
        c[n + 1 + i] = round_to(v[n + 1 + i], ep);
    }
    c[n] = round_to(v[n], et);
}

#endif
