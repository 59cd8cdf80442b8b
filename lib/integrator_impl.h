/* SPDX-License-Identifier: MIT */
/* The integrator's private state, shared by integrator.c and the branch/regularization code. */
#ifndef DTH_INTEGRATOR_IMPL_H
#define DTH_INTEGRATOR_IMPL_H

#include <stdarg.h>
#include "dth/integrator.h"
#include "dth_internal.h"

/**
 * The small path's Schur complement (linsolve small, autonomous separable H = T(p) + V(q) with
 * diagonal positive T'', n <= 3): the bordered step matrix [[B, c], [g^T, 0]] with
 * B = [[I, -(lambda/2) T''], [(lambda/2) V'', I]] is solved through K = I + (lambda^2/4) T'' V''
 * (n x n; bench_floor's analytic 2 x 2 for Kepler), as banded.c does for chains.
 */
typedef struct dth__small_schur {
    int on;            /* the last factorization is this one (else the LU in it->A / it->piv) */
    int piv[3];        /* pivots of K */
    double K[9];       /* LU factors of K (n x n, column-major), the reciprocals of its pivots */
    double kinv[3];
    double V[9];       /* V'' (n x n) at the factorization */
    double t[3];       /* the diagonal of T'' */
    double g[6];       /* the border row: grad H over (q, p) at the factorization */
    double y2[6];      /* B^-1 c over (q, p) */
    double sinv, hl;   /* 1 / the bordered Schur complement -g^T B^-1 c; lambda / 2 */
} dth__small_schur;

struct dth_integrator {
    const dth_model *model;
    const dth_allocator *alloc;
    dth_options opt;
    size_t n, N, d;   /* dof, extended dim 2n+2, physical dim 2n+1 */
    int auton;        /* autonomous model: t and wp rows in closed form */
    int m;            /* Newton unknowns: active components of d, then lambda */
    int *act;         /* z-index of each active unknown (m-1 of them) */
    dth_linsolve kind; /* the linear solver in use (never AUTO) */
    const struct dth__linsolver *ls; /* its entry in the linear-solver table (integrator.c) */
    int nsmall;       /* n (1..3) where the step takes the small path (autonomous, written out), else 0 */
    int small_schur;  /* the small path may use its Schur complement (separable model, not small-lu) */
    dth__small_schur ss;
    /* the model's eval callback and state, called directly in the Newton loop (which sees a
     * non-finite output in its correction instead of sweeping for it) */
    int (*meval)(const void *self, const double *y, unsigned what, double *H, double *grad, double *hess);
    int (*mhdiff)(const void *self, const double *y1, const double *y0, double *dH); /* NULL: dth__model_hdiff's rule */
    const void *mself;
    /* state: vertex in double-double, last step */
    double *z, *zlo;  /* vertex z_k = z + zlo */
    double *zbar;     /* midpoint of the last step */
    double *dprev;    /* offset zbar - z_{k-1} of the last step (predictor) */
    double *dprev2, *dprev3; /* the two offsets before it (quadratic predictor) */
    double *dnew;     /* scratch for the next offset (the four buffers rotate) */
    double *hwork;    /* 2(2n+1) doubles for dth__model_hdiff (models without their own hdiff) */
    double *zblo;     /* low part of the midpoint of the compensated solution (it->zb + it->zblo) */
    double lam;       /* last step (0 if none) */
    double lam2, lam3; /* the steps before it */
    int nhist;        /* consecutive ordinary steps in dprev.. (0..3) */
    double rho;       /* the vertex offset H(z_k), carried: H(z_(k+1)) - H(zbar) from the model's hdiff
                         (the compensated constraint, dth__newton) */
    double lam_hint;  /* step size to aim for when there is no history */
    double dir;       /* +1 forward, -1 backward */
    int have_prev, have_mid, pending_exact;
    long steps;
    /* workspace */
    double *znew, *znewlo, *zb, *grad, *hess, *u, *ybar, *A, *F, *x, *dx, *work, *B;
    double Hphys;     /* H_phys at it->zb after the last step evaluation */
    double bs[4];     /* block scales (q, t, p, wp) of the Newton solve in progress (step_judge) */
    double ibq, ibp;  /* 1 / bs[0], 1 / bs[2] */
    int *piv;
    int fact_valid;   /* the last step was an ordinary DTH step: a tangent map exists */
    dth__newton_track nt; /* progress of the current Newton solve (messages) */
    double *block;
    struct dth__band *band; /* banded step solve (banded.c), NULL for the dense path */
    struct dth_rootfinder *rf; /* branch selection (branch.c), NULL when opt.branch_check is off */
    /* regularization (regularize.c): the hook, and one flag of state: the sign of psi at the
     * current vertex (psi_known = 0 until computed; reset with the history). */
    dth_regularizer *reg;
    int psi_sign, psi_known;
    double *rbuf;     /* (4 + DTH_REG_MAX_SEG) N doubles of hook workspace */
    unsigned reg_what; /* within one step: what a hook asked before the ordinary step (KEEP [| FIXUP]) */
    char errmsg[192];
};

/** Outcome of a Newton solve. */
typedef struct dth__solution {
    double lambda;
    double residual;
    int iters;
} dth__solution;

/**
 * Newton on the bordered system from the current vertex, seeded with lambda0 and the offset
 * d0 (length 2n+2), finished by chord steps on the compensated constraint (opt.compensate). On
 * success it->x holds (d, lambda), it->zb the midpoint and it->zblo its low part; the factors of
 * the last iteration stay with the linear solver (it->A / it->piv, it->ss, or the band). Does not
 * change the vertex.
 */
int dth__newton(dth_integrator *it, double lam0, const double *d0, dth__solution *sol);

/* ---- branch selection (branch.c) ---- */
/** Allocate it->rf if opt.branch_check is on (dense models only). */
int dth__branch_create(dth_integrator *it);
/** Free it->rf. */
void dth__branch_free(dth_integrator *it);
/**
 * Decide the step's root after Newton returned `rc` / `sol` from the predictor: keep Newton's
 * root if the cheap test shows it physical, else search all roots and take the physical one ahead
 * (it->x / it->zb then hold its solution, *sol updated). Otherwise DTH_ENEGOFFSET, DTH_EGHOST,
 * DTH_EFOLD or DTH_ENOROOT (the vertex is untouched).
 */
int dth__branch_select(dth_integrator *it, int rc, dth__solution *sol, dth_branch *branch);

/* ---- regularization (regularize.c) ---- */
/** Commit the solution in it->x / it->zb as the next vertex (integrator.c). */
int dth__integrator_commit(dth_integrator *it, double lam);
/**
 * With a regularizer attached: take the ordinary step `rc` / `sol` (root `br`) if it succeeded
 * without changing the sign of psi, else call the hook and commit what it decides. pre != 0: the
 * hook was already asked (dth__reg_pre) and kept the ordinary step; commit it, or return its status.
 */
int dth__reg_step(dth_integrator *it, int rc, const dth__solution *sol, dth_branch br, dth_step_info *info, int pre);
/** After a step that is not an ordinary DTH step (a regularizer's): the carried vertex offset
 *  from a direct evaluation at the new vertex (no-op when opt.compensate is off). */
int dth__integrator_rho_reset(dth_integrator *it);
/** Nonzero if the attached regularizer replaces every step (its type's replaces_all). */
int dth__reg_replaces_all(const dth_integrator *it);
/** dth__reg_pre's answer: the hook kept the ordinary step, which is still to be computed. */
#define DTH__REG_PLAIN 1000
/**
 * For a regularizer that replaces every step: ask the hook before any ordinary step is computed
 * (ev.plain_pending = 1). Returns DTH_OK (its step is committed), a status, or DTH__REG_PLAIN.
 */
int dth__reg_pre(dth_integrator *it, dth_step_info *info);

#endif
