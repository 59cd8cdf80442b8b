/* SPDX-License-Identifier: MIT */
/* Helpers shared by the shipped regularizers (regularize/: none, prescribed, smooth; paper, section 7). */
#ifndef DTH_REG_COMMON_H
#define DTH_REG_COMMON_H

#include <stdio.h>
#include "dth/regularize.h"

/* A create() error: "parameter 'KEY' must be WHAT" into a->err (if given); DTH_EINVAL. */
static inline int dth__reg_param_err(const dth_reg_args *a, const char *key, const char *what)
{
    if (a->err && a->errlen) snprintf(a->err, a->errlen, "parameter '%s' must be %s", key, what);
    return DTH_EINVAL;
}

#endif
