/* SPDX-License-Identifier: MIT */
/*
 * Kepler model: derivatives (2-D, 3-D), invariants against orbital elements, the exact solution
 * against Kepler's equation run forwards, and raw DTH on bound orbits: energy exact at midpoints,
 * angular momentum at round-off, second-order position error and LRL precession (paper,
 * Theorem "DTH Equations"), and what happens at the psi = 0 crossing of an e = 0.9 orbit
 * (section 5). With -DDTH_KEPLER_LONG: Brouwer's sqrt(N) law for |Delta L| over 1e6 steps.
 */
#include <float.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include "cu_main.h"
#include "dth/dth.h"
#include "dth_internal.h"

#define PI 3.14159265358979323846

static dth_model *new_kepler(size_t dim)
{
    dth_model *m = NULL;
    char err[256];
    CU_ASSERT_FATAL(dth_model_new(&dth_model_kepler, NULL, 0, dim, NULL, &m, err, sizeof err) == DTH_OK);
    return m;
}

/* Pericentre state of the orbit with a = mu = 1 and eccentricity e: q = (1-e, 0), p = (0, v). */
static void pericentre(double e, double *y)
{
    y[0] = 1 - e;
    y[1] = 0;
    y[2] = 0;
    y[3] = 0;
    y[4] = sqrt((1 + e) / (1 - e));
}

/* State (2-D, a = mu = 1, pericentre on +x) at eccentric anomaly E, and the time since
 * pericentre by Kepler's equation run forwards (no solving): an independent reference. */
static double state_at_E(double e, double E, double *y)
{
    double b = sqrt(1 - e * e), den = 1 - e * cos(E);
    y[0] = cos(E) - e;
    y[1] = b * sin(E);
    y[3] = -sin(E) / den;
    y[4] = b * cos(E) / den;
    return E - e * sin(E);
}

static double energy2(const double *y) { return 0.5 * (y[3] * y[3] + y[4] * y[4]) - 1 / hypot(y[0], y[1]); }

/* ------------------------------------------------------------------ model */

static void test_derivatives(void)
{
    static const double pts2[][5] = {
        {0.4, 0.0, 0.0, 0.0, 2.0}, {-1.3, 0.7, 2.0, 0.3, -0.5}, {0.05, -0.02, 0.0, 3.0, 4.0}, {2.0, 3.0, 1.0, -0.1, 0.2}};
    static const double pts3[][7] = {
        {0.4, 0.1, -0.2, 0.0, 0.3, 2.0, 0.1}, {-1.0, 0.5, 0.8, 5.0, -0.2, 0.1, 0.9}, {0.1, 0.02, -0.03, 0.0, 1.0, -2.0, 3.0}};
    double worst = 0;
    for (size_t dim = 2; dim <= 3; dim++) {
        dth_model *m = new_kepler(dim);
        size_t np = dim == 2 ? 4 : 3;
        for (size_t k = 0; k < np; k++) {
            const double *y = dim == 2 ? pts2[k] : pts3[k];
            dth_model_check_report rep;
            CU_ASSERT_EQUAL_FATAL(dth_model_check(m, y, &rep), DTH_OK);
            CU_ASSERT(rep.grad_err < 1e-7);
            CU_ASSERT(rep.hess_err < 1e-7);
            CU_ASSERT(rep.sym_err == 0);
            CU_ASSERT(rep.third_err < 1e-6);
            worst = fmax(worst, fmax(rep.grad_err, fmax(rep.hess_err, rep.third_err)));
            /* psi in closed form: mu (|p|^2/r^3 - 3 (q.p)^2/r^5) + mu^2/r^4 */
            double w[64], psi, dpsi, r2 = 0, pp = 0, qp = 0;
            CU_ASSERT_FATAL(dth_model_psi(m, y, &psi, &dpsi, w) == DTH_OK);
            for (size_t i = 0; i < dim; i++) {
                r2 += y[i] * y[i];
                pp += y[dim + 1 + i] * y[dim + 1 + i];
                qp += y[i] * y[dim + 1 + i];
            }
            double r = sqrt(r2), ref = pp / (r2 * r) - 3 * qp * qp / (r2 * r2 * r) + 1 / (r2 * r2);
            CU_ASSERT(fabs(psi - ref) <= 1e-13 * (fabs(ref) + pp / (r2 * r) + 1 / (r2 * r2)));
        }
        /* q = 0 is outside the domain */
        double y0[7] = {0};
        y0[dim + 1] = 1;
        double H;
        CU_ASSERT_EQUAL(dth_model_eval(m, y0, DTH_EVAL_H, &H, NULL, NULL), DTH_EDOMAIN);
        dth_model_free(m);
    }
    printf(" [worst mismatch %.2g] ", worst);
}

static void test_params(void)
{
    dth_model *m = NULL;
    char err[256];
    dth_kv mu0[] = {{"mu", "0"}}, mun[] = {{"mu", "-2"}}, dim4[] = {{"dim", "4"}}, dim3[] = {{"dim", "3"}};
    dth_kv dimx[] = {{"dim", "2.5"}}, mu2[] = {{"mu", "2"}};
    CU_ASSERT_EQUAL(dth_model_new(&dth_model_kepler, mu0, 1, 2, NULL, &m, err, sizeof err), DTH_EINVAL);
    CU_ASSERT_PTR_NOT_NULL(strstr(err, "'mu'"));
    CU_ASSERT_EQUAL(dth_model_new(&dth_model_kepler, mun, 1, 2, NULL, &m, err, sizeof err), DTH_EINVAL);
    CU_ASSERT_PTR_NOT_NULL(strstr(err, "'mu'"));
    CU_ASSERT_EQUAL(dth_model_new(&dth_model_kepler, dim4, 1, 0, NULL, &m, err, sizeof err), DTH_EINVAL);
    CU_ASSERT_PTR_NOT_NULL(strstr(err, "'dim'"));
    CU_ASSERT_EQUAL(dth_model_new(&dth_model_kepler, dimx, 1, 0, NULL, &m, err, sizeof err), DTH_EINVAL);
    CU_ASSERT_PTR_NOT_NULL(strstr(err, "'dim'"));
    CU_ASSERT_EQUAL(dth_model_new(&dth_model_kepler, dim3, 1, 2, NULL, &m, err, sizeof err), DTH_EINVAL);
    CU_ASSERT_PTR_NOT_NULL(strstr(err, "'dim'"));
    CU_ASSERT_EQUAL(dth_model_new(&dth_model_kepler, NULL, 0, 1, NULL, &m, err, sizeof err), DTH_EINVAL);
    CU_ASSERT_EQUAL(dth_model_new(&dth_model_kepler, NULL, 0, 4, NULL, &m, err, sizeof err), DTH_EINVAL);
    CU_ASSERT_PTR_NULL(m);
    /* dimension from dim, from the q count, default 2 */
    CU_ASSERT_EQUAL_FATAL(dth_model_new(&dth_model_kepler, dim3, 1, 0, NULL, &m, err, sizeof err), DTH_OK);
    CU_ASSERT_EQUAL(dth_model_dof(m), 3);
    CU_ASSERT_EQUAL(dth_model_get_type(m)->n_invariants(dth__model_self(m)), 7);
    dth_model_free(m);
    CU_ASSERT_EQUAL_FATAL(dth_model_new(&dth_model_kepler, NULL, 0, 3, NULL, &m, err, sizeof err), DTH_OK);
    CU_ASSERT_EQUAL(dth_model_dof(m), 3);
    dth_model_free(m);
    CU_ASSERT_EQUAL_FATAL(dth_model_new(&dth_model_kepler, NULL, 0, 0, NULL, &m, err, sizeof err), DTH_OK);
    CU_ASSERT_EQUAL(dth_model_dof(m), 2);
    CU_ASSERT_EQUAL(dth_model_get_info(m)->autonomous, 1);
    dth_model_free(m);
    /* mu scales the potential */
    CU_ASSERT_EQUAL_FATAL(dth_model_new(&dth_model_kepler, mu2, 1, 2, NULL, &m, err, sizeof err), DTH_OK);
    double y[5] = {0.5, 0, 0, 1, 0}, H;
    CU_ASSERT_EQUAL(dth_model_eval(m, y, DTH_EVAL_H, &H, NULL, NULL), DTH_OK);
    CU_ASSERT_DOUBLE_EQUAL(H, 0.5 - 4.0, 1e-15);
    dth_model_free(m);
}

/* Invariants against the orbital elements they encode: L = sqrt(mu a (1 - e^2)), |A| = mu e, and
 * omega the argument of pericentre, for planar and inclined (rotated) orbits. */
static void test_invariants_elements(void)
{
    dth_model *m2 = new_kepler(2), *m3 = new_kepler(3);
    const dth_model_type *t = dth_model_get_type(m2);
    double e = 0.6, y[5], inv[7];
    state_at_E(e, 1.1, y);
    y[2] = 0;
    CU_ASSERT_FATAL(t->invariants(dth__model_self(m2), y, inv) == 0);
    CU_ASSERT_DOUBLE_EQUAL(inv[0], sqrt(1 - e * e), 1e-15);
    CU_ASSERT_DOUBLE_EQUAL(inv[1], e, 1e-15);
    CU_ASSERT_DOUBLE_EQUAL(inv[2], 0, 1e-15);
    CU_ASSERT_DOUBLE_EQUAL(inv[3], 0, 1e-15);
    CU_ASSERT_STRING_EQUAL(t->invariant_name(dth__model_self(m2), 0), "L");
    CU_ASSERT_STRING_EQUAL(t->invariant_name(dth__model_self(m2), 3), "omega");
    CU_ASSERT_STRING_EQUAL(t->invariant_name(dth__model_self(m3), 6), "omega");
    /* 3-D: rotate by argument of pericentre w, inclination i, node Om (R = Rz(Om) Rx(i) Rz(w)) */
    static const double cases[][3] = {{0.7, 0.4, 1.2}, {-2.0, 2.5, -0.3}, {0.3, 0.0, 0.9}, {1.0, PI, 0.0}};
    for (size_t c = 0; c < sizeof cases / sizeof cases[0]; c++) {
        double w = cases[c][0], inc = cases[c][1], Om = cases[c][2];
        double cw = cos(w), sw = sin(w), ci = cos(inc), si = sin(inc), cO = cos(Om), sO = sin(Om);
        double R[3][2] = {{cO * cw - sO * ci * sw, -cO * sw - sO * ci * cw},
                          {sO * cw + cO * ci * sw, -sO * sw + cO * ci * cw},
                          {si * sw, si * cw}};
        double y3[7];
        for (int i = 0; i < 3; i++) {
            y3[i] = R[i][0] * y[0] + R[i][1] * y[1];
            y3[4 + i] = R[i][0] * y[3] + R[i][1] * y[4];
        }
        y3[3] = 0;
        CU_ASSERT_FATAL(t->invariants(dth__model_self(m3), y3, inv) == 0);
        double Ln = sqrt(inv[0] * inv[0] + inv[1] * inv[1] + inv[2] * inv[2]);
        double An = sqrt(inv[3] * inv[3] + inv[4] * inv[4] + inv[5] * inv[5]);
        CU_ASSERT_DOUBLE_EQUAL(Ln, sqrt(1 - e * e), 1e-14);
        CU_ASSERT_DOUBLE_EQUAL(An, e, 1e-14);
        CU_ASSERT_DOUBLE_EQUAL(inv[2], sqrt(1 - e * e) * ci, 1e-14);
        /* inclined: the argument of pericentre w; equatorial: the longitude of pericentre
         * counted along the motion, Om + w (prograde) or, with Om = 0 here, w (retrograde) */
        double want = inc == 0 ? w + Om : w;
        CU_ASSERT(fabs(remainder(inv[6] - want, 2 * PI)) <= 1e-13);
    }
    dth_model_free(m2);
    dth_model_free(m3);
}

/* ------------------------------------------------------------------ exact solution */

/* Energy, L and A conserved by `exact`; the period returns y0; half a period is apocentre. */
static void test_exact_conservation(void)
{
    dth_model *m = new_kepler(2);
    const dth_model_type *t = dth_model_get_type(m);
    const void *self = dth__model_self(m);
    static const double es[] = {0.0, 0.3, 0.6, 0.9, 0.99, 0.999};
    double worst = 0;
    for (size_t k = 0; k < sizeof es / sizeof es[0]; k++) {
        double e = es[k], y0[5], y[5], i0[4], i1[4];
        /* start away from pericentre, at E = 2 */
        state_at_E(e, 2.0, y0);
        y0[2] = 0.25;
        double H0 = energy2(y0);
        t->invariants(self, y0, i0);
        double errH = 0, errL = 0, errA = 0;
        for (int j = 1; j <= 400; j++) {
            double tt = 0.25 + 0.0731 * j * j; /* up to ~1.2e4: many periods */
            CU_ASSERT_FATAL(t->exact(self, y0, tt, y) == 0);
            CU_ASSERT(y[2] == tt);
            t->invariants(self, y, i1);
            errH = fmax(errH, fabs(energy2(y) - H0));
            errL = fmax(errL, fabs(i1[0] - i0[0]));
            errA = fmax(errA, hypot(i1[1] - i0[1], i1[2] - i0[2]));
        }
        /* the periapsis speed ~ sqrt(2/(1-e)) sets the scale of the kinetic and potential terms */
        double sc = 2 / (1 - e);
        CU_ASSERT(errH <= 16 * DBL_EPSILON * sc);
        CU_ASSERT(errL <= 16 * DBL_EPSILON * sqrt(sc));
        CU_ASSERT(errA <= 16 * DBL_EPSILON * sc);
        worst = fmax(worst, fmax(errH / sc, fmax(errL / sqrt(sc), errA / sc)) / DBL_EPSILON);
        /* period T = 2 pi (a = mu = 1) */
        CU_ASSERT_FATAL(t->exact(self, y0, 0.25 + 2 * PI, y) == 0);
        for (int i = 0; i < 5; i++) CU_ASSERT(fabs(y[i] - (i == 2 ? 0.25 + 2 * PI : y0[i])) <= 1e-13 * sc);
        /* from pericentre, half a period later: apocentre (-(1+e), 0), p = (0, -sqrt((1-e)/(1+e))) */
        double yp[5];
        pericentre(e, yp);
        CU_ASSERT_FATAL(t->exact(self, yp, PI, y) == 0);
        CU_ASSERT(fabs(y[0] + (1 + e)) <= 1e-14 * sc);
        CU_ASSERT(fabs(y[1]) <= 1e-14 * sc);
        CU_ASSERT(fabs(y[3]) <= 1e-14 * sc);
        CU_ASSERT(fabs(y[4] + sqrt((1 - e) / (1 + e))) <= 1e-14 * sc);
    }
    /* unbound orbits are outside the exact solution's scope */
    double par[5] = {1, 0, 0, 0, sqrt(2.0)}, hyp[5] = {1, 0, 0, 0.3, 1.5}, y[5];
    CU_ASSERT(t->exact(self, par, 1.0, y) > 0);
    CU_ASSERT(t->exact(self, hyp, 1.0, y) > 0);
    printf(" [worst drift %.1f eps of the scale] ", worst);
    dth_model_free(m);
}

/* Against Kepler's equation run forwards: the state at eccentric anomaly E is reached at time
 * t(E) = E - e sin E. Covers e = 0.999 close to pericentre, where E - e sin E cancels. */
static void test_exact_kepler_equation(void)
{
    dth_model *m = new_kepler(2);
    const dth_model_type *t = dth_model_get_type(m);
    const void *self = dth__model_self(m);
    static const double es[] = {0.1, 0.6, 0.9, 0.999, 0.9999};
    static const double Es[] = {1e-6, 1e-4, 1e-3, 0.01, 0.03, 0.1, 0.5, 1.0, 2.0, 3.0, 3.14159, -0.002, -1.5};
    double worst = 0, worst_rt = 0;
    for (size_t a = 0; a < sizeof es / sizeof es[0]; a++) {
        /* Near pericentre the energy v^2/2 - mu/r cancels to a factor 1/(1 - e): the orbit's
         * elements, hence the state after a given time, are known only to about eps/(1 - e). */
        double e = es[a], yp[5], y[5], ref[5], cond = DBL_EPSILON / (1 - e);
        pericentre(e, yp);
        size_t nE = sizeof Es / sizeof Es[0];
        for (size_t b = 0; b < nE + 400; b++) {
            /* the listed anomalies, then a sweep of the whole orbit */
            double Eb = b < nE ? Es[b] : -PI + 2 * PI * ((double)(b - nE) + 0.5) / 400;
            double tE = state_at_E(e, Eb, ref);
            CU_ASSERT_FATAL(t->exact(self, yp, tE, y) == 0);
            /* Relative to the local scale of position and momentum, widened by what a relative
             * error cond in the mean motion does: a time shift cond * t, moving q by t |p| cond and
             * p by t |dp/dt| cond (at apocentre of e = 0.9999, |p| is 2e4 times below t |dp/dt|). */
            double rq = hypot(ref[0], ref[1]), rp = hypot(ref[3], ref[4]);
            rq += fabs(tE) * rp;
            rp += fabs(tE) / (hypot(ref[0], ref[1]) * hypot(ref[0], ref[1]));
            double err = fmax(hypot(y[0] - ref[0], y[1] - ref[1]) / rq, hypot(y[3] - ref[3], y[4] - ref[4]) / rp);
            worst = fmax(worst, err / cond);
            CU_ASSERT(err <= 8 * cond);
            if (err > 8 * cond) printf("\n  e=%g E=%g: relative error %.3g\n", e, Eb, err);
        }
        /* Round trip from pericentre, out by dt and back. Mapping the state at radius r1 back
         * to pericentre magnifies its round-off by r1 / r_p on top of the 1/(1 - e) above. */
        for (double dt = 1e-5; dt < 2; dt *= 7) {
            double y1[5], y2[5];
            CU_ASSERT_FATAL(t->exact(self, yp, dt, y1) == 0);
            CU_ASSERT_FATAL(t->exact(self, y1, 0, y2) == 0);
            double eq = hypot(y2[0] - yp[0], y2[1] - yp[1]) / yp[0], ep = hypot(y2[3] - yp[3], y2[4] - yp[4]) / yp[4];
            double c = cond * hypot(y1[0], y1[1]) / yp[0];
            worst_rt = fmax(worst_rt, fmax(eq, ep) / c);
            CU_ASSERT(eq <= 8 * c && ep <= 8 * c);
            CU_ASSERT(y2[2] == 0);
        }
    }
    printf(" [worst error / (eps/(1-e)): %.2g, round trip %.2g] ", worst, worst_rt);
    dth_model_free(m);
}

/* 3-D: an inclined orbit agrees with the rotated planar solution. */
static void test_exact_3d(void)
{
    dth_model *m2 = new_kepler(2), *m3 = new_kepler(3);
    const dth_model_type *t = dth_model_get_type(m2);
    double e = 0.9, y[5], y2[5], y3[7], z3[7];
    state_at_E(e, 0.3, y);
    y[2] = 0;
    double ci = cos(0.8), si = sin(0.8);
    /* rotation about the x axis by 0.8 */
    double yr[7] = {y[0], ci * y[1], si * y[1], 0, y[3], ci * y[4], si * y[4]};
    for (double tt = 0.1; tt < 20; tt += 1.37) {
        CU_ASSERT_FATAL(t->exact(dth__model_self(m2), y, tt, y2) == 0);
        CU_ASSERT_FATAL(t->exact(dth__model_self(m3), yr, tt, y3) == 0);
        double want[7] = {y2[0], ci * y2[1], si * y2[1], tt, y2[3], ci * y2[4], si * y2[4]};
        for (int i = 0; i < 7; i++) CU_ASSERT(fabs(y3[i] - want[i]) <= 1e-13 * 20);
        (void)z3;
    }
    dth_model_free(m2);
    dth_model_free(m3);
}

/* ------------------------------------------------------------------ DTH */

typedef struct run_stats {
    long steps;
    int rc;
    double t_end;      /* time reached */
    double max_res;    /* max |wp + H_phys(zbar)| / (eps * terms) over midpoints */
    int wp_changed;    /* wp at some vertex differs in any bit from the first */
    double max_dL;     /* max |L(z_k) - L(z_0)| over vertices */
    double max_err;    /* max |q_k - q_exact(t_k)| over vertices */
    double prec_rate;  /* least-squares slope of omega(t) at vertices (precession per unit time) */
    double psi_stop;   /* psi at the vertex where a run stopped */
    double z_stop[6];
    int nonfinite;     /* a vertex had a NaN or Inf */
    int untouched;     /* the failed step left the vertex bit-identical */
} run_stats;

/* Raw DTH on the pericentre orbit of eccentricity e (midpoint start), to time t_end. */
static void run_dth(double e, double h, double t_end, run_stats *st)
{
    memset(st, 0, sizeof *st);
    dth_model *m = new_kepler(2);
    const dth_model_type *t = dth_model_get_type(m);
    const void *self = dth__model_self(m);
    dth_options o;
    dth_options_default(&o);
    o.h = h;
    dth_integrator *it;
    CU_ASSERT_FATAL(dth_integrator_new(m, &o, &it) == DTH_OK);
    double y0[5];
    pericentre(e, y0);
    double q0[2] = {y0[0], y0[1]}, p0[2] = {y0[3], y0[4]};
    CU_ASSERT_FATAL(dth_integrator_start(it, q0, p0, 0.0) == DTH_OK);
    const double *z = dth_integrator_vertex(it);
    double inv0[4], inv[4], ye[5], wp0 = z[5], w[64];
    t->invariants(self, z, inv0);
    /* least squares for omega(t) = c0 + c1 t, unwrapped */
    double sx = 0, sy = 0, sxx = 0, sxy = 0, cnt = 0, om_prev = inv0[3], om_acc = inv0[3];
    while (z[2] < t_end) {
        double zsave[6];
        memcpy(zsave, z, sizeof zsave);
        dth_step_info info;
        st->rc = dth_integrator_step(it, &info);
        if (st->rc) {
            st->untouched = memcmp(zsave, z, sizeof zsave) == 0;
            break;
        }
        st->steps++;
        const double *zb = dth_integrator_midpoint(it);
        double Hb;
        CU_ASSERT_FATAL(dth_model_eval(m, zb, DTH_EVAL_H, &Hb, NULL, NULL) == DTH_OK);
        double terms = fabs(zb[5]) + 0.5 * (zb[3] * zb[3] + zb[4] * zb[4]) + 1 / hypot(zb[0], zb[1]);
        st->max_res = fmax(st->max_res, fabs(zb[5] + Hb) / (DBL_EPSILON * terms));
        if (memcmp(&z[5], &wp0, sizeof wp0) != 0) st->wp_changed = 1;
        for (int i = 0; i < 6; i++)
            if (!isfinite(z[i])) st->nonfinite = 1;
        t->invariants(self, z, inv);
        st->max_dL = fmax(st->max_dL, fabs(inv[0] - inv0[0]));
        if (t->exact(self, y0, z[2], ye) == 0)
            st->max_err = fmax(st->max_err, hypot(ye[0] - z[0], ye[1] - z[1]));
        om_acc += remainder(inv[3] - om_prev, 2 * PI);
        om_prev = inv[3];
        sx += z[2];
        sy += om_acc;
        sxx += z[2] * z[2];
        sxy += z[2] * om_acc;
        cnt += 1;
    }
    st->t_end = z[2];
    st->prec_rate = cnt > 2 ? (cnt * sxy - sx * sy) / (cnt * sxx - sx * sx) : 0;
    memcpy(st->z_stop, z, sizeof st->z_stop);
    st->psi_stop = NAN;
    dth_model_psi(m, z, &st->psi_stop, NULL, w);
    dth_integrator_free(it);
    dth_model_free(m);
}

/* e = 0.6 over 100 time units at h = 0.01: psi > 0 all along, so raw DTH runs through. */
static void test_dth_e06(void)
{
    run_stats st;
    run_dth(0.6, 0.01, 100, &st);
    CU_ASSERT_EQUAL(st.rc, DTH_OK);
    CU_ASSERT(st.t_end >= 100);
    CU_ASSERT(st.max_res <= 4);       /* energy -wp at every midpoint to a few ulps of the terms */
    CU_ASSERT(st.wp_changed == 0);    /* wp carried bit for bit */
    /* L is a quadratic invariant the midpoint rule keeps exactly: what remains is round-off */
    CU_ASSERT(st.max_dL <= 16 * DBL_EPSILON);
    CU_ASSERT(st.max_err < 0.05);
    printf(" [%ld steps, res %.2f ulp, |dL| %.2g, err %.3g] ", st.steps, st.max_res, st.max_dL, st.max_err);
}

/* 3-D, an inclined e = 0.6 orbit: the L vector at round-off, wp bit for bit, midpoint energy,
 * and the vertices are those of the planar run rotated (DTH commutes with rotations). */
static void test_dth_3d(void)
{
    dth_model *m = new_kepler(3);
    const dth_model_type *t = dth_model_get_type(m);
    const void *self = dth__model_self(m);
    dth_options o;
    dth_options_default(&o);
    o.h = 0.01;
    dth_integrator *it;
    CU_ASSERT_FATAL(dth_integrator_new(m, &o, &it) == DTH_OK);
    double e = 0.6, v = sqrt((1 + e) / (1 - e)), ci = cos(0.7), si = sin(0.7);
    double q0[3] = {1 - e, 0, 0}, p0[3] = {0, ci * v, si * v};
    double y0[7] = {q0[0], q0[1], q0[2], 0, p0[0], p0[1], p0[2]};
    CU_ASSERT_FATAL(dth_integrator_start(it, q0, p0, 0.0) == DTH_OK);
    dth_model *m2 = new_kepler(2);
    dth_integrator *it2;
    CU_ASSERT_FATAL(dth_integrator_new(m2, &o, &it2) == DTH_OK);
    double q2[2] = {1 - e, 0}, p2[2] = {0, v};
    CU_ASSERT_FATAL(dth_integrator_start(it2, q2, p2, 0.0) == DTH_OK);
    const double *z = dth_integrator_vertex(it), *w = dth_integrator_vertex(it2);
    double inv0[7], inv[7], ye[7], wp0 = z[7], dL = 0, res = 0, err = 0, rot = 0;
    t->invariants(self, z, inv0);
    for (int k = 0; k < 2000; k++) {
        CU_ASSERT_FATAL(dth_integrator_step(it, NULL) == DTH_OK);
        CU_ASSERT_FATAL(dth_integrator_step(it2, NULL) == DTH_OK);
        double wr[8] = {w[0], ci * w[1], si * w[1], w[2], w[3], ci * w[4], si * w[4], w[5]};
        for (int i = 0; i < 8; i++) rot = fmax(rot, fabs(z[i] - wr[i]) / (1 + fabs(wr[i])));
        const double *zb = dth_integrator_midpoint(it);
        double Hb;
        CU_ASSERT_FATAL(dth_model_eval(m, zb, DTH_EVAL_H, &Hb, NULL, NULL) == DTH_OK);
        double terms = fabs(zb[7]) + 0.5 * (zb[4] * zb[4] + zb[5] * zb[5] + zb[6] * zb[6]) +
                       1 / sqrt(zb[0] * zb[0] + zb[1] * zb[1] + zb[2] * zb[2]);
        res = fmax(res, fabs(zb[7] + Hb) / (DBL_EPSILON * terms));
        CU_ASSERT(memcmp(&z[7], &wp0, sizeof wp0) == 0);
        t->invariants(self, z, inv);
        for (int i = 0; i < 3; i++) dL = fmax(dL, fabs(inv[i] - inv0[i]));
        CU_ASSERT_FATAL(t->exact(self, y0, z[3], ye) == 0);
        err = fmax(err, sqrt((z[0] - ye[0]) * (z[0] - ye[0]) + (z[1] - ye[1]) * (z[1] - ye[1]) +
                             (z[2] - ye[2]) * (z[2] - ye[2])));
    }
    printf(" [res %.2f ulp, |dL| %.2g, err %.3g at t = %.1f, vs rotated 2-D %.2g] ", res, dL, err, z[3], rot);
    CU_ASSERT(res <= 4);
    CU_ASSERT(dL <= 16 * DBL_EPSILON);
    CU_ASSERT(err < 0.025); /* O(h^2) phase error, growing with t: the 2-D run has 0.0239 at t = 100 */
    /* round-off differs between the runs: eps per step, times the phase's linear growth
     * (~ t = 80), times the 2000 steps gives ~4e-11; allow ten times that */
    CU_ASSERT(rot <= 4e-10);
    dth_integrator_free(it);
    dth_integrator_free(it2);
    dth_model_free(m);
    dth_model_free(m2);
}

/* Position error against the exact solution and the LRL precession rate are O(h^2). */
static void test_dth_order(void)
{
    static const double hs[] = {0.02, 0.01, 0.005, 0.0025};
    enum { NH = sizeof hs / sizeof hs[0] };
    double lh[NH], le[NH], lp[NH];
    for (int k = 0; k < NH; k++) {
        run_stats st;
        run_dth(0.6, hs[k], 100, &st);
        CU_ASSERT_EQUAL_FATAL(st.rc, DTH_OK);
        lh[k] = log(hs[k]);
        le[k] = log(st.max_err);
        lp[k] = log(fabs(st.prec_rate * 2 * PI)); /* per orbit (T = 2 pi) */
        printf("\n    h = %-7g max|q - q_exact| = %.4g  precession per orbit = %.4g", hs[k], st.max_err, st.prec_rate * 2 * PI);
    }
    /* least-squares slopes of log error against log h */
    double mx = 0, me = 0, mp = 0, sxx = 0, sxe = 0, sxp = 0;
    for (int k = 0; k < NH; k++) {
        mx += lh[k] / NH;
        me += le[k] / NH;
        mp += lp[k] / NH;
    }
    for (int k = 0; k < NH; k++) {
        sxx += (lh[k] - mx) * (lh[k] - mx);
        sxe += (lh[k] - mx) * (le[k] - me);
        sxp += (lh[k] - mx) * (lp[k] - mp);
    }
    double se = sxe / sxx, sp = sxp / sxx;
    printf("\n    slopes: position %.3f, precession %.3f\n  ", se, sp);
    CU_ASSERT(fabs(se - 2) <= 0.1);
    CU_ASSERT(fabs(sp - 2) <= 0.1);
}

/* e = 0.9 meets psi = 0 (e^2 > 5/8) at t = 0.0749, r = 0.223, just after pericentre. Raw DTH
 * must either run or stop with a positive status, the state untouched and finite. */
static void test_dth_e09(void)
{
    static const double hs[] = {0.01, 0.001};
    for (size_t k = 0; k < sizeof hs / sizeof hs[0]; k++) {
        run_stats st;
        run_dth(0.9, hs[k], 100, &st);
        CU_ASSERT(st.rc >= 0);
        CU_ASSERT(st.nonfinite == 0);
        CU_ASSERT(isfinite(st.psi_stop));
        if (st.rc) CU_ASSERT(st.untouched);
        printf("\n    h = %g: %s after %ld steps at t = %.5f, q = (%.5f, %.5f), psi = %.4g", hs[k],
               dth_status_name(st.rc), st.steps, st.t_end, st.z_stop[0], st.z_stop[1], st.psi_stop);
    }
    printf("\n  ");
}

#ifdef DTH_KEPLER_LONG
/* Brouwer: round-off in L random-walks, so max |Delta L| over N steps grows like sqrt(N) at most. */
static void test_brouwer(void)
{
    dth_model *m = new_kepler(2);
    const dth_model_type *t = dth_model_get_type(m);
    dth_options o;
    dth_options_default(&o);
    o.h = 0.01;
    dth_integrator *it;
    CU_ASSERT_FATAL(dth_integrator_new(m, &o, &it) == DTH_OK);
    double y0[5], inv0[4], inv[4];
    pericentre(0.6, y0);
    double q0[2] = {y0[0], y0[1]}, p0[2] = {y0[3], y0[4]};
    CU_ASSERT_FATAL(dth_integrator_start(it, q0, p0, 0.0) == DTH_OK);
    const double *z = dth_integrator_vertex(it);
    t->invariants(dth__model_self(m), z, inv0);
    double maxdL = 0, at[3];
    long N = 1000000, mark = 10000;
    int j = 0;
    for (long k = 1; k <= N; k++) {
        if (dth_integrator_step(it, NULL) != DTH_OK) {
            CU_FAIL("step failed");
            break;
        }
        t->invariants(dth__model_self(m), z, inv);
        maxdL = fmax(maxdL, fabs(inv[0] - inv0[0]));
        if (k == mark) {
            at[j++] = maxdL;
            mark *= 10;
        }
    }
    if (j == 3) {
        printf("\n    max|dL|/eps at N = 1e4: %.1f, 1e5: %.1f, 1e6: %.1f (t = %.0f)\n  ", at[0] / DBL_EPSILON,
               at[1] / DBL_EPSILON, at[2] / DBL_EPSILON, z[2]);
        /* a random walk of per-step round-off of a few eps: well under eps sqrt(N) per unit L */
        CU_ASSERT(at[2] <= 2 * DBL_EPSILON * sqrt(1e6));
        CU_ASSERT(at[2] <= 3 * sqrt(100.0) * fmax(at[0], DBL_EPSILON));
    }
    dth_integrator_free(it);
    dth_model_free(m);
}
#endif

static CU_TestInfo model_tests[] = {
    {"derivatives and psi at 2-D and 3-D points", test_derivatives},
    {"parameters: mu, dim, q count; messages name the key", test_params},
    {"L, A, omega against orbital elements (planar, inclined)", test_invariants_elements},
    CU_TEST_INFO_NULL,
};
static CU_TestInfo exact_tests[] = {
    {"exact conserves H, L, A; period and apocentre", test_exact_conservation},
    {"exact inverts Kepler's equation up to e = 0.9999", test_exact_kepler_equation},
    {"3-D exact equals the rotated planar orbit", test_exact_3d},
    CU_TEST_INFO_NULL,
};
static CU_TestInfo dth_tests[] = {
    {"e = 0.6: energy at midpoints, wp, L", test_dth_e06},
    {"e = 0.6: position error and precession O(h^2)", test_dth_order},
    {"e = 0.6, 3-D inclined: L vector, wp, energy", test_dth_3d},
    {"e = 0.9: raw DTH at the psi = 0 crossing", test_dth_e09},
    CU_TEST_INFO_NULL,
};
#ifdef DTH_KEPLER_LONG
static CU_TestInfo long_tests[] = {
    {"Brouwer: |dL| over 1e6 steps", test_brouwer},
    CU_TEST_INFO_NULL,
};
#endif

CU_SuiteInfo dth_test_suites[] = {
    {.pName = "kepler-model", .pTests = model_tests},
    {.pName = "kepler-exact", .pTests = exact_tests},
    {.pName = "kepler-dth", .pTests = dth_tests},
#ifdef DTH_KEPLER_LONG
    {.pName = "kepler-long", .pTests = long_tests},
#endif
    CU_SUITE_INFO_NULL,
};
