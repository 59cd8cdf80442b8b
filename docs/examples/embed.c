/* SPDX-License-Identifier: MIT */
/*
 * Example of embedding dth in a program: register a user model (the double well) next to the
 * built-in ones so that a scene file can select it by name, validate it, and integrate it with
 * the library's run driver (dth_run), writing the same CSV rows as `dth run` (without the
 * diagnostics columns) to standard output. Only the public header is used. Build against an
 * installed dth with
 *     cc embed.c double_well.c $(pkg-config --cflags --libs dth) -o embed
 * Usage: embed SCENE.ini [-s section.key=value]...
 * Exit status 0 when the run ends and the energy held at every midpoint to 1e-14 (relative).
 */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <dth/dth.h>
#include "double_well.h"

/* What the sample callback needs. */
typedef struct out {
    const dth_run_setup *rs;
    double E0;      /* the energy -wp */
    double worst;   /* largest |E - E0| on midpoint samples */
} out;

/* One CSV row per sample, formatted as `dth run` formats them. */
static int on_sample(void *user, const dth_sample *s)
{
    out *o = user;
    const dth_run_setup *rs = o->rs;
    size_t n = rs->n, N = 2 * n + 2;
    const double *z = s->z;
    double E = NAN;
    if (dth_model_eval(rs->model, z, DTH_EVAL_H, &E, NULL, NULL) != DTH_OK) E = NAN;
    long k = s->kind == DTH_SAMPLE_TIME || (s->kind == DTH_SAMPLE_END && rs->dt > 0) ? s->index : s->k;
    printf("%ld,%.17g,%.17g", k, z[n], s->step->lambda);
    for (size_t i = 0; i < n; i++) printf(",%.17g", z[i]);
    for (size_t i = 0; i < n; i++) printf(",%.17g", z[n + 1 + i]);
    printf(",%.17g,%.17g,%.17g", z[N - 1], z[N - 1] + E, E);
    /* with a regularizer (the default `land`): was the step an ordinary (symplectic) DTH step? */
    if (rs->regularizer) printf(",%d", (s->step->flags & DTH_STEP_REGULARIZED) ? 0 : 1);
    printf("\n");
    if (s->kind == DTH_SAMPLE_MIDPOINT) o->worst = fmax(o->worst, fabs(E - o->E0) / fmax(fabs(o->E0), 1e-300));
    return ferror(stdout) ? DTH_EIO : 0;
}

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
    double *y = NULL;

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
    for (int i = 2; i < argc; i += 2) {
        if (i + 1 == argc) {
            fprintf(stderr, "'%s' has no value (usage: %s SCENE.ini [-s section.key=value]...)\n", argv[i], argv[0]);
            goto out;
        }
        if (strcmp(argv[i], "-s") || dth_scene_set(scene, argv[i + 1], err, sizeof err)) {
            fprintf(stderr, "bad override: %s\n", argv[i + 1]);
            goto out;
        }
    }
    if (dth_scene_setup(scene, reg, &rs, err, sizeof err)) {
        fprintf(stderr, "%s\n", err);
        goto out;
    }
    if (strcmp(rs.method, "dth")) {
        fprintf(stderr, "this example runs method = dth only\n");
        goto out;
    }
    /* 3. validate the model's derivatives before trusting a run: the check's verdict */
    size_t n = rs.n;
    y = calloc(2 * n + 1, sizeof *y);
    if (!y) goto out;
    memcpy(y, rs.q0, n * sizeof *y);
    y[n] = rs.t0;
    memcpy(y + n + 1, rs.p0, n * sizeof *y);
    dth_model_check_report rep;
    int rc = dth_model_check(rs.model, y, &rep);
    fprintf(stderr, "model '%s' check: %s\n", dth_model_get_type(rs.model)->name, rc ? dth_strerror(rc) : rep.message);
    if (rc || !rep.pass) goto out;
    /* 4. integrate with the run driver: what the scene asks for, rows to stdout */
    if (dth_integrator_new(rs.model, &rs.opt, &it) || dth_integrator_start(it, rs.q0, rs.p0, rs.t0)) {
        fprintf(stderr, "cannot start the integrator\n");
        goto out;
    }
    out o = {&rs, 0, 0};
    double H;
    if (dth_model_eval(rs.model, y, DTH_EVAL_H, &H, NULL, NULL) == DTH_OK) o.E0 = H;
    dth_run_config c;
    dth_run_config_from_setup(&c, &rs); /* its length, start and [events] (a terminal one ends the run) */
    c.points = rs.points;
    c.every = rs.every;
    c.dt = rs.dt;
    c.sample = on_sample;
    c.user = &o;
    printf("k,t,lambda");
    for (size_t i = 0; i < n; i++) printf(",q%zu", i + 1);
    for (size_t i = 0; i < n; i++) printf(",p%zu", i + 1);
    printf(",wp,H,E%s\n", rs.regularizer ? ",ordinary" : "");
    dth_run_state st;
    dth_run_state_init(&st);
    rc = dth_run(it, &c, &st);
    if (rc) fprintf(stderr, "stopped at k = %ld, t = %.17g: %s (%s)\n", st.k, st.t, dth_strerror(rc),
                    dth_integrator_errmsg(it));
    fprintf(stderr, "%ld steps to t = %.17g, %ld rows; midpoint rows: max |E - E0| / |E0| = %.2e\n", st.k,
            st.t_stop, st.samples, o.worst);
    status = rc == DTH_OK && o.worst <= 1e-14 && fflush(stdout) == 0 ? 0 : 1;
out:
    free(y);
    dth_integrator_free(it);
    dth_run_setup_clear(&rs);
    dth_scene_free(scene);
    dth_registry_free(reg);
    return status;
}
