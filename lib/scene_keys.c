/* SPDX-License-Identifier: MIT */
/*
 * The scene keys of [initial], [integrator], [output] and [events] as one table: type, where the
 * value goes (dth_run_setup, dth_options or the events' values), bounds and doc. One generic parser
 * reads them all and words every bad value from the entry; the "unknown key" messages, the "did
 * you mean" and the user guide's key tables (dth keys --markdown) come from the same table.
 */
#include <errno.h>
#include <limits.h>
#include <math.h>
#include <stdarg.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include "dth/methods.h"
#include "compose.h"
#include "dth_internal.h"
#include "scene_keys.h"

/* Values are stored as int in the enum members (dth_start, dth_linsolve, dth_finish). */
_Static_assert(sizeof(dth_start) == sizeof(int) && sizeof(dth_linsolve) == sizeof(int) &&
                   sizeof(dth_finish) == sizeof(int),
               "enum members are written as int");

/* ---------------------------------------------------------------- the names of BOOL and CHOICE keys */

#define CHOICES(fn, ...)                                                                                     \
    static int fn(size_t j, dth__choice *c)                                                                  \
    {                                                                                                        \
        static const dth__choice t[] = {__VA_ARGS__};                                                        \
        if (j >= sizeof t / sizeof t[0]) return 0;                                                           \
        *c = t[j];                                                                                           \
        return 1;                                                                                            \
    }

CHOICES(yes_no, {"yes", 1, 0, NULL}, {"no", 0, 0, NULL}, {"true", 1, 1, NULL}, {"false", 0, 1, NULL},
        {"1", 1, 1, NULL}, {"0", 0, 1, NULL})
/* integrator.reversible: yes/no choose the finish (dth_finish) */
CHOICES(finish_yes_no, {"yes", DTH_FINISH_REVERSIBLE, 0, NULL}, {"no", DTH_FINISH_COMPENSATED, 0, NULL},
        {"true", DTH_FINISH_REVERSIBLE, 1, NULL}, {"false", DTH_FINISH_COMPENSATED, 1, NULL},
        {"1", DTH_FINISH_REVERSIBLE, 1, NULL}, {"0", DTH_FINISH_COMPENSATED, 1, NULL})
CHOICES(starts,
        {"midpoint", DTH_START_MIDPOINT, 0,
         "(q, t, p) is the first *midpoint*: wp = -H_phys there and the first step is exactly h; the vertex z_0 "
         "lies half a step earlier, at t0 - h/2"},
        {"vertex", DTH_START_VERTEX, 0,
         "(q, t, p) is the vertex z_0, and wp is solved for so that the first step is exactly h (the run is "
         "refused, naming h, where no wp gives that step), or taken from `[initial] wp`"})
CHOICES(points,
        {"auto", -1, 0, "midpoints for `method = dth` of order 2 with `start = midpoint`, else vertices"},
        {"vertices", DTH_POINTS_VERTICES, 0, "the vertices z_k"},
        {"midpoints", DTH_POINTS_MIDPOINTS, 0,
         "every step's midpoint zbar, where H(zbar) = 0: the energy is exact on every row (`method = dth` of "
         "order 2 only)"})
CHOICES(directions, {"up", 1, 0, "the function increases through zero"},
        {"down", -1, 0, "it decreases through zero"}, {"both", 0, 0, "either"})

/* integrator.method: the methods of methods.h, with their docs */
static int methods(size_t j, dth__choice *c)
{
    const char *name = dth_method_name(j);
    if (!name) return 0;
    *c = (dth__choice){name, (int)j, 0, dth_method_doc(name)};
    return 1;
}

/* integrator.linsolve: linsolve.c's table */
static int linsolves(size_t j, dth__choice *c)
{
    const dth__linsolve_info *ls = dth__linsolve_at(j);
    if (!ls) return 0;
    *c = (dth__choice){ls->name, (int)ls->kind, 0, ls->doc};
    return 1;
}

/* integrator.table: order 4's coefficient tables (compose.c) */
static int tables(size_t j, dth__choice *c)
{
    const dth__table *t = dth__table_at(j);
    if (!t) return 0;
    *c = (dth__choice){t->name, (int)j, 0, t->doc};
    return 1;
}

/* ---------------------------------------------------------------- the table */

#define MEMBER(type, m) sizeof(((type *)0)->m), offsetof(type, m)
#define RS(m) {DTH__IN_SETUP, MEMBER(dth_run_setup, m)}
#define X(m) {DTH__IN_EXTRA, MEMBER(dth__scene_extra, m)}
/* the first part of an entry: section, key, type, required, default, doc */
#define KEY(sec, key, type, req, def, doc) .info = {sec, key, DTH_SCENE_##type, req, def, doc}

static const dth__scene_key keys[] = {
    /* [initial] */
    {KEY("initial", "q", NUMBERS, 1, "",
         "Initial positions. The number of values, n, fixes the model's degrees of freedom and is passed to the "
         "model; if the model disagrees, that is an error at this line."),
     .to = RS(q0), .count = RS(n)},
    {KEY("initial", "p", NUMBERS, 1, "", "Initial momenta: exactly n values."), .to = RS(p0), .count = X(np)},
    {KEY("initial", "t", NUMBER, 0, "0", "Initial time t0."), .to = RS(t0)},
    {KEY("initial", "wp", NUMBER, 0, "",
         "An explicit wp for a vertex start (`start = vertex`) instead of the one that makes the first step h. "
         "With `start = midpoint` it is an error."),
     .to = RS(opt.wp), .given = RS(opt.has_wp)},

    /* [integrator] */
    {KEY("integrator", "method", CHOICE, 0, "dth",
         "How to step: the DTH step, or a fixed-step baseline for comparison. For a baseline, `h` is the fixed "
         "step, the CSV's `wp` column holds -H_phys at the start (so `H` shows the energy error), and "
         "`[regularize]` must stay `none`; `verlet` needs a separable model, `midpoint-proj` an autonomous one."),
     .to = RS(opt.method), .choice = methods, .as_name = DTH__NAME_GIVEN},
    {KEY("integrator", "start", CHOICE, 0, "midpoint",
         "Where the initial state lies. The energy a vertex start conserves (every midpoint's, -wp) differs from "
         "H_phys(z_0) by about psi h^2/8; `dth run` warns when they differ by more than 1 %, and when an explicit "
         "wp encodes a first step more than 10 % from h."),
     .to = RS(opt.start), .choice = starts},
    {KEY("integrator", "h", NUMBER, 0, "",
         "The first step. Later steps are whatever the DTH equations give: away from psi = 0 they keep "
         "lambda^6 psi^2 = C, one constant C for the run, which h fixes at the start (docs/theory.md, \"What h "
         "fixes\"), so on an eccentric orbit they can grow to many h. For a bound on every step give `h_max`, for "
         "an error at the end `tol`. A baseline's fixed step. Required unless `h_max` or `tol` is given: with "
         "`h_max` h gives the direction only, with `tol` alone the first pilot's step too (default: the sign of "
         "t_end - t, and (t_end - t) / 1000)."),
     .to = RS(opt.h), .bound = DTH__NONZERO, .note = "its sign sets the direction of time",
     .refuse = "the step must be nonzero (its sign sets the direction of time)"},
    {KEY("integrator", "steps", INTEGER, 0, "",
         "Take exactly this many steps (steps + 1 vertices). Exactly one of `steps` and `t_end` is required."),
     .to = RS(steps), .ilo = 0, .ihi = LONG_MAX},
    {KEY("integrator", "t_end", NUMBER, 0, "",
         "The run ends exactly at `t_end` (see \"The end of a run\" below). It must lie on the side of `t` that "
         "the sign of h points to."),
     .to = RS(t_end)},
    {KEY("integrator", "max_iter", INTEGER, 0, "30", "Newton iterations allowed per step."), .to = RS(opt.max_iter),
     .ilo = 1, .ihi = 100000},
    {KEY("integrator", "K", NUMBER, 0, "0",
         "The paper's constant K, used for the region diagnostics: 0 means the model's bound if it has one, else "
         "a local estimate from the step (Lemma g_taylor, inverted)."),
     .to = RS(opt.K), .bound = DTH__GE, .lo = 0, .note = "0: estimate K locally"},
    {KEY("integrator", "branch_check", BOOL, 0, "yes",
         "`yes`: every step's root is classified (docs/theory.md) and a ghost root is never taken; where no "
         "physical root lies ahead the run stops with a branch status. `no`: take whatever root Newton converges "
         "to, as raw DTH does (for comparison; it can silently follow a ghost)."),
     .to = RS(opt.branch_check), .choice = yes_no},
    {KEY("integrator", "reversible", BOOL, 0, "no",
         "`yes`: the reversible finish: each step and the step back from its end find the same root to about "
         "2^-100 (double-double unknowns and vertex offset, the model read at a coarsened midpoint), so a run "
         "reversed with `--roundtrip` comes back to its start (exactly: `bench_roundtrip`'s orbits at 10^4 and "
         "10^6 steps, and `--roundtrip` on the pendulum, Kepler and coupled scenes; a step whose root lies at the "
         "edge of the finish's coarse cells, about one per 10^6 steps, leaves a small error that grows with the "
         "steps after it: docs/theory.md, \"A step that is its own reverse\"). `prescribed`'s segments are finished "
         "the same way (docs/regularization.md); a step that is not its own reverse (`land`'s at a crossing and its "
         "clock-corrected ones, `prescribed`'s fallback) is counted on the end line, and the run warns that it does "
         "not retrace itself. It costs about 2.4 times the step "
         "on the smallest models (bench_floor, docs/performance.md) and needs a dense Hessian: with a banded "
         "solver the scene is refused (set `linsolve = dense`). `no`: the compensated constraint (the carried "
         "vertex offset), whose round trips are as good as the plain constraint's."),
     .to = RS(opt.finish), .choice = finish_yes_no},
    {KEY("integrator", "order", INTEGER, 0, "2",
         "The order of `method = dth`: `2`, the DTH step, or `4`, a composition of level-shifted DTH steps "
         "(docs/theory.md, \"Order 4\"): symplectic, wp kept bit for bit, quadratic momenta exact at vertices, "
         "its vertex energy O(h^4) and flat, its steps solved for like DTH's (tau ~ psi^(-1/2)). With order 4 "
         "both `start` modes mean the vertex z_0 = (q, t, p), wp = -H_phys there (or the explicit `[initial] "
         "wp`), rows are vertices (`points = midpoints` is refused: the substeps' midpoints lie on their levels, "
         "not on the energy surface), the dense output is of order 4, the error estimate's shadow is of order 6, "
         "and psi = 0 crossings are carried by the composition's own band (`band_time`) under the default "
         "regularizer `land` (land's replaced step and its parameters belong to order 2: giving them with order "
         "4 is refused, as is `prescribed`; with `[regularize] method = none` the run ends at the first "
         "crossing). `6` and `8` are refused: the construction measures order 4 with every 6th- and 8th-order "
         "table (docs/theory.md). Kepler e = 0.6 over 1000 orbits: order 4 takes 0.066 of the CPU of order 2 "
         "at equal error 1e-5 (`bench_order4 --full`, part 3). Baselines have their own order (leave it at 2)."),
     .to = RS(opt.order), .ilo = 2, .ihi = 8},
    {KEY("integrator", "table", CHOICE, 0, "",
         "Order 4's coefficient table (unset: `suzuki4`); order 2 refuses the key. The 6th- and 8th-order "
         "tables measure order 4 here, and their small coefficients lose the root of their substep at larger h."),
     .to = RS(opt.table), .choice = tables, .as_name = DTH__NAME_KNOWN},
    {KEY("integrator", "band_time", NUMBER, 0, "0",
         "Order 4 with the default regularizer: a psi = 0 crossing is carried by the band (prescribed-step "
         "compositions) from where it is less than 4 composite steps ahead (`0`, the default rule) or, with "
         "`band_time` > 0, also less than `band_time` ahead in time: a band fixed in phase space, which keeps "
         "order 4 through crossings (about 4.0 on the rotating pendulum with 0.6, on Kepler e = 0.9 with 0.2; "
         "the default rule gives about 2) at more band steps. Order 2 refuses a value other than 0."),
     .to = RS(opt.band_time), .bound = DTH__GE, .lo = 0, .note = "0: the default crossing rule"},
    {KEY("integrator", "estimate", BOOL, 0, "yes",
         "`yes`: the run carries an error estimate (a shadow trajectory of the classical Runge-Kutta method, "
         "Butcher's of order 6 for `order = 4`, with the run's own steps, projected onto the initial energy): "
         "the end line prints it, the rows' "
         "`err_q`, `err_p` columns hold it, and the run stops (exit 3) where the steps ran away from h and the "
         "estimate passed `stop_error` (docs/theory.md, \"The error estimate\"). It costs about four model "
         "gradients per step."),
     .to = RS(opt.estimate), .choice = yes_no},
    {KEY("integrator", "stop_error", NUMBER, 0, "0.25",
         "The run stops with status DTH_EACCURACY (exit 3) where a step exceeded `warn_ratio` h (or order 4's "
         "band carried most steps) and the "
         "estimated error in q or in p exceeds this fraction of the largest |q| or |p| so far."),
     .to = RS(stop_error), .bound = DTH__GE, .lo = 0, .note = "0: never stop"},
    {KEY("integrator", "warn_ratio", NUMBER, 0, "16",
         "A step larger than this multiple of |h| is reported on standard error (the step ran away from what h "
         "asked for), and arms the stop of `stop_error`. With `order = 4` the multiple is warn_ratio^(3/2) (64 "
         "by default): its steps follow tau^2 psi = const, where the DTH step's follow lambda^6 psi^2 = const, so "
         "the same change of psi moves its step by the 3/2 power of the ratio."),
     .to = RS(warn_ratio), .bound = DTH__GE, .lo = 0, .note = "0: never warn, never stop"},
    {KEY("integrator", "h_max", NUMBER, 0, "0",
         "The largest step the run may take. DTH's steps follow lambda^6 psi^2 = C; with `h_max` the run's "
         "constant C (its first step) is chosen before the first step, by silent pilot runs from the initial "
         "state to `pilot`, so that every step stays <= h_max (the step where psi is smallest sets the largest "
         "step). A later step above 1.05 h_max (a part of the orbit the pilots did not see) stops the run after "
         "it with exit 3, the rows kept. Needs `t_end` and `method = dth` with `order = 2`; the pilots cost about one run."),
     .to = RS(h_max), .bound = DTH__GE, .lo = 0, .note = "0: no bound"},
    {KEY("integrator", "tol", NUMBER, 0, "0",
         "The estimated global position error |q - q_exact| at `t_end` the run aims at: pilot runs with the "
         "error estimate (`estimate`) find C such that the estimate, which grows as C^(1/3) (lambda^2), ends "
         "at about tol / 2. Where the last pilot ended before `t_end` (`pilot`, or a step that failed), its "
         "estimate is extrapolated linearly in time and `dth run` says so. With `h_max` as well, the smaller "
         "constant wins. Needs `t_end` and `method = dth` with `order = 2`."),
     .to = RS(tol), .bound = DTH__GE, .lo = 0, .note = "0: none"},
    {KEY("integrator", "pilot", NUMBER, 0, "",
         "The time the pilots of `h_max` and `tol` run to (between `t` and `t_end`; default `t_end`): for a periodic orbit one "
         "period sees all of it at a fraction of the cost; `tol` then extrapolates the estimate to `t_end`."),
     .to = RS(pilot)},
    {KEY("integrator", "linsolve", CHOICE, 0, "auto",
         "The linear solver of the step's Newton system: all give the same steps to round-off and differ in cost "
         "(docs/performance.md; more below the table). The banded ones need a model with a banded Hessian."),
     .to = RS(opt.linsolve), .choice = linsolves},

    /* [output] */
    {KEY("output", "file", TEXT, 0, "standard output",
         "Output path, relative to the current directory; missing folders are created. A name ending in `.h5` "
         "or `.hdf5` writes HDF5, any other CSV. The `-o` option wins over it."),
     .to = RS(out_file), .note = "leave the key out to write to standard output"},
    {KEY("output", "points", CHOICE, 0, "auto",
         "Which points of the trajectory are rows (\"Why midpoint rows are the default\" below)."),
     .to = X(points), .choice = points},
    {KEY("output", "every", INTEGER, 0, "1",
         "Write every `every`-th vertex or midpoint (k = 0, every, 2 every, ...). With vertex rows the end of the "
         "run is always written."),
     .to = RS(every), .ilo = 1, .ihi = LONG_MAX},
    {KEY("output", "dt", NUMBER, 0, "0",
         "If > 0, write the trajectory at the output times t0, t0 +- dt, t0 +- 2 dt, ... (and at `t_end`) by "
         "dense output of the method's order (below), instead of vertices or midpoints. Cannot be combined with "
         "`every` > 1 or an explicit `points`."),
     .to = RS(dt), .bound = DTH__GE, .lo = 0, .note = "0: vertices or midpoints"},
    {KEY("output", "diagnostics", BOOL, 0, "no",
         "Adds the model's invariants and `psi,dpsi,region,iters,branch` to the rows, and `err_q,err_p` (the "
         "estimated global error at the row) with an estimate."),
     .to = RS(diagnostics), .choice = yes_no},

    /* [events] */
    {KEY("events", "section", COORDINATE, 0, "",
         "A Poincare section: an event where this coordinate crosses `section_value`."),
     .to = X(section)},
    {KEY("events", "section_value", NUMBER, 0, "0", "The value of the section."), .to = X(section_value)},
    {KEY("events", "section_direction", CHOICE, 0, "up", "Which crossings of the section count."),
     .to = X(section_direction), .choice = directions},
    {KEY("events", "section_terminal", BOOL, 0, "no", "`yes`: the run ends at the first such crossing."),
     .to = X(section_terminal), .choice = yes_no},
    {KEY("events", "time", NUMBERS, 0, "", "Times: an event row at each (exactly at that time)."), .to = X(times),
     .count = X(ntimes)},
    {KEY("events", "time_terminal", BOOL, 0, "no", "`yes`: the run ends at the first of them."),
     .to = X(time_terminal), .choice = yes_no},
    {KEY("events", "distance", NUMBER, 0, "",
         "A radius R: an event where |q| (over `distance_dofs`) crosses R: escape (`up`) or collision (`down`)."),
     .to = X(distance), .bound = DTH__GT, .lo = 0},
    {KEY("events", "distance_dofs", DOFS, 0, "all",
         "The degrees of freedom |q| is taken over, e.g. `1,2` for the first body of a planar model."),
     .to = X(dofs), .count = X(ndofs)},
    {KEY("events", "distance_direction", CHOICE, 0, "both", "Which crossings of the radius count."),
     .to = X(distance_direction), .choice = directions},
    {KEY("events", "distance_terminal", BOOL, 0, "no", "`yes`: the run ends at the first such crossing."),
     .to = X(distance_terminal), .choice = yes_no},
    {KEY("events", "file", TEXT, 0, "OUT-events.csv",
         "The events CSV (next to the trajectory's `OUT.csv`). Needed when the trajectory goes to standard "
         "output."),
     .to = RS(events_file)},
};
enum { NKEYS = sizeof keys / sizeof keys[0] };

/* The sections, in the order messages list them. */
static const struct {
    const char *name;
    int kind;
} sections[] = {
    {"model", DTH__SECTION_MODEL},   {"initial", DTH__SECTION_KEYS},         {"integrator", DTH__SECTION_KEYS},
    {"regularize", DTH__SECTION_REGULARIZE}, {"output", DTH__SECTION_KEYS}, {"events", DTH__SECTION_KEYS},
};
enum { NSECTIONS = sizeof sections / sizeof sections[0] };

int dth__scene_section_kind(const char *section)
{
    for (size_t i = 0; section && i < NSECTIONS; i++)
        if (!strcmp(sections[i].name, section)) return sections[i].kind;
    return DTH__SECTION_UNKNOWN;
}

const dth__scene_key *dth__scene_key_get(size_t i) { return i < NKEYS ? &keys[i] : NULL; }

const dth__scene_key *dth__scene_key_find(const char *section, const char *key)
{
    for (size_t i = 0; section && key && i < NKEYS; i++)
        if (!strcmp(keys[i].info.section, section) && !strcmp(keys[i].info.key, key)) return &keys[i];
    return NULL;
}

void dth__scene_defaults(dth_run_setup *rs, dth__scene_extra *x, const dth_allocator *alloc)
{
    memset(rs, 0, sizeof *rs);
    rs->alloc = alloc;
    dth_options_default(&rs->opt);
    rs->opt.alloc = alloc;
    rs->opt.estimate = 1; /* scene runs report an error estimate (integrator.h) */
    rs->stop_error = 0.25;
    rs->warn_ratio = 16;
    rs->pilot = NAN;
    snprintf(rs->method, sizeof rs->method, "dth");
    snprintf(rs->regularize, sizeof rs->regularize, "none");
    rs->every = 1;
    memset(x, 0, sizeof *x);
    x->points = -1;
    x->section_direction = 1;
    x->distance_direction = 0;
}

void dth__scene_extra_clear(dth__scene_extra *x, const dth_allocator *alloc)
{
    dth_free(alloc, x->times);
    dth_free(alloc, x->dofs);
    x->times = NULL;
    x->dofs = NULL;
    x->ntimes = x->ndofs = 0;
}

/* ---------------------------------------------------------------- parsing */

static void *slot_at(const dth__scene_slot *s, const dth__scene_target *t)
{
    if (s->base == DTH__IN_SETUP) return (char *)t->rs + s->off;
    if (s->base == DTH__IN_EXTRA) return (char *)t->x + s->off;
    return NULL;
}

static void store_int(const dth__scene_slot *s, const dth__scene_target *t, long v)
{
    void *p = slot_at(s, t);
    if (!p) return;
    if (s->size == sizeof(int)) {
        int i = (int)v;
        memcpy(p, &i, sizeof i);
    } else {
        memcpy(p, &v, sizeof v);
    }
}

/* Replace an owned pointer member (a list or a string) by p. */
static void store_owned(const dth__scene_slot *s, const dth__scene_target *t, void *p)
{
    void *old;
    char *at = slot_at(s, t);
    memcpy(&old, at, sizeof old);
    dth_free(t->alloc, old);
    memcpy(at, &p, sizeof p);
}

/* A count: a whole-string decimal integer, or a number with an integer value ("1e6"), in [lo, hi].
 * 0, or PARSE_NOT_INT, PARSE_LOW / PARSE_HIGH (an integer below lo, above hi). */
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

/* Append to buf as snprintf would, *n counting every character asked for (also past len). */
static void add(char *buf, size_t len, size_t *n, const char *fmt, ...) __attribute__((format(printf, 4, 5)));
static void add(char *buf, size_t len, size_t *n, const char *fmt, ...)
{
    va_list ap;
    va_start(ap, fmt);
    int w = vsnprintf(buf && *n < len ? buf + *n : NULL, buf && *n < len ? len - *n : 0, fmt, ap);
    va_end(ap);
    if (w > 0) *n += (size_t)w;
}

size_t dth__scene_key_describe(const dth__scene_key *k, char *buf, size_t len)
{
    size_t n = 0;
    const char *note = k->note;
    if (buf && len) buf[0] = '\0';
    switch (k->info.type) {
    case DTH_SCENE_NUMBER:
        add(buf, len, &n, "a finite number");
        if (k->bound == DTH__GE) add(buf, len, &n, " >= %g", k->lo);
        if (k->bound == DTH__GT) add(buf, len, &n, " > %g", k->lo);
        if (k->bound == DTH__NONZERO) {
            add(buf, len, &n, " (nonzero%s%s)", note ? ": " : "", note ? note : "");
            note = NULL;
        }
        break;
    case DTH_SCENE_INTEGER:
        if (k->ihi == LONG_MAX) add(buf, len, &n, "an integer >= %ld", k->ilo);
        else add(buf, len, &n, "an integer in %ld..%ld", k->ilo, k->ihi);
        break;
    case DTH_SCENE_BOOL:
        add(buf, len, &n, "yes or no");
        break;
    case DTH_SCENE_CHOICE: {
        dth__choice c;
        add(buf, len, &n, "one of");
        for (size_t j = 0, listed = 0; k->choice(j, &c); j++)
            if (!c.alias) add(buf, len, &n, "%s %s", listed++ ? "," : "", c.name);
        break;
    }
    case DTH_SCENE_NUMBERS:
        add(buf, len, &n, "a comma-separated list of finite numbers");
        break;
    case DTH_SCENE_DOFS:
        add(buf, len, &n, "a comma-separated list of degrees of freedom (1-based)");
        break;
    case DTH_SCENE_TEXT:
        add(buf, len, &n, "a file name");
        break;
    case DTH_SCENE_COORDINATE:
        add(buf, len, &n, "a coordinate q<i> or p<i> (1-based i)");
        break;
    }
    if (note) add(buf, len, &n, " (%s)", note);
    return n;
}

/* "'v' is not <what the key accepts>" */
static int refuse(const dth__scene_key *k, const char *v, char *msg, size_t len)
{
    char what[512];
    dth__scene_key_describe(k, what, sizeof what);
    dth__set_err(msg, len, "'%s' is not %s", v, what);
    return DTH_EINVAL;
}

/* distance_dofs: integers >= 1 separated by commas or blanks, as given (1-based); an empty list is
 * refused once the events are built (after the rules between the [events] keys). */
static int parse_dofs(const dth__scene_key *k, const char *v, const dth__scene_target *t, char *msg, size_t len)
{
    size_t *d = dth_calloc(t->alloc, strlen(v) / 2 + 1, sizeof *d), m = 0;
    if (!d) return DTH_ENOMEM;
    for (const char *p = v;;) {
        while (*p == ' ' || *p == '\t' || *p == ',') p++;
        if (!*p) break;
        char *end;
        errno = 0;
        long x = *p >= '0' && *p <= '9' ? strtol(p, &end, 10) : 0;
        if (x < 1 || errno == ERANGE || (*end && !strchr(" \t,", *end))) {
            dth_free(t->alloc, d);
            return refuse(k, v, msg, len);
        }
        d[m++] = (size_t)x;
        p = end;
    }
    store_owned(&k->to, t, d);
    memcpy(slot_at(&k->count, t), &m, sizeof m);
    return DTH_OK;
}

static int parse_number(const dth__scene_key *k, const char *v, const dth__scene_target *t, char *msg, size_t len)
{
    double d;
    if (dth_parse_double(v, &d)) return refuse(k, v, msg, len);
    int in = k->bound == DTH__GE ? d >= k->lo : k->bound == DTH__GT ? d > k->lo : k->bound == DTH__NONZERO ? d != 0 : 1;
    if (!in && k->refuse) {
        dth__set_err(msg, len, "%s", k->refuse);
        return DTH_EINVAL;
    }
    if (!in) return refuse(k, v, msg, len);
    memcpy(slot_at(&k->to, t), &d, sizeof d);
    if (k->given.base) store_int(&k->given, t, 1);
    return DTH_OK;
}

static int parse_choice(const dth__scene_key *k, const char *v, const dth__scene_target *t, char *msg, size_t len)
{
    dth__choice c;
    const char *name = NULL;
    for (size_t j = 0; !name && k->choice(j, &c); j++)
        if (!strcmp(c.name, v)) name = c.name;
    if (!name && k->as_name != DTH__NAME_GIVEN) return refuse(k, v, msg, len);
    if (k->as_name) {
        /* the static name; an unknown one as given, for dth_options_check to refuse with its message */
        const char *p = name ? name : v;
        memcpy(slot_at(&k->to, t), &p, sizeof p);
    } else {
        store_int(&k->to, t, c.value);
    }
    return DTH_OK;
}

int dth__scene_key_parse(const dth__scene_key *k, const char *v, const dth__scene_target *t, char *msg, size_t len)
{
    long x;
    int pr;
    switch (k->info.type) {
    case DTH_SCENE_NUMBER:
        return parse_number(k, v, t, msg, len);
    case DTH_SCENE_INTEGER:
        pr = parse_long(v, k->ilo, k->ihi, &x);
        if (pr == PARSE_HIGH) {
            dth__set_err(msg, len, "'%s' is too large (an integer from %ld to %ld)", v, k->ilo, k->ihi);
            return DTH_EINVAL;
        }
        if (pr) return refuse(k, v, msg, len);
        store_int(&k->to, t, x);
        return DTH_OK;
    case DTH_SCENE_BOOL:
    case DTH_SCENE_CHOICE:
        return parse_choice(k, v, t, msg, len);
    case DTH_SCENE_NUMBERS: {
        size_t max = count_items(v), n;
        double *a = dth_calloc(t->alloc, max, sizeof *a);
        if (!a) return DTH_ENOMEM;
        if (dth__parse_list(v, a, max, &n)) {
            dth_free(t->alloc, a);
            return refuse(k, v, msg, len);
        }
        store_owned(&k->to, t, a);
        memcpy(slot_at(&k->count, t), &n, sizeof n);
        return DTH_OK;
    }
    case DTH_SCENE_DOFS:
        return parse_dofs(k, v, t, msg, len);
    case DTH_SCENE_TEXT: {
        if (!v[0]) {
            char what[256];
            dth__scene_key_describe(k, what, sizeof what);
            dth__set_err(msg, len, "an empty value is not %s", what);
            return DTH_EINVAL;
        }
        size_t l = strlen(v);
        char *d = dth_calloc(t->alloc, l + 1, 1);
        if (!d) return DTH_ENOMEM;
        memcpy(d, v, l);
        store_owned(&k->to, t, d);
        return DTH_OK;
    }
    case DTH_SCENE_COORDINATE:
        if ((v[0] != 'q' && v[0] != 'p') || parse_long(v + 1, 1, 1000000000L, &x)) return refuse(k, v, msg, len);
        store_int(&k->to, t, v[0] == 'q' ? x : -x);
        return DTH_OK;
    }
    return refuse(k, v, msg, len);
}

/* ---------------------------------------------------------------- unknown names, "did you mean" */

/* Edit distance with adjacent swaps (optimal string alignment); SIZE_MAX for names over 63 characters. */
static size_t distance(const char *a, const char *b)
{
    size_t la = strlen(a), lb = strlen(b);
    if (la > 63 || lb > 63) return SIZE_MAX;
    unsigned char d[64][64];
    for (size_t i = 0; i <= la; i++) d[i][0] = (unsigned char)i;
    for (size_t j = 0; j <= lb; j++) d[0][j] = (unsigned char)j;
    for (size_t i = 1; i <= la; i++)
        for (size_t j = 1; j <= lb; j++) {
            unsigned v = d[i - 1][j - 1] + (a[i - 1] != b[j - 1]);
            if (d[i - 1][j] + 1u < v) v = d[i - 1][j] + 1u;
            if (d[i][j - 1] + 1u < v) v = d[i][j - 1] + 1u;
            if (i > 1 && j > 1 && a[i - 1] == b[j - 2] && a[i - 2] == b[j - 1] && d[i - 2][j - 2] + 1u < v)
                v = d[i - 2][j - 2] + 1u;
            d[i][j] = (unsigned char)v;
        }
    return d[la][lb];
}

void dth__suggest_init(dth__suggest *s, const char *word)
{
    s->word = word;
    s->best = NULL;
    s->dist = SIZE_MAX;
}

/* Close means at most two edits, and fewer than the word has characters (x is not "close" to t). */
void dth__suggest_offer(dth__suggest *s, const char *candidate)
{
    size_t d = distance(s->word, candidate);
    if (d <= 2 && d < strlen(s->word) && d < s->dist) {
        s->best = candidate;
        s->dist = d;
    }
}

void dth__scene_unknown_key(const char *section, const char *key, char *msg, size_t len)
{
    char known[512];
    size_t n = 0;
    const char *elsewhere = NULL; /* a section that has this very key */
    dth__suggest sg;
    dth__suggest_init(&sg, key);
    for (size_t i = 0; i < NKEYS; i++) {
        if (strcmp(keys[i].info.section, section)) {
            if (!elsewhere && !strcmp(keys[i].info.key, key)) elsewhere = keys[i].info.section;
            continue;
        }
        add(known, sizeof known, &n, "%s%s", n ? ", " : "", keys[i].info.key);
        dth__suggest_offer(&sg, keys[i].info.key);
    }
    if (sg.best) dth__set_err(msg, len, "unknown key (known in [%s]: %s); did you mean %s?", section, known, sg.best);
    else if (elsewhere) dth__set_err(msg, len, "unknown key (known in [%s]: %s); did you mean %s.%s?", section, known,
                                     elsewhere, key);
    else dth__set_err(msg, len, "unknown key (known in [%s]: %s)", section, known);
}

void dth__scene_unknown_section(const char *section, char *msg, size_t len)
{
    char known[256];
    size_t n = 0;
    dth__suggest sg;
    dth__suggest_init(&sg, section);
    for (size_t i = 0; i < NSECTIONS; i++) {
        add(known, sizeof known, &n, "%s%s", i ? ", " : "", sections[i].name);
        dth__suggest_offer(&sg, sections[i].name);
    }
    if (sg.best)
        dth__set_err(msg, len, "unknown section [%s] (known: %s); did you mean [%s]?", section, known, sg.best);
    else
        dth__set_err(msg, len, "unknown section [%s] (known: %s)", section, known);
}

/* ---------------------------------------------------------------- the public listing */

size_t dth_scene_key_count(void) { return NKEYS; }

const dth_scene_key_info *dth_scene_key_at(size_t i) { return i < NKEYS ? &keys[i].info : NULL; }

const char *dth_scene_key_choice(size_t i, size_t j, const char **doc)
{
    if (doc) *doc = NULL;
    if (i >= NKEYS || !keys[i].choice) return NULL;
    dth__choice c;
    for (size_t m = 0, listed = 0; keys[i].choice(m, &c); m++)
        if (!c.alias && listed++ == j) {
            if (doc) *doc = c.doc;
            return c.name;
        }
    return NULL;
}

size_t dth_scene_key_describe(size_t i, char *buf, size_t len)
{
    if (i < NKEYS) return dth__scene_key_describe(&keys[i], buf, len);
    if (buf && len) buf[0] = '\0';
    return 0;
}
