/* SPDX-License-Identifier: MIT */
/*
 * Restart at every step, bit for bit: for each shipped regularizer (none, land, prescribed, also under
 * the reversible finish; with and without the branch check) and each model (the rotating pendulum through psi = 0, Kepler e = 0.9, the harmonic
 * oscillator, a 2-D chain through psi = 0), a straight run saves a checkpoint before every step;
 * from each one a fresh integrator with a fresh regularizer is restored and steps on, and every
 * step it takes (status, step record, vertex, and the whole serialised state after it) must equal
 * the straight run's bit for bit. Also: save(restore(c)) == c.
 * DTH_RESTART_SCALE=s sets the run lengths (default 4 x the table's). On the code before the branch
 * policy's memory was state (c64ae1a) scale 1 found 3 differing restart points, the default 12 (in
 * 4 combinations), scale 10 found 23.
 */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include "cu_main.h"
#include "dth/dth.h"

enum { AHEAD = 3 }; /* steps compared after each restart */

typedef struct model_case {
    const char *name;
    const dth_model_type *type;
    const dth_kv *kv;
    size_t nkv, n;
    double q[6], p[6], h;
    dth_start start;
    long steps;
} model_case;

typedef struct reg_case {
    const char *label;
    const dth_regularizer_type *type; /* NULL: no regularizer attached */
    dth_kv kv[2];
    size_t nkv;
    int reversible; /* 1: the reversible finish (DTH_FINISH_REVERSIBLE) */
} reg_case;

static const dth_kv chain_kv[] = {{"preset", "chain"}, {"size", "3"}, {"dim", "2"}, {"k", "1"}, {"L", "1"}};
static const dth_kv harm_kv[] = {{"mass", "1"}, {"omega", "1, 1.7320508075688772"}};

static const model_case models[] = {
    {"pendulum rotating", &dth_model_pendulum, NULL, 0, 1, {0}, {2.2}, 0.05, DTH_START_VERTEX, 600},
    {"kepler e=0.9", &dth_model_kepler, NULL, 0, 2, {-1.9, 0}, {0, -0.22941573387056177}, 0.05,
     DTH_START_MIDPOINT, 400},
    {"harmonic", &dth_model_harmonic, harm_kv, 2, 2, {1, 0}, {0, 1}, 0.05, DTH_START_MIDPOINT, 200},
    {"chain3 2-D", &dth_model_coupled, chain_kv, 5, 6, {0, 0, 0.5, 0, 1.0, 0}, {0, 1, 0, -2, 0, 1.5}, 0.02,
     DTH_START_MIDPOINT, 300},
};

static const reg_case regs[] = {
    {"raw", NULL, {{0}}, 0, 0},
    {"none", &dth_reg_none, {{0}}, 0, 0},
    {"land", &dth_reg_land, {{0}}, 0, 0},
    {"land clock=no", &dth_reg_land, {{"clock", "no"}}, 1, 0},
    {"prescribed", &dth_reg_prescribed, {{0}}, 0, 0},
    {"prescribed alpha=1", &dth_reg_prescribed, {{"alpha", "1"}}, 1, 0},
    {"prescribed reversible", &dth_reg_prescribed, {{0}}, 0, 1},
    {"prescribed a=1 rev.", &dth_reg_prescribed, {{"alpha", "1"}}, 1, 1},
};

typedef struct rec {
    int rc;
    dth_step_info info;
} rec;

typedef struct inst {
    dth_regularizer *reg;
    dth_integrator *it;
} inst;

static int make(const dth_model *m, const model_case *mc, const reg_case *rc, int bc, inst *x)
{
    memset(x, 0, sizeof *x);
    char err[256] = "";
    if (rc->type && dth_regularizer_new(rc->type, rc->kv, rc->nkv, m, NULL, &x->reg, err, sizeof err)) {
        fprintf(stderr, "regularizer %s: %s\n", rc->label, err);
        return -1;
    }
    dth_options o;
    dth_options_default(&o);
    o.h = mc->h;
    o.start = mc->start;
    o.branch_check = bc;
    o.regularizer = x->reg;
    if (rc->reversible) o.finish = DTH_FINISH_REVERSIBLE;
    if (dth_integrator_new(m, &o, &x->it)) return -1;
    return 0;
}

static void drop(inst *x)
{
    dth_integrator_free(x->it);
    dth_regularizer_free(x->reg);
}

static unsigned char *save(const dth_integrator *it, size_t *len)
{
    if (dth_checkpoint_save(it, NULL, 0, NULL, 0, len)) return NULL;
    unsigned char *b = malloc(*len);
    if (b && dth_checkpoint_save(it, NULL, 0, b, *len, len)) {
        free(b);
        return NULL;
    }
    return b;
}

static int same_rec(const rec *a, const rec *b)
{
    return a->rc == b->rc && memcmp(&a->info, &b->info, sizeof a->info) == 0;
}

/* One combination: returns the number of restart points whose continuation differs. */
static long check_case(const dth_model *m, const model_case *mc, const reg_case *rcase, int bc, long steps,
                       long *crossings, long *ran)
{
    inst A;
    if (make(m, mc, rcase, bc, &A)) return -1;
    if (dth_integrator_start(A.it, mc->q, mc->p, 0.0)) {
        drop(&A);
        return -1;
    }
    unsigned char **ck = calloc((size_t)steps + 1, sizeof *ck);
    size_t *len = calloc((size_t)steps + 1, sizeof *len);
    rec *r = calloc((size_t)steps + 1, sizeof *r);
    if (!ck || !len || !r) abort();
    long K = 0;
    *crossings = 0;
    for (; K < steps; K++) {
        ck[K] = save(A.it, &len[K]);
        if (!ck[K]) abort();
        memset(&r[K].info, 0, sizeof r[K].info);
        r[K].rc = dth_integrator_step(A.it, &r[K].info);
        if (r[K].info.flags & DTH_STEP_CROSSING) (*crossings)++;
        if (r[K].rc) break; /* the failed step is compared too */
    }
    long nrec = K < steps ? K + 1 : K; /* step records (a failed last step included) */
    if (K == steps) {
        ck[K] = save(A.it, &len[K]);
        if (!ck[K]) abort();
    }
    *ran = K;
    long bad = 0;
    for (long k = 0; k < nrec; k++) {
        inst C;
        if (make(m, mc, rcase, bc, &C)) abort();
        char err[256] = "";
        int ok = dth_checkpoint_restore(C.it, ck[k], len[k], err, sizeof err) == DTH_OK;
        size_t l2 = 0;
        unsigned char *c2 = ok ? save(C.it, &l2) : NULL;
        ok = ok && c2 && l2 == len[k] && memcmp(c2, ck[k], l2) == 0;
        free(c2);
        for (long j = k; ok && j < k + AHEAD && j < nrec; j++) {
            rec x;
            memset(&x.info, 0, sizeof x.info);
            x.rc = dth_integrator_step(C.it, &x.info);
            ok = same_rec(&x, &r[j]);
            if (!ok || x.rc) break;
            {
                c2 = save(C.it, &l2);
                ok = c2 && l2 == len[j + 1] && memcmp(c2, ck[j + 1], l2) == 0;
                free(c2);
            }
        }
        if (!ok) {
            if (bad < 3)
                printf("  [%s, %s, branch_check=%d: restart at k=%ld differs%s%s]\n", mc->name, rcase->label, bc, k,
                       err[0] ? ": " : "", err);
            bad++;
        }
        drop(&C);
    }
    for (long k = 0; k <= steps; k++) free(ck[k]);
    free(ck);
    free(len);
    free(r);
    drop(&A);
    return bad;
}

static void test_every_step(void)
{
    const char *sc = getenv("DTH_RESTART_SCALE");
    double scale = sc ? atof(sc) : 4.0;
    if (!(scale > 0)) scale = 4.0;
    long total = 0, total_cross = 0;
    for (size_t i = 0; i < sizeof models / sizeof models[0]; i++) {
        const model_case *mc = &models[i];
        dth_model *m = NULL;
        char err[256] = "";
        CU_ASSERT_FATAL(dth_model_new(mc->type, mc->kv, mc->nkv, mc->n, NULL, &m, err, sizeof err) == DTH_OK);
        for (size_t j = 0; j < sizeof regs / sizeof regs[0]; j++)
            for (int bc = 1; bc >= 0; bc--) {
                /* the reversible finish's vertex start does not find this state's offset (dth_start.c) */
                if (regs[j].reversible && mc->start == DTH_START_VERTEX) continue;
                long cr = 0, ran = 0;
                long steps = (long)(scale * (double)mc->steps);
                long bad = check_case(m, mc, &regs[j], bc, steps, &cr, &ran);
                printf("  [%-17s %-20s bc=%d: %5ld steps, %3ld crossings, %ld restart points differ]\n", mc->name,
                       regs[j].label, bc, ran, cr, bad);
                CU_ASSERT(bad == 0);
                /* what was covered: the crossing regularizers run through the models that cross (at
                 * the default scale 4: 849 to 2400 steps, 15 to 90 crossings each) */
                if (regs[j].type == &dth_reg_land && mc->type != &dth_model_harmonic)
                    CU_ASSERT(ran >= steps * 7 / 10 && cr >= (long)(3 * scale));
                total += ran;
                total_cross += cr;
            }
        dth_model_free(m);
    }
    printf("  [%ld restart points, %ld crossings in all]\n", total, total_cross);
    CU_ASSERT(total >= (long)(7000 * scale) && total_cross >= (long)(150 * scale));
}

static CU_TestInfo restart_tests[] = {
    {"restart at every step == straight run, bit for bit (every regularizer x model x branch check)", test_every_step},
    CU_TEST_INFO_NULL,
};

CU_SuiteInfo dth_test_suites[] = {
    {.pName = "restart", .pTests = restart_tests},
    CU_SUITE_INFO_NULL,
};
