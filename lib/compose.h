/* SPDX-License-Identifier: MIT */
/*
 * The DTH method of order 4 (issue 22; paper, Theorem "DTH Equations" with the constraint moved to a
 * level, H(zbar) + s = 0): a palindromic composition of level-shifted DTH substeps, the levels s_i fixed
 * once by an implicit-midpoint composition step at the start, a band of prescribed-step midpoint
 * compositions around psi = 0 crossings; private to compose.c, compose_band.c and compose_mid.c.
 */
#ifndef DTH_COMPOSE_H
#define DTH_COMPOSE_H

#include "dth_core.h"
#include "fields.h"

/** Most stages of a table (Kahan-Li's 17). */
#define DTH__MAX_STAGES 17

/** A palindromic coefficient table: tau = sum gamma_i, substep i takes about gamma_i tau. */
typedef struct dth__table {
    const char *name;
    int nominal;        /* the order the table has for a composition of a symmetric method of order 2 */
    int stages;
    const double *g;
    const char *doc;
} dth__table;

/** Table i of the list (NULL past its end); the default is entry 0 (suzuki4). */
const dth__table *dth__table_at(size_t i);
/** The table called name (NULL: the default), NULL if none. */
const dth__table *dth__table_find(const char *name);

/* The composition's scalars, saved with the checkpoint ("compose" section, veclen N). */
#define DTH__COMP_FIELDS(X)                                                                         \
    X(zprev, VEC, FINITE, "the vertex before the current one (a resumed run's cut segment)")       \
    X(href, F64, FINITE, "H(z) at the start vertex: mirror centre of the levels, the band's projection target") \
    X(tau_b, F64, FINITE, "the band's step (0 outside a band)")                                     \
    X(tau_b0, F64, FINITE, "the band's largest step (its entry step, halved where a band step failed)") \
    X(psi_est, F64, ANY, "psi read off the last composite step's first substep (8 rho_1 / lambda_1^2), NaN: none") \
    X(dpsi_x, F64, ANY, "psi' at the vertex of step kx (the entry test's curvature of psi)")     \
    X(d2psi, F64, ANY, "psi'' from psi' at the vertices kx - 1 and kx (NaN: not known)")          \
    X(kx, LONG, PSISTEP, "the step whose vertex had psi, psi' evaluated (-1: none)")             \
    X(lam, F64, FINITE, "the last step's tau = sum of its substeps (0 before the first step)")     \
    X(h, F64, NONZERO, "the step option h as it stands (reverse flips it)")                        \
    X(dir, F64, UNIT, "direction of travel")                                                        \
    X(band, INT, BOOL, "stepping in a band (prescribed steps) around a psi = 0 crossing")           \
    X(sigma, INT, UNIT, "the level set in use: +1 the start's, -1 its mirror (psi of the other sign)") \
    X(sign0, INT, UNIT, "sign of psi where the levels were made")                                   \
    X(have_levels, INT, BOOL, "the levels are made")                                                \
    X(pending, INT, BOOL, "the next step is the start step that makes the levels")                  \
    X(nh, INT, NHIST, "composite steps in the predictor's history (lam1..lam3; d1..d3)")           \
    X(last_band, INT, BOOL, "the last step was a prescribed-step composition (band or start)")      \
    X(fact_valid, INT, BOOL, "the last step has a tangent map (not a band exit's projection)")      \
    X(have_prev, INT, BOOL, "zprev holds the vertex before the current one")                        \
    X(steps, LONG, COUNT, "steps since the start (composite, start and band steps)")               \
    X(band_steps, LONG, COUNT, "band steps since the start")

/* Per stage (veclen = stages). */
#define DTH__STAGE_FIELDS(X)                                                                        \
    X(levels, VEC, FINITE, "the levels s_i of the start's set (the mirror's are -2 href - s_i)")   \
    X(lam1, VEC, FINITE, "the substeps lambda_i of the last step")                                 \
    X(lam2, VEC, FINITE, "those of the step before it")                                           \
    X(lam3, VEC, FINITE, "those of the step before that")

/* Per stage and extended coordinate (veclen = stages N). */
#define DTH__HIST_FIELDS(X)                                                                         \
    X(d1, VEC, FINITE, "the substeps' offsets zbar_i - z_(i-1) of the last step")                   \
    X(d2, VEC, FINITE, "those of the step before it")                                               \
    X(d3, VEC, FINITE, "those of the step before that")                                             \
    X(mids, VEC, FINITE, "the last step's midpoints zbar_i (its tangent map)")

typedef struct dth__comp_state {
    DTH__COMP_FIELDS(DTH__FIELD_MEMBER)
} dth__comp_state;
typedef struct dth__stage_state {
    DTH__STAGE_FIELDS(DTH__FIELD_MEMBER)
} dth__stage_state;
typedef struct dth__hist_state {
    DTH__HIST_FIELDS(DTH__FIELD_MEMBER)
} dth__hist_state;

/** The prescribed-step implicit midpoint substep (compose_mid.c). */
typedef struct dth__mid dth__mid;

/** The state at the start of a step (a failed step leaves it as it was). */
typedef struct dth__comp_snap {
    dth__comp_state st;
    dth__state core;
    double *dnew;
} dth__comp_snap;

typedef struct dth__comp {
    const dth_model *model;
    const dth_allocator *alloc;
    dth_options opt;          /* as checked */
    const dth__table *tab;
    int m;                    /* stages */
    size_t n, N;
    int auton;
    int band_on;              /* crossings are carried by the band (a regularizer is attached) */
    dth__dth *core;           /* the DTH step (dth_step.c's), whose level each substep sets */
    dth__mid *mid;            /* the band's and the start's prescribed midpoint solve */
    dth__comp_state st;
    dth__stage_state sg;
    dth__hist_state hs;
    dth__comp_snap sv;            /* the step's start (with the core's vectors in sz, szlo, szbar, sdp) */
    /* workspace */
    double *nd1, *nmids, *nlam;   /* a step's new offsets, midpoints (m N) and substeps (m) */
    double *sz, *szlo, *szbar, *sdp; /* the core's z, zlo, zbar, dprev..dprev3 (4 N) at the step's start */
    double *y, *ylo, *d, *u, *g;  /* a vertex in double-double, an offset, a flow, a gradient (N each) */
    double *M1, *M2;              /* tangent maps (N^2 each), allocated at the first dth_integrator_tangent */
    double *pw;                   /* dth_model_psi's workspace */
    double *block;
    char errmsg[224];
} dth__comp;

/* compose.c */
void dth__comp_seterr(dth__comp *c, const char *fmt, ...) __attribute__((format(printf, 2, 3)));
/** The level of substep i in the level set sigma. */
double dth__comp_level(const dth__comp *c, int i, int sigma);
/** Place the vertex z + zlo in the core (its carried offset evaluated there), keeping its options. */
int dth__comp_place(dth__comp *c, const double *z, const double *zlo);
/** The composite step on the level set sigma from the core's vertex, its substeps predicted from the
 *  history (nh) or, without one, from gamma_i tau_pred; on success the new offsets, midpoints and
 *  substeps are in nd1, nmids, nlam and the core is at the new vertex (the caller keeps copies).
 *  @return DTH_OK or the failing substep's status (message set). */
int dth__comp_composite(dth__comp *c, int sigma, double tau_pred, dth_step_info *info);
/** Commit the history after a step whose offsets, midpoints and substeps are in nd1, nmids, nlam. */
void dth__comp_commit_hist(dth__comp *c, int band);
/** Back to the state at the step's start: the core's (and with `all` the composition's too). */
void dth__comp_rewind(dth__comp *c, int all);

/* compose_band.c: the start step, the band, its entry and exit */
/** psi and psi' = [psi, H] at the vertex z. */
int dth__comp_psi(dth__comp *c, const double *z, double *psi, double *dpsi);
/** The start step: an implicit-midpoint composition of tau = h from the core's vertex; its midpoints
 *  make the levels (s_i = -H(zbar_i)). */
int dth__comp_start_step(dth__comp *c, dth_step_info *info);
/** After a composite step (the core at the new vertex, z0 the old one): enter the band if a
 *  crossing is near. *undo: psi changed sign within the step (the caller restores z0 and bands). */
int dth__comp_health(dth__comp *c, const double *z0, double rho1, int *undo);
/** One band step (prescribed tau_b), or (exit != 0) the exit from the band into a composite step
 *  where the vertex passes the exit test. */
int dth__comp_band_step(dth__comp *c, int exit, dth_step_info *info);
/** Decide at the start vertex whether it lies in a band (levels made at its exit). */
int dth__comp_start_band(dth__comp *c);

/* compose_mid.c: the prescribed-step midpoint substep and its tangent map */
int dth__mid_new(const dth_model *model, dth_linsolve kind, const dth_allocator *al, dth__mid **out);
void dth__mid_free(dth__mid *w);
/**
 * The implicit midpoint step of length lam from z (+ zlo): d = zbar - z with d = (lam/2) J grad H(zbar)
 * over the extended z (t advances by lam; an autonomous model's wp stays), by Newton from the seed d
 * (N values; in: a seed, out: the solution), to round-off. zbar into zbar (N). @return DTH_OK,
 * DTH_ENOCONV, DTH_ESINGULAR, the model's status.
 */
int dth__mid_solve(dth__mid *w, const double *z, const double *zlo, double lam, double *d, double *zbar, int max_iter,
                   int *iters);
/** The tangent map ((N x N) row-major) of the midpoint step with midpoint zbar and length lam. */
int dth__mid_tangent(dth__mid *w, const double *zbar, double lam, double *M);
/**
 * The symmetric projection of the vertex z + zlo onto H(z) = target along n (grad H over (q, p) with the
 * gradients of the model's quadratic invariants projected out, at the midpoint of z and z'): z' = z + mu
 * n((z + z')/2), so quadratic invariants are kept; t and wp untouched. A non-autonomous model moves wp
 * instead. Result in z, zlo. @return DTH_OK, DTH_ENOCONV, the model's status.
 */
int dth__mid_project(dth__mid *w, double *z, double *zlo, double target);

#endif
