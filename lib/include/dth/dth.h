/* SPDX-License-Identifier: MIT */
/** @file dth.h  Umbrella header of the dth library: include this one. */
#ifndef DTH_DTH_H
#define DTH_DTH_H

#include "dth/version.h" /* DTH_VERSION_STRING, generated from meson.build's project version */
#include "dth/status.h"
#include "dth/model.h"
#include "dth/models.h"
#include "dth/integrator.h"
#include "dth/regularize.h"
#include "dth/branch.h"
#include "dth/scene.h"
#include "dth/fields.h"
#include "dth/checkpoint.h"
#include "dth/methods.h"
#include "dth/run.h"
#include "dth/chaos.h"
#include "dth/control.h"

#endif
