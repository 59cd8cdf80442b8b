/* SPDX-License-Identifier: MIT */
/*
 * Crossings of psi = 0 at fixed times (docs/regularization.md, "land"; paper, section 7): the global
 * position error at T = 10 and T = 100 against the exact solution, its observed order between
 * successive h, the replaced steps and the cost per step, for each regularizer (and land without its
 * clock correction) on the rotating pendulum (q0 = 0, p0 = 2.2) and Kepler e = 0.9 (from its
 * apocentre), midpoint start. The error is the largest of |q_i - q_i(T)|, |p_i - p_i(T)| at the end.
 * Usage: bench_crossing [T_long [cost]]   (default 100; `cost`: the cost table only)
 */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include "bench_common.h"
#include "dth/dth.h"

typedef struct end_point {
    double z[8];
} end_point;

static int on_sample(void *user, const dth_sample *s)
{
    if (s->kind == DTH_SAMPLE_END) memcpy(((end_point *)user)->z, s->z, sizeof ((end_point *)user)->z);
    return 0;
}

typedef struct result {
    int rc;
    double err, secs;
    long steps, replaced;
} result;

static result run(const dth_model *m, const dth_regularizer_type *rt, const dth_kv *kv, size_t nkv, const double *q0,
                  const double *p0, double h, double T)
{
    result r = {0, NAN, 0, 0, 0};
    dth_options o;
    dth_options_default(&o);
    o.h = h;
    dth_regularizer *rg = NULL;
    if (rt && dth_regularizer_new(rt, kv, nkv, m, NULL, &rg, NULL, 0)) exit(1);
    o.regularizer = rg;
    if (rt == &dth_reg_prescribed) o.branch_check = 0; /* it computes no ordinary step */
    dth_integrator *it = NULL;
    if (dth_integrator_new(m, &o, &it) || dth_integrator_start(it, q0, p0, 0)) exit(1);
    dth_run_config c;
    dth_run_config_default(&c);
    c.has_t_end = 1;
    c.t_end = T;
    c.t0 = 0;
    end_point e;
    c.sample = on_sample;
    c.user = &e;
    dth_run_state st;
    dth_run_state_init(&st);
    double t0 = bench_now();
    r.rc = dth_run(it, &c, &st);
    r.secs = bench_now() - t0;
    r.steps = st.k;
    r.replaced = st.regularized;
    size_t n = dth_model_dof(m);
    double y0[8] = {0}, ye[8];
    memcpy(y0, q0, n * sizeof *y0);
    memcpy(y0 + n + 1, p0, n * sizeof *y0);
    if (!r.rc && dth_model_exact(m, y0, T, ye) == DTH_OK) {
        double s = 0;
        for (size_t i = 0; i < n; i++) s = fmax(s, fmax(fabs(e.z[i] - ye[i]), fabs(e.z[n + 1 + i] - ye[n + 1 + i])));
        r.err = s;
    }
    dth_integrator_free(it);
    dth_regularizer_free(rg);
    return r;
}

static void table(const char *name, const dth_model *m, const double *q0, const double *p0, const double *hs, int nh,
                  const double *Ts, int nT)
{
    /* land without its clock correction: what the correction of t near psi = 0 buys */
    static const dth_kv noclock[] = {{"clock", "no"}};
    const struct {
        const dth_regularizer_type *type;
        const dth_kv *kv;
        size_t nkv;
        const char *name;
    } regs[] = {{&dth_reg_land, NULL, 0, "land"}, {&dth_reg_land, noclock, 1, "land clock=no"}, {&dth_reg_prescribed, NULL, 0, "prescribed"}};
    printf("\n#### %s\n\n| regularizer | T | h | error | order | steps | replaced | us/step |\n|---|---|---|---|---|---|---|---|\n",
           name);
    for (size_t g = 0; g < sizeof regs / sizeof regs[0]; g++)
        for (int k = 0; k < nT; k++) {
            double prev = NAN;
            for (int i = 0; i < nh; i++) {
                result r = run(m, regs[g].type, regs[g].kv, regs[g].nkv, q0, p0, hs[i], Ts[k]);
                char ord[32] = "";
                if (i > 0 && r.err > 0 && prev > 0) snprintf(ord, sizeof ord, "%.2f", log(prev / r.err) / log(hs[i - 1] / hs[i]));
                if (r.rc) printf("| %s | %g | %g | stopped (%s) | | %ld | %ld | |\n", regs[g].name, Ts[k], hs[i],
                                 dth_status_name(r.rc), r.steps, r.replaced);
                else
                    printf("| %s | %g | %g | %.3e | %s | %ld | %ld | %.2f |\n", regs[g].name, Ts[k], hs[i], r.err, ord,
                           r.steps, r.replaced, 1e6 * r.secs / (double)r.steps);
                prev = r.rc ? NAN : r.err;
            }
        }
}

/*
 * Cost (issue 23): CPU time per step of the rotating pendulum with `land` against a libration (q0 = 0,
 * p0 = 1) with no regularizer, h = 0.05 to T = 100, the two runs interleaved and the best of `reps` each.
 */
static void cost(const dth_model *m, int reps)
{
    double best[2] = {INFINITY, INFINITY}, q0 = 0, p[2] = {1.0, 2.2};
    long steps[2] = {0, 0}, replaced = 0;
    for (int k = 0; k < reps; k++)
        for (int g = 0; g < 2; g++) {
            result r = run(m, g ? &dth_reg_land : NULL, NULL, 0, &q0, &p[g], 0.05, 100);
            if (r.rc) {
                printf("cost run %d stopped: %s\n", g, dth_status_name(r.rc));
                return;
            }
            best[g] = fmin(best[g], r.secs / (double)r.steps);
            steps[g] = r.steps;
            if (g) replaced = r.replaced;
        }
    printf("\n#### cost per step, h = 0.05, T = 100 (best of %d, interleaved)\n\n"
           "| run | steps | replaced | us/step | ratio |\n|---|---|---|---|---|\n"
           "| libration p0 = 1, none | %ld | 0 | %.3f | 1 |\n| rotation p0 = 2.2, land | %ld | %ld | %.3f | %.2f |\n",
           reps, steps[0], 1e6 * best[0], steps[1], replaced, 1e6 * best[1], best[1] / best[0]);
}

int main(int argc, char **argv)
{
    double Tl = argc > 1 ? atof(argv[1]) : 100;
    dth_model *pend = NULL, *kep = NULL;
    if (dth_model_new(&dth_model_pendulum, NULL, 0, 1, NULL, &pend, NULL, 0) ||
        dth_model_new(&dth_model_kepler, NULL, 0, 2, NULL, &kep, NULL, 0))
        return 1;
    const double hs[] = {0.05, 0.025, 0.0125, 0.00625}, Ts[] = {10, Tl};
    double q0 = 0, p0 = 2.2;
    int only_cost = argc > 2 && !strcmp(argv[2], "cost");
    if (!only_cost) {
        table("rotating pendulum q0 = 0, p0 = 2.2", pend, &q0, &p0, hs, 4, Ts, 2);
        double e = 0.9, kq[2] = {-(1 + e), 0}, kp[2] = {0, -sqrt((1 - e) / (1 + e))};
        table("Kepler e = 0.9 from the apocentre", kep, kq, kp, hs, 4, Ts, 2);
    }
    cost(pend, 15);
    dth_model_free(pend);
    dth_model_free(kep);
    return 0;
}
