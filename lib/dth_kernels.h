/* SPDX-License-Identifier: MIT */
/*
 * The DTH step's inline kernels shared by its start-up solves (dth_start.c) and its Newton system
 * (dth_newton.c): the midpoint from the unknowns, the carried vertex offset measured from a
 * midpoint, and the reversible finish's coarse point and Taylor terms (paper, Theorem "DTH
 * Equations"; docs/theory.md, "A step that is its own reverse").
 */
#ifndef DTH_DTH_KERNELS_H
#define DTH_DTH_KERNELS_H

#include <math.h>
#include <string.h>
#include "dd.h"
#include "dth_core.h"

/* Inline kernels take nc: the number of degrees of freedom when it is a compile-time constant
 * (the small path instantiates them for n = 1, 2, 3, so their loops unroll; nc > 0 implies an
 * autonomous model), else 0 (it->n). */
#define AI static inline __attribute__((always_inline))

/*
 * The vertex offset's difference H(c) - H(zbar), in double-double (rho + rholo), without
 * cancellation: c is the vertex's high part over y (coarsened by coarsen_y in the reversible
 * finish), wp enters by both parts, and zbar = zb + dyh + zblo, zb the point the model was read at
 * (dyh: the reversible finish's offset from its coarse point y = zb to the midpoint's high part,
 * NULL otherwise; zblo may be NULL). Terms: the wp difference, the model's hdiff between c and zb,
 * and minus (grad + gl/2) (dyh + zblo), the Taylor terms to the midpoint (grad at zb; gl = H''(zb)
 * (dyh + zblo), NULL: none), g dyh exactly. The carried offset rho is thus H at each vertex's c: a
 * definition, exact to O(eps^2), that keeps the step's equations a function of (vertex, rho)
 * alone. The vertex's low part shows in the midpoint (zbar carries it), where the gradient is the
 * right one; read through the midpoint's gradient at the vertex it would err by |H''| |d| |zlo|,
 * about eps |d| per step, the noise that random-walked the offset and the round trip's phase.
 * The midpoint's low part matters: a double midpoint moves in steps of eps |zbar|, which changes
 * H by eps S.
 */
AI int rho_from_mid_n(dth__dth *it, const size_t nc, const double *zb, const double *dyh, const double *zblo,
                     const double *grad, const double *gl, const double *z, const double *zlo, double *rho, double *rholo)
{
    size_t d = nc ? 2 * nc + 1 : it->d, N = d + 1;
    double dh;
    const double *c = z;
    int rc;
    if (it->rev) { /* the coarsened vertex (wp as it is), kept for the vertex it was made from */
        if (memcmp(z, it->vcsrc, N * sizeof *z) != 0) {
            coarsen_y(nc ? nc : it->n, z, it->vc);
            it->vc[d] = z[d];
            memcpy(it->vcsrc, z, N * sizeof *z);
        }
        c = it->vc;
    }
    if (it->mhdiff) { /* dth__model_hdiff without the call */
        rc = it->mhdiff(it->mself, c, zb, &dh);
        if (rc) return rc > 0 ? DTH_EDOMAIN : DTH_EMODEL;
        if (!isfinite(dh)) return DTH_EDOMAIN;
    } else {
        rc = dth__model_hdiff(it->model, c, zb, it->hwork, &dh);
        if (rc) return rc;
    }
    double wph = z[N - 1] - zb[N - 1], wpl = zlo[N - 1] - (zblo ? zblo[N - 1] : 0), l2;
    if (!dyh) { /* the compensated default: the midpoint's low part through the gradient there */
        double lo = 0;
        if (zblo)
            for (size_t j = 0; j < d; j++) lo -= grad[j] * zblo[j];
        double h2 = two_sum(dh, wph, &l2);
        *rho = two_sum(h2, l2 + (wpl + lo), rholo);
        return DTH_OK;
    }
    /* minus (g + gl/2) (dyh + zblo): g dyh exactly (dyh is up to 2^-27 |zb|), in double-double */
    double s = 0, e = 0, r = 0;
    for (size_t j = 0; j < d; j++) {
        double h = dyh ? dyh[j] : 0, l = zblo ? zblo[j] : 0, gj = grad[j], t;
        if (h != 0) {
            double p = gj * h, pe = prod_err(gj, h, p);
            s = two_sum(s, p, &t);
            e += t + pe;
        }
        r += gj * l + (gl ? 0.5 * gl[j] * (h + l) : 0);
    }
    /* the wp difference by its parts (a non-autonomous step moves wp by about lambda dH/dt, as
     * large as dh: rounded into the low part it would be noise of eps |dH/dt| lambda) */
    double l1, h1 = two_sum(dh, -s, &l1), h2 = two_sum(h1, wph, &l2);
    *rho = two_sum(h2, (l1 + l2) + (wpl - (e + r)), rholo);
    return DTH_OK;
}

static inline int rho_from_mid(dth__dth *it, const double *zb, const double *zblo, const double *grad, const double *z,
                        const double *zlo, double *rho, double *rholo)
{
    return rho_from_mid_n(it, 0, zb, NULL, zblo, grad, NULL, z, zlo, rho, rholo);
}

/*
 * The reversible finish's Taylor term gl = H''(y) (dy + zblo) (it->hess at the coarse point y, d x d)
 * in double-double, gl + gll: the products with dy, up to 2^-27 of the scale, exactly (their
 * rounding would be noise in the step's equations); zblo's are small. As (J gl)_j over z by
 * j_of_gl, the way dth__flow_z maps the gradient.
 */
static inline void taylor_grad(const dth__dth *it, size_t d, const double *dy, const double *zblo, double *gl,
                        double *gll)
{
    taylor_grad_h(it->hess, d, dy, zblo, gl, gll);
}

/* (J v)_j over z = (q, t, p, wp) for v over y = (q, t, p) (n degrees of freedom, d = 2n + 1). */
static inline double j_of_gl(size_t n, size_t d, size_t j, const double *v)
{
    return j < n ? v[n + 1 + j] : j == n ? 0 : j < d ? -v[j - n - 1] : -v[n];
}


/*
 * The reversible finish (DTH_FINISH_REVERSIBLE): the point y where a chord step evaluates the model, and
 * dy = zbar - y (zbar = zb + zblo, dy's high part here, zblo the rest): y is the midpoint coarsened
 * to a multiple of 2^-28 of its blocks' scales (coarsen_y), and the step reads the model there with
 * its Taylor terms, g(zbar) = g(y) + H''(y) dy and H(zbar) = H(y) + (g + H'' dy / 2) dy. With
 * dy <= 2^-27 of the scale the gradient's next term, H''' dy^2 / 2, is about eps (a fixed, smooth
 * change of the equations, as the model's own rounding is) and the energy's below eps^2. Why not at
 * zbar itself: the model's values carry their own rounding, eps |g|, different at every double
 * point, and lambda amplifies a change of the equations by about 1/lambda^2 (it is fixed at second
 * order); where the chord steps move the double midpoint by an ulp, the equations jump and the step
 * and its reverse settle at different roots. The coarse point is the same for both (their
 * double-double midpoints agree to about 2^-100) unless the root lies within that rounding of a
 * cell's edge (step_again). Pinned (step_again): y stays.
 */
static inline void coarse_n(dth__dth *it, const size_t nc, const double *zb, double *dy)
{
    size_t d = nc ? 2 * nc + 1 : it->d;
    if (!it->ypinned) coarsen_y(nc ? nc : it->n, zb, it->yc);
    for (size_t j = 0; j < d; j++) {
        double c = it->yc[j];
        dy[j] = zb[j] - c; /* exact (c is a multiple of zb's ulp within 2^-28 of the scale); zblo is the rest */
    }
    it->yc[d] = zb[d];
    dy[d] = 0;
}


/* a + b, and with lo != NULL its rounding error in *lo */
AI double sum_lo(double a, double b, double *lo) { return lo ? two_sum(a, b, lo) : a + b; }

/*
 * zbar = (z + zlo) + (x + xlo) for the unknowns x and their low part xlo (the finishing chord
 * steps' roundings, newton.h; zero during the iterations); passive t, wp in closed form
 * (autonomous). zblo (NULL: not wanted) gets the low part, zb + zblo = z + zlo + x + xlo to
 * O(eps^2 |zbar|): the finishing midpoint is not quantized to the ulp of the offset d, which would
 * leave an energy residual of eps |grad H| |d| at the midpoint (and a vertex offset that the
 * reverse step does not reproduce). Without zblo, the double sum the iterations need.
 */
AI double mid_dd(int rev, double z, double zlo, double x, double xlo, double *lo)
{
    if (!lo) return z + (zlo + x);
    if (!rev) return two_sum(z, zlo + x, lo); /* to the rounding of zlo + x, far below eps |zbar| */
    return dd_add(z, zlo, x, xlo, lo);
}

AI void midpoint_n(const dth__dth *it, const size_t nc, const double *x, double *zb, double *zblo)
{
    size_t n = nc ? nc : it->n, N = 2 * n + 2;
    int m = nc ? (int)(2 * nc + 1) : it->m;
    const double *z = it->st.z, *zlo = it->st.zlo, *xl = it->xlo; /* NULL unless rev: mid_dd reads it then only */
    if (nc || it->auton) {
        /* unknowns (d_q, d_p, lambda) */
        for (size_t i = 0; i < n; i++) {
            zb[i] = mid_dd(it->rev, z[i], zlo[i], x[i], xl ? xl[i] : 0, zblo ? &zblo[i] : NULL);
            zb[n + 1 + i] = mid_dd(it->rev, z[n + 1 + i], zlo[n + 1 + i], x[n + i], xl ? xl[n + i] : 0, zblo ? &zblo[n + 1 + i] : NULL);
        }
        zb[n] = mid_dd(it->rev, z[n], zlo[n], 0.5 * x[m - 1], xl ? 0.5 * xl[m - 1] : 0, zblo ? &zblo[n] : NULL);
        zb[N - 1] = sum_lo(z[N - 1], zlo[N - 1], zblo ? &zblo[N - 1] : NULL);
        return;
    }
    for (int a = 0; a < m - 1; a++) zb[a] = mid_dd(it->rev, z[a], zlo[a], x[a], xl ? xl[a] : 0, zblo ? &zblo[a] : NULL);
}

/* The Newton unknowns it->x from a step: the offset d (length N) over the active components, then
 * lambda. */
AI void unknowns_n(dth__dth *it, const size_t nc, const double *d, double lam)
{
    size_t n = nc ? nc : it->n;
    int m = nc ? (int)(2 * nc + 1) : it->m;
    double *x = it->x;
    if (nc) {
        for (size_t i = 0; i < n; i++) {
            x[i] = d[i];
            x[n + i] = d[n + 1 + i];
        }
    } else {
        for (int a = 0; a < m - 1; a++) x[a] = d[it->act[a]];
    }
    x[m - 1] = lam;
    if (it->xlo) memset(it->xlo, 0, (size_t)m * sizeof *it->xlo);
    it->ypinned = 0;
}

#endif
