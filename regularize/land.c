/* SPDX-License-Identifier: MIT */
/*
 * Regularizer "land", the default: raw DTH wherever it runs, and at a psi = 0 crossing (paper,
 * section 7: where the physical root merges with the ghost, Theorem EU_2) ONE replaced step, only on
 * the step raw DTH refuses (no physical root ahead) or whose root crosses psi = 0
 * (docs/regularization.md, "land"):
 *   - the landing segment: a kicked segment zbar = z_a + (lambda J grad H(zbar) + mu n(zbar))/2,
 *     H(zbar) = 0, whose step lambda is an unknown too, closed by landing its end vertex just past
 *     psi = 0, psi(z_b) = kappa psi'(z_b) dir l(z_b), l = (C/psi'^2)^(1/8) the crossing's time scale
 *     (one Newton on (d, lambda, mu));
 *   - the offset reset: the end vertex moved along n, no time passing and not back across psi = 0, onto
 *     the exit branch of the level set I = C of ordinary DTH's step invariant (step_invariant.c), so the
 *     ordinary steps after the crossing continue the run's step sequence (C: the run's constant,
 *     lambda^6 psi^2 of its first step, or the parameter `invariant`; before any ordinary step, the
 *     vertex's own I);
 *   - where the landing does not converge, does not cross or would exceed `bound` times the last ordinary
 *     step (psi bends away from its linear model), a kicked segment of the last ordinary step's length
 *     or 1/2, 1/4, 1/8 of it: the longest that does not cross, its end reset onto I = C on its own side
 *     (the next vertex tries again), else the longest that crosses, reset onto the exit branch; where no
 *     reset exists (the move that would reach the level set crosses psi = 0 first) the first converged
 *     segment as it is (apply).
 * Ordinary steps are raw DTH bit for bit (symplectic, their own reverse); a replaced step keeps the
 * energy at its midpoint and the quadratic invariants, and is neither symplectic nor reversible (the
 * reset collapses a direction: DTH_STEP_RESET).
 */
#include <float.h>
#include <math.h>
#include <stddef.h>
#include <string.h>
#include "dth_internal.h"
#include "reg_common.h"

/* candidates of a replaced step (apply): the landing (0) and the fallback segments of 1, 1/2, 1/4, 1/8 of the
 * last ordinary step (1..4) */
enum { NCAND = 5 };

typedef struct land {
    const dth_model *model;
    const dth_allocator *alloc;
    size_t n, N;
    double C;       /* the run's step invariant I (lambda^6 psi^2 far from psi = 0) */
    int C_fixed;    /* C set (parameter `invariant`, or the first ordinary step): a constant after that */
    double kappa;   /* the landing distance past psi = 0 in units of l */
    double bound;   /* the largest landing step, in units of the last ordinary step */
    double dir;     /* the event's direction of travel (the closing condition's) */
    int clock;      /* the clock correction on (parameter `clock`; autonomous models only) */
    int crossed;    /* a crossing was replaced: window corrections apply as they come */
    double acc;     /* the corrections of the windows before the first crossing (added there) */
    int have_prev;  /* dpsi_prev, lam_prev hold the last vertex's psi' and the step from it */
    double dpsi_prev, lam_prev;
    size_t nkj, ngp, nkick, nck;
    double *ck;     /* the clock's workspace: Hessian, u, (J H) u, (J H)^2 u, and dth__model_d3aab's */
    double *kj, *gp, *kick; /* workspaces of dth__kicked_joint, dth__model_grad_psi, dth__kick_at (at the
                               first crossing: ordinary steps need none) */
    double *cd;             /* the replaced step's candidate segments' offsets (NCAND x N, with kj) */
    double *vec, *pw;       /* the vectors below, and dth_model_psi's workspace (at creation, O(n)) */
    double *d, *zb, *y, *g, *nv, *gpsi;
} land;

static const dth_param_spec params[] = {
    {"invariant", "", "the run's step invariant C (lambda^6 psi^2 far from psi = 0; > 0); default: from the "
                      "first ordinary step, so the steps after each crossing continue the run's"},
    {"kappa", "0.01", "how far past psi = 0 the landing segment ends, in units of the crossing's time scale "
                      "(C/psi'^2)^(1/8) (> 0)"},
    {"bound", "2", "the largest landing step in units of the last ordinary step; beyond it a segment of the last "
                   "ordinary step's length (or 1/2, 1/4, 1/8) that does not cross yet (> 1)"},
    {"clock", "yes", "correct the time of the steps near psi = 0 (|psi psi''| < 1.15 psi'^2) by their leading local "
                     "time error, once the run has crossed (yes/no; autonomous models only): second order through "
                     "crossings"},
};

static int create(const dth_reg_args *a, void **self)
{
    land *r = dth_calloc(a->alloc, 1, sizeof *r);
    if (!r) return DTH_ENOMEM;
    *self = r;
    r->model = a->model;
    r->alloc = a->alloc;
    r->n = dth_model_dof(a->model);
    r->N = 2 * r->n + 2;
    r->kappa = 0.01;
    r->bound = 2;
    r->clock = 1;
    for (size_t i = 0; i < a->nkv; i++) {
        const char *k = a->kv[i].key, *v = a->kv[i].value;
        if (!strcmp(k, "invariant")) {
            if (dth_parse_double(v, &r->C) || !(r->C > 0) || !isfinite(r->C)) return dth__reg_param_err(a, k, "a number > 0");
            r->C_fixed = 1;
        }
        if (!strcmp(k, "kappa") && (dth_parse_double(v, &r->kappa) || !(r->kappa > 0) || !isfinite(r->kappa)))
            return dth__reg_param_err(a, k, "a number > 0");
        if (!strcmp(k, "bound") && (dth_parse_double(v, &r->bound) || !(r->bound > 1) || !isfinite(r->bound)))
            return dth__reg_param_err(a, k, "a number > 1");
        if (!strcmp(k, "clock")) {
            if (!strcmp(v, "yes")) r->clock = 1;
            else if (!strcmp(v, "no")) r->clock = 0;
            else return dth__reg_param_err(a, k, "yes or no");
        }
    }
    if (!dth_model_get_info(a->model)->autonomous) r->clock = 0;
    size_t N = r->N, nw = dth_model_work_size(a->model);
    r->vec = dth_calloc(a->alloc, 5 * N + (N - 1) + nw, sizeof(double));
    if (!r->vec) return DTH_ENOMEM;
    r->d = r->vec;
    r->zb = r->d + N;
    r->y = r->zb + N;
    r->g = r->y + N;
    r->nv = r->g + N;
    r->gpsi = r->nv + N;
    r->pw = r->gpsi + (N - 1);
    return DTH_OK;
}

static void destroy(void *self, const dth_allocator *alloc)
{
    land *r = self;
    if (!r) return;
    dth_free(alloc, r->kj);
    dth_free(alloc, r->ck);
    dth_free(alloc, r->vec);
    dth_free(alloc, r);
}

/* The workspace, allocated at the first crossing (ordinary steps need none: a large model runs until it
 * first crosses). */
static int workspace(land *r)
{
    if (r->kj) return DTH_OK;
    r->nkj = dth__kicked_joint_work_size(r->model);
    r->ngp = dth__model_gpsi_work(r->model);
    r->nkick = dth__kick_work_size(r->model);
    r->kj = dth_calloc(r->alloc, r->nkj + r->ngp + r->nkick + NCAND * r->N, sizeof(double));
    if (!r->kj) return DTH_ENOMEM;
    r->gp = r->kj + r->nkj;
    r->kick = r->gp + r->ngp;
    r->cd = r->kick + r->nkick;
    return DTH_OK;
}

/* C-infinity window of the clock: 1 for x <= 0.4, 0 for x >= 1.15 (x = |psi psi''| / psi'^2). */
static double window(double x)
{
    const double a = 0.4, b = 1.15;
    if (!(x < b)) return 0;
    if (x <= a) return 1;
    double t = (x - a) / (b - a), e1 = exp(-1 / (1 - t)), e2 = exp(-1 / t);
    return e1 / (e1 + e2);
}

/* The clock's workspace, at the first window step. */
static int clock_workspace(land *r)
{
    if (r->ck) return DTH_OK;
    size_t d = r->N - 1;
    r->nck = d * d + 3 * d + dth__model_d3_work(r->model);
    r->ck = dth_calloc(r->alloc, r->nck, sizeof(double));
    return r->ck ? DTH_OK : DTH_ENOMEM;
}

/*
 * The time-like part of a midpoint segment's leading local error at its midpoint y (paper's extended
 * flow u = J grad H, autonomous: the t rows play no part):
 *   tau = lambda^3 [u^T (J H)^2 u / 12 - D^3H[u, u, grad H] / 24] / |u|^2   over (q, p)
 * (the local error lambda^3 (f'f'f/12 - f''(f, f)/24) of the midpoint rule, f = J grad H, projected on u).
 */
static int clock_tau(land *r, const double *y, double lambda, double *tau)
{
    size_t n = r->n, d = r->N - 1;
    int rc = clock_workspace(r);
    if (rc) return rc;
    double *A = r->ck, *u = A + d * d, *v = u + d, *w = v + d, *work = w + d, H;
    rc = dth_model_eval(r->model, y, DTH_EVAL_H | DTH_EVAL_GRAD | DTH_EVAL_HESS, &H, r->g, A);
    if (rc) return rc;
    dth__flow_y(n, r->g, u);
    u[n] = 0;
    r->g[n] = 0;
    for (size_t j = 0; j < d; j++) {
        v[j] = 0;
        for (size_t m = 0; m < d; m++) v[j] += dth__dudz(n, A, j, m) * u[m];
    }
    v[n] = 0;
    double uu = 0, uw = 0, d3;
    for (size_t j = 0; j < d; j++) {
        w[j] = 0;
        for (size_t m = 0; m < d; m++) w[j] += dth__dudz(n, A, j, m) * v[m];
        if (j != n) {
            uu += u[j] * u[j];
            uw += u[j] * w[j];
        }
    }
    rc = dth__model_d3aab(r->model, y, u, r->g, &d3, work);
    if (rc) return rc;
    if (!(uu > 0)) {
        *tau = 0;
        return DTH_OK;
    }
    *tau = lambda * lambda * lambda * (uw / 12 - d3 / 24) / uu;
    return isfinite(*tau) ? DTH_OK : DTH_EDOMAIN;
}

/* A window step's correction: added now once the run has crossed, else kept for the first crossing. */
static int clock_add(land *r, const double *y, double lambda, double w, double *dt)
{
    double tau;
    int rc = clock_tau(r, y, lambda, &tau);
    if (rc) return rc;
    if (r->crossed) *dt += w * tau;
    else r->acc += w * tau;
    return DTH_OK;
}

/*
 * Every ordinary step: the first fixes C = lambda^6 psi(zbar)^2 (far from psi = 0 that is the step
 * invariant); a step in a crossing's window (|psi psi''| < 1.15 psi'^2 at its start vertex, psi'' from
 * psi' at the last two vertices) gets its clock correction.
 */
static int observe(void *self, const dth_reg_step *s, double *dt)
{
    land *r = self;
    if (!r->C_fixed) {
        double psi;
        if (dth_model_psi(r->model, s->zbar, &psi, NULL, r->pw)) return DTH_EMODEL;
        double l2 = s->lambda * s->lambda, C = l2 * l2 * l2 * psi * psi;
        if (C > 0 && isfinite(C)) {
            r->C = C;
            r->C_fixed = 1;
        }
    }
    double psi = s->psi_a, dpsi = s->dpsi_a;
    if (isnan(psi) || isnan(dpsi)) {
        if (!r->clock) { /* psi'' for the landing's seed only where the branch test read psi' anyway */
            r->have_prev = 0;
            return DTH_OK;
        }
        int rc = dth_model_psi(r->model, s->za, &psi, &dpsi, r->pw);
        if (rc) return rc;
    }
    double w = 0;
    if (r->have_prev && r->lam_prev != 0 && dpsi != 0) w = window(fabs(psi * (dpsi - r->dpsi_prev) / r->lam_prev) / (dpsi * dpsi));
    r->dpsi_prev = dpsi;
    r->lam_prev = s->lambda;
    r->have_prev = 1;
    return w > 0 && r->clock ? clock_add(r, s->zbar, s->lambda, w, dt) : DTH_OK;
}

/* The landing condition c(z_b) = psi - kappa psi' dir l, l = (C/psi'^2)^(1/8), with d c / dy ~ grad psi
 * (the small target's own derivative left out). */
static int land_close(void *ctx, const double *yb, double *c, double *grad)
{
    land *r = ctx;
    double psi, dpsi;
    int rc = dth__model_grad_psi(r->model, yb, grad, &psi, &dpsi, r->gp);
    if (rc) return rc;
    if (dpsi == 0) return DTH_EDOMAIN;
    *c = psi - r->kappa * dpsi * r->dir * pow(r->C / (dpsi * dpsi), 0.125);
    return DTH_OK;
}

/*
 * The reset's residual at nu: the end vertex zb moved to y = zb + nu n(m), n read at the move's own
 * midpoint m = zb + nu n(m)/2 (a fixed point in m, from the last n: n moves by O(nu), so two or three
 * rounds), and F = wp + H(y) - R(psi(y), psi'(y)), R the offset on the level set I = C (exit: its exit
 * branch, continuous through psi = 0; else the branch on psi's own side). dF: its derivative along n (n's
 * own motion left out). Returns 1 where psi(y) has left zb's side *s0 (the move keeps the vertex on the side
 * the segment reached; *s0 = 0: set it, at nu = 0), 0, or a status.
 */
static int reset_eval(land *r, const double *zb, double wp, int exit, int *s0, double nu, double tol, double *F,
                      double *dF)
{
    size_t n = r->n, d = r->N - 1;
    int rc;
    for (int k = 0; k < 8; k++) {
        for (size_t j = 0; j < d; j++)
            r->y[j] = nu == 0 ? zb[j] : zb[j] + (j < n ? 0.5 * nu * r->nv[j] : j > n ? 0.5 * nu * r->nv[j - 1] : 0);
        memcpy(r->g, r->nv, 2 * n * sizeof *r->g);
        rc = dth__kick_at(r->model, r->y, r->nv, r->kick);
        if (rc) return rc;
        double moved = 0;
        for (size_t i = 0; i < 2 * n; i++) moved = fmax(moved, fabs(nu * (r->nv[i] - r->g[i])));
        if (moved <= tol || nu == 0) break;
    }
    for (size_t j = 0; j < d; j++) r->y[j] = nu == 0 ? zb[j] : zb[j] + (j < n ? nu * r->nv[j] : j > n ? nu * r->nv[j - 1] : 0);
    double H, psi, dpsi, R, dR;
    rc = dth_model_eval(r->model, r->y, DTH_EVAL_H | DTH_EVAL_GRAD, &H, r->g, NULL);
    if (!rc) rc = dth__model_grad_psi(r->model, r->y, r->gpsi, &psi, &dpsi, r->gp);
    if (rc) return rc;
    if (*s0 == 0) { /* nu = 0: psi's side at zb */
        if (psi == 0) return DTH_ENOROOT;
        *s0 = psi > 0 ? 1 : -1;
    }
    if (psi == 0 || (psi > 0 ? 1 : -1) != *s0) return 1;
    rc = exit ? dth__inv_exit_offset(r->C, psi, dpsi, r->dir, &R, &dR) : dth__inv_level_offset(r->C, psi, dpsi, &R, &dR);
    if (rc) return DTH_EDOMAIN;
    double gn = 0, pn = 0;
    for (size_t i = 0; i < n; i++) {
        gn += r->g[i] * r->nv[i] + r->g[n + 1 + i] * r->nv[n + i];
        pn += r->gpsi[i] * r->nv[i] + r->gpsi[n + 1 + i] * r->nv[n + i];
    }
    *F = wp + H - R;
    *dF = gn - dR * pn;
    return isfinite(*F) && isfinite(*dF) ? DTH_OK : DTH_EDOMAIN;
}

/*
 * The reset of the end vertex zb along the kick direction, no time passing: zb' = zb + nu n(m) with n read
 * at the move's own midpoint m = (zb + zb')/2 (so the quadratic invariants, whose gradients at m are
 * orthogonal to n(m), are kept exactly, as by a kicked segment), and wp + H(zb') = R(psi, psi') there
 * (reset_eval). A safeguarded Newton on the scalar nu: Newton's step while it stays inside what is known
 * (the bracket of a sign change of F once there is one, and short of any nu where psi left zb's side),
 * else bisection. DTH_ENOROOT: no reset exists on zb's side (F keeps its sign up to where psi changes
 * sign: the move along n that would put the offset on the level set crosses psi = 0 first; the own-side
 * level set's offset jumps there). *iters: the residuals evaluated. The jump zb' - zb goes to jump (N).
 */
static int reset(land *r, const double *zb, double wp, int exit, double *jump, int *iters)
{
    size_t n = r->n, N = r->N, d = N - 1;
    double scale = 1e-300;
    for (size_t j = 0; j < d; j++)
        if (j != n) scale = fmax(scale, fabs(zb[j])); /* over (q, p): no bits depend on t */
    double tol = 4 * DBL_EPSILON * scale;
    int rc, s0 = 0;
    *iters = 0;
    /* a: the last nu evaluated with F(0)'s sign; b: the last with the other sign (have_b); lim: the last nu
     * where psi had left its side (have_lim) */
    double nu = 0, a = 0, Fa = NAN, b = NAN, Fb = NAN, lim = NAN, F = NAN, dF = NAN;
    int have_b = 0, have_lim = 0, it, done = 0;
    for (it = 1; it <= 60 && !done; it++) {
        rc = reset_eval(r, zb, wp, exit, &s0, nu, tol, &F, &dF); /* nu = 0 first: n at zb, the fixed point's start */
        ++*iters;
        if (rc < 0 || rc > 1) return rc;
        double nrm = 0;
        for (size_t i = 0; i < 2 * n; i++) nrm += r->nv[i] * r->nv[i];
        nrm = sqrt(nrm);
        double next;
        if (rc == 1) { /* psi left its side at nu (never at nu = 0): a limit; halfway back to a */
            lim = nu;
            have_lim = 1;
            next = have_b ? 0.5 * (a + b) : 0.5 * (a + lim);
        } else {
            if (it == 1 || (F > 0) == (Fa > 0)) {
                a = nu;
                Fa = F;
            } else {
                b = nu;
                Fb = F;
                have_b = 1;
            }
            if (F == 0) break;
            /* Newton's step, kept inside the bracket (or short of the side's limit) */
            next = nu - F / dF;
            double lo = have_b ? fmin(a, b) : have_lim ? fmin(a, lim) : -INFINITY;
            double hi = have_b ? fmax(a, b) : have_lim ? fmax(a, lim) : INFINITY;
            if (!(next > lo && next < hi)) {
                if (!have_b && !have_lim) return DTH_ENOCONV; /* not finite */
                next = have_b ? 0.5 * (a + b) : 0.5 * (a + lim);
            } else if (fabs(next - nu) * nrm <= tol) {
                break; /* Newton converged: the last n(m) belongs to this nu */
            }
        }
        if (have_b && fabs(b - a) * nrm <= tol) { /* bracketed to round-off: the better end */
            double best = fabs(Fb) < fabs(Fa) ? b : a;
            if (best != nu || rc == 1) {
                nu = best;
                rc = reset_eval(r, zb, wp, exit, &s0, nu, tol, &F, &dF); /* its own n(m) */
                ++*iters;
                if (rc) return rc == 1 ? DTH_ENOROOT : rc;
            }
            done = 1;
        } else if (!have_b && have_lim && fabs(lim - a) * nrm <= tol) {
            return DTH_ENOROOT; /* F keeps its sign up to where psi changes sign */
        } else {
            nu = next;
        }
    }
    if (it > 60 && !done) return DTH_ENOCONV;
    memset(jump, 0, N * sizeof *jump);
    for (size_t i = 0; i < n; i++) {
        jump[i] = nu * r->nv[i];
        jump[n + 1 + i] = nu * r->nv[n + i];
    }
    return DTH_OK;
}

/* The root of a x^2 + b x + c nearest 0 on the side dir (NaN: none). */
static double side_root(double a, double b, double c, double dir)
{
    double best = NAN, r[2];
    int k = 0;
    if (fabs(a) * fabs(c) <= 1e-12 * b * b) { /* linear (or nearly) */
        if (b != 0) r[k++] = -c / b;
    } else {
        double disc = b * b - 4 * a * c;
        if (disc < 0) return NAN;
        double qq = -0.5 * (b + copysign(sqrt(disc), b));
        r[k++] = qq / a;
        if (qq != 0) r[k++] = c / qq;
    }
    for (int i = 0; i < k; i++)
        if (r[i] * dir > 0 && (isnan(best) || fabs(r[i]) < fabs(best))) best = r[i];
    return best;
}

/* The step to the landing target from psi's quadratic model psi + psi' l + psi'' l^2 / 2 (psi'' = d2, 0 if
 * unknown), the target's psi' at the landing point: a few fixed-point rounds. The landing crosses psi = 0:
 * from a vertex moving away from it (psi psi' dir >= 0: just after a crossing, where psi dips back) the
 * target is past the model's next zero, with psi' there. NaN: no crossing ahead. */
static double landing_step(const land *r, double psi, double dpsi, double d2)
{
    double l = NAN, db0 = dpsi;
    if (psi * dpsi * r->dir >= 0) { /* receding: psi' where the model comes back through 0 */
        double l0 = side_root(0.5 * d2, dpsi, psi, r->dir);
        if (isnan(l0)) return NAN;
        db0 = dpsi + d2 * l0;
    }
    for (int k = 0; k < 8; k++) {
        double db = isnan(l) ? db0 : dpsi + d2 * l;
        if (db == 0 || (psi != 0 && (db * r->dir > 0) == (psi > 0))) return NAN; /* not toward the other side */
        double tgt = r->kappa * db * r->dir * pow(r->C / (db * db), 0.125);
        double ln = side_root(0.5 * d2, dpsi, psi - tgt, r->dir);
        if (isnan(ln)) return NAN;
        int done = !isnan(l) && fabs(ln - l) <= 1e-12 * fabs(l);
        l = ln;
        if (done) break;
    }
    return l;
}

/*
 * The seed of the landing segment from the vertex's cubic model with a linear psi: the step that ends at
 * the landing target, the kick from the offsets' sum relation (rho_a + rho_b = psibar lambda^2/4) and
 * d = (lambda/2) u + (lambda^2/8) J H u + (mu/2) n.
 */
static int seed(land *r, const dth_reg_event *ev, double psi, double dpsi, double d2, double rho_a, double lam_last,
                double l_fixed, double *lam, double *mu)
{
    size_t n = r->n, N = r->N, d = N - 1;
    for (size_t j = 0; j < d; j++) r->y[j] = ev->z[j] + ev->zlo[j];
    double l = l_fixed != 0 ? l_fixed : landing_step(r, psi, dpsi, d2);
    if (!(l * r->dir > 0) || !(fabs(l) <= 8 * lam_last)) l = r->dir * lam_last;
    int rc = dth__kick_at(r->model, r->y, r->nv, r->kick);
    double *A = r->gp, H; /* the Hessian in the psi workspace's room (d x d fits it) */
    if (!rc) rc = dth_model_eval(r->model, r->y, DTH_EVAL_H | DTH_EVAL_GRAD | DTH_EVAL_HESS, &H, r->g, A);
    if (rc) return rc;
    double c = 0, pbar = psi + dpsi * l / 2 + d2 * l * l / 8, rho_b = pbar * l * l / 4 - rho_a;
    for (size_t i = 0; i < n; i++) c += r->g[i] * r->nv[i] + r->g[n + 1 + i] * r->nv[n + i];
    double k = c != 0 ? (rho_b - rho_a - dpsi * l * l * l / 24) / c : 0;
    dth__flow_y(n, r->g, r->zb); /* u over y, into zb's room */
    memset(r->d, 0, N * sizeof *r->d);
    for (size_t j = 0; j < d; j++) {
        double ju = 0; /* (J H u)_j over y: q rows H's p rows, p rows minus H's q rows */
        for (size_t m = 0; m < d; m++) ju += dth__dudz(n, A, j, m) * r->zb[m];
        r->d[j] = 0.5 * l * r->zb[j] + 0.125 * l * l * ju;
    }
    for (size_t i = 0; i < n; i++) {
        r->d[i] += 0.5 * k * r->nv[i];
        r->d[n + 1 + i] += 0.5 * k * r->nv[n + i];
    }
    r->d[n] = 0.5 * l;
    *lam = l;
    *mu = k;
    return DTH_OK;
}

/* A segment from the event's vertex closed by `close` (seeded by seed()), and its end vertex in r->zb. */
static int segment(land *r, const dth_reg_event *ev, const dth__kj_close *close, double lam0, double mu0, double *lam,
                   double *mu, double *res, int *its)
{
    *lam = lam0;
    *mu = mu0;
    int rc = dth__kicked_joint(r->model, ev->z, ev->zlo, close, r->d, lam, mu, res, its, r->kj);
    if (rc) return rc;
    if (!(*lam * r->dir > 0)) return DTH_EREFUSED;
    for (size_t j = 0; j < r->N; j++) r->zb[j] = ev->z[j] + (ev->zlo[j] + 2 * r->d[j]);
    return DTH_OK;
}

typedef struct cand {
    int rc;           /* the segment's status (DTH_OK: converged; -1: not computed) */
    int crossed;      /* its end vertex has the other sign of psi */
    double lam, mu, res;
} cand;

/* Candidate k: the segment (its offset d into r->cd + k N), whether it crossed. */
static int candidate(land *r, const dth_reg_event *ev, int k, double psi, double dpsi, double d2, double rho_a,
                     double lam_ref, cand *c, int *its)
{
    size_t N = r->N;
    double lam0, mu0, pb, lk = k ? r->dir * lam_ref / (double)(1 << (k - 1)) : 0;
    dth__kj_close landing = {land_close, r, 0}, fixed = {NULL, NULL, lk};
    int it = 0;
    c->rc = seed(r, ev, psi, dpsi, d2, rho_a, lam_ref, lk, &lam0, &mu0);
    if (!c->rc) c->rc = segment(r, ev, k ? &fixed : &landing, lam0, mu0, &c->lam, &c->mu, &c->res, &it);
    if (!c->rc) c->rc = dth_model_psi(r->model, r->zb, &pb, NULL, r->pw);
    *its += it;
    if (c->rc < 0) return c->rc; /* hard errors end the step */
    if (c->rc) return DTH_OK;
    c->crossed = (pb > 0) != (psi > 0);
    memcpy(r->cd + (size_t)k * N, r->d, N * sizeof *r->d);
    return DTH_OK;
}

/* The reset of candidate k's end vertex onto I = C (exit: the exit branch; else psi's own side). */
static int reset_cand(land *r, const dth_reg_event *ev, int k, int exit, double *jump, int *its)
{
    size_t N = r->N;
    const double *dk = r->cd + (size_t)k * N;
    for (size_t j = 0; j < N; j++) r->zb[j] = ev->z[j] + (ev->zlo[j] + 2 * dk[j]);
    int it = 0, rc = reset(r, r->zb, ev->z[N - 1] + ev->zlo[N - 1], exit, jump, &it);
    *its += it;
    return rc;
}

/*
 * The replaced step. In order, the first that works:
 *   1. the landing segment (converged, crossed, within `bound` times the last ordinary step), reset onto the
 *      exit branch;
 *   2. a segment of the last ordinary step's length, or 1/2, 1/4, 1/8 of it: the longest that does not cross,
 *      reset onto I = C on its own side (the next vertex tries again); then the longest that crosses, reset
 *      onto the exit branch;
 *   3. no reset exists for any of them (the move along n that would put the offset on the level set crosses
 *      psi = 0 first, or does not converge): the first converged one of 1-2 as it is, its end offset the
 *      kicked segment's (flagged like the others; the next step starts from it, and the next crossing
 *      restores C).
 * Refused only if no segment converges at all.
 */
static int apply(void *self, const dth_reg_event *ev, dth_reg_action *act)
{
    land *r = self;
    size_t N = r->N;
    int rc = workspace(r);
    if (rc) return rc;
    r->dir = ev->dir;
    double psi, dpsi, Hp;
    for (size_t j = 0; j + 1 < N; j++) r->y[j] = ev->z[j] + ev->zlo[j];
    rc = dth__model_grad_psi(r->model, r->y, r->gpsi, &psi, &dpsi, r->gp);
    if (!rc) rc = dth_model_eval(r->model, r->y, DTH_EVAL_H, &Hp, NULL, NULL);
    if (rc) return rc;
    /* the last ordinary step: the incoming one, or after a replaced step (or before the first step) the one
     * the integrator aims for (the last ordinary step's, or h) */
    double lam_ref = fabs(ev->in_d && ev->lam_in != 0 ? ev->lam_in : ev->lam_hint);
    if (!(lam_ref > 0)) lam_ref = fabs(ev->lam_in != 0 ? ev->lam_in : ev->plain_lambda);
    double rho_a = ev->z[N - 1] + ev->zlo[N - 1] + Hp;
    if (!(lam_ref > 0) || !isfinite(lam_ref)) {
        act->why = "no step to continue (the integrator gave no step size)";
        return DTH_EREFUSED;
    }
    if (!r->C_fixed) {
        /* a crossing before any ordinary step: the vertex's own step invariant (what the ordinary steps from it
         * keep), else the far-field invariant of the step asked for, else a crossing time scale of that step */
        double I = dth__inv_I(psi, rho_a, dpsi), l2 = lam_ref * lam_ref;
        r->C = isfinite(I) && I > 0 ? I : l2 * l2 * l2 * psi * psi;
        if (!(r->C > 0) || !isfinite(r->C)) r->C = l2 * l2 * l2 * l2 * dpsi * dpsi;
        r->C_fixed = r->C > 0 && isfinite(r->C);
        if (!r->C_fixed) {
            act->why = "psi = psi' = 0 at the first vertex: no step invariant to continue (a start away from psi = 0)";
            return DTH_EREFUSED;
        }
    }
    /* psi'' from psi' at the last two vertices (observe), 0 without: the landing step's quadratic model,
     * which also finds a crossing back through 0 just after a dip (psi grazing 0) */
    double d2 = r->have_prev && r->lam_prev != 0 ? (dpsi - r->dpsi_prev) / r->lam_prev : 0;
    if (!isfinite(d2)) d2 = 0;
    cand c[NCAND];
    for (int k = 0; k < NCAND; k++) c[k].rc = -1;
    int its = 0, its2 = 0, pick = -1, k;
    double *jump = act->jump;
    /* 1. the landing */
    if (dpsi != 0) {
        rc = candidate(r, ev, 0, psi, dpsi, d2, rho_a, lam_ref, &c[0], &its);
        if (rc) return rc;
        if (!c[0].rc && c[0].crossed && fabs(c[0].lam) <= r->bound * lam_ref) {
            rc = reset_cand(r, ev, 0, 1, jump, &its2);
            if (rc < 0) return rc;
            if (!rc) pick = 0;
        }
    }
    /* 2. the fallback segments: the longest that does not cross (own side), then the longest that crosses */
    for (int pass = 0; pass < 2 && pick < 0; pass++)
        for (k = 1; k < NCAND && pick < 0; k++) {
            if (c[k].rc == -1) {
                rc = candidate(r, ev, k, psi, dpsi, d2, rho_a, lam_ref, &c[k], &its);
                if (rc) return rc;
            }
            if (c[k].rc || c[k].crossed != pass) continue;
            rc = reset_cand(r, ev, k, pass, jump, &its2);
            if (rc < 0) return rc;
            if (!rc) pick = k;
        }
    /* 3. no reset: the first converged segment as it is (the landing, then the longest that does not cross,
     * then the longest that crosses) */
    if (pick < 0) {
        if (!c[0].rc && c[0].crossed && fabs(c[0].lam) <= r->bound * lam_ref) pick = 0;
        for (int pass = 0; pass < 2 && pick < 0; pass++)
            for (k = 1; k < NCAND && pick < 0; k++)
                if (!c[k].rc && c[k].crossed == pass) pick = k;
        if (pick < 0) {
            act->why = "no landing segment past psi = 0, and no segment of 1, 1/2, 1/4, 1/8 of the last ordinary "
                       "step converged (an unresolved crossing: a smaller h)";
            return DTH_EREFUSED;
        }
        memset(jump, 0, N * sizeof *jump);
    }
    memcpy(r->d, r->cd + (size_t)pick * N, N * sizeof *r->d);
    double lam = c[pick].lam;
    if (r->clock) { /* the segment's own correction (w = 1: psi ~ 0 at its midpoint), and the windows' so far */
        for (size_t j = 0; j + 1 < N; j++) r->y[j] = ev->z[j] + (ev->zlo[j] + r->d[j]);
        rc = clock_add(r, r->y, lam, 1.0, &act->dt);
        if (rc) return rc;
        if (!r->crossed) act->dt = r->acc;
        r->crossed = 1;
        r->acc = 0;
    }
    r->dpsi_prev = dpsi; /* psi'' at the next vertex from this segment's ends */
    r->lam_prev = lam;
    r->have_prev = 1;
    memcpy(act->d, r->d, N * sizeof *act->d);
    act->what = DTH_REG_REPLACE;
    act->lambda = lam;
    act->residual = c[pick].res;
    act->iters = its + its2;
    act->fresh = 1;
    return DTH_OK;
}

/* The state a checkpoint keeps (all that carries from one step to the next; kappa, bound and clock are
 * parameters, dir is set by each event before use, the rest is workspace): the step invariant C, the
 * clock's accumulator and whether the run has crossed, the last vertex's psi' and the step from it. */
static const dth_field state_fields[] = {
    {"C", offsetof(land, C), DTH_FIELD_F64, DTH_CHECK_NONNEG, 1},
    {"C_fixed", offsetof(land, C_fixed), DTH_FIELD_INT, DTH_CHECK_BOOL, 1},
    {"crossed", offsetof(land, crossed), DTH_FIELD_INT, DTH_CHECK_BOOL, 1},
    {"acc", offsetof(land, acc), DTH_FIELD_F64, DTH_CHECK_FINITE, 1},
    {"have_prev", offsetof(land, have_prev), DTH_FIELD_INT, DTH_CHECK_BOOL, 1},
    {"dpsi_prev", offsetof(land, dpsi_prev), DTH_FIELD_F64, DTH_CHECK_FINITE, 1},
    {"lam_prev", offsetof(land, lam_prev), DTH_FIELD_F64, DTH_CHECK_FINITE, 1},
};

/* After a restore or a rollback: a fixed C is the run's constant (> 0; an unfixed one is overwritten
 * before it is read); the clock's accumulator collects only before the first crossing; only a clock
 * marks a crossing or accumulates (a parameter: an instance without it never has either). */
static int state_loaded(void *self)
{
    const land *r = self;
    if (r->C_fixed && !(r->C > 0)) return -1;
    if (r->crossed && r->acc != 0) return -1;
    if (!r->clock && (r->crossed || r->acc != 0)) return -1;
    return 0;
}

const dth_regularizer_type dth_reg_land = {
    DTH_REG_TYPE_HEAD,
    .name = "land",
    .doc = "raw DTH (symplectic, reversible) wherever it runs; one replaced step per psi = 0 crossing, which lands "
           "just past psi = 0 and resets its end vertex's offset onto the run's step invariant, so the steps after "
           "it continue the run's: energy-exact at every midpoint, keeps quadratic invariants; the replaced step is "
           "neither symplectic nor reversible",
    .params = params,
    .n_params = sizeof params / sizeof params[0],
    .create = create,
    .destroy = destroy,
    .apply = apply,
    .observe = observe,
    .fields = state_fields,
    .n_fields = sizeof state_fields / sizeof state_fields[0],
    .state_loaded = state_loaded,
};
