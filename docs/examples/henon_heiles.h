/* SPDX-License-Identifier: MIT */
/* The example user model (Henon-Heiles), declared for the Poincare-section program. */
#ifndef EXAMPLE_HENON_HEILES_H
#define EXAMPLE_HENON_HEILES_H
#include <dth/dth.h>
extern const dth_model_type example_henon_heiles;
#endif
