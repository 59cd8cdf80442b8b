/* SPDX-License-Identifier: MIT */
/*
 * What a user model pays without the optional callbacks hdiff and third (issue 22 item 5; the paper's
 * DTH step, Theorem "DTH Equations", finishes on the compensated constraint, whose H(zbar) - H(z_k)
 * comes from hdiff, else a 4-point Gauss-Legendre rule on the gradient; psi' = D^3 H[u, u, u] comes from
 * third, else a central difference of two Hessians): the Henon-Heiles user model (docs/examples) as it
 * is, with hdiff, with third and with both, each model evaluation counted, the cost of a step timed,
 * for the DTH step (order 2) and the composite step of order 4. Not a test: it prints figures.
 * Usage: bench_fallback [steps]   (default 200000; the median of 5 repeats)
 */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>
#include "dth/dth.h"
#include "../docs/examples/henon_heiles.h"

/* evaluations by kind, counted through a wrapper of the example's eval */
static long n_grad, n_hess, n_h, n_third, n_hdiff;

static int create(const dth_model_args *a, void **self, dth_model_info *info)
{
    return example_henon_heiles.create(a, self, info);
}
static void destroy(void *self, const dth_allocator *al) { example_henon_heiles.destroy(self, al); }
static int eval(const void *self, const double *y, unsigned what, double *H, double *g, double *h)
{
    if (what & DTH_EVAL_HESS) n_hess++;
    else if (what & DTH_EVAL_GRAD) n_grad++;
    else n_h++;
    return example_henon_heiles.eval(self, y, what, H, g, h);
}

/* H = (p1^2 + p2^2)/2 + (q1^2 + q2^2)/2 + q1^2 q2 - q2^3/3 (lambda = 1): the difference without
 * cancellation, exactly antisymmetric in (y1, y0) */
static int hdiff(const void *self, const double *y1, const double *y0, double *dH)
{
    (void)self;
    n_hdiff++;
    double a1 = y1[0], b1 = y1[1], a0 = y0[0], b0 = y0[1];
    double da = a1 - a0, db = b1 - b0, sa = a1 + a0, sb = b1 + b0;
    double kin = 0.5 * ((y1[3] - y0[3]) * (y1[3] + y0[3]) + (y1[4] - y0[4]) * (y1[4] + y0[4]));
    /* a1^2 b1 - a0^2 b0 = (a1^2 - a0^2)(b1 + b0)/2 + (a1^2 + a0^2)(b1 - b0)/2 */
    double cub = 0.5 * (da * sa) * sb + 0.5 * (a1 * a1 + a0 * a0) * db;
    /* b1^3 - b0^3 = db (b1^2 + b0^2 + b1 b0), the sum symmetric in (b1, b0) */
    double cub2 = db * ((b1 * b1 + b0 * b0) + b1 * b0) / 3;
    *dH = kin + 0.5 * (da * sa + db * sb) + cub - cub2;
    return 0;
}

static int third(const void *self, const double *y, const double *u, double *d3)
{
    (void)self, (void)y;
    n_third++;
    /* D^3 (q1^2 q2 - q2^3 / 3)[u, u, u] = 6 u1^2 u2 - 2 u2^3 (the quadratic part has none) */
    *d3 = 6 * u[0] * u[0] * u[1] - 2 * u[1] * u[1] * u[1];
    return 0;
}

static const dth_model_type counted = {DTH_MODEL_TYPE_HEAD, .name = "henon-heiles-counted", .doc = "counted",
                                       .create = create, .destroy = destroy, .eval = eval};
static const dth_model_type with_hdiff = {DTH_MODEL_TYPE_HEAD, .name = "henon-heiles-hdiff", .doc = "with hdiff",
                                          .create = create, .destroy = destroy, .eval = eval, .hdiff = hdiff};
static const dth_model_type with_third = {DTH_MODEL_TYPE_HEAD, .name = "henon-heiles-third", .doc = "with third",
                                          .create = create, .destroy = destroy, .eval = eval, .third = third};
static const dth_model_type with_both = {DTH_MODEL_TYPE_HEAD, .name = "henon-heiles-full", .doc = "with hdiff, third",
                                         .create = create, .destroy = destroy, .eval = eval, .third = third,
                                         .hdiff = hdiff};

static double cpu_now(void)
{
    struct timespec ts;
    clock_gettime(CLOCK_PROCESS_CPUTIME_ID, &ts);
    return (double)ts.tv_sec + 1e-9 * (double)ts.tv_nsec;
}

static int cmp(const void *a, const void *b)
{
    double x = *(const double *)a, y = *(const double *)b;
    return (x > y) - (x < y);
}

/* ns per step (median of 5) and the evaluations per step of one counted run; t at the end (the same
 * trajectory whatever the callbacks) */
static void measure(const dth_model_type *t, int order, long steps, double *ns, double per[5], double *t_end)
{
    dth_model *m = NULL;
    char err[256];
    if (dth_model_new(t, NULL, 0, 2, NULL, &m, err, sizeof err)) {
        fprintf(stderr, "%s\n", err);
        exit(1);
    }
    double q0[2] = {0, 0.1}, p0[2] = {0.39665266081716, 0}, tm[5];
    for (int r = 0; r < 5; r++) {
        dth_options o;
        dth_options_default(&o);
        o.order = order;
        o.h = order == 4 ? 0.1 : 0.05;
        dth_integrator *it = NULL;
        if (dth_integrator_new(m, &o, &it) || dth_integrator_start(it, q0, p0, 0)) exit(1);
        n_grad = n_hess = n_h = n_third = n_hdiff = 0;
        double c0 = cpu_now();
        for (long k = 0; k < steps; k++)
            if (dth_integrator_step(it, NULL)) exit(1);
        tm[r] = (cpu_now() - c0) / (double)steps * 1e9;
        if (r == 0) {
            double s = (double)steps;
            per[0] = (double)n_grad / s, per[1] = (double)n_hess / s, per[2] = (double)n_h / s;
            per[3] = (double)n_hdiff / s, per[4] = (double)n_third / s;
            *t_end = dth_integrator_vertex(it)[2];
        }
        dth_integrator_free(it);
    }
    qsort(tm, 5, sizeof tm[0], cmp);
    *ns = tm[2];
    dth_model_free(m);
}

int main(int argc, char **argv)
{
    long steps = argc > 1 ? atol(argv[1]) : 200000;
    if (steps < 1) return 2;
    printf("# bench_fallback: the Henon-Heiles user model (docs/examples/henon_heiles.c) without and with hdiff and "
           "third,\n# %ld steps (order 2: h = 0.05; order 4: %ld composite steps, h = 0.1), evaluations per step\n\n", steps,
           steps / 5);
    printf("| order | model | ns per step | gradients | Hessians | H only | hdiff calls | third calls | t at the end |\n"
           "|---|---|---|---|---|---|---|---|---|\n");
    const dth_model_type *types[4] = {&counted, &with_hdiff, &with_third, &with_both};
    const char *names[4] = {"as in docs/examples", "with hdiff", "with third", "with hdiff, third"};
    for (int order = 2; order <= 4; order += 2) {
        double ns[4], per[4][5], t[4];
        for (int k = 0; k < 4; k++) {
            measure(types[k], order, order == 4 ? steps / 5 : steps, &ns[k], per[k], &t[k]);
            printf("| %d | %s | %.0f | %.2f | %.2f | %.2f | %.2f | %.2f | %.6f |\n", order, names[k], ns[k], per[k][0],
                   per[k][1], per[k][2], per[k][3], per[k][4], t[k]);
        }
        printf("| %d | without / with both | %.2f | | | | | | |\n", order, ns[0] / ns[3]);
    }
    return 0;
}
