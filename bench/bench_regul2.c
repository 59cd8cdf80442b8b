/* SPDX-License-Identifier: MIT */
/*
 * Benchmark (not a test): the "prescribed" regularizer (every step a kicked segment with the step
 * lambda = arc/|u(zbar)|^alpha set at its own midpoint; paper, section 7) against the open targets of
 * docs/regularization.md: 10^4 pendulum revolutions and the phase order, 10^3 Kepler orbits at
 * e = 0.9 / 0.99 (energy, L, precession of omega), a 2-D chain through psi = 0, round trips through
 * >= 10 crossings, step ratio at crossings, tangent-map defect, kick size against h, cost per step;
 * the reversible finish (integrator.reversible = yes): round trips and cost per step beside the
 * compensated default.
 * Usage: bench_regul2 [scale] [reversible]   (scale 1: the doc's figures, about a minute; 0.1: a quick
 * look; a second argument "reversible": that section alone)
 */
#include <float.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>
#include <gsl/gsl_sf_ellint.h>
#include "dth/dth.h"

#define PI 3.14159265358979323846
#define MAXN 64

static double now(void)
{
    struct timespec ts;
    clock_gettime(CLOCK_MONOTONIC, &ts);
    return (double)ts.tv_sec + 1e-9 * (double)ts.tv_nsec;
}

typedef struct problem {
    const char *name;
    const dth_model_type *type;
    dth_kv mkv[4];
    size_t nmkv, n;
    double q0[MAXN], p0[MAXN], h;
    dth_start start;
    dth_kv rkv[3]; /* regularizer parameters */
    size_t nrkv;
    const dth_regularizer_type *reg; /* NULL: raw DTH */
    int no_branch_check;             /* 1: dth_options.branch_check = 0 */
    int reversible;                  /* 1: dth_options.finish = DTH_FINISH_REVERSIBLE */
} problem;

typedef struct run_out {
    long steps, crossings, kept;
    int status;
    double t_end, energy, wp_change, L_err, max_ratio, max_ratio_cross, omega_drift, secs, q_end, psi_min, psi_max;
} run_out;

typedef struct ctx {
    dth_model *m;
    dth_regularizer *r;
    dth_integrator *it;
    size_t N;
} ctx;

static ctx open_pb(const problem *pb)
{
    ctx c = {0};
    char err[256];
    if (dth_model_new(pb->type, pb->nmkv ? pb->mkv : NULL, pb->nmkv, pb->n, NULL, &c.m, err, sizeof err) ||
        (pb->reg && dth_regularizer_new(pb->reg, pb->rkv, pb->nrkv, c.m, NULL, &c.r, err, sizeof err))) {
        fprintf(stderr, "%s: %s\n", pb->name, err);
        exit(1);
    }
    dth_options o;
    dth_options_default(&o);
    o.h = pb->h;
    o.start = pb->start;
    o.regularizer = c.r;
    if (pb->no_branch_check) o.branch_check = 0;
    if (pb->reversible) o.finish = DTH_FINISH_REVERSIBLE;
    if (dth_integrator_new(c.m, &o, &c.it) || dth_integrator_start(c.it, pb->q0, pb->p0, 0.0)) {
        fprintf(stderr, "%s: cannot start\n", pb->name);
        exit(1);
    }
    c.N = dth_integrator_dim(c.it);
    return c;
}

static void close_pb(ctx *c)
{
    dth_integrator_free(c->it);
    dth_regularizer_free(c->r);
    dth_model_free(c->m);
}

/* |wp + H_phys(zbar)| relative to the size of H's terms at the midpoint. */
static double midpoint_energy(const dth_model *m, const double *zb, size_t N)
{
    double H, g[2 * MAXN + 2];
    if (dth_model_eval(m, zb, DTH_EVAL_H | DTH_EVAL_GRAD, &H, g, NULL)) return INFINITY;
    double s = fabs(zb[N - 1]) + fabs(H);
    for (size_t j = 0; j + 1 < N; j++) s += fabs(g[j] * zb[j]);
    return fabs(zb[N - 1] + H) / s;
}

/* Quadratic invariant watched: L (Kepler), total angular momentum (2-D coupled), else none. */
static int watch_L(const problem *pb, const double *z, double *L)
{
    size_t n = pb->n;
    if (pb->type == &dth_model_kepler) {
        *L = z[0] * z[n + 2] - z[1] * z[n + 1];
        return 1;
    }
    if (pb->type == &dth_model_coupled) {
        *L = 0;
        for (size_t i = 0; i + 1 < n; i += 2) *L += z[i] * z[n + 1 + i + 1] - z[i + 1] * z[n + 1 + i];
        return 1;
    }
    return 0;
}

static double omega_of(const ctx *c, const double *z)
{
    double I[8];
    if (dth_model_invariants(c->m, z, I)) return NAN;
    return I[3];
}

/* Run until t >= t_end or `steps` steps. */
static run_out run(const problem *pb, double t_end, long steps)
{
    run_out o = {0};
    o.psi_min = INFINITY;
    o.psi_max = -INFINITY;
    ctx c = open_pb(pb);
    size_t N = c.N, n = pb->n;
    double work[4096];
    double wp0 = dth_integrator_vertex(c.it)[N - 1], L0 = 0, L;
    int hasL = watch_L(pb, dth_integrator_vertex(c.it), &L0);
    int kep = pb->type == &dth_model_kepler;
    double om0 = kep ? omega_of(&c, dth_integrator_vertex(c.it)) : 0, om_prev = om0, om_unw = om0;
    double lprev = 0;
    double t0 = now();
    for (long k = 0; k < steps; k++) {
        dth_step_info inf;
        int rc = dth_integrator_step(c.it, &inf);
        if (rc) {
            o.status = rc;
            break;
        }
        o.steps++;
        double l = dth_integrator_lambda(c.it);
        int cross = (inf.flags & DTH_STEP_CROSSING) != 0;
        if (cross) o.crossings++;
        if (k > 0 && !(inf.flags & DTH_STEP_REGULARIZED)) o.kept++; /* not the exact first step */
        if (lprev != 0 && k > 1) {
            double q = fabs(l / lprev);
            if (q < 1) q = 1 / q;
            o.max_ratio = fmax(o.max_ratio, q);
            if (cross) o.max_ratio_cross = fmax(o.max_ratio_cross, q);
        }
        lprev = l;
        const double *z = dth_integrator_vertex(c.it);
        o.energy = fmax(o.energy, midpoint_energy(c.m, dth_integrator_midpoint(c.it), N));
        if (z[N - 1] != wp0) o.wp_change = fmax(o.wp_change, fabs(z[N - 1] - wp0));
        if (hasL && watch_L(pb, z, &L)) o.L_err = fmax(o.L_err, fabs(L - L0) / fabs(L0));
        if (kep) {
            double om = omega_of(&c, z), dw = om - om_prev;
            dw -= 2 * PI * floor(dw / (2 * PI) + 0.5);
            om_unw += dw;
            om_prev = om;
        }
        if (N - 1 <= 64 && (k & 63) == 0) {
            double psi;
            if (!dth_model_psi(c.m, z, &psi, NULL, work)) {
                o.psi_min = fmin(o.psi_min, psi);
                o.psi_max = fmax(o.psi_max, psi);
            }
        }
        if (z[n] >= t_end) break;
    }
    o.secs = now() - t0;
    o.t_end = dth_integrator_vertex(c.it)[n];
    o.q_end = dth_integrator_vertex(c.it)[0];
    o.omega_drift = om_unw - om0;
    close_pb(&c);
    return o;
}

/* After the first step: `steps` forward, reverse, as many back; relative distance to the start. */
static double round_trip(const problem *pb, long steps, long *crossings, int *status)
{
    ctx c = open_pb(pb);
    size_t N = c.N;
    dth_step_info inf;
    *status = dth_integrator_step(c.it, &inf);
    double z0[2 * MAXN + 2], nz = 0, err = 0;
    memcpy(z0, dth_integrator_vertex(c.it), N * sizeof *z0);
    *crossings = 0;
    long k;
    for (k = 0; k < steps && !*status; k++) {
        *status = dth_integrator_step(c.it, &inf);
        if (inf.flags & DTH_STEP_CROSSING) ++*crossings;
    }
    dth_integrator_reverse(c.it);
    for (long j = 0; j < k && !*status; j++) *status = dth_integrator_step(c.it, &inf);
    const double *z = dth_integrator_vertex(c.it);
    for (size_t j = 0; j < N; j++) {
        nz = fmax(nz, fabs(z0[j]));
        err = fmax(err, fabs(z[j] - z0[j]));
    }
    close_pb(&c);
    return err / nz;
}

/*
 * The reversible finish's round trip: after the first step, S steps forward (every vertex kept),
 * reverse, S back; the relative distance to the start, the vertices on the way back that differ in any
 * bit from the way out's, and the seconds of the 2 S steps.
 */
static double rev_trip(const problem *pb, long S, long *crossings, long *differ, double *secs, int *status)
{
    ctx c = open_pb(pb);
    size_t N = c.N;
    dth_step_info inf;
    *status = dth_integrator_step(c.it, &inf);
    double *out = malloc((size_t)(S + 1) * N * sizeof *out), nz = 0, err = 0;
    if (!out) exit(1);
    memcpy(out, dth_integrator_vertex(c.it), N * sizeof *out);
    *crossings = *differ = 0;
    double t0 = now();
    long k;
    for (k = 0; k < S && !*status; k++) {
        *status = dth_integrator_step(c.it, &inf);
        if (inf.flags & DTH_STEP_CROSSING) ++*crossings;
        memcpy(out + (size_t)(k + 1) * N, dth_integrator_vertex(c.it), N * sizeof *out);
    }
    dth_integrator_reverse(c.it);
    for (long j = 0; j < k && !*status; j++) {
        *status = dth_integrator_step(c.it, &inf);
        if (memcmp(out + (size_t)(k - 1 - j) * N, dth_integrator_vertex(c.it), N * sizeof *out)) ++*differ;
    }
    *secs = now() - t0;
    const double *z = dth_integrator_vertex(c.it);
    for (size_t j = 0; j < N; j++) {
        nz = fmax(nz, fabs(out[j]));
        err = fmax(err, fabs(z[j] - out[j]));
    }
    free(out);
    close_pb(&c);
    return err / nz;
}

/*
 * Tangent-map defect max|M^T J M - J| of nsteps whole steps by central differences (eps), from the
 * first crossing step (cross = 1) or the first step that does not cross (0) starting at or after the
 * fixed time t = 0.5 (a fixed step number would move toward t = 0 as h shrinks and probe a different
 * place of the orbit at each h); *block: the same for the (q, p) block of M alone.
 */
static double tangent_defect(const problem *pb, int cross, double eps, int nsteps, double *block)
{
    *block = NAN;
    ctx c = open_pb(pb);
    size_t N = c.N, n = pb->n;
    double za[2 * MAXN + 2], lam = 0;
    int found = 0;
    dth_step_info inf;
    dth_integrator_step(c.it, &inf);
    for (long k = 0; k < 200000; k++) {
        memcpy(za, dth_integrator_vertex(c.it), N * sizeof *za);
        lam = dth_integrator_lambda(c.it);
        if (dth_integrator_step(c.it, &inf)) break;
        if (((inf.flags & DTH_STEP_CROSSING) != 0) == cross && za[n] >= 0.5) {
            found = 1;
            break;
        }
    }
    double defect = NAN;
    if (found && N <= 16) {
        double M[256], zp[16], zm[16], zz[16];
        for (size_t j = 0; j < N && found; j++) {
            double e = eps * fmax(1.0, fabs(za[j]));
            for (int s = 0; s < 2; s++) {
                memcpy(zz, za, N * sizeof *zz);
                zz[j] += s ? -e : e;
                if (dth_integrator_set_vertex(c.it, zz, lam)) found = 0;
                for (int k = 0; k < nsteps && found; k++)
                    if (dth_integrator_step(c.it, &inf)) found = 0;
                if (found) memcpy(s ? zm : zp, dth_integrator_vertex(c.it), N * sizeof *zp);
            }
            for (size_t i = 0; i < N; i++) M[i * N + j] = (zp[i] - zm[i]) / (2 * e);
        }
        if (found) {
            defect = 0;
            for (size_t a = 0; a < N; a++)
                for (size_t b = 0; b < N; b++) {
                    double s = 0;
                    for (size_t i = 0; i <= n; i++) s += M[i * N + a] * M[(i + n + 1) * N + b] - M[(i + n + 1) * N + a] * M[i * N + b];
                    double Jab = (b == a + n + 1) ? 1.0 : (a == b + n + 1 ? -1.0 : 0.0);
                    defect = fmax(defect, fabs(s - Jab));
                }
            /* the (q, p) block alone (t and wp held): the map on the physical phase space */
            *block = 0;
            for (size_t a = 0; a < N; a++)
                for (size_t b = 0; b < N; b++) {
                    if (a == n || b == n || a == N - 1 || b == N - 1) continue;
                    double s = 0;
                    for (size_t i = 0; i < n; i++) s += M[i * N + a] * M[(i + n + 1) * N + b] - M[(i + n + 1) * N + a] * M[i * N + b];
                    double Jab = (b == a + n + 1) ? 1.0 : (a == b + n + 1 ? -1.0 : 0.0);
                    *block = fmax(*block, fabs(s - Jab));
                }
        }
    }
    close_pb(&c);
    return defect;
}

/* Pendulum: mean time per revolution over revolutions 1..R+1 (linear interpolation of t at q = 2 pi j). */
static double mean_period(const problem *pb, int R, int *status)
{
    ctx c = open_pb(pb);
    double qa = 0, ta = 0, t1 = NAN, tR = NAN;
    int j = 1;
    *status = 0;
    while (j <= R + 1) {
        dth_step_info inf;
        int rc = dth_integrator_step(c.it, &inf);
        if (rc) {
            *status = rc;
            break;
        }
        const double *z = dth_integrator_vertex(c.it);
        while (j <= R + 1 && z[0] >= 2 * PI * j) {
            double t = ta + (2 * PI * j - qa) / (z[0] - qa) * (z[1] - ta);
            if (j == 1) t1 = t;
            if (j == R + 1) tR = t;
            j++;
        }
        qa = z[0];
        ta = z[1];
    }
    close_pb(&c);
    return (tR - t1) / R;
}

/* Pendulum: largest kick |mu| over the steps up to t_end, from the chord: mu = grad H . (z_b - z_a) / |grad H|^2 at zbar. */
static double max_kick(const problem *pb, double t_end)
{
    ctx c = open_pb(pb);
    double za[4], H, g[3], mx = 0;
    dth_step_info inf;
    dth_integrator_step(c.it, &inf);
    while (dth_integrator_vertex(c.it)[1] < t_end) {
        memcpy(za, dth_integrator_vertex(c.it), 4 * sizeof *za);
        if (dth_integrator_step(c.it, &inf)) return NAN;
        const double *zb = dth_integrator_vertex(c.it), *zm = dth_integrator_midpoint(c.it);
        if (dth_model_eval(c.m, zm, DTH_EVAL_H | DTH_EVAL_GRAD, &H, g, NULL)) return NAN;
        double mu = (g[0] * (zb[0] - za[0]) + g[2] * (zb[2] - za[2])) / (g[0] * g[0] + g[2] * g[2]);
        mx = fmax(mx, fabs(mu));
    }
    close_pb(&c);
    return mx;
}

static const char *st(int s) { return s ? dth_status_name(s) : "ok"; }

int main(int argc, char **argv)
{
    double scale = argc > 1 ? atof(argv[1]) : 1.0;
    if (!(scale > 0)) scale = 1;
    /* rotating pendulum q0 = 0, p0 = 2.2 (midpoint start: the energy of (q0, p0) exactly) */
    problem pend = {"pendulum", &dth_model_pendulum, {{0}}, 0, 1, {0}, {2.2}, 0.05, DTH_START_MIDPOINT,
                    {{"alpha", "0"}}, 1, &dth_reg_prescribed, 1, 0};
    double E = 0.5 * 2.2 * 2.2 - 1, kk = sqrt(2 / (1 + E));
    double T = 2 * gsl_sf_ellint_Kcomp(kk, GSL_PREC_DOUBLE) * kk;

    int only_rev = argc > 2 && !strcmp(argv[2], "reversible");
    printf("# bench_regul2 %g (prescribed regularizer)\n\n", scale);
    if (only_rev) goto reversible;
    /* ---- long runs ---- */
    long R = (long)(10000 * scale);
    printf("## long runs\n\n| problem | alpha | h | steps | end | t reached | revolutions / orbits | crossings | max midpoint energy residual (rel.) | wp change | max rel. L error | precession per orbit | max step ratio (all / at crossings) | psi range (sampled) | ordinary steps kept | us per step |\n");
    printf("|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|\n");
    {
        run_out o = run(&pend, T * (double)R + 1, 1L << 40);
        printf("| %s | 0 | %.3g | %ld | %s | %.1f | %.1f | %ld | %.1e | %.1e | - | - | %.4f / %.4f | [%.2g, %.2g] | %ld | %.2f |\n", pend.name, pend.h, o.steps,
               st(o.status), o.t_end, o.q_end / (2 * PI), o.crossings, o.energy, o.wp_change, o.max_ratio, o.max_ratio_cross, o.psi_min,
               o.psi_max, o.kept, 1e6 * o.secs / (double)o.steps);
        fflush(stdout);
    }
    /* Kepler a = mu = 1 from apocentre (period 2 pi); alpha = 0.75 makes lambda ~ r^(3/2) near
     * pericentre (|u| ~ 1/r^2), Sundman's time transformation, alpha = 1 lambda ~ r^2; no fallback:
     * every step is a kicked segment or the run ends */
    struct { double e, h; const char *alpha; } kc[] = {{0.9, 0.05, "1"}, {0.99, 0.025, "1"}, {0.9, 0.025, "1"}, {0.99, 0.0125, "1"}};
    long orbits = (long)(1000 * scale);
    if (orbits < 1) orbits = 1;
    problem kps[4];
    char knames[4][64];
    for (size_t i = 0; i < 4; i++) {
        snprintf(knames[i], sizeof knames[i], "kepler e=%g apocentre", kc[i].e);
        problem kp = {knames[i], &dth_model_kepler, {{0}}, 0, 2, {-(1 + kc[i].e), 0}, {0, -sqrt((1 - kc[i].e) / (1 + kc[i].e))},
                      kc[i].h, DTH_START_MIDPOINT, {{"alpha", kc[i].alpha}, {"fallback", "no"}}, 2, &dth_reg_prescribed, 1, 0};
        kps[i] = kp;
        run_out o = run(&kp, 2 * PI * (double)(i < 2 ? orbits : orbits / 10 + 1), 1L << 40);
        double norb = o.t_end / (2 * PI);
        printf("| %s | %s | %.3g | %ld | %s | %.1f | %.1f | %ld | %.1e | %.1e | %.1e | %+.3e | %.4f / %.4f | [%.2g, %.2g] | %ld | %.2f |\n", knames[i], kc[i].alpha, kp.h,
               o.steps, st(o.status), o.t_end, norb, o.crossings, o.energy, o.wp_change, o.L_err, o.omega_drift / norb, o.max_ratio,
               o.max_ratio_cross, o.psi_min, o.psi_max, o.kept, 1e6 * o.secs / (double)o.steps);
        fflush(stdout);
    }
    /* 2-D chain of 3 particles (k = 1, L = 1) started compressed with transverse momenta: psi < 0 at
     * the start (transverse stiffness k (1 - L/r) < 0), > 0 once the springs stretch */
    problem chain = {"chain 3 particles 2-D", &dth_model_coupled, {{"preset", "chain"}, {"size", "3"}, {"dim", "2"}, {"L", "1"}}, 4, 6,
                     {0, 0, 0.5, 0, 1.0, 0}, {0, 1, 0, -2, 0, 1.5}, 0.02, DTH_START_MIDPOINT, {{"alpha", "0"}}, 1, &dth_reg_prescribed, 1, 0};
    /* the same with 10 particles (spacing 0.5, transverse momenta of zero sum) */
    problem chain10 = {"chain 10 particles 2-D", &dth_model_coupled, {{"preset", "chain"}, {"size", "10"}, {"dim", "2"}, {"L", "1"}}, 4, 20,
                       {0}, {0, -1.2661, 0, 1.5869, 0, 1.2519, 0, -0.7831, 0, 0.1789, 0, -0.0051, 0, 0.8029, 0, 1.3519, 0, -1.4281, 0, -1.6901},
                       0.02, DTH_START_MIDPOINT, {{"alpha", "0"}}, 1, &dth_reg_prescribed, 1, 0};
    for (int i = 0; i < 10; i++) chain10.q0[2 * i] = 0.5 * i;
    const problem *chains[] = {&chain, &chain10};
    for (int c = 0; c < 2; c++) {
        const problem *ch = chains[c];
        run_out o = run(ch, 200 * scale + 1, 1L << 40);
        printf("| %s | 0 | %.3g | %ld | %s | %.1f | - | %ld | %.1e | %.1e | %.1e | - | %.4f / %.4f | [%.2g, %.2g] | %ld | %.2f |\n", ch->name, ch->h, o.steps,
               st(o.status), o.t_end, o.crossings, o.energy, o.wp_change, o.L_err, o.max_ratio, o.max_ratio_cross, o.psi_min, o.psi_max,
               o.kept, 1e6 * o.secs / (double)o.steps);
        problem raw = *ch;
        raw.reg = NULL;
        run_out r0 = run(&raw, 200, 1L << 40);
        printf("| %s, raw DTH | - | %.3g | %ld | %s | %.1f | - | %ld | - | - | - | - | - | - | - | %.2f |\n", ch->name, ch->h, r0.steps, st(r0.status),
               r0.t_end, r0.crossings, 1e6 * r0.secs / (double)(r0.steps ? r0.steps : 1));
        fflush(stdout);
    }

    /* ---- phase: mean period against the exact one ---- */
    int RP = (int)(200 * scale);
    if (RP < 20) RP = 20;
    printf("\n## pendulum phase (alpha = 0, midpoint start): mean time per revolution over revolutions 1..%d, exact period %.15f\n\n", RP + 1, T);
    printf("| h | period error | observed order | end |\n|---|---|---|---|\n");
    {
        double prev = NAN;
        for (double h = 0.05; h > 0.006; h /= 2) {
            problem pb = pend;
            pb.h = h;
            int s2;
            double e = mean_period(&pb, RP, &s2) - T;
            char ord[32] = "-";
            if (isfinite(prev) && isfinite(e)) snprintf(ord, sizeof ord, "%.2f", log2(fabs(prev / e)));
            printf("| %.5f | %+.3e | %s | %s |\n", h, e, ord, st(s2));
            prev = e;
        }
    }
    /* ---- the kick against h ---- */
    printf("\n## pendulum: largest kick |mu| over t in [0, 20] (crossings included)\n\n| h | max |mu| | order |\n|---|---|---|\n");
    {
        double prev = NAN;
        for (double h = 0.05; h > 0.006; h /= 2) {
            problem pb = pend;
            pb.h = h;
            double k = max_kick(&pb, 20);
            char ord[32] = "-";
            if (isfinite(prev)) snprintf(ord, sizeof ord, "%.2f", log2(prev / k));
            printf("| %.5f | %.3e | %s |\n", h, k, ord);
            prev = k;
        }
    }
    /* ---- round trips, step ratio, tangent defect ---- */
    printf("\n## round trip (after the first step: S steps, reverse, S back), tangent defect of one step (central differences, eps 1e-7)\n\n");
    printf("| problem | S | crossings | round trip (rel.) | end | one step, extended z: at a crossing / elsewhere | one step, (q, p) block | two steps, (q, p) block |\n|---|---|---|---|---|---|---|---|\n");
    {
        problem pend2 = pend;
        pend2.h = 0.025;
        pend2.name = "pendulum h=0.025";
        problem pend4 = pend;
        pend4.h = 0.0125;
        pend4.name = "pendulum";
        pend2.name = "pendulum";
        problem kp2 = kps[0], kp3 = kps[1], kp4 = kps[1];
        /* a midpoint on the first pericentre, where the Euclidean kick had no kicked segment (the
         * scaled one has: no fallback step is taken) */
        kp4.h = 0.0125;
        kp4.rkv[0] = (dth_kv){"alpha", "0.75"};
        kp4.rkv[1] = (dth_kv){"fallback", "yes"};
        kp4.name = "kepler e=0.99 alpha=0.75 fallback=yes";
        const problem *rt[] = {&pend, &pend2, &pend4, &kp2, &kp3, &kp4, &chain, &chain10};
        long S[] = {2000, 4000, 8000, 4000, 20000, 4000, 2000, 2000};
        for (size_t i = 0; i < sizeof rt / sizeof rt[0]; i++) {
            long cr;
            int s2;
            double e = round_trip(rt[i], S[i], &cr, &s2);
            double bc, bn, b2c, b2n, dc = tangent_defect(rt[i], 1, 1e-7, 1, &bc), dn = tangent_defect(rt[i], 0, 1e-7, 1, &bn);
            tangent_defect(rt[i], 1, 1e-7, 2, &b2c);
            tangent_defect(rt[i], 0, 1e-7, 2, &b2n);
            /* "-": not measured (the finite-difference probe handles up to 16 extended dimensions) */
            double v[6] = {dc, dn, bc, bn, b2c, b2n};
            char f[6][16];
            for (int j = 0; j < 6; j++) {
                if (isfinite(v[j])) snprintf(f[j], sizeof f[j], "%.1e", v[j]);
                else snprintf(f[j], sizeof f[j], "-");
            }
            printf("| %s, h=%g | %ld | %ld | %.1e | %s | %s / %s | %s / %s | %s / %s |\n", rt[i]->name, rt[i]->h, S[i], cr, e, st(s2), f[0], f[1],
                   f[2], f[3], f[4], f[5]);
            fflush(stdout);
        }
        problem raw = pend;
        raw.reg = NULL;
        double bn, b2n, dn = tangent_defect(&raw, 0, 1e-7, 1, &bn);
        tangent_defect(&raw, 0, 1e-7, 2, &b2n);
        printf("| pendulum raw DTH h=0.05 | - | - | - | - | - / %.1e | - / %.1e | - / %.1e |\n", dn, bn, b2n);
    }
    /* ---- existence: a grid of Kepler runs with fallback = no (every step a kicked segment) ---- */
    {
        long no = (long)(100 * scale);
        if (no < 2) no = 2;
        printf("\n## existence: Kepler from apocentre, fallback = no; orbits completed of %ld (end status if short)\n\n", no);
        const double es[] = {0.6, 0.9, 0.99}, hs[] = {0.1, 0.05, 0.025};
        const char *as[] = {"0", "0.5", "0.75", "1"};
        printf("| e | alpha | h = 0.1 | h = 0.05 | h = 0.025 |\n|---|---|---|---|---|\n");
        long runs = 0, full = 0;
        for (size_t ie = 0; ie < 3; ie++)
            for (size_t ia = 0; ia < 4; ia++) {
                printf("| %g | %s |", es[ie], as[ia]);
                for (size_t ih = 0; ih < 3; ih++) {
                    double e = es[ie];
                    problem kp = {"kepler", &dth_model_kepler, {{0}}, 0, 2, {-(1 + e), 0}, {0, -sqrt((1 - e) / (1 + e))}, hs[ih],
                                  DTH_START_MIDPOINT, {{"alpha", as[ia]}, {"fallback", "no"}}, 2, &dth_reg_prescribed, 1, 0};
                    run_out o = run(&kp, 2 * PI * (double)no, 1L << 40);
                    runs++;
                    if (!o.status) {
                        full++;
                        printf(" %ld |", no);
                    } else {
                        printf(" %.1f (%s) |", o.t_end / (2 * PI), st(o.status));
                    }
                    fflush(stdout);
                }
                printf("\n");
            }
        printf("\n%ld of %ld runs completed %ld orbits.\n", full, runs, no);
    }
    /* ---- cost per step, side by side on a libration orbit (no crossing) ---- */
    printf("\n## cost per step with no crossing: pendulum libration q0 = 0, p0 = 1, h = 0.05; Kepler e = 0.6 (same run; ratios only)\n\n| configuration | us per step |\n|---|---|\n");
    {
        long ns = (long)(200000 * scale);
        if (ns < 2000) ns = 2000;
        problem lib = pend;
        lib.p0[0] = 1;
        problem cfg[5] = {lib, lib, lib, lib, lib};
        cfg[0].reg = NULL;
        cfg[1].no_branch_check = 0;
        const dth_regularizer_type *others[] = {&dth_reg_none, &dth_reg_land};
        for (int i = 3; i < 5; i++) {
            cfg[i].reg = others[i - 3];
            cfg[i].nrkv = 0;
            cfg[i].no_branch_check = 0;
        }
        const char *lab[] = {"raw DTH (branch_check = 0)", "prescribed, branch_check = 1", "prescribed",
                             "none (one psi per step, for the sign)", "land (the default: psi's sign at each new vertex, psi, psi' from the branch test)"};
        for (int i = 0; i < 5; i++) {
            run_out o = run(&cfg[i], INFINITY, ns);
            printf("| pendulum: %s | %.2f |\n", lab[i], 1e6 * o.secs / (double)o.steps);
        }
        /* Kepler e = 0.6 has no psi = 0 crossing: raw DTH runs too (alpha = 0: the same step law) */
        double e = 0.6;
        problem k6 = {"kepler", &dth_model_kepler, {{0}}, 0, 2, {-(1 + e), 0}, {0, -sqrt((1 - e) / (1 + e))}, 0.05,
                      DTH_START_MIDPOINT, {{"alpha", "0"}}, 1, &dth_reg_prescribed, 1, 0};
        problem k6raw = k6;
        k6raw.reg = NULL;
        run_out o = run(&k6raw, INFINITY, ns);
        printf("| kepler e=0.6 h=0.05: raw DTH (%s) | %.2f |\n", st(o.status), 1e6 * o.secs / (double)o.steps);
        o = run(&k6, INFINITY, ns);
        printf("| kepler e=0.6 h=0.05: prescribed alpha=0 (%s) | %.2f |\n", st(o.status), 1e6 * o.secs / (double)o.steps);
    }
reversible:
    /* ---- the reversible finish: round trips and cost per step, each configuration run 3 times
     * alternating with the compensated default, the fastest run of each kept ---- */
    printf("\n## the reversible finish (integrator.reversible = yes) against the compensated default: round trip after the first step "
           "(S steps, reverse, S back), vertices on the way back that differ in any bit from the way out's, us per step (best of 3)\n\n");
    printf("| problem | S | crossings | round trip compensated / reversible (rel.) | vertices differing (reversible) | us per step compensated / reversible | ratio |\n|---|---|---|---|---|---|---|\n");
    {
        double e9 = 0.9, e99 = 0.99;
        problem p05 = {"pendulum rotation p0 = 2.2, alpha = 0", &dth_model_pendulum, {{0}}, 0, 1, {0}, {2.2}, 0.05, DTH_START_MIDPOINT,
                       {{"alpha", "0"}}, 1, &dth_reg_prescribed, 1, 0};
        problem k9 = {"kepler e=0.9 apocentre, alpha = 1", &dth_model_kepler, {{0}}, 0, 2, {-(1 + e9), 0}, {0, -sqrt((1 - e9) / (1 + e9))}, 0.05,
                      DTH_START_MIDPOINT, {{"alpha", "1"}}, 1, &dth_reg_prescribed, 1, 0};
        problem k99 = {"kepler e=0.99 apocentre, alpha = 1", &dth_model_kepler, {{0}}, 0, 2, {-(1 + e99), 0}, {0, -sqrt((1 - e99) / (1 + e99))},
                       0.025, DTH_START_MIDPOINT, {{"alpha", "1"}}, 1, &dth_reg_prescribed, 1, 0};
        problem ch3 = {"chain 3 particles 2-D, alpha = 0", &dth_model_coupled, {{"preset", "chain"}, {"size", "3"}, {"dim", "2"}, {"L", "1"}}, 4, 6,
                       {0, 0, 0.5, 0, 1.0, 0}, {0, 1, 0, -2, 0, 1.5}, 0.02, DTH_START_MIDPOINT, {{"alpha", "0"}}, 1, &dth_reg_prescribed, 1, 0};
        const problem *pr[] = {&p05, &p05, &k9, &k99, &ch3, &ch3};
        long S0[] = {4400, 20000, 23000, 20000, 5400, 20000};
        for (size_t i = 0; i < sizeof pr / sizeof pr[0]; i++) {
            long S = (long)((double)S0[i] * (scale < 1 ? scale : 1));
            if (S < 100) S = 100;
            double rt[2] = {0, 0}, best[2] = {INFINITY, INFINITY};
            long cr = 0, diff[2] = {0, 0};
            int s2[2] = {0, 0};
            for (int rep = 0; rep < 3; rep++)
                for (int f = 0; f < 2; f++) {
                    problem pb = *pr[i];
                    pb.reversible = f;
                    double secs;
                    rt[f] = rev_trip(&pb, S, &cr, &diff[f], &secs, &s2[f]);
                    best[f] = fmin(best[f], 1e6 * secs / (2.0 * (double)S));
                }
            printf("| %s, h=%g | %ld | %ld | %.1e / %.1e%s%s | %ld of %ld | %.2f / %.2f | %.2f |\n", pr[i]->name, pr[i]->h, S, cr, rt[0], rt[1],
                   s2[0] ? " compensated: " : "", s2[0] ? st(s2[0]) : (s2[1] ? st(s2[1]) : ""), diff[1], S, best[0], best[1], best[1] / best[0]);
            fflush(stdout);
        }
    }
    return 0;
}
