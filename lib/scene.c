/* SPDX-License-Identifier: MIT */
/*
 * Scene files: an INI key store that remembers where each value came from (FILE:LINE or the
 * -s override), and its validation into a run setup (model, initial state, DTH step options of
 * the paper's section 2 and the start modes, output). Parsing uses inih; nothing is printed.
 */
#include <errno.h>
#include <ini.h>
#include <limits.h>
#include <math.h>
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include "dth/scene.h"
#include "dth/methods.h"
#include "dth_internal.h"

typedef struct entry {
    char *section, *key, *value, *origin;
} entry;

struct dth_scene {
    const dth_allocator *alloc;
    entry *e;
    size_t n, cap;
    char *source; /* first file loaded, for messages about missing keys */
};

static char *dup_n(const dth_allocator *a, const char *s, size_t len)
{
    char *d = dth_calloc(a, len + 1, 1);
    if (d) memcpy(d, s, len);
    return d;
}

static char *dup_s(const dth_allocator *a, const char *s) { return dup_n(a, s, strlen(s)); }

static void entry_free(const dth_allocator *a, entry *e)
{
    dth_free(a, e->section);
    dth_free(a, e->key);
    dth_free(a, e->value);
    dth_free(a, e->origin);
    memset(e, 0, sizeof *e);
}

int dth_scene_new(const dth_allocator *alloc, dth_scene **out)
{
    if (!out) return DTH_EINVAL;
    *out = NULL;
    dth_scene *s = dth_calloc(alloc, 1, sizeof *s);
    if (!s) return DTH_ENOMEM;
    s->alloc = alloc;
    *out = s;
    return DTH_OK;
}

void dth_scene_free(dth_scene *s)
{
    if (!s) return;
    for (size_t i = 0; i < s->n; i++) entry_free(s->alloc, &s->e[i]);
    dth_free(s->alloc, s->e);
    dth_free(s->alloc, s->source);
    dth_free(s->alloc, s);
}

/* Room for `extra` more entries, so that the insertions that follow cannot fail. */
static int reserve(dth_scene *s, size_t extra)
{
    if (s->n + extra <= s->cap) return DTH_OK;
    size_t cap = s->cap ? s->cap : 16;
    while (cap < s->n + extra) cap *= 2;
    entry *e = dth_calloc(s->alloc, cap, sizeof *e);
    if (!e) return DTH_ENOMEM;
    if (s->n) memcpy(e, s->e, s->n * sizeof *e);
    dth_free(s->alloc, s->e);
    s->e = e;
    s->cap = cap;
    return DTH_OK;
}

static long find(const dth_scene *s, const char *section, const char *key)
{
    for (size_t i = 0; s && section && key && i < s->n; i++)
        if (strcmp(s->e[i].section, section) == 0 && strcmp(s->e[i].key, key) == 0) return (long)i;
    return -1;
}

/* Store an entry whose strings are already allocated (ownership passes); capacity reserved. */
static void put(dth_scene *s, entry *x)
{
    long i = find(s, x->section, x->key);
    if (i < 0) {
        s->e[s->n++] = *x;
        return;
    }
    entry *e = &s->e[i];
    dth_free(s->alloc, e->value);
    dth_free(s->alloc, e->origin);
    e->value = x->value;
    e->origin = x->origin;
    dth_free(s->alloc, x->section);
    dth_free(s->alloc, x->key);
}

static int make_entry(const dth_allocator *a, const char *section, size_t sl, const char *key,
                      size_t kl, const char *value, size_t vl, const char *origin, entry *x)
{
    x->section = dup_n(a, section, sl);
    x->key = dup_n(a, key, kl);
    x->value = dup_n(a, value, vl);
    x->origin = dup_s(a, origin);
    if (x->section && x->key && x->value && x->origin) return DTH_OK;
    entry_free(a, x);
    return DTH_ENOMEM;
}

/* ---------------------------------------------------------------- loading */

typedef struct load_ctx {
    dth_scene *tmp;
    FILE *f;
    const char *path;
    int lineno;     /* lines read so far: the line the handler is called for */
    int too_long;   /* a line did not fit inih's buffer */
    int indented;   /* the current line starts with blank space: inih's continuation line */
    int nomem;
} load_ctx;

/* fgets that counts lines, notes indented (continuation) lines, and refuses lines inih would split. */
static char *reader(char *str, int num, void *stream)
{
    load_ctx *c = stream;
    if (!fgets(str, num, c->f)) return NULL;
    c->lineno++;
    c->indented = str[0] == ' ' || str[0] == '\t';
    size_t len = strlen(str);
    if (len + 1 == (size_t)num && str[len - 1] != '\n') {
        int ch = fgetc(c->f);
        if (ch != EOF) {
            c->too_long = 1;
            return NULL;
        }
    }
    return str;
}

static int handler(void *user, const char *section, const char *name, const char *value)
{
    load_ctx *c = user;
    long i = c->indented ? find(c->tmp, section, name) : -1;
    if (i >= 0) {
        /* A continuation line extends the key's value as more list items (long q= and p=
         * lists), keeping the origin of the key's first line. */
        entry *e = &c->tmp->e[i];
        size_t ol = strlen(e->value), vl = strlen(value);
        while (ol && (e->value[ol - 1] == ',' || e->value[ol - 1] == ' ')) ol--;
        char *v = dth_calloc(c->tmp->alloc, ol + vl + 2, 1);
        if (!v) {
            c->nomem = 1;
            return 0;
        }
        memcpy(v, e->value, ol);
        v[ol] = ',';
        memcpy(v + ol + 1, value, vl);
        dth_free(c->tmp->alloc, e->value);
        e->value = v;
        return 1;
    }
    char origin[4096 + 32];
    snprintf(origin, sizeof origin, "%s:%d", c->path, c->lineno);
    entry x;
    if (reserve(c->tmp, 1) || make_entry(c->tmp->alloc, section, strlen(section), name, strlen(name),
                                         value, strlen(value), origin, &x)) {
        c->nomem = 1;
        return 0;
    }
    put(c->tmp, &x);
    return 1;
}

static int load_stream(dth_scene *s, FILE *f, const char *path, char *err, size_t errlen);

int dth_scene_load(dth_scene *s, const char *path, char *err, size_t errlen)
{
    if (!s || !path) {
        dth__set_err(err, errlen, "invalid arguments to dth_scene_load");
        return DTH_EINVAL;
    }
    FILE *f = fopen(path, "r");
    if (!f) {
        dth__set_err(err, errlen, "%s: cannot read: %s", path, strerror(errno));
        return DTH_EIO;
    }
    return load_stream(s, f, path, err, errlen);
}

int dth_scene_load_mem(dth_scene *s, const char *name, const char *text, size_t len, char *err,
                       size_t errlen)
{
    if (!s || !name || (!text && len)) {
        dth__set_err(err, errlen, "invalid arguments to dth_scene_load_mem");
        return DTH_EINVAL;
    }
    static const char empty[1] = "";
    FILE *f = fmemopen((void *)(len ? text : empty), len ? len : 1, "r");
    if (!f) {
        dth__set_err(err, errlen, "%s: cannot read: %s", name, strerror(errno));
        return errno == ENOMEM ? DTH_ENOMEM : DTH_EIO;
    }
    return load_stream(s, f, name, err, errlen);
}

/* Parse an open stream (closed here) into the scene; on failure the scene is unchanged. */
static int load_stream(dth_scene *s, FILE *f, const char *path, char *err, size_t errlen)
{
    load_ctx c = {.f = f, .path = path};
    int rc = dth_scene_new(s->alloc, &c.tmp);
    if (rc) {
        fclose(f);
        dth__set_err(err, errlen, "out of memory");
        return rc;
    }
    int line = ini_parse_stream(reader, &c, handler, &c);
    int ioerr = ferror(f) ? errno : 0;
    fclose(f);
    char *src = s->source ? NULL : dup_s(s->alloc, path);
    if (ioerr) {
        dth__set_err(err, errlen, "%s: cannot read: %s", path, strerror(ioerr));
        rc = DTH_EIO;
    } else if (c.too_long) {
        dth__set_err(err, errlen, "%s:%d: line longer than 197 characters", path, c.lineno);
        rc = DTH_EPARSE;
    } else if (c.nomem || line == -2 || (!s->source && !src) || reserve(s, c.tmp->n)) {
        dth__set_err(err, errlen, "out of memory");
        rc = DTH_ENOMEM;
    } else if (line != 0) {
        dth__set_err(err, errlen, "%s:%d: syntax error: expected [section], key=value, or a comment", path, line);
        rc = DTH_EPARSE;
    }
    if (rc) {
        dth_free(s->alloc, src);
        dth_scene_free(c.tmp);
        return rc;
    }
    /* merge: capacity is reserved, so nothing below can fail */
    for (size_t i = 0; i < c.tmp->n; i++) put(s, &c.tmp->e[i]);
    c.tmp->n = 0;
    dth_scene_free(c.tmp);
    if (src) s->source = src;
    return DTH_OK;
}

static void trim(const char **b, const char **e)
{
    while (*b < *e && (**b == ' ' || **b == '\t')) (*b)++;
    while (*e > *b && ((*e)[-1] == ' ' || (*e)[-1] == '\t')) (*e)--;
}

int dth_scene_set(dth_scene *s, const char *assignment, char *err, size_t errlen)
{
    if (!s || !assignment) {
        dth__set_err(err, errlen, "invalid arguments to dth_scene_set");
        return DTH_EINVAL;
    }
    const char *eq = strchr(assignment, '=');
    const char *dot = eq ? memchr(assignment, '.', (size_t)(eq - assignment)) : NULL;
    if (!eq || !dot) {
        dth__set_err(err, errlen, "-s %s: expected section.key=value", assignment);
        return DTH_EPARSE;
    }
    const char *sb = assignment, *se = dot, *kb = dot + 1, *ke = eq, *vb = eq + 1,
               *ve = eq + strlen(eq);
    trim(&sb, &se);
    trim(&kb, &ke);
    trim(&vb, &ve);
    if (sb == se || kb == ke) {
        dth__set_err(err, errlen, "-s %s: expected section.key=value", assignment);
        return DTH_EPARSE;
    }
    size_t olen = strlen(assignment) + 4;
    char *origin = dth_calloc(s->alloc, olen, 1);
    entry x = {0};
    int rc = origin ? DTH_OK : DTH_ENOMEM;
    if (!rc) {
        snprintf(origin, olen, "-s %s", assignment);
        rc = make_entry(s->alloc, sb, (size_t)(se - sb), kb, (size_t)(ke - kb), vb, (size_t)(ve - vb),
                        origin, &x);
    }
    dth_free(s->alloc, origin);
    if (!rc) rc = reserve(s, 1);
    if (rc) {
        if (x.section) entry_free(s->alloc, &x);
        dth__set_err(err, errlen, "out of memory");
        return rc;
    }
    put(s, &x);
    return DTH_OK;
}

const char *dth_scene_get(const dth_scene *s, const char *section, const char *key)
{
    long i = find(s, section, key);
    return i < 0 ? NULL : s->e[i].value;
}

const char *dth_scene_origin(const dth_scene *s, const char *section, const char *key)
{
    long i = find(s, section, key);
    return i < 0 ? NULL : s->e[i].origin;
}

size_t dth_scene_count(const dth_scene *s) { return s ? s->n : 0; }

int dth_scene_entry(const dth_scene *s, size_t i, const char **section, const char **key,
                    const char **value, const char **origin)
{
    if (!s || i >= s->n) return DTH_EINVAL;
    if (section) *section = s->e[i].section;
    if (key) *key = s->e[i].key;
    if (value) *value = s->e[i].value;
    if (origin) *origin = s->e[i].origin;
    return DTH_OK;
}

/* ---------------------------------------------------------------- validation */

void dth_run_setup_clear(dth_run_setup *rs)
{
    if (!rs) return;
    dth_regularizer_free(rs->regularizer); /* before the model it serves */
    rs->regularizer = NULL;
    rs->opt.regularizer = NULL;
    dth_model_free(rs->model);
    dth_free(rs->alloc, rs->q0);
    dth_free(rs->alloc, rs->p0);
    dth_free(rs->alloc, rs->out_file);
    rs->model = NULL;
    rs->q0 = rs->p0 = NULL;
    rs->out_file = NULL;
}

/* "ORIGIN: section.key: message" */
static int bad(char *err, size_t len, const entry *e, const char *fmt, ...) __attribute__((format(printf, 4, 5)));
static int bad(char *err, size_t len, const entry *e, const char *fmt, ...)
{
    if (!err || !len) return DTH_EINVAL;
    int k = snprintf(err, len, "%s: %s.%s: ", e->origin, e->section, e->key);
    if (k >= 0 && (size_t)k < len) {
        va_list ap;
        va_start(ap, fmt);
        vsnprintf(err + k, len - (size_t)k, fmt, ap);
        va_end(ap);
    }
    return DTH_EINVAL;
}

/* Whole-string decimal integer in [lo, hi]. */
static int parse_long(const char *v, long lo, long hi, long *out)
{
    while (*v == ' ' || *v == '\t') v++;
    if (!*v) return -1;
    char *end;
    errno = 0;
    long x = strtol(v, &end, 10);
    if (end == v || errno) return -1;
    while (*end == ' ' || *end == '\t') end++;
    if (*end || x < lo || x > hi) return -1;
    *out = x;
    return 0;
}

static size_t count_items(const char *v)
{
    size_t k = 1;
    for (; *v; v++) k += *v == ',';
    return k;
}

/* List of finite doubles into a fresh array. */
static int parse_vec(const dth_allocator *a, const char *v, double **out, size_t *n)
{
    size_t max = count_items(v);
    double *x = dth_calloc(a, max, sizeof *x);
    if (!x) return DTH_ENOMEM;
    if (dth__parse_list(v, x, max, n)) {
        dth_free(a, x);
        return DTH_EINVAL;
    }
    *out = x;
    return DTH_OK;
}

static void list_models(const dth_registry *reg, char *buf, size_t len)
{
    size_t k = 0;
    buf[0] = '\0';
    for (size_t i = 0; i < dth_registry_model_count(reg) && k < len; i++) {
        int w = snprintf(buf + k, len - k, "%s%s", i ? ", " : "", dth_registry_model_at(reg, i)->name);
        if (w < 0) break;
        k += (size_t)w;
    }
}

static void list_params(const dth_model_type *t, char *buf, size_t len)
{
    size_t k = 0;
    snprintf(buf, len, "none");
    for (size_t i = 0; i < t->n_params && k < len; i++) {
        int w = snprintf(buf + k, len - k, "%s%s", i ? ", " : "", t->params[i].key);
        if (w < 0) break;
        k += (size_t)w;
    }
}

/* Does the message mention 'key' (quoted), the way the model helpers name parameters? */
static int names_key(const char *msg, const char *key)
{
    char q[256];
    snprintf(q, sizeof q, "'%s'", key);
    return strstr(msg, q) != NULL;
}

typedef struct setup_ctx {
    const dth_scene *s;
    char *err;
    size_t errlen;
    const entry *q, *p, *t, *wp, *h, *steps, *t_end, *every, *dt, *start, *linsolve;
} setup_ctx;

static int check_initial(setup_ctx *c, dth_run_setup *rs, const entry *e)
{
    const dth_allocator *a = c->s->alloc;
    const char *k = e->key;
    if (strcmp(k, "q") == 0 || strcmp(k, "p") == 0) {
        double **dst = k[0] == 'q' ? &rs->q0 : &rs->p0;
        size_t cnt;
        int rc = parse_vec(a, e->value, dst, &cnt);
        if (rc == DTH_ENOMEM) return rc;
        if (rc) return bad(c->err, c->errlen, e, "'%s' is not a comma-separated list of finite numbers", e->value);
        if (k[0] == 'q') {
            rs->n = cnt;
            c->q = e;
        } else {
            c->p = e; /* its count is checked once q is known */
        }
        return DTH_OK;
    }
    if (strcmp(k, "t") == 0) {
        c->t = e;
        if (dth_parse_double(e->value, &rs->t0)) return bad(c->err, c->errlen, e, "'%s' is not a finite number", e->value);
        return DTH_OK;
    }
    if (strcmp(k, "wp") == 0) {
        c->wp = e;
        rs->opt.has_wp = 1;
        if (dth_parse_double(e->value, &rs->opt.wp)) return bad(c->err, c->errlen, e, "'%s' is not a finite number", e->value);
        return DTH_OK;
    }
    return bad(c->err, c->errlen, e, "unknown key (known in [initial]: q, p, t, wp)");
}

static int check_integrator(setup_ctx *c, dth_run_setup *rs, const entry *e)
{
    const char *k = e->key, *v = e->value;
    long x;
    if (strcmp(k, "method") == 0) {
        if (strcmp(v, "dth") != 0 && !dth_fixed_method_doc(v)) {
            char avail[256] = "dth";
            for (size_t i = 0; i < dth_fixed_method_count(); i++) {
                size_t l = strlen(avail);
                snprintf(avail + l, sizeof avail - l, ", %s", dth_fixed_method_name(i));
            }
            return bad(c->err, c->errlen, e, "unknown method '%s' (available: %s)", v, avail);
        }
        snprintf(rs->method, sizeof rs->method, "%s", v);
    } else if (strcmp(k, "start") == 0) {
        c->start = e;
        if (strcmp(v, "midpoint") == 0) rs->opt.start = DTH_START_MIDPOINT;
        else if (strcmp(v, "vertex") == 0) rs->opt.start = DTH_START_VERTEX;
        else return bad(c->err, c->errlen, e, "'%s' is not one of midpoint, vertex", v);
    } else if (strcmp(k, "h") == 0) {
        c->h = e;
        if (dth_parse_double(v, &rs->opt.h)) return bad(c->err, c->errlen, e, "'%s' is not a finite number", v);
        if (rs->opt.h == 0) return bad(c->err, c->errlen, e, "the step must be nonzero (its sign sets the direction of time)");
    } else if (strcmp(k, "steps") == 0) {
        c->steps = e;
        if (parse_long(v, 0, LONG_MAX, &rs->steps)) return bad(c->err, c->errlen, e, "'%s' is not an integer >= 0", v);
    } else if (strcmp(k, "t_end") == 0) {
        c->t_end = e;
        if (dth_parse_double(v, &rs->t_end)) return bad(c->err, c->errlen, e, "'%s' is not a finite number", v);
    } else if (strcmp(k, "max_iter") == 0) {
        if (parse_long(v, 1, 100000, &x)) return bad(c->err, c->errlen, e, "'%s' is not an integer in 1..100000", v);
        rs->opt.max_iter = (int)x;
    } else if (strcmp(k, "K") == 0) {
        if (dth_parse_double(v, &rs->opt.K) || rs->opt.K < 0)
            return bad(c->err, c->errlen, e, "'%s' is not a finite number >= 0 (0: estimate K locally)", v);
    } else if (strcmp(k, "branch_check") == 0) {
        /* no: take whatever root Newton converges to, as raw DTH does (for comparison only) */
        if (!strcmp(v, "yes") || !strcmp(v, "true") || !strcmp(v, "1")) rs->opt.branch_check = 1;
        else if (!strcmp(v, "no") || !strcmp(v, "false") || !strcmp(v, "0")) rs->opt.branch_check = 0;
        else return bad(c->err, c->errlen, e, "'%s' is not one of yes, no", v);
    } else if (strcmp(k, "linsolve") == 0) {
        c->linsolve = e;
        dth_linsolve ls;
        for (ls = DTH_LINSOLVE_AUTO; dth_linsolve_name(ls); ls++)
            if (strcmp(v, dth_linsolve_name(ls)) == 0) break;
        if (!dth_linsolve_name(ls))
            return bad(c->err, c->errlen, e, "'%s' is not one of auto, dense, small, small-lu, banded, banded-lu", v);
        rs->opt.linsolve = ls;
    } else {
        return bad(c->err, c->errlen, e,
                   "unknown key (known in [integrator]: method, start, h, steps, t_end, max_iter, K, branch_check, linsolve)");
    }
    return DTH_OK;
}

static int check_output(setup_ctx *c, dth_run_setup *rs, const entry *e)
{
    const char *k = e->key, *v = e->value;
    if (strcmp(k, "file") == 0) {
        if (!v[0]) return bad(c->err, c->errlen, e, "empty file name (leave the key out to write to stdout)");
        dth_free(c->s->alloc, rs->out_file);
        rs->out_file = dup_s(c->s->alloc, v);
        if (!rs->out_file) return DTH_ENOMEM;
    } else if (strcmp(k, "every") == 0) {
        c->every = e;
        if (parse_long(v, 1, LONG_MAX, &rs->every)) return bad(c->err, c->errlen, e, "'%s' is not an integer >= 1", v);
    } else if (strcmp(k, "dt") == 0) {
        c->dt = e;
        if (dth_parse_double(v, &rs->dt) || rs->dt < 0)
            return bad(c->err, c->errlen, e, "'%s' is not a finite number >= 0 (0: write vertices)", v);
    } else if (strcmp(k, "diagnostics") == 0) {
        if (!strcmp(v, "yes") || !strcmp(v, "true") || !strcmp(v, "1")) rs->diagnostics = 1;
        else if (!strcmp(v, "no") || !strcmp(v, "false") || !strcmp(v, "0")) rs->diagnostics = 0;
        else return bad(c->err, c->errlen, e, "'%s' is not yes or no", v);
    } else {
        return bad(c->err, c->errlen, e, "unknown key (known in [output]: file, every, dt, diagnostics)");
    }
    return DTH_OK;
}

/* Every key on its own, in the order the keys were first set; collects the model's keys. */
static int check_keys(setup_ctx *c, const dth_model_type *type, dth_run_setup *rs, dth_kv *kv,
                      const entry **kv_entry, size_t *nkv)
{
    const dth_scene *s = c->s;
    char buf[256];
    for (size_t i = 0; i < s->n; i++) {
        const entry *e = &s->e[i];
        const char *sec = e->section, *k = e->key;
        int rc = DTH_OK;
        if (strcmp(sec, "model") == 0) {
            if (strcmp(k, "name") == 0) continue;
            if (!dth__model_accepts_key(type, k)) {
                list_params(type, buf, sizeof buf);
                return bad(c->err, c->errlen, e, "model '%s' has no parameter '%s' (its parameters: %s)",
                           type->name, k, buf);
            }
            kv[*nkv] = (dth_kv){k, e->value};
            kv_entry[(*nkv)++] = e;
        } else if (strcmp(sec, "initial") == 0) {
            rc = check_initial(c, rs, e);
        } else if (strcmp(sec, "integrator") == 0) {
            rc = check_integrator(c, rs, e);
        } else if (strcmp(sec, "regularize") == 0) {
            continue; /* checked by setup_regularizer once the model exists */
        } else if (strcmp(sec, "output") == 0) {
            rc = check_output(c, rs, e);
        } else if (!sec[0]) {
            dth__set_err(c->err, c->errlen, "%s: key '%s' is outside any [section]", e->origin, k);
            return DTH_EINVAL;
        } else {
            dth__set_err(c->err, c->errlen, "%s: unknown section [%s] (known: model, initial, integrator, regularize, output)",
                    e->origin, sec);
            return DTH_EINVAL;
        }
        if (rc == DTH_ENOMEM) dth__set_err(c->err, c->errlen, "out of memory");
        if (rc) return rc;
    }
    return DTH_OK;
}

static int is_override(const entry *e) { return strncmp(e->origin, "-s ", 3) == 0; }

/* Checks that involve several keys. */
static int check_cross(setup_ctx *c, dth_run_setup *rs)
{
    const char *src = c->s->source ? c->s->source : "scene";
    if (!c->q || !c->p) {
        dth__set_err(c->err, c->errlen, "%s: missing [initial] %s= (comma-separated initial values)", src, c->q ? "p" : "q");
        return DTH_EINVAL;
    }
    size_t np = count_items(c->p->value);
    if (np != rs->n)
        return bad(c->err, c->errlen, c->p, "%zu values, but initial.q has %zu (%s)", np, rs->n, c->q->origin);
    if (!c->h) {
        dth__set_err(c->err, c->errlen, "%s: missing [integrator] h= (the first step; its sign sets the direction)", src);
        return DTH_EINVAL;
    }
    if (c->steps && c->t_end && is_override(c->steps) != is_override(c->t_end)) {
        /* an override of the run length replaces the file's, whichever key the file used */
        if (is_override(c->steps)) c->t_end = NULL;
        else c->steps = NULL;
    }
    if (c->steps && c->t_end) {
        const entry *later = c->steps > c->t_end ? c->steps : c->t_end, *first = later == c->steps ? c->t_end : c->steps;
        return bad(c->err, c->errlen, later, "give either steps= or t_end=, not both (%s.%s set at %s)",
                   first->section, first->key, first->origin);
    }
    if (!c->steps && !c->t_end) {
        dth__set_err(c->err, c->errlen, "%s: missing [integrator] steps= or t_end= (how long to run)", src);
        return DTH_EINVAL;
    }
    rs->has_t_end = c->t_end != NULL;
    if (c->t_end && (rs->t_end - rs->t0) * rs->opt.h < 0)
        return bad(c->err, c->errlen, c->t_end, "t_end = %.17g lies behind t = %.17g for h = %.17g (the sign of h is the direction of time)",
                   rs->t_end, rs->t0, rs->opt.h);
    if (c->wp && rs->opt.start != DTH_START_VERTEX)
        return bad(c->err, c->errlen, c->wp, "an explicit wp applies only with [integrator] start=vertex");
    if (c->every && c->dt && rs->dt > 0 && rs->every != 1)
        return bad(c->err, c->errlen, c->dt, "dt > 0 resamples at uniform times and cannot be combined with every= (%s)",
                   c->every->origin);
    return DTH_OK;
}

/* [regularize]: method= names a registered regularizer; every other key is its parameter.
 * The instance is made for the model (paper, section 7; docs/regularization.md). */
static int setup_regularizer(const dth_scene *s, const dth_registry *reg, dth_run_setup *rs, char *err,
                             size_t errlen)
{
    const entry *em = NULL;
    size_t np = 0;
    for (size_t i = 0; i < s->n; i++)
        if (!strcmp(s->e[i].section, "regularize")) {
            if (!strcmp(s->e[i].key, "method")) em = &s->e[i];
            else np++;
        }
    const dth_regularizer_type *t = dth_registry_find_regularizer(reg, em ? em->value : "none");
    if (!t) {
        char names[256];
        size_t len = 0;
        names[0] = '\0';
        for (size_t i = 0; i < dth_registry_regularizer_count(reg) && len < sizeof names; i++)
            len += (size_t)snprintf(names + len, sizeof names - len, "%s%s", i ? ", " : "",
                                    dth_registry_regularizer_at(reg, i)->name);
        return bad(err, errlen, em, "unknown regularizer '%s' (available: %s)", em->value, names);
    }
    snprintf(rs->regularize, sizeof rs->regularize, "%s", t->name);
    if (!strcmp(t->name, "none")) {
        for (size_t i = 0; i < s->n; i++)
            if (!strcmp(s->e[i].section, "regularize") && strcmp(s->e[i].key, "method"))
                return bad(err, errlen, &s->e[i], "unknown key (regularizer 'none' takes no parameters)");
        return DTH_OK;
    }
    dth_kv *kv = dth_calloc(s->alloc, np + 1, sizeof *kv);
    const entry **ke = dth_calloc(s->alloc, np + 1, sizeof *ke);
    int rc = kv && ke ? DTH_OK : DTH_ENOMEM;
    size_t n = 0;
    for (size_t i = 0; !rc && i < s->n; i++)
        if (!strcmp(s->e[i].section, "regularize") && strcmp(s->e[i].key, "method")) {
            kv[n] = (dth_kv){s->e[i].key, s->e[i].value};
            ke[n++] = &s->e[i];
        }
    if (!rc) {
        char rerr[256] = "";
        rc = dth_regularizer_new(t, kv, n, rs->model, s->alloc, &rs->regularizer, rerr, sizeof rerr);
        if (rc == DTH_ENOMEM) dth__set_err(err, errlen, "out of memory");
        else if (rc) {
            const entry *at = em;
            for (size_t i = 0; i < n; i++)
                if (names_key(rerr, kv[i].key)) at = ke[i];
            rc = bad(err, errlen, at, "%s", rerr);
        } else {
            rs->opt.regularizer = rs->regularizer;
        }
    } else {
        dth__set_err(err, errlen, "out of memory");
    }
    dth_free(s->alloc, kv);
    dth_free(s->alloc, ke);
    return rc;
}

int dth_scene_setup(const dth_scene *s, const dth_registry *reg, dth_run_setup *out, char *err, size_t errlen)
{
    if (!s || !reg || !out) {
        dth__set_err(err, errlen, "invalid arguments to dth_scene_setup");
        return DTH_EINVAL;
    }
    const char *src = s->source ? s->source : "scene";
    char names[512];
    long in = find(s, "model", "name");
    if (in < 0) {
        list_models(reg, names, sizeof names);
        dth__set_err(err, errlen, "%s: missing [model] name= (known models: %s)", src, names);
        return DTH_EINVAL;
    }
    const entry *ename = &s->e[in];
    const dth_model_type *type = dth_registry_find_model(reg, ename->value);
    if (!type) {
        list_models(reg, names, sizeof names);
        return bad(err, errlen, ename, "unknown model '%s' (known models: %s)", ename->value, names);
    }

    dth_run_setup rs;
    memset(&rs, 0, sizeof rs);
    rs.alloc = s->alloc;
    dth_options_default(&rs.opt);
    rs.opt.alloc = s->alloc;
    snprintf(rs.method, sizeof rs.method, "dth");
    snprintf(rs.regularize, sizeof rs.regularize, "none");
    rs.every = 1;

    setup_ctx c = {.s = s, .err = err, .errlen = errlen};
    dth_kv *kv = dth_calloc(s->alloc, s->n + 1, sizeof *kv);
    const entry **kv_entry = dth_calloc(s->alloc, s->n + 1, sizeof *kv_entry);
    size_t nkv = 0;
    int rc = kv && kv_entry ? DTH_OK : DTH_ENOMEM;
    if (rc) dth__set_err(err, errlen, "out of memory");
    if (!rc) rc = check_keys(&c, type, &rs, kv, kv_entry, &nkv);
    if (!rc) rc = check_cross(&c, &rs);
    if (!rc) {
        char merr[256];
        rc = dth_model_new(type, kv, nkv, rs.n, s->alloc, &rs.model, merr, sizeof merr);
        if (rc == DTH_ENOMEM) {
            dth__set_err(err, errlen, "out of memory");
        } else if (rc) {
            /* name the line of the parameter the model complains about; else the q values */
            const entry *at = c.q;
            for (size_t i = 0; i < nkv; i++)
                if (names_key(merr, kv[i].key)) at = kv_entry[i];
            rc = bad(err, errlen, at, "model '%s': %s", type->name, merr);
        } else if (dth_model_dof(rs.model) != rs.n) {
            rc = bad(err, errlen, c.q, "model '%s' has %zu degrees of freedom, but %zu q values are given",
                     type->name, dth_model_dof(rs.model), rs.n);
        } else if ((rs.opt.linsolve == DTH_LINSOLVE_BANDED || rs.opt.linsolve == DTH_LINSOLVE_BANDED_LU) &&
                   !dth__model_banded(rs.model)) {
            rc = bad(err, errlen, c.linsolve, "'%s' needs a model with a banded Hessian (model '%s' has a dense one)",
                     dth_linsolve_name(rs.opt.linsolve), type->name);
        }
    }
    dth_free(s->alloc, kv);
    dth_free(s->alloc, kv_entry);
    if (!rc) rc = setup_regularizer(s, reg, &rs, err, errlen);
    if (rc) {
        dth_run_setup_clear(&rs);
        return rc < 0 ? rc : DTH_EINVAL;
    }
    *out = rs;
    return DTH_OK;
}
