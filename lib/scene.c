/* SPDX-License-Identifier: MIT */
/*
 * Scene files: an INI key store that remembers where each value came from (FILE:LINE or the
 * -s override), and its validation into a run setup (model, initial state, DTH step options of
 * the paper's section 2 and the start modes, output). Parsing uses inih; nothing is printed.
 */
#include <ctype.h>
#include <errno.h>
#include <ini.h>
#include <limits.h>
#include <math.h>
#include <stdarg.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include "dth/scene.h"
#include "dth/methods.h"
#include "compose.h"
#include "dth_internal.h"

typedef struct entry {
    char *section, *key, *value, *origin;
    size_t vlen, vcap; /* length of value and its allocation (continuation lines grow it) */
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
    e->vlen = x->vlen;
    e->vcap = x->vcap;
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
    x->vlen = vl;
    x->vcap = vl + 1;
    x->origin = dup_s(a, origin);
    if (x->section && x->key && x->value && x->origin) return DTH_OK;
    entry_free(a, x);
    return DTH_ENOMEM;
}

/* ---------------------------------------------------------------- loading */

/* The longest line a scene file may hold (inih reads lines into 200 bytes: 197 characters, CR,
 * LF, NUL), and the longest section or key name inih keeps whole (its buffers hold 49). */
enum { LINE_MAX_CHARS = 197, NAME_MAX_CHARS = 49 };

typedef struct load_ctx {
    dth_scene *tmp;
    FILE *f;
    const char *path;
    int lineno;     /* lines read so far: the line the handler is called for */
    int too_long;   /* a line did not fit inih's buffer */
    int nul;        /* a line holds a NUL byte (it would hide the rest of the line) */
    const char *line; /* inih's line buffer and its size (what reader() was given) */
    int linecap;
    int nomem;
    long last;      /* the entry the last handler call stored or extended (-1: none) */
    const char *why; /* a line the loader refuses although inih reads it: what is wrong */
    int why_line;
} load_ctx;

/* One line for inih: counts lines and refuses lines longer than LINE_MAX_CHARS (inih would split
 * them) and lines with a NUL byte (fgets would hide the rest of the line behind it). */
static char *reader(char *str, int num, void *stream)
{
    load_ctx *c = stream;
    FILE *f = c->f;
    int len = 0, ch = EOF;
    c->line = str;
    c->linecap = num;
    while (len + 1 < num && (ch = getc(f)) != EOF) {
        if (ch == '\0') {
            c->lineno++;
            c->nul = 1;
            return NULL;
        }
        str[len++] = (char)ch;
        if (ch == '\n') break;
    }
    if (len == 0) return NULL;
    str[len] = '\0';
    c->lineno++;
    /* inih keeps 49 characters of a section name and drops the rest: refuse longer ones (an
     * indented line continues a value) */
    const char *close = str[0] == '[' ? strchr(str, ']') : NULL;
    if (close && close - str - 1 > NAME_MAX_CHARS && !c->why) {
        c->why = "a section name longer than 49 characters";
        c->why_line = c->lineno;
    }
    int vis = len; /* without the line end */
    if (vis && str[vis - 1] == '\n') vis--;
    if (vis && str[vis - 1] == '\r') vis--;
    if (vis > LINE_MAX_CHARS || (len + 1 == num && str[len - 1] != '\n' && (ch = getc(f)) != EOF)) {
        c->too_long = 1;
        return NULL;
    }
    return str;
}

static int handler(void *user, const char *section, const char *name, const char *value)
{
    load_ctx *c = user;
    long i = -1;
    /* inih passes a key=value line's name from its line buffer, and a continuation line's (the
     * previous key's) from a buffer of its own: the exact test of what inih decided */
    uintptr_t np = (uintptr_t)name, lp = (uintptr_t)c->line;
    if (!(np >= lp && np < lp + (uintptr_t)c->linecap)) {
        /* inih calls back with the previous key: usually the entry stored last */
        if (c->last >= 0 && !strcmp(c->tmp->e[c->last].section, section) && !strcmp(c->tmp->e[c->last].key, name))
            i = c->last;
        else
            i = find(c->tmp, section, name);
    }
    if (i >= 0) {
        /* A continuation line extends the key's value as more list items (long q= and p=
         * lists), keeping the origin of the key's first line. The value grows geometrically,
         * so a list over L lines loads in O(L) (a copy per line made it O(L^2)). */
        entry *e = &c->tmp->e[i];
        size_t ol = e->vlen, vl = 0;
        /* a ';' after a blank starts a comment here too, as on the key's own line (inih 55 keeps it
         * in continuation lines, later versions drop it): one rule, and values never hold it */
        for (; value[vl]; vl++)
            if (value[vl] == ';' && vl > 0 && isspace((unsigned char)value[vl - 1])) break;
        while (vl > 0 && isspace((unsigned char)value[vl - 1])) vl--;
        while (ol && (e->value[ol - 1] == ',' || e->value[ol - 1] == ' ')) ol--;
        size_t need = ol + vl + 2;
        if (need > e->vcap) {
            size_t cap = e->vcap > need / 2 ? 2 * e->vcap : need;
            char *v = dth_calloc(c->tmp->alloc, cap, 1);
            if (!v) {
                c->nomem = 1;
                return 0;
            }
            memcpy(v, e->value, ol);
            dth_free(c->tmp->alloc, e->value);
            e->value = v;
            e->vcap = cap;
        }
        e->value[ol] = ',';
        memcpy(e->value + ol + 1, value, vl);
        e->value[ol + 1 + vl] = '\0';
        e->vlen = ol + 1 + vl;
        c->last = i;
        return 1;
    }
    /* inih passes an empty key ("= value") and keeps only 49 characters of a key for its
     * continuation lines: refuse both, so that every loaded key can be written back (dth_scene_text) */
    if (!name[0] || strlen(name) > NAME_MAX_CHARS) {
        if (!c->why) {
            c->why = name[0] ? "a key longer than 49 characters" : "a value without a key";
            c->why_line = c->lineno;
        }
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
    c->last = find(c->tmp, section, name);
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
    static const char empty[1] = "\n"; /* fmemopen needs a nonempty buffer: an empty line */
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
    load_ctx c = {.f = f, .path = path, .last = -1};
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
        dth__set_err(err, errlen, "%s:%d: line longer than %d characters", path, c.lineno, LINE_MAX_CHARS);
        rc = DTH_EPARSE;
    } else if (c.nul) {
        dth__set_err(err, errlen, "%s:%d: a NUL byte in the line (not a text file?)", path, c.lineno);
        rc = DTH_EPARSE;
    } else if (c.why && (line == 0 || c.why_line < line)) {
        dth__set_err(err, errlen, "%s:%d: %s", path, c.why_line, c.why);
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

/* ---------------------------------------------------------------- writing */

/* inih's notion of blank (its lskip, rstrip and the blank before an inline ';') */
static int blank(char ch) { return isspace((unsigned char)ch) != 0; }


/*
 * How the writer lays out `key=value` over lines (dth_scene_text): the first line is key=, and
 * the value is split at commas onto continuation lines " item,item" where the loader puts it back
 * exactly. inih drops a line's leading and trailing blanks (isspace), reads a piece starting with
 * ';' or '#' as a comment and cuts at a blank followed by ';'; the loader then joins a continuation
 * piece B to the value so far A as strip(A) "," B, strip removing trailing commas and spaces. So
 * the value may be split at its comma at index c when the next piece v[c+1..] is nonempty and
 * starts with none of blank, ';', '#', and the piece before it is empty only at the start (c == 0)
 * and does not end in ',' or ' '. The split comma is not written (the loader puts it back), unless
 * v[c-1] is another blank (a tab, a form feed), which inih would drop from the line end: then the
 * comma ends the line and the loader strips it. Greedy (each line as long as it can be) finds a
 * layout whenever one exists, and the lines of any file the loader read are one (they are at least
 * as long). Writes into t (if not NULL) and returns the number of characters, or 0 if the value
 * cannot be laid out.
 */
static size_t layout(const char *key, const char *v, char *t)
{
    size_t kl = strlen(key), vl = strlen(v), n = 0, pos = 0, room = LINE_MAX_CHARS - kl - 1;
    if (kl + 1 > LINE_MAX_CHARS) return 0;
    if (t) {
        memcpy(t, key, kl);
        t[kl] = '=';
    }
    n = kl + 1;
    for (;;) {
        if (vl - pos <= room) { /* the rest fits */
            if (t) memcpy(t + n, v + pos, vl - pos);
            n += vl - pos;
            break;
        }
        size_t best = 0, keep = 0; /* the furthest allowed split comma within reach; its line's length */
        for (size_t c = pos; c < vl && c - pos <= room; c++) {
            if (v[c] != ',') continue;
            if (c == pos ? pos > 0 : (v[c - 1] == ',' || v[c - 1] == ' ')) continue; /* stripped by the loader */
            char nx = v[c + 1];
            if (!nx || blank(nx) || nx == ';' || nx == '#') continue; /* dropped, or read as a comment */
            size_t len = c - pos + (c > pos && blank(v[c - 1])); /* with the comma after a tab or so */
            if (len > room) continue;
            best = c + 1;
            keep = len;
        }
        if (!best || kl > NAME_MAX_CHARS) return 0; /* inih keeps 49 characters of a continued key */
        if (t) {
            memcpy(t + n, v + pos, keep);
            t[n + keep] = '\n';
            t[n + keep + 1] = ' ';
        }
        n += keep + 2;
        pos = best;
        room = LINE_MAX_CHARS - 1;
    }
    if (t) t[n] = '\n';
    return n + 1;
}

/* Why a scene file cannot hold this entry (NULL: it can). Section and key as stored after
 * trimming; the value as well. */
static const char *unwritable(const char *sec, const char *key, const char *val)
{
    const char *parts[] = {sec, key, val};
    for (int i = 0; i < 3; i++)
        for (const char *p = parts[i]; *p; p++) {
            if ((unsigned char)*p < 0x20 && *p != '\t') return "a control character";
            if (*p == 0x7f) return "a control character";
            if (*p == ';' && p > parts[i] && blank(p[-1])) return "';' after a blank (a comment)";
        }
    if (!sec[0] || strlen(sec) > NAME_MAX_CHARS) return "a section name of 1 to 49 characters";
    if (strchr(sec, ']')) return "']' in the section name";
    if (!key[0] || strlen(key) > NAME_MAX_CHARS) return "a key of 1 to 49 characters";
    if (strpbrk(key, "=:")) return "'=' or ':' in the key";
    if (key[0] == '#' || key[0] == '[' || key[0] == ';') return "a key starting with '#', '[' or ';'";
    if (!layout(key, val, NULL)) return "a value that does not fit scene lines (197 characters between commas)";
    return NULL;
}

int dth_scene_text(const dth_scene *s, int (*keep)(void *ctx, const char *section, const char *key), void *ctx,
                   char **text, size_t *len)
{
    if (text) *text = NULL;
    if (len) *len = 0;
    if (!s || !text || !len) return DTH_EINVAL;
    /* pass 1 sizes, pass 2 writes; entries grouped by section in order of first appearance */
    char *t = NULL;
    size_t n = 0;
    for (int pass = 0; pass < 2; pass++) {
        n = 0;
        for (size_t i = 0; i < s->n; i++) {
            const char *sec = s->e[i].section;
            int first = 1;
            for (size_t j = 0; j < i && first; j++)
                if (!strcmp(s->e[j].section, sec)) first = 0;
            if (!first) continue;
            int header = 0;
            for (size_t j = i; j < s->n; j++) {
                const entry *e = &s->e[j];
                if (strcmp(e->section, sec) || (keep && !keep(ctx, e->section, e->key))) continue;
                if (!header) {
                    size_t sl = strlen(sec);
                    if (t) {
                        t[n] = '[';
                        memcpy(t + n + 1, sec, sl);
                        memcpy(t + n + 1 + sl, "]\n", 2);
                    }
                    n += sl + 3;
                    header = 1;
                }
                size_t l = layout(e->key, e->value, t ? t + n : NULL);
                if (!l) {
                    dth_free(s->alloc, t);
                    return DTH_EINVAL; /* cannot happen: every entry was checked when stored */
                }
                n += l;
            }
        }
        if (pass == 0) {
            t = dth_calloc(s->alloc, n + 1, 1);
            if (!t) return DTH_ENOMEM;
        }
    }
    t[n] = '\0';
    *text = t;
    *len = n;
    return DTH_OK;
}

static void trim(const char **b, const char **e)
{
    while (*b < *e && (**b == ' ' || **b == '\t')) (*b)++;
    while (*e > *b && ((*e)[-1] == ' ' || (*e)[-1] == '\t')) (*e)--;
}

/* An override in a message: its first 80 characters, and "..." if there are more (printf "%.*s%s"). */
#define AS_CUT(a) strlen(a) > 80 ? 80 : (int)strlen(a), (a), strlen(a) > 80 ? "..." : ""

int dth_scene_set(dth_scene *s, const char *assignment, char *err, size_t errlen)
{
    if (!s || !assignment) {
        dth__set_err(err, errlen, "invalid arguments to dth_scene_set");
        return DTH_EINVAL;
    }
    const char *eq = strchr(assignment, '=');
    const char *dot = eq ? memchr(assignment, '.', (size_t)(eq - assignment)) : NULL;
    if (!eq || !dot) {
        dth__set_err(err, errlen, "-s %.*s%s: expected section.key=value", AS_CUT(assignment));
        return DTH_EPARSE;
    }
    const char *sb = assignment, *se = dot, *kb = dot + 1, *ke = eq, *vb = eq + 1,
               *ve = eq + strlen(eq);
    trim(&sb, &se);
    trim(&kb, &ke);
    trim(&vb, &ve);
    if (sb == se || kb == ke) {
        dth__set_err(err, errlen, "-s %.*s%s: expected section.key=value", AS_CUT(assignment));
        return DTH_EPARSE;
    }
    /* only what a scene file could hold (a checkpoint saves the scene as a file) */
    char sec[NAME_MAX_CHARS + 2] = "", key[NAME_MAX_CHARS + 2] = "";
    const char *why = NULL;
    if ((size_t)(se - sb) > NAME_MAX_CHARS || (size_t)(ke - kb) > NAME_MAX_CHARS) {
        why = "a section name and key of 1 to 49 characters";
    } else {
        memcpy(sec, sb, (size_t)(se - sb));
        memcpy(key, kb, (size_t)(ke - kb));
        char *val = dup_n(s->alloc, vb, (size_t)(ve - vb));
        if (!val) {
            dth__set_err(err, errlen, "out of memory");
            return DTH_ENOMEM;
        }
        why = unwritable(sec, key, val);
        dth_free(s->alloc, val);
    }
    if (why) {
        dth__set_err(err, errlen, "-s %.*s%s: a scene file cannot hold this (%s)", AS_CUT(assignment), why);
        return DTH_EPARSE;
    }
    /* the override names itself in messages, cut after 80 characters */
    size_t olen = 80 + 8;
    char *origin = dth_calloc(s->alloc, olen, 1);
    entry x = {0};
    int rc = origin ? DTH_OK : DTH_ENOMEM;
    if (!rc) {
        snprintf(origin, olen, "-s %.*s%s", AS_CUT(assignment));
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
    dth_free(rs->alloc, rs->events);
    dth_free(rs->alloc, rs->event_specs);
    dth_free(rs->alloc, (void *)rs->event_names);
    dth_free(rs->alloc, rs->event_dofs);
    dth_free(rs->alloc, rs->events_file);
    rs->model = NULL;
    rs->q0 = rs->p0 = NULL;
    rs->out_file = NULL;
    rs->events = NULL;
    rs->event_specs = NULL;
    rs->event_names = NULL;
    rs->event_dofs = NULL;
    rs->events_file = NULL;
    rs->nevents = 0;
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

/* A count: a whole-string decimal integer, or a number with an integer value ("1e6"), in
 * [lo, hi]. 0, or PARSE_NOT_INT (not an integer), PARSE_LOW / PARSE_HIGH (an integer below lo,
 * above hi). */
enum { PARSE_NOT_INT = -1, PARSE_LOW = -2, PARSE_HIGH = -3 };
static int parse_long(const char *v, long lo, long hi, long *out)
{
    while (*v == ' ' || *v == '\t') v++;
    if (!*v) return PARSE_NOT_INT;
    char *end;
    errno = 0;
    long x = strtol(v, &end, 10);
    const char *rest = end;
    while (*rest == ' ' || *rest == '\t') rest++;
    if (end == v || *rest) {
        /* not plain decimal: a number whose value is an integer (1e6, 2.0) counts too */
        double d;
        if (dth_parse_double(v, &d) || d != floor(d)) return PARSE_NOT_INT;
        if (d < (double)lo || !(d > -0x1p63)) return PARSE_LOW;
        if (d > (double)hi || !(d < 0x1p63)) return PARSE_HIGH;
        x = (long)d;
    } else if (errno == ERANGE) {
        return x < 0 ? PARSE_LOW : PARSE_HIGH;
    }
    if (x < lo) return PARSE_LOW;
    if (x > hi) return PARSE_HIGH;
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
    const entry *q, *p, *t, *wp, *h, *steps, *t_end, *every, *dt, *start, *points, *method, *linsolve, *reversible;
    const entry *order, *table, *band_time; /* [integrator] of order 4 (compose.c) */
    /* [events] */
    const entry *section, *section_value, *section_dir, *section_term, *time, *time_term, *dist, *dist_dofs,
        *dist_dir, *dist_term;
    int points_kind; /* -1 auto, else dth_points */
} setup_ctx;

/* The message for a count that parse_long refused. */
static int bad_count(setup_ctx *c, const entry *e, int why, long lo, long hi)
{
    if (why == PARSE_HIGH)
        return bad(c->err, c->errlen, e, "'%s' is too large (an integer from %ld to %ld)", e->value, lo, hi);
    if (hi < LONG_MAX) return bad(c->err, c->errlen, e, "'%s' is not an integer in %ld..%ld", e->value, lo, hi);
    return bad(c->err, c->errlen, e, "'%s' is not an integer >= %ld", e->value, lo);
}

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

/* yes/true/1 or no/false/0; -1 (out untouched) otherwise */
static int parse_bool(const char *v, int *out)
{
    if (!strcmp(v, "yes") || !strcmp(v, "true") || !strcmp(v, "1")) *out = 1;
    else if (!strcmp(v, "no") || !strcmp(v, "false") || !strcmp(v, "0")) *out = 0;
    else return -1;
    return 0;
}

static int check_integrator(setup_ctx *c, dth_run_setup *rs, const entry *e)
{
    const char *k = e->key, *v = e->value;
    long x;
    if (strcmp(k, "method") == 0) {
        c->method = e;
        size_t i = 0;
        while (dth_method_name(i) && strcmp(v, dth_method_name(i)) != 0) i++;
        if (!dth_method_name(i)) {
            char avail[256] = "";
            for (size_t j = 0; dth_method_name(j); j++) {
                size_t l = strlen(avail);
                snprintf(avail + l, sizeof avail - l, "%s%s", j ? ", " : "", dth_method_name(j));
            }
            return bad(c->err, c->errlen, e, "unknown method '%s' (available: %s)", v, avail);
        }
        snprintf(rs->method, sizeof rs->method, "%s", v);
        rs->opt.method = dth_method_name(i); /* static storage: the setup may be copied */
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
        int pr = parse_long(v, 0, LONG_MAX, &rs->steps);
        if (pr) return bad_count(c, e, pr, 0, LONG_MAX);
    } else if (strcmp(k, "t_end") == 0) {
        c->t_end = e;
        if (dth_parse_double(v, &rs->t_end)) return bad(c->err, c->errlen, e, "'%s' is not a finite number", v);
    } else if (strcmp(k, "max_iter") == 0) {
        int pr = parse_long(v, 1, 100000, &x);
        if (pr) return bad_count(c, e, pr, 1, 100000);
        rs->opt.max_iter = (int)x;
    } else if (strcmp(k, "K") == 0) {
        if (dth_parse_double(v, &rs->opt.K) || rs->opt.K < 0)
            return bad(c->err, c->errlen, e, "'%s' is not a finite number >= 0 (0: estimate K locally)", v);
    } else if (strcmp(k, "branch_check") == 0) {
        /* no: take whatever root Newton converges to, as raw DTH does (for comparison only) */
        if (parse_bool(v, &rs->opt.branch_check)) return bad(c->err, c->errlen, e, "'%s' is not one of yes, no", v);
    } else if (strcmp(k, "reversible") == 0) {
        /* yes: the reversible finish (dth_options.compensate = 2); no: the compensated constraint */
        c->reversible = e;
        int rv;
        if (parse_bool(v, &rv)) return bad(c->err, c->errlen, e, "'%s' is not one of yes, no", v);
        rs->opt.finish = rv ? DTH_FINISH_REVERSIBLE : DTH_FINISH_COMPENSATED;
    } else if (strcmp(k, "order") == 0) {
        /* 2 or 4 (checked with the method once the model exists: dth_options_check's message) */
        c->order = e;
        int pr = parse_long(v, 1, 1000, &x);
        if (pr) return bad_count(c, e, pr, 1, 1000);
        rs->opt.order = (int)x;
    } else if (strcmp(k, "table") == 0) {
        /* order 4's coefficient table: its name in static storage (the setup may be copied) */
        c->table = e;
        const dth__table *t = dth__table_find(v);
        if (!t) return bad(c->err, c->errlen, e, "'%s' is not one of suzuki4, yoshida4, yoshida6a, kahanli6, kahanli8", v);
        rs->opt.table = t->name;
    } else if (strcmp(k, "band_time") == 0) {
        c->band_time = e;
        if (dth_parse_double(v, &rs->opt.band_time) || rs->opt.band_time < 0)
            return bad(c->err, c->errlen, e, "'%s' is not a finite time >= 0 (0: the default crossing rule)", v);
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
                   "unknown key (known in [integrator]: method, start, h, steps, t_end, max_iter, K, branch_check, reversible, linsolve, order, table, band_time)");
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
    } else if (strcmp(k, "points") == 0) {
        c->points = e;
        if (!strcmp(v, "auto")) c->points_kind = -1;
        else if (!strcmp(v, "vertices")) c->points_kind = DTH_POINTS_VERTICES;
        else if (!strcmp(v, "midpoints")) c->points_kind = DTH_POINTS_MIDPOINTS;
        else return bad(c->err, c->errlen, e, "'%s' is not one of auto, vertices, midpoints", v);
    } else if (strcmp(k, "every") == 0) {
        c->every = e;
        int pr = parse_long(v, 1, LONG_MAX, &rs->every);
        if (pr) return bad_count(c, e, pr, 1, LONG_MAX);
    } else if (strcmp(k, "dt") == 0) {
        c->dt = e;
        if (dth_parse_double(v, &rs->dt) || rs->dt < 0)
            return bad(c->err, c->errlen, e, "'%s' is not a finite number >= 0 (0: write vertices)", v);
    } else if (strcmp(k, "diagnostics") == 0) {
        if (parse_bool(v, &rs->diagnostics)) return bad(c->err, c->errlen, e, "'%s' is not yes or no", v);
    } else {
        return bad(c->err, c->errlen, e, "unknown key (known in [output]: file, points, every, dt, diagnostics)");
    }
    return DTH_OK;
}

static int parse_direction(const char *v, int *out)
{
    if (!strcmp(v, "up")) *out = 1;
    else if (!strcmp(v, "down")) *out = -1;
    else if (!strcmp(v, "both")) *out = 0;
    else return -1;
    return 0;
}

/* [events]: each key on its own; the events are built once n is known (build_events). */
static int check_events(setup_ctx *c, dth_run_setup *rs, const entry *e)
{
    const char *k = e->key, *v = e->value;
    int b;
    double x;
    if (!strcmp(k, "file")) {
        if (!v[0]) return bad(c->err, c->errlen, e, "empty file name");
        dth_free(c->s->alloc, rs->events_file);
        rs->events_file = dup_s(c->s->alloc, v);
        return rs->events_file ? DTH_OK : DTH_ENOMEM;
    }
    if (!strcmp(k, "section")) {
        c->section = e;
        if ((v[0] != 'q' && v[0] != 'p') || parse_long(v + 1, 1, 1000000000L, &(long){0}))
            return bad(c->err, c->errlen, e, "'%s' is not a coordinate q<i> or p<i> (1-based i)", v);
    } else if (!strcmp(k, "section_value")) {
        c->section_value = e;
        if (dth_parse_double(v, &x)) return bad(c->err, c->errlen, e, "'%s' is not a finite number", v);
    } else if (!strcmp(k, "section_direction") || !strcmp(k, "distance_direction")) {
        if (k[1] == 'e') c->section_dir = e;
        else c->dist_dir = e;
        if (parse_direction(v, &b)) return bad(c->err, c->errlen, e, "'%s' is not one of up, down, both", v);
    } else if (!strcmp(k, "section_terminal") || !strcmp(k, "time_terminal") || !strcmp(k, "distance_terminal")) {
        if (k[0] == 's') c->section_term = e;
        else if (k[0] == 't') c->time_term = e;
        else c->dist_term = e;
        if (parse_bool(v, &b)) return bad(c->err, c->errlen, e, "'%s' is not yes or no", v);
    } else if (!strcmp(k, "time")) {
        c->time = e;
        size_t cnt = count_items(v);
        double *list = dth_calloc(c->s->alloc, cnt, sizeof *list);
        if (!list) return DTH_ENOMEM;
        int r = dth__parse_list(v, list, cnt, &cnt);
        dth_free(c->s->alloc, list);
        if (r) return bad(c->err, c->errlen, e, "'%s' is not a comma-separated list of finite times", v);
    } else if (!strcmp(k, "distance")) {
        c->dist = e;
        if (dth_parse_double(v, &x) || !(x > 0)) return bad(c->err, c->errlen, e, "'%s' is not a finite number > 0", v);
    } else if (!strcmp(k, "distance_dofs")) {
        c->dist_dofs = e;
        for (const char *p = v; *p; p++)
            if (!strchr("0123456789, \t", *p))
                return bad(c->err, c->errlen, e, "'%s' is not a comma-separated list of degrees of freedom (1-based)", v);
    } else {
        return bad(c->err, c->errlen, e,
                   "unknown key (known in [events]: section, section_value, section_direction, section_terminal, "
                   "time, time_terminal, distance, distance_dofs, distance_direction, distance_terminal, file)");
    }
    return DTH_OK;
}

/* The events of [events], once the model's n is known. */
static int build_events(setup_ctx *c, dth_run_setup *rs)
{
    const dth_allocator *a = c->s->alloc;
    size_t n = rs->n, nt = c->time ? count_items(c->time->value) : 0;
    size_t ne = (c->section ? 1 : 0) + nt + (c->dist ? 1 : 0);
    const entry *orphan = !c->section ? (c->section_value ? c->section_value : c->section_dir ? c->section_dir : c->section_term)
                                      : NULL;
    if (orphan) return bad(c->err, c->errlen, orphan, "needs [events] section= (the coordinate of the section)");
    orphan = !c->dist ? (c->dist_dofs ? c->dist_dofs : c->dist_dir ? c->dist_dir : c->dist_term) : NULL;
    if (orphan) return bad(c->err, c->errlen, orphan, "needs [events] distance= (the radius)");
    if (!c->time && c->time_term) return bad(c->err, c->errlen, c->time_term, "needs [events] time= (the times)");
    if (!ne) return DTH_OK;
    rs->events = dth_calloc(a, ne, sizeof *rs->events);
    rs->event_specs = dth_calloc(a, ne, sizeof *rs->event_specs);
    rs->event_names = dth_calloc(a, ne, sizeof *rs->event_names);
    size_t nd = c->dist_dofs ? count_items(c->dist_dofs->value) : 0;
    rs->event_dofs = dth_calloc(a, nd + 1, sizeof *rs->event_dofs);
    if (!rs->events || !rs->event_specs || !rs->event_names || !rs->event_dofs) return DTH_ENOMEM;
    size_t i = 0;
    if (c->section) {
        long idx;
        parse_long(c->section->value + 1, 1, 1000000000L, &idx);
        if ((size_t)idx > n)
            return bad(c->err, c->errlen, c->section, "'%s': the model has %zu degrees of freedom", c->section->value, n);
        dth_event_spec *sp = &rs->event_specs[i];
        sp->index = c->section->value[0] == 'q' ? (size_t)idx - 1 : n + (size_t)idx;
        if (c->section_value) dth_parse_double(c->section_value->value, &sp->value);
        rs->events[i] = (dth_event){dth_event_coordinate, sp, 1, 0};
        if (c->section_dir) parse_direction(c->section_dir->value, &rs->events[i].direction);
        if (c->section_term) parse_bool(c->section_term->value, &rs->events[i].terminal);
        rs->event_names[i++] = "section";
    }
    if (nt) {
        double *list = dth_calloc(a, nt, sizeof *list);
        if (!list) return DTH_ENOMEM;
        dth__parse_list(c->time->value, list, nt, &nt);
        int term = 0;
        if (c->time_term) parse_bool(c->time_term->value, &term);
        for (size_t j = 0; j < nt; j++, i++) {
            rs->event_specs[i].value = list[j];
            rs->events[i] = (dth_event){dth_event_time, &rs->event_specs[i], 0, term};
            rs->event_names[i] = "time";
        }
        dth_free(a, list);
    }
    if (c->dist) {
        dth_event_spec *sp = &rs->event_specs[i];
        dth_parse_double(c->dist->value, &sp->value);
        if (c->dist_dofs) {
            const char *v = c->dist_dofs->value;
            size_t m = 0;
            while (*v) {
                char *end;
                long d = strtol(v, &end, 10);
                if (end == v || d < 1 || (size_t)d > n)
                    return bad(c->err, c->errlen, c->dist_dofs, "'%s': degrees of freedom are 1..%zu", c->dist_dofs->value, n);
                rs->event_dofs[m++] = (size_t)d - 1;
                v = end;
                while (*v == ' ' || *v == '\t' || *v == ',') v++;
            }
            if (!m) return bad(c->err, c->errlen, c->dist_dofs, "empty list of degrees of freedom");
            sp->dofs = rs->event_dofs;
            sp->ndofs = m;
        }
        rs->events[i] = (dth_event){dth_event_distance, sp, 0, 0};
        if (c->dist_dir) parse_direction(c->dist_dir->value, &rs->events[i].direction);
        if (c->dist_term) parse_bool(c->dist_term->value, &rs->events[i].terminal);
        rs->event_names[i++] = "distance";
    }
    rs->nevents = i;
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
        } else if (strcmp(sec, "events") == 0) {
            rc = check_events(c, rs, e);
        } else if (!sec[0]) {
            dth__set_err(c->err, c->errlen, "%s: key '%s' is outside any [section]", e->origin, k);
            return DTH_EINVAL;
        } else {
            dth__set_err(c->err, c->errlen, "%s: unknown section [%s] (known: model, initial, integrator, regularize, output, events)",
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
    /* the time must move: a step below the resolution of t (t + h == t, or nearly) never
     * advances it, and a run to t_end would never end */
    double h = fabs(rs->opt.h);
    if (!(h > 2 * DBL_EPSILON * fabs(rs->t0)))
        return bad(c->err, c->errlen, c->t ? c->t : c->h,
                   "the time t = %.17g does not advance by steps of h = %.3g (t + h == t in double precision): "
                   "start the clock nearer 0 or take a larger step", rs->t0, rs->opt.h);
    if (c->t_end && !(h > 2 * DBL_EPSILON * fabs(rs->t_end)))
        return bad(c->err, c->errlen, c->t_end,
                   "t_end = %.17g cannot be reached by steps of h = %.3g (t + h == t in double precision long before)",
                   rs->t_end, rs->opt.h);
    if (c->t_end && (rs->t_end - rs->t0) * rs->opt.h < 0)
        return bad(c->err, c->errlen, c->t_end, "t_end = %.17g lies behind t = %.17g for h = %.17g (the sign of h is the direction of time)",
                   rs->t_end, rs->t0, rs->opt.h);
    if (c->wp && rs->opt.start != DTH_START_VERTEX)
        return bad(c->err, c->errlen, c->wp, "an explicit wp applies only with [integrator] start=vertex");
    if (c->every && c->dt && rs->dt > 0 && rs->every != 1)
        return bad(c->err, c->errlen, c->dt, "dt > 0 resamples at uniform times and cannot be combined with every= (%s)",
                   c->every->origin);
    int is_dth = strcmp(rs->method, "dth") == 0;
    /* output times far denser than the steps: millions of rows per step fill a disk, they do not
     * resolve the trajectory (the method's steps do) */
    if (rs->dt > 0 && !(fabs(rs->opt.h) / rs->dt <= 1e6))
        return bad(c->err, c->errlen, c->dt, "%.3g asks for %.3g rows per step of h = %.3g: at most 1e6 (a larger dt)",
                   rs->dt, fabs(rs->opt.h) / rs->dt, rs->opt.h);
    if (rs->dt > 0) {
        if (c->points && c->points_kind >= 0)
            return bad(c->err, c->errlen, c->points, "dt > 0 writes output times and cannot be combined with points=%s (%s)",
                       c->points->value, c->dt->origin);
        rs->points = DTH_POINTS_TIMES;
    } else if (c->points && c->points_kind >= 0) {
        if (c->points_kind == DTH_POINTS_MIDPOINTS && !is_dth)
            return bad(c->err, c->errlen, c->points, "midpoints exist for method = dth only (%s)",
                       c->method ? c->method->origin : "method");
        if (c->points_kind == DTH_POINTS_MIDPOINTS && rs->opt.order != 2)
            return bad(c->err, c->errlen, c->points, "midpoints exist for order 2 only: order %d's substep midpoints lie on "
                       "their levels, not on the energy surface (%s)", rs->opt.order, c->order ? c->order->origin : "order");
        rs->points = (dth_points)c->points_kind;
    } else {
        rs->points = is_dth && rs->opt.order == 2 && rs->opt.start == DTH_START_MIDPOINT ? DTH_POINTS_MIDPOINTS
                                                                                        : DTH_POINTS_VERTICES;
    }
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
    /* default: `smooth` for DTH (ordinary steps, a changeover around psi = 0), none for baselines */
    const char *def = strcmp(rs->method, "dth") ? "none" : "smooth";
    const dth_regularizer_type *t = dth_registry_find_regularizer(reg, em ? em->value : def);
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
            /* the line of the parameter the message names, else method=, else the first parameter
             * (the default regularizer has no method= line) */
            const entry *at = em ? em : n ? ke[0] : NULL;
            for (size_t i = 0; i < n; i++)
                if (names_key(rerr, kv[i].key)) at = ke[i];
            if (at) {
                rc = bad(err, errlen, at, "%s", rerr);
            } else {
                dth__set_err(err, errlen, "%s: [regularize] %s: %s", s->source ? s->source : "scene", t->name, rerr);
                rc = DTH_EINVAL;
            }
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

/* The model must evaluate at the initial state (q, t, p): else say why, naming initial.q. */
static int check_start(setup_ctx *c, dth_run_setup *rs, const char *model)
{
    size_t n = rs->n;
    double *y = dth_calloc(c->s->alloc, 2 * n + 1, sizeof *y);
    if (!y) {
        dth__set_err(c->err, c->errlen, "out of memory");
        return DTH_ENOMEM;
    }
    memcpy(y, rs->q0, n * sizeof *y);
    y[n] = rs->t0;
    memcpy(y + n + 1, rs->p0, n * sizeof *y);
    char why[200];
    int rc = dth_model_domain_check(rs->model, y, why, sizeof why);
    dth_free(c->s->alloc, y);
    if (rc == DTH_ENOMEM) dth__set_err(c->err, c->errlen, "out of memory");
    else if (rc) rc = bad(c->err, c->errlen, c->q, "the model '%s' cannot start here (initial.q, initial.p): %s", model, why);
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
    rs.opt.estimate = 1; /* scene runs report an error estimate (integrator.h) */
    rs.stop_error = 0.25;
    rs.warn_ratio = 16;
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
        } else if (rs.opt.finish == DTH_FINISH_REVERSIBLE &&
                   (rs.opt.linsolve == DTH_LINSOLVE_BANDED || rs.opt.linsolve == DTH_LINSOLVE_BANDED_LU ||
                    (rs.opt.linsolve == DTH_LINSOLVE_AUTO && dth__model_banded(rs.model)))) {
            /* the reversible finish reads the dense Hessian at its coarse point (integrator.c, coarse_n) */
            rc = bad(err, errlen, c.reversible,
                     "the reversible finish needs a dense Hessian, and model '%s' takes the banded solver here: "
                     "add integrator.linsolve = dense",
                     type->name);
        } else if (c.order || c.table || c.band_time) {
            /* the order, its table and band against the method and the model (dth_options_check) */
            dth_options o = rs.opt;
            char m[256];
            const entry *at = c.order ? c.order : c.table ? c.table : c.band_time;
            if (dth_options_check(rs.model, &o, m, sizeof m)) rc = bad(err, errlen, at, "%s", m);
            else rc = check_start(&c, &rs, type->name);
        } else {
            rc = check_start(&c, &rs, type->name);
        }
    }
    dth_free(s->alloc, kv);
    dth_free(s->alloc, kv_entry);
    if (!rc) rc = build_events(&c, &rs);
    if (rc == DTH_ENOMEM) dth__set_err(err, errlen, "out of memory");
    if (!rc) rc = setup_regularizer(s, reg, &rs, err, errlen);
    if (rc) {
        dth_run_setup_clear(&rs);
        return rc < 0 ? rc : DTH_EINVAL;
    }
    *out = rs;
    return DTH_OK;
}
