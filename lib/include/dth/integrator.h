/* SPDX-License-Identifier: MIT */
/**
 * @file integrator.h  The DTH step (paper, Theorem "DTH Equations") and its driver state.
 *
 * One step from the vertex z_k solves, for the midpoint zbar and the time step lambda,
 *     zbar - z_k - (lambda/2) J grad H(zbar) = 0,    H(zbar) = 0,
 * and sets z_{k+1} = 2 zbar - z_k. H(z) = wp + H_phys(q, t, p), so the energy -wp holds at
 * every midpoint and the time advances by exactly lambda. The unknowns (zbar - z_k, lambda) are
 * found by Newton's method on the bordered system
 *     [ I - (lambda/2) J H_zz(zbar)   -(1/2) J grad H(zbar) ]
 *     [ grad H(zbar)^T                 0                    ]
 * factored by the linear solver that dth_options.linsolve chooses (dth_linsolve). For autonomous
 * models the t and wp rows are solved in closed form (t advances by lambda, wp is carried bit for
 * bit), leaving a (2n+1)-square system.
 */
#ifndef DTH_INTEGRATOR_H
#define DTH_INTEGRATOR_H

#include <stddef.h>
#include "dth/model.h"
#include "dth/regularize.h"

#ifdef __cplusplus
extern "C" {
#endif

/** How the initial state (q0, p0, t0) is placed on the trajectory (order 2; with dth_options.order = 4
 *  both mean the vertex z_0 = (q0, t0, p0) with wp = -H_phys there or the explicit wp, and the first
 *  step is the start step of length h that makes the composition's levels). */
typedef enum dth_start {
    /** (q0, t0, p0) is the first midpoint, wp = -H_phys: the first step is exactly h. */
    DTH_START_MIDPOINT = 0,
    /** (q0, t0, p0) is the vertex z_0; wp is solved for so that the first step is h (a secant
     *  aiming at 8 ulps, accepted within 1e-10 |h|; refused with DTH_ENOROOT where no wp gives
     *  that step), unless given explicitly. */
    DTH_START_VERTEX = 1
} dth_start;

/**
 * Linear solver of the step's Newton system (and of its tangent map). All paths solve the same
 * equations and agree to round-off; they differ in cost.
 */
typedef enum dth_linsolve {
    DTH_LINSOLVE_AUTO = 0,   /**< banded for banded models, else small for m <= 8 unknowns, else dense */
    DTH_LINSOLVE_DENSE = 1,  /**< LAPACK dgetrf/dgetrs on the bordered system: the reference path */
    DTH_LINSOLVE_SMALL = 2,  /**< written out, no library call (no OpenBLAS lock): for autonomous separable
                                  models with n <= 3, where T'' is diagonal and positive at the
                                  midpoint, the Schur complement K = I + (lambda^2/4) T'' V'' (n x n,
                                  LU with partial pivoting) and its border in closed form; else (or
                                  where K or the bordered complement is singular) LU with partial
                                  pivoting of the bordered system */
    DTH_LINSOLVE_BANDED = 3, /**< banded models only: for separable H where T'' is diagonal and positive
                                  at the midpoint, the Schur complement K = T''^-1 + (lambda^2/4) V''
                                  by a banded Cholesky (written out as LDL^T for half-bandwidths of K
                                  up to 16, LAPACK dpbtrf above; LAPACK banded LU where K is not
                                  positive definite), else LAPACK banded LU of the step matrix */
    DTH_LINSOLVE_BANDED_LU = 4, /**< banded models only: banded LU of the whole (2n) step matrix, never the
                                     Schur complement (for comparison, or a model whose T'' is not diagonal) */
    DTH_LINSOLVE_SMALL_LU = 5  /**< the small path's LU with partial pivoting, never its Schur complement
                                    (for comparison) */
} dth_linsolve;

/** Name of a linear-solver choice ("auto", "dense", "small", "banded", "banded-lu", "small-lu"), NULL if
 *  unknown. */
DTH_API const char *dth_linsolve_name(dth_linsolve k);
/** The choice called `name` into *out. @return DTH_OK, DTH_ENOTFOUND. */
DTH_API int dth_linsolve_from_name(const char *name, dth_linsolve *out);

/**
 * How a DTH step is finished (its last chord steps and the vertex offset it carries). All three
 * solve the same equations; they differ in the round-off the step's lambda carries.
 */
typedef enum dth_finish {
    /** The constraint evaluated directly, wp + H_phys(zbar): its round-off eps S (S: the size of the
     *  terms of H at the midpoint) moves lambda by about 4 eps S / (|psi| lambda^2), which shows at
     *  tiny steps (docs/performance.md, "Conditioning"). */
    DTH_FINISH_PLAIN = 0,
    /** The default: the vertex offset H(z_k) (at its high part over q, t, p) carried from step to
     *  step in double-double plus H(zbar) - H(z_k) from the model's hdiff, whose round-off scales
     *  with the step rather than the energy's size; where it has drifted from the direct value by
     *  more than 4 eps S the step takes the direct value. */
    DTH_FINISH_COMPENSATED = 1,
    /** As COMPENSATED without that fallback, with double-double unknowns, exact residual rows and
     *  the model read at a coarsened midpoint with its Taylor terms, so that a step and the step
     *  back from its end find the same root to about 2^-100 (round trips exact over 10^4 steps in
     *  bench_roundtrip). Needs a dense Hessian (a banded linsolve refuses it); about 2.4 times the
     *  step's cost on the smallest models. */
    DTH_FINISH_REVERSIBLE = 2
} dth_finish;
/** Name of a finish ("plain", "compensated", "reversible"), NULL if unknown. */
DTH_API const char *dth_finish_name(dth_finish f);

/**
 * Options of an integrator. Initialize with dth_options_default(), which also sets `size`: the
 * library refuses options whose size is not the one it was built with (a program compiled against
 * another layout of this struct).
 */
typedef struct dth_options {
    size_t size;                /**< sizeof(dth_options), set by dth_options_default */
    const char *method;         /**< how to step: "dth" (NULL means "dth") or a fixed-step baseline of
                                     methods.h ("midpoint", "gauss4", "rk4", "verlet", "midpoint-proj") */
    int order;                  /**< order of the DTH method: 2 (the default) or 4 (a composition of
                                     level-shifted DTH steps, `table`); baselines have their own order and
                                     take the default. 6 and 8 are refused: the construction measures order
                                     4 with every 6th- and 8th-order table (docs/theory.md, "Order 4") */
    double h;                   /**< first step; its sign is the direction of travel (a baseline's step) */
    dth_start start;            /**< start mode (DTH only) */
    int has_wp;                 /**< vertex start: use `wp` exactly as the vertex's wp */
    double wp;                  /**< explicit wp (has_wp) */
    int max_iter;               /**< Newton iteration limit per step (default 30) */
    double K;                   /**< the paper's constant K for regions (>= 0); 0: local estimate */
    const dth_allocator *alloc; /**< allocation functions, NULL for malloc */
    int branch_check;           /**< classify each step's root and refuse non-physical ones (branch.h);
                                     default 1 (dense models; banded models skip the check) */
    dth_regularizer *regularizer; /**< called where the ordinary step fails or crosses psi = 0
                                       (regularize.h); borrowed; NULL: raw DTH. DTH only. */
    dth_linsolve linsolve;      /**< linear solver of the Newton system (default AUTO) */
    dth_finish finish;          /**< how each step is finished (default DTH_FINISH_COMPENSATED) */
    int estimate;               /**< 1: estimate the global error along the run (dth_integrator_error); a
                                     shadow trajectory (classical Runge-Kutta of order 4 with the run's own
                                     steps from the exact initial state, projected onto its energy for an
                                     autonomous model) costs about 4 gradients and one projection per step
                                     (16 to 36 % of a step on the smallest models). Default 0; scene files
                                     turn it on ([integrator] estimate = yes, their default) */
    const char *table;          /**< order 4: the composition's coefficient table, "suzuki4" (5 stages, the
                                     default: NULL) or "yoshida4" (3 stages); also "yoshida6a", "kahanli6",
                                     "kahanli8" (nominally of order 6, 6, 8: here order 4, see `order`) */
    double band_time;           /**< order 4 with a regularizer: a psi = 0 crossing is entered where it is
                                     less than band_time ahead in time (|psi / psi'| < band_time) as well as
                                     two steps ahead (the default rule, band_time = 0): a band fixed in phase
                                     space, which keeps order 4 through crossings at more band steps */
} dth_options;

/** Fill `o` with defaults: size, method "dth", order 2, h = 0.01, midpoint start, max_iter = 30,
 *  K = 0, branch_check = 1, linsolve = DTH_LINSOLVE_AUTO, finish = DTH_FINISH_COMPENSATED. */
DTH_API void dth_options_default(dth_options *o);

/**
 * Check `opt` for `model`: every rule dth_integrator_new applies (values in range, the method known
 * and able to integrate the model, the linear solver and the finish fit the model), each refusal
 * with a one-line message in err (may be NULL) naming the option and the fix. On success the
 * choices left to the library are resolved in place: linsolve AUTO becomes the solver a new
 * integrator would use, method NULL becomes "dth".
 * @return DTH_OK, DTH_EINVAL (a value out of range, a wrong size), DTH_ENOTFOUND (unknown method),
 *         DTH_EUNSUPPORTED (a valid option this model cannot take).
 */
DTH_API int dth_options_check(const dth_model *model, dth_options *opt, char *err, size_t errlen);

/** Which root a step took (filled by the branch logic; see branch.h). */
typedef enum dth_branch {
    DTH_BRANCH_NONE = 0,  /**< no step taken */
    DTH_BRANCH_MINUS = 1, /**< physical backward root */
    DTH_BRANCH_PLUS = 2,  /**< physical forward root */
    DTH_BRANCH_GHOST = 3, /**< ghost root (never taken silently) */
    DTH_BRANCH_EXACT = 4, /**< the exact first step of a midpoint start */
    DTH_BRANCH_REG = 5    /**< a regularizer's crossing step */
} dth_branch;

/** Record of one step. */
typedef struct dth_step_info {
    double lambda;   /**< time step taken */
    int iters;       /**< Newton iterations (factorizations) */
    double residual; /**< |H(zbar)| at the accepted midpoint */
    dth_branch branch; /**< which root was taken */
    unsigned flags;  /**< DTH_STEP_* flags */
    int proj_iters;  /**< baseline "midpoint-proj": iterations of its energy projection, else 0 */
    double lerr;     /**< the run driver's estimate of the step's local error in q (dth_run_config.local_error:
                          the defect of the step's cubic Hermite interpolant, (2/3) lambda |P'(1/2) - f(P(1/2))|),
                          else NaN */
} dth_step_info;

/** dth_step_info.flags */
enum {
    DTH_STEP_REGULARIZED = 1u, /**< a regularizer changed the vertex or replaced the step (order 4: a band step) */
    DTH_STEP_CROSSING = 2u,    /**< psi changed sign across this step */
    DTH_STEP_RESET = 4u,       /**< the regularizer moved the new vertex off its segment (an offset reset;
                                    order 4: a band exit, whose projection moved the vertex it starts from):
                                    the step is neither symplectic nor reversible */
    DTH_STEP_CLOCK = 8u,       /**< the regularizer corrected the new vertex's time (q, p, wp are the step's):
                                    the extended map is not symplectic in t, nor reversible */
    DTH_STEP_ONEWAY = 16u,     /**< a regularizer that replaces every step kept the ordinary step here
                                    (prescribed's fallback): the step back from its end is the regularizer's
                                    segment again, not this step's reverse, so the step is not reversible */
    /** Not a flag: the flags of a step that is not its own reverse (a round trip through it does not
     *  come back; dth_run_state.nonreversible counts such steps) */
    DTH_STEP_NONREVERSIBLE = DTH_STEP_RESET | DTH_STEP_CLOCK | DTH_STEP_ONEWAY
};

/** The integrator: a method (the DTH step or a fixed-step baseline, dth_options.method) with its
 *  state and preallocated workspace. Opaque. Accessors accept NULL (NULL, NaN or 0 back). */
typedef struct dth_integrator dth_integrator;

/**
 * Create an integrator for `model` (borrowed: it must outlive the integrator). All working
 * memory is allocated here; stepping allocates nothing. The options are checked as
 * dth_options_check does (call it first for the message).
 * @return DTH_OK, DTH_ENOMEM, or dth_options_check's status.
 */
DTH_API int dth_integrator_new(const dth_model *model, const dth_options *opt,
                               dth_integrator **out);
/** Free; NULL is a no-op. */
DTH_API void dth_integrator_free(dth_integrator *it);

/**
 * Place the initial state according to the start mode. q0, p0 have n values each.
 * @return DTH_OK, DTH_EINVAL (non-finite input, or a time t0 that steps of h cannot advance:
 *         t0 + h == t0), DTH_EDOMAIN / DTH_EMODEL from the model.
 */
DTH_API int dth_integrator_start(dth_integrator *it, const double *q0, const double *p0, double t0);

/**
 * Set the vertex z (length 2n+2: q, t, p, wp) exactly, with `lambda` as the incoming step
 * (its sign sets the direction; its size seeds the predictor). Clears the step history.
 */
DTH_API int dth_integrator_set_vertex(dth_integrator *it, const double *z, double lambda);

/**
 * Take one step from the current vertex. On success the vertex advances; on any failure the
 * state is exactly as before the call and `info` (may be NULL) says how far Newton got.
 * @return DTH_OK or a status (positive: recoverable).
 */
DTH_API int dth_integrator_step(dth_integrator *it, dth_step_info *info);

/** Reverse the direction of travel in place: the next step retraces the last one backward. */
DTH_API void dth_integrator_reverse(dth_integrator *it);

/** The current vertex z_k (length 2n+2). */
DTH_API const double *dth_integrator_vertex(const dth_integrator *it);
/** The midpoint of the last step (length 2n+2), or NULL before the first step; always NULL for order 4
 *  (its substeps' midpoints lie on their levels, not on H = 0). */
DTH_API const double *dth_integrator_midpoint(const dth_integrator *it);
/** The incoming (last) step lambda, 0 before the first step of a vertex start (a baseline: its h; order
 *  4: the composite step tau, the sum of its substeps). */
DTH_API double dth_integrator_lambda(const dth_integrator *it);
/** The direction of travel, +1 or -1 (NaN for NULL). */
DTH_API double dth_integrator_direction(const dth_integrator *it);
/** The method's name ("dth", or a baseline's: methods.h). */
DTH_API const char *dth_integrator_method(const dth_integrator *it);
/** The method's order. */
DTH_API int dth_integrator_order(const dth_integrator *it);
/**
 * The energy the trajectory conserves: -wp at the current vertex, which every midpoint carries
 * (H(zbar) = wp + H_phys = 0) for an autonomous model. With a midpoint start it is H_phys of the
 * initial state; with a vertex start it differs from H_phys(z_0) by about psi h^2/8 (the vertex lies
 * off the energy surface by the offset that encodes the step).
 */
DTH_API double dth_integrator_energy(const dth_integrator *it);
/** Steps taken since start / set_vertex. */
DTH_API long dth_integrator_steps(const dth_integrator *it);
/** Dimension of the extended state, 2n+2. */
DTH_API size_t dth_integrator_dim(const dth_integrator *it);
/** The model. */
DTH_API const dth_model *dth_integrator_model(const dth_integrator *it);
/** Detail of the last failure (a fixed string if none). */
DTH_API const char *dth_integrator_errmsg(const dth_integrator *it);

/**
 * The estimated global error at the current vertex (dth_options.estimate): |q - q_exact| and
 * |p - p_exact| (Euclidean over the q and p blocks), measured against a shadow trajectory (the
 * classical Runge-Kutta method of order 4 with the run's own steps from the exact initial state,
 * projected onto the initial energy for an autonomous model). Within a few per cent of the true
 * error on integrable orbits (docs/performance.md, "The error estimate"); NaN where the shadow left
 * the model's domain.
 * @return DTH_OK, DTH_EUNSUPPORTED (no estimate: dth_options.estimate = 0), DTH_EINVAL.
 */
DTH_API int dth_integrator_error(dth_integrator *it, double *eq, double *ep);
/** The same at a point z (2n+2 values) of the trajectory near the current vertex, at its time z[n]
 *  (a dense output point of the last step): the shadow carried there by one Runge-Kutta step. */
DTH_API int dth_integrator_error_at(dth_integrator *it, const double *z, double *eq, double *ep);

/**
 * Tangent map of the last step, M = d z_{k+1} / d z_k ((2n+2)^2, row-major), by implicit
 * differentiation of the bordered system, factored afresh at the converged midpoint (order 4: the
 * product of its substeps' maps; the midpoint rule's for its start and band steps).
 * @return DTH_OK; DTH_EINVAL before any step or after a regularizer's step or an order-4 band exit
 *         (no tangent map);
 *         the model's status.
 */
DTH_API int dth_integrator_tangent(dth_integrator *it, double *M);

/** Region of a vertex in the paper's sense (section 5). */
typedef enum dth_region {
    DTH_REGION_NONE = 0, /**< psi = 0 and dpsi = 0 (an equilibrium) */
    DTH_REGION_I = 1,    /**< psi != 0, dpsi^2 <= 24 K |psi| */
    DTH_REGION_II = 2,   /**< psi != 0, dpsi^2 > 24 K |psi| */
    DTH_REGION_III = 3   /**< psi = 0, dpsi != 0 */
} dth_region;

/** Per-vertex diagnostics. */
typedef struct dth_diag {
    double H;    /**< extended Hamiltonian at the vertex, H(z_k) */
    double psi;  /**< psi(z_k) */
    double dpsi; /**< psi'(z_k) = [psi, H] */
    double K;    /**< the K used for the region */
    dth_region region;
} dth_diag;

/**
 * Diagnose a vertex z (length 2n+2). K: if `K` > 0 it is used; else the model's bound if any;
 * else a local estimate from a known root `lambda_root` of the step constraint at z (for
 * example the incoming step negated, or the outgoing step):
 *     K ~ |H_k - psi lambda^2/8 - psi' lambda^3/24| / lambda^4   (Lemma g_taylor, inverted).
 * If none is available (lambda_root == 0), K = 0 (psi != 0 then reads as region II).
 * `work` must hold dth_model_work_size(model) doubles.
 */
DTH_API int dth_diagnose(const dth_model *model, const double *z, double lambda_root, double K,
                         dth_diag *d, double *work);

/** Region from psi, dpsi and K. */
DTH_API dth_region dth_region_of(double psi, double dpsi, double K);

/** Name of a region ("I", "II", "III", "-"). */
DTH_API const char *dth_region_name(dth_region r);
/** Name of a branch ("minus", "plus", "ghost", "exact", "reg", "-"). */
DTH_API const char *dth_branch_name(dth_branch b);

/**
 * Dense output on the piecewise-linear trajectory: the point of the segment za -> zb (length
 * dim) whose time coordinate (index n) is t. t outside the segment extrapolates linearly.
 * Kept for compatibility: its interpolation error h^2 |z''|/8 per segment can exceed the
 * method's own; dth_dense_eval (run.h) interpolates with the vertices' flows and the midpoint.
 */
DTH_API void dth_interpolate(size_t n, const double *za, const double *zb, double t, double *z);

#ifdef __cplusplus
}
#endif
#endif
