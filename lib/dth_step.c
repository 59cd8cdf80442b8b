/* SPDX-License-Identifier: MIT */
/*
 * The DTH stepper (paper, Theorem "DTH Equations"): one step is predict -> Newton -> candidate ->
 * policy (policy.c: the branch test and the regularizer) -> commit, and nothing else changes the
 * step state. Also its workspace, accessors, tangent map and checkpoint sections: the
 * dth__stepper_dth entry of the stepper table (stepper.h).
 */
#include <math.h>
#include <stdio.h>
#include <string.h>
#include "dth_kernels.h"
#include "stepper.h"

void dth__seterr(dth__dth *it, const char *fmt, ...)
{
    va_list ap;
    va_start(ap, fmt);
    vsnprintf(it->errmsg, sizeof it->errmsg, fmt, ap);
    va_end(ap);
}

/* The full search's polisher (policy.h: dth__polish_fn): the step's own Newton from the vertex. */
static int polish(void *ctx, double lam, const double *d0, double *lam_out, double *res, double *zbar)
{
    dth__dth *it = ctx;
    dth__solution sol;
    if (dth__newton(it, lam, d0, it->opt.max_iter, &sol) != DTH_OK) return 0;
    *lam_out = sol.lambda;
    *res = sol.residual;
    memcpy(zbar, it->zb, it->N * sizeof *zbar);
    return 1;
}

int dth__dth_polish(void *core, double lam, const double *d0, double *lam_out, double *res, double *zbar)
{
    return polish(core, lam, d0, lam_out, res, zbar);
}

static void destroy(void *s)
{
    dth__dth *it = s;
    if (!it) return;
    dth__policy_free(&it->pol);
    dth_free(it->alloc, it->block);
    dth_free(it->alloc, it->piv);
    dth__band_free(it->band, it->alloc);
    dth_free(it->alloc, it);
}

/* The workspace: one block of doubles, carved into the state's vectors and the scratch. */
static int carve(dth__dth *it, int dense)
{
    size_t N = it->N, d = it->d, m = (size_t)it->m, nd = 0, rv = it->rev;
    size_t sizes[] = {N, N, N, N, N, N, N, N, N, N, d, (size_t)dense * d * d, N, d, (size_t)dense * m * m, m, m, m,
                      dth_model_work_size(it->model), (size_t)dense * m * N,
                      dth_model_get_type(it->model)->hdiff ? 0 : 2 * d, N, rv * m, rv * N, rv * N, rv * N, rv * N, rv * N, rv * N};
    /* hwork: dth__model_hdiff's rule only; xlo, yc, ydel, ygl, vc, yprev, vcsrc: the reversible finish only */
    for (size_t i = 0; i < sizeof sizes / sizeof sizes[0]; i++) nd += sizes[i];
    it->block = dth_calloc(it->alloc, nd, sizeof(double));
    it->piv = dth_calloc(it->alloc, 2 * m, sizeof(int));
    if (!it->block || !it->piv) return DTH_ENOMEM;
    double *p = it->block;
    double **slots[] = {&it->st.z, &it->st.zlo, &it->st.zbar, &it->st.dprev, &it->st.dprev2, &it->st.dprev3, &it->dnew, &it->znew, &it->znewlo,
                        &it->zb, &it->grad, &it->hess, &it->u, &it->ybar, &it->A, &it->F, &it->x, &it->dx,
                        &it->work, &it->B, &it->hwork, &it->zblo, &it->xlo, &it->yc, &it->ydel, &it->ygl, &it->vc, &it->yprev, &it->vcsrc};
    for (size_t i = 0; i < sizeof slots / sizeof slots[0]; i++) {
        *slots[i] = sizes[i] ? p : NULL;
        p += sizes[i];
    }
    it->act = it->piv + m;
    return DTH_OK;
}

static int create(const dth_model *model, const dth_options *opt, void **out)
{
    size_t n = dth_model_dof(model);
    dth_linsolve kind = opt->linsolve;
    int auton = dth_model_get_info(model)->autonomous;
    int dense = !dth__linsolve_find(kind)->banded; /* banded: no O(n^2) buffers */
    dth__dth *it = dth_calloc(opt->alloc, 1, sizeof *it);
    if (!it) return DTH_ENOMEM;
    it->model = model;
    it->opt = *opt;
    it->alloc = opt->alloc;
    it->kind = kind;
    it->n = n;
    it->N = 2 * n + 2;
    it->d = 2 * n + 1;
    it->auton = auton;
    it->m = (int)(auton ? 2 * n + 1 : 2 * n + 3);
    it->rev = opt->finish == DTH_FINISH_REVERSIBLE; /* the reversible finish (dense only: dth_options_check) */
    int rc = carve(it, dense);
    if (!rc && !dense) {
        it->hess = it->A = it->B = NULL;
        rc = dth__band_new(model, kind == DTH_LINSOLVE_BANDED, it->alloc, &it->band);
    }
    if (!rc) rc = dth__policy_init(&it->pol, model, opt, polish, it, it->errmsg, sizeof it->errmsg);
    if (rc) {
        destroy(it);
        return rc;
    }
    it->nsmall = auton && dense && dth__lu_small(kind, it->m) && n <= 3 ? (int)n : 0;
    it->small_schur = it->nsmall && kind != DTH_LINSOLVE_SMALL_LU && dth_model_get_info(model)->separable;
    dth__newton_setup(it);
    it->meval = dth_model_get_type(model)->eval;
    it->mhdiff = dth_model_get_type(model)->hdiff;
    it->mself = dth__model_self(model);
    /* unknowns: the z-components that Newton solves for, then lambda */
    int a = 0;
    for (size_t j = 0; j < it->N; j++) {
        if (it->auton && (j == it->n || j == it->N - 1)) continue; /* t and wp in closed form */
        it->act[a++] = (int)j;
    }
    it->st.dir = opt->h > 0 ? 1.0 : -1.0;
    it->st.lam_hint = opt->h;
    it->st.h = opt->h;
    snprintf(it->errmsg, sizeof it->errmsg, "no error");
    *out = it;
    return DTH_OK;
}

void dth__view_vertex(const dth__dth *it, dth__view *v)
{
    /* H_k: the compensated finish's carried offset (not the reversible finish's: its rho is H at the
     * coarsened vertex, 2^-28 of the scale away) */
    double hk = it->opt.finish == DTH_FINISH_COMPENSATED ? it->st.rho + it->st.rholo : NAN;
    *v = (dth__view){it->model, it->n, it->N, it->auton, it->st.z, it->st.zlo, it->st.lam, it->st.lam_hint,
                     it->st.dir, it->st.have_prev, it->st.dprev, it->st.steps, hk, DTH_OK, NAN, NAN, 0, NULL};
}

/* The predictor of the next step: quadratic extrapolation of (d, lambda) over the last three
 * ordinary steps, else the reflection of the last offset (the next midpoint offset mirrors it). */
static const double *predict(dth__dth *it, double *lam0)
{
    size_t N = it->N;
    *lam0 = it->st.lam;
    if (it->st.nhist < 3) return it->st.dprev;
    double l = 3 * (it->st.lam - it->st.lam2) + it->st.lam3;
    if (!(l * it->st.dir > 0) || !(fabs(l) <= 2 * fabs(it->st.lam)) || !(2 * fabs(l) >= fabs(it->st.lam))) return it->st.dprev;
    double *d = it->znewlo;
    for (size_t j = 0; j < N; j++) d[j] = 3 * (it->st.dprev[j] - it->st.dprev2[j]) + it->st.dprev3[j];
    *lam0 = l;
    return d;
}

/* The seed of a step without history: the cubic model's root near lam_hint, along the flow. */
static int seed(dth__dth *it, double *lam0, const double **d0)
{
    size_t N = it->N;
    double Hphys, psi, dpsi;
    int rc = dth_model_eval(it->model, it->st.z, DTH_EVAL_H | DTH_EVAL_GRAD, &Hphys, it->grad, NULL);
    if (!rc) rc = dth_model_psi(it->model, it->st.z, &psi, &dpsi, it->work);
    if (rc) {
        dth__seterr(it, "model evaluation failed at the vertex");
        return rc;
    }
    *lam0 = dth__cubic_predict(it->st.z[N - 1] + Hphys, psi, dpsi, it->st.lam_hint);
    dth__flow_z(it->n, it->grad, it->u);
    for (size_t j = 0; j < N; j++) it->znewlo[j] = 0.5 * *lam0 * it->u[j];
    *d0 = it->znewlo;
    return DTH_OK;
}

/* Midpoint start: zbar_0 and lambda = h solve the step equations exactly. */
static int step_exact(dth__dth *it, dth_step_info *info)
{
    size_t N = it->N;
    double lam = it->st.lam_hint;
    unknowns_n(it, 0, it->st.dprev, lam);
    int rc;
    if (it->rev) {
        /* the start's offset again (exact_offset_rev is deterministic: dhi is dprev), with its low
         * part for the commit; the model left at the coarse point for the new offset */
        double *dhi = it->dnew, *dlo = it->yprev; /* scratch until the commit */
        rc = dth__exact_offset_rev(it, it->st.zbar, lam, dhi, dlo);
        if (!rc) rc = dth_model_eval(it->model, it->st.zbar, DTH_EVAL_H, &it->Hphys, NULL, NULL);
        for (int a = 0; a < it->m - 1; a++) it->xlo[a] = dlo[it->act[a]];
    } else {
        memcpy(it->zb, it->st.zbar, N * sizeof *it->zb);
        rc = dth_model_eval(it->model, it->zb, DTH_EVAL_H | DTH_EVAL_GRAD, &it->Hphys, it->grad, NULL);
    }
    if (rc) {
        dth__seterr(it, "model evaluation failed at the first (exact) midpoint");
        return rc;
    }
    rc = dth__commit(it, lam, 0);
    if (rc) return rc;
    it->st.nhist = 1;
    it->st.pending_exact = 0;
    info->lambda = lam;
    info->iters = 0;
    info->residual = fabs(it->st.zbar[N - 1] + it->Hphys);
    info->branch = DTH_BRANCH_EXACT;
    return DTH_OK;
}

/* The candidate's offset zbar - z_k from the unknowns (into the view, it->dnew's scratch twin). */
static void candidate(dth__dth *it, const dth__solution *sol, int rc, dth__view *v)
{
    double *dd = it->u; /* scratch until the commit */
    v->status = rc;
    v->lambda = sol->lambda;
    v->residual = sol->residual;
    v->iters = sol->iters;
    v->d = NULL;
    if (rc) return;
    memset(dd, 0, it->N * sizeof *dd);
    for (int a = 0; a < it->m - 1; a++) dd[it->act[a]] = it->x[a];
    if (it->auton) dd[it->n] = 0.5 * sol->lambda;
    v->d = dd;
}

/* Commit the policy's decision (a regularizer's segment or the candidate) and record the step. */
static int commit_decision(dth__dth *it, const dth__decision *dec, const dth__solution *sol, dth_branch br,
                           int psi_sign_new, dth_step_info *info)
{
    int replace = dec->verdict == DTH__REPLACE;
    double lam_last = it->st.have_prev ? it->st.lam : it->st.lam_hint; /* the last step a fresh start aims at */
    if (replace) dth__set_solution(it, dec->d, dec->lambda);
    if (replace && it->rev && dec->dlo) dth__set_solution_lo(it, dec->dlo);
    it->jump = replace ? dec->jump : NULL;
    int rc = dth__commit(it, dec->lambda, replace);
    it->jump = NULL;
    if (rc) return rc;
    if (replace && dec->fresh) { /* the next step from the last ordinary step's size, without this segment */
        it->st.have_prev = 0;
        it->st.nhist = 0;
        it->st.lam_hint = lam_last;
    }
    if (dec->dt != 0) { /* the regularizer's clock correction of the new vertex's time */
        size_t n = it->n;
        it->st.z[n] = two_sum(it->st.z[n], it->st.zlo[n] + dec->dt, &it->st.zlo[n]);
        info->flags |= DTH_STEP_CLOCK;
    }
    info->residual = replace ? dec->residual : sol->residual;
    info->branch = replace ? DTH_BRANCH_REG : br;
    info->flags |= dec->flags;
    info->lambda = dec->lambda;
    if (it->pol.reg) dth__policy_commit(&it->pol, psi_sign_new);
    return DTH_OK;
}

/* The branch test's RESEED: solve again from the root the full search found and check that Newton
 * polished it (sol and rc then describe it). */
static int reseed(dth__dth *it, const dth__decision *dec, const dth__view *v, dth__solution *sol)
{
    double want = dec->lambda;
    int nr = dth__newton(it, want, dec->d, it->opt.max_iter, sol);
    if (nr) return nr;
    if (fabs(sol->lambda - want) > 1e-6 * fabs(want)) {
        dth__seterr(it, "the physical root %.17g did not polish (Newton went to %.17g)", want, sol->lambda);
        return DTH_ENOCONV;
    }
    dth__policy_took(&it->pol, dec->psi, v->steps);
    return DTH_OK;
}

/* An ordinary step: predict -> Newton -> candidate -> the policy -> commit. */
static int step_ordinary(dth__dth *it, dth_step_info *info)
{
    dth__view v;
    dth__view_vertex(it, &v);
    dth__decision dec;
    int pre = 0, psi_new = 0, rc;
    if (dth__policy_replaces_all(&it->pol)) {
        /* a regularizer that replaces every step: no ordinary step unless it keeps one */
        rc = dth__policy_pre(&it->pol, &v, &dec, &psi_new);
        info->iters = dec.iters;
        if (rc) return rc;
        if (dec.verdict == DTH__REPLACE) return commit_decision(it, &dec, NULL, DTH_BRANCH_REG, psi_new, info);
        pre = 1;
    }
    int pre_iters = info->iters;
    double lam0;
    const double *d0;
    if (it->st.have_prev) d0 = predict(it, &lam0);
    else if ((rc = seed(it, &lam0, &d0)) != 0) return rc;
    dth__solution sol = {NAN, NAN, 0};
    rc = dth__newton(it, lam0, d0, it->opt.max_iter, &sol);
    int iters0 = pre_iters + sol.iters; /* the first solve's: the record of a step the regularizer was asked about */
    info->iters = iters0;
    info->residual = sol.residual;
    /* which root: Newton's if physical, else the physical root ahead, else a status */
    candidate(it, &sol, rc, &v);
    rc = dth__policy_branch(&it->pol, &v, &dec);
    dth_branch br = dec.branch;
    if (!rc && dec.verdict == DTH__RESEED) rc = reseed(it, &dec, &v, &sol);
    candidate(it, &sol, rc, &v);
    if (!it->pol.reg) {
        if (rc) {
            if (rc == DTH_ENOROOT && isfinite(sol.lambda)) info->lambda = sol.lambda;
            return rc;
        }
        info->iters = sol.iters;
        dec = (dth__decision){.verdict = DTH__TAKE, .lambda = sol.lambda};
        return commit_decision(it, &dec, &sol, br, it->pol.st.psi_sign, info);
    }
    /* psi = 0 crossings: the regularizer */
    rc = dth__policy_cross(&it->pol, &v, pre, &dec, &psi_new);
    /* the record counts the first solve's iterations where the regularizer was asked (or a step
     * failed before it), else the root's own solve's */
    info->iters = dec.asked ? iters0 + dec.iters : rc ? iters0 : pre_iters + sol.iters;
    if (rc) return rc;
    return commit_decision(it, &dec, &sol, br, psi_new, info);
}

/* One step, atomic: on failure the step state, the policy's and the regularizer's are as before. */
static int step(void *s, dth_step_info *info)
{
    dth__dth *it = s;
    dth__state saved = it->st;
    dth__policy_state psaved = it->pol.st;
    double *dnew = it->dnew;
    dth__policy_begin(&it->pol);
    it->errmsg[0] = '\0'; /* the message describes this step */
    int rc = it->st.pending_exact ? step_exact(it, info) : step_ordinary(it, info);
    if (!rc) {
        memcpy(it->errmsg, "no error", sizeof "no error");
        return DTH_OK;
    }
    if (!it->errmsg[0]) snprintf(it->errmsg, sizeof it->errmsg, "%s", dth_strerror(rc));
    it->st = saved;
    it->dnew = dnew;
    dth__policy_rollback(&it->pol, &psaved);
    return rc;
}

static int tangent(void *s, double *M)
{
    dth__dth *it = s;
    if (!it->st.fact_valid) return DTH_EINVAL; /* no step yet, or a regularizer's step */
    return dth__tangent(it, M);
}

static const double *vertex(const void *s) { return ((const dth__dth *)s)->st.z; }
static const double *midpoint(const void *s)
{
    const dth__dth *it = s;
    return it->st.have_mid ? it->st.zbar : NULL;
}
static double lambda(const void *s) { return ((const dth__dth *)s)->st.lam; }
static double direction(const void *s) { return ((const dth__dth *)s)->st.dir; }
static double energy(const void *s)
{
    const dth__dth *it = s;
    return -(it->st.z[it->N - 1] + it->st.zlo[it->N - 1]);
}
static long steps(const void *s) { return ((const dth__dth *)s)->st.steps; }
static int order(const void *s) { return ((const dth__dth *)s)->opt.order; }
static const char *errmsg(const void *s) { return ((const dth__dth *)s)->errmsg; }

/* ---- checkpoint sections: the step state, the policy's; the options that change the steps ---- */

#define STATE_ENTRY(name, kind, check, doc) DTH__FIELD(dth__state, name, kind, check),
static const dth__field state_fields[] = {DTH__STATE_FIELDS(STATE_ENTRY)};
#undef STATE_ENTRY
#define POLICY_ENTRY(name, kind, check, doc) DTH__FIELD(dth__policy_state, name, kind, check),
static const dth__field policy_fields[] = {DTH__POLICY_FIELDS(POLICY_ENTRY)};
#undef POLICY_ENTRY

static size_t sections(void *s, dth__section *out)
{
    dth__dth *it = s;
    out[0] = (dth__section){"state", state_fields, sizeof state_fields / sizeof state_fields[0], &it->st, it->N};
    out[1] = (dth__section){"policy", policy_fields, sizeof policy_fields / sizeof policy_fields[0], &it->pol.st, it->N};
    return 2;
}

/* The options a restored run must share with the saved one: they change the steps. (The start
 * mode, explicit wp and h act at the start only; h as it stands is state.) */
typedef struct optv {
    long branch_check; /* a root finder is attached (banded models have none) */
    long finish, max_iter, order;
    long linsolve;     /* the solver in use (AUTO resolved) */
    double K;
} optv;
static const dth__field opt_fields[] = {
    DTH__FIELD(optv, branch_check, LONG, ANY), DTH__FIELD(optv, finish, LONG, ANY), DTH__FIELD(optv, max_iter, LONG, ANY),
    DTH__FIELD(optv, order, LONG, ANY),        DTH__FIELD(optv, linsolve, LONG, ANY), DTH__FIELD(optv, K, F64, ANY),
};
_Static_assert(sizeof(optv) <= 64, "options_section's scratch");

static void options_section(const void *s, dth__section *out, void *scratch)
{
    const dth__dth *it = s;
    optv *o = scratch;
    *o = (optv){it->pol.rf != NULL, it->opt.finish, it->opt.max_iter, it->opt.order, (long)it->kind, it->opt.K};
    *out = (dth__section){"options", opt_fields, sizeof opt_fields / sizeof opt_fields[0], o, 0};
}

static struct dth_regularizer *regularizer(const void *s) { return ((const dth__dth *)s)->pol.reg; }

/* After a restore: the reversible finish's coarse-vertex cache is stale. */
static void restored(void *s)
{
    dth__dth *it = s;
    if (it->vcsrc) memset(it->vcsrc, 0xff, it->N * sizeof *it->vcsrc);
    snprintf(it->errmsg, sizeof it->errmsg, "no error");
}

const dth__stepper_type dth__stepper_dth = {
    .name = "dth",
    .doc = "the DTH step: symplectic, energy exact at every midpoint, quadratic momenta exact at vertices; "
           "the step lambda is solved for (order 2)",
    .create = create,
    .destroy = destroy,
    .start = dth__dth_start,
    .set_vertex = dth__dth_set_vertex,
    .step = step,
    .reverse = dth__dth_reverse,
    .vertex = vertex,
    .midpoint = midpoint,
    .lambda = lambda,
    .direction = direction,
    .energy = energy,
    .steps = steps,
    .order = order,
    .errmsg = errmsg,
    .tangent = tangent,
    .midpoints = 1,
    .sections = sections,
    .options_section = options_section,
    .regularizer = regularizer,
    .restored = restored,
    .consistent = dth__dth_consistent,
};
