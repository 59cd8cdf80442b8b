/* SPDX-License-Identifier: MIT */
/*
 * Example: a Poincare section with the run driver's events. Registers the user model
 * henon_heiles.c, reads a scene with an [events] section (henon-heiles.ini: q1 = 0 crossed
 * upward) and writes every located crossing as "t,q2,p2,E" to standard output; nothing else is
 * sampled. Usage: poincare SCENE.ini [-s section.key=value]...
 */
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <dth/dth.h>
#include "henon_heiles.h"

static int on_event(void *user, const dth_sample *s)
{
    const dth_run_setup *rs = user;
    size_t n = rs->n;
    double E;
    if (dth_model_eval(rs->model, s->z, DTH_EVAL_H, &E, NULL, NULL) != DTH_OK) return DTH_EDOMAIN;
    printf("%.17g,%.17g,%.17g,%.17g\n", s->z[n], s->z[1], s->z[n + 2], E);
    return ferror(stdout) ? DTH_EIO : 0;
}

int main(int argc, char **argv)
{
    if (argc < 2) {
        fprintf(stderr, "usage: %s SCENE.ini [-s section.key=value]...\n", argv[0]);
        return 2;
    }
    char err[512];
    int status = 1, rc;
    dth_registry *reg = NULL;
    dth_scene *scene = NULL;
    dth_run_setup rs;
    memset(&rs, 0, sizeof rs);
    dth_integrator *it = NULL;
    if (dth_registry_new(NULL, &reg) || dth_registry_add_builtin(reg) ||
        dth_registry_add_model(reg, &example_henon_heiles)) {
        fprintf(stderr, "cannot set up the model registry\n");
        goto out;
    }
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
    if (!rs.nevents) {
        fprintf(stderr, "the scene has no [events]\n");
        goto out;
    }
    if ((rc = dth_integrator_new(rs.model, &rs.opt, &it)) || (rc = dth_integrator_start(it, rs.q0, rs.p0, rs.t0))) {
        fprintf(stderr, "cannot start: %s\n", dth_strerror(rc));
        goto out;
    }
    dth_run_config c;
    dth_run_config_from_setup(&c, &rs); /* its length, start and [events] */
    c.on_event = on_event;
    c.user = &rs;
    dth_run_state st;
    dth_run_state_init(&st);
    printf("t,q2,p2,E\n");
    rc = dth_run(it, &c, &st);
    fprintf(stderr, "%ld steps to t = %.17g, %ld section points%s%s\n", st.k, st.t_stop, st.events,
            rc ? ": " : "", rc ? dth_strerror(rc) : "");
    status = rc == DTH_OK && fflush(stdout) == 0 ? 0 : 1;
out:
    dth_integrator_free(it);
    dth_run_setup_clear(&rs);
    dth_scene_free(scene);
    dth_registry_free(reg);
    return status;
}
