/* SPDX-License-Identifier: MIT */
/*
 * The DTH stepper's private state (paper, Theorem "DTH Equations"), shared by its own files only:
 * dth_step.c (the stepper type: predict -> Newton -> candidate -> policy -> commit), dth_start.c
 * (start modes), dth_newton.c (the Newton system, its finishes, the commit), dth_tangent.c, and the
 * checkpoint's field tables (checkpoint.c reads the state through them).
 */
#ifndef DTH_DTH_CORE_H
#define DTH_DTH_CORE_H

#include <stdarg.h>
#include "dth/integrator.h"
#include "dth_internal.h"
#include "fields.h"
#include "policy.h"

/*
 * The step state: everything that carries from one step to the next, nothing else (no workspace,
 * no options). This one list declares the fields of dth__state and generates the checkpoint's
 * field table (fields.h), so a field cannot be left out of a checkpoint; the policy's state has
 * its own list (policy.h). X(name, kind, check, meaning), kinds and checks as fields.h says.
 */
#define DTH__STATE_FIELDS(X)                                                                        \
    X(z, VEC, FINITE, "vertex z_k, high part")                                                      \
    X(zlo, VEC, FINITE, "vertex, low part: z_k = z + zlo exactly (double-double)")                  \
    X(zbar, VEC, FINITE, "midpoint of the last step")                                               \
    X(dprev, VEC, FINITE, "offset zbar - z_(k-1) of the last step (predictor)")                     \
    X(dprev2, VEC, FINITE, "the offset of the step before it (quadratic predictor)")               \
    X(dprev3, VEC, FINITE, "the offset of the step before that")                                    \
    X(lam, F64, STEP, "the last step's lambda (0 if none)")                                       \
    X(lam2, F64, STEP, "lambda of the step before it")                                            \
    X(lam3, F64, STEP, "lambda of the step before that")                                          \
    X(nhist, INT, NHIST, "consecutive ordinary steps in dprev, dprev2, dprev3")                     \
    X(rho, F64, FINITE, "carried vertex offset H(z_k) of the compensated constraint")              \
    X(rholo, F64, FINITE, "its low part (double-double)")                                           \
    X(lam_hint, F64, STEP, "step size to aim for when there is no history")                       \
    X(dir, F64, UNIT, "direction of travel")                                                        \
    X(h, F64, HSTEP, "the step option h as it stands (dth_integrator_reverse flips it)")         \
    X(have_prev, INT, BOOL, "dprev and lam hold a step")                                            \
    X(have_mid, INT, BOOL, "zbar holds a midpoint")                                                 \
    X(pending_exact, INT, BOOL, "midpoint start: the exact first step is still to be taken")        \
    X(fact_valid, INT, BOOL, "the last step was an ordinary DTH step (a tangent map exists)")       \
    X(steps, LONG, COUNT, "steps since the start")

typedef struct dth__state {
    DTH__STATE_FIELDS(DTH__FIELD_MEMBER)
} dth__state;

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

typedef struct dth__dth dth__dth;

/** Outcome of a Newton solve. */
typedef struct dth__solution {
    double lambda;
    double residual;
    int iters;
} dth__solution;

/** The path-specific kernels (dth_newton.c): the generic one and the small path's for n = 1, 2, 3. */
typedef struct dth__kernels {
    int (*newton)(dth__dth *it, double lam0, const double *d0, int max_iter, dth__solution *sol);
    int (*commit)(dth__dth *it, double lam, int replaced);
} dth__kernels;

struct dth__dth {
    const dth_model *model;
    const dth_allocator *alloc;
    dth_options opt;  /* as checked: linsolve resolved */
    size_t n, N, d;   /* dof, extended dim 2n+2, physical dim 2n+1 */
    int auton;        /* autonomous model: t and wp rows in closed form */
    int m;            /* Newton unknowns: active components of d, then lambda */
    int *act;         /* z-index of each active unknown (m-1 of them) */
    dth_linsolve kind; /* the linear solver in use (never AUTO) */
    const struct dth__linsolver *ls; /* its factor/solve/tangent (dth_newton.c) */
    const dth__kernels *kern;        /* the kernels of the path at hand */
    int nsmall;       /* n (1..3) where the step takes the small path (autonomous, written out), else 0 */
    int small_schur;  /* the small path may use its Schur complement (separable model, not small-lu) */
    dth__small_schur ss;
    /* the model's eval callback and state, called directly in the Newton loop (which sees a
     * non-finite output in its correction instead of sweeping for it) */
    int (*meval)(const void *self, const double *y, unsigned what, double *H, double *grad, double *hess);
    int (*mhdiff)(const void *self, const double *y1, const double *y0, double *dH); /* NULL: dth__model_hdiff's rule */
    const void *mself;
    dth__state st;    /* the step state (above): everything a checkpoint holds but the policy's */
    dth__policy pol;  /* the policy stage: which root, and what replaces a step (policy.h) */
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
    int rev;                  /* the reversible finish (opt.finish == DTH_FINISH_REVERSIBLE): coarse_n */
    int tiny;                 /* the Newton solve in progress iterates on the compensated constraint (newton_n) */
    const double *jump;       /* a replaced step's end-vertex displacement during its commit, else NULL */
    double level;             /* the constraint's level s: H(zbar) + s = 0 (0: the DTH step; a composition's
                                 substeps set theirs, issue "fourth order": the step T_-s o Phi o T_s) */
    double Hphys;     /* H_phys at it->zb after the last step evaluation */
    double bs[4];     /* block scales (q, t, p, wp) of the Newton solve in progress (step_judge) */
    double ibq, ibp;  /* 1 / bs[0], 1 / bs[2] */
    int *piv;
    dth__newton_track nt; /* progress of the current Newton solve (messages) */
    double *block;
    struct dth__band *band; /* banded step solve (banded.c), NULL for the dense path */
    char errmsg[192];
};

/** printf into it->errmsg. */
void dth__seterr(dth__dth *it, const char *fmt, ...) __attribute__((format(printf, 2, 3)));

/* ---- dth_newton.c: the Newton system and the commit ---- */
/** Point it->ls and it->kern at the path's table entries (after it->kind, it->nsmall are set). */
void dth__newton_setup(dth__dth *it);
/**
 * Newton on the bordered system from the current vertex, seeded with lambda0 and the offset d0
 * (length 2n+2), finished by chord steps on the compensated constraint (opt.finish). On success
 * it->x holds (d, lambda), it->zb the midpoint and it->zblo its low part; the factors of the last
 * iteration stay with the linear solver. Does not change the vertex.
 */
static inline int dth__newton(dth__dth *it, double lam0, const double *d0, int max_iter, dth__solution *sol)
{
    return it->kern->newton(it, lam0, d0, max_iter, sol);
}
/**
 * Commit the solution in it->x / it->zb as the next vertex z + 2 d (double-double), atomically: the
 * state changes only if the new vertex and its carried offset are computed. replaced: the segment
 * is a regularizer's (dth__set_solution), whose vertex offset is evaluated afresh at the new vertex
 * and which has no tangent map.
 */
static inline int dth__commit(dth__dth *it, double lam, int replaced) { return it->kern->commit(it, lam, replaced); }
/** Put the step with offset d (zbar - z_k, length N; autonomous: its t and wp entries are not read)
 *  and lambda in it->x, its midpoint in it->zb, for dth__commit. */
void dth__set_solution(dth__dth *it, const double *d, double lam);
/** After dth__set_solution, under the reversible finish: the offset's low part dlo (N; autonomous: its
 *  t entry is half lambda's low part) into it->xlo, so that dth__commit makes z + 2 (d + dlo). */
void dth__set_solution_lo(dth__dth *it, const double *dlo);
/** The root of the cubic model of the constraint near `target` (Lemma g_taylor), else target. */
double dth__cubic_predict(double Hk, double psi, double dpsi, double target);
/** The last step's tangent map by its path's solver (the dense one: dth__dense_tangent). */
int dth__tangent(dth__dth *it, double *M);
int dth__dense_tangent(dth__dth *it, double *M);

/* ---- dth_start.c: start modes ---- */
/** The vertex offset H(z) evaluated directly at the vertex z (+ zlo, wp's low part), over y at the
 *  high part (coarsened in the reversible finish, kept in it->vc). */
int dth__rho_direct(dth__dth *it, const double *z, const double *zlo, double *rho, double *rholo);
/** The reversible finish's exact first step of a midpoint start (dhi + dlo: its offset in
 *  double-double); leaves the model read at the coarse point of zbar. */
int dth__exact_offset_rev(dth__dth *it, const double *zbar, double h, double *dhi, double *dlo);
int dth__dth_start(void *s, const double *q0, const double *p0, double t0);
int dth__dth_set_vertex(void *s, const double *z, double lambda);
void dth__dth_reverse(void *s);

/* ---- dth_step.c: the stepper ---- */
/** The policy's read-only view of the vertex (the candidate's members are filled per step). */
void dth__view_vertex(const dth__dth *it, dth__view *v);

#endif
