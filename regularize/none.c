/* SPDX-License-Identifier: MIT */
/* Regularizer "none": raw DTH across psi = 0 (paper, section 7): the run ends where raw DTH ends. */
#include "dth/regularize.h"

static int apply(void *self, const dth_reg_event *ev, dth_reg_action *act)
{
    (void)self;
    (void)ev;
    act->what = DTH_REG_KEEP; /* a crossing ordinary step is kept; a failed one returns its status */
    return DTH_OK;
}

const dth_regularizer_type dth_reg_none = {
DTH_REG_TYPE_HEAD,
    .name = "none",
    .doc = "raw DTH: no regularization; the run ends with the branch status where no physical root exists",
    .apply = apply,
};
