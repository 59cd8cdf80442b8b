/* SPDX-License-Identifier: MIT */
/**
 * @file branch.h  Branch selection: every real root of the decoupled step constraint and its class
 * (paper, Theorem "Decoupling", Lemmas "g_taylor" and "Monotonicity", Theorems EU_1, EU_2, EU_3
 * and "ghost").
 *
 * For a vertex z_k the midpoint zbar(lambda, z_k) solves zbar = z_k + (lambda/2) J grad H(zbar)
 * (continued from zbar(0) = z_k), and the step constraint is g(lambda) = H(zbar(lambda, z_k)) = 0.
 * dth_find_roots() scans g on [-L, L], brackets and refines every sign change, looks at every local
 * extremum of g for a root pair hidden between grid points or a double root (a fold, where the
 * physical root meets the ghost), polishes each simple root with the bordered Newton of the step,
 * and classifies the vertex (region I/II/III) and each root:
 *   - s = -(psi'_k / psi_k) lambda (the paper's reparametrisation of Theorem EU_2);
 *   - the root nearest 0 on a side is physical (minus: lambda < 0, plus: lambda > 0) if s <= 6/5;
 *     every other root is a ghost (lambda*, Theorem "ghost": |s| > 6/5, it does not tend to 0
 *     as H_k/psi_k -> 0+);
 *   - where psi_k = 0 (region III, Theorem EU_3) the root nearest 0 on the side of sign(H_k/psi'_k)
 *     is the physical one.
 */
#ifndef DTH_BRANCH_H
#define DTH_BRANCH_H

#include <stddef.h>
#include "dth/model.h"
#include "dth/integrator.h"

#ifdef __cplusplus
extern "C" {
#endif

/** Most roots one search reports (more set dth_root_set.truncated). */
#define DTH_MAX_ROOTS 16

/** dth_root.flags */
enum {
    DTH_ROOT_DOUBLE = 1u,     /**< a double root (extremum of g at round-off level: a fold) */
    DTH_ROOT_ZERO = 2u,       /**< lambda = 0 with H_k = 0 to round-off (Theorem EU_1 (ii)) */
    DTH_ROOT_UNPOLISHED = 4u  /**< the bordered Newton did not confirm the root; lambda from g alone */
};

/** One real root of g. */
typedef struct dth_root {
    double lambda;    /**< the step */
    double s;         /**< -(psi'_k/psi_k) lambda; NaN where psi_k = 0 */
    dth_branch cls;   /**< DTH_BRANCH_MINUS, _PLUS or _GHOST (DTH_BRANCH_NONE for lambda = 0) */
    unsigned flags;   /**< DTH_ROOT_* */
    double residual;  /**< |H(zbar)| at the polished midpoint (|g| for unpolished roots) */
    double slope;     /**< g'(lambda) */
} dth_root;

/** Everything one search found. */
typedef struct dth_root_set {
    dth_diag vertex;   /**< H_k, psi_k, psi'_k, the K used, the region */
    int psi_zero;      /**< psi_k is zero to round-off (region III or an equilibrium) */
    int sign_H_psi;    /**< sign of H_k/psi_k (0 if H_k = 0 or psi_zero) */
    int sign_H_dpsi;   /**< sign of H_k/psi'_k (0 if H_k = 0 or psi'_k = 0) */
    double lo, hi;     /**< the range actually scanned (the decoupled solve may fail before -L, L; the
                            grid reaches at most 1024 times the vertex's root scale) */
    double tol;        /**< round-off level of g used for double roots */
    long evals;        /**< decoupled solves spent */
    size_t count;      /**< roots in root[], increasing lambda */
    int truncated;     /**< the list may be incomplete: more than DTH_MAX_ROOTS roots, or the scan
                            stopped short of [-L, L] (lo > -L or hi < L) */
    dth_root root[DTH_MAX_ROOTS];
} dth_root_set;

/** Options of a root search. Initialize with dth_root_options_default(). */
typedef struct dth_root_options {
    int n_uniform;  /**< uniform grid points per side (default 64) */
    int n_geom;     /**< geometric grid points per side, from L*1e-6 to L (default 40) */
    int max_iter;   /**< Newton iteration limit of one decoupled solve (default 30) */
    int polish;     /**< polish simple roots with the bordered Newton of the step (default 1) */
    double K;       /**< the paper's K; <= 0: the model's bound, else the local estimate */
} dth_root_options;

/** Fill `o` with the defaults. */
DTH_API void dth_root_options_default(dth_root_options *o);

/** A root finder for one model: workspace allocated once, searches allocate nothing. Opaque. */
typedef struct dth_rootfinder dth_rootfinder;

/** Create a root finder (`opt` may be NULL for defaults). @return DTH_OK, DTH_EINVAL, DTH_ENOMEM. */
DTH_API int dth_rootfinder_new(const dth_model *model, const dth_root_options *opt,
                               const dth_allocator *alloc, dth_rootfinder **out);
/** Free; NULL is a no-op. */
DTH_API void dth_rootfinder_free(dth_rootfinder *rf);

/**
 * Find and classify every real root of g in [-L, L] at the vertex z (length 2n+2). The grid's reach
 * is at most 1024 ell, ell the vertex's root scale (the largest real root of g's Taylor model
 * H_k - psi_k lambda^2/8 - psi'_k lambda^3/24, or 6 |psi_k/psi'_k|): a longer range is scanned that
 * far only, and the set says so (truncated, lo, hi). Beyond such a reach the coarse grid would follow
 * g across branches of zbar, miss the physical pair and misname a far root as physical.
 * The vertex K (region) is, in order: opt.K if > 0; the model's dth_model_info.K if > 0; else the
 * local estimate K = max |g(lambda) - (H_k - psi_k lambda^2/8 - psi'_k lambda^3/24)| / lambda^4
 * over the scanned grid points with |lambda| >= L/8 (Lemma g_taylor inverted on the range).
 * @return DTH_OK (out filled; count may be 0), DTH_EINVAL, DTH_EDOMAIN / DTH_EMODEL at the vertex.
 */
DTH_API int dth_find_roots(dth_rootfinder *rf, const double *z, double L, dth_root_set *out);

/**
 * The decoupled constraint at one lambda: zbar(lambda, z) by Newton on the first block, continued
 * from zbar(0) = z in `steps` equal substeps (>= 1; more substeps follow the branch more safely),
 * then g = H(zbar) and dg = g'(lambda). zbar (length 2n+2, may be NULL) receives the midpoint.
 * @return DTH_OK, DTH_ENOCONV (no decoupled solution on the way), DTH_EDOMAIN, DTH_EMODEL.
 */
DTH_API int dth_decoupled(dth_rootfinder *rf, const double *z, double lambda, int steps, double *g,
                          double *dg, double *zbar);

/** Class name of a root: "minus", "plus", "ghost", "double" (DTH_ROOT_DOUBLE) or "zero". */
DTH_API const char *dth_root_class_name(const dth_root *r);

#ifdef __cplusplus
}
#endif
#endif
