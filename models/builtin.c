/* SPDX-License-Identifier: MIT */
/* The list of built-in models: the only place that names them all. */
#include "dth/models.h"
#include "dth/regularize.h"

int dth_registry_add_builtin(dth_registry *r)
{
    static const dth_model_type *const builtin[] = {
        &dth_model_pendulum,
        &dth_model_harmonic,
        &dth_model_kepler,
        &dth_model_coupled,
    };
    for (size_t i = 0; i < sizeof builtin / sizeof builtin[0]; i++) {
        int rc = dth_registry_add_model(r, builtin[i]);
        if (rc) return rc;
    }
    static const dth_regularizer_type *const regs[] = {&dth_reg_land, &dth_reg_none, &dth_reg_prescribed};
    for (size_t i = 0; i < sizeof regs / sizeof regs[0]; i++) {
        int rc = dth_registry_add_regularizer(r, regs[i]);
        if (rc) return rc;
    }
    return DTH_OK;
}
