/* SPDX-License-Identifier: MIT */
/* Helpers shared by the shipped regularizers (regularize/: none, prescribed, smooth; paper, section 7). */
#ifndef DTH_REG_COMMON_H
#define DTH_REG_COMMON_H

#include "dth/regularize.h"

#endif
