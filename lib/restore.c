/* SPDX-License-Identifier: MIT */
/*
 * Restoring a checkpoint (checkpoint.c writes and verifies it): every field read by its list and
 * each value checked (fields.c); then the rules between fields on the restored state (the
 * stepper's `consistent`, the regularizer's state_loaded, the run state's rules below), and the
 * integrator goes back to what it was if any of them refuses: a restore changes all or nothing.
 */
#include <math.h>
#include <stdarg.h>
#include <stdio.h>
#include <string.h>
#include "dth/checkpoint.h"
#include "ckpt_format.h"
#include "run_fields.h"

static int same_str(const char *a, const char *b, size_t blen) { return strlen(a) == blen && memcmp(a, b, blen) == 0; }

/* Read the saved section that must match `want` (its name, veclen and fields), validating every
 * value; pos gets each field's reader position. */
static int read_section(dth__rd *r, const dth__section *want, size_t *pos, char *err, size_t errlen)
{
    size_t nl;
    const char *nm = dth__get_str(r, DTH__CKPT_MAX_NAME, &nl);
    uint64_t veclen = dth__get_u64(r);
    uint32_t nf = dth__get_u32(r);
    if (r->bad || !same_str(want->name, nm, nl) || veclen != want->veclen || nf != want->nfields) {
        dth__set_err(err, errlen, "checkpoint section '%.*s' (%u fields of %llu) where this library expects '%s' (%zu of %zu)",
                     r->bad ? 0 : (int)nl, r->bad ? "" : nm, (unsigned)nf, (unsigned long long)veclen, want->name,
                     want->nfields, want->veclen);
        return DTH_EPARSE;
    }
    for (size_t i = 0; i < want->nfields; i++) {
        char msg[200];
        int rc = dth__get_field(r, &want->fields[i], want->veclen, &pos[i], msg, sizeof msg);
        if (rc) {
            dth__set_err(err, errlen, "checkpoint section '%s': %s", want->name, msg);
            return rc;
        }
    }
    return DTH_OK;
}

/* The saved options equal the integrator's (they change the steps). */
static int same_options(const dth__rd *r, const dth__section *o, const size_t *pos, char *err, size_t errlen)
{
    double saved[8];
    for (size_t i = 0; i < o->nfields; i++) {
        const dth_field *f = &o->fields[i];
        dth__load_field(r, pos[i], f, saved, 0);
        const char *a = (const char *)o->base + f->offset, *b = (const char *)(void *)saved + f->offset;
        if (memcmp(a, b, f->kind == DTH__K_F64 ? sizeof(double) : sizeof(long)) == 0) continue;
        if (f->kind == DTH__K_F64)
            dth__set_err(err, errlen, "checkpoint was written with option %s = %.17g, this integrator has %.17g", f->name,
                         *(const double *)(const void *)b, *(const double *)(const void *)a);
        else
            dth__set_err(err, errlen, "checkpoint was written with option %s = %ld, this integrator has %ld", f->name,
                         *(const long *)(const void *)b, *(const long *)(const void *)a);
        return DTH_EINVAL;
    }
    return DTH_OK;
}

/* ---- the run state's rules: among its own fields, and against the integrator it runs ---- */

static int all_zero(const void *p, size_t n)
{
    const unsigned char *b = p;
    for (size_t i = 0; i < n; i++)
        if (b[i]) return 0;
    return 1;
}

static int run_refuse(char *err, size_t errlen, const char *fmt, ...) __attribute__((format(printf, 3, 4)));
static int run_refuse(char *err, size_t errlen, const char *fmt, ...)
{
    char msg[240];
    va_list ap;
    va_start(ap, fmt);
    vsnprintf(msg, sizeof msg, fmt, ap);
    va_end(ap);
    dth__set_err(err, errlen, "checkpoint section 'run': %s", msg);
    return DTH_EPARSE;
}

static int run_rules(const dth_run_state *S, char *err, size_t errlen)
{
    size_t nf;
    const dth_field *f = dth__run_fields(&nf);
    for (size_t i = 0; !S->started && i < nf; i++)
        if (!all_zero((const char *)S + f[i].offset, dth__field_size(&f[i])))
            return run_refuse(err, errlen, "field '%s' is set in a run that has not started (started = 0)", f[i].name);
    if (S->k0 > S->k) return run_refuse(err, errlen, "field 'k0' = %ld exceeds field 'k' = %ld", S->k0, S->k);
    const struct {
        const char *name;
        long v;
    } counts[] = {{"crossings", S->crossings}, {"regularized", S->regularized}, {"nonreversible", S->nonreversible}};
    for (size_t i = 0; i < sizeof counts / sizeof counts[0]; i++)
        if (counts[i].v > S->k)
            return run_refuse(err, errlen, "field '%s' = %ld exceeds the steps taken, field 'k' = %ld", counts[i].name,
                              counts[i].v, S->k);
    if (S->k == 0)
        for (size_t i = 0; i < nf; i++)
            if (!strncmp(f[i].name, "in.", 3) && !all_zero((const char *)S + f[i].offset, dth__field_size(&f[i])))
                return run_refuse(err, errlen, "field '%s' describes a step, but no step was taken (k = 0)", f[i].name);
    if (S->k > 0 && S->in.lambda == 0)
        return run_refuse(err, errlen, "field 'in.lambda' is 0, but k = %ld steps were taken", S->k);
    if (S->prev_crossing != ((S->in.flags & DTH_STEP_CROSSING) != 0))
        return run_refuse(err, errlen, "field 'prev_crossing' = %d disagrees with field 'in.flags' = %u", S->prev_crossing,
                          S->in.flags);
    if (S->max_ratio > 0 && S->crossings == 0)
        return run_refuse(err, errlen, "field 'max_ratio' = %.17g without a crossing (crossings = 0)", S->max_ratio);
    return DTH_OK;
}

static int run_fits(const dth_integrator *it, const dth_run_state *S, char *err, size_t errlen)
{
    if (!S->started) return DTH_OK;
    double t = it->type->vertex(it->state)[it->n], dir = it->type->direction(it->state);
    if (S->t != t)
        return run_refuse(err, errlen, "field 't' = %.17g is not the time of the integrator's vertex, %.17g", S->t, t);
    /* samples went out up to t_stop: from the run's start to the vertex (or the start itself, while
     * the vertex lies before it: a midpoint start's first vertex) */
    double hi = dir * (t - S->t_first) > 0 ? t : S->t_first;
    if (dir * (S->t_stop - S->t_first) < 0 || dir * (S->t_stop - hi) > 0)
        return run_refuse(err, errlen, "field 't_stop' = %.17g lies outside the run's span from t_first = %.17g to t = %.17g",
                          S->t_stop, S->t_first, t);
    return DTH_OK;
}

/* The error estimate's shadow, where it is valid, is a finite state at the vertex's time. */
static int estimate_fits(const dth_integrator *it, char *err, size_t errlen)
{
    const dth__estimate *e = &it->est;
    if (!e->on || !e->valid) return DTH_OK;
    int finite = isfinite(e->E0);
    for (size_t j = 0; j < e->N; j++) finite &= isfinite(e->x[j]) != 0;
    double t = it->type->vertex(it->state)[it->n];
    if (!finite || e->x[it->n] != t) {
        dth__set_err(err, errlen, "checkpoint section 'estimate': field 'valid' = 1 with %s",
                     finite ? "field 'x' at a time other than the integrator's vertex's" : "a non-finite 'x' or 'E0'");
        return DTH_EPARSE;
    }
    return DTH_OK;
}

/* ---- everything read and checked, as reader positions ---- */

typedef struct plan {
    dth__section sec[DTH__CKPT_MAX_SECTIONS], reg, run;
    size_t ns;
    double scratch[8];
    size_t pos[DTH__CKPT_MAX_SECTIONS][DTH__MAX_FIELDS], regpos[DTH__MAX_FIELDS], runpos[DTH__MAX_FIELDS];
} plan;

/* The method, model, dimension, options and regularizer must be the integrator's. */
static int same_kind(const dth_integrator *it, const dth__ckpt *s, char *err, size_t errlen)
{
    const char *mname = dth_model_get_type(it->model)->name, *rname = dth__ckpt_reg_name(it);
    if (!same_str(it->type->name, s->method, s->method_len)) {
        dth__set_err(err, errlen, "checkpoint of method '%.*s', this integrator steps with '%s'", (int)s->method_len,
                     s->method, it->type->name);
        return DTH_EINVAL;
    }
    if (!same_str(mname, s->name, s->name_len) || s->n != it->n) {
        dth__set_err(err, errlen, "checkpoint of model '%.*s' with %llu degrees of freedom does not fit model '%s' with %zu",
                     (int)s->name_len, s->name, (unsigned long long)s->n, mname, it->n);
        return DTH_EINVAL;
    }
    if (!same_str(rname, s->reg, s->reg_name_len)) {
        dth__set_err(err, errlen, "checkpoint was written with %s%.*s%s, this integrator has %s%s%s",
                     s->reg_name_len ? "regularizer '" : "no regularizer", (int)s->reg_name_len, s->reg,
                     s->reg_name_len ? "'" : "", rname[0] ? "regularizer '" : "none", rname, rname[0] ? "'" : "");
        return DTH_EINVAL;
    }
    return DTH_OK;
}

static int read_all(dth_integrator *it, const dth__ckpt *s, dth__rd *q, dth_run_state *run, plan *p, char *err,
                    size_t errlen)
{
    int rc = same_kind(it, s, err, errlen);
    if (rc) return rc;
    p->ns = dth__ckpt_sections(it, p->sec, p->scratch);
    if (s->nsec != p->ns) {
        /* the method is the same (same_kind): only the error estimate's section can differ */
        int est = s->nsec + 1 == p->ns && it->est.on ? 1 : s->nsec == p->ns + 1 && !it->est.on ? -1 : 0;
        dth__set_err(err, errlen, "checkpoint has %u state sections, this integrator %zu%s", (unsigned)s->nsec, p->ns,
                     est > 0   ? " (its error estimate: the checkpoint was written without one, dth_options.estimate = 0)"
                     : est < 0 ? " (the checkpoint holds an error estimate, dth_options.estimate = 1: this integrator "
                                 "has none)"
                               : "");
        return est ? DTH_EINVAL : DTH_EPARSE;
    }
    q->pos = s->pos_sec;
    for (size_t i = 0; i < p->ns; i++) {
        if (p->sec[i].nfields > DTH__MAX_FIELDS) return DTH_EINVAL;
        if ((rc = read_section(q, &p->sec[i], p->pos[i], err, errlen)) != 0) return rc;
    }
    if ((rc = same_options(q, &p->sec[0], p->pos[0], err, errlen)) != 0) return rc;
    dth__ckpt_reg_section(it, &p->reg);
    q->pos = s->pos_reg;
    if ((rc = read_section(q, &p->reg, p->regpos, err, errlen)) != 0) return rc;
    if (!run) return DTH_OK;
    if (!s->has_run) {
        dth__set_err(err, errlen, "checkpoint holds no run state (it was written without one: dth_checkpoint_save)");
        return DTH_ENOTFOUND;
    }
    dth__run_section(run, &p->run);
    q->pos = s->pos_run;
    if ((rc = read_section(q, &p->run, p->runpos, err, errlen)) != 0) return rc;
    memset(run, 0, sizeof *run);
    for (size_t f = 0; f < p->run.nfields; f++) dth__load_field(q, p->runpos[f], &p->run.fields[f], run, 0);
    return run_rules(run, err, errlen);
}

/* ---- the integrator's state before: kept in the checkpoint's encoding, loaded back unchecked ---- */

static void put_snapshot(dth__wr *w, const plan *p)
{
    for (size_t i = 1; i < p->ns; i++) dth__put_section(w, &p->sec[i]);
    dth__put_section(w, &p->reg);
}

static void load_raw(dth__rd *r, const dth__section *sec)
{
    size_t nl;
    dth__get_str(r, DTH__CKPT_MAX_NAME, &nl);
    dth__get_u64(r);
    uint32_t nf = dth__get_u32(r);
    for (uint32_t i = 0; i < nf && i < sec->nfields && !r->bad; i++) {
        dth__get_str(r, DTH__CKPT_MAX_NAME, &nl);
        dth__get_u32(r);
        uint64_t count = dth__get_u64(r);
        dth__load_field(r, r->pos, &sec->fields[i], sec->base, sec->veclen);
        dth__get_bytes(r, (size_t)count * 8);
    }
}

static void load_snapshot(const plan *p, const unsigned char *buf, size_t len)
{
    dth__rd r = {buf, len, 0, 0};
    for (size_t i = 1; i < p->ns; i++) load_raw(&r, &p->sec[i]);
    load_raw(&r, &p->reg);
}

/* Load everything read into the integrator, then the rules between the fields: DTH_OK, or the
 * integrator back as it was and DTH_EPARSE naming the rule. */
static int commit(dth_integrator *it, const dth__rd *q, const plan *p, const dth_run_state *run, char *err, size_t errlen)
{
    dth__wr w = {NULL, 0, 0};
    put_snapshot(&w, p);
    unsigned char *old = dth_calloc(it->alloc, w.len ? w.len : 1, 1);
    if (!old) {
        dth__set_err(err, errlen, "out of memory restoring a checkpoint");
        return DTH_ENOMEM;
    }
    w = (dth__wr){old, w.len, 0};
    put_snapshot(&w, p);
    for (size_t i = 1; i < p->ns; i++)
        for (size_t f = 0; f < p->sec[i].nfields; f++)
            dth__load_field(q, p->pos[i][f], &p->sec[i].fields[f], p->sec[i].base, p->sec[i].veclen);
    for (size_t f = 0; f < p->reg.nfields; f++) dth__load_field(q, p->regpos[f], &p->reg.fields[f], p->reg.base, p->reg.veclen);
    struct dth_regularizer *reg = dth__ckpt_reg(it);
    int rc = DTH_OK;
    if (dth__reg_loaded(reg) < 0) {
        dth__set_err(err, errlen, "checkpoint section 'regularizer': regularizer '%s' refuses its state (the rules "
                     "between its fields)", dth__ckpt_reg_name(it));
        rc = DTH_EPARSE;
    }
    char msg[240];
    if (!rc && it->type->consistent && it->type->consistent(it->state, msg, sizeof msg)) {
        dth__set_err(err, errlen, "checkpoint state of method '%s': %s", it->type->name, msg);
        rc = DTH_EPARSE;
    }
    if (!rc) rc = estimate_fits(it, err, errlen);
    if (!rc && run) rc = run_fits(it, run, err, errlen);
    if (rc) {
        load_snapshot(p, old, w.len);
        dth__reg_loaded(reg);
    }
    dth_free(it->alloc, old);
    return rc;
}

int dth_checkpoint_restore_run(dth_integrator *it, dth_run_state *run, const void *buf, size_t len, char *err,
                               size_t errlen)
{
    if (!it) return DTH_EINVAL;
    if (!it->type->sections) {
        dth__set_err(err, errlen, "method '%s' has no checkpoints", it->type->name);
        return DTH_EUNSUPPORTED;
    }
    dth__rd r;
    dth__ckpt s;
    int rc = dth__ckpt_verify(buf, len, &r, &s, err, errlen);
    if (rc) return rc;
    plan p;
    dth_run_state saved;
    dth__rd q = {r.p, r.len, 0, 0};
    rc = read_all(it, &s, &q, run ? &saved : NULL, &p, err, errlen);
    if (!rc) rc = commit(it, &q, &p, run ? &saved : NULL, err, errlen);
    if (rc) return rc;
    if (it->type->restored) it->type->restored(it->state);
    if (run) *run = saved;
    return DTH_OK;
}

int dth_checkpoint_restore(dth_integrator *it, const void *buf, size_t len, char *err, size_t errlen)
{
    return dth_checkpoint_restore_run(it, NULL, buf, len, err, errlen);
}

int dth_checkpoint_run_state(const void *buf, size_t len, dth_run_state *run, char *err, size_t errlen)
{
    if (!run) return DTH_EINVAL;
    dth__rd r;
    dth__ckpt s;
    int rc = dth__ckpt_verify(buf, len, &r, &s, err, errlen);
    if (rc) return rc;
    if (!s.has_run) {
        dth__set_err(err, errlen, "checkpoint holds no run state (it was written without one: dth_checkpoint_save)");
        return DTH_ENOTFOUND;
    }
    dth_run_state saved;
    dth__section sec;
    size_t pos[DTH__MAX_FIELDS];
    dth__run_section(&saved, &sec);
    dth__rd q = {r.p, r.len, s.pos_run, 0};
    if ((rc = read_section(&q, &sec, pos, err, errlen)) != 0) return rc;
    memset(&saved, 0, sizeof saved);
    for (size_t f = 0; f < sec.nfields; f++) dth__load_field(&q, pos[f], &sec.fields[f], &saved, 0);
    if ((rc = run_rules(&saved, err, errlen)) != 0) return rc;
    *run = saved;
    return DTH_OK;
}
