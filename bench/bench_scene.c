/* SPDX-License-Identifier: MIT */
/*
 * Scene loading cost against size: a 1-D chain scene of N particles (q and p lists of N values
 * over continuation lines, as scripts/make-chain-scene.py writes them) parsed by dth_scene_load_mem
 * and validated by dth_scene_setup, for N = 10^4 .. Nmax (default 10^6). Prints seconds and
 * microseconds per particle; a linear loader keeps the last column flat.
 * Usage: bench_scene [Nmax]
 */
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>
#include "dth/dth.h"

static double now(void)
{
    struct timespec ts;
    clock_gettime(CLOCK_MONOTONIC, &ts);
    return (double)ts.tv_sec + 1e-9 * (double)ts.tv_nsec;
}

/* Append "key = v1,v2,..." with lines of at most 197 characters. */
static size_t list(char *t, size_t n, const char *key, size_t N, int mom)
{
    size_t col = (size_t)sprintf(t + n, "%s = ", key);
    n += col;
    for (size_t i = 0; i < N; i++) {
        char item[40];
        int l = mom ? sprintf(item, "%s%s", (i * 2654435761u) % 7 < 3 ? "-1" : "1", i + 1 < N ? "," : "")
                    : sprintf(item, "%zu%s", i, i + 1 < N ? "," : "");
        if (col + (size_t)l > 197) {
            t[n++] = '\n';
            memcpy(t + n, "    ", 4);
            n += 4;
            col = 4;
        }
        memcpy(t + n, item, (size_t)l);
        n += (size_t)l;
        col += (size_t)l;
    }
    t[n++] = '\n';
    return n;
}

int main(int argc, char **argv)
{
    size_t nmax = argc > 1 ? (size_t)atof(argv[1]) : 1000000;
    dth_registry *reg;
    if (dth_registry_new(NULL, &reg) || dth_registry_add_builtin(reg)) return 1;
    printf("%10s %10s %10s %12s %12s\n", "N", "bytes", "load s", "setup s", "us/particle");
    for (size_t N = 10000; N <= nmax; N *= 10) {
        char *t = malloc(24 * N + 4096);
        if (!t) return 1;
        size_t n = (size_t)sprintf(t, "[model]\nname = coupled\npreset = chain\nsize = %zu\ndim = 1\nk = 1\nL = 1\n\n"
                                      "[initial]\n", N);
        n = list(t, n, "q", N, 0);
        n = list(t, n, "p", N, 1);
        n += (size_t)sprintf(t + n, "\n[integrator]\nh = 0.2\nsteps = 10\n");
        dth_scene *s;
        char err[256];
        if (dth_scene_new(NULL, &s)) return 1;
        double t0 = now();
        int rc = dth_scene_load_mem(s, "chain.ini", t, n, err, sizeof err);
        double t1 = now();
        dth_run_setup rs;
        if (!rc) rc = dth_scene_setup(s, reg, &rs, err, sizeof err);
        double t2 = now();
        if (rc) {
            fprintf(stderr, "bench_scene: N = %zu: %s\n", N, err);
            return 1;
        }
        printf("%10zu %10zu %10.3f %12.3f %12.3f\n", N, n, t1 - t0, t2 - t1, 1e6 * (t2 - t0) / (double)N);
        fflush(stdout);
        dth_run_setup_clear(&rs);
        dth_scene_free(s);
        free(t);
    }
    dth_registry_free(reg);
    return 0;
}
