/* SPDX-License-Identifier: MIT */
/* Helpers shared by the shipped regularizers (vertex diagnostics, the flow direction). */
#ifndef DTH_REG_COMMON_H
#define DTH_REG_COMMON_H

#include "dth/integrator.h"
#include "dth/regularize.h"

/* H(z), psi, psi' at the vertex z (length 2n+2); work: dth_model_work_size doubles. */
static inline int dth__reg_vertex(const dth_model *m, const double *z, double *H, double *psi,
                                  double *dpsi, double *work)
{
    dth_diag dg;
    int rc = dth_diagnose(m, z, 0.0, 1.0, &dg, work);
    if (rc) return rc;
    *H = dg.H;
    *psi = dg.psi;
    *dpsi = dg.dpsi;
    return DTH_OK;
}

#endif
