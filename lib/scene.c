/* SPDX-License-Identifier: MIT */
/* Scene files: STUB, to be written. */
#include "dth/scene.h"
