/* SPDX-License-Identifier: MIT */
/* The error estimate's shadow trajectory (estimate.c), held by the integrator handle (stepper.h). */
#ifndef DTH_ESTIMATE_H
#define DTH_ESTIMATE_H

#include "dth_internal.h"
#include "fields.h"

/* Its state: X(name, kind, check, meaning) as fields.h says. */
#define DTH__ESTIMATE_FIELDS(X)                                                                     \
    X(x, VEC, ANY, "the shadow (q, t, p, 0) at the vertex's time")                                  \
    X(E0, F64, ANY, "the initial energy it is projected onto")                                      \
    X(valid, INT, BOOL, "the shadow could be advanced so far")

typedef struct dth__estimate {
    double *x;        /* the shadow at the current vertex's time (N values, the last unused) */
    double E0;        /* H_phys at the initial state */
    int valid;        /* 0 once the shadow left the model's domain (no estimate from then on) */
    int on, project;  /* estimating; projecting onto E0 (autonomous models) */
    int rk6;          /* the shadow is Butcher's method of order 6 (an integrator of order 4), else RK4 */
    size_t n, d, N;
    const dth_model *model;
    const dth_allocator *alloc;
    double *k, *y, *g, *xs; /* workspace: 4 slopes, a stage point, a gradient, the shadow at a sample */
} dth__estimate;

/** Allocate for the model (e->on = 1). @return DTH_OK, DTH_ENOMEM. */
int dth__estimate_init(dth__estimate *e, const dth_model *m, const dth_allocator *al);
void dth__estimate_free(dth__estimate *e);
/** Start from the initial state y0 = (q, t, p), carried to the first vertex's time. */
int dth__estimate_start(dth__estimate *e, const double *y0, double t_vertex);
/** Advance the shadow to the new vertex's time. */
void dth__estimate_step(dth__estimate *e, double t_new);
/** The estimate at the point z (q, t, p, wp) on the trajectory near the last vertex: |q - x_q| and
 *  |p - x_p| of the shadow at z's time (NaN where the shadow is invalid). @return DTH_OK,
 *  DTH_EUNSUPPORTED (not estimating). */
int dth__estimate_at(dth__estimate *e, const double *z, double *eq, double *ep);

#endif
