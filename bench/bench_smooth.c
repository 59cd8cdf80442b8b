/* SPDX-License-Identifier: MIT */
/*
 * Benchmark (not a test): the default regularizer "smooth" (ordinary DTH steps, a C-infinity
 * changeover to kicked segments of a step law around psi = 0; paper, section 7) against the
 * targets of issue 11: the rotating pendulum (revolutions, share of non-symplectic steps against h,
 * the tangent map of every ordinary step, step ratios at band edges, no drift of the step, round
 * trips), and Kepler e = 0.9 / 0.99, coupled chains and rings, Henon-Heiles (energy at midpoints,
 * quadratic invariants, refusals).
 * Usage: bench_smooth [scale]   (scale 1: the documented figures, a few minutes; 0.01: a smoke run)
 */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include "bench_common.h"
#include "dth/dth.h"
#include "symp_models.h" /* the Henon-Heiles user model (hh_type) */

#define PI 3.14159265358979323846
#define MAXN 48


/* ---- one run ---- */

typedef struct problem {
    const char *name;
    const dth_model_type *type;
    dth_kv mkv[6];
    size_t nmkv, n;
    double q0[MAXN], p0[MAXN], h, t_end;
    const char *quad[8]; /* names of the quadratic invariants to follow (NULL-terminated) */
} problem;

typedef struct stats {
    int status;
    long steps, reg, crossings;
    double t, emid, inv, ratio, ratio_edge, tangent, secs;
    char msg[160];
} stats;

static int is_quad(const problem *pb, const char *name)
{
    for (int i = 0; i < 8 && pb->quad[i]; i++)
        if (!strcmp(pb->quad[i], name)) return 1;
    return 0;
}

/* Integrate pb to t_end with `smooth` (params kv); per step: midpoint energy against the initial
 * energy, the quadratic invariants at vertices, step ratios, and optionally the symplectic defect of
 * every ordinary step's tangent map. lam_out (may be NULL) collects the steps. */
static stats run(const problem *pb, const dth_kv *kv, size_t nkv, int tangent, double *lam_out, long lam_cap)
{
    stats s = {0};
    char err[256];
    dth_model *m = NULL;
    dth_regularizer *r = NULL;
    dth_integrator *it = NULL;
    if (dth_model_new(pb->type, pb->nmkv ? pb->mkv : NULL, pb->nmkv, pb->n, NULL, &m, err, sizeof err) ||
        dth_regularizer_new(&dth_reg_smooth, kv, nkv, m, NULL, &r, err, sizeof err)) {
        fprintf(stderr, "%s: %s\n", pb->name, err);
        exit(1);
    }
    dth_options o;
    dth_options_default(&o);
    o.h = pb->h;
    o.regularizer = r;
    if (dth_integrator_new(m, &o, &it) || dth_integrator_start(it, pb->q0, pb->p0, 0.0)) {
        fprintf(stderr, "%s: cannot start\n", pb->name);
        exit(1);
    }
    size_t n = pb->n, N = 2 * n + 2, ni = dth_model_n_invariants(m);
    double y0[2 * MAXN + 1], E0, I0[16], I[16], M[(2 * MAXN + 2) * (2 * MAXN + 2)];
    for (size_t i = 0; i < n; i++) y0[i] = pb->q0[i], y0[n + 1 + i] = pb->p0[i];
    y0[n] = 0;
    dth_model_eval(m, y0, DTH_EVAL_H, &E0, NULL, NULL);
    if (ni > 16) ni = 0;
    /* quadratic invariants are exact at vertices (a midpoint start's first vertex differs from the
     * initial state by O(h^2)); their scale: |I0|, or the size of q x p and p when I0 ~ 0 */
    double isc = 0;
    for (size_t i = 0; i < n; i++) isc += fabs(pb->p0[i]) * (1 + fabs(pb->q0[i]));
    if (ni) dth_model_invariants(m, dth_integrator_vertex(it), I0);
    double lprev = 0;
    int prev_reg = -1;
    double t0 = bench_now();
    for (;;) {
        const double *z = dth_integrator_vertex(it);
        if (z[n] >= pb->t_end) break;
        dth_step_info inf;
        int rc = dth_integrator_step(it, &inf);
        if (rc) {
            s.status = rc;
            snprintf(s.msg, sizeof s.msg, "%s", dth_integrator_errmsg(it));
            break;
        }
        int reg = (inf.flags & DTH_STEP_REGULARIZED) != 0;
        if (lam_out && s.steps < lam_cap) lam_out[s.steps] = inf.lambda;
        s.steps++;
        s.reg += reg;
        s.crossings += (inf.flags & DTH_STEP_CROSSING) != 0;
        const double *zb = dth_integrator_midpoint(it);
        /* midpoint energy error against the size of its terms, |E0| + sum |dH/dy_j y_j| (the
         * round-off of evaluating H at a double point) */
        double E, g[2 * MAXN + 1], sc = fabs(E0);
        if (!dth_model_eval(m, zb, DTH_EVAL_H | DTH_EVAL_GRAD, &E, g, NULL)) {
            for (size_t j = 0; j < 2 * n + 1; j++) sc += fabs(g[j] * zb[j]);
            s.emid = fmax(s.emid, fabs(E - E0) / sc);
        }
        if (ni && !dth_model_invariants(m, dth_integrator_vertex(it), I))
            for (size_t k = 0; k < ni; k++)
                if (is_quad(pb, dth_model_invariant_name(m, k)))
                    s.inv = fmax(s.inv, fabs(I[k] - I0[k]) / fmax(fabs(I0[k]), isc));
        if (lprev != 0) {
            double q = fabs(inf.lambda / lprev);
            q = q < 1 ? 1 / q : q;
            s.ratio = fmax(s.ratio, q);
            if (prev_reg >= 0 && prev_reg != reg) s.ratio_edge = fmax(s.ratio_edge, q);
        }
        lprev = inf.lambda;
        prev_reg = reg;
        if (tangent && !reg && dth_integrator_tangent(it, M) == DTH_OK) {
            /* |M^T J M - J| / |M|^2 */
            double mm = 0, dmax = 0;
            size_t hN = N / 2;
            for (size_t i = 0; i < N * N; i++) mm = fmax(mm, fabs(M[i]));
            for (size_t a = 0; a < N; a++)
                for (size_t b = 0; b < N; b++) {
                    double acc = 0;
                    for (size_t k = 0; k < hN; k++) acc += M[k * N + a] * M[(hN + k) * N + b] - M[(hN + k) * N + a] * M[k * N + b];
                    double j = (a < hN && b == a + hN) ? 1 : (a >= hN && b + hN == a) ? -1 : 0;
                    dmax = fmax(dmax, fabs(acc - j));
                }
            s.tangent = fmax(s.tangent, dmax / (mm * mm));
        }
    }
    s.secs = bench_now() - t0;
    s.t = dth_integrator_vertex(it)[n];
    dth_integrator_free(it);
    dth_regularizer_free(r);
    dth_model_free(m);
    return s;
}

static double median(double *v, long k)
{
    if (k <= 0) return NAN;
    qsort(v, (size_t)k, sizeof *v, bench_cmp_double);
    return v[k / 2];
}

/* Rotating pendulum q0 = 0, p0 = 2.2: revolutions take about 4.22. */
static problem pendulum(double h, double revs)
{
    problem pb = {.name = "pendulum", .type = &dth_model_pendulum, .n = 1, .h = h, .t_end = revs * 4.2216800668656};
    pb.q0[0] = 0, pb.p0[0] = 2.2;
    return pb;
}

/* The pendulum's median step over revolution j (steps in lam; q advances 2 pi per revolution). */
static void table_pendulum(double scale)
{
    printf("## Rotating pendulum (q0 = 0, p0 = 2.2, midpoint start), default `smooth`\n\n");
    printf("| h | revolutions | steps | crossings | non-symplectic steps | share | max |M^T J M - J| / |M|^2, ordinary steps | "
           "step ratio: max / at band edges | max midpoint energy error (rel. to its terms) | median step: revolution 1 / last | drift | s |\n");
    printf("|---|---|---|---|---|---|---|---|---|---|---|---|\n");
    double hs[3] = {0.05, 0.025, 0.0125}, dev_med[3] = {0}, dev_mean[3] = {0};
    long nrevs[3] = {0};
    for (int i = 0; i < 3; i++) {
        double revs = (i == 0 ? 1e4 : 1e3) * scale;
        if (revs < 3) revs = 3;
        problem pb = pendulum(hs[i], revs);
        long cap = (long)(revs * 4.23 / hs[i] * 1.2) + 1000;
        double *lam = malloc((size_t)cap * sizeof *lam);
        stats s = run(&pb, NULL, 0, 1, lam, cap);
        /* steps per revolution: the revolution time is 4.2216800668656; rev j spans
         * [j T, (j + 1) T), found from the cumulative time */
        long k1 = 0, kl0 = 0;
        double t = 0, T = 4.2216800668656, last0 = (floor(s.t / T) - 1) * T;
        for (long k = 0; k < s.steps && k < cap; k++) {
            t += lam[k];
            if (t < T) k1 = k + 1;
            if (t < last0) kl0 = k + 1;
        }
        double *first = malloc((size_t)(k1 + 1) * sizeof *first);
        memcpy(first, lam, (size_t)k1 * sizeof *first);
        long nl = 0;
        double *lastv = malloc((size_t)(s.steps + 1) * sizeof *lastv);
        t = 0;
        for (long k = 0; k < s.steps && k < cap; k++) {
            t += lam[k];
            if (k >= kl0 && t < last0 + T) lastv[nl++] = lam[k];
        }
        double m1 = median(first, k1), ml = median(lastv, nl);
        /* every full revolution's median and mean step: their largest relative deviation from the
         * average over the revolutions (revolution j: the steps ending in [j T, (j + 1) T)) */
        long nfull = (long)floor(s.t / T), kk = 0;
        double *med = malloc((size_t)(nfull + 1) * sizeof *med), *mean = malloc((size_t)(nfull + 1) * sizeof *mean);
        double *rv = malloc((size_t)(s.steps + 1) * sizeof *rv), smed = 0, smean = 0;
        t = 0;
        for (long j = 0; j < nfull; j++) {
            long nr = 0;
            double sum = 0;
            while (kk < s.steps && kk < cap && t + lam[kk] < (j + 1) * T) {
                t += lam[kk];
                sum += lam[kk];
                rv[nr++] = lam[kk++];
            }
            med[j] = median(rv, nr), mean[j] = nr ? sum / (double)nr : NAN;
            smed += med[j], smean += mean[j];
        }
        for (long j = 0; j < nfull; j++) {
            dev_med[i] = fmax(dev_med[i], fabs(med[j] / (smed / (double)nfull) - 1));
            dev_mean[i] = fmax(dev_mean[i], fabs(mean[j] / (smean / (double)nfull) - 1));
        }
        nrevs[i] = nfull;
        free(med);
        free(mean);
        free(rv);
        printf("| %.4f | %.0f | %ld | %ld | %ld | %.3f | %.1e | %.3f / %.3f | %.1e | %.5f / %.5f | %+.2f %% | %.1f |\n", hs[i],
               s.t / T, s.steps, s.crossings, s.reg, (double)s.reg / (double)s.steps, s.tangent, s.ratio, s.ratio_edge,
               s.emid, m1, ml, 100 * (ml / m1 - 1), s.secs);
        if (s.status) printf("\n(ended: %s: %s)\n", dth_strerror(s.status), s.msg);
        free(first);
        free(lastv);
        free(lam);
    }
    printf("\nEvery full revolution's median step and mean step, against their averages over the revolutions:\n\n");
    printf("| h | full revolutions | median step of a revolution: largest deviation | mean step of a revolution: largest deviation |\n"
           "|---|---|---|---|\n");
    for (int i = 0; i < 3; i++)
        printf("| %.4f | %ld | %.2f %% | %.2f %% |\n", hs[i], nrevs[i], 100 * dev_med[i], 100 * dev_mean[i]);
    printf("\n");
}

/* Round trip: S steps, reverse, S steps back; relative distance of (q, p) to the start. */
static void table_roundtrip(double scale)
{
    printf("## Round trips (S steps forward, dth_integrator_reverse, S steps back)\n\n");
    printf("| problem | S | crossings | |q - q0|, |p - p0|, |t| after the return (relative) | end |\n|---|---|---|---|---|\n");
    double revs[3] = {1, 5, 50};
    for (int i = 0; i < 3; i++) {
        if (i == 2 && scale < 0.1) break;
        problem pb = pendulum(0.05, revs[i]);
        char err[256];
        dth_model *m = NULL;
        dth_regularizer *r = NULL;
        dth_integrator *it = NULL;
        dth_model_new(pb.type, NULL, 0, 1, NULL, &m, err, sizeof err);
        dth_regularizer_new(&dth_reg_smooth, NULL, 0, m, NULL, &r, err, sizeof err);
        dth_options o;
        dth_options_default(&o);
        o.h = pb.h;
        o.regularizer = r;
        dth_integrator_new(m, &o, &it);
        dth_integrator_start(it, pb.q0, pb.p0, 0.0);
        double z0[4];
        memcpy(z0, dth_integrator_vertex(it), sizeof z0);
        long S = 0, cr = 0;
        int rc = 0;
        dth_step_info inf;
        while (dth_integrator_vertex(it)[1] < pb.t_end && !(rc = dth_integrator_step(it, &inf))) {
            S++;
            cr += (inf.flags & DTH_STEP_CROSSING) != 0;
        }
        dth_integrator_reverse(it);
        for (long k = 0; !rc && k < S; k++) rc = dth_integrator_step(it, &inf);
        const double *z = dth_integrator_vertex(it);
        double sc = fabs(z0[0]) + fabs(z0[2]) + 1;
        printf("| pendulum h = 0.05, %.0f revolutions | %ld | %ld | %.1e, %.1e, %.1e | %s |\n", revs[i], S, 2 * cr,
               fabs(z[0] - z0[0]) / sc, fabs(z[2] - z0[2]) / sc, fabs(z[1] - z0[1]) / (pb.t_end), rc ? dth_strerror(rc) : "ok");
        dth_integrator_free(it);
        dth_regularizer_free(r);
        dth_model_free(m);
    }
    printf("\n");
}

static void row(const problem *pb)
{
    stats s = run(pb, NULL, 0, 0, NULL, 0);
    printf("| %s | %g | %.1f | %ld | %ld | %ld | %.3f | %.1e | %.1e | %.3f / %.3f | %s |\n", pb->name, pb->h, s.t, s.steps, s.crossings,
           s.reg, (double)s.reg / (double)(s.steps ? s.steps : 1), s.emid, s.inv, s.ratio, s.ratio_edge,
           s.status ? dth_strerror(s.status) : "ok");
    if (s.status) fprintf(stderr, "%s: %s\n", pb->name, s.msg);
}

static void table_models(double scale)
{
    printf("## Other systems with the default `smooth` (midpoint start)\n\n");
    printf("| problem | h | t reached | steps | crossings | non-symplectic steps | share | max midpoint energy error (rel. to its terms) | "
           "max quadratic-invariant error (rel.) | step ratio: max / at band edges | end |\n");
    printf("|---|---|---|---|---|---|---|---|---|---|---|\n");
    double orbits = 1000 * scale;
    if (orbits < 2) orbits = 2;
    for (int i = 0; i < 2; i++) {
        double e = i ? 0.99 : 0.9;
        problem pb = {.type = &dth_model_kepler, .n = 2, .h = i ? 0.002 : 0.01, .t_end = orbits * 2 * PI, .quad = {"L"}};
        static char nm[2][64];
        snprintf(nm[i], sizeof nm[i], "Kepler e = %g, %.0f orbits from apocentre", e, orbits);
        pb.name = nm[i];
        pb.q0[0] = -(1 + e), pb.q0[1] = 0, pb.p0[0] = 0, pb.p0[1] = -sqrt((1 - e) / (1 + e));
        row(&pb);
    }
    {
        /* the 2-D three-particle chain of scenes/coupled-chain3-prescribed.ini, started compressed */
        problem pb = {.name = "chain, 3 particles, 2-D, compressed", .type = &dth_model_coupled, .n = 6, .h = 0.01,
                      .t_end = fmax(20, 2000 * scale), .quad = {"Px", "Py", "Lz"}};
        pb.mkv[0] = (dth_kv){"preset", "chain"}, pb.mkv[1] = (dth_kv){"size", "3"}, pb.mkv[2] = (dth_kv){"dim", "2"};
        pb.nmkv = 3;
        double q[6] = {0, 0, 0.5, 0, 1.0, 0}, p[6] = {0, 1, 0, -2, 0, 1.5};
        memcpy(pb.q0, q, sizeof q), memcpy(pb.p0, p, sizeof p);
        row(&pb);
    }
    for (int st = 0; st < 2; st++) {
        /* a 3-D ring of 5 springs (L = 1: natural radius 0.8507), compressed (R = 0.5, tangential and
         * out-of-plane velocities) or stretched (R = 2, scenes/coupled-ring5-3d-stretched.ini: raw
         * DTH stops at a region II fold with psi = 1.03 > 0 at k = 85) */
        problem pb = {.type = &dth_model_coupled, .n = 15, .h = 0.02, .t_end = fmax(20, 2000 * scale), .quad = {"Px", "Py", "Pz", "Lx", "Ly", "Lz"}};
        pb.name = st ? "ring of 5, 3-D, stretched (R = 2)" : "ring of 5, 3-D, compressed (R = 0.5)";
        pb.mkv[0] = (dth_kv){"preset", "ring"}, pb.mkv[1] = (dth_kv){"size", "5"}, pb.mkv[2] = (dth_kv){"dim", "3"};
        pb.nmkv = 3;
        double R = st ? 2 : 0.5;
        for (int j = 0; j < 5; j++) {
            double a = 2 * PI * j / 5;
            pb.q0[3 * j] = R * cos(a), pb.q0[3 * j + 1] = R * sin(a);
            if (st) {
                /* the scene's six-digit values */
                pb.q0[3 * j] = round(1e6 * pb.q0[3 * j]) / 1e6, pb.q0[3 * j + 1] = round(1e6 * pb.q0[3 * j + 1]) / 1e6;
                pb.q0[3 * j + 2] = round(1e6 * 0.1 * sin(3 * a)) / 1e6;
                pb.p0[3 * j] = round(1e6 * 0.05 * j) / 1e6, pb.p0[3 * j + 1] = 0, pb.p0[3 * j + 2] = round(1e6 * 0.2 * cos(2 * a)) / 1e6;
            } else {
                pb.q0[3 * j + 2] = 0;
                pb.p0[3 * j] = -0.3 * sin(a), pb.p0[3 * j + 1] = 0.3 * cos(a), pb.p0[3 * j + 2] = 0.2 * cos(2 * a);
            }
        }
        row(&pb);
    }
    {
        /* Henon-Heiles at E = 1/6 (a user model): x = y = 0, px = 0.3, py from the energy */
        problem pb = {.name = "Henon-Heiles E = 1/6 (user model)", .type = &hh_type, .n = 2, .h = 0.05, .t_end = fmax(50, 1e4 * scale)};
        pb.q0[0] = 0, pb.q0[1] = 0, pb.p0[0] = 0.3, pb.p0[1] = sqrt(1.0 / 3 - 0.09);
        row(&pb);
    }
    printf("\n");
}

int main(int argc, char **argv)
{
    double scale = argc > 1 ? atof(argv[1]) : 1;
    if (!(scale > 0)) {
        fprintf(stderr, "usage: bench_smooth [scale > 0]\n");
        return 2;
    }
    printf("# bench_smooth %g\n\n", scale);
    table_pendulum(scale);
    table_roundtrip(scale);
    table_models(scale);
    return 0;
}
