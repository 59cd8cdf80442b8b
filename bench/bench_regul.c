/* SPDX-License-Identifier: MIT */
/*
 * Benchmark (not a test): compares the shipped regularizers across psi = 0 (paper, section 7) on
 * the rotating pendulum and Kepler orbits with e = 0.9 / 0.99, and prints the table of
 * docs/regularization.md: crossings survived, energy and momentum errors, round-trip error, step
 * ratio at crossings, tangent-map defect of the crossing map, cost per step.
 * Usage: bench_regul [steps]   (default 100000 steps per long run)
 */
#include <float.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>
#include "dth/dth.h"
#include "bench_common.h"

typedef struct problem {
    const char *name;
    const dth_model_type *type;
    dth_kv kv[2];
    size_t nkv, n;
    double q0[3], p0[3], h;
    dth_start start;
} problem;

typedef struct result {
    long steps, crossings, regs;
    int status;
    double t_end, energy, wp_change, inv_err, max_ratio, secs;
} result;

static dth_model *make_model(const problem *pb)
{
    dth_model *m = NULL;
    char err[256];
    if (dth_model_new(pb->type, pb->kv, pb->nkv, pb->n, NULL, &m, err, sizeof err)) {
        fprintf(stderr, "%s: %s\n", pb->name, err);
        exit(1);
    }
    return m;
}

static dth_regularizer *make_reg(const dth_regularizer_type *t, const dth_kv *kv, size_t nkv, const dth_model *m)
{
    dth_regularizer *r = NULL;
    char err[256];
    if (dth_regularizer_new(t, kv, nkv, m, NULL, &r, err, sizeof err)) {
        fprintf(stderr, "%s: %s\n", t->name, err);
        exit(1);
    }
    return r;
}

static dth_integrator *make_it(const problem *pb, const dth_model *m, dth_regularizer *r)
{
    dth_options o;
    dth_options_default(&o);
    o.h = pb->h;
    o.start = pb->start;
    o.regularizer = r;
    /* prescribed replaces every ordinary step: searching that step's roots is wasted work */
    if (r && dth_regularizer_get_type(r) == &dth_reg_prescribed) o.branch_check = 0;
    dth_integrator *it = NULL;
    if (dth_integrator_new(m, &o, &it) || dth_integrator_start(it, pb->q0, pb->p0, 0.0)) {
        fprintf(stderr, "%s: cannot start\n", pb->name);
        exit(1);
    }
    return it;
}

/* |wp + H_phys(zbar)| relative to the size of H's terms at the midpoint. */
static double midpoint_energy(const dth_model *m, const double *zb, size_t N)
{
    double H, g[64];
    if (N - 1 > 64 || dth_model_eval(m, zb, DTH_EVAL_H | DTH_EVAL_GRAD, &H, g, NULL)) return INFINITY;
    double s = fabs(zb[N - 1]) + fabs(H);
    for (size_t j = 0; j + 1 < N; j++) s += fabs(g[j] * zb[j]);
    return fabs(zb[N - 1] + H) / s;
}

/* Quadratic invariant to watch: index 0 for Kepler (L), none otherwise. */
static int watch_inv(const dth_model *m, const double *z, double *I)
{
    const dth_model_type *t = dth_model_get_type(m);
    if (strcmp(t->name, "kepler") != 0) return 0;
    size_t n = dth_model_dof(m);
    *I = z[0] * z[n + 1 + 1] - z[1] * z[n + 1];
    return 1;
}

static result run(const problem *pb, const dth_regularizer_type *rt, const dth_kv *kv, size_t nkv, long steps)
{
    result rs = {0};
    dth_model *m = make_model(pb);
    dth_regularizer *r = rt ? make_reg(rt, kv, nkv, m) : NULL;
    dth_integrator *it = make_it(pb, m, r);
    size_t N = dth_integrator_dim(it);
    double wp0 = dth_integrator_vertex(it)[N - 1], I0 = 0, I;
    int has_inv = watch_inv(m, dth_integrator_vertex(it), &I0);
    double lprev = 0;
    int after_reg = 0;
    double t0 = bench_now();
    for (long k = 0; k < steps; k++) {
        dth_step_info inf;
        int rc = dth_integrator_step(it, &inf);
        if (rc) {
            rs.status = rc;
            break;
        }
        rs.steps++;
        double lseg = dth_integrator_lambda(it);
        if (inf.flags & DTH_STEP_CROSSING) rs.crossings++;
        if (inf.flags & DTH_STEP_REGULARIZED) rs.regs++;
        /* step ratio around regularized steps: incoming -> crossing segment (a chain's segments
         * are equal), and crossing segment -> the next step */
        if (lprev != 0 && ((inf.flags & DTH_STEP_REGULARIZED) || after_reg)) {
            double q = fabs(lseg / lprev);
            if (q < 1) q = 1 / q;
            if (q > rs.max_ratio) rs.max_ratio = q;
        }
        after_reg = (inf.flags & DTH_STEP_REGULARIZED) != 0;
        lprev = lseg;
        const double *zb = dth_integrator_midpoint(it);
        double e = midpoint_energy(m, zb, N);
        if (e > rs.energy) rs.energy = e;
        const double *z = dth_integrator_vertex(it);
        if (z[N - 1] != wp0) rs.wp_change = fmax(rs.wp_change, fabs(z[N - 1] - wp0));
        if (has_inv && watch_inv(m, z, &I)) rs.inv_err = fmax(rs.inv_err, fabs(I - I0) / fabs(I0));
    }
    rs.secs = bench_now() - t0;
    rs.t_end = dth_integrator_vertex(it)[pb->n];
    dth_integrator_free(it);
    dth_regularizer_free(r);
    dth_model_free(m);
    return rs;
}

/* Forward `steps`, reverse, the same number back: relative distance to the start, and crossings. */
static double round_trip(const problem *pb, const dth_regularizer_type *rt, const dth_kv *kv, size_t nkv,
                         long steps, long *crossings, int *status)
{
    dth_model *m = make_model(pb);
    dth_regularizer *r = rt ? make_reg(rt, kv, nkv, m) : NULL;
    dth_integrator *it = make_it(pb, m, r);
    size_t N = dth_integrator_dim(it);
    dth_step_info inf;
    *status = dth_integrator_step(it, &inf); /* first step: from here on the vertex is a true vertex */
    double z0[16], nz = 0, err = 0;
    memcpy(z0, dth_integrator_vertex(it), N * sizeof *z0);
    *crossings = 0;
    long k;
    for (k = 0; k < steps && !*status; k++) {
        *status = dth_integrator_step(it, &inf);
        if (inf.flags & DTH_STEP_CROSSING) ++*crossings;
    }
    dth_integrator_reverse(it);
    for (long j = 0; j < k && !*status; j++) *status = dth_integrator_step(it, &inf);
    const double *z = dth_integrator_vertex(it);
    for (size_t j = 0; j < N; j++) {
        nz = fmax(nz, fabs(z0[j]));
        err = fmax(err, fabs(z[j] - z0[j]));
    }
    dth_integrator_free(it);
    dth_regularizer_free(r);
    dth_model_free(m);
    return err / nz;
}

/*
 * Tangent-map defect max|M^T J M - J| of one step by central differences (eps), at the first
 * vertex where the step is regularized (reg = 1) or at the first ordinary step (reg = 0).
 */
static double tangent_defect(const problem *pb, const dth_regularizer_type *rt, const dth_kv *kv, size_t nkv,
                             int reg, double eps)
{
    dth_model *m = make_model(pb);
    dth_regularizer *r = rt ? make_reg(rt, kv, nkv, m) : NULL;
    dth_integrator *it = make_it(pb, m, r);
    size_t N = dth_integrator_dim(it), n = pb->n;
    double za[16], lam = 0;
    int found = 0;
    dth_step_info inf;
    dth_integrator_step(it, &inf);
    for (long k = 0; k < 100000; k++) {
        memcpy(za, dth_integrator_vertex(it), N * sizeof *za);
        lam = dth_integrator_lambda(it);
        if (dth_integrator_step(it, &inf)) break;
        if (((inf.flags & DTH_STEP_REGULARIZED) != 0) == reg && k > 3) {
            found = 1;
            break;
        }
    }
    double defect = NAN;
    if (found) {
        double M[256], zp[16], zm[16], zz[16];
        for (size_t j = 0; j < N; j++) {
            double e = eps * fmax(1.0, fabs(za[j]));
            int ok = 1;
            for (int s = 0; s < 2 && ok; s++) {
                memcpy(zz, za, N * sizeof *zz);
                zz[j] += s ? -e : e;
                if (dth_integrator_set_vertex(it, zz, lam) || dth_integrator_step(it, &inf)) ok = 0;
                else memcpy(s ? zm : zp, dth_integrator_vertex(it), N * sizeof *zp);
            }
            if (!ok) {
                found = 0;
                break;
            }
            for (size_t i = 0; i < N; i++) M[i * N + j] = (zp[i] - zm[i]) / (2 * e);
        }
        if (found) {
            /* J pairs (q_i, p_i) and (t, wp): J[i][i + n + 1] = 1, J[i + n + 1][i] = -1 */
            defect = 0;
            for (size_t a = 0; a < N; a++)
                for (size_t b = 0; b < N; b++) {
                    double s = 0;
                    for (size_t i = 0; i <= n; i++) s += M[i * N + a] * M[(i + n + 1) * N + b] - M[(i + n + 1) * N + a] * M[i * N + b];
                    double Jab = (b == a + n + 1) ? 1.0 : (a == b + n + 1 ? -1.0 : 0.0);
                    defect = fmax(defect, fabs(s - Jab));
                }
        }
    }
    dth_integrator_free(it);
    dth_regularizer_free(r);
    dth_model_free(m);
    return defect;
}

static void fmt_or_dash(char *buf, size_t len, const char *fmt, double v)
{
    if (isfinite(v) && v > 0) snprintf(buf, len, fmt, v);
    else snprintf(buf, len, "-");
}

int main(int argc, char **argv)
{
    long steps = argc > 1 ? atol(argv[1]) : 100000;
    problem pend = {"pendulum q0=0 p0=2.2 h=0.05", &dth_model_pendulum, {{0}}, 0, 1, {0}, {2.2}, 0.05, DTH_START_VERTEX};
    /* Kepler (mu = 1, a = 1) from apocentre */
    problem kep9 = {"kepler e=0.9 h=0.01", &dth_model_kepler, {{0}}, 0, 2, {-1.9, 0}, {0, 0}, 0.01, DTH_START_MIDPOINT};
    kep9.p0[1] = -sqrt(0.1 / 1.9);
    problem kep99 = {"kepler e=0.99 h=0.002", &dth_model_kepler, {{0}}, 0, 2, {-1.99, 0}, {0, 0}, 0.002, DTH_START_MIDPOINT};
    kep99.p0[1] = -sqrt(0.01 / 1.99);
    const problem *pbs[] = {&pend, &kep9, &kep99};
    static const dth_kv reseed_kv[] = {{"step", "0.1"}};
    static const dth_kv presc0_kv[] = {{"alpha", "0"}}, presc75_kv[] = {{"alpha", "0.75"}};
    struct {
        const char *label;
        const dth_regularizer_type *t;
        const dth_kv *kv;
        size_t nkv;
    } regs[] = {
        {"none", &dth_reg_none, NULL, 0},
        {"reseed", &dth_reg_reseed, NULL, 0},
        {"reseed step=0.1", &dth_reg_reseed, reseed_kv, 1},
        {"symkick", &dth_reg_symkick, NULL, 0},
        {"prescribed alpha=0", &dth_reg_prescribed, presc0_kv, 1},
        {"prescribed alpha=0.75", &dth_reg_prescribed, presc75_kv, 1},
    };
    size_t nr = sizeof regs / sizeof regs[0];
    printf("# bench_regul %ld: long runs of %ld steps; round trip 2 x 2000 steps; tangent defect by central differences (eps 1e-7)\n", steps, steps);
    printf("| problem | regularizer | steps run | end status | t reached | crossings | max midpoint energy residual (rel.) | wp change | max rel. L error | round trip (rel.) [crossings] | max step ratio at crossings | tangent defect crossing / ordinary | us per step |\n");
    printf("|---|---|---|---|---|---|---|---|---|---|---|---|---|\n");
    for (size_t p = 0; p < sizeof pbs / sizeof pbs[0]; p++) {
        for (size_t i = 0; i < nr; i++) {
            int is_pend = pbs[p]->type == &dth_model_pendulum;
            if (!is_pend && regs[i].kv == reseed_kv) continue; /* step= is pendulum-scaled */
            if (is_pend == (regs[i].kv == presc75_kv) && regs[i].t == &dth_reg_prescribed) continue; /* alpha 0: pendulum, 0.75: Kepler */
            result rs = run(pbs[p], regs[i].t, regs[i].kv, regs[i].nkv, steps);
            long rc_cross;
            int rst;
            double rt = round_trip(pbs[p], regs[i].t, regs[i].kv, regs[i].nkv, 2000, &rc_cross, &rst);
            double dc = tangent_defect(pbs[p], regs[i].t, regs[i].kv, regs[i].nkv, 1, 1e-7);
            double dp = tangent_defect(pbs[p], regs[i].t, regs[i].kv, regs[i].nkv, 0, 1e-7);
            char trip[64];
            if (rst) snprintf(trip, sizeof trip, "(%s) [%ld]", dth_status_name(rst), rc_cross);
            else snprintf(trip, sizeof trip, "%.1e [%ld]", rt, rc_cross);
            char inv[32];
            if (pbs[p]->type == &dth_model_kepler) snprintf(inv, sizeof inv, "%.1e", rs.inv_err);
            else snprintf(inv, sizeof inv, "-");
            /* "-": not applicable (no crossing, or no ordinary step, found within the probe) */
            char ratio[32], dcs[32], dps[32];
            fmt_or_dash(ratio, sizeof ratio, "%.3f", rs.max_ratio);
            fmt_or_dash(dcs, sizeof dcs, "%.1e", dc);
            fmt_or_dash(dps, sizeof dps, "%.1e", dp);
            printf("| %s | %s | %ld | %s | %.1f | %ld | %.1e | %.1e | %s | %s | %s | %s / %s | %.2f |\n", pbs[p]->name,
                   regs[i].label, rs.steps, rs.status ? dth_status_name(rs.status) : "ok", rs.t_end, rs.crossings, rs.energy,
                   rs.wp_change, inv, trip, ratio, dcs, dps, rs.steps ? 1e6 * rs.secs / (double)rs.steps : 0.0);
            fflush(stdout);
        }
    }
    /* symkick's round trips through 1, 2, 4 pendulum crossings: each crossing is its own reverse,
     * but the crossing map expands perturbations, round-off included */
    printf("\n## symkick round trips, pendulum (S steps after the first, reverse, S back)\n\n| S | crossings | round trip (rel.) |\n|---|---|---|\n");
    const long Ss[] = {30, 60, 150};
    for (size_t i = 0; i < 3; i++) {
        long cr;
        int st;
        double rt = round_trip(&pend, &dth_reg_symkick, NULL, 0, Ss[i], &cr, &st);
        if (st) printf("| %ld | %ld | (%s) |\n", Ss[i], cr, dth_status_name(st));
        else printf("| %ld | %ld | %.1e |\n", Ss[i], cr, rt);
    }
    return 0;
}
