/* SPDX-License-Identifier: MIT */
/*
 * Ordinary DTH's step invariant near psi = 0 (paper, Lemma g_taylor's cubic model with a linear psi):
 * I(psi, rho, psi') = 512 rho^3/psi G(rho psi'^2/psi^3) is conserved by ordinary steps (where
 * lambda^6 psi^2, its far-field form, is not: it falls by 5-15 % next to a crossing), and its level
 * set I = C gives the vertex offset that continues a run's step sequence past a crossing. G and the
 * exit branch's universal offset come from the build-time tables (gen_step_invariant.c).
 */
#include <math.h>
#include "dth_internal.h"
#include "step_invariant_table.h"

double dth__inv_G(double r)
{
    if (!(r > 0)) return 1.0;
    double s = (log10(r) - DTH__INV_LOG_R0) / (DTH__INV_LOG_R1 - DTH__INV_LOG_R0) * (DTH__INV_NG - 1);
    if (s <= 0) return 1.0 - 0.22 * r;                       /* G = 1 - 0.22 r + ... far away */
    if (s >= DTH__INV_NG - 1) return DTH__INV_C_INF / cbrt(r); /* G -> c_inf r^(-1/3) at psi = 0 */
    int i = (int)s;
    return inv_G[i] + (s - i) * (inv_G[i + 1] - inv_G[i]);
}

double dth__inv_I(double psi, double rho, double dpsi)
{
    if (!(rho * psi > 0) && !(psi == 0 && rho != 0)) return NAN;
    if (psi == 0) return 512 * DTH__INV_C_INF * pow(fabs(rho), 8.0 / 3.0) / cbrt(dpsi * dpsi);
    return 512 * rho * rho * rho / psi * dth__inv_G(rho * dpsi * dpsi / (psi * psi * psi));
}

/* R(x) of the unit branch (x >= 0, linear between the table's points; the far field (x/512)^(1/3))
 * and dR/dx. */
static double R_unit(double x, double *dRdx)
{
    if (x >= inv_x[DTH__INV_NR - 1]) {
        double R = cbrt(x / 512);
        *dRdx = R / (3 * x);
        return R;
    }
    int lo = 0, hi = DTH__INV_NR - 1; /* inv_x[lo] <= x < inv_x[hi] */
    while (hi - lo > 1) {
        int mid = (lo + hi) / 2;
        if (inv_x[mid] <= x) lo = mid;
        else hi = mid;
    }
    *dRdx = (inv_R[hi] - inv_R[lo]) / (inv_x[hi] - inv_x[lo]);
    return inv_R[lo] + *dRdx * (x - inv_x[lo]);
}

int dth__inv_exit_offset(double C, double psi, double dpsi, double dir, double *R, double *dR)
{
    if (!(C > 0) || dpsi == 0 || !isfinite(psi) || !isfinite(dpsi)) return DTH_EINVAL;
    double ell = pow(C / (dpsi * dpsi), 0.125); /* the crossing's time scale C^(1/8) |psi'|^(-1/4) */
    double sg = dpsi * dir > 0 ? 1.0 : -1.0;     /* the sign of psi (and rho) on the exit side */
    double x = psi / (dpsi * dir) / ell, unit = fabs(dpsi) * ell * ell * ell, dRdx, r;
    if (x <= 0) { /* before the crossing: the branch continued linearly */
        dRdx = (inv_R[1] - inv_R[0]) / (inv_x[1] - inv_x[0]);
        r = inv_R[0] + dRdx * x;
    } else {
        r = R_unit(x, &dRdx);
    }
    *R = sg * unit * r;
    *dR = sg * unit * dRdx / (dpsi * dir * ell);
    return DTH_OK;
}

int dth__inv_level_offset(double C, double psi, double dpsi, double *R, double *dR)
{
    if (!(C > 0) || dpsi == 0 || psi == 0 || !isfinite(psi) || !isfinite(dpsi)) return DTH_EINVAL;
    double ell = pow(C / (dpsi * dpsi), 0.125), unit = fabs(dpsi) * ell * ell * ell;
    double x = fabs(psi) / (fabs(dpsi) * ell), sg = psi > 0 ? 1.0 : -1.0, dRdx, r = R_unit(x, &dRdx);
    *R = sg * unit * r;
    *dR = unit * dRdx / (fabs(dpsi) * ell);
    return DTH_OK;
}
