/* SPDX-License-Identifier: MIT */
/*
 * Benchmark (not a test): what a step does to the vertex offset rho = H(z) = wp + H_phys (paper,
 * section 7; docs/regularization.md, "What is proved about reversible crossings"). For one step
 * z_a -> z_b of the extended map (z = (q, t, p, wp)) it prints
 *   f = d rho_b / d rho_a   with rho_a moved through wp_a alone (q_a, t_a, p_a held),
 *   det M and |M^T J M - J|_F / |M|_F^2,   M = d z_b / d z_a,
 * for
 *   A. ordinary DTH steps of the pendulum (omega^2 = 1) from the vertex (q, p) = (1.7, 2.0), whose wp is
 *      chosen so that the step is lambda (vertex start), at s = -(psi'/psi) lambda = 0.17, 0.84, 1.00,
 *      1.15 (the paper's Theorem EU_2: the physical root exists up to s = 6/5), next to the cubic
 *      model's f = (1 - s)/(1 - s/2); M from dth_integrator_tangent;
 *   B. the replaced steps of `land` at four crossings of the rotating pendulum (q0 = 0, p0 = 2.2,
 *      h = 0.05, midpoint start; from the second crossing on), M by central differences (eps = 1e-7
 *      relative): each perturbed step from the state the run had at that vertex (the run replayed from
 *      the start, then dth_integrator_set_vertex), so the regularizer's own state is the run's (after
 *      set_vertex it scales to the lambda given, the incoming step's). A crossing whose probe fails is
 *      skipped, and counted;
 *   C. `prescribed` (alpha = 0) on the same orbit: its steps at four crossings (psibar ~ 0) and the one
 *      with the largest psi, M the same way.
 * Usage: bench_offset_map
 */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include "dth/dth.h"

enum { N = 4, NX = 4, NTRY = 16 }; /* the pendulum's extended dimension; crossings measured in B and C, tried */

static dth_model *pendulum(void)
{
    dth_model *m = NULL;
    char err[256];
    if (dth_model_new(&dth_model_pendulum, NULL, 0, 1, NULL, &m, err, sizeof err)) {
        fprintf(stderr, "%s\n", err);
        exit(1);
    }
    return m;
}

/* rho = wp + H_phys and its gradient over the extended z (q, t, p, wp). */
static double rho(const dth_model *m, const double *z, double *g)
{
    double H, gy[3];
    if (dth_model_eval(m, z, DTH_EVAL_H | DTH_EVAL_GRAD, &H, gy, NULL)) exit(1);
    if (g) {
        memcpy(g, gy, 3 * sizeof *g);
        g[3] = 1;
    }
    return z[3] + H;
}

static double det4(const double *A)
{
    double a[N * N], d = 1;
    memcpy(a, A, sizeof a);
    for (int c = 0; c < N; c++) {
        int p = c;
        for (int r = c + 1; r < N; r++)
            if (fabs(a[r * N + c]) > fabs(a[p * N + c])) p = r;
        if (a[p * N + c] == 0) return 0;
        if (p != c) {
            for (int k = 0; k < N; k++) {
                double t = a[c * N + k];
                a[c * N + k] = a[p * N + k];
                a[p * N + k] = t;
            }
            d = -d;
        }
        d *= a[c * N + c];
        for (int r = c + 1; r < N; r++) {
            double l = a[r * N + c] / a[c * N + c];
            for (int k = c; k < N; k++) a[r * N + k] -= l * a[c * N + k];
        }
    }
    return d;
}

/* |M^T J M - J|_F / |M|_F^2, J pairing q with p and t with wp. */
static double symp_defect(const double *M)
{
    double def = 0, mm = 0;
    for (int a = 0; a < N; a++)
        for (int b = 0; b < N; b++) {
            double s = 0;
            for (int i = 0; i < 2; i++) s += M[i * N + a] * M[(i + 2) * N + b] - M[(i + 2) * N + a] * M[i * N + b];
            double J = (b == a + 2) ? 1.0 : (a == b + 2 ? -1.0 : 0.0);
            def += (s - J) * (s - J);
            mm += M[a * N + b] * M[a * N + b];
        }
    return sqrt(def) / mm;
}

/* f = grad rho(z_b) . M e_wp */
static double f_of(const dth_model *m, const double *zb, const double *M)
{
    double g[N], f = 0;
    rho(m, zb, g);
    for (int i = 0; i < N; i++) f += g[i] * M[i * N + 3];
    return f;
}

/* ---- A: ordinary steps ---- */
static void part_ordinary(void)
{
    dth_model *m = pendulum();
    double q = 1.7, p = 2.0, y[3] = {q, 0, p}, psi, dpsi, *w = calloc(dth_model_work_size(m) + 1, sizeof *w);
    if (!w || dth_model_psi(m, y, &psi, &dpsi, w)) exit(1);
    printf("### A. Ordinary DTH steps, pendulum, vertex (q, p) = (1.7, 2.0): psi = %.4f, psi' = %.4f\n\n", psi, dpsi);
    printf("| lambda | s = -(psi'/psi) lambda | f = d rho_b / d rho_a | (1 - s)/(1 - s/2) | det M | \\|M^T J M - J\\| / \\|M\\|^2 | branch |\n");
    printf("|---|---|---|---|---|---|---|\n");
    const double ss[] = {0.17, 0.5, 0.84, 1.00, 1.05, 1.10, 1.15};
    for (size_t k = 0; k < sizeof ss / sizeof ss[0]; k++) {
        double lam = ss[k] * psi / fabs(dpsi);
        dth_options o;
        dth_options_default(&o);
        o.h = lam;
        o.start = DTH_START_VERTEX;
        dth_integrator *it = NULL;
        dth_step_info inf;
        double M[N * N];
        if (dth_integrator_new(m, &o, &it) || dth_integrator_start(it, &q, &p, 0)) exit(1);
        int rc = dth_integrator_step(it, &inf);
        if (!rc) rc = dth_integrator_tangent(it, M);
        if (rc) {
            printf("| %.4f | %.2f | %s | | | | |\n", lam, ss[k], dth_status_name(rc));
        } else {
            const double *zb = dth_integrator_vertex(it);
            double s = -(dpsi / psi) * inf.lambda;
            printf("| %.4f | %.3f | %+.4f | %+.4f | %.6f | %.1e | %s |\n", inf.lambda, s, f_of(m, zb, M), (1 - s) / (1 - s / 2), det4(M),
                   symp_defect(M), dth_branch_name(inf.branch));
        }
        dth_integrator_free(it);
    }
    free(w);
    dth_model_free(m);
    printf("\n");
}

/* ---- B, C: replaced steps by central differences ---- */

typedef struct runner {
    dth_model *m;
    dth_regularizer *r;
    dth_integrator *it;
} runner;

static void open_run(runner *x, const dth_regularizer_type *type)
{
    static const dth_kv a0[] = {{"alpha", "0"}};
    x->m = pendulum();
    char err[256];
    int pres = type == &dth_reg_prescribed;
    if (dth_regularizer_new(type, pres ? a0 : NULL, pres, x->m, NULL, &x->r, err, sizeof err)) {
        fprintf(stderr, "%s\n", err);
        exit(1);
    }
    dth_options o;
    dth_options_default(&o);
    o.h = 0.05;
    o.regularizer = x->r;
    if (pres) o.branch_check = 0;
    double q = 0, p = 2.2;
    if (dth_integrator_new(x->m, &o, &x->it) || dth_integrator_start(x->it, &q, &p, 0)) exit(1);
}

static void close_run(runner *x)
{
    dth_integrator_free(x->it);
    dth_regularizer_free(x->r);
    dth_model_free(x->m);
}

/* The vertex before step k (1-based) of a fresh run, its incoming step, and step k's flags. */
static int replay(const dth_regularizer_type *type, long k, runner *x, double *za, double *lam)
{
    open_run(x, type);
    dth_step_info inf;
    for (long j = 1; j < k; j++)
        if (dth_integrator_step(x->it, &inf)) return -1;
    memcpy(za, dth_integrator_vertex(x->it), N * sizeof *za);
    *lam = dth_integrator_lambda(x->it);
    return 0;
}

/* M of step k by central differences; *flags: the flags every perturbed step shared (-1: they differed). */
static int fd_map(const dth_regularizer_type *type, long k, double *za, double *zb, double *M, int *flags)
{
    runner x;
    double lam, z0[N], zz[N], zp[N], zm[N];
    dth_step_info inf;
    if (replay(type, k, &x, z0, &lam)) return -1;
    memcpy(za, z0, sizeof z0);
    if (dth_integrator_step(x.it, &inf)) return -1;
    memcpy(zb, dth_integrator_vertex(x.it), N * sizeof *zb);
    *flags = (int)inf.flags;
    close_run(&x);
    for (int j = 0; j < N; j++) {
        double e = 1e-7 * fmax(1.0, fabs(z0[j]));
        for (int s = 0; s < 2; s++) {
            if (replay(type, k, &x, zz, &lam)) return -1;
            zz[j] += s ? -e : e;
            int rc = dth_integrator_set_vertex(x.it, zz, lam);
            if (!rc) rc = dth_integrator_step(x.it, &inf);
            if (rc) {
                close_run(&x);
                return -1;
            }
            if ((int)inf.flags != *flags) *flags = -1;
            memcpy(s ? zm : zp, dth_integrator_vertex(x.it), N * sizeof zp[0]);
            close_run(&x);
        }
        for (int i = 0; i < N; i++) M[i * N + j] = (zp[i] - zm[i]) / (2 * e);
    }
    return 0;
}

static void part_replaced(const dth_regularizer_type *type, const char *title)
{
    /* the step numbers of the crossings from the second on, and (prescribed) one step far from psi = 0 */
    runner x;
    open_run(&x, type);
    long ks[NTRY + 1];
    int nk = 0, nc = 0;
    double psimax = -1;
    long kfar = 0;
    dth_step_info inf;
    double *w = calloc(dth_model_work_size(x.m) + 1, sizeof *w);
    for (long k = 1; k < 100000 && nk < NTRY; k++) {
        if (dth_integrator_step(x.it, &inf)) break;
        double psi;
        if (dth_model_psi(x.m, dth_integrator_midpoint(x.it), &psi, NULL, w)) exit(1);
        if (nc >= 1 && psi > psimax && !(inf.flags & DTH_STEP_CROSSING)) {
            psimax = psi;
            kfar = k;
        }
        if ((inf.flags & DTH_STEP_CROSSING) && ++nc >= 2) ks[nk++] = k;
    }
    free(w);
    close_run(&x);
    printf("### %s\n\n", title);
    printf("| step | t | psi at the midpoint | f = d rho_b / d rho_a | det M | \\|M^T J M - J\\| / \\|M\\|^2 | flags |\n");
    printf("|---|---|---|---|---|---|---|\n");
    int shown = 0, skipped = 0;
    for (int i = 0; i <= nk && shown < NX + (type == &dth_reg_prescribed); i++) {
        long k = i < nk ? ks[i] : kfar;
        if (i == nk && type != &dth_reg_prescribed) break;
        if (i < nk && shown >= NX) continue;
        double za[N], zb[N], M[N * N], psi, zbar[N];
        int flags;
        if (fd_map(type, k, za, zb, M, &flags)) {
            skipped++;
            continue;
        }
        dth_model *m = pendulum();
        double *w2 = calloc(dth_model_work_size(m) + 1, sizeof *w2);
        runner y;
        double z0[N], lam;
        if (replay(type, k, &y, z0, &lam) || dth_integrator_step(y.it, &inf)) exit(1);
        memcpy(zbar, dth_integrator_midpoint(y.it), sizeof zbar);
        close_run(&y);
        if (dth_model_psi(m, zbar, &psi, NULL, w2)) exit(1);
        char fl[64] = "";
        if (flags < 0) snprintf(fl, sizeof fl, "differ between the perturbed steps");
        else
            snprintf(fl, sizeof fl, "%s%s%s%s", flags & DTH_STEP_REGULARIZED ? "REGULARIZED " : "", flags & DTH_STEP_CROSSING ? "CROSSING " : "",
                     flags & DTH_STEP_RESET ? "RESET " : "", flags & DTH_STEP_CLOCK ? "CLOCK" : "");
        printf("| %ld | %.4f | %+.3e | %+.4f | %+.2e | %.2f | %s |\n", k, za[1], psi, f_of(m, zb, M), det4(M), symp_defect(M), fl);
        shown++;
        free(w2);
        dth_model_free(m);
    }
    if (skipped)
        printf("\n%d crossing(s) before these not probed: a perturbed step from it failed.\n", skipped);
    printf("\n");
}

int main(void)
{
    printf("# bench_offset_map: f = d rho_b / d rho_a (rho = wp + H_phys, moved through wp), det M, symplectic defect\n\n");
    part_ordinary();
    part_replaced(&dth_reg_land, "B. land's replaced steps, rotating pendulum q0 = 0, p0 = 2.2, h = 0.05 (four crossings from the second on; central differences)");
    part_replaced(&dth_reg_prescribed, "C. prescribed (alpha = 0), same orbit: the steps across psi = 0 (crossings 2-5) and the step with the largest psi (central differences)");
    return 0;
}
