/* SPDX-License-Identifier: MIT */
/* Internal declarations shared by the library's files (dth__ prefix, not installed). */
#ifndef DTH_INTERNAL_H
#define DTH_INTERNAL_H

#include <float.h>
#include <stddef.h>
#include "dth/integrator.h"
#include "dth/model.h"

/** Most degrees of freedom a model may have: every buffer is O(n) doubles (or O(n^2) on the dense
 *  path, which has its own limit), so sizes up to this never overflow a size_t. */
#define DTH__MAX_DOF ((size_t)1 << 40)
/** Most invariants a model may report. */
#define DTH__MAX_INVARIANTS ((size_t)1 << 16)
/** The model's own state pointer (for calling optional callbacks directly). */
const void *dth__model_self(const dth_model *m);
/** Bit j set: invariant j is (at most) quadratic in (q, p), as probed once when the model was made. */
unsigned long long dth__model_quad_mask(const dth_model *m);
/** 1 if the model type's parameter spec accepts `key`. */
int dth__model_accepts_key(const dth_model_type *t, const char *key);
/** u = J grad H over y = (q, t, p): (dH/dp, 1, -dH/dq). */
void dth__flow_y(size_t n, const double *grad, double *u);
/**
 * The one index map of J H_zz: d u_j / d z_l over z = (q, t, p, wp), u = J grad H, from the Hessian of
 * H_phys over y = (q, t, p) (d x d row-major, d = 2n + 1): q rows read H's p rows, p rows minus H's q
 * rows, the wp row minus H's t row; the t row and the wp column are zero.
 */
static inline double dth__dudz(size_t n, const double *hess, size_t j, size_t l)
{
    size_t d = 2 * n + 1;
    if (l >= d) return 0;
    if (j < n) return hess[(n + 1 + j) * d + l];
    if (j >= n + 1 && j < d) return -hess[(j - n - 1) * d + l];
    if (j == d) return -hess[n * d + l];
    return 0;
}
/** u = J grad H over z = (q, t, p, wp): dth__flow_y, and -dH/dt in the wp slot. */
static inline void dth__flow_z(size_t n, const double *grad, double *u)
{
    dth__flow_y(n, grad, u);
    u[2 * n + 1] = -grad[n];
}
/**
 * Check the head of a table a program or plugin filled (model.h: abi and size first): the magic, a
 * layout version from `oldest` to `version` (the current one, whose table has `full` bytes) and a
 * size that fits the version. `kind` names the table in the message ("model", "regularizer").
 * @return DTH_OK, DTH_EINVAL (message in err).
 */
int dth__abi_check(unsigned abi, size_t size, unsigned oldest, unsigned version, size_t full, const char *kind, char *err,
                   size_t len);
/** Copy a checked table of `size` bytes into `dst` (`full` bytes): members past size read as 0. */
void dth__table_copy(void *dst, size_t full, const void *src, size_t size);
struct dth_regularizer;
/** The fields of a regularizer instance's state (its type's list; *n = 0: stateless or NULL), the
 *  struct they are offsets into, the count of a F64_PTR field of count 0 (2n + 2). */
const struct dth_field *dth__reg_fields(const struct dth_regularizer *r, size_t *n);
void *dth__reg_self(const struct dth_regularizer *r);
size_t dth__reg_veclen(const struct dth_regularizer *r);
/** The type's state_loaded callback after its fields were written (0 if it has none). */
int dth__reg_loaded(struct dth_regularizer *r);
/** Bytes of state a regularizer instance carries (0: stateless or NULL): its fields' bytes in
 *  memory, for the policy's snapshot of a step (not a format: checkpoints write the fields). */
size_t dth__reg_state_size(const struct dth_regularizer *r);
/** Save that state into buf (dth__reg_state_size bytes). */
void dth__reg_save_state(const struct dth_regularizer *r, void *buf);
/** Load it back (then the type's state_loaded); -1 if len does not match or state_loaded refuses. */
int dth__reg_load_state(struct dth_regularizer *r, const void *buf, size_t len);
/** The instance's admit callback (regularize.h; the type has one). */
int dth__reg_admit(struct dth_regularizer *r, const double *za, const double *zb, double lambda);
/** The instance's observe callback (the type has one). */
int dth__reg_observe(struct dth_regularizer *r, const struct dth_reg_step *st, double *dt);
/** Nonzero if the instance replaces every step (its type's replaces_all). */
int dth__reg_replaces_all(const struct dth_regularizer *r);
struct dth_rootfinder;
struct dth_root_options;
/** A root finder whose roots are polished by `polish` (the DTH stepper's own Newton from its
 *  vertex: policy.h's dth__polish_fn); NULL: by a DTH integrator of its own, set to each vertex. */
int dth__rootfinder_new(const dth_model *model, const struct dth_root_options *opt, const dth_allocator *alloc,
                        int (*polish)(void *, double, const double *, double *, double *, double *), void *ctx,
                        struct dth_rootfinder **out);
/** The vertex z + zlo (rounded to double) kept in the finder (dth__rootfinder_point), and its H, psi,
 *  psi' and the scale of psi's round-off. */
int dth__rootfinder_vertex(struct dth_rootfinder *rf, const double *z, const double *zlo, double *H, double *psi,
                           double *dpsi, double *pabs);
const double *dth__rootfinder_point(const struct dth_rootfinder *rf);
/** The midpoint of root k of the last dth_find_roots (N values). */
const double *dth__rootfinder_root_mid(const struct dth_rootfinder *rf, size_t k);
struct dth__dth;
/** The DTH core of an integrator of method "dth" (dth_core.h), else NULL. */
struct dth__dth *dth__integrator_core(dth_integrator *it);
/** The integrator's method carries wp unchanged (a baseline): the dense output's wp flow is 0. */
int dth__integrator_wp_fixed(const dth_integrator *it);
/** dth_options.h as the integrator was made with (the step the user asked for). */
double dth__integrator_h(const dth_integrator *it);
/** The integrator's method has midpoints (DTH). */
int dth__integrator_has_midpoints(const dth_integrator *it);
/** The integrator's dense output is the quintic Hermite interpolant (order 4: stepper.h). */
int dth__integrator_dense5(const dth_integrator *it);
/** The vertex before the current one if the method keeps it (order 4), else NULL. */
const double *dth__integrator_prev_vertex(const dth_integrator *it);
/** The quintic Hermite interpolant on za -> zb at time t: flows ua, ub and their time derivatives
 *  aa, ab = J H_zz u (run.c's dense output for order 4). */
void dth__dense_eval5(size_t n, const double *za, const double *zb, const double *ua, const double *ub,
                      const double *aa, const double *ab, double t, double *z);
/** u = J grad H and a = J H_zz u at z (2n + 2 each; work: dth__flow2_work_size doubles; banded models
 *  through their banded Hessian). */
int dth__flow2(const dth_model *model, const double *z, double *u, double *a, double *work);
size_t dth__flow2_work_size(const dth_model *model);
/** Solve the DTH step from the core's current vertex seeded with (lam, d0): 1 if it converged,
 *  with lambda, the residual and the midpoint out (policy.h's dth__polish_fn). */
int dth__dth_polish(void *core, double lam, const double *d0, double *lam_out, double *res, double *zbar);
/** Doubles of workspace dth__model_grad_psi needs. */
size_t dth__model_gpsi_work(const dth_model *m);
/** The gradient of psi over y = (q, t, p) (d values) at y, D^3H[u, u, .] + 2 H J^T H u with u = J grad H
 *  (the third derivative from the model's `third` by polarization, else by a second difference of the
 *  gradient along u), and psi, psi' there
 *  (dth_model_psi). Dense Hessians only. */
int dth__model_grad_psi(const dth_model *m, const double *y, double *gpsi, double *psi, double *dpsi, double *work);

/** A closing condition of dth__kicked_joint: c(z_b) = 0 at the segment's end vertex (eval: its value and
 *  gradient over y = (q, t, p)), or lambda = `lambda` where eval is NULL. */
typedef struct dth__kj_close {
    int (*eval)(void *ctx, const double *yb, double *c, double *grad);
    void *ctx;
    double lambda;
} dth__kj_close;
/** Doubles of workspace dth__kicked_joint needs. */
size_t dth__kicked_joint_work_size(const dth_model *model);
/**
 * A kicked segment from the vertex z (+ zlo) with its time step lambda unknown too, closed by `close`
 * (regularize.c): ONE Newton on (d, lambda, mu). On entry dz (N), *lambda, *mu hold a seed; on success the
 * midpoint offset, the step and the kick. Autonomous models only.
 * @return DTH_OK, DTH_ENOCONV, DTH_ESINGULAR, DTH_EDOMAIN, DTH_EUNSUPPORTED, the closing condition's status.
 */
int dth__kicked_joint(const dth_model *model, const double *z, const double *zlo, const dth__kj_close *close, double *dz,
                      double *lambda, double *mu, double *residual, int *iters, double *work);
/** Doubles of workspace dth__kicked_law_rev needs. */
size_t dth__kicked_law_work_size(const dth_model *model);
/**
 * A kicked segment from the vertex z (+ zlo) whose step is the law lambda = dir arc / |u(zbar)|^alpha at
 * its own midpoint (u: the (q, p) part of J grad H), with the DTH step's reversible finish (prescribed_rev.c):
 * ONE Newton on (d, lambda, mu), then chord steps in double-double reading the model at the coarsened
 * midpoint, so that the segment back from its end finds the same midpoint to about 2^-100. On entry dz
 * (N), *lambda, *mu hold a seed; on success dz + dzlo (N each) the offset in double-double (t entry:
 * lambda/2 and half lambda's low part), the step and the kick. Autonomous models only. work (zeroed before
 * the first call, then kept for the same model) carries the quadratic invariants' Hessians from call to
 * call (found once).
 * @return DTH_OK, DTH_ENOCONV, DTH_ESINGULAR, DTH_EDOMAIN, DTH_EMODEL, DTH_EUNSUPPORTED.
 */
int dth__kicked_law_rev(const dth_model *model, const double *z, const double *zlo, double arc, double alpha,
                        double dir, double *dz, double *dzlo, double *lambda, double *mu, double *residual, int *iters,
                        double *work);
/** Doubles of workspace dth__kick_at needs. */
size_t dth__kick_work_size(const dth_model *model);
/** The kick direction n over (q, p) (2n values) at y, as the kicked segments use it. */
int dth__kick_at(const dth_model *model, const double *y, double *nv, double *work);

/** D^3 H[a, a, b] at y over y = (q, t, p): the model's `third` by polarization (three calls), else a
 *  central difference of the Hessian form a^T H a along b. Dense Hessians only. */
int dth__model_d3aab(const dth_model *m, const double *y, const double *a, const double *b, double *out, double *work);
/** Doubles of workspace dth__model_d3aab needs. */
size_t dth__model_d3_work(const dth_model *m);

/* ---- ordinary DTH's step invariant near psi = 0 (step_invariant.c) ---- */
/** G(r) of I = 512 rho^3/psi G(rho psi'^2/psi^3) (1 at r = 0). */
double dth__inv_G(double r);
/** I(psi, rho, psi'), NaN where rho psi < 0 (no ordinary step continues from there). */
double dth__inv_I(double psi, double rho, double dpsi);
/** The vertex offset R on the exit branch of the level set I = C at a vertex with psi, psi' travelling
 *  in direction dir (continued linearly before the crossing), and dR/dpsi. */
int dth__inv_exit_offset(double C, double psi, double dpsi, double dir, double *R, double *dR);
/** The offset R with I(psi, R, psi') = C on the side of psi (psi != 0), and dR/dpsi. */
int dth__inv_level_offset(double C, double psi, double dpsi, double *R, double *dR);
/** printf into a caller's message buffer (err may be NULL or len 0: nothing is written). */
void dth__set_err(char *err, size_t len, const char *fmt, ...) __attribute__((format(printf, 3, 4)));
/** Parse a comma-separated list of finite doubles; 0 on success. */
int dth__parse_list(const char *v, double *out, size_t max, size_t *count);

/* ---- dense LU (linsolve.c: LAPACK, or written out for m <= DTH__SMALL_MAX) ---- */

/** The factor/solve/tangent of a linear-solver path (dth_newton.c: the dense paths, the banded ones). */
struct dth__linsolver;
extern const struct dth__linsolver dth__dense_ls, dth__band_ls;

/** One linear-solver choice (linsolve.c's table): a new solver is one entry here and its ops. */
typedef struct dth__linsolve_info {
    dth_linsolve kind;
    const char *name;
    int banded;      /* needs a banded model; no O(m^2) buffers (banded.c) */
    const char *doc;
    const struct dth__linsolver *ops; /* the step's factor/solve/tangent (NULL: AUTO, resolved first) */
} dth__linsolve_info;
/** The entry of choice k, NULL if k is not one. */
const dth__linsolve_info *dth__linsolve_find(dth_linsolve k);
/** Entry i of the table (0 <= i < its length), else NULL. */
const dth__linsolve_info *dth__linsolve_at(size_t i);
/** The solver AUTO means for a model (banded or not) with m Newton unknowns; k itself otherwise. */
dth_linsolve dth__linsolve_resolve(dth_linsolve k, int banded_model, size_t m);

/** Largest system the small path factors itself (no library call). */
#define DTH__SMALL_MAX 8
/** 1 if dth__lu_* take the small path for this choice and size. */
int dth__lu_small(dth_linsolve k, int m);
/** Factor the column-major m x m matrix a in place; piv gets m (1-based) pivots.
 *  @return DTH_OK, DTH_ESINGULAR, DTH_ELAPACK. */
int dth__lu_factor(dth_linsolve k, int m, double *a, int *piv);
/** Solve with the factors for nrhs column-major right-hand sides in b (ldb = m). */
int dth__lu_solve(dth_linsolve k, int m, const double *a, const int *piv, int nrhs, double *b);
/** Sign of the determinant from the factors (0 if a pivot is zero or NaN). */
int dth__lu_det_sign(int m, const double *a, const int *piv);

/* ---- the Newton driver (newton.c) ---- */

/** Verdicts of a Newton iteration. */
enum { DTH__NT_MORE = 0, DTH__NT_DONE, DTH__NT_CHORD, DTH__NT_STALLED, DTH__NT_DIVERGED, DTH__NT_MAXITER };
/** Progress of a Newton solve: iteration, its relative correction and the previous one. */
typedef struct dth__newton_track {
    int iter;
    double r, r_prev;
    int verdict;
} dth__newton_track;
/** A Newton problem. */
typedef struct dth__newton_ops {
    /** Residual F at x; with jac != 0 also assemble and factor the Jacobian there. jac == 0 is
     *  the chord step's residual, which may be a finishing form of the equations (the DTH step's
     *  compensated constraint). */
    int (*eval)(void *ctx, const double *x, double *F, int jac);
    /** b = J^-1 b in place, with the factors of the last eval(jac = 1). */
    int (*solve)(void *ctx, double *b);
    /** After the update x -= dx (F: the residual before it): set tr->r and *verdict to
     *  DTH__NT_DONE, DTH__NT_CHORD (finish with one chord step) or DTH__NT_MORE; a nonzero
     *  return ends the solve with that status. */
    int (*judge)(void *ctx, const double *x, const double *dx, const double *F, dth__newton_track *tr, int *verdict);
} dth__newton_ops;
/** After chord step number `chords` (dx: its correction): nonzero asks for one more (newton.h). */
typedef int (*dth__newton_again)(void *ctx, const double *x, const double *dx, int chords);
/** Verdict from the relative correction r: DONE (r <= tol), CHORD (the quadratic rate predicts
 *  the next correction below eps), STALLED (r >= r_prev / 2), DIVERGED (not finite) or MORE. */
int dth__newton_rate(double r, double r_prev, int iter, double tol);
/** Iterate from x (m unknowns) until the judge says done (then DTH_OK), a callback fails (its
 *  status) or max_iter passes (DTH_ENOCONV); a CHORD verdict finishes with one chord step. F and dx
 *  are m doubles of workspace. (newton.h: the loop itself, with an optional `again` test.) */
int dth__newton_run(const dth__newton_ops *ops, void *ctx, int m, int max_iter, double *x, double *F,
                    double *dx, dth__newton_track *tr);

/* ---- banded step solve (banded.c, which calls LAPACK's banded LU) ---- */

/** dth_model_eval without the NaN/Inf sweep of the Hessian (H and the gradient are checked): for
 *  Newton loops, which see a non-finite Hessian entry in their correction. */
int dth__model_eval_raw(const dth_model *m, const double *y, unsigned what, double *H, double *grad, double *hess);
/** H_phys(y1) - H_phys(y0) without cancellation: the model's hdiff, else a 4-point Gauss-Legendre
 *  rule on the gradient along the segment (work: 2(2n+1) doubles). Exactly antisymmetric in (y1, y0). */
int dth__model_hdiff(const dth_model *m, const double *y1, const double *y0, double *work, double *dH);
/** 1 if the integrator and psi use the model's banded Hessian (DTH_HESS_BANDED with hess_band,
 *  autonomous); the dense Hessian is then never evaluated by them. */
int dth__model_banded(const dth_model *m);
/** The model's banded Hessian at y (interleaved layout, model.h), checked for NaN/Inf.
 *  @return DTH_OK, DTH_EDOMAIN, DTH_EMODEL. */
int dth__model_hess_band(const dth_model *m, const double *y, double *band);
/** The same without the NaN/Inf sweep (Newton loops see non-finite entries in their correction). */
int dth__model_hess_band_raw(const dth_model *m, const double *y, double *band);
/** Workspace and factors of the banded bordered solve. */
typedef struct dth__band dth__band;
/** Allocate for a banded model; schur: use the Schur complement where H is separable with diagonal
 *  T'' (else always the banded LU of the whole step matrix). @return DTH_OK, DTH_EINVAL, DTH_ENOMEM. */
int dth__band_new(const dth_model *m, int schur, const dth_allocator *al, dth__band **out);
/** Free; NULL is a no-op. */
void dth__band_free(dth__band *b, const dth_allocator *al);
/** Assemble and factor the step Jacobian at midpoint zb (gradient `grad` over y there) and lam.
 *  @return DTH_OK, DTH_ESINGULAR, DTH_ELAPACK, or the model's status. */
int dth__band_factor(dth__band *b, const dth_model *m, const double *zb, const double *grad, double lam);
/** Tests: on != 0 makes the Schur complement's Cholesky always LAPACK's dpbtrf (never written out). */
void dth__band_lapack_only(dth__band *b, int on);
/** How the last factorization solved B: 1 Schur complement by Cholesky, 2 by LU, 3 banded LU of B. */
int dth__band_mode(const dth__band *b);
/** Solve the factored system in place; x (length 2n+1) is in the integrator's unknown order
 *  (d_q, d_p, lambda), as the dense path's right-hand side. @return DTH_OK, DTH_ELAPACK. */
int dth__band_solve(dth__band *b, double *x);
/** Tangent map of the step with midpoint zbar and step lam ((2n+2)^2 row-major, as
 *  dth_integrator_tangent). Overwrites the factors. */
int dth__band_tangent(dth__band *b, const dth_model *m, const double *zbar, double lam, double *M);
/** The first block B = I - (lambda/2) J H_xx alone at zb, factored (a prescribed lambda: the order-4
 *  composition's midpoint substeps, compose_mid.c). Overwrites the factors. */
int dth__band_factor_block(dth__band *b, const dth_model *m, const double *zb, double lam);
/** x = B^-1 x with those factors, x over (q block, p block) (2n values). @return DTH_OK, DTH_ELAPACK. */
int dth__band_solve_block(dth__band *b, double *x);
/** Orthonormal rows G (ninv x 2n) spanning sc * grad I over (q, p) of the model's quadratic invariants at
 *  y (regularize.c; sc: 2n metric scales); ys: 2n + 1, tmp: 2 ninv doubles. Returns the rows kept. */
size_t dth__quad_invariant_basis(const dth_model *model, const double *y, const double *sc, double *G, double *ys,
                                 double *tmp);

#endif
