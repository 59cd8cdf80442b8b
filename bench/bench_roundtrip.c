/* SPDX-License-Identifier: MIT */
/*
 * Benchmark (not a test): round trips of the DTH step (paper, Theorem "DTH Equations": the step is
 * its own reverse) against implicit midpoint on the same orbit. DTH with its three finishes
 * (dth_options.compensate): 2, the reversible finish (the step and its reverse find the same root
 * to about 2^-100: double-double unknowns and offset, the model read at a coarsened midpoint);
 * 1, the compensated constraint (the default: the vertex offset carried from step to step); 0,
 * the plain constraint. S steps forward, reverse, S steps back; the distance to the start
 * relative to the state's size, and |t - t0| relative to the time span. Henon-Heiles regular
 * orbits at E = 1/12 (a user model; x = 0, y = 0.1 and four values of p_x) and the pendulum; raw
 * DTH (no regularizer: psi > 0 on these orbits).
 * Usage: bench_roundtrip [scale]   (scale 1: 10^4 and 10^6 steps; 0.01: 100 and 10^4)
 */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include "bench_common.h"
#include "dth/dth.h"
#include "symp_models.h" /* the Henon-Heiles user model (hh_type) */


typedef struct rt {
    double dz, dt;
    int rc;
} rt;

/* Distance of (q, p) to the start relative to max(|q0|, |p0|, 1), and of t relative to t_span. */
static rt measure(size_t n, const double *y0, const double *y, double t_span, int rc)
{
    rt r = {0, 0, rc};
    double sc = 1;
    for (size_t i = 0; i < n; i++) sc = fmax(sc, fmax(fabs(y0[i]), fabs(y0[n + 1 + i])));
    for (size_t i = 0; i < n; i++) r.dz = fmax(r.dz, fmax(fabs(y[i] - y0[i]), fabs(y[n + 1 + i] - y0[n + 1 + i])) / sc);
    r.dt = fabs(y[n] - y0[n]) / t_span;
    return r;
}

static rt dth_roundtrip(const dth_model *m, const double *q0, const double *p0, double h, long S, int compensate)
{
    dth_options o;
    dth_options_default(&o);
    o.h = h;
    o.finish = (dth_finish)compensate;
    dth_integrator *it = NULL;
    if (dth_integrator_new(m, &o, &it) || dth_integrator_start(it, q0, p0, 0.0)) exit(1);
    size_t n = dth_model_dof(m), N = 2 * n + 2;
    dth_step_info inf;
    int rc = dth_integrator_step(it, &inf); /* past the exact first step: from the first vertex on */
    double z0[64];
    memcpy(z0, dth_integrator_vertex(it), N * sizeof *z0);
    for (long k = 0; !rc && k < S; k++) rc = dth_integrator_step(it, &inf);
    double span = dth_integrator_vertex(it)[n] - z0[n];
    dth_integrator_reverse(it);
    for (long k = 0; !rc && k < S; k++) rc = dth_integrator_step(it, &inf);
    rt r = measure(n, z0, dth_integrator_vertex(it), span, rc);
    dth_integrator_free(it);
    return r;
}

static rt midpoint_roundtrip(const dth_model *m, const double *q0, const double *p0, double h, long S)
{
    dth_integrator *f = NULL;
    if (bench_baseline(m, "midpoint", h, q0, p0, &f)) exit(1);
    size_t n = dth_model_dof(m);
    double y0[64];
    memcpy(y0, dth_integrator_vertex(f), (2 * n + 1) * sizeof *y0);
    int rc = 0;
    for (long k = 0; !rc && k < S; k++) rc = dth_integrator_step(f, NULL);
    double span = dth_integrator_vertex(f)[n] - y0[n];
    dth_integrator_reverse(f);
    for (long k = 0; !rc && k < S; k++) rc = dth_integrator_step(f, NULL);
    rt r = measure(n, y0, dth_integrator_vertex(f), span, rc);
    dth_integrator_free(f);
    return r;
}

int main(int argc, char **argv)
{
    double scale = argc > 1 ? atof(argv[1]) : 1;
    if (!(scale > 0)) {
        fprintf(stderr, "usage: bench_roundtrip [scale > 0]\n");
        return 2;
    }
    char err[256];
    dth_model *hh = NULL, *pend = NULL;
    if (dth_model_new(&hh_type, NULL, 0, 2, NULL, &hh, err, sizeof err) ||
        dth_model_new(&dth_model_pendulum, NULL, 0, 1, NULL, &pend, err, sizeof err)) {
        fprintf(stderr, "%s\n", err);
        return 1;
    }
    /* Henon-Heiles E = 1/12: x = 0, y = 0.1, px given, py from the energy */
    double pxs[4] = {0.35, 0.3, 0.25, 0.2}, hq[2] = {0, 0.1}, hp[4][2];
    double V = 0.5 * 0.01 - 0.001 / 3;
    for (int i = 0; i < 4; i++) {
        hp[i][0] = pxs[i];
        hp[i][1] = sqrt(2 * (1.0 / 12 - V) - pxs[i] * pxs[i]);
    }
    double pq = 1, pp = 0;
    printf("# bench_roundtrip %g: S steps forward, reverse, S back; |q, p| error relative to the state, |t| relative to the span\n\n", scale);
    printf("| orbit | h | S | implicit midpoint: q, p / t | DTH reversible (compensate = 2): q, p / t | DTH compensated (1, default): q, p / t | DTH plain (0): q, p / t | ratio to midpoint (q, p): reversible, compensated |\n");
    printf("|---|---|---|---|---|---|---|---|\n");
    long Ss[2] = {(long)fmax(100, 1e4 * scale), (long)fmax(1000, 1e6 * scale)};
    struct {
        const char *name;
        const dth_model *m;
        const double *q, *p;
        double h;
    } orb[] = {{"Henon-Heiles E = 1/12, p_x = 0.35", hh, hq, hp[0], 0.05}, {"Henon-Heiles E = 1/12, p_x = 0.30", hh, hq, hp[1], 0.05},
               {"Henon-Heiles E = 1/12, p_x = 0.25", hh, hq, hp[2], 0.05}, {"Henon-Heiles E = 1/12, p_x = 0.20", hh, hq, hp[3], 0.05},
               {"pendulum, amplitude 1 rad", pend, &pq, &pp, 0.05}, {"pendulum, amplitude 1 rad", pend, &pq, &pp, 1e-3}};
    for (size_t i = 0; i < sizeof orb / sizeof orb[0]; i++)
        for (int j = 0; j < 2; j++) {
            long S = Ss[j];
            if (orb[i].h < 0.01 && j == 1) continue;
            rt a = midpoint_roundtrip(orb[i].m, orb[i].q, orb[i].p, orb[i].h, S);
            rt r = dth_roundtrip(orb[i].m, orb[i].q, orb[i].p, orb[i].h, S, 2);
            rt b = dth_roundtrip(orb[i].m, orb[i].q, orb[i].p, orb[i].h, S, 1);
            rt c = dth_roundtrip(orb[i].m, orb[i].q, orb[i].p, orb[i].h, S, 0);
            printf("| %s | %g | %ld | %.1e / %.1e | %.1e / %.1e%s | %.1e / %.1e%s | %.1e / %.1e%s | %.0f, %.0f |\n", orb[i].name, orb[i].h, S, a.dz,
                   a.dt, r.dz, r.dt, r.rc ? " (stopped)" : "", b.dz, b.dt, b.rc ? " (stopped)" : "", c.dz, c.dt, c.rc ? " (stopped)" : "",
                   r.dz / fmax(a.dz, 1e-300), b.dz / fmax(a.dz, 1e-300));
            fflush(stdout);
        }
    dth_model_free(hh);
    dth_model_free(pend);
    return 0;
}
