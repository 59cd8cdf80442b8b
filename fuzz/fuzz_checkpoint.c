/* SPDX-License-Identifier: MIT */
/*
 * libFuzzer target: what a restore reads (dth_checkpoint_restore_run, dth_checkpoint_run_state, dth
 * run's "cli" blob). The first byte chooses, modulo 3:
 *   0: field values. Checkpoints of six configurations (the DTH step with no regularizer, with
 *      `land` and with `prescribed`, a vertex start of a two-dof oscillator, the baselines
 *      midpoint and verlet; the second byte) after 0, 1, 4 or 25 steps of dth_run (the third), with
 *      the run state. The rest is a list of patches of 11 bytes: u16 which number (of every field
 *      value of every section, found by the documented layout), u8 how (the input's bits, an
 *      interesting double or integer, add, negate, copy another, flip bits, scale) and 8 bytes;
 *      the checksum is recomputed, so every patched checkpoint reaches the field checks and the
 *      rules between fields.
 *   1: a whole checkpoint (the second byte: which configuration restores it) with its length and
 *      checksum fixed: the structure fuzzed past the checksum.
 *   2: a "cli" blob by itself (cli_ckpt_decode), and the same bytes as a field record.
 * Invariants: nothing crashes or reads out of bounds; a refusal says why and leaves the integrator
 * and the run state as they were; an accepted checkpoint saves back to the same bytes, its run
 * state agrees with dth_checkpoint_run_state, and the run goes on through dth_run (a step that
 * returns DTH_OK leaves a finite vertex); an accepted blob has its paths absolute.
 * Each distinct refusal (its message with the numbers, and a name read from the input where the
 * library expects another, taken out: a restore path) is appended to the file $DTH_FUZZ_REFUSALS
 * if set, which scripts/ci-fuzz.sh counts. With DTH_FUZZ_SEEDS=DIR the
 * target writes seed inputs of each kind to DIR first (fuzz/corpus/fuzz_checkpoint holds them).
 */
#include <math.h>
#include <float.h>
#include <stdlib.h>
#include <string.h>
#include "dth/dth.h"
#include "ckpt.h"
#include "ckpt_walk.h"
#include "fuzz_common.h"

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size);
int LLVMFuzzerInitialize(int *argc, char ***argv);

/* ---- the configurations and their checkpoints ---- */

enum { NCONF = 6, NSTEPS = 4, MAXLEN = 16384 };
static const long steps_of[NSTEPS] = {0, 1, 4, 25};

typedef struct conf {
    dth_model *m;
    dth_regularizer *reg;
    dth_integrator *it;
} conf;

static void conf_new(int c, conf *x)
{
    static const dth_kv two[] = {{"n", "2"}};
    memset(x, 0, sizeof *x);
    FUZZ_CHECK(dth_model_new(c == 3 ? &dth_model_harmonic : &dth_model_pendulum, c == 3 ? two : NULL, c == 3,
                             c == 3 ? 0 : 1, NULL, &x->m, NULL, 0) == DTH_OK);
    const dth_regularizer_type *rt = c == 1 ? &dth_reg_land : c == 2 ? &dth_reg_prescribed : NULL;
    if (rt) FUZZ_CHECK(dth_regularizer_new(rt, NULL, 0, x->m, NULL, &x->reg, NULL, 0) == DTH_OK);
    dth_options o;
    dth_options_default(&o);
    o.h = c == 1 ? 0.1 : 0.05;
    o.regularizer = x->reg;
    o.method = c == 4 ? "midpoint" : c == 5 ? "verlet" : NULL;
    o.start = c == 3 ? DTH_START_VERTEX : DTH_START_MIDPOINT;
    FUZZ_CHECK(dth_integrator_new(x->m, &o, &x->it) == DTH_OK);
    double q[2] = {1.0, -0.3}, p[2] = {c == 1 ? 2.2 : 0.2, 0.4};
    FUZZ_CHECK(dth_integrator_start(x->it, q, p, 0.5) == DTH_OK);
}

static void conf_free(conf *x)
{
    dth_integrator_free(x->it);
    dth_regularizer_free(x->reg);
    dth_model_free(x->m);
}

static int stop_sampling(void *user, const dth_sample *s)
{
    (void)s;
    return ++*(long *)user > 2000; /* output far denser than the steps: stop */
}

/* Run x's integrator through dth_run to vertex `steps` from the run state st. */
static int run_to(conf *x, dth_run_state *st, long steps)
{
    long samples = 0;
    dth_run_config c;
    dth_run_config_default(&c);
    c.steps = steps;
    c.sample = stop_sampling;
    c.user = &samples;
    return dth_run(x->it, &c, st);
}

static unsigned char *base[NCONF][NSTEPS];
static size_t base_len[NCONF][NSTEPS];

static const unsigned char *base_of(int c, int s, size_t *len)
{
    if (!base[c][s]) {
        conf x;
        conf_new(c, &x);
        dth_run_state st;
        dth_run_state_init(&st);
        FUZZ_CHECK(run_to(&x, &st, steps_of[s]) == DTH_OK);
        base[c][s] = malloc(MAXLEN);
        FUZZ_CHECK(base[c][s] != NULL);
        FUZZ_CHECK(dth_checkpoint_save_run(x.it, &st, NULL, 0, base[c][s], MAXLEN, &base_len[c][s]) == DTH_OK);
        conf_free(&x);
    }
    *len = base_len[c][s];
    return base[c][s];
}

/* ---- distinct refusals: the message with its numbers taken out ---- */

static void record_refusal(const char *err)
{
    static uint64_t seen[8192];
    static size_t nseen;
    const char *file = getenv("DTH_FUZZ_REFUSALS");
    if (!file) return;
    char t[512];
    size_t k = 0;
    /* a name read from the input (a field, section, method, model or regularizer where another
     * is expected) is one path whatever it is */
    const char *where = strstr(err, " where this library expects "), *from = NULL, *to = NULL;
    for (const char *q = err; where && q < where; q++) /* the last quoted name before it */
        if (*q == '\'') {
            const char *e = strchr(q + 1, '\'');
            if (!e || e >= where) break;
            from = q, to = e, q = e;
        }
    if (!where && (strstr(err, "checkpoint of ") || strstr(err, "was written with regularizer"))) {
        from = strchr(err, '\'');
        to = from ? strchr(from + 1, '\'') : NULL;
    }
    for (const char *p = err; *p && k + 2 < sizeof t;) {
        if (to && p == from + 1) {
            t[k++] = '?';
            p = to;
            continue;
        }
        int num = (*p >= '0' && *p <= '9') || ((*p == '-' || *p == '+' || *p == '.') && p[1] >= '0' && p[1] <= '9');
        if (!strncmp(p, "nan", 3) || !strncmp(p, "inf", 3)) {
            p += 3;
            t[k++] = '#';
        } else if (p[0] == '0' && p[1] == 'x') { /* a hexadecimal number */
            for (p += 2; (*p >= '0' && *p <= '9') || (*p >= 'a' && *p <= 'f');) p++;
            t[k++] = '#';
        } else if (num) {
            while ((*p >= '0' && *p <= '9') || *p == '.' || *p == '-' || *p == '+' ||
                   ((*p == 'e') && (p[1] == '+' || p[1] == '-' || (p[1] >= '0' && p[1] <= '9'))))
                p++;
            t[k++] = '#';
        } else {
            t[k++] = *p++;
        }
    }
    t[k] = '\0';
    uint64_t h = walk_fnv((const unsigned char *)t, k);
    for (size_t i = 0; i < nseen; i++)
        if (seen[i] == h) return;
    if (nseen < sizeof seen / sizeof seen[0]) seen[nseen++] = h;
    FILE *f = fopen(file, "a");
    if (f) {
        fprintf(f, "%s\n", t);
        fclose(f);
    }
}

/* ---- patches of field values ---- */

typedef struct slots {
    size_t at[1024];
    int dbl[1024];
    size_t n;
} slots;

static void add_slots(void *ctx, const walk_field *f)
{
    slots *s = ctx;
    for (uint64_t i = 0; f->type != 3 && i < f->count && s->n < 1024; i++) {
        s->at[s->n] = f->values + 8 * i;
        s->dbl[s->n++] = f->type == 1;
    }
}

static const double odd_f64[] = {0.0, -0.0, 1.0, -1.0, 0.5, 2.0, 1e100, 1.0000000000000002e100, 1e101, 1e300,
                                 1e308, -1e308, DBL_MAX, DBL_MIN, 4.9e-324, 1e-300, NAN, INFINITY, -INFINITY};
static const int64_t odd_i64[] = {0, 1, -1, 2, 3, 4, 5, -2, -3, INT64_MAX, INT64_MIN, INT64_C(1) << 53,
                                  (INT64_C(1) << 53) + 1, INT32_MAX, (int64_t)INT32_MAX + 1, UINT32_MAX,
                                  INT64_C(1) << 62};

static void patch(unsigned char *b, const slots *s, const uint8_t *p)
{
    size_t i = ((size_t)p[0] | (size_t)p[1] << 8) % s->n;
    unsigned how = p[2] % 8;
    const uint8_t *v = p + 3;
    uint64_t bits = walk_le(b + s->at[i], 8), raw = walk_le(v, 8);
    double x;
    memcpy(&x, &bits, sizeof x);
    int8_t k = (int8_t)v[0];
    switch (how) {
    case 0: bits = raw; break;
    case 1: memcpy(&bits, &odd_f64[v[0] % (sizeof odd_f64 / sizeof odd_f64[0])], sizeof bits); break;
    case 2: bits = (uint64_t)odd_i64[v[0] % (sizeof odd_i64 / sizeof odd_i64[0])]; break;
    case 3:
        if (s->dbl[i]) x += k, memcpy(&bits, &x, sizeof bits);
        else bits += (uint64_t)(int64_t)k;
        break;
    case 4:
        if (s->dbl[i]) x = -x, memcpy(&bits, &x, sizeof bits);
        else bits = (uint64_t)0 - bits;
        break;
    case 5: bits = walk_le(b + s->at[((size_t)v[0] | (size_t)v[1] << 8) % s->n], 8); break;
    case 6: bits ^= raw; break;
    default:
        if (s->dbl[i]) x = ldexp(x, k), memcpy(&bits, &x, sizeof bits);
        else bits <<= (unsigned)v[0] % 64;
        break;
    }
    walk_put_le(b + s->at[i], bits, 8);
}

/* Restore the checkpoint b into a fresh integrator of configuration c, with the invariants above;
 * `exact`: b was saved without blobs, so an accepted one saves back to the same bytes. */
static void restore_into(int c, const unsigned char *b, size_t len, int exact)
{
    static unsigned char before[MAXLEN], after[MAXLEN];
    conf x;
    conf_new(c, &x);
    size_t lb = 0, la = 0;
    dth_run_state st, fresh;
    memset(&st, 0x5a, sizeof st);
    fresh = st;
    FUZZ_CHECK(dth_checkpoint_save_run(x.it, NULL, NULL, 0, before, sizeof before, &lb) == DTH_OK);
    char err[512] = "", err2[512] = "";
    int rc = dth_checkpoint_restore_run(x.it, &st, b, len, err, sizeof err);
    dth_run_state alone;
    int rc2 = dth_checkpoint_run_state(b, len, &alone, err2, sizeof err2);
    if (rc2 != DTH_OK) record_refusal(err2);
    if (rc != DTH_OK) {
        FUZZ_CHECK(err[0] != '\0' && rc < 0);
        record_refusal(err);
        FUZZ_CHECK(memcmp(&st, &fresh, sizeof st) == 0);
        FUZZ_CHECK(dth_checkpoint_save_run(x.it, NULL, NULL, 0, after, sizeof after, &la) == DTH_OK);
        FUZZ_CHECK(la == lb && memcmp(before, after, lb) == 0);
    } else {
        FUZZ_CHECK(rc2 == DTH_OK && memcmp(&alone, &st, sizeof st) == 0);
        if (exact) {
            FUZZ_CHECK(dth_checkpoint_save_run(x.it, &st, NULL, 0, after, sizeof after, &la) == DTH_OK);
            FUZZ_CHECK(la == len && memcmp(after, b, len) == 0);
        }
        /* the run goes on from the restored state */
        rc = run_to(&x, &st, st.k + 3);
        FUZZ_CHECK(strcmp(dth_status_name(rc), "DTH_UNKNOWN") != 0);
        if (rc == DTH_OK) {
            const double *z = dth_integrator_vertex(x.it);
            for (size_t j = 0; j < dth_integrator_dim(x.it); j++) FUZZ_CHECK(isfinite(z[j]));
        }
    }
    conf_free(&x);
}

static void check_blob(const void *p, size_t n)
{
    cli_ckpt c;
    char err[512] = "";
    if (cli_ckpt_decode(p, n, &c, err, sizeof err) == 0) {
        const cli_ckpt_out *o[2] = {&c.out, &c.ev};
        for (int i = 0; i < 2; i++) {
            FUZZ_CHECK(strlen(o[i]->path) <= 4096 && strlen(o[i]->tmp) <= 4096);
            FUZZ_CHECK(!o[i]->path[0] || o[i]->path[0] == '/');
            FUZZ_CHECK(!o[i]->tmp[0] || o[i]->tmp[0] == '/');
            FUZZ_CHECK(o[i]->bytes <= (1ULL << 62) && (o[i]->path[0] || !o[i]->bytes));
        }
        FUZZ_CHECK(c.out.path[0]);
    } else {
        FUZZ_CHECK(err[0] != '\0');
        record_refusal(err);
    }
    cli_ckpt_clear(&c);
}

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
    if (size < 1) return 0;
    unsigned mode = data[0] % 3;
    if (mode == 2) {
        check_blob(data + 1, size - 1);
        return 0;
    }
    int c = size > 1 ? data[1] % NCONF : 0;
    if (mode == 1) {
        if (size < 2 + 32 || size - 2 > MAXLEN) return 0;
        size_t len = size - 2;
        unsigned char *b = malloc(len);
        FUZZ_CHECK(b != NULL);
        memcpy(b, data + 2, len);
        walk_put_le(b + 16, len, 8);
        walk_reseal(b, len);
        restore_into(c, b, len, 0);
        const void *blob;
        size_t bl;
        if (dth_checkpoint_blob(b, len, "cli", &blob, &bl) == DTH_OK) check_blob(blob, bl);
        free(b);
        return 0;
    }
    int s = size > 2 ? data[2] % NSTEPS : 0;
    size_t len;
    const unsigned char *good = base_of(c, s, &len);
    unsigned char *b = malloc(len);
    FUZZ_CHECK(b != NULL);
    memcpy(b, good, len);
    slots sl = {.n = 0};
    walk_state(b, len, add_slots, &sl);
    FUZZ_CHECK(sl.n > 0);
    for (size_t at = 3; at + 11 <= size && at < 3 + 11 * 16; at += 11) patch(b, &sl, data + at);
    walk_reseal(b, len);
    restore_into(c, b, len, 1);
    free(b);
    return 0;
}

/* ---- seeds (DTH_FUZZ_SEEDS=DIR) ---- */

static void write_seed(const char *dir, const char *name, const unsigned char *head, size_t hl, const void *body,
                       size_t bl)
{
    char path[4096];
    snprintf(path, sizeof path, "%s/%s", dir, name);
    FILE *f = fopen(path, "wb");
    FUZZ_CHECK(f != NULL);
    FUZZ_CHECK(fwrite(head, 1, hl, f) == hl && (!bl || fwrite(body, 1, bl, f) == bl));
    fclose(f);
}

int LLVMFuzzerInitialize(int *argc, char ***argv)
{
    (void)argc, (void)argv;
    const char *dir = getenv("DTH_FUZZ_SEEDS");
    if (!dir) return 0;
    char name[64];
    for (int c = 0; c < NCONF; c++) {
        size_t len;
        const unsigned char *b = base_of(c, 2, &len);
        unsigned char head[3 + 11] = {0, (unsigned char)c, 2};
        snprintf(name, sizeof name, "values-%d", c);
        write_seed(dir, name, head, 3, NULL, 0);
        for (unsigned how = 0; how < 8; how++) {
            head[3] = (unsigned char)(7 * how + (unsigned)c), head[4] = 0, head[5] = (unsigned char)how;
            head[6] = (unsigned char)(how * 5 + 1);
            snprintf(name, sizeof name, "values-%d-how%u", c, how);
            write_seed(dir, name, head, sizeof head, NULL, 0);
        }
        head[0] = 1;
        snprintf(name, sizeof name, "whole-%d", c);
        write_seed(dir, name, head, 2, b, len);
    }
    cli_ckpt k;
    memset(&k, 0, sizeof k);
    k.scene_hash = 0x0123456789abcdefULL;
    k.out = (cli_ckpt_out){"/data/o.csv", "/data/o.csv.tmp.7.AbCdEf", 1234, 0xfeed};
    k.ev = (cli_ckpt_out){"", "", 0, CLI_FNV_OFFSET};
    unsigned char *blob, mode = 2;
    size_t bl;
    FUZZ_CHECK(cli_ckpt_encode(&k, &blob, &bl) == 0);
    write_seed(dir, "cli-blob", &mode, 1, blob, bl);
    free(blob);
    return 0;
}
