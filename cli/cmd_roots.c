/* SPDX-License-Identifier: MIT */
/*
 * dth roots: every real root of the decoupled step constraint g(lambda) = H(zbar(lambda, z_0)) at a
 * scene's initial vertex, with its class (paper, Theorems EU_1-EU_3 and "ghost"; lib/branch.c).
 */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include "cli.h"

static void usage_roots(FILE *f)
{
    fprintf(f, "usage: dth roots SCENE.ini [-s section.key=value]... [--range L]\n"
               "  the scene's initial state is taken as a vertex (start = vertex; [initial] wp= exactly)\n"
               "  --range L   search lambda in [-L, L] (default 16 |h|)\n"
               "  prints CSV lambda,class,s,region,H,psi,dpsi, one row per root, increasing lambda\n");
}

int cli_cmd_roots(int argc, char **argv)
{
    const char *scene_path = NULL;
    double L = 0;
    char err[1024];
    for (int i = 1; i < argc; i++) {
        const char *a = argv[i];
        if (!strcmp(a, "-h") || !strcmp(a, "--help")) {
            usage_roots(stdout);
            return CLI_OK;
        } else if (!strcmp(a, "-s") || !strcmp(a, "--range")) {
            if (i + 1 >= argc) {
                cli_error("option %s needs an argument (try dth roots --help)", a);
                return CLI_USAGE;
            }
            if (a[1] == '-' && (dth_parse_double(argv[i + 1], &L) || !(L > 0))) {
                cli_error("--range: '%s' is not a positive number", argv[i + 1]);
                return CLI_USAGE;
            }
            i++;
        } else if (a[0] == '-' && a[1]) {
            cli_error("unknown option '%s' (try dth roots --help)", a);
            return CLI_USAGE;
        } else if (scene_path) {
            cli_error("more than one scene file ('%s' and '%s')", scene_path, a);
            return CLI_USAGE;
        } else {
            scene_path = a;
        }
    }
    if (!scene_path) {
        cli_error("no scene file (usage: dth roots SCENE.ini [-s section.key=value]... [--range L])");
        return CLI_USAGE;
    }
    int status = CLI_USAGE;
    dth_registry *reg = cli_registry();
    dth_scene *scene = NULL;
    dth_run_setup rs;
    memset(&rs, 0, sizeof rs);
    dth_integrator *it = NULL;
    dth_rootfinder *rf = NULL;
    if (!reg) return CLI_FAIL;
    int rc = dth_scene_new(NULL, &scene);
    if (!rc) rc = dth_scene_load(scene, scene_path, err, sizeof err);
    for (int i = 1; !rc && i < argc; i++) {
        if (!strcmp(argv[i], "--range")) i++;
        else if (!strcmp(argv[i], "-s")) rc = dth_scene_set(scene, argv[++i], err, sizeof err);
    }
    if (!rc) rc = dth_scene_setup(scene, reg, &rs, err, sizeof err);
    if (rc) {
        cli_error("%s", rc == DTH_ENOMEM ? "out of memory" : err);
        status = rc == DTH_ENOMEM ? CLI_FAIL : CLI_USAGE;
        goto done;
    }
    rs.opt.start = DTH_START_VERTEX; /* the initial state is the vertex z_0 */
    rs.opt.branch_check = 0;
    rc = dth_integrator_new(rs.model, &rs.opt, &it);
    if (!rc) rc = dth_integrator_start(it, rs.q0, rs.p0, rs.t0);
    if (!rc) {
        dth_root_options ro;
        dth_root_options_default(&ro);
        ro.K = rs.opt.K;
        rc = dth_rootfinder_new(rs.model, &ro, NULL, &rf);
    }
    if (rc) {
        cli_error("%s: cannot place the initial vertex: %s", scene_path, dth_strerror(rc));
        status = rc < 0 && rc != DTH_EINVAL ? CLI_FAIL : CLI_USAGE;
        goto done;
    }
    if (!(L > 0)) L = 16 * fabs(rs.opt.h);
    dth_root_set s;
    rc = dth_find_roots(rf, dth_integrator_vertex(it), L, &s);
    if (rc) {
        cli_error("%s: root search failed at the initial vertex: %s", scene_path, dth_strerror(rc));
        status = rc < 0 && rc != DTH_EINVAL ? CLI_FAIL : CLI_USAGE;
        goto done;
    }
    printf("lambda,class,s,region,H,psi,dpsi\n");
    for (size_t i = 0; i < s.count; i++) {
        const dth_root *r = &s.root[i];
        printf("%.17g,%s,%.17g,%s,%.17g,%.17g,%.17g\n", r->lambda, dth_root_class_name(r), r->s,
               dth_region_name(s.vertex.region), s.vertex.H, s.vertex.psi, s.vertex.dpsi);
    }
    if (s.count >= DTH_MAX_ROOTS && s.truncated) cli_error("more than %d roots: the list is truncated", DTH_MAX_ROOTS);
    if (s.lo > -L || s.hi < L)
        cli_error("note: the scan covers lambda in [%.6g, %.6g] only, not all of --range %g (it reaches as far as the "
                  "decoupled solve continues and its grid resolves from this vertex): roots outside are not listed",
                  s.lo, s.hi, L);
    status = cli_flush_stdout();
done:
    dth_rootfinder_free(rf);
    dth_integrator_free(it);
    dth_run_setup_clear(&rs);
    dth_scene_free(scene);
    dth_registry_free(reg);
    return status;
}
