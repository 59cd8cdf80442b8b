/* SPDX-License-Identifier: MIT */
/*
 * The DTH step's policy stage (policy.c): which root a step takes (the branch test: paper,
 * Theorems EU_1-EU_3 and the ghost roots of section 6) and what replaces a step where psi changes
 * sign or no physical root lies ahead (the regularizer: section 7). The stepper (dth_step.c)
 * computes a candidate step and hands the policy a read-only view of it; the policy answers with
 * a decision, and the stepper alone changes the step state. The policy's own state is a field
 * list saved with the checkpoint.
 */
#ifndef DTH_POLICY_H
#define DTH_POLICY_H

#include "dth/branch.h"
#include "dth/integrator.h"
#include "dth/regularize.h"
#include "fields.h"

/* The policy's state: X(name, kind, check, meaning) as fields.h says. */
#define DTH__POLICY_FIELDS(X)                                                                       \
    X(psi_known, INT, BOOL, "psi_sign holds the sign of psi at z_k (regularizers)")                 \
    X(psi_sign, INT, SIGN, "sign of psi at z_k")                                                    \
    X(psi_prev, F64, FINITE, "branch test: psi at the vertex of the last root it accepted")         \
    X(psi_step, LONG, PSISTEP, "branch test: that vertex's step count (-2: none)")

typedef struct dth__policy_state {
    DTH__POLICY_FIELDS(DTH__FIELD_MEMBER)
} dth__policy_state;

/** What the policy sees of the step in progress (borrowed for the call). */
typedef struct dth__view {
    const dth_model *model;
    size_t n, N;
    int auton;
    const double *z, *zlo;  /* the vertex z_k = z + zlo */
    double lam;             /* the incoming step (0 if none) */
    double lam_hint;        /* the step to aim for without history */
    double dir;             /* direction of travel */
    int have_prev;          /* dprev and lam hold the incoming step */
    const double *dprev;    /* its offset zbar - z_(k-1) */
    long steps;             /* steps since the start */
    double hk;              /* H(z_k) as the step reads it (the compensated finish's carried offset), NaN:
                               from the model (wp + H_phys at the vertex) */
    /* the candidate: the ordinary step Newton found from the predictor */
    int status;             /* Newton's status */
    double lambda, residual;
    int iters;
    const double *d;        /* its offset zbar - z_k (N), when status == DTH_OK */
} dth__view;

/** dth__decision.verdict */
enum {
    DTH__TAKE = 0,    /* take the candidate (branch: its root is the physical one) */
    DTH__RESEED = 1,  /* solve the step again from (lambda, d): the physical root of the full search */
    DTH__REPLACE = 2, /* replace the step by the regularizer's segment (lambda, d) */
    DTH__PLAIN = 3    /* (dth__policy_pre) compute the ordinary step */
};

/** The policy's answer. */
typedef struct dth__decision {
    int verdict;
    double lambda;    /* RESEED, REPLACE: the step */
    const double *d;  /* RESEED, REPLACE: its offset zbar - z_k (N; the policy's buffer) */
    const double *dlo; /* REPLACE under the reversible finish: the offset's low part (N), NULL: none */
    const double *jump; /* REPLACE: the end vertex's displacement (N), NULL: none */
    int fresh;        /* REPLACE: the next step starts without history */
    double dt;        /* TAKE, REPLACE: the regularizer's correction of the new vertex's time */
    double residual;  /* REPLACE: |H(zbar)| of the segment */
    int iters;        /* iterations the regularizer spent */
    int asked;        /* the regularizer was consulted on this candidate (or before it) */
    double psi;       /* RESEED: psi at the vertex, for dth__policy_took */
    dth_branch branch;
    unsigned flags;   /* DTH_STEP_* */
} dth__decision;

/** Polishes a root of the full search with the step's own Newton from the current vertex: seeded
 *  with (lam, d0 = zbar - z_k); the converged lambda, residual and midpoint out. 1 if it converged. */
typedef int (*dth__polish_fn)(void *ctx, double lam, const double *d0, double *lam_out, double *res, double *zbar);

typedef struct dth__policy {
    dth__policy_state st;
    struct dth_rootfinder *rf; /* the branch test's full search, NULL without the branch check */
    dth_regularizer *reg;      /* the regularizer (borrowed), NULL: raw DTH */
    size_t N;
    double *work;              /* dth_model_psi's workspace */
    double *cand, *dd, *ad;    /* a vertex, an offset, the regularizer's answer (its offset, jump and
                                  the offset's low part: 3N) */
    int finish;                /* the integrator's dth_finish (the hook's event says it) */
    unsigned char *regsnap;    /* the regularizer's own state at the start of the step */
    size_t regsnap_len;
    const dth_allocator *alloc;
    double psi_a, dpsi_a;      /* psi, psi' at the vertex as the branch test read them (NaN: not read) */
    char *err;                 /* the stepper's message buffer */
    size_t errlen;
} dth__policy;

/** Set up for `model` and the options (branch_check, regularizer, K, max_iter). polish/ctx: the
 *  stepper's Newton for the full search. @return DTH_OK, DTH_ENOMEM. */
int dth__policy_init(dth__policy *p, const dth_model *model, const dth_options *o, dth__polish_fn polish, void *ctx,
                     char *err, size_t errlen);
void dth__policy_free(dth__policy *p);
/** Forget the history (a new start): the sign of psi and the branch test's memory. */
void dth__policy_reset(dth__policy *p);
/** Save the regularizer's own state before a step (restored by dth__policy_rollback on failure). */
void dth__policy_begin(dth__policy *p);
void dth__policy_rollback(dth__policy *p, const dth__policy_state *saved);

/** 1 if the regularizer replaces every step (it is asked before an ordinary step is computed). */
int dth__policy_replaces_all(const dth__policy *p);
/** Ask such a regularizer at the vertex: REPLACE (its segment; *psi_sign_new as dth__policy_cross
 *  says) or PLAIN. @return DTH_OK or a status. */
int dth__policy_pre(dth__policy *p, const dth__view *v, dth__decision *dec, int *psi_sign_new);
/**
 * The branch test on the candidate: TAKE (its root is the physical one), RESEED (the physical root
 * of the full search, to be solved again and checked), or a status (DTH_ENEGOFFSET, DTH_EGHOST,
 * DTH_EFOLD, DTH_ENOROOT, or Newton's own). dec->branch names the root.
 */
int dth__policy_branch(dth__policy *p, const dth__view *v, dth__decision *dec);
/**
 * With a regularizer: TAKE the candidate (v->status is the branch test's outcome) if it is
 * ordinary and psi keeps its sign (and the regularizer admits it), else ask the regularizer:
 * REPLACE with its segment, TAKE the candidate, or a status. dec->flags get DTH_STEP_CROSSING
 * where psi changes sign and DTH_STEP_REGULARIZED for a segment; *psi_sign_new the sign at the
 * new vertex (committed by dth__policy_commit once the step is). pre: the regularizer was asked
 * before the candidate (dth__policy_pre) and kept it.
 */
int dth__policy_cross(dth__policy *p, const dth__view *v, int pre, dth__decision *dec, int *psi_sign_new);
/** The step was committed: remember the sign of psi at its vertex. */
void dth__policy_commit(dth__policy *p, int psi_sign_new);
/** A RESEED root polished to the one the search found: remember psi at the vertex (the cheap test
 *  of the next step compares with it). */
void dth__policy_took(dth__policy *p, double psi, long steps);

#endif
