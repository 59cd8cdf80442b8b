/* SPDX-License-Identifier: MIT */
/*
 * Per-vertex diagnostics of the DTH step: psi, psi', the paper's constant K and the regions of
 * section 5; the names of regions and branches; the conditioning limits of the step (the floor
 * below which lambda is round-off, Lemma g_taylor; the ceiling where the physical root meets the
 * ghost, Theorem EU_2); linear interpolation on a segment.
 */
#include <float.h>
#include <math.h>
#include "dth_internal.h"
#include "dth/methods.h"

const char *dth_region_name(dth_region r)
{
    switch (r) {
    case DTH_REGION_I: return "I";
    case DTH_REGION_II: return "II";
    case DTH_REGION_III: return "III";
    default: return "-";
    }
}

const char *dth_branch_name(dth_branch b)
{
    switch (b) {
    case DTH_BRANCH_MINUS: return "minus";
    case DTH_BRANCH_PLUS: return "plus";
    case DTH_BRANCH_GHOST: return "ghost";
    case DTH_BRANCH_EXACT: return "exact";
    case DTH_BRANCH_REG: return "reg";
    default: return "-";
    }
}

dth_region dth_region_of(double psi, double dpsi, double K)
{
    if (psi == 0) return dpsi != 0 ? DTH_REGION_III : DTH_REGION_NONE;
    return dpsi * dpsi <= 24 * K * fabs(psi) ? DTH_REGION_I : DTH_REGION_II;
}

int dth_diagnose(const dth_model *model, const double *z, double lambda_root, double K,
                 dth_diag *dg, double *work)
{
    if (!model || !z || !dg || !work) return DTH_EINVAL;
    size_t n = dth_model_dof(model), N = 2 * n + 2;
    double Hphys;
    int rc = dth_model_eval(model, z, DTH_EVAL_H, &Hphys, NULL, NULL);
    if (!rc) rc = dth_model_psi(model, z, &dg->psi, &dg->dpsi, work);
    if (rc) return rc;
    dg->H = z[N - 1] + Hphys;
    if (!(K > 0)) K = dth_model_get_info(model)->K;
    if (!(K > 0) && lambda_root != 0 && isfinite(lambda_root)) {
        double l = lambda_root, l2 = l * l;
        K = fabs(dg->H - dg->psi * l2 / 8 - dg->dpsi * l2 * l / 24) / (l2 * l2);
    }
    dg->K = K > 0 ? K : 0;
    dg->region = dth_region_of(dg->psi, dg->dpsi, dg->K);
    return DTH_OK;
}

void dth_interpolate(size_t n, const double *za, const double *zb, double t, double *z)
{
    size_t N = 2 * n + 2;
    double ta = za[n], tb = zb[n];
    double s = tb != ta ? (t - ta) / (tb - ta) : 0.0;
    for (size_t j = 0; j < N; j++) z[j] = za[j] + s * (zb[j] - za[j]);
    z[n] = t;
}

int dth_step_floor(const dth_model *model, const double *z, double rel_tol, double *h_min, double *work)
{
    if (!model || !z || !h_min || !work || !(rel_tol > 0 && rel_tol <= 1)) return DTH_EINVAL;
    size_t n = dth_model_dof(model), d = 2 * n + 1;
    double Hp, psi;
    double *g = work; /* the first d doubles; dth_model_psi uses the whole of work afterwards */
    int rc = dth_model_eval(model, z, DTH_EVAL_H | DTH_EVAL_GRAD, &Hp, g, NULL);
    if (rc) return rc;
    double S = fabs(z[d]) + fabs(Hp);
    for (size_t j = 0; j < d; j++) S += fabs(g[j] * z[j]);
    rc = dth_model_psi(model, z, &psi, NULL, work);
    if (rc) return rc;
    if (psi == 0) {
        *h_min = INFINITY;
        return DTH_ESINGULAR;
    }
    *h_min = sqrt(4 * DBL_EPSILON * S / (fabs(psi) * rel_tol));
    return DTH_OK;
}

int dth_step_ceiling(const dth_model *model, const double *z, double *h_max, double *work)
{
    if (!model || !z || !h_max || !work) return DTH_EINVAL;
    double psi, dpsi;
    int rc = dth_model_psi(model, z, &psi, &dpsi, work);
    if (rc) return rc;
    if (psi == 0) {
        *h_max = 0;
        return DTH_ESINGULAR;
    }
    *h_max = dpsi != 0 ? 1.2 * fabs(psi / dpsi) : INFINITY;
    return DTH_OK;
}
