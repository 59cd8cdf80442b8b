/* SPDX-License-Identifier: MIT */
/**
 * @file model.h  The model interface: a Hamiltonian H_phys(q, t, p) as a static table of callbacks.
 *
 * The integrator works in extended phase space z = (q_1..q_n, t, p_1..p_n, wp) with
 * H(z) = wp + H_phys(q, t, p) (paper, section 2). Models only ever see the physical part
 * y = (q_1..q_n, t, p_1..p_n), a vector of length 2n+1; the extended coordinate wp enters H
 * linearly and is handled by the library.
 *
 * A model type is a `static const dth_model_type` table. An instance (`dth_model`) pairs the
 * table with the state its `create` callback builds from text parameters. Nothing in the library
 * names a model: a user's model is just another table (see docs/examples/).
 *
 * Callback return convention: 0 success, > 0 the point is outside the model's domain
 * (recoverable: the step fails with DTH_EDOMAIN), < 0 a hard error.
 */
#ifndef DTH_MODEL_H
#define DTH_MODEL_H

#include <stddef.h>
#include "dth/status.h"

#ifdef __cplusplus
extern "C" {
#endif

/** Allocation functions supplied by the caller; NULL anywhere means malloc/free. */
typedef struct dth_allocator {
    void *(*alloc)(void *ctx, size_t size); /**< like malloc; NULL on failure */
    void (*free)(void *ctx, void *ptr);     /**< like free; must accept NULL */
    void *ctx;                              /**< passed back to both */
} dth_allocator;

/** Allocate `n * size` zeroed bytes with `a` (NULL: calloc). NULL on failure or overflow. */
DTH_API void *dth_calloc(const dth_allocator *a, size_t n, size_t size);
/** Release memory from dth_calloc; NULL is a no-op. */
DTH_API void dth_free(const dth_allocator *a, void *ptr);

/** One textual parameter, as read from a scene file or given by a program. */
typedef struct dth_kv {
    const char *key;   /**< parameter name, e.g. "omega2" */
    const char *value; /**< its text, e.g. "1.5" or a comma-separated list */
} dth_kv;

/** Description of one parameter a model accepts. A key ending in '*' accepts any suffix. */
typedef struct dth_param_spec {
    const char *key; /**< name, or prefix followed by '*' */
    const char *def; /**< default as text, or NULL if required / derived */
    const char *doc; /**< one-line description */
} dth_param_spec;

/** What `create` receives. */
typedef struct dth_model_args {
    const dth_kv *kv;           /**< parameters (keys already checked against the spec) */
    size_t nkv;                 /**< number of parameters */
    size_t n_hint;              /**< number of q values the caller has, 0 if unknown */
    const dth_allocator *alloc; /**< allocate the model state with this (may be NULL) */
    char *err;                  /**< buffer for a one-line error naming the key */
    size_t errlen;              /**< size of err (may be 0) */
} dth_model_args;

/** Storage of the Hessian a model provides. */
typedef enum dth_hess_kind {
    DTH_HESS_DENSE = 0, /**< full (2n+1)^2 row-major Hessian over y */
    DTH_HESS_BANDED = 1 /**< additionally a banded form, see dth_model_type.hess_band */
} dth_hess_kind;

/** Facts about an instance, filled by `create`. */
typedef struct dth_model_info {
    size_t n;                /**< degrees of freedom (>= 1) */
    int autonomous;          /**< 1 if H_phys does not depend on t (then wp is constant) */
    int separable;           /**< 1 if H_phys = T(p) + V(q, t) */
    dth_hess_kind hess_kind; /**< Hessian structure */
    size_t bandwidth;        /**< half-bandwidth in the banded layout (DTH_HESS_BANDED) */
    double K;                /**< a bound for the paper's constant K (Lemma g_taylor), 0 if none */
} dth_model_info;

/** Flags for dth_model_type.eval: which outputs to compute. */
enum {
    DTH_EVAL_H = 1u,    /**< H_phys(y) */
    DTH_EVAL_GRAD = 2u, /**< gradient over y, length 2n+1 */
    DTH_EVAL_HESS = 4u  /**< Hessian over y, (2n+1)^2 row-major */
};

/**
 * Tables that a program or a plugin fills and the library reads (dth_model_type,
 * dth_regularizer_type) start with the layout they were compiled against: `abi` (the magic
 * DTH_ABI_MAGIC with the layout's version in the low byte) and `size` (sizeof the table as the
 * plugin saw it). Start every such table with its _HEAD macro:
 *     static const dth_model_type my_model = {DTH_MODEL_TYPE_HEAD, .name = "my", ...};
 * The library refuses a table without the magic (one built before the tables were versioned, whose
 * first member was `name`) or of a newer layout than it reads, and never reads past `size`: a
 * member added to a later layout reads as NULL for a table of an earlier one.
 */
#define DTH_ABI_MAGIC 0x44544800u
/** Layout version of dth_model_type (1: the unversioned layout, refused). */
#define DTH_MODEL_TYPE_VERSION (DTH_ABI_MAGIC | 2u)

/** A model type: a static table of callbacks. Optional entries may be NULL. */
typedef struct dth_model_type {
    unsigned abi;                  /**< DTH_MODEL_TYPE_VERSION (write DTH_MODEL_TYPE_HEAD first) */
    size_t size;                   /**< sizeof(dth_model_type) where the table was compiled */
    const char *name;              /**< selects the model in scene files */
    const char *doc;               /**< one-line description */
    const dth_param_spec *params;  /**< accepted parameters */
    size_t n_params;               /**< length of params */

    /** Build an instance from parameters; write a message to args->err on failure. */
    int (*create)(const dth_model_args *args, void **self, dth_model_info *info);
    /** Release an instance (self may be NULL). */
    void (*destroy)(void *self, const dth_allocator *alloc);
    /**
     * Evaluate what `what` asks for at y = (q, t, p). Outputs not asked for may be NULL and
     * must not be touched. Return 0, > 0 outside the domain, < 0 on error.
     */
    int (*eval)(const void *self, const double *y, unsigned what, double *H, double *grad,
                double *hess);

    /* ---- optional ---- */
    /** Third derivative of H_phys in direction u, three times: sum H_ijk u_i u_j u_k. */
    int (*third)(const void *self, const double *y, const double *u, double *d3);
    /** Number of invariants reported for diagnostics. */
    size_t (*n_invariants)(const void *self);
    /** Name of invariant i, e.g. "L" (used as a CSV column). */
    const char *(*invariant_name)(const void *self, size_t i);
    /**
     * Evaluate the invariants at y into out[0 .. n_invariants-1] (nonzero: y is outside the
     * domain). Those that are at most quadratic in (q, p) are kept exactly by the regularizers'
     * kicked segments (regularize.h); dth_model_new finds them once, by third differences at six
     * points with (q, p) in [0.25, 1.25] and [-1, 1] (at least two must evaluate).
     */
    int (*invariants)(const void *self, const double *y, double *out);
    /** Exact solution: from y0 (whose t is y0[n]) to time t; writes y (length 2n+1). */
    int (*exact)(const void *self, const double *y0, double t, double *y);
    /**
     * Banded Hessian (DTH_HESS_BANDED models, autonomous only): the Hessian of H_phys over
     * the interleaved ordering x = (q_1, p_1, q_2, p_2, ..., q_n, p_n), stored by diagonals:
     * band[i * (2w+1) + (j - i + w)] = d2H/dx_i dx_j for |i - j| <= w, w = info.bandwidth.
     */
    int (*hess_band)(const void *self, const double *y, double *band);
    /**
     * H_phys(y1) - H_phys(y0), computed without the cancellation of two evaluations (for example
     * p1^2 - p0^2 as (p1 - p0)(p1 + p0)), so that its error scales with |y1 - y0|, and exactly
     * antisymmetric: swapping y1 and y0 negates the result bit for bit. The step's constraint is
     * evaluated with it (compensated: the step size then carries no round-off of the energy's
     * size). Without it the library integrates the gradient along the segment by a 4-point
     * Gauss-Legendre rule.
     */
    int (*hdiff)(const void *self, const double *y1, const double *y0, double *dH);
    /**
     * Why y = (q, t, p) lies outside the model's domain, in a few words that name the
     * coordinates or particles (e.g. "r = 0 (q1 = q2 = 0)", "particles 1 and 2 coincide"),
     * written into why (len bytes, NUL-terminated); return nonzero then, 0 if y is inside. For
     * messages about a starting state (dth_model_domain_check).
     */
    int (*domain)(const void *self, const double *y, char *why, size_t len);
} dth_model_type;

/** The first two members of every dth_model_type: `{DTH_MODEL_TYPE_HEAD, .name = ...}`. */
#define DTH_MODEL_TYPE_HEAD DTH_MODEL_TYPE_VERSION, sizeof(dth_model_type)

/**
 * Whether `t` is a table this library can read: the magic and a layout version it knows in `abi`,
 * a plausible `size`, a name, and the required callbacks (create, eval). Writes a one-line reason
 * naming the table into err (may be NULL) when not. dth_model_new and dth_registry_add_model
 * check every table this way; a loader of plugins (dlsym) calls it for its message.
 * @return DTH_OK, DTH_EINVAL.
 */
DTH_API int dth_model_type_check(const dth_model_type *t, char *err, size_t errlen);

/** An instance: a type plus its state. Opaque. */
typedef struct dth_model dth_model;

/**
 * Create an instance. Keys are checked against type->params (unknown keys are an error naming
 * the key). `err` (may be NULL) receives a one-line message on failure.
 * @return DTH_OK, DTH_EINVAL (bad parameter), DTH_ENOMEM.
 */
DTH_API int dth_model_new(const dth_model_type *type, const dth_kv *kv, size_t nkv, size_t n_hint,
                          const dth_allocator *alloc, dth_model **out, char *err, size_t errlen);
/** Free an instance; NULL is a no-op. */
DTH_API void dth_model_free(dth_model *m);
/** The instance's facts (never NULL for a valid model). */
DTH_API const dth_model_info *dth_model_get_info(const dth_model *m);
/** The instance's type table. */
DTH_API const dth_model_type *dth_model_get_type(const dth_model *m);
/** Degrees of freedom n. */
DTH_API size_t dth_model_dof(const dth_model *m);

/**
 * Whether H_phys and its gradient evaluate to finite values at y = (q, t, p); if not, a one-line
 * reason in why (may be NULL) naming the coordinates or particles: the model's own (its type's
 * `domain`), else the first non-finite output ("dH/dq2 is not finite").
 * @return DTH_OK, DTH_EDOMAIN, DTH_EMODEL.
 */
DTH_API int dth_model_domain_check(const dth_model *m, const double *y, char *why, size_t len);

/**
 * Evaluate the model at y and check the outputs for NaN/Inf.
 * @return DTH_OK, DTH_EDOMAIN (outside domain or non-finite output), DTH_EMODEL.
 */
DTH_API int dth_model_eval(const dth_model *m, const double *y, unsigned what, double *H,
                           double *grad, double *hess);

/** Number of invariants the model reports (0 if it reports none). */
DTH_API size_t dth_model_n_invariants(const dth_model *m);
/** Name of invariant i (a CSV column name), or NULL if out of range. */
DTH_API const char *dth_model_invariant_name(const dth_model *m, size_t i);
/**
 * Evaluate the invariants at y into out[0 .. dth_model_n_invariants-1].
 * @return DTH_OK, DTH_EUNSUPPORTED (none), DTH_EDOMAIN, DTH_EMODEL.
 */
DTH_API int dth_model_invariants(const dth_model *m, const double *y, double *out);
/**
 * Exact solution from y0 (time y0[n]) to time t, if the model has one.
 * @return DTH_OK, DTH_EUNSUPPORTED (no exact solution), DTH_EDOMAIN (outside its scope).
 */
DTH_API int dth_model_exact(const dth_model *m, const double *y0, double t, double *y);

/** Doubles of workspace that dth_model_psi needs. */
DTH_API size_t dth_model_work_size(const dth_model *m);

/**
 * psi = (J grad H)^T H_zz (J grad H) and dpsi = [psi, H] at y (paper, Lemma g_lambda and
 * g_taylor). dpsi uses the model's `third` callback when present, otherwise a central difference
 * of the Hessian quadratic form along u = J grad H with u held fixed. Either output may be NULL.
 * `work` must hold dth_model_work_size(m) doubles.
 */
DTH_API int dth_model_psi(const dth_model *m, const double *y, double *psi, double *dpsi,
                          double *work);

/** Default threshold of dth_model_check's verdict: differencing noise is about 1e-7 or below. */
#define DTH_MODEL_CHECK_TOL 1e-5

/** Result of dth_model_check. */
typedef struct dth_model_check_report {
    double grad_err;  /**< largest relative mismatch of the gradient with central differences */
    size_t grad_idx;  /**< where it occurs */
    double hess_err;  /**< largest mismatch of the Hessian with differences of the gradient, each entry
                           relative to its own scale: max(sqrt(|H_ii H_jj|), |H_ij|, 1e-3 x the largest
                           entry of its (q, t, p) block) */
    size_t hess_i, hess_j;
    double sym_err;   /**< largest |H_ij - H_ji| relative to the Hessian's scale */
    double third_err; /**< relative mismatch of `third` with differences (0 if not provided) */
    double band_err;  /**< largest mismatch of hess_band with the dense Hessian (0 if none) */
    double tol;       /**< the threshold of the verdict (DTH_MODEL_CHECK_TOL) */
    int pass;         /**< the verdict: 1 if every mismatch above is <= tol */
    char message[200]; /**< "pass: ..." or "FAIL: worst Hessian d2H/dq1 dq1 mismatches finite
                            differences by 2 (relative; threshold 1.0e-05)" */
} dth_model_check_report;

/**
 * Compare a model's derivatives with finite differences at y, so a user can validate a model
 * before trusting runs, and give a verdict: `pass` and a one-line `message` naming the worst
 * entry and the threshold. The differences are taken at two step sizes per coordinate and
 * Richardson-extrapolated, the step shrinking while the two disagree, so that the check scales with
 * the model's own magnitudes (an exact Hessian passes also where it is large and varies fast, e.g.
 * a Kepler pericentre at e = 0.9999); each entry is judged against its own scale (so a wrong entry
 * of a small block is not hidden by a large one). Mismatches around 1e-7 or below are differencing
 * noise; anything above the threshold DTH_MODEL_CHECK_TOL = 1e-5 is a bug in the model. Memory:
 * 3 (2n+1)^2 doubles.
 * @return DTH_OK (the report is filled, whatever the verdict), or the status of a failing
 * evaluation.
 */
DTH_API int dth_model_check(const dth_model *m, const double *y, dth_model_check_report *rep);

/* ---- helpers for writing models (parameter parsing with messages naming the key) ---- */

/** Value text for key, or NULL if absent. */
DTH_API const char *dth_args_get(const dth_model_args *a, const char *key);
/** Read a finite double (default `def` if absent). DTH_EINVAL with a message naming the key. */
DTH_API int dth_args_double(const dth_model_args *a, const char *key, double def, double *out);
/**
 * Read a comma-separated list of finite doubles into out[0..max-1]; *count gets the number
 * read (0 if absent). More than max values is an error naming the key.
 */
DTH_API int dth_args_list(const dth_model_args *a, const char *key, double *out, size_t max,
                          size_t *count);
/** Write a formatted one-line error into a->err (printf-style) and return DTH_EINVAL. */
DTH_API int dth_args_error(const dth_model_args *a, const char *fmt, ...)
    __attribute__((format(printf, 2, 3)));

/** Parse a finite double from the whole of `s` (no trailing garbage). 0 on success. */
DTH_API int dth_parse_double(const char *s, double *out);

#ifdef __cplusplus
}
#endif
#endif
