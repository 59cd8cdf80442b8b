/* SPDX-License-Identifier: MIT */
/*
 * Benchmark (not a test): the library's DTH step (paper, Theorem "DTH Equations") against its own
 * floor, the same step written out in closed form for one model (same equations, tolerance, block
 * scales, quadratic predictor, chord finish on the compensated constraint with the carried vertex
 * offset and the closed-form hdiff, cheap branch test, residual at the accepted midpoint and
 * double-double vertex), and against peers per step, all timed interleaved in one run:
 *   - pendulum (h = 0.05, amplitude 1): library step (also with compensate = 0 and with
 *     branch_check = 0, to show what the compensated finish and the cheap branch test cost, and with
 *     compensate = 2, the reversible finish, to show what it adds; without
 *     the branch check the steps are the same bits here, the cheap test accepting Newton's root at
 *     every step), closed-form floor (3x3 elimination written out), GSL rk4imp
 *     (gsl_odeiv2_step_apply, its own Jacobian), Stormer-Verlet;
 *   - Kepler e = 0.6 (h = 0.01): library step, floor with the analytic 2x2 Schur complement;
 *   - throughput of independent pendulum integrations in 1 and 2 threads.
 * The floors are checked to take the library's steps (lambda to round-off) before they are timed.
 * Usage: bench_floor [steps]   (default 200000; median of 9 interleaved repeats), or
 *        bench_floor --only VARIANT steps   (one untimed run of pend-lib, pend-lib-nocomp,
 *        pend-lib-nobranch, pend-lib-rev, pend-floor, kep-lib, kep-floor, rk4imp or verlet: for instruction counts under callgrind, where wall
 *        clock on a shared machine is too noisy; scripts/bench-instr.sh). The process
 * re-executes itself with OPENBLAS_NUM_THREADS=1 unless that is set (OpenBLAS's idle worker
 * threads otherwise compete with the second application thread on a 2-core machine).
 */
#define _GNU_SOURCE /* sincos */
#include <float.h>
#include <math.h>
#include <pthread.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>
#include <gsl/gsl_errno.h>
#include <gsl/gsl_odeiv2.h>
#include "dth/dth.h"
#include "bench_common.h"

enum { REPEATS = 9 };

static inline double two_sum(double a, double b, double *e)
{
    double s = a + b, bb = s - a;
    *e = (a - (s - bb)) + (b - bb);
    return s;
}

/* The verdict rule of the library's Newton driver (newton.c), for the floors. */
enum { MORE, DONE, CHORD, STALLED };
static int rate(double r, double r_prev, int iter)
{
    if (r <= 4 * DBL_EPSILON) return DONE;
    if (iter >= 2 && r < 1e-6 && r * (r / r_prev) * (r / r_prev) <= DBL_EPSILON) return CHORD;
    if (r >= 0.5 * r_prev) return STALLED;
    return MORE;
}

/* ------------------------------------------------------------------ pendulum floor */

/* H = p^2/2 - cos q; vertex (q, t, p, wp) with low parts; the carried vertex offset rho = H(z_k) of
 * the compensated constraint; the last three offsets for the predictor. */
typedef struct pend {
    double z[4], lo[4], rho;
    double d[3][2], lam[3]; /* offsets (dq, dp) and steps, newest first */
    int nh;
    double psi_prev;
    long steps;
} pend;

/* H(q1, p1) - H(q0, p0) without cancellation: the model's hdiff. */
static inline double pend_hdiff(double q1, double p1, double q0, double p0)
{
    return 0.5 * (p1 - p0) * (p1 + p0) + 2 * sin(0.5 * (q1 + q0)) * sin(0.5 * (q1 - q0));
}

/* H(z + lo) - H(zbar + blo) (the library's rho_from_mid; the wp parts cancel exactly): hdiff between
 * the high parts, the low parts through the gradient (sn, pb) at the midpoint. */
static inline double pend_offset(const double *z, const double *lo, double qb, double pb, double bl0, double bl2, double sn,
                                 double gp)
{
    return pend_hdiff(z[0], z[2], qb, pb) + (sn * (lo[0] - bl0) + gp * (lo[2] - bl2));
}

/* Midpoint start at (q0, p0), then the exact first step (lambda = h): the library's start. */
static void pend_start(pend *s, double q0, double p0, double h)
{
    memset(s, 0, sizeof *s);
    double zb[4] = {q0, 0, p0, -(0.5 * p0 * p0 - cos(q0))}, u[4] = {p0, 1, -sin(q0), 0}, z0[4];
    for (int j = 0; j < 3; j++) z0[j] = two_sum(zb[j], -0.5 * h * u[j], &s->lo[j]);
    double sn = sin(q0);
    for (int j = 0; j < 3; j++) s->z[j] = two_sum(z0[j], 2 * (0.5 * h * u[j]) + s->lo[j], &s->lo[j]);
    s->z[3] = zb[3];
    s->lo[3] = 0;
    /* the vertex offset after the exact first step, from zbar_0 (where H = 0 exactly) */
    s->rho = pend_offset(s->z, s->lo, q0, p0, 0, 0, sn, p0);
    s->d[0][0] = 0.5 * h * u[0];
    s->d[0][1] = 0.5 * h * u[2];
    s->lam[0] = h;
    s->nh = 1;
    s->psi_prev = p0 * p0 * cos(q0) + sin(q0) * sin(q0); /* not used before it is set again */
    s->steps = 1;
}

static int pend_step(pend *s, double *lam_out)
{
    double q = s->z[0], t = s->z[1], p = s->z[2], wp = s->z[3], ql = s->lo[0], tl = s->lo[1], pl = s->lo[2];
    double x0, x1, x2; /* dq, dp, lambda */
    double l0 = s->lam[0];
    if (s->nh >= 3) {
        double l = 3 * (s->lam[0] - s->lam[1]) + s->lam[2];
        if (l > 0 && l <= 2 * l0 && 2 * l >= l0) {
            x0 = 3 * (s->d[0][0] - s->d[1][0]) + s->d[2][0];
            x1 = 3 * (s->d[0][1] - s->d[1][1]) + s->d[2][1];
            x2 = l;
        } else {
            x0 = s->d[0][0], x1 = s->d[0][1], x2 = l0;
        }
    } else {
        x0 = s->d[0][0], x1 = s->d[0][1], x2 = l0;
    }
    double r_prev = INFINITY, qb = 0, pb = 0, sn = 0, cs = 0, hl, f0, f1, f2, g1, g2, d0, d1, d2;
    double a12 = 0, a13 = 0, a21 = 0, a31 = 0, i22 = 0, m23 = 0, m32 = 0, i33 = 0;
    /* the convergence test's block scales |z| + |zbar| at the predicted midpoint (the library's) */
    double bq = fabs(q) + fabs(q + (ql + x0)), bp = fabs(p) + fabs(p + (pl + x1));
    double top = fmax(fmax(bq, bp), fmax(fabs(t) + fabs(t + (tl + 0.5 * x2)), 2 * fabs(wp)));
    double ibq = 1 / (bq > 0 ? bq : top > 0 ? top : 1), ibp = 1 / (bp > 0 ? bp : top > 0 ? top : 1);
    int iter, done = 0;
    for (iter = 1; iter <= 30 && !done; iter++) {
        qb = q + (ql + x0);
        pb = p + (pl + x1);
        sincos(qb, &sn, &cs);
        hl = 0.5 * x2;
        f0 = x0 - hl * pb, f1 = x1 + hl * sn, f2 = wp + (0.5 * pb * pb - cs);
        /* J = [[1, -l/2, -pb/2], [l/2 cos, 1, sin/2], [sin, pb, 0]], eliminated without pivoting */
        a12 = -hl, a13 = -0.5 * pb, a21 = hl * cs, a31 = sn;
        double a23 = 0.5 * sn, a32 = pb;
        i22 = 1 / (1 - a21 * a12), m23 = a23 - a21 * a13, m32 = a32 - a31 * a12;
        i33 = 1 / (-a31 * a13 - m32 * m23 * i22);
        g1 = f1 - a21 * f0, g2 = f2 - a31 * f0;
        d2 = (g2 - m32 * g1 * i22) * i33, d1 = (g1 - m23 * d2) * i22, d0 = f0 - a12 * d1 - a13 * d2;
        x0 -= d0, x1 -= d1, x2 -= d2;
        double r = fmax(fmax(fabs(d0) * ibq, fabs(d1) * ibp), fabs(d2) / fabs(x2));
        int v = rate(r, r_prev, iter);
        if (v == DONE || v == CHORD) done = 1;
        else if (v == STALLED && iter >= 8) return 1;
        r_prev = r;
    }
    if (!done) return 1;
    /* the compensated finish: chord steps on the constraint rho_k - (H(z_k) - H(zbar)) (the direct
     * wp + H_phys where they differ by more than 4 eps S), a second and third where lambda moved */
    double bl0, bl2, gq = 0, gp = 0;
    for (int c = 1;; c++) {
        qb = q + (ql + x0);
        pb = p + (pl + x1);
        sincos(qb, &sn, &cs);
        hl = 0.5 * x2;
        double Hp = 0.5 * pb * pb - cs, rd = wp + Hp;
        f0 = x0 - hl * pb, f1 = x1 + hl * sn;
        two_sum(q, ql + x0, &bl0);
        two_sum(p, pl + x1, &bl2);
        double ec = s->rho - pend_offset(s->z, s->lo, qb, pb, bl0, bl2, sn, pb);
        double tau = 4 * DBL_EPSILON * (fabs(wp) + fabs(Hp) + fabs(sn * qb) + fabs(pb * pb));
        f2 = fabs(ec - rd) <= tau ? ec : rd;
        g1 = f1 - a21 * f0, g2 = f2 - a31 * f0;
        d2 = (g2 - m32 * g1 * i22) * i33, d1 = (g1 - m23 * d2) * i22, d0 = f0 - a12 * d1 - a13 * d2;
        x0 -= d0, x1 -= d1, x2 -= d2;
        gq = sn, gp = pb;
        if (!(c < 3 && d2 * d2 > DBL_EPSILON * (x2 * x2))) break;
    }
    /* residual at the accepted midpoint (the library reports it), its low part */
    qb = q + (ql + x0);
    pb = p + (pl + x1);
    volatile double res = fabs(wp + (0.5 * pb * pb - cos(qb)));
    (void)res;
    two_sum(q, ql + x0, &bl0);
    two_sum(p, pl + x1, &bl2);
    /* cheap branch test at the vertex: ahead, H/psi > 0, s <= 1, psi's sign kept, ratio in [1/2, 2] */
    double qv = q + ql, pv = p + pl, sv, cv;
    sincos(qv, &sv, &cv);
    double H = wp + (0.5 * pv * pv - cv), psi = pv * pv * cv + sv * sv, dpsi = -sv * pv * pv * pv;
    double sfac = -(dpsi / psi) * x2, ratio = x2 / l0;
    if (!(x2 > 0 && H * psi > 0 && sfac <= 1 && (s->psi_prev > 0) == (psi > 0) && ratio >= 0.5 && ratio <= 2)) return 2;
    s->psi_prev = psi;
    /* commit in double-double, the next vertex's offset from this midpoint; the predictor's history */
    double dd[3] = {x0, 0.5 * x2, x1};
    for (int j = 0; j < 3; j++) s->z[j] = two_sum(s->z[j], 2 * dd[j] + s->lo[j], &s->lo[j]);
    s->rho = pend_offset(s->z, s->lo, qb, pb, bl0, bl2, gq, gp);
    memmove(s->d[1], s->d[0], 2 * sizeof s->d[0]);
    s->lam[2] = s->lam[1], s->lam[1] = s->lam[0];
    s->d[0][0] = x0, s->d[0][1] = x1, s->lam[0] = x2;
    if (s->nh < 3) s->nh++;
    s->steps++;
    *lam_out = x2;
    return 0;
}

/* ------------------------------------------------------------------ Kepler floor (2-D, mu = 1) */

typedef struct kep {
    double z[6], lo[6], rho; /* q1, q2, t, p1, p2, wp; the carried vertex offset */
    double d[3][4], lam[3];
    int nh;
    double psi_prev;
} kep;

/* V = -1/r, its gradient and Hessian, written as the model does (mr3 = 1/r^3). */
static void kep_grad(double q1, double q2, double *V, double g[2], double Vh[3])
{
    double r2 = q1 * q1 + q2 * q2, r = sqrt(r2), mr3 = 1 / (r2 * r);
    *V = -1 / r;
    g[0] = mr3 * q1, g[1] = mr3 * q2;
    if (Vh) {
        Vh[0] = -3 * mr3 * q1 * q1 / r2 + mr3;
        Vh[1] = -3 * mr3 * q2 * q1 / r2;
        Vh[2] = -3 * mr3 * q2 * q2 / r2 + mr3;
    }
}

/* H(y1) - H(y0) without cancellation (the model's hdiff); y = (q1, q2, p1, p2). */
static inline double kep_hdiff(const double *y1, const double *y0)
{
    double r1 = sqrt(y1[0] * y1[0] + y1[1] * y1[1]), r0 = sqrt(y0[0] * y0[0] + y0[1] * y0[1]);
    double dd = (y1[0] - y0[0]) * (y1[0] + y0[0]) + (y1[1] - y0[1]) * (y1[1] + y0[1]);
    double kin = (y1[2] - y0[2]) * (y1[2] + y0[2]) + (y1[3] - y0[3]) * (y1[3] + y0[3]);
    return 0.5 * kin + (dd / (r1 + r0)) / (r1 * r0);
}

/* H(z + lo) - H(zbar + blo): hdiff between the high parts (yb = (q, p) of zbar), the low parts (blo
 * over (q, p)) through the gradient g = (V', pb) at the midpoint; the wp parts cancel exactly. */
static inline double kep_offset(const double *z, const double *lo, const double *yb, const double *blo, const double *g)
{
    double y1[4] = {z[0], z[1], z[3], z[4]};
    double l = g[0] * (lo[0] - blo[0]) + g[1] * (lo[1] - blo[1]) + g[2] * (lo[3] - blo[2]) + g[3] * (lo[4] - blo[3]);
    return kep_hdiff(y1, yb) + l;
}

static void kep_start(kep *s, const double q0[2], const double p0[2], double h)
{
    memset(s, 0, sizeof *s);
    double V, g[2];
    kep_grad(q0[0], q0[1], &V, g, NULL);
    double zb[6] = {q0[0], q0[1], 0, p0[0], p0[1], -(0.5 * (p0[0] * p0[0] + p0[1] * p0[1]) + V)};
    double u[6] = {p0[0], p0[1], 1, -g[0], -g[1], 0}, z0[6];
    double yb[4] = {q0[0], q0[1], p0[0], p0[1]}, blo[4] = {0, 0, 0, 0}, gg[4] = {g[0], g[1], p0[0], p0[1]};
    for (int j = 0; j < 5; j++) z0[j] = two_sum(zb[j], -0.5 * h * u[j], &s->lo[j]);
    for (int j = 0; j < 5; j++) s->z[j] = two_sum(z0[j], 2 * (0.5 * h * u[j]) + s->lo[j], &s->lo[j]);
    s->z[5] = zb[5];
    /* the vertex offset after the exact first step, from zbar_0 (where H = 0 exactly) */
    s->rho = kep_offset(s->z, s->lo, yb, blo, gg);
    for (int i = 0; i < 2; i++) {
        s->d[0][i] = 0.5 * h * u[i];
        s->d[0][2 + i] = 0.5 * h * u[3 + i];
    }
    s->lam[0] = h;
    s->nh = 1;
    s->psi_prev = 1;
}

/* Solve J dx = f with the analytic Schur complement: K = I + (lambda^2/4) V'' (2 x 2). */
typedef struct kfac {
    double hl, pb[2], g[2], Vh[3], Ki[3], b[2], c[2], iden;
} kfac;

static void kep_factor(kfac *k, double hl, const double pb[2], const double g[2], const double Vh[3])
{
    k->hl = hl;
    memcpy(k->pb, pb, sizeof k->pb);
    memcpy(k->g, g, sizeof k->g);
    memcpy(k->Vh, Vh, sizeof k->Vh);
    double c = hl * hl, K0 = 1 + c * Vh[0], K1 = c * Vh[1], K2 = 1 + c * Vh[2], idet = 1 / (K0 * K2 - K1 * K1);
    k->Ki[0] = K2 * idet, k->Ki[1] = -K1 * idet, k->Ki[2] = K0 * idet;
    /* b = K^-1 ((lambda/4) V'' pb + g/2), c = pb + (lambda/2) g */
    double v0 = 0.5 * hl * (Vh[0] * pb[0] + Vh[1] * pb[1]) + 0.5 * g[0];
    double v1 = 0.5 * hl * (Vh[1] * pb[0] + Vh[2] * pb[1]) + 0.5 * g[1];
    k->b[0] = k->Ki[0] * v0 + k->Ki[1] * v1, k->b[1] = k->Ki[1] * v0 + k->Ki[2] * v1;
    k->c[0] = pb[0] + hl * g[0], k->c[1] = pb[1] + hl * g[1];
    k->iden = 1 / (0.5 * (g[0] * pb[0] + g[1] * pb[1]) - (k->c[0] * k->b[0] + k->c[1] * k->b[1]));
}

static void kep_solve(const kfac *k, const double f[5], double dx[5])
{
    const double *fq = f, *fp = f + 2, *Vh = k->Vh;
    double w0 = fp[0] - k->hl * (Vh[0] * fq[0] + Vh[1] * fq[1]);
    double w1 = fp[1] - k->hl * (Vh[1] * fq[0] + Vh[2] * fq[1]);
    double a0 = k->Ki[0] * w0 + k->Ki[1] * w1, a1 = k->Ki[1] * w0 + k->Ki[2] * w1;
    double dl = (f[4] - (k->g[0] * fq[0] + k->g[1] * fq[1]) - (k->c[0] * a0 + k->c[1] * a1)) * k->iden;
    dx[2] = a0 - k->b[0] * dl, dx[3] = a1 - k->b[1] * dl;
    dx[0] = fq[0] + k->hl * dx[2] + 0.5 * k->pb[0] * dl;
    dx[1] = fq[1] + k->hl * dx[3] + 0.5 * k->pb[1] * dl;
    dx[4] = dl;
}

/* Residual at the unknowns x (dq1, dq2, dp1, dp2, lambda); fills the midpoint's qb, pb, g, Vh and *Hp. */
static void kep_residual(const kep *s, const double x[5], double f[5], double qb[2], double pb[2], double g[2], double *Vh,
                         double *Hp)
{
    qb[0] = s->z[0] + (s->lo[0] + x[0]), qb[1] = s->z[1] + (s->lo[1] + x[1]);
    pb[0] = s->z[3] + (s->lo[3] + x[2]), pb[1] = s->z[4] + (s->lo[4] + x[3]);
    double V;
    kep_grad(qb[0], qb[1], &V, g, Vh);
    double hl = 0.5 * x[4];
    f[0] = x[0] - hl * pb[0], f[1] = x[1] - hl * pb[1];
    f[2] = x[2] + hl * g[0], f[3] = x[3] + hl * g[1];
    *Hp = 0.5 * (pb[0] * pb[0] + pb[1] * pb[1]) + V;
    f[4] = s->z[5] + *Hp;
}

/* The low part of the midpoint over (q1, q2, p1, p2). */
static void kep_midlo(const kep *s, const double x[5], double blo[4])
{
    two_sum(s->z[0], s->lo[0] + x[0], &blo[0]);
    two_sum(s->z[1], s->lo[1] + x[1], &blo[1]);
    two_sum(s->z[3], s->lo[3] + x[2], &blo[2]);
    two_sum(s->z[4], s->lo[4] + x[3], &blo[3]);
}

static int kep_step(kep *s, double *lam_out)
{
    double x[5], l0 = s->lam[0];
    int quad = 0;
    if (s->nh >= 3) {
        double l = 3 * (s->lam[0] - s->lam[1]) + s->lam[2];
        quad = l > 0 && l <= 2 * l0 && 2 * l >= l0;
        if (quad) {
            for (int j = 0; j < 4; j++) x[j] = 3 * (s->d[0][j] - s->d[1][j]) + s->d[2][j];
            x[4] = l;
        }
    }
    if (!quad) {
        memcpy(x, s->d[0], 4 * sizeof *x);
        x[4] = l0;
    }
    double r_prev = INFINITY, f[5], dx[5], qb[2], pb[2], g[2], Vh[3], Hp;
    kfac K;
    int done = 0;
    /* the convergence test's block scales at the predicted midpoint (the library's) */
    double bq = 0, bp = 0;
    for (int i = 0; i < 2; i++) {
        bq = fmax(bq, fabs(s->z[i]) + fabs(s->z[i] + (s->lo[i] + x[i])));
        bp = fmax(bp, fabs(s->z[3 + i]) + fabs(s->z[3 + i] + (s->lo[3 + i] + x[2 + i])));
    }
    double top = fmax(fmax(bq, bp), fmax(fabs(s->z[2]) + fabs(s->z[2] + (s->lo[2] + 0.5 * x[4])), 2 * fabs(s->z[5])));
    double ibq = 1 / (bq > 0 ? bq : top > 0 ? top : 1), ibp = 1 / (bp > 0 ? bp : top > 0 ? top : 1);
    for (int iter = 1; iter <= 30 && !done; iter++) {
        kep_residual(s, x, f, qb, pb, g, Vh, &Hp);
        kep_factor(&K, 0.5 * x[4], pb, g, Vh);
        kep_solve(&K, f, dx);
        for (int j = 0; j < 5; j++) x[j] -= dx[j];
        double r = fmax(fmax(fabs(dx[0]), fabs(dx[1])) * ibq, fmax(fabs(dx[2]), fabs(dx[3])) * ibp);
        r = fmax(r, fabs(dx[4]) / fabs(x[4]));
        int v = rate(r, r_prev, iter);
        if (v == DONE || v == CHORD) done = 1;
        else if (v == STALLED && iter >= 8) return 1;
        r_prev = r;
    }
    if (!done) return 1;
    /* the compensated finish (as the pendulum's) */
    double blo[4], gg[4], yb[4];
    for (int c = 1;; c++) {
        kep_residual(s, x, f, qb, pb, g, NULL, &Hp);
        kep_midlo(s, x, blo);
        yb[0] = qb[0], yb[1] = qb[1], yb[2] = pb[0], yb[3] = pb[1];
        gg[0] = g[0], gg[1] = g[1], gg[2] = pb[0], gg[3] = pb[1];
        double ec = s->rho - kep_offset(s->z, s->lo, yb, blo, gg), rd = f[4];
        double tau = 4 * DBL_EPSILON * (fabs(s->z[5]) + fabs(Hp) + fabs(g[0] * qb[0]) + fabs(g[1] * qb[1]) +
                                        fabs(pb[0] * pb[0]) + fabs(pb[1] * pb[1]));
        f[4] = fabs(ec - rd) <= tau ? ec : rd;
        kep_solve(&K, f, dx);
        for (int j = 0; j < 5; j++) x[j] -= dx[j];
        if (!(c < 3 && dx[4] * dx[4] > DBL_EPSILON * (x[4] * x[4]))) break;
    }
    /* residual at the accepted midpoint (the library reports it), its low part */
    double g2[2], qb2[2], pb2[2];
    kep_residual(s, x, f, qb2, pb2, g2, NULL, &Hp);
    volatile double res = fabs(f[4]);
    (void)res;
    kep_midlo(s, x, blo);
    yb[0] = qb2[0], yb[1] = qb2[1], yb[2] = pb2[0], yb[3] = pb2[1];
    /* cheap branch test at the vertex: psi = p.V''p + |grad V|^2, psi' = D^3 V[p, p, p] */
    double qv[2] = {s->z[0] + s->lo[0], s->z[1] + s->lo[1]}, pv[2] = {s->z[3] + s->lo[3], s->z[4] + s->lo[4]};
    double V, gv[2], Vv[3];
    kep_grad(qv[0], qv[1], &V, gv, Vv);
    double r2 = qv[0] * qv[0] + qv[1] * qv[1], r = sqrt(r2), qp = qv[0] * pv[0] + qv[1] * pv[1];
    double pp = pv[0] * pv[0] + pv[1] * pv[1];
    double H = s->z[5] + (0.5 * pp + V);
    double psi = pv[0] * (Vv[0] * pv[0] + Vv[1] * pv[1]) + pv[1] * (Vv[1] * pv[0] + Vv[2] * pv[1]) + gv[0] * gv[0] + gv[1] * gv[1];
    double dpsi = qp * (15 * qp * qp / r2 - 9 * pp) / (r2 * r2 * r);
    double sfac = -(dpsi / psi) * x[4], ratio = x[4] / l0;
    if (!(x[4] > 0 && H * psi > 0 && sfac <= 1 && (s->psi_prev > 0) == (psi > 0) && ratio >= 0.5 && ratio <= 2)) return 2;
    s->psi_prev = psi;
    double dd[5] = {x[0], x[1], 0.5 * x[4], x[2], x[3]};
    for (int j = 0; j < 5; j++) s->z[j] = two_sum(s->z[j], 2 * dd[j] + s->lo[j], &s->lo[j]);
    s->rho = kep_offset(s->z, s->lo, yb, blo, gg); /* gg: the gradient of the last chord residual, as the library */
    memmove(s->d[1], s->d[0], 2 * sizeof s->d[0]);
    s->lam[2] = s->lam[1], s->lam[1] = s->lam[0];
    memcpy(s->d[0], x, 4 * sizeof *x);
    s->lam[0] = x[4];
    if (s->nh < 3) s->nh++;
    *lam_out = x[4];
    return 0;
}

/* ------------------------------------------------------------------ GSL rk4imp on the pendulum */

static int gsl_pend_f(double t, const double y[], double f[], void *par)
{
    (void)t, (void)par;
    f[0] = y[1];
    f[1] = -sin(y[0]);
    return GSL_SUCCESS;
}

static int gsl_pend_jac(double t, const double y[], double *dfdy, double dfdt[], void *par)
{
    (void)t, (void)par;
    dfdy[0] = 0, dfdy[1] = 1, dfdy[2] = -cos(y[0]), dfdy[3] = 0;
    dfdt[0] = dfdt[1] = 0;
    return GSL_SUCCESS;
}

/* ------------------------------------------------------------------ timing */

static dth_model *pen_model, *kep_model;
static double sink;

static double time_lib_opt(const dth_model *m, double h, int compensate, int branch_check, const double *q0,
                           const double *p0, long steps, double *iters)
{
    dth_options o;
    dth_options_default(&o);
    o.h = h;
    o.finish = (dth_finish)compensate;
    o.branch_check = branch_check;
    dth_integrator *it;
    if (dth_integrator_new(m, &o, &it) || dth_integrator_start(it, q0, p0, 0.0) || dth_integrator_step(it, NULL)) {
        fprintf(stderr, "cannot start the library's integrator\n");
        exit(1);
    }
    dth_step_info info;
    double t0 = bench_now();
    for (long k = 0; k < steps; k++) {
        if (dth_integrator_step(it, &info)) {
            fprintf(stderr, "library step %ld failed: %s\n", k, dth_integrator_errmsg(it));
            exit(1);
        }
        if (iters) *iters += info.iters;
    }
    double dt = (bench_now() - t0) / (double)steps;
    sink += dth_integrator_vertex(it)[0];
    dth_integrator_free(it);
    return dt;
}

static double time_lib(const dth_model *m, double h, const double *q0, const double *p0, long steps, double *iters)
{
    return time_lib_opt(m, h, 1, 1, q0, p0, steps, iters);
}

static double time_pend_floor(long steps)
{
    pend s;
    pend_start(&s, 1.0, 0.0, 0.05);
    double lam, t0 = bench_now();
    for (long k = 0; k < steps; k++)
        if (pend_step(&s, &lam)) {
            fprintf(stderr, "pendulum floor failed at step %ld\n", k);
            exit(1);
        }
    double dt = (bench_now() - t0) / (double)steps;
    sink += s.z[0];
    return dt;
}

static double time_kep_floor(const double q0[2], const double p0[2], long steps)
{
    kep s;
    kep_start(&s, q0, p0, 0.01);
    double lam, t0 = bench_now();
    for (long k = 0; k < steps; k++)
        if (kep_step(&s, &lam)) {
            fprintf(stderr, "kepler floor failed at step %ld\n", k);
            exit(1);
        }
    double dt = (bench_now() - t0) / (double)steps;
    sink += s.z[0];
    return dt;
}

static double time_gsl(long steps)
{
    gsl_odeiv2_system sys = {gsl_pend_f, gsl_pend_jac, 2, NULL};
    /* an implicit GSL stepper needs a driver (it sets the stepper's iteration tolerance) */
    gsl_odeiv2_driver *dr = gsl_odeiv2_driver_alloc_y_new(&sys, gsl_odeiv2_step_rk4imp, 0.05, 1e-12, 1e-12);
    gsl_odeiv2_step *st = dr->s;
    double y[2] = {1.0, 0.0}, yerr[2], t = 0, h = 0.05;
    double t0 = bench_now();
    for (long k = 0; k < steps; k++) {
        if (gsl_odeiv2_step_apply(st, t, h, y, yerr, NULL, NULL, &sys) != GSL_SUCCESS) {
            fprintf(stderr, "GSL rk4imp step %ld failed\n", k);
            exit(1);
        }
        t += h;
    }
    double dt = (bench_now() - t0) / (double)steps;
    sink += y[0];
    gsl_odeiv2_driver_free(dr);
    return dt;
}

static double time_verlet(long steps)
{
    double h = 0.05, q = 1.0, p = 0.0, t0 = bench_now();
    for (long k = 0; k < steps; k++) {
        p -= 0.5 * h * sin(q);
        q += h * p;
        p -= 0.5 * h * sin(q);
    }
    double dt = (bench_now() - t0) / (double)steps;
    sink += q;
    return dt;
}

/* The floors take the library's steps: the largest relative difference of lambda over the first
 * 1000 steps (into *early) and over `steps` steps (returned; the two trajectories drift apart from
 * their first difference in round-off, as any two orderings of the same arithmetic would). */
static double pend_agree(long steps, double *early)
{
    dth_options o;
    dth_options_default(&o);
    o.h = 0.05;
    dth_integrator *it;
    double q0 = 1.0, p0 = 0.0, worst = 0, lam;
    if (dth_integrator_new(pen_model, &o, &it) || dth_integrator_start(it, &q0, &p0, 0.0) || dth_integrator_step(it, NULL)) exit(1);
    pend s;
    pend_start(&s, q0, p0, 0.05);
    for (long k = 0; k < steps; k++) {
        dth_step_info info;
        int a = dth_integrator_step(it, &info), b = pend_step(&s, &lam);
        if (a || b) {
            fprintf(stderr, "pendulum agreement: step %ld: library %d, floor %d\n", k, a, b);
            exit(1);
        }
        worst = fmax(worst, fabs(lam - info.lambda) / info.lambda);
        if (k == 999) *early = worst;
    }
    dth_integrator_free(it);
    return worst;
}

static double kep_agree(const double q0[2], const double p0[2], long steps, double *early)
{
    dth_options o;
    dth_options_default(&o);
    o.h = 0.01;
    dth_integrator *it;
    double worst = 0, lam;
    if (dth_integrator_new(kep_model, &o, &it) || dth_integrator_start(it, q0, p0, 0.0) || dth_integrator_step(it, NULL)) exit(1);
    kep s;
    kep_start(&s, q0, p0, 0.01);
    for (long k = 0; k < steps; k++) {
        dth_step_info info;
        int a = dth_integrator_step(it, &info), b = kep_step(&s, &lam);
        if (a || b) {
            fprintf(stderr, "kepler agreement: step %ld: library %d, floor %d\n", k, a, b);
            exit(1);
        }
        worst = fmax(worst, fabs(lam - info.lambda) / info.lambda);
        if (k == 999) *early = worst;
    }
    dth_integrator_free(it);
    return worst;
}

/* ------------------------------------------------------------------ threads */

typedef struct job {
    long steps;
    double q0;
} job;

static void *thread_run(void *arg)
{
    job *j = arg;
    double p0 = 0;
    time_lib(pen_model, 0.05, &j->q0, &p0, j->steps, NULL);
    return NULL;
}

/* Wall time of `nt` threads, each integrating its own pendulum for `steps` steps. */
static double time_threads(int nt, long steps)
{
    pthread_t th[2];
    job jobs[2] = {{steps, 1.0}, {steps, 0.9}};
    double t0 = bench_now();
    for (int i = 0; i < nt; i++) pthread_create(&th[i], NULL, thread_run, &jobs[i]);
    for (int i = 0; i < nt; i++) pthread_join(th[i], NULL);
    return bench_now() - t0;
}

static double median(double *v)
{
    qsort(v, REPEATS, sizeof *v, bench_cmp_double);
    return v[REPEATS / 2];
}

int main(int argc, char **argv)
{
    if (!getenv("OPENBLAS_NUM_THREADS")) {
        setenv("OPENBLAS_NUM_THREADS", "1", 1);
        execv("/proc/self/exe", argv);
    }
    const char *only = argc > 2 && !strcmp(argv[1], "--only") ? argv[2] : NULL;
    long steps = only ? (argc > 3 ? atol(argv[3]) : 20000) : argc > 1 ? atol(argv[1]) : 200000;
    if (steps < 100) return 2;
    char err[256];
    if (dth_model_new(&dth_model_pendulum, NULL, 0, 1, NULL, &pen_model, err, sizeof err) ||
        dth_model_new(&dth_model_kepler, NULL, 0, 2, NULL, &kep_model, err, sizeof err)) {
        fprintf(stderr, "%s\n", err);
        return 1;
    }
    const double e = 0.6, kq[2] = {1 - e, 0}, kp[2] = {0, sqrt((1 + e) / (1 - e))};
    double pq = 1.0, pp = 0.0;
    if (only) {
        if (!strcmp(only, "pend-lib")) time_lib(pen_model, 0.05, &pq, &pp, steps, NULL);
        else if (!strcmp(only, "pend-lib-nocomp")) time_lib_opt(pen_model, 0.05, 0, 1, &pq, &pp, steps, NULL);
        else if (!strcmp(only, "pend-lib-nobranch")) time_lib_opt(pen_model, 0.05, 1, 0, &pq, &pp, steps, NULL);
        else if (!strcmp(only, "pend-lib-rev")) time_lib_opt(pen_model, 0.05, 2, 1, &pq, &pp, steps, NULL);
        else if (!strcmp(only, "pend-floor")) time_pend_floor(steps);
        else if (!strcmp(only, "kep-lib")) time_lib(kep_model, 0.01, kq, kp, steps, NULL);
        else if (!strcmp(only, "kep-floor")) time_kep_floor(kq, kp, steps);
        else if (!strcmp(only, "rk4imp")) time_gsl(steps);
        else if (!strcmp(only, "verlet")) time_verlet(steps);
        else return 2;
        dth_model_free(pen_model);
        dth_model_free(kep_model);
        return 0;
    }
    double ap1 = NAN, ak1 = NAN, ap = pend_agree(20000, &ap1), ak = kep_agree(kq, kp, 20000, &ak1);
    double tl[REPEATS], tf[REPEATS], tg[REPEATS], tv[REPEATS], tkl[REPEATS], tkf[REPEATS], tc[REPEATS], tb[REPEATS];
    double trv[REPEATS];
    double it_p = 0, it_k = 0;
    for (int r = 0; r < REPEATS; r++) {
        tl[r] = time_lib(pen_model, 0.05, &pq, &pp, steps, &it_p);
        tc[r] = time_lib_opt(pen_model, 0.05, 0, 1, &pq, &pp, steps, NULL);
        tb[r] = time_lib_opt(pen_model, 0.05, 1, 0, &pq, &pp, steps, NULL);
        trv[r] = time_lib_opt(pen_model, 0.05, 2, 1, &pq, &pp, steps, NULL);
        tf[r] = time_pend_floor(steps);
        tg[r] = time_gsl(steps / 4);
        tv[r] = time_verlet(steps);
        tkl[r] = time_lib(kep_model, 0.01, kq, kp, steps, &it_k);
        tkf[r] = time_kep_floor(kq, kp, steps);
    }
    double l = median(tl), f = median(tf), g = median(tg), v = median(tv), kl = median(tkl), kf = median(tkf), c = median(tc);
    double b = median(tb), rv = median(trv);
    double nr = (double)REPEATS * (double)steps;
    printf("DTH step against its closed-form floor and peers, %ld steps, median of %d interleaved runs\n", steps, REPEATS);
    printf("pendulum, h = 0.05, amplitude 1 (floor's lambda within %.1e of the library's over 1000 steps, %.1e over 20000)\n",
           ap1, ap);
    printf("  library DTH step     %8.1f ns   (%.2f Newton iterations per step)\n", 1e9 * l, it_p / nr);
    printf("  same, compensate = 0 %8.1f ns   (the compensated finish costs %.0f%% of the step)\n", 1e9 * c,
           100 * (l - c) / l);
    printf("  same, branch_check = 0 %6.1f ns   (the cheap branch test costs %.0f%% of the step)\n", 1e9 * b,
           100 * (l - b) / l);
    printf("  same, compensate = 2 %8.1f ns   (the reversible finish: %.2f x the step)\n", 1e9 * rv, rv / l);
    printf("  closed-form floor    %8.1f ns   library / floor %.2f   (target <= 1.5)\n", 1e9 * f, l / f);
    printf("  GSL rk4imp step      %8.1f ns   library / rk4imp %.2f   (target <= 0.35)\n", 1e9 * g, l / g);
    printf("  Stormer-Verlet step  %8.1f ns   library / Verlet %.1f\n", 1e9 * v, l / v);
    printf("kepler e = 0.6, h = 0.01 (floor's lambda within %.1e of the library's over 1000 steps, %.1e over 20000)\n",
           ak1, ak);
    printf("  library DTH step     %8.1f ns   (%.2f Newton iterations per step)\n", 1e9 * kl, it_k / nr);
    printf("  2x2 Schur floor      %8.1f ns   library / floor %.2f   (target <= 1.5)\n", 1e9 * kf, kl / kf);
    double w1[REPEATS], w2[REPEATS];
    long ts = steps * 2;
    for (int r = 0; r < REPEATS; r++) {
        w1[r] = time_threads(1, ts);
        w2[r] = time_threads(2, ts);
    }
    double t1 = median(w1), t2 = median(w2);
    printf("independent pendulum integrations, %ld steps each (%ld online CPUs)\n", ts, sysconf(_SC_NPROCESSORS_ONLN));
    printf("  1 thread   %8.1f steps/us\n", (double)ts / t1 / 1e6);
    printf("  2 threads  %8.1f steps/us   throughput 2 / 1 threads %.2f   (target >= 1.8)\n", 2.0 * (double)ts / t2 / 1e6,
           2.0 * t1 / t2);
    if (sink == 12345.678) puts("");
    dth_model_free(pen_model);
    dth_model_free(kep_model);
    return 0;
}
