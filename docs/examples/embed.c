/* SPDX-License-Identifier: MIT */
/*
 * Example of embedding dth in a program: register a user model (the double well) next to the
 * built-in ones so that a scene file can select it by name, validate it, and integrate it.
 * Only the public header is used. Build against an installed dth with
 *     cc embed.c double_well.c $(pkg-config --cflags --libs dth) -o embed
 * Usage: embed SCENE.ini [-s section.key=value]...
 */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <dth/dth.h>
#include "double_well.h"

int main(int argc, char **argv)
{
    if (argc < 2) {
        fprintf(stderr, "usage: %s SCENE.ini [-s section.key=value]...\n", argv[0]);
        return 2;
    }
    char err[512];
    int status = 1;
    dth_registry *reg = NULL;
    dth_scene *scene = NULL;
    dth_run_setup rs;
    memset(&rs, 0, sizeof rs);
    dth_integrator *it = NULL;

    /* 1. a registry: the built-in models plus ours, selectable by name from scene files */
    if (dth_registry_new(NULL, &reg) || dth_registry_add_builtin(reg) ||
        dth_registry_add_model(reg, &example_double_well)) {
        fprintf(stderr, "cannot set up the model registry\n");
        goto out;
    }
    /* 2. the scene file and overrides, validated against the registry */
    if (dth_scene_new(NULL, &scene) || dth_scene_load(scene, argv[1], err, sizeof err)) {
        fprintf(stderr, "%s\n", scene ? err : "out of memory");
        goto out;
    }
    for (int i = 2; i + 1 < argc; i += 2)
        if (strcmp(argv[i], "-s") || dth_scene_set(scene, argv[i + 1], err, sizeof err)) {
            fprintf(stderr, "bad override: %s\n", argv[i + 1]);
            goto out;
        }
    if (dth_scene_setup(scene, reg, &rs, err, sizeof err)) {
        fprintf(stderr, "%s\n", err);
        goto out;
    }
    /* 3. validate the model's derivatives before trusting a run */
    size_t n = rs.n, N = 2 * n + 2;
    double *y = calloc(N, sizeof *y);
    if (!y) goto out;
    memcpy(y, rs.q0, n * sizeof *y);
    y[n] = rs.t0;
    memcpy(y + n + 1, rs.p0, n * sizeof *y);
    dth_model_check_report rep;
    int rc = dth_model_check(rs.model, y, &rep);
    printf("model '%s' check: gradient %.1e, Hessian %.1e, third %.1e\n",
           dth_model_get_type(rs.model)->name, rep.grad_err, rep.hess_err, rep.third_err);
    if (rc || rep.grad_err > 1e-5 || rep.hess_err > 1e-5 || rep.third_err > 1e-5) {
        fprintf(stderr, "the model's derivatives do not match finite differences\n");
        free(y);
        goto out;
    }
    /* 4. integrate; the energy -wp holds at every midpoint */
    if (dth_integrator_new(rs.model, &rs.opt, &it) || dth_integrator_start(it, rs.q0, rs.p0, rs.t0)) {
        fprintf(stderr, "cannot start the integrator\n");
        free(y);
        goto out;
    }
    long steps = rs.has_t_end ? 1000000000L : rs.steps;
    double worst = 0, H;
    long k;
    for (k = 0; k < steps; k++) {
        const double *z = dth_integrator_vertex(it);
        if (rs.has_t_end && (z[n] - rs.t_end) * rs.opt.h >= 0) break;
        rc = dth_integrator_step(it, NULL);
        if (rc) {
            fprintf(stderr, "stopped at step %ld: %s (%s)\n", k, dth_strerror(rc), dth_integrator_errmsg(it));
            break;
        }
        const double *zb = dth_integrator_midpoint(it);
        if (dth_model_eval(rs.model, zb, DTH_EVAL_H, &H, NULL, NULL) == DTH_OK)
            worst = fmax(worst, fabs(zb[N - 1] + H));
    }
    const double *z = dth_integrator_vertex(it);
    printf("%ld steps to t = %.6f: q1 = %.9f, p1 = %.9f, max |H(zbar)| = %.2e\n", k, z[n], z[0], z[n + 1], worst);
    status = (rc == DTH_OK && worst <= 1e-14) ? 0 : 1;
    free(y);
out:
    dth_integrator_free(it);
    dth_run_setup_clear(&rs);
    dth_scene_free(scene);
    dth_registry_free(reg);
    return status;
}
