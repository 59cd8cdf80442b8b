/* SPDX-License-Identifier: MIT */
/*
 * Checkpoint and restart: N steps + save + restore (into a fresh integrator) + N steps gives
 * the same bits as 2N steps, for every model and both start modes; corrupted, truncated,
 * extended or foreign checkpoints are refused and leave the integrator untouched; blobs and
 * crash-safe files.
 */
#include <math.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <dirent.h>
#include <unistd.h>
#include "cu_main.h"
#include "dth/dth.h"
#include "failing_alloc.h"

static const dth_kv coupled_kv[] = {{"preset", "chain"}, {"size", "4"}, {"dim", "2"}, {"L", "0.5"}};

static dth_model *make_model(const dth_model_type *t)
{
    dth_model *m = NULL;
    if (strcmp(t->name, "coupled") == 0 && dth_model_new(t, coupled_kv, 4, 8, NULL, &m, NULL, 0) == DTH_OK)
        return m;
    for (size_t n = 2; n >= 1; n--)
        if (dth_model_new(t, NULL, 0, n, NULL, &m, NULL, 0) == DTH_OK) return m;
    return NULL;
}

static dth_integrator *make_it(const dth_model *m, double h, dth_start start)
{
    dth_options o;
    dth_options_default(&o);
    o.h = h;
    o.start = start;
    dth_integrator *it = NULL;
    CU_ASSERT_FATAL(dth_integrator_new(m, &o, &it) == DTH_OK);
    return it;
}

/* Initial values away from collisions and equilibria (as in test_models). */
static void initial(size_t n, double *q, double *p)
{
    for (size_t i = 0; i < n; i++) {
        q[i] = 0.3 + 0.9 * (double)i + 0.1 * (double)(i % 3);
        p[i] = (i % 2 ? -0.25 : 0.35);
    }
    if (n == 1) { /* pendulum: libration */
        q[0] = 0.8;
        p[0] = 0.3;
    }
}

/* One step's observable output: vertex, midpoint, lambda, info (bitwise). */
typedef struct rec {
    double z[64], zbar[64];
    dth_step_info info;
    int rc;
} rec;

static void record(dth_integrator *it, rec *r)
{
    memset(r, 0, sizeof *r);
    r->rc = dth_integrator_step(it, &r->info);
    size_t N = dth_integrator_dim(it);
    memcpy(r->z, dth_integrator_vertex(it), N * sizeof(double));
    const double *mid = dth_integrator_midpoint(it);
    if (mid) memcpy(r->zbar, mid, N * sizeof(double));
}

static unsigned char *save_alloc(const dth_integrator *it, const dth_blob *b, size_t nb, size_t *len)
{
    CU_ASSERT_FATAL(dth_checkpoint_save(it, b, nb, NULL, 0, len) == DTH_OK);
    unsigned char *buf = malloc(*len);
    CU_ASSERT_FATAL(buf != NULL);
    size_t len2;
    CU_ASSERT_FATAL(dth_checkpoint_save(it, b, nb, buf, *len, &len2) == DTH_OK);
    CU_ASSERT(len2 == *len);
    return buf;
}

/* 2N steps straight vs N, save, restore into a fresh integrator, N more. */
static void resume_identical(const dth_model *m, double h, dth_start start, long N, int reverse_at_n)
{
    size_t n = dth_model_dof(m), D = 2 * n + 2;
    CU_ASSERT_FATAL(D <= 64);
    double q[31], p[31];
    initial(n, q, p);
    rec *a = calloc((size_t)N, sizeof *a), r;
    CU_ASSERT_FATAL(a != NULL);
    dth_integrator *A = make_it(m, h, start), *B = make_it(m, h, start);
    CU_ASSERT_FATAL(dth_integrator_start(A, q, p, 0.25) == DTH_OK);
    CU_ASSERT_FATAL(dth_integrator_start(B, q, p, 0.25) == DTH_OK);
    for (long k = 0; k < N; k++) {
        record(A, &r);
        record(B, &r);
    }
    if (reverse_at_n) {
        dth_integrator_reverse(A);
        dth_integrator_reverse(B);
    }
    double MA[64 * 64], MC[64 * 64];
    int tanA = N > 0 ? dth_integrator_tangent(A, MA) : DTH_EINVAL;
    for (long k = 0; k < N; k++) record(A, &a[k]);
    size_t len;
    unsigned char *buf = save_alloc(B, NULL, 0, &len);
    dth_integrator_free(B);
    dth_integrator *C = make_it(m, h, start); /* fresh: never started */
    char err[200];
    CU_ASSERT_FATAL(dth_checkpoint_restore(C, buf, len, err, sizeof err) == DTH_OK);
    CU_ASSERT(dth_integrator_steps(C) == N);
    if (N > 0 && tanA == DTH_OK && D <= 64) {
        CU_ASSERT(dth_integrator_tangent(C, MC) == DTH_OK);
        CU_ASSERT(memcmp(MA, MC, D * D * sizeof(double)) == 0);
    }
    long mism = 0;
    for (long k = 0; k < N; k++) {
        record(C, &r);
        if (memcmp(&r, &a[k], sizeof r) != 0) mism++;
    }
    if (mism)
        printf("  [%s h=%g start=%d N=%ld: %ld resumed steps differ]\n", dth_model_get_type(m)->name, h,
               (int)start, N, mism);
    CU_ASSERT(mism == 0);
    CU_ASSERT(dth_integrator_steps(C) == dth_integrator_steps(A));
    free(buf);
    free(a);
    dth_integrator_free(A);
    dth_integrator_free(C);
}

static void test_resume_bit_identical(void)
{
    dth_registry *reg;
    CU_ASSERT_FATAL(dth_registry_new(NULL, &reg) == DTH_OK);
    CU_ASSERT_FATAL(dth_registry_add_builtin(reg) == DTH_OK);
    for (size_t i = 0; i < dth_registry_model_count(reg); i++) {
        dth_model *m = make_model(dth_registry_model_at(reg, i));
        if (!m) {
            printf("  [cannot build model %s]\n", dth_registry_model_at(reg, i)->name);
            CU_FAIL("model without a default configuration");
            continue;
        }
        for (int s = 0; s < 2; s++) {
            dth_start st = s ? DTH_START_VERTEX : DTH_START_MIDPOINT;
            resume_identical(m, 0.03, st, 0, 0);  /* before the first step */
            resume_identical(m, 0.03, st, 1, 0);  /* after the exact first step */
            resume_identical(m, 0.03, st, 40, 0);
            resume_identical(m, -0.02, st, 25, 1); /* backward, then reversed */
        }
        dth_model_free(m);
    }
    dth_registry_free(reg);
}

/* Rotating pendulum across its first psi = 0 crossing (region changes, steps collapse). */
static void test_resume_across_crossing(void)
{
    dth_model *m = make_model(&dth_model_pendulum);
    CU_ASSERT_FATAL(m != NULL);
    double q = 0, p = 2.2;
    dth_integrator *A = make_it(m, 0.05, DTH_START_VERTEX);
    CU_ASSERT_FATAL(dth_integrator_start(A, &q, &p, 0) == DTH_OK);
    rec r, ra;
    for (int k = 0; k < 12; k++) record(A, &r);
    size_t len;
    unsigned char *buf = save_alloc(A, NULL, 0, &len);
    dth_integrator *C = make_it(m, 0.05, DTH_START_VERTEX);
    CU_ASSERT_FATAL(dth_checkpoint_restore(C, buf, len, NULL, 0) == DTH_OK);
    int same = 1;
    for (int k = 0; k < 60; k++) {
        record(A, &ra);
        record(C, &r);
        same &= memcmp(&r, &ra, sizeof r) == 0;
    }
    CU_ASSERT(same);
    free(buf);
    dth_integrator_free(A);
    dth_integrator_free(C);
    dth_model_free(m);
}

/* Any single changed byte, any truncation, any extension: DTH_EPARSE, state untouched. */
static void test_corruption_refused(void)
{
    dth_model *m = make_model(&dth_model_pendulum);
    dth_integrator *A = make_it(m, 0.1, DTH_START_MIDPOINT), *C = make_it(m, 0.1, DTH_START_MIDPOINT);
    double q = 1.0, p = 0.2, q2 = -0.5, p2 = 0.7;
    CU_ASSERT_FATAL(dth_integrator_start(A, &q, &p, 0) == DTH_OK);
    CU_ASSERT_FATAL(dth_integrator_start(C, &q2, &p2, 3) == DTH_OK);
    for (int k = 0; k < 5; k++) {
        CU_ASSERT(dth_integrator_step(A, NULL) == DTH_OK);
        CU_ASSERT(dth_integrator_step(C, NULL) == DTH_OK);
    }
    const char text[] = "[model]\nname=pendulum\n";
    dth_blob blobs[] = {{"scene", text, sizeof text - 1}, {"empty", NULL, 0}};
    size_t len, clen;
    unsigned char *good = save_alloc(A, blobs, 2, &len);
    unsigned char *before = save_alloc(C, NULL, 0, &clen), *bad = malloc(len + 1);
    CU_ASSERT_FATAL(bad != NULL);
    long wrong = 0, touched = 0;
    for (size_t i = 0; i < len; i++)
        for (int bit = 0; bit < 8; bit += 3) {
            memcpy(bad, good, len);
            bad[i] ^= (unsigned char)(1u << bit);
            if (dth_checkpoint_restore(C, bad, len, NULL, 0) != DTH_EPARSE) wrong++;
            if (dth_checkpoint_verify(bad, len, NULL, 0) != DTH_EPARSE) wrong++;
        }
    for (size_t l = 0; l < len; l++)
        if (dth_checkpoint_restore(C, good, l, NULL, 0) != DTH_EPARSE) wrong++;
    memcpy(bad, good, len);
    bad[len] = 0;
    if (dth_checkpoint_restore(C, bad, len + 1, NULL, 0) != DTH_EPARSE) wrong++;
    size_t alen;
    unsigned char *after = save_alloc(C, NULL, 0, &alen);
    touched = alen != clen || memcmp(before, after, clen) != 0;
    CU_ASSERT(wrong == 0);
    CU_ASSERT(touched == 0);
    /* the messages say what is wrong */
    char err[200] = "";
    CU_ASSERT(dth_checkpoint_restore(C, good, len - 1, err, sizeof err) == DTH_EPARSE);
    CU_ASSERT(strstr(err, "truncated") != NULL);
    memcpy(bad, good, len);
    bad[len - 20] ^= 1;
    CU_ASSERT(dth_checkpoint_restore(C, bad, len, err, sizeof err) == DTH_EPARSE);
    CU_ASSERT(strstr(err, "checksum") != NULL);
    /* blobs come back as saved */
    const void *data;
    size_t size;
    CU_ASSERT(dth_checkpoint_blob(good, len, "scene", &data, &size) == DTH_OK);
    CU_ASSERT(size == sizeof text - 1 && memcmp(data, text, size) == 0);
    CU_ASSERT(dth_checkpoint_blob(good, len, "empty", &data, &size) == DTH_OK);
    CU_ASSERT(size == 0);
    CU_ASSERT(dth_checkpoint_blob(good, len, "scen", &data, &size) == DTH_ENOTFOUND);
    CU_ASSERT(dth_checkpoint_blob(bad, len, "scene", &data, &size) == DTH_EPARSE);
    char name[32];
    CU_ASSERT(dth_checkpoint_model_name(good, len, name, sizeof name) == DTH_OK);
    CU_ASSERT(strcmp(name, "pendulum") == 0);
    /* bad blob lists and a short buffer */
    dth_blob dup[] = {{"a", "x", 1}, {"a", "y", 1}}, noname[] = {{"", "x", 1}};
    size_t l2;
    CU_ASSERT(dth_checkpoint_save(A, dup, 2, NULL, 0, &l2) == DTH_EINVAL);
    CU_ASSERT(dth_checkpoint_save(A, noname, 1, NULL, 0, &l2) == DTH_EINVAL);
    CU_ASSERT(dth_checkpoint_save(A, blobs, 2, bad, len - 1, &l2) == DTH_EINVAL);
    CU_ASSERT(l2 == len);
    free(good);
    free(bad);
    free(before);
    free(after);
    dth_integrator_free(A);
    dth_integrator_free(C);
    dth_model_free(m);
}

/* FNV-1a 64, written out again here so tests can forge well-checksummed bad content. */
static uint64_t fnv(const unsigned char *p, size_t n)
{
    uint64_t h = 14695981039346656037ULL;
    for (size_t i = 0; i < n; i++) h = (h ^ p[i]) * 1099511628211ULL;
    return h;
}

static void reseal(unsigned char *b, size_t len)
{
    uint64_t h = fnv(b, len - 8);
    for (int i = 0; i < 8; i++) b[len - 8 + (size_t)i] = (unsigned char)(h >> (8 * i));
}

/* Offset of the first value of the state field `name` (format: u32 name length, name, u32 type,
 * u64 count, values), 0 if not found. */
static size_t field_values(const unsigned char *b, size_t len, const char *name)
{
    size_t nl = strlen(name);
    for (size_t i = 0; i + 4 + nl + 12 <= len; i++)
        if (b[i] == nl && !b[i + 1] && !b[i + 2] && !b[i + 3] && memcmp(b + i + 4, name, nl) == 0 &&
            b[i + 4 + nl] >= 1 && b[i + 4 + nl] <= 2)
            return i + 4 + nl + 12;
    return 0;
}

static void put_le(unsigned char *p, uint64_t v)
{
    for (int i = 0; i < 8; i++) p[i] = (unsigned char)(v >> (8 * i));
}

/* Content errors behind a valid checksum: version, invalid fields, other options, foreign model. */
static void test_invalid_content_refused(void)
{
    dth_model *m = make_model(&dth_model_pendulum), *hm = NULL;
    CU_ASSERT_FATAL(dth_model_new(&dth_model_harmonic, NULL, 0, 1, NULL, &hm, NULL, 0) == DTH_OK);
    dth_integrator *A = make_it(m, 0.1, DTH_START_MIDPOINT);
    double q = 1.0, p = 0.2;
    CU_ASSERT_FATAL(dth_integrator_start(A, &q, &p, 0) == DTH_OK);
    CU_ASSERT(dth_integrator_step(A, NULL) == DTH_OK);
    size_t len;
    unsigned char *good = save_alloc(A, NULL, 0, &len), *bad = malloc(len);
    char err[200] = "";
    /* resealed good copy restores: reseal itself is right */
    memcpy(bad, good, len);
    reseal(bad, len);
    CU_ASSERT(memcmp(bad, good, len) == 0);
    /* a version this library does not read */
    bad[8] = DTH_CHECKPOINT_VERSION + 1;
    reseal(bad, len);
    CU_ASSERT(dth_checkpoint_restore(A, bad, len, err, sizeof err) == DTH_EPARSE);
    CU_ASSERT(strstr(err, "version") != NULL);
    /* an old version is refused with a message naming both versions */
    memcpy(bad, good, len);
    bad[8] = 3;
    reseal(bad, len);
    CU_ASSERT(dth_checkpoint_restore(A, bad, len, err, sizeof err) == DTH_EPARSE);
    CU_ASSERT(strstr(err, "version 3") != NULL);
    /* NaN in the vertex, a flag out of range, an unknown field name: refused naming the field */
    size_t z0 = field_values(good, len, "z"), ps = field_values(good, len, "psi_sign"),
           nh = field_values(good, len, "nhist");
    CU_ASSERT_FATAL(z0 && ps && nh);
    memcpy(bad, good, len);
    put_le(bad + z0, 0x7ff8000000000000ULL); /* a NaN */
    reseal(bad, len);
    CU_ASSERT(dth_checkpoint_restore(A, bad, len, err, sizeof err) == DTH_EPARSE);
    CU_ASSERT(strstr(err, "'z'") != NULL);
    memcpy(bad, good, len);
    put_le(bad + ps, 5);
    reseal(bad, len);
    CU_ASSERT(dth_checkpoint_restore(A, bad, len, err, sizeof err) == DTH_EPARSE);
    CU_ASSERT(strstr(err, "'psi_sign'") != NULL);
    memcpy(bad, good, len);
    put_le(bad + nh, (uint64_t)-1);
    reseal(bad, len);
    CU_ASSERT(dth_checkpoint_restore(A, bad, len, err, sizeof err) == DTH_EPARSE);
    CU_ASSERT(strstr(err, "'nhist'") != NULL);
    memcpy(bad, good, len);
    bad[nh - 12 - 5] ^= 0x20; /* the name "nhist" -> "Nhist" */
    reseal(bad, len);
    CU_ASSERT(dth_checkpoint_restore(A, bad, len, err, sizeof err) == DTH_EPARSE);
    CU_ASSERT(strstr(err, "'Nhist'") != NULL && strstr(err, "'nhist'") != NULL);
    /* the options that change the steps must match: branch check, regularizer */
    dth_options o;
    dth_options_default(&o);
    o.h = 0.1;
    o.branch_check = 0;
    dth_integrator *B = NULL;
    CU_ASSERT_FATAL(dth_integrator_new(m, &o, &B) == DTH_OK);
    CU_ASSERT(dth_checkpoint_restore(B, good, len, err, sizeof err) == DTH_EINVAL);
    CU_ASSERT(strstr(err, "branch_check") != NULL);
    dth_integrator_free(B);
    dth_regularizer *rg = NULL;
    CU_ASSERT_FATAL(dth_regularizer_new(&dth_reg_prescribed, NULL, 0, m, NULL, &rg, NULL, 0) == DTH_OK);
    dth_options_default(&o);
    o.h = 0.1;
    o.regularizer = rg;
    CU_ASSERT_FATAL(dth_integrator_new(m, &o, &B) == DTH_OK);
    CU_ASSERT(dth_checkpoint_restore(B, good, len, err, sizeof err) == DTH_EINVAL);
    CU_ASSERT(strstr(err, "no regularizer") != NULL && strstr(err, "'prescribed'") != NULL);
    dth_integrator_free(B);
    dth_regularizer_free(rg);
    /* a pendulum checkpoint does not fit a harmonic oscillator of the same dimension */
    dth_integrator *H = make_it(hm, 0.1, DTH_START_MIDPOINT);
    CU_ASSERT(dth_checkpoint_restore(H, good, len, err, sizeof err) == DTH_EINVAL);
    CU_ASSERT(strstr(err, "pendulum") != NULL && strstr(err, "harmonic") != NULL);
    CU_ASSERT(dth_integrator_steps(H) == 0);
    free(good);
    free(bad);
    dth_integrator_free(A);
    dth_integrator_free(H);
    dth_model_free(m);
    dth_model_free(hm);
}

/* Entries of a folder other than . and .. */
static int files_in(const char *dir)
{
    DIR *d = opendir(dir);
    int k = 0;
    if (!d) return -1;
    for (struct dirent *e; (e = readdir(d));)
        if (strcmp(e->d_name, ".") && strcmp(e->d_name, "..")) k++;
    closedir(d);
    return k;
}

/* Files: crash-safe replace, no temporary left, read back, errors name the file, ENOMEM clean. */
static void test_files(void)
{
    char dir[] = "/tmp/dth_ckpt_XXXXXX";
    CU_ASSERT_FATAL(mkdtemp(dir) != NULL);
    char path[128], tmp[140];
    snprintf(path, sizeof path, "%s/run.ckpt", dir);
    snprintf(tmp, sizeof tmp, "%s.tmp", path);
    dth_model *m = make_model(&dth_model_pendulum);
    dth_integrator *A = make_it(m, 0.05, DTH_START_MIDPOINT), *C = make_it(m, 0.05, DTH_START_MIDPOINT);
    double q = 0.5, p = 0.5;
    CU_ASSERT_FATAL(dth_integrator_start(A, &q, &p, 0) == DTH_OK);
    char err[256] = "";
    const char text[] = "scene text";
    dth_blob b = {"scene", text, sizeof text};
    CU_ASSERT(dth_checkpoint_write_file(A, &b, 1, path, err, sizeof err) == DTH_OK);
    for (int k = 0; k < 7; k++) CU_ASSERT(dth_integrator_step(A, NULL) == DTH_OK);
    CU_ASSERT(dth_checkpoint_write_file(A, &b, 1, path, err, sizeof err) == DTH_OK); /* replaces */
    CU_ASSERT(access(tmp, F_OK) != 0);
    CU_ASSERT(files_in(dir) == 1); /* no temporary left: only run.ckpt */
    /* a folder is no checkpoint: said so (not "out of memory") */
    void *dbuf = NULL;
    size_t dlen;
    CU_ASSERT(dth_checkpoint_read_file(dir, NULL, &dbuf, &dlen, err, sizeof err) == DTH_EIO);
    CU_ASSERT(strstr(err, "Is a directory") != NULL && dbuf == NULL);
    void *buf = NULL;
    size_t len;
    CU_ASSERT_FATAL(dth_checkpoint_read_file(path, NULL, &buf, &len, err, sizeof err) == DTH_OK);
    CU_ASSERT(dth_checkpoint_restore(C, buf, len, err, sizeof err) == DTH_OK);
    CU_ASSERT(dth_integrator_steps(C) == 7);
    CU_ASSERT(memcmp(dth_integrator_vertex(A), dth_integrator_vertex(C), 4 * sizeof(double)) == 0);
    const void *data;
    size_t size;
    CU_ASSERT(dth_checkpoint_blob(buf, len, "scene", &data, &size) == DTH_OK && size == sizeof text);
    dth_free(NULL, buf);
    /* a corrupted file is refused with a message naming it */
    FILE *f = fopen(path, "r+b");
    CU_ASSERT_FATAL(f != NULL);
    fseek(f, 40, SEEK_SET);
    fputc(0x55, f);
    fclose(f);
    CU_ASSERT(dth_checkpoint_read_file(path, NULL, &buf, &len, err, sizeof err) == DTH_EPARSE);
    CU_ASSERT(buf == NULL && strstr(err, path) != NULL);
    /* unreadable / unwritable paths */
    char nodir[160];
    snprintf(nodir, sizeof nodir, "%s/no/such/dir/x.ckpt", dir);
    CU_ASSERT(dth_checkpoint_write_file(A, NULL, 0, nodir, err, sizeof err) == DTH_EIO);
    CU_ASSERT(strstr(err, "x.ckpt") != NULL);
    CU_ASSERT(dth_checkpoint_read_file(nodir, NULL, &buf, &len, err, sizeof err) == DTH_EIO);
    CU_ASSERT(strstr(err, "x.ckpt") != NULL);
    /* every allocation of read_file / write_file fails in turn: ENOMEM, nothing leaked */
    failing_alloc fa;
    dth_allocator al = failing_alloc_make(&fa, 0);
    CU_ASSERT(dth_checkpoint_read_file(nodir, &al, &buf, &len, NULL, 0) == DTH_EIO);
    CU_ASSERT(fa.count == 0);
    dth_options o;
    dth_options_default(&o);
    o.h = 0.05;
    o.alloc = &al;
    dth_integrator *F = NULL;
    CU_ASSERT_FATAL(dth_integrator_new(m, &o, &F) == DTH_OK);
    CU_ASSERT_FATAL(dth_integrator_start(F, &q, &p, 0) == DTH_OK);
    long base = fa.count;
    CU_ASSERT(dth_checkpoint_write_file(F, NULL, 0, path, NULL, 0) == DTH_OK);
    long total = fa.count - base;
    CU_ASSERT(total >= 1);
    for (long k = 1; k <= total; k++) {
        long live = fa.live;
        fa.fail_at = fa.count + k;
        CU_ASSERT(dth_checkpoint_write_file(F, NULL, 0, path, NULL, 0) == DTH_ENOMEM);
        CU_ASSERT(fa.live == live);
    }
    fa.fail_at = fa.count + 1;
    CU_ASSERT(dth_checkpoint_read_file(path, &al, &buf, &len, NULL, 0) == DTH_ENOMEM);
    CU_ASSERT(buf == NULL);
    dth_integrator_free(F);
    CU_ASSERT(fa.live == 0);
    remove(path);
    remove(dir);
    dth_integrator_free(A);
    dth_integrator_free(C);
    dth_model_free(m);
}

/* The documented layout (docs/checkpoint.md) read independently: walk a checkpoint by it, and
 * every section and field it holds is named in the document's tables, with the counts. */
static uint64_t le(const unsigned char *p, int n)
{
    uint64_t v = 0;
    for (int i = n - 1; i >= 0; i--) v = (v << 8) | p[i];
    return v;
}

/* One section at b + *pos: its name and field count in the document's form, each field named there. */
static void documented_section(const unsigned char *b, size_t *pos, const char *doc, int count_in_doc)
{
    size_t sl = (size_t)le(b + *pos, 4);
    char sname[64] = "`";
    CU_ASSERT_FATAL(sl > 0 && sl < 60);
    memcpy(sname + 1, b + *pos + 4, sl);
    memcpy(sname + 1 + sl, "` |", 4);
    *pos += 4 + sl;
    uint64_t veclen = le(b + *pos, 8), nf = le(b + *pos + 8, 4);
    *pos += 12;
    char want[96], vl[24] = "N"; /* the pendulum's N = 2n + 2 = 4 reads as N in the document */
    if (veclen != 4) snprintf(vl, sizeof vl, "%llu", (unsigned long long)veclen);
    if (count_in_doc) snprintf(want, sizeof want, "| %s u64 %s, u32 count (%llu)", sname, vl, (unsigned long long)nf);
    else snprintf(want, sizeof want, "| %s u64 %s, u32 count", sname, vl);
    if (doc && !strstr(doc, want)) {
        printf("  [section %s is not in docs/checkpoint.md as '%s']\n", sname, want);
        CU_FAIL("undocumented section");
    }
    for (uint64_t i = 0; i < nf; i++) {
        size_t nl = (size_t)le(b + *pos, 4);
        char name[64] = "`";
        CU_ASSERT_FATAL(nl > 0 && nl < 60);
        memcpy(name + 1, b + *pos + 4, nl);
        memcpy(name + 1 + nl, "` |", 4);
        *pos += 4 + nl;
        uint64_t type = le(b + *pos, 4), count = le(b + *pos + 4, 8);
        CU_ASSERT(type == 1 || type == 2);
        CU_ASSERT(count == 1 || count == veclen);
        *pos += 12 + 8 * count;
        if (doc && !strstr(doc, name)) {
            printf("  [field %s is not in docs/checkpoint.md]\n", name);
            CU_FAIL("undocumented field");
        }
    }
}

/* A checkpoint of the pendulum with regularizer rt (NULL: none), the error estimate if est, and a run
 * state, walked by the document. */
static void documented_checkpoint(const dth_regularizer_type *rt, int est, const char *doc)
{
    dth_model *m = make_model(&dth_model_pendulum);
    dth_regularizer *rg = NULL;
    if (rt) CU_ASSERT_FATAL(dth_regularizer_new(rt, NULL, 0, m, NULL, &rg, NULL, 0) == DTH_OK);
    dth_options o;
    dth_options_default(&o);
    o.h = 0.1;
    o.regularizer = rg;
    o.estimate = est;
    dth_integrator *A = NULL;
    CU_ASSERT_FATAL(dth_integrator_new(m, &o, &A) == DTH_OK);
    double q = 1.0, p = 0.2;
    CU_ASSERT_FATAL(dth_integrator_start(A, &q, &p, 0) == DTH_OK);
    dth_run_config c;
    dth_run_config_default(&c);
    c.steps = 3;
    dth_run_state st;
    dth_run_state_init(&st);
    CU_ASSERT_FATAL(dth_run(A, &c, &st) == DTH_OK);
    const char text[] = "x";
    dth_blob blob = {"scene", text, 1};
    size_t len;
    CU_ASSERT_FATAL(dth_checkpoint_save_run(A, &st, &blob, 1, NULL, 0, &len) == DTH_OK);
    unsigned char *b = malloc(len);
    CU_ASSERT_FATAL(b && dth_checkpoint_save_run(A, &st, &blob, 1, b, len, &len) == DTH_OK);
    /* header (the byte-order mark: 04 03 02 01), method, model, n, then the sections: options
     * first, then the stepper's */
    CU_ASSERT(memcmp(b, "DTHCKPT", 8) == 0 && le(b + 8, 4) == DTH_CHECKPOINT_VERSION && le(b + 12, 4) == 0x01020304u &&
              le(b + 16, 8) == len);
    size_t pos = 24;
    CU_ASSERT(le(b + pos, 4) == 3 && memcmp(b + pos + 4, "dth", 3) == 0);
    pos += 4 + le(b + pos, 4);
    pos += 4 + le(b + pos, 4);
    CU_ASSERT(le(b + pos, 8) == 1);
    pos += 8;
    uint64_t nsec = le(b + pos, 4);
    pos += 4;
    CU_ASSERT(nsec == 3 + (uint64_t)est); /* options, state, policy; the estimate's */
    for (uint64_t sec = 0; sec < nsec; sec++) documented_section(b, &pos, doc, 1);
    /* the regularizer's name and its section, the run state's flag and section */
    size_t rl = (size_t)le(b + pos, 4);
    CU_ASSERT(rl == (rt ? strlen(rt->name) : 0) && (!rt || memcmp(b + pos + 4, rt->name, rl) == 0));
    pos += 4 + rl;
    CU_ASSERT(le(b + pos + 4 + 11 + 8, 4) == (rt ? rt->n_fields : 0));
    documented_section(b, &pos, doc, 0);
    CU_ASSERT(le(b + pos, 4) == 1);
    pos += 4;
    documented_section(b, &pos, doc, 1);
    /* one blob, checksum */
    CU_ASSERT(le(b + pos, 4) == 1);
    pos += 4;
    CU_ASSERT(le(b + pos, 4) == 5 && memcmp(b + pos + 4, "scene", 5) == 0 && le(b + pos + 9, 8) == 1);
    pos += 4 + 5 + 8 + 1;
    CU_ASSERT(pos + 8 == len);
    free(b);
    dth_integrator_free(A);
    dth_regularizer_free(rg);
    dth_model_free(m);
}

static void test_documented_layout(void)
{
    const char *root = getenv("DTH_SOURCE_ROOT");
    char *doc = NULL;
    if (root) {
        char path[4096];
        snprintf(path, sizeof path, "%s/docs/checkpoint.md", root);
        FILE *f = fopen(path, "rb");
        CU_ASSERT_FATAL(f != NULL);
        doc = calloc(1, 1 << 16);
        CU_ASSERT_FATAL(doc != NULL);
        size_t got = fread(doc, 1, (1 << 16) - 1, f);
        fclose(f);
        CU_ASSERT(got > 0);
    } else {
        printf("  [DTH_SOURCE_ROOT not set: the document is not compared]\n");
    }
    documented_checkpoint(NULL, 0, doc);
    documented_checkpoint(&dth_reg_land, 1, doc);
    documented_checkpoint(&dth_reg_prescribed, 0, doc);
    free(doc);
}

static CU_TestInfo checkpoint_tests[] = {
    {"N + save/restore + N == 2N steps, bit for bit (every model, both starts)", test_resume_bit_identical},
    {"resume across the rotating pendulum's psi = 0 crossing", test_resume_across_crossing},
    {"corrupted / truncated / extended checkpoints: DTH_EPARSE, untouched", test_corruption_refused},
    {"invalid content behind a valid checksum; foreign model", test_invalid_content_refused},
    {"files: crash-safe replace, read back, errors name the file, ENOMEM", test_files},
    {"the layout of docs/checkpoint.md, and every field named there", test_documented_layout},
    CU_TEST_INFO_NULL,
};

CU_SuiteInfo dth_test_suites[] = {
    {.pName = "checkpoint", .pTests = checkpoint_tests},
    CU_SUITE_INFO_NULL,
};
