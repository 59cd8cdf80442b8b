/* SPDX-License-Identifier: MIT */
/*
 * The stepper table (GSL's step type): how dth_integrator steps. The DTH step (dth_step.c) and the
 * fixed-step baselines (baselines.c) are types of one table (integrator.c), chosen by
 * dth_options.method; dth_integrator is a handle {type, state} that forwards each call. Adding a
 * stepper is one file with its type plus one entry in integrator.c's table.
 */
#ifndef DTH_STEPPER_H
#define DTH_STEPPER_H

#include "dth/integrator.h"
#include "estimate.h"
#include "fields.h"

/** A section of a stepper's state for the checkpoint codec: a field table over a struct. */
typedef struct dth__section {
    const char *name;         /* "state", "policy", ... */
    const dth__field *fields;
    size_t nfields;
    void *base;               /* the struct the fields' offsets are from */
    size_t veclen;            /* doubles of each VEC field */
} dth__section;

/** Most sections a stepper's state has. */
#define DTH__MAX_SECTIONS 4

typedef struct dth__stepper_type {
    const char *name;
    const char *doc;
    /** The type's rules beyond dth_options_check's common ones (e.g. a separable model), with a
     *  message; NULL: none. */
    int (*check)(const dth_model *model, const dth_options *o, char *err, size_t len);
    /** Build the state for the model with checked options; DTH_OK, DTH_ENOMEM. */
    int (*create)(const dth_model *model, const dth_options *o, void **state);
    void (*destroy)(void *state);
    int (*start)(void *state, const double *q0, const double *p0, double t0);
    int (*set_vertex)(void *state, const double *z, double lambda);
    /** One step; on failure the state is exactly as before. */
    int (*step)(void *state, dth_step_info *info);
    void (*reverse)(void *state);
    const double *(*vertex)(const void *state);   /* z (2n+2): q, t, p, wp */
    const double *(*midpoint)(const void *state); /* the last step's midpoint, NULL if none */
    double (*lambda)(const void *state);          /* the incoming step */
    double (*direction)(const void *state);       /* +1 or -1 */
    double (*energy)(const void *state);          /* -wp */
    long (*steps)(const void *state);
    int (*order)(const void *state);
    const char *(*errmsg)(const void *state);
    /** The last step's tangent map ((2n+2)^2); NULL: DTH_EUNSUPPORTED. */
    int (*tangent)(void *state, double *M);
    /** wp is a constant of the stepper (a baseline carries it unchanged; the dense output's wp
     *  flow is then 0, not -dH/dt). */
    int wp_fixed;
    /** The method has midpoints (dth_run's DTH_POINTS_MIDPOINTS). */
    int midpoints;
    /** The state as checkpoint sections (at most DTH__MAX_SECTIONS); NULL: no checkpoints. */
    size_t (*sections)(void *state, dth__section *out);
    /** The options a restored state must share with the saved one, as a section (NULL: none). */
    void (*options_section)(const void *state, dth__section *out, void *scratch);
    /** The regularizer whose own state goes into the checkpoint (NULL: none). */
    struct dth_regularizer *(*regularizer)(const void *state);
    /** After a restore: the derived state (caches) made consistent; may be NULL. */
    void (*restored)(void *state);
    /** A restored state's rules between fields (a field's own range is its check): DTH_OK, or
     *  DTH_EPARSE with a message naming the fields (the restore is then undone). NULL: none. */
    int (*consistent)(const void *state, char *err, size_t errlen);
    /** The dense output between vertices is the quintic Hermite interpolant of order 4 (run.c: from
     *  the flow f and f' = J H_zz f at both vertices); 0: the cubic/quartic of dth_dense_eval. */
    int dense5;
    /** The vertex before the current one (a resumed run's cut segment); NULL: none, or (NULL hook)
     *  the driver rebuilds it from the midpoint. */
    const double *(*prev_vertex)(const void *state);
} dth__stepper_type;

/** The handle. */
struct dth_integrator {
    const dth__stepper_type *type;
    void *state;
    const dth_model *model;
    const dth_allocator *alloc;
    size_t n, N;
    double h;          /* dth_options.h as given (the step the user asked for) */
    dth__estimate est; /* the error estimate (dth_options.estimate), est.on = 0 without */
};

extern const dth__stepper_type dth__stepper_dth;
/** The DTH stepper's `consistent` (restore_rules.c). */
int dth__dth_consistent(const void *state, char *err, size_t errlen);
/** The DTH method of order 4: a composition of level-shifted DTH steps (compose.c). */
extern const dth__stepper_type dth__stepper_compose;
/** The baselines (baselines.c): count and entry i. */
size_t dth__baseline_count(void);
const dth__stepper_type *dth__baseline_at(size_t i);

/** The type called `name` (NULL: "dth"), NULL if none. */
const dth__stepper_type *dth__stepper_find(const char *name);
/** The type that steps method `name` at `order` (method "dth" of order 4: the composition). */
const dth__stepper_type *dth__stepper_find_order(const char *name, int order);

#endif
