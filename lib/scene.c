/* SPDX-License-Identifier: MIT */
/*
 * Scene files: an INI key store that remembers where each value came from (FILE:LINE or the
 * -s override), and its validation into a run setup (model, initial state, DTH step options of
 * the paper's section 2 and the start modes, output): each key by the table of scene_keys.c, the
 * rules between keys here, the integrator's rules by dth_options_check. Parsing uses inih;
 * nothing is printed.
 */
#include <ctype.h>
#include <errno.h>
#include <ini.h>
#include <math.h>
#include <stdarg.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include "dth/scene.h"
#include "dth_internal.h"
#include "scene_keys.h"

typedef struct entry {
    char *section, *key, *value, *origin;
    size_t vlen, vcap; /* length of value and its allocation (continuation lines grow it) */
    int override;      /* set by dth_scene_set / dth_scene_set_from, not read from a file */
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
    e->override = x->override;
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
    x->override = 0; /* dth_scene_set_from marks its own */
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
    entry x = {0};
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
    return dth_scene_set_from(s, NULL, assignment, err, errlen);
}

int dth_scene_check_entry(const char *section, const char *key, const char *value, char *err, size_t errlen)
{
    if (!section || !key || !value) {
        dth__set_err(err, errlen, "invalid arguments to dth_scene_check_entry");
        return DTH_EINVAL;
    }
    const char *why = unwritable(section, key, value);
    if (why) {
        dth__set_err(err, errlen, "%.49s.%.49s: a scene file cannot hold this (%s)", section, key, why);
        return DTH_EPARSE;
    }
    return DTH_OK;
}

int dth_scene_set_from(dth_scene *s, const char *from, const char *assignment, char *err, size_t errlen)
{
    if (!s || !assignment) {
        dth__set_err(err, errlen, "invalid arguments to dth_scene_set");
        return DTH_EINVAL;
    }
    /* the override names itself in messages (and as its origin), cut after 80 characters */
    char origin[80 + 8];
    if (from) snprintf(origin, sizeof origin, "%.*s%s", AS_CUT(from));
    else snprintf(origin, sizeof origin, "-s %.*s%s", AS_CUT(assignment));
    const char *eq = strchr(assignment, '=');
    const char *dot = eq ? memchr(assignment, '.', (size_t)(eq - assignment)) : NULL;
    if (!eq || !dot) {
        dth__set_err(err, errlen, "%s: expected section.key=value", origin);
        return DTH_EPARSE;
    }
    const char *sb = assignment, *se = dot, *kb = dot + 1, *ke = eq, *vb = eq + 1,
               *ve = eq + strlen(eq);
    trim(&sb, &se);
    trim(&kb, &ke);
    trim(&vb, &ve);
    if (sb == se || kb == ke) {
        dth__set_err(err, errlen, "%s: expected section.key=value", origin);
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
        dth__set_err(err, errlen, "%s: a scene file cannot hold this (%s)", origin, why);
        return DTH_EPARSE;
    }
    entry x = {0};
    int rc = make_entry(s->alloc, sb, (size_t)(se - sb), kb, (size_t)(ke - kb), vb, (size_t)(ve - vb), origin, &x);
    x.override = 1;
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
    dth__scene_extra *x; /* what the table's keys set besides the run setup */
} setup_ctx;

/* The entry of section.key, NULL if the scene does not set it. */
static const entry *given(const setup_ctx *c, const char *section, const char *key)
{
    long i = find(c->s, section, key);
    return i < 0 ? NULL : &c->s->e[i];
}

/* A [model] key: one of the model's parameters, collected for dth_model_new. */
static int check_model_key(setup_ctx *c, const dth_model_type *type, const entry *e, dth_kv *kv,
                           const entry **kv_entry, size_t *nkv)
{
    if (strcmp(e->key, "name") == 0) return DTH_OK;
    if (!dth__model_accepts_key(type, e->key)) {
        char buf[256];
        list_params(type, buf, sizeof buf);
        dth__suggest sg;
        dth__suggest_init(&sg, e->key);
        for (size_t i = 0; i < type->n_params; i++) dth__suggest_offer(&sg, type->params[i].key);
        return bad(c->err, c->errlen, e, "model '%s' has no parameter '%s' (its parameters: %s)%s%s%s", type->name,
                   e->key, buf, sg.best ? "; did you mean " : "", sg.best ? sg.best : "", sg.best ? "?" : "");
    }
    kv[*nkv] = (dth_kv){e->key, e->value};
    kv_entry[(*nkv)++] = e;
    return DTH_OK;
}

/* Every key on its own, in the order the keys were first set: the table's keys (scene_keys.c) into
 * the run setup; collects the model's keys. */
static int check_keys(setup_ctx *c, const dth_model_type *type, dth_run_setup *rs, dth_kv *kv,
                      const entry **kv_entry, size_t *nkv)
{
    const dth_scene *s = c->s;
    const dth__scene_target t = {rs, c->x, s->alloc};
    char msg[1024];
    for (size_t i = 0; i < s->n; i++) {
        const entry *e = &s->e[i];
        const dth__scene_key *k;
        int rc = DTH_OK;
        switch (dth__scene_section_kind(e->section)) {
        case DTH__SECTION_MODEL:
            rc = check_model_key(c, type, e, kv, kv_entry, nkv);
            break;
        case DTH__SECTION_REGULARIZE:
            break; /* checked by setup_regularizer once the model exists */
        case DTH__SECTION_KEYS:
            k = dth__scene_key_find(e->section, e->key);
            if (!k) {
                dth__scene_unknown_key(e->section, e->key, msg, sizeof msg);
                return bad(c->err, c->errlen, e, "%s", msg);
            }
            rc = dth__scene_key_parse(k, e->value, &t, msg, sizeof msg);
            if (rc == DTH_EINVAL) return bad(c->err, c->errlen, e, "%s", msg);
            break;
        default:
            if (!e->section[0]) {
                dth__set_err(c->err, c->errlen, "%s: key '%s' is outside any [section]", e->origin, e->key);
                return DTH_EINVAL;
            }
            dth__scene_unknown_section(e->section, msg, sizeof msg);
            dth__set_err(c->err, c->errlen, "%s: %s", e->origin, msg);
            return DTH_EINVAL;
        }
        if (rc == DTH_ENOMEM) dth__set_err(c->err, c->errlen, "out of memory");
        if (rc) return rc;
    }
    return DTH_OK;
}

static int is_override(const entry *e) { return e->override; }

/* The run's extent: steps or t_end (an override of one replaces the other from the file), and a
 * clock that moves with steps of h. */
static int check_length(setup_ctx *c, dth_run_setup *rs, const char *src)
{
    const entry *steps = given(c, "integrator", "steps"), *t_end = given(c, "integrator", "t_end");
    if (steps && t_end && is_override(steps) != is_override(t_end)) {
        if (is_override(steps)) t_end = NULL;
        else steps = NULL;
    }
    if (steps && t_end) {
        const entry *later = steps > t_end ? steps : t_end, *first = later == steps ? t_end : steps;
        return bad(c->err, c->errlen, later, "give either steps= or t_end=, not both (%s.%s set at %s)",
                   first->section, first->key, first->origin);
    }
    if (!steps && !t_end) {
        dth__set_err(c->err, c->errlen, "%s: missing [integrator] steps= or t_end= (how long to run)", src);
        return DTH_EINVAL;
    }
    rs->has_t_end = t_end != NULL;
    /* the time must move: a step below the resolution of t (t + h == t, or nearly) never
     * advances it, and a run to t_end would never end */
    const entry *t = given(c, "initial", "t");
    double h = fabs(rs->opt.h);
    if (!(h > 2 * DBL_EPSILON * fabs(rs->t0)))
        return bad(c->err, c->errlen, t ? t : given(c, "integrator", "h"),
                   "the time t = %.17g does not advance by steps of h = %.3g (t + h == t in double precision): "
                   "start the clock nearer 0 or take a larger step", rs->t0, rs->opt.h);
    if (t_end && !(h > 2 * DBL_EPSILON * fabs(rs->t_end)))
        return bad(c->err, c->errlen, t_end,
                   "t_end = %.17g cannot be reached by steps of h = %.3g (t + h == t in double precision long before)",
                   rs->t_end, rs->opt.h);
    if (t_end && (rs->t_end - rs->t0) * rs->opt.h < 0)
        return bad(c->err, c->errlen, t_end, "t_end = %.17g lies behind t = %.17g for h = %.17g (the sign of h is the direction of time)",
                   rs->t_end, rs->t0, rs->opt.h);
    return DTH_OK;
}

/* integrator.h_max, tol and pilot (control.h): a DTH run to t_end; h defaults to h_max (or a thousandth of
 * the run for tol alone), in the direction of t_end; the guard step_max = 1.05 h_max. */
static int check_control(setup_ctx *c, dth_run_setup *rs)
{
    const entry *hm = given(c, "integrator", "h_max"), *tol = given(c, "integrator", "tol"),
                *pilot = given(c, "integrator", "pilot"), *h = given(c, "integrator", "h"),
                *t_end = given(c, "integrator", "t_end"), *steps = given(c, "integrator", "steps"),
                *method = given(c, "integrator", "method"), *wp = given(c, "initial", "wp");
    const entry *ask = (tol && rs->tol > 0) ? tol : (hm && rs->h_max > 0) ? hm : NULL;
    if (!ask) {
        if (pilot) return bad(c->err, c->errlen, pilot, "the end of the pilots of h_max and tol: give one of them");
        rs->h_asked = rs->opt.h;
        return DTH_OK;
    }
    if (strcmp(rs->opt.method, "dth"))
        return bad(c->err, c->errlen, ask, "chooses the constant of a DTH run; method '%s' takes the fixed step h (%s)",
                   rs->opt.method, method ? method->origin : "method");
    if (rs->opt.order != 2) /* its pilots and step law are order 2's (lambda^6 psi^2 = C) */
        return bad(c->err, c->errlen, ask, "calibrates order 2's step law; order %d's steps follow another "
                   "(tau^2 psi = const): use h with order %d, or order = 2", rs->opt.order, rs->opt.order);
    if (!t_end || (steps && is_override(steps) && !is_override(t_end)))
        return bad(c->err, c->errlen, ask, "calibrates the run up to its end: give [integrator] t_end= instead of "
                   "steps=");
    if (wp)
        return bad(c->err, c->errlen, ask, "chooses the first step, which the explicit initial.wp (%s) fixes: leave "
                   "one out", wp->origin);
    double span = rs->t_end - rs->t0;
    if (!h) {
        rs->opt.h = rs->h_max > 0 ? copysign(rs->h_max, span) : span / 1000;
        if (!(rs->opt.h != 0))
            return bad(c->err, c->errlen, t_end, "t_end = %.17g is the start t: no run to calibrate", rs->t_end);
    }
    if (pilot && !(isfinite(rs->pilot) && (rs->pilot - rs->t0) * rs->opt.h > 0 && (rs->pilot - rs->t_end) * rs->opt.h <= 0))
        return bad(c->err, c->errlen, pilot, "%.17g: the pilots' end must lie after t = %.17g and not beyond t_end = %.17g",
                   rs->pilot, rs->t0, rs->t_end);
    rs->h_asked = rs->opt.h;
    rs->step_max = rs->h_max > 0 ? 1.05 * rs->h_max : 0;
    return DTH_OK;
}

/* What is written: dt against every and points, midpoints for DTH only, points=auto resolved. */
static int check_rows(setup_ctx *c, dth_run_setup *rs)
{
    const entry *every = given(c, "output", "every"), *dt = given(c, "output", "dt"),
                *points = given(c, "output", "points"), *method = given(c, "integrator", "method");
    int kind = c->x->points; /* -1: auto */
    if (every && dt && rs->dt > 0 && rs->every != 1)
        return bad(c->err, c->errlen, dt, "dt > 0 resamples at uniform times and cannot be combined with every= (%s)",
                   every->origin);
    int is_dth = strcmp(rs->opt.method, "dth") == 0;
    /* output times far denser than the steps: millions of rows per step fill a disk, they do not
     * resolve the trajectory (the method's steps do) */
    if (rs->dt > 0 && !(fabs(rs->opt.h) / rs->dt <= DTH_RUN_MAX_SAMPLES_PER_STEP))
        return bad(c->err, c->errlen, dt, "%.3g asks for %.3g rows per step of h = %.3g: at most 1e6 (a larger dt)",
                   rs->dt, fabs(rs->opt.h) / rs->dt, rs->opt.h);
    if (rs->dt > 0) {
        if (points && kind >= 0)
            return bad(c->err, c->errlen, points, "dt > 0 writes output times and cannot be combined with points=%s (%s)",
                       points->value, dt->origin);
        rs->points = DTH_POINTS_TIMES;
    } else if (points && kind >= 0) {
        if (kind == DTH_POINTS_MIDPOINTS && !is_dth)
            return bad(c->err, c->errlen, points, "midpoints exist for method = dth only (%s)",
                       method ? method->origin : "method");
        if (kind == DTH_POINTS_MIDPOINTS && rs->opt.order != 2) {
            const entry *order = given(c, "integrator", "order");
            return bad(c->err, c->errlen, points, "midpoints exist for order 2 only: order %d's substep midpoints lie on "
                       "their levels, not on the energy surface (%s)", rs->opt.order, order ? order->origin : "order");
        }
        rs->points = (dth_points)kind;
    } else {
        rs->points = is_dth && rs->opt.order == 2 && rs->opt.start == DTH_START_MIDPOINT ? DTH_POINTS_MIDPOINTS
                                                                                        : DTH_POINTS_VERTICES;
    }
    return DTH_OK;
}

/* Checks that involve several keys. */
static int check_cross(setup_ctx *c, dth_run_setup *rs)
{
    const char *src = c->s->source ? c->s->source : "scene";
    const entry *q = given(c, "initial", "q"), *p = given(c, "initial", "p"), *wp = given(c, "initial", "wp");
    if (!q || !p) {
        dth__set_err(c->err, c->errlen, "%s: missing [initial] %s= (comma-separated initial values)", src, q ? "p" : "q");
        return DTH_EINVAL;
    }
    if (c->x->np != rs->n)
        return bad(c->err, c->errlen, p, "%zu value%s, but initial.q has %zu (%s)", c->x->np, c->x->np == 1 ? "" : "s",
                   rs->n, q->origin);
    const entry *hm = given(c, "integrator", "h_max"), *tol = given(c, "integrator", "tol");
    int ctl = (hm && rs->h_max > 0) || (tol && rs->tol > 0);
    if (!given(c, "integrator", "h") && !ctl) {
        dth__set_err(c->err, c->errlen, "%s: missing [integrator] h= (the first step; its sign sets the direction), "
                     "or h_max= or tol=", src);
        return DTH_EINVAL;
    }
    int rc = check_control(c, rs);
    if (rc) return rc;
    rc = check_length(c, rs, src);
    if (rc) return rc;
    if (wp && rs->opt.start != DTH_START_VERTEX)
        return bad(c->err, c->errlen, wp, "an explicit wp applies only with [integrator] start=vertex");
    return check_rows(c, rs);
}

/* The model from [model] and n; a refusal names the parameter's line (else initial.q). */
static int make_model(setup_ctx *c, const dth_model_type *type, dth_run_setup *rs, const dth_kv *kv,
                      const entry *const *kv_entry, size_t nkv)
{
    char merr[256];
    const entry *q = given(c, "initial", "q");
    int rc = dth_model_new(type, kv, nkv, rs->n, c->s->alloc, &rs->model, merr, sizeof merr);
    if (rc == DTH_ENOMEM) {
        dth__set_err(c->err, c->errlen, "out of memory");
        return rc;
    }
    if (rc) {
        const entry *at = q;
        for (size_t i = 0; i < nkv; i++)
            if (names_key(merr, kv[i].key)) at = kv_entry[i];
        return bad(c->err, c->errlen, at, "model '%s': %s", type->name, merr);
    }
    if (dth_model_dof(rs->model) != rs->n)
        return bad(c->err, c->errlen, q, "model '%s' has %zu degree%s of freedom, but %zu q value%s given", type->name,
                   dth_model_dof(rs->model), dth_model_dof(rs->model) == 1 ? "" : "s", rs->n, rs->n == 1 ? " is" : "s are");
    return DTH_OK;
}

/* The key an options refusal concerns: the last one in the scene whose default value (as the table
 * stores it in dth_options; [regularize] method: no regularizer) makes the refusal go away or change.
 * A rule between two keys (linsolve and reversible, method and [regularize] method) so names the one
 * set later. NULL if no key does (the model's size is the matter). */
static const entry *options_key(const setup_ctx *c, const dth_run_setup *rs, const char *msg)
{
    dth_options def;
    dth_options_default(&def);
    const size_t base = offsetof(dth_run_setup, opt);
    for (size_t i = c->s->n; i-- > 0;) {
        const entry *e = &c->s->e[i];
        const dth__scene_key *k = dth__scene_key_find(e->section, e->key);
        dth_options o = rs->opt;
        const dth__scene_slot *sl[2] = {k ? &k->to : NULL, k ? &k->given : NULL};
        int hit = 0;
        for (int j = 0; j < 2; j++)
            if (sl[j] && sl[j]->base == DTH__IN_SETUP && sl[j]->off >= base && sl[j]->off < base + sizeof o) {
                memcpy((char *)&o + (sl[j]->off - base), (const char *)&def + (sl[j]->off - base), sl[j]->size);
                hit = 1;
            }
        if (!k && !strcmp(e->section, "regularize") && !strcmp(e->key, "method")) {
            o.regularizer = NULL;
            hit = 1;
        }
        if (!hit) continue;
        char again[512];
        if (dth_options_check(rs->model, &o, again, sizeof again) == DTH_OK || strcmp(again, msg)) return e;
    }
    return NULL;
}

/* The integrator-level rules, dth_options_check's (the method, the linear solver and the finish
 * against the model, a regularizer with a baseline), each refusal at the line of the key concerned.
 * On success the method is its static name, also in rs->method. */
static int check_options(setup_ctx *c, dth_run_setup *rs)
{
    dth_options o = rs->opt;
    char msg[512];
    int rc = dth_options_check(rs->model, &o, msg, sizeof msg);
    if (rc == DTH_ENOMEM) {
        dth__set_err(c->err, c->errlen, "out of memory");
        return rc;
    }
    if (rc) {
        const entry *at = options_key(c, rs, msg);
        return bad(c->err, c->errlen, at ? at : given(c, "initial", "q"), "%s", msg);
    }
    rs->opt.method = o.method;
    snprintf(rs->method, sizeof rs->method, "%s", o.method);
    return DTH_OK;
}

/* The events of [events] from the values the keys gave (dth__scene_extra), once n is known; the
 * rules between the keys first (a key of an event that is not there). */
static int build_events(setup_ctx *c, dth_run_setup *rs)
{
    const dth_allocator *a = c->s->alloc;
    const dth__scene_extra *x = c->x;
    const entry *sec = given(c, "events", "section"), *dist = given(c, "events", "distance"),
                *time = given(c, "events", "time"), *dofs = given(c, "events", "distance_dofs");
    const entry *orphan = NULL;
    if (!sec && !(orphan = given(c, "events", "section_value")) && !(orphan = given(c, "events", "section_direction")))
        orphan = given(c, "events", "section_terminal");
    if (orphan) return bad(c->err, c->errlen, orphan, "needs [events] section= (the coordinate of the section)");
    if (!dist && !(orphan = dofs) && !(orphan = given(c, "events", "distance_direction")))
        orphan = given(c, "events", "distance_terminal");
    if (orphan) return bad(c->err, c->errlen, orphan, "needs [events] distance= (the radius)");
    if (!time && (orphan = given(c, "events", "time_terminal")))
        return bad(c->err, c->errlen, orphan, "needs [events] time= (the times)");
    size_t n = rs->n, ne = (sec ? 1 : 0) + x->ntimes + (dist ? 1 : 0);
    if (!ne) return DTH_OK;
    rs->events = dth_calloc(a, ne, sizeof *rs->events);
    rs->event_specs = dth_calloc(a, ne, sizeof *rs->event_specs);
    rs->event_names = dth_calloc(a, ne, sizeof *rs->event_names);
    rs->event_dofs = dth_calloc(a, x->ndofs + 1, sizeof *rs->event_dofs);
    if (!rs->events || !rs->event_specs || !rs->event_names || !rs->event_dofs) return DTH_ENOMEM;
    size_t i = 0;
    if (sec) {
        size_t idx = (size_t)labs(x->section);
        if (idx > n)
            return bad(c->err, c->errlen, sec, "'%s': the model has %zu degree%s of freedom", sec->value, n, n == 1 ? "" : "s");
        dth_event_spec *sp = &rs->event_specs[i];
        sp->index = x->section > 0 ? idx - 1 : n + idx;
        sp->value = x->section_value;
        rs->events[i] = (dth_event){dth_event_coordinate, sp, x->section_direction, x->section_terminal};
        rs->event_names[i++] = "section";
    }
    for (size_t j = 0; j < x->ntimes; j++, i++) {
        rs->event_specs[i].value = x->times[j];
        rs->events[i] = (dth_event){dth_event_time, &rs->event_specs[i], 0, x->time_terminal};
        rs->event_names[i] = "time";
    }
    if (dist) {
        dth_event_spec *sp = &rs->event_specs[i];
        sp->value = x->distance;
        if (dofs) {
            if (!x->ndofs) return bad(c->err, c->errlen, dofs, "empty list of degrees of freedom");
            for (size_t m = 0; m < x->ndofs; m++) {
                if (x->dofs[m] > n)
                    return bad(c->err, c->errlen, dofs, "'%s': degrees of freedom are 1..%zu", dofs->value, n);
                rs->event_dofs[m] = x->dofs[m] - 1;
            }
            sp->dofs = rs->event_dofs;
            sp->ndofs = x->ndofs;
        }
        rs->events[i] = (dth_event){dth_event_distance, sp, x->distance_direction, x->distance_terminal};
        rs->event_names[i++] = "distance";
    }
    rs->nevents = i;
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
    /* default: `land` for DTH (raw DTH, one replaced step per psi = 0 crossing), none for baselines */
    const char *def = strcmp(rs->method, "dth") ? "none" : "land";
    const char *name = em ? em->value : def;
    const dth_regularizer_type *t = dth_registry_find_regularizer(reg, name);
    if (!t && !em && strcmp(name, "none")) {
        /* a registry built without the regularizers (a program's own, holding models only) */
        dth__set_err(err, errlen, "%s: [regularize]: the default regularizer '%s' is not in the registry (register "
                     "it, e.g. with dth_registry_add_builtin, or give [regularize] method = none)",
                     s->source ? s->source : "scene", def);
        return DTH_EINVAL;
    }
    if (!t && strcmp(name, "none")) {
        char names[256];
        size_t len = 0;
        names[0] = '\0';
        for (size_t i = 0; i < dth_registry_regularizer_count(reg) && len < sizeof names; i++)
            len += (size_t)snprintf(names + len, sizeof names - len, "%s%s", i ? ", " : "",
                                    dth_registry_regularizer_at(reg, i)->name);
        if (!strcmp(em->value, "smooth")) /* retired with issue 23 */
            return bad(err, errlen, em, "regularizer 'smooth' was retired: it replaced steps where nothing crosses and "
                       "lost order; 'land', the default, crosses psi = 0 at second order (docs/regularization.md; "
                       "available: %s)", names);
        return bad(err, errlen, em, "unknown regularizer '%s' (available: %s)", em->value, names);
    }
    snprintf(rs->regularize, sizeof rs->regularize, "%s", t ? t->name : "none");
    if (!t || !strcmp(t->name, "none")) { /* none (raw DTH, the baselines' default) needs no registered type */
        for (size_t i = 0; i < s->n; i++)
            if (!strcmp(s->e[i].section, "regularize") && strcmp(s->e[i].key, "method"))
                return bad(err, errlen, &s->e[i], "unknown key (regularizer 'none' takes no parameters)");
        return DTH_OK;
    }
    if (rs->opt.order == 4 && !strcmp(t->name, "land")) /* the band carries order 4's crossings, not land's step */
        for (size_t i = 0; i < s->n; i++)
            if (!strcmp(s->e[i].section, "regularize") && strcmp(s->e[i].key, "method"))
                return bad(err, errlen, &s->e[i], "the parameters of regularizer '%s' apply to order 2 (its "
                           "replaced step at a crossing); order 4 carries psi = 0 crossings by its own band "
                           "(integrator.band_time; docs/theory.md, \"Order 4\")", t->name);
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
    else if (rc) rc = bad(c->err, c->errlen, given(c, "initial", "q"), "the model '%s' cannot start here (initial.q, initial.p): %s", model, why);
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
    dth__scene_extra x;
    dth__scene_defaults(&rs, &x, s->alloc);
    setup_ctx c = {.s = s, .err = err, .errlen = errlen, .x = &x};
    dth_kv *kv = dth_calloc(s->alloc, s->n + 1, sizeof *kv);
    const entry **kv_entry = dth_calloc(s->alloc, s->n + 1, sizeof *kv_entry);
    size_t nkv = 0;
    int rc = kv && kv_entry ? DTH_OK : DTH_ENOMEM;
    if (rc) dth__set_err(err, errlen, "out of memory");
    if (!rc) rc = check_keys(&c, type, &rs, kv, kv_entry, &nkv);
    if (!rc) rc = check_cross(&c, &rs);
    if (!rc) rc = make_model(&c, type, &rs, kv, kv_entry, nkv);
    if (!rc) rc = check_options(&c, &rs);
    if (!rc) rc = check_start(&c, &rs, type->name);
    dth_free(s->alloc, kv);
    dth_free(s->alloc, kv_entry);
    if (!rc) rc = build_events(&c, &rs);
    if (rc == DTH_ENOMEM) dth__set_err(err, errlen, "out of memory");
    if (!rc) rc = setup_regularizer(s, reg, &rs, err, errlen);
    /* the options again with the regularizer: a baseline takes none */
    if (!rc && rs.regularizer) rc = check_options(&c, &rs);
    dth__scene_extra_clear(&x, s->alloc);
    if (rc) {
        dth_run_setup_clear(&rs);
        return rc < 0 ? rc : DTH_EINVAL;
    }
    *out = rs;
    return DTH_OK;
}
