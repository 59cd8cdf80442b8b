/* SPDX-License-Identifier: MIT */
/*
 * Benchmark (not a test): phase accuracy of the regularizers across psi = 0 (paper, section 7) on
 * the rotating pendulum q0 = 0, p0 = 2.2: the mean time per revolution over the first R
 * revolutions against the exact period 2 K(k) k (omega = 1, k^2 = 2/(1 + E)), for h, h/2, h/4,
 * and the observed order log2(err(h)/err(h/2)).
 * Usage: bench_regul_phase [revolutions]   (default 20)
 */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <gsl/gsl_sf_ellint.h>
#include "dth/dth.h"

#define PI 3.14159265358979323846

/* Mean period over R revolutions (t where q crosses 2 pi j, by linear interpolation), or NAN. */
static double mean_period(const dth_regularizer_type *rt, const dth_kv *kv, size_t nkv, double h, int R, int *status)
{
    dth_model *m = NULL;
    dth_regularizer *r = NULL;
    char err[256];
    if (dth_model_new(&dth_model_pendulum, NULL, 0, 1, NULL, &m, err, sizeof err) ||
        dth_regularizer_new(rt, kv, nkv, m, NULL, &r, err, sizeof err)) {
        fprintf(stderr, "%s\n", err);
        exit(1);
    }
    dth_options o;
    dth_options_default(&o);
    o.h = h;
    o.start = DTH_START_MIDPOINT; /* the energy is exactly that of (q0, p0) */
    o.regularizer = r;
    dth_integrator *it = NULL;
    double q0 = 0, p0 = 2.2, t1 = NAN, tR = NAN;
    if (dth_integrator_new(m, &o, &it) || dth_integrator_start(it, &q0, &p0, 0.0)) exit(1);
    double qa = 0, ta = 0;
    int j = 1;
    *status = 0;
    while (j <= R + 1) {
        dth_step_info inf;
        int rc = dth_integrator_step(it, &inf);
        if (rc) {
            *status = rc;
            break;
        }
        const double *z = dth_integrator_vertex(it);
        while (j <= R + 1 && z[0] >= 2 * PI * j) {
            double t = ta + (2 * PI * j - qa) / (z[0] - qa) * (z[1] - ta);
            if (j == 1) t1 = t;
            if (j == R + 1) tR = t;
            j++;
        }
        qa = z[0];
        ta = z[1];
    }
    dth_integrator_free(it);
    dth_regularizer_free(r);
    dth_model_free(m);
    return (tR - t1) / R;
}

int main(int argc, char **argv)
{
    int R = argc > 1 ? atoi(argv[1]) : 20;
    double E = 0.5 * 2.2 * 2.2 - 1, k = sqrt(2 / (1 + E));
    double T = 2 * gsl_sf_ellint_Kcomp(k, GSL_PREC_DOUBLE) * k;
    printf("# exact period %.15f; mean time per revolution over revolutions 1..%d\n", T, R + 1);
    printf("| regularizer | h | period error | observed order | end |\n|---|---|---|---|---|\n");
    static const dth_kv alpha0 = {"alpha", "0"};
    struct { const char *label; const dth_regularizer_type *t; const dth_kv *kv; size_t nkv; } regs[] = {
        {"land (the default)", &dth_reg_land, NULL, 0}, {"prescribed alpha=0", &dth_reg_prescribed, &alpha0, 1}};
    for (size_t i = 0; i < sizeof regs / sizeof regs[0]; i++) {
        double prev = NAN;
        for (double h = 0.05; h > 0.006; h /= 2) {
            int st;
            double P = mean_period(regs[i].t, regs[i].kv, regs[i].nkv, h, R, &st);
            double e = P - T;
            char err[32] = "-", ord[32] = "-";
            if (isfinite(e)) snprintf(err, sizeof err, "%+.3e", e);
            if (isfinite(prev) && isfinite(e)) snprintf(ord, sizeof ord, "%.2f", log2(fabs(prev / e)));
            printf("| %s | %.5f | %s | %s | %s |\n", regs[i].label, h, err, ord, st ? dth_status_name(st) : "ok");
            prev = e;
        }
    }
    return 0;
}
