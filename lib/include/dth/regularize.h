/* SPDX-License-Identifier: MIT */
/**
 * @file regularize.h  Regularizers: what the integrator does where psi = 0 (paper, section 7,
 * "DTH dynamics needs to be regularized").
 *
 * Where psi = (J grad H)^T H_zz (J grad H) changes sign along a trajectory, the physical root of
 * the step constraint merges with the ghost root and raw DTH either jumps to a much shorter step
 * or ends (H/psi < 0). A regularizer is a static table of callbacks (like dth_model_type) that the
 * integrator calls, and only calls, when the ordinary step from the vertex z_k
 *   - failed with a recoverable status (no root, no convergence, singular, branch statuses), or
 *   - succeeded but psi has a different sign at z_k and at z_(k+1) (the step crossed psi = 0).
 * The hook sees the vertex, the incoming step and the ordinary candidate, and answers with an
 * action: keep the ordinary step, or replace it by its own segment (a midpoint offset
 * d = zbar - z_k and a time step lambda; the integrator sets z_(k+1) = z_k + 2 d). Returning a
 * nonzero status (typically DTH_EREFUSED) ends the step with that status and leaves the
 * integrator's state untouched.
 *
 * A type whose instance replaces every step (replaces_all) is instead called at every step, before
 * any ordinary step is computed.
 *
 * Attach an instance through dth_options.regularizer. A user's regularizer is just another table;
 * dth_kicked_segment() is the building block the shipped ones use.
 */
#ifndef DTH_REGULARIZE_H
#define DTH_REGULARIZE_H

#include <stddef.h>
#include "dth/fields.h"
#include "dth/model.h"

#ifdef __cplusplus
extern "C" {
#endif

/** What a regularizer's `create` receives. */
typedef struct dth_reg_args {
    const dth_kv *kv;           /**< parameters (keys already checked against the spec) */
    size_t nkv;                 /**< number of parameters */
    const dth_model *model;     /**< the model it will serve (borrowed) */
    const dth_allocator *alloc; /**< allocate all state and workspace with this (may be NULL) */
    char *err;                  /**< one-line error naming the key */
    size_t errlen;              /**< size of err (may be 0) */
} dth_reg_args;

/** What the integrator tells the hook (all pointers borrowed for the duration of the call). */
typedef struct dth_reg_event {
    const dth_model *model; /**< the model */
    size_t N;               /**< extended dimension 2n+2 */
    const double *z;        /**< vertex z_k (high part) */
    const double *zlo;      /**< its low part: z_k = z + zlo exactly (compensated sums) */
    double lam_in;          /**< incoming step (signed), 0 if none */
    double dir;             /**< direction of travel, +1 or -1 */
    int psi_sign;           /**< sign of psi at z_k (-1, 0, +1) */
    int plain_status;       /**< status of the ordinary DTH step from z_k */
    const double *plain_d;  /**< its midpoint offset zbar - z_k (N), NULL unless plain_status == 0 */
    double plain_lambda;    /**< its lambda (0 unless plain_status == 0) */
    int plain_psi_sign;     /**< sign of psi at the vertex it reaches (0 unless plain_status == 0) */
    const double *in_d;     /**< the incoming step's midpoint offset zbar - z_(k-1) (N): its midpoint
                                 is z_k - in_d; NULL if there is no incoming step */
    int plain_pending;      /**< 1: the ordinary step has not been computed (the type's replaces_all
                                 said so; plain_status is then DTH_EUNSUPPORTED): answering KEEP
                                 computes it and takes it, or ends the step with its status */
    int finish;             /**< the integrator's finish (dth_finish, integrator.h; appended in the
                                 prescribed reversible finish): with DTH_FINISH_REVERSIBLE a replacing
                                 segment may hand back its offset in double-double (dth_reg_action.dlo),
                                 so that a segment and the one back from its end meet exactly */
    double lam_hint;        /**< the step the integrator aims for without history (signed): h (or
                                 dth_integrator_set_vertex's lambda) before the first step, the last
                                 ordinary step's after a replacement with `fresh`: the step a
                                 regularizer can scale to where in_d is NULL (appended after finish: a
                                 plugin compiled before them reads the others as before) */
} dth_reg_event;

/** What the integrator tells `observe` about an ordinary step it takes (borrowed for the call). */
typedef struct dth_reg_step {
    const dth_model *model; /**< the model */
    size_t N;               /**< extended dimension 2n+2 */
    const double *za;       /**< the step's start vertex z_k */
    const double *zbar;     /**< its midpoint */
    const double *zb;       /**< its end vertex z_(k+1) */
    double lambda;          /**< its time step */
    double dir;             /**< direction of travel */
    double psi_a, dpsi_a;   /**< psi and psi' at z_k, NaN where the integrator did not compute them */
} dth_reg_step;

/** dth_reg_action.what. */
enum {
    DTH_REG_KEEP = 0u,   /**< keep the ordinary step (its status is returned if it failed) */
    DTH_REG_REPLACE = 1u /**< replace it by the segment (d, lambda) */
};

/**
 * The hook's answer. The integrator owns `d` (N doubles), zeroed before the call. A replacement is
 * one segment from the vertex: midpoint offset d = zbar - z_k and time step lambda (the integrator
 * sets z_(k+1) = z_k + 2 d).
 */
typedef struct dth_reg_action {
    unsigned what;   /**< DTH_REG_KEEP or DTH_REG_REPLACE */
    double lambda;   /**< the replacing segment's time step (sign = direction of travel) */
    double *d;       /**< its midpoint offset zbar - z (N) */
    double residual; /**< |H(zbar)| at the replacing segment's midpoint */
    int iters;       /**< iterations spent (for the step record) */
    const char *why; /**< with a nonzero return: why, in a few words (static storage), or NULL;
                          dth_integrator_errmsg() then includes it */
    double *jump;    /**< REPLACE: the integrator owns it (N doubles, zeroed): a displacement of the segment's
                          end vertex, z_(k+1) = z_k + 2 d + jump, no time passing (a reset of its vertex
                          offset); a nonzero jump makes the step neither symplectic nor reversible
                          (DTH_STEP_RESET). wp must not move. */
    int fresh;       /**< REPLACE: 1 to start the next step without history: its predictor and the branch
                          test's step ratio from the last ordinary step, not from this segment */
    double dt;       /**< REPLACE: a correction of the new vertex's time (a clock correction: no other
                          coordinate moves), 0 for none */
    double *dlo;     /**< REPLACE, read only where ev->finish is DTH_FINISH_REVERSIBLE: the integrator owns it
                          (N doubles, zeroed): the low part of the offset, d + dlo in double-double (each
                          |dlo[j]| at most half an ulp of d[j]; autonomous models: the t entry is half the
                          low part of lambda, the wp entry 0), z_(k+1) = z_k + 2 (d + dlo) in double-double */
} dth_reg_action;

/** Layout version of dth_regularizer_type (model.h says how tables are versioned). 3: the
 *  instance's state as a field list (fields, n_fields, state_loaded) in place of the raw bytes of
 *  state_size / save_state / load_state; tables of layout 2 are refused (rebuild them). */
#define DTH_REG_TYPE_VERSION (DTH_ABI_MAGIC | 3u)

/** A regularizer type: a static table of callbacks. */
typedef struct dth_regularizer_type {
    unsigned abi;                 /**< DTH_REG_TYPE_VERSION (write DTH_REG_TYPE_HEAD first) */
    size_t size;                  /**< sizeof(dth_regularizer_type) where the table was compiled */
    const char *name;             /**< selects it in scene files ([regularize] method=) */
    const char *doc;              /**< one-line description (what it preserves, what it gives up) */
    const dth_param_spec *params; /**< accepted parameters */
    size_t n_params;              /**< length of params */
    /** Build an instance (allocate its workspace here; workspace needed only by rare events may be
     *  allocated once, at the first such event, with the allocator create was given, as `land`
     *  does its crossing workspace); may be NULL if it needs no state. */
    int (*create)(const dth_reg_args *args, void **self);
    /** Release an instance (self may be NULL). */
    void (*destroy)(void *self, const dth_allocator *alloc);
    /** Decide what to do at an event. Must not allocate, but for the one-time workspace above
     *  (DTH_ENOMEM if that fails). Return 0 or a status (ends the step). */
    int (*apply)(void *self, const dth_reg_event *ev, dth_reg_action *act);
    /**
     * Optional screen of an ordinary step za -> zb (time step lambda) that did not change the
     * sign of psi: return 1 to take it, 0 to treat it as an event (apply is then called), < 0 on
     * error. NULL takes every such step. For a reversible regularizer the answer must depend on
     * the unordered pair {za, zb} and |lambda| only.
     */
    int (*admit)(void *self, const double *za, const double *zb, double lambda);
    /**
     * Optional, for a regularizer whose instance carries state from step to step (a constant
     * fixed at the first step, a predictor's seed): the members of the instance struct (`self`)
     * that hold it, as a field list (dth/fields.h: kinds F64, F64_PTR, INT, LONG; a F64_PTR of
     * count 0 points to 2n + 2 doubles). The library saves them in checkpoints, little-endian
     * like every other number there, restores them with each value checked by its field's check,
     * and keeps them through a failed step, so that restarts continue bit for bit. NULL / 0: the
     * instance is stateless.
     */
    const dth_field *fields;
    size_t n_fields;             /**< length of fields */
    /**
     * Optional: called after the library wrote the fields into the instance (a checkpoint's
     * restore, a failed step's rollback). Check the rules between them (a constant marked fixed
     * is > 0) and drop caches of the state before: 0, or < 0 to refuse them (a restore is then
     * refused and the instance gets its fields back). NULL: any values the checks pass.
     */
    int (*state_loaded)(void *self);
    /**
     * Optional: nonzero if this instance replaces every step. The integrator then calls apply at
     * every step *before* computing the ordinary step (ev->plain_pending = 1), which saves that
     * step's cost; admit is not called. Asked at every step, so the answer may change (e.g. once a
     * constant is fixed). NULL: apply is called only at the events above. An ordinary step such an
     * instance keeps (DTH_REG_KEEP) is flagged DTH_STEP_ONEWAY: the step back from its end is asked of
     * the hook again, so it is not this step's reverse.
     */
    int (*replaces_all)(const void *self);
    /**
     * Optional: called for every ordinary step the integrator takes (after admit), before it is
     * committed; *dt (0 on entry) may correct the new vertex's time (a clock correction: q, p and wp
     * stay the step's bits; the step's extended map is then neither symplectic nor reversible).
     * Return 0 or a status (ends the step).
     */
    int (*observe)(void *self, const dth_reg_step *step, double *dt);
} dth_regularizer_type;

/** The first two members of every dth_regularizer_type: `{DTH_REG_TYPE_HEAD, .name = ...}`. */
#define DTH_REG_TYPE_HEAD DTH_REG_TYPE_VERSION, sizeof(dth_regularizer_type)

/**
 * Whether `t` is a table this library can read (model.h: dth_model_type_check), with a one-line
 * reason in err when not. @return DTH_OK, DTH_EINVAL.
 */
DTH_API int dth_regularizer_type_check(const dth_regularizer_type *t, char *err, size_t errlen);

/** An instance: a type plus its state. Opaque. Not shared between integrators running at once. */
typedef struct dth_regularizer dth_regularizer;

/**
 * Create an instance for `model`. Keys are checked against type->params.
 * @return DTH_OK, DTH_EINVAL (bad parameter; message in err), DTH_ENOMEM.
 */
DTH_API int dth_regularizer_new(const dth_regularizer_type *type, const dth_kv *kv, size_t nkv,
                                const dth_model *model, const dth_allocator *alloc,
                                dth_regularizer **out, char *err, size_t errlen);
/** Free; NULL is a no-op. */
DTH_API void dth_regularizer_free(dth_regularizer *r);
/** The instance's type. */
DTH_API const dth_regularizer_type *dth_regularizer_get_type(const dth_regularizer *r);
/** Call the hook (what the integrator does). */
DTH_API int dth_regularizer_apply(dth_regularizer *r, const dth_reg_event *ev, dth_reg_action *act);

/** Raw DTH: never changes anything (the run ends with the ordinary step's status). */
DTH_API extern const dth_regularizer_type dth_reg_none;
/** Every step a kicked segment with lambda = arc/|u(zbar)|^alpha: reversible, energy-exact (not symplectic). */
DTH_API extern const dth_regularizer_type dth_reg_prescribed;
/** Raw DTH wherever it runs; one replaced step per psi = 0 crossing that lands just past it and resets
 *  its end vertex's offset onto the run's step invariant (the default). */
DTH_API extern const dth_regularizer_type dth_reg_land;

/* ---- building blocks for writing regularizers ---- */

/** Doubles of workspace dth_kicked_segment needs for `model`. */
DTH_API size_t dth_kicked_segment_work_size(const dth_model *model);

/**
 * A kicked segment from the vertex z (+ zlo, may be NULL) with a given time step lambda: solve
 *     zbar = z + (1/2) (lambda J grad H(zbar) + mu n(zbar)),   H(zbar) = 0
 * for the midpoint offset d = zbar - z (N values) and the kick mu, where n is the (q, p) part of
 * grad H with the gradients of the model's invariants projected out (so quadratic invariants
 * are kept exactly, by the midpoint identity). t advances by exactly lambda; wp is untouched.
 * The map is symmetric under reversal: (z_b, -lambda, -mu) has the same midpoint.
 * On entry d and *mu hold a seed (zeros are fine). Autonomous models only.
 * @return DTH_OK, DTH_ENOCONV, DTH_ESINGULAR, DTH_EDOMAIN, DTH_EUNSUPPORTED (non-autonomous).
 */
DTH_API int dth_kicked_segment(const dth_model *model, const double *z, const double *zlo,
                               double lambda, double *d, double *mu, double *residual, int *iters,
                               double *work);

/**
 * Root of the cubic model of the step constraint at a vertex (paper, Lemma g_taylor),
 *     c(lambda) = H - psi lambda^2/8 - dpsi lambda^3/24,
 * nearest to 0 on the side `side` (+1 / -1). A function of (H, psi, dpsi) only.
 * @return the root (signed), or 0 if c has no root on that side.
 */
DTH_API double dth_cubic_root(double H, double psi, double dpsi, double side);

#ifdef __cplusplus
}
#endif
#endif
