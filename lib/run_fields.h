/* SPDX-License-Identifier: MIT */
/*
 * The run driver's state (dth/run.h: dth_run_state) as one field list, read by the checkpoint's
 * "run" section (checkpoint.c). A mirror struct generated from the list must have the layout of
 * dth_run_state, member for member, padding included: a member added to dth_run_state (or to its
 * dth_step_info `in`) without an entry here moves an offset or the size and fails to compile.
 * X(name, kind, check, meaning), kinds and checks as fields.h says; STEP: the nested dth_step_info,
 * whose own members are DTH__STEP_INFO_FIELDS (saved as in.lambda, in.iters, ...).
 */
#ifndef DTH_RUN_FIELDS_H
#define DTH_RUN_FIELDS_H

#include <stddef.h>
#include "dth/run.h"
#include "fields.h"

#define DTH__RUN_FIELDS(X)                                                                          \
    X(started, INT, BOOL, "0: a fresh state (everything else 0)")                                   \
    X(pending, INT, BOOL, "the current vertex's VERTEX sample is still to come")                   \
    X(k, LONG, COUNT, "index of the current vertex (steps from the run's start)")                  \
    X(k0, LONG, COUNT, "vertex index `every` counts from (<= k)")                                   \
    X(samples, LONG, COUNT, "trajectory samples handed out")                                        \
    X(events, LONG, COUNT, "events handed out")                                                     \
    X(j, LONG, COUNT, "index of the next output time")                                              \
    X(t, F64, TIME, "time of the current vertex (the integrator's vertex's t, bit for bit)")       \
    X(t_first, F64, TIME, "the run's start time")                                                   \
    X(in, STEP, ANY, "the step that arrived at the current vertex (all 0 at k = 0)")               \
    X(crossings, LONG, COUNT, "steps flagged DTH_STEP_CROSSING (<= k)")                             \
    X(regularized, LONG, COUNT, "steps flagged DTH_STEP_REGULARIZED (<= k)")                        \
    X(max_ratio, F64, RATIO, "largest ratio of consecutive steps around a crossing")               \
    X(prev_crossing, INT, BOOL, "the step that arrived was a crossing (in.flags says so too)")      \
    X(stop, INT, STOP, "dth_run_stop: why the last call returned")                                  \
    X(t_stop, F64, TIME, "samples are handed out for times after this one (t_first .. t)")        \
    X(err_q, F64, ERR, "the estimated global error in q at the current vertex (NaN: none)")        \
    X(err_p, F64, ERR, "the estimated global error in p at the current vertex (NaN: none)")        \
    X(q_max, F64, MAG, "the largest |q| at the vertices so far (+inf: |q| overflowed)")            \
    X(p_max, F64, MAG, "the largest |p| at the vertices so far")                                    \
    X(lam_max, F64, NONNEG, "the largest |lambda| of the steps so far")                             \
    X(t_lam_max, F64, TIME, "the time of the vertex that step arrived at")                          \
    X(nonreversible, LONG, COUNT, "steps with a flag of DTH_STEP_NONREVERSIBLE (<= k)")             \
    X(e_err, F64, MAG, "a baseline's energy error at the current vertex (0 for DTH)")               \
    X(e_scale, F64, MAG, "the size of the energy's terms at the first vertex")

#define DTH__STEP_INFO_FIELDS(X)                                                                    \
    X(lambda, F64, STEP, "time step taken")                                                         \
    X(iters, INT, NONNEG, "Newton iterations")                                                      \
    X(residual, F64, RESID, "|H(zbar)| at the accepted midpoint (NaN: none)")                       \
    X(branch, INT, BRANCH, "which root was taken (a dth_branch)")                                   \
    X(flags, UINT, FLAGS, "DTH_STEP_* flags")                                                       \
    X(proj_iters, INT, NONNEG, "iterations of the energy projection (midpoint-proj)")             \
    X(lerr, F64, ERR, "the run driver's local error estimate of the step (NaN: none)")

/* The mirror structs: the lists' members with the lists' types, in the lists' order. */
#define DTH__CTYPE_STEP struct dth__step_info_mirror
struct dth__step_info_mirror {
    DTH__STEP_INFO_FIELDS(DTH__FIELD_MEMBER)
};
struct dth__run_state_mirror {
    DTH__RUN_FIELDS(DTH__FIELD_MEMBER)
};

#define DTH__SAME_MEMBER(type, mirror, name, kind)                                                  \
    _Static_assert(offsetof(type, name) == offsetof(struct mirror, name) &&                         \
                       sizeof(((type *)0)->name) == sizeof(((struct mirror *)0)->name),             \
                   #type "." #name ": update its field list in lib/run_fields.h");
#define DTH__SAME_RUN(name, kind, check, doc) DTH__SAME_MEMBER(dth_run_state, dth__run_state_mirror, name, kind)
#define DTH__SAME_STEP(name, kind, check, doc) DTH__SAME_MEMBER(dth_step_info, dth__step_info_mirror, name, kind)
DTH__RUN_FIELDS(DTH__SAME_RUN)
DTH__STEP_INFO_FIELDS(DTH__SAME_STEP)
_Static_assert(sizeof(dth_run_state) == sizeof(struct dth__run_state_mirror),
               "dth_run_state has a member lib/run_fields.h does not list");
_Static_assert(sizeof(dth_step_info) == sizeof(struct dth__step_info_mirror),
               "dth_step_info has a member lib/run_fields.h does not list");
#undef DTH__SAME_RUN
#undef DTH__SAME_STEP

/** The run state's field table (checkpoint.c), flattened: in.lambda, ... in place of `in`. */
const dth_field *dth__run_fields(size_t *n);

#endif
