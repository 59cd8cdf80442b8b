/* SPDX-License-Identifier: MIT */
/* The example user model (double well), declared for the embedding program and the tests. */
#ifndef EXAMPLE_DOUBLE_WELL_H
#define EXAMPLE_DOUBLE_WELL_H
#include <dth/dth.h>
extern const dth_model_type example_double_well;
#endif
