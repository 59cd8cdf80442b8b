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

/* (a + alo) + (b + blo) as hi + *lo (to O(eps^2) of the sum; alo, blo below the ulps of a, b). */
static inline double dd_add(double a, double alo, double b, double blo, double *lo)
{
    double e, s = two_sum(a, b, &e);
    return two_sum(s, (alo + blo) + e, lo);
}

/* The rounding error of the product p = a b, exactly (Dekker: no fma call; |a|, |b| < 2^995). */
static inline double prod_err(double a, double b, double p)
{
    double ca = 134217729.0 * a, ah = ca - (ca - a), al = a - ah;
    double cb = 134217729.0 * b, bh = cb - (cb - b), bl = b - bh;
    return ((ah * bh - p) + ah * bl + al * bh) + al * bl;
}

/*
 * (x + xlo) - (hl + hlo) (u + ulh + ull) with one rounding at the end: the products hl u and hl ulh
 * exactly (prod_err gives their errors), where ulh + ull = (J H''(y) (zbar - y))_j, up to 2^-27 |u|.
 * A row d - (lambda/2) u(zbar) of the reversible finish (dth_newton.c).
 */
static inline double exact_row(double x, double xlo, double hl, double hlo, double u, double ulh, double ull)
{
    double ph = hl * u, pl = prod_err(hl, u, ph), qh = hl * ulh, ql = prod_err(hl, ulh, qh), e1, e2;
    double s1 = two_sum(x, -ph, &e1), s2 = two_sum(s1, -qh, &e2);
    return s2 + (((((xlo - pl) - ql) - hlo * u) - (hl * ull + hlo * ulh)) + (e1 + e2));
}

/*
 * exact_row minus a kick (hm + hmlo) (n0 + n1), again with one rounding at the end: the products
 * hm n0 and hm n1 exactly (n1, the kick direction's change from y to the midpoint, is up to 2^-27
 * |n0|). A row d - (lambda/2) u(zbar) - (mu/2) n(zbar) of a kicked segment's reversible finish
 * (prescribed_rev.c).
 */
static inline double exact_row_kick(double x, double xlo, double hl, double hlo, double u, double ulh, double ull,
                                    double hm, double hmlo, double n0, double n1)
{
    double ph = hl * u, pl = prod_err(hl, u, ph), qh = hl * ulh, ql = prod_err(hl, ulh, qh);
    double kh = hm * n0, kl = prod_err(hm, n0, kh), mh = hm * n1, ml = prod_err(hm, n1, mh), e1, e2, e3, e4;
    double s1 = two_sum(x, -ph, &e1), s2 = two_sum(s1, -qh, &e2), s3 = two_sum(s2, -kh, &e3), s4 = two_sum(s3, -mh, &e4);
    double lo = ((((xlo - pl) - ql) - (kl + ml)) - (hlo * u + hmlo * (n0 + n1))) - (hl * ull + hlo * ulh);
    return s4 + (lo + ((e1 + e2) + (e3 + e4)));
}

/*
 * gl + gll = hess (dy + zblo) in double-double (hess d x d row-major, at a coarse point y; dy = zbar -
 * y, up to 2^-27 of the scale, zblo the midpoint's low part): the products with dy exactly (their
 * rounding would be noise in the equations of the reversible finish), zblo's rounded (they are small).
 * The Taylor term of the gradient from y to the midpoint (dth_kernels.h: taylor_grad; prescribed_rev.c).
 */
static inline void taylor_grad_h(const double *hess, size_t d, const double *dy, const double *zblo, double *gl,
                                 double *gll)
{
    for (size_t j = 0; j < d; j++) {
        double a = 0, al = 0, t;
        for (size_t k = 0; k < d; k++) {
            double h = hess[j * d + k], p = h * dy[k];
            a = two_sum(a, p, &t);
            al += (t + prod_err(h, dy[k], p)) + h * zblo[k];
        }
        gl[j] = two_sum(a, al, &gll[j]);
    }
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
