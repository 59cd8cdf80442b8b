/* SPDX-License-Identifier: MIT */
/* The integrator's private state, shared by integrator.c and the branch/regularization code. */
#ifndef DTH_INTEGRATOR_IMPL_H
#define DTH_INTEGRATOR_IMPL_H

#include <stdarg.h>
#include "dth/integrator.h"
#include "dth_internal.h"

/*
 * The step state: everything that carries from one step to the next, nothing else (no workspace,
 * no options). This one list declares the fields of dth__state and generates the checkpoint's
 * field table (checkpoint.c), so a field cannot be left out of a checkpoint; the regularizer's
 * own state is saved through its type. X(name, kind, check, meaning):
 *   kind  VEC: N = 2n+2 doubles behind a pointer; F64: double; INT: int; LONG: long
 *   check what a restored value must satisfy (checkpoint.c): FINITE, NONZERO (finite, != 0),
 *         UNIT (+1 or -1), BOOL (0 or 1), SIGN (-1, 0, 1), NHIST (0..3), COUNT (>= 0),
 *         PSISTEP (>= -2)
 */
#define DTH__STATE_FIELDS(X)                                                                        \
    X(z, VEC, FINITE, "vertex z_k, high part")                                                      \
    X(zlo, VEC, FINITE, "vertex, low part: z_k = z + zlo exactly (double-double)")                  \
    X(zbar, VEC, FINITE, "midpoint of the last step")                                               \
    X(dprev, VEC, FINITE, "offset zbar - z_(k-1) of the last step (predictor)")                     \
    X(dprev2, VEC, FINITE, "the offset of the step before it (quadratic predictor)")               \
    X(dprev3, VEC, FINITE, "the offset of the step before that")                                    \
    X(lam, F64, FINITE, "the last step's lambda (0 if none)")                                       \
    X(lam2, F64, FINITE, "lambda of the step before it")                                            \
    X(lam3, F64, FINITE, "lambda of the step before that")                                          \
    X(nhist, INT, NHIST, "consecutive ordinary steps in dprev, dprev2, dprev3")                     \
    X(rho, F64, FINITE, "carried vertex offset H(z_k) of the compensated constraint")              \
    X(rholo, F64, FINITE, "its low part (double-double)")                                           \
    X(lam_hint, F64, FINITE, "step size to aim for when there is no history")                       \
    X(dir, F64, UNIT, "direction of travel")                                                        \
    X(h, F64, NONZERO, "the step option h as it stands (dth_integrator_reverse flips it)")         \
    X(have_prev, INT, BOOL, "dprev and lam hold a step")                                            \
    X(have_mid, INT, BOOL, "zbar holds a midpoint")                                                 \
    X(pending_exact, INT, BOOL, "midpoint start: the exact first step is still to be taken")        \
    X(fact_valid, INT, BOOL, "the last step was an ordinary DTH step (a tangent map exists)")       \
    X(steps, LONG, COUNT, "steps since the start")                                                  \
    X(psi_known, INT, BOOL, "psi_sign holds the sign of psi at z_k (regularizers)")                 \
    X(psi_sign, INT, SIGN, "sign of psi at z_k")                                                    \
    X(psi_prev, F64, FINITE, "branch policy: psi at the vertex of the last root it accepted")       \
    X(psi_step, LONG, PSISTEP, "branch policy: that vertex's step count (-2: none)")

#define DTH__CTYPE_VEC double *
#define DTH__CTYPE_F64 double
#define DTH__CTYPE_INT int
#define DTH__CTYPE_LONG long
#define DTH__STATE_MEMBER(name, kind, check, doc) DTH__CTYPE_##kind name;
typedef struct dth__state {
    DTH__STATE_FIELDS(DTH__STATE_MEMBER)
} dth__state;
#undef DTH__STATE_MEMBER
/* how many VEC fields the list has */
#define DTH__STATE_ISVEC(name, kind, check, doc) +DTH__ISVEC_##kind
#define DTH__ISVEC_VEC 1
#define DTH__ISVEC_F64 0
#define DTH__ISVEC_INT 0
#define DTH__ISVEC_LONG 0
enum { DTH__STATE_NVEC = 0 DTH__STATE_FIELDS(DTH__STATE_ISVEC) };
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
    dth__state st;    /* the step state (above): everything a checkpoint holds */
    /* workspace: nothing here carries from one step to the next */
    double *dnew;     /* scratch for the next offset (rotates with st.dprev..st.dprev3) */
    double *hwork;    /* 2(2n+1) doubles for dth__model_hdiff (models without their own hdiff) */
    double *zblo;     /* low part of the midpoint of the compensated solution (it->zb + it->zblo) */
    double *znew, *znewlo, *zb, *grad, *hess, *u, *ybar, *A, *F, *x, *dx, *work, *B;
    double *xlo; /* low part of the unknowns x from the finishing chord steps (newton.h) */
    double *yc, *ydel, *ygl; /* a compensated chord step's evaluation point y, zbar - y, H''(y) (zbar - y) (coarse_n) */
    double *vc;               /* the vertex coarsened, where the carried offset rho is H (rho_from_mid_n) */
    double *vcsrc;            /* the vertex vc was made from (its cache key; NaN-free: compared by bits) */
    double *yprev;            /* the evaluation point before yc (step_again: cells alternating) */
    int ypinned;              /* yc is pinned for the rest of this solve (step_again) */
    int rev;                  /* the reversible finish (opt.compensate == 2 on a dense path): coarse_n */
    double Hphys;     /* H_phys at it->zb after the last step evaluation */
    double bs[4];     /* block scales (q, t, p, wp) of the Newton solve in progress (step_judge) */
    double ibq, ibp;  /* 1 / bs[0], 1 / bs[2] */
    int *piv;
    dth__newton_track nt; /* progress of the current Newton solve (messages) */
    double *block;
    struct dth__band *band; /* banded step solve (banded.c), NULL for the dense path */
    struct dth_rootfinder *rf; /* branch selection (branch.c), NULL when opt.branch_check is off */
    /* regularization (regularize.c): the hook and its workspace (its state: st.psi_sign, and the
     * regularizer's own, saved through its type) */
    dth_regularizer *reg;
    double *rbuf;     /* 4 N doubles of hook workspace */
    double *snap;     /* with a regularizer: DTH__STATE_NVEC x N doubles, the vectors of st while a step
                         may fail after committing (a regularizer's segment: the vertex offset afresh) */
    int snapped;      /* snap holds the vectors of this step's start */
    unsigned char *regsnap; /* the regularizer's own state at the start of the step (restored on failure) */
    size_t regsnap_len;
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
/** Put the step with offset d (zbar - z_k, length N; autonomous: its t and wp entries are not
 *  read, t advances by lambda/2 and wp stays) and lambda in it->x, its midpoint in it->zb, for
 *  dth__integrator_commit. */
void dth__integrator_set_solution(dth_integrator *it, const double *d, double lam);
/**
 * With a regularizer attached: take the ordinary step `rc` / `sol` (root `br`) if it succeeded
 * without changing the sign of psi, else call the hook and commit what it decides. pre != 0: the
 * hook was already asked (dth__reg_pre) and kept the ordinary step; commit it, or return its status.
 */
int dth__reg_step(dth_integrator *it, int rc, const dth__solution *sol, dth_branch br, dth_step_info *info, int pre);
/** After a step that is not an ordinary DTH step (a regularizer's): the carried vertex offset
 *  from a direct evaluation at the new vertex (no-op when opt.compensate is off). */
int dth__integrator_rho_reset(dth_integrator *it);
/** Copy the vectors of the step state into it->snap (before a commit that a later failure of the
 *  same step must undo); dth_integrator_step copies them back if the step fails. */
void dth__state_snapshot(dth_integrator *it);
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
