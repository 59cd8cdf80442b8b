/* SPDX-License-Identifier: MIT */
/*
 * Coupled oscillators in Cartesian coordinates: N point masses in d = 1..3 dimensions joined by
 * springs V = k/2 (|x_i - x_j| - L)^2 (and optional anchor springs to fixed points). With L > 0
 * H is not quadratic. Provides the exact D^3 H[u,u,u] for psi' (paper, Lemma g_taylor), linear
 * and angular momentum, and the banded Hessian used by the banded step solve (lib/banded.c).
 */
#include <math.h>
#include <stdio.h>
#include <stdint.h>
#include <string.h>
#include "dth/models.h"

/* One spring between particles i and j (0-based), or an anchor (j unused, a = fixed point). */
typedef struct spring {
    size_t i, j;
    double k, L;
    double a[3];
} spring;

typedef struct coupled {
    size_t N, dim, n;  /* particles, space dimension, degrees of freedom N*dim */
    size_t ns, na;     /* springs, anchors */
    size_t w;          /* half-bandwidth of the Hessian in the interleaved layout */
    double *minv;      /* 1/m_i per particle */
    spring *spr, *anc; /* ns springs, na anchors */
} coupled;

static const dth_param_spec params[] = {
    {"particles", NULL, "number of particles N (required unless preset= is given)"},
    {"dim", "2", "dimension of space: 1, 2 or 3"},
    {"mass", "1", "masses: one value or N comma-separated values (> 0)"},
    {"spring*", NULL, "springK = i,j,k,L: spring between particles i and j (1-based), stiffness k >= 0, rest length L >= 0"},
    {"anchor*", NULL, "anchorK = i,k,L,ax[,ay[,az]]: spring from particle i to the fixed point a"},
    {"preset", NULL, "generated spring graph: chain (N = size in a line), ring (closed chain), lattice (size x size grid)"},
    {"size", NULL, "preset size (chain, ring: particles; lattice: particles per side)"},
    {"k", "1", "preset spring stiffness (>= 0)"},
    {"L", "1", "preset spring rest length (>= 0)"},
    {"structure", "auto", "Hessian structure declared to the integrator: auto (banded when narrow), banded, dense"},
};

/* Invariant names: linear momentum for each axis, then angular momentum (d = 2: Lz). */
static const char *const inv_names[4][6] = {
    {NULL},
    {"Px"},
    {"Px", "Py", "Lz"},
    {"Px", "Py", "Pz", "Lx", "Ly", "Lz"},
};
static const size_t inv_count[4] = {0, 1, 3, 6};

enum { MAX_PARTICLES = 10000000 };

static void destroy(void *self, const dth_allocator *alloc)
{
    coupled *c = self;
    if (!c) return;
    dth_free(alloc, c->minv);
    dth_free(alloc, c->spr);
    dth_free(alloc, c->anc);
    dth_free(alloc, c);
}

/* A non-negative integer parameter (absent: def). */
static int args_count(const dth_model_args *a, const char *key, double def, size_t max, size_t *out)
{
    double v;
    int rc = dth_args_double(a, key, def, &v);
    if (rc) return rc;
    if (v < 0 || v != floor(v) || v > (double)max)
        return dth_args_error(a, "parameter '%s' must be an integer in 0..%zu (got %g)", key, max, v);
    *out = (size_t)v;
    return DTH_OK;
}

/* 1-based particle index v of key into 0-based *i. */
static int particle_index(const dth_model_args *a, const char *key, double v, size_t N, size_t *i)
{
    if (v != floor(v) || v < 1 || v > (double)N)
        return dth_args_error(a, "parameter '%s': particle %g does not exist (particles are 1..%zu)", key, v, N);
    *i = (size_t)v - 1;
    return DTH_OK;
}

static int has_prefix(const char *s, const char *p) { return strncmp(s, p, strlen(p)) == 0; }

/* Index of kv entry i's key if it is the last entry with that key (dth_args_get's "last wins"). */
static int is_last(const dth_model_args *a, size_t i)
{
    for (size_t j = i + 1; j < a->nkv; j++)
        if (strcmp(a->kv[j].key, a->kv[i].key) == 0) return 0;
    return 1;
}

/* Parse the explicit springs (keys spring...) or anchors (keys anchor...), appending to out. */
static int parse_explicit(const dth_model_args *a, const coupled *c, int anchor, spring *out, size_t *cnt)
{
    const char *prefix = anchor ? "anchor" : "spring";
    for (size_t e = 0; e < a->nkv; e++) {
        const char *key = a->kv[e].key;
        if (!has_prefix(key, prefix) || !is_last(a, e)) continue;
        double v[6];
        size_t nv = 0;
        int rc = dth_args_list(a, key, v, anchor ? 3 + c->dim : 4, &nv);
        if (rc) return rc;
        spring s = {0};
        if (anchor) {
            if (nv < 4) return dth_args_error(a, "parameter '%s' needs i,k,L and %zu anchor coordinates", key, c->dim);
            rc = particle_index(a, key, v[0], c->N, &s.i);
            if (rc) return rc;
            s.k = v[1];
            s.L = v[2];
            for (size_t x = 0; x + 3 < nv; x++) s.a[x] = v[3 + x];
        } else {
            if (nv != 4) return dth_args_error(a, "parameter '%s' needs 4 values i,j,k,L (got %zu)", key, nv);
            rc = particle_index(a, key, v[0], c->N, &s.i);
            if (!rc) rc = particle_index(a, key, v[1], c->N, &s.j);
            if (rc) return rc;
            if (s.i == s.j) return dth_args_error(a, "parameter '%s': a spring needs two different particles (got %g twice)", key, v[0]);
            s.k = v[2];
            s.L = v[3];
        }
        if (!(s.k >= 0)) return dth_args_error(a, "parameter '%s': stiffness must be >= 0 (got %g)", key, s.k);
        if (!(s.L >= 0)) return dth_args_error(a, "parameter '%s': rest length must be >= 0 (got %g)", key, s.L);
        out[(*cnt)++] = s;
    }
    return DTH_OK;
}

static size_t count_prefix(const dth_model_args *a, const char *prefix)
{
    size_t k = 0;
    for (size_t e = 0; e < a->nkv; e++) k += has_prefix(a->kv[e].key, prefix) && is_last(a, e);
    return k;
}

static int create(const dth_model_args *a, void **self, dth_model_info *info)
{
    size_t dim, N = 0, size = 0;
    int rc = args_count(a, "dim", 2, 3, &dim);
    if (rc) return rc;
    if (dim < 1) return dth_args_error(a, "parameter 'dim' must be 1, 2 or 3");
    const char *preset = dth_args_get(a, "preset");
    int kind = 0; /* 0 explicit, 1 chain, 2 ring, 3 lattice */
    if (preset) {
        if (strcmp(preset, "chain") == 0) kind = 1;
        else if (strcmp(preset, "ring") == 0) kind = 2;
        else if (strcmp(preset, "lattice") == 0) kind = 3;
        else return dth_args_error(a, "parameter 'preset' must be chain, ring or lattice (got '%s')", preset);
        if (!dth_args_get(a, "size")) return dth_args_error(a, "parameter 'size' is required with preset=%s", preset);
        rc = args_count(a, "size", 0, kind == 3 ? 3162 : MAX_PARTICLES, &size);
        if (rc) return rc;
        size_t min = kind == 2 ? 3 : 2;
        if (size < min) return dth_args_error(a, "parameter 'size' must be >= %zu for preset=%s", min, preset);
        N = kind == 3 ? size * size : size;
    } else if (dth_args_get(a, "size")) {
        return dth_args_error(a, "parameter 'size' needs preset=");
    }
    if (dth_args_get(a, "particles") || !preset) {
        size_t Np;
        if (!dth_args_get(a, "particles")) return dth_args_error(a, "parameter 'particles' is required (or give preset=)");
        rc = args_count(a, "particles", 0, MAX_PARTICLES, &Np);
        if (rc) return rc;
        if (Np == 0) return dth_args_error(a, "parameter 'particles' must be >= 1");
        if (preset && Np != N)
            return dth_args_error(a, "parameter 'particles' = %zu contradicts preset=%s with size %zu (%zu particles)", Np, preset, size, N);
        N = Np;
    }
    double k, L;
    rc = dth_args_double(a, "k", 1.0, &k);
    if (!rc) rc = dth_args_double(a, "L", 1.0, &L);
    if (rc) return rc;
    if (!(k >= 0)) return dth_args_error(a, "parameter 'k' must be >= 0 (got %g)", k);
    if (!(L >= 0)) return dth_args_error(a, "parameter 'L' must be >= 0 (got %g)", L);
    const char *st = dth_args_get(a, "structure");
    int structure = 0; /* 0 auto, 1 banded, 2 dense */
    if (st) {
        if (strcmp(st, "banded") == 0) structure = 1;
        else if (strcmp(st, "dense") == 0) structure = 2;
        else if (strcmp(st, "auto") != 0) return dth_args_error(a, "parameter 'structure' must be auto, banded or dense (got '%s')", st);
    }

    if (a->n_hint && a->n_hint != N * dim)
        return dth_args_error(a, "%zu particles in %zu dimensions need %zu q values (got %zu): check 'particles'/'size' and 'dim'",
                              N, dim, N * dim, a->n_hint);
    coupled *c = dth_calloc(a->alloc, 1, sizeof *c);
    if (!c) return DTH_ENOMEM;
    *self = c; /* dth_model_new destroys it on failure */
    c->N = N;
    c->dim = dim;
    c->n = N * dim;
    size_t npre = kind == 1 ? N - 1 : kind == 2 ? N : kind == 3 ? 2 * size * (size - 1) : 0;
    size_t nexp = count_prefix(a, "spring"), nanc = count_prefix(a, "anchor");
    c->minv = dth_calloc(a->alloc, N, sizeof *c->minv);
    c->spr = dth_calloc(a->alloc, npre + nexp, sizeof *c->spr);
    c->anc = dth_calloc(a->alloc, nanc, sizeof *c->anc);
    if (!c->minv || !c->spr || !c->anc) return DTH_ENOMEM;

    /* masses: one value or N (parsed into minv, then inverted) */
    size_t nm = 0;
    rc = dth_args_list(a, "mass", c->minv, N, &nm);
    if (rc) return rc;
    if (nm > 1 && nm != N) return dth_args_error(a, "parameter 'mass' has %zu values, expected 1 or %zu", nm, N);
    double m0 = nm == 0 ? 1.0 : c->minv[0]; /* minv[0] is overwritten below */
    for (size_t i = 0; i < N; i++) {
        double m = nm <= 1 ? m0 : c->minv[i];
        if (!(m > 0)) return dth_args_error(a, "parameter 'mass': value %zu must be > 0 (got %g)", nm == 1 ? 1 : i + 1, m);
        c->minv[i] = 1 / m;
    }

    /* the preset's springs, then the explicit ones */
    if (kind == 1 || kind == 2)
        for (size_t i = 0; i < npre; i++) c->spr[c->ns++] = (spring){.i = i, .j = (i + 1) % N, .k = k, .L = L};
    if (kind == 3)
        for (size_t r = 0; r < size; r++)
            for (size_t s = 0; s < size; s++) {
                size_t p = r * size + s;
                if (s + 1 < size) c->spr[c->ns++] = (spring){.i = p, .j = p + 1, .k = k, .L = L};
                if (r + 1 < size) c->spr[c->ns++] = (spring){.i = p, .j = p + size, .k = k, .L = L};
            }
    rc = parse_explicit(a, c, 0, c->spr, &c->ns);
    if (!rc) rc = parse_explicit(a, c, 1, c->anc, &c->na);
    if (rc) return rc;

    /* bandwidth in x = (q_1, p_1, ...): q-index a = particle*dim + axis sits at 2a */
    size_t span = c->na ? dim - 1 : 0;
    for (size_t s = 0; s < c->ns; s++) {
        size_t di = c->spr[s].i > c->spr[s].j ? c->spr[s].i - c->spr[s].j : c->spr[s].j - c->spr[s].i;
        if ((di + 1) * dim - 1 > span) span = (di + 1) * dim - 1;
    }
    c->w = 2 * span;
    /* auto: banded when the band is narrower than half the matrix (a ring is dense: its closing
     * spring couples the first and last particle) */
    int banded = structure == 1 || (structure == 0 && c->w < c->n);
    *info = (dth_model_info){.n = c->n, .autonomous = 1, .separable = 1,
                             .hess_kind = banded ? DTH_HESS_BANDED : DTH_HESS_DENSE,
                             .bandwidth = banded ? c->w : 0};
    return DTH_OK;
}

/*
 * Geometry of spring s at positions q: r = x_i - x_j (or x_i - a), its length, and
 * f = 1 - L/|r| (the force is -k f r). Returns 1 if L > 0 and |r| = 0 (the force is singular).
 */
static int geometry(const coupled *c, const spring *s, int anchor, const double *q, double *r, double *len, double *f)
{
    const double *xi = q + s->i * c->dim, *xj = anchor ? s->a : q + s->j * c->dim;
    double r2 = 0;
    for (size_t x = 0; x < c->dim; x++) {
        r[x] = xi[x] - xj[x];
        r2 += r[x] * r[x];
    }
    *len = sqrt(r2);
    if (s->L == 0) {
        *f = 1;
        return 0;
    }
    if (!(*len > 0)) return 1;
    *f = 1 - s->L / *len;
    return 0;
}

/* Position index of spring s's second end (anchors have none: SIZE_MAX). */
static size_t second(const coupled *c, const spring *s, int anchor) { return anchor ? SIZE_MAX : s->j * c->dim; }

/*
 * Add the q-q Hessian of the potential into out at out[a * ra + b * rb + off] for q-indices
 * a, b: the dense Hessian over y (ra = 2n+1, rb = 1, off = 0) and the banded one over the
 * interleaved x (ra = 2(2w+1) - 2, rb = 2, off = w) share this one accumulation order, so the
 * two agree bit for bit. Block K = k (f I + (L/|r|^3) r r^T); +K on ii, jj and -K on ij, ji.
 */
static int add_q_hessian(const coupled *c, const double *q, double *out, size_t ra, size_t rb, size_t off)
{
    size_t dim = c->dim;
    for (int anchor = 0; anchor < 2; anchor++) {
        size_t cnt = anchor ? c->na : c->ns;
        const spring *sp = anchor ? c->anc : c->spr;
        for (size_t s = 0; s < cnt; s++) {
            double r[3], len, f, K[9];
            if (geometry(c, &sp[s], anchor, q, r, &len, &f)) return 1;
            double g = sp[s].L == 0 ? 0 : sp[s].L / (len * len * len);
            for (size_t x = 0; x < dim; x++)
                for (size_t y = 0; y < dim; y++) K[x * dim + y] = sp[s].k * ((x == y ? f : 0) + g * (r[x] * r[y])); /* symmetric bit for bit */
            size_t bi = sp[s].i * dim, bj = second(c, &sp[s], anchor);
            for (size_t x = 0; x < dim; x++)
                for (size_t y = 0; y < dim; y++) {
                    double v = K[x * dim + y];
                    out[(bi + x) * ra + (bi + y) * rb + off] += v;
                    if (bj == SIZE_MAX) continue;
                    out[(bj + x) * ra + (bj + y) * rb + off] += v;
                    out[(bi + x) * ra + (bj + y) * rb + off] -= v;
                    out[(bj + x) * ra + (bi + y) * rb + off] -= v;
                }
        }
    }
    return 0;
}

static int eval(const void *self, const double *y, unsigned what, double *H, double *g, double *hs)
{
    const coupled *c = self;
    size_t n = c->n, d = 2 * n + 1, dim = c->dim;
    const double *q = y, *p = y + n + 1;
    if (what & DTH_EVAL_GRAD) {
        for (size_t i = 0; i < n; i++) g[i] = 0;
        g[n] = 0;
        for (size_t i = 0; i < n; i++) g[n + 1 + i] = p[i] * c->minv[i / dim];
    }
    double V = 0;
    for (int anchor = 0; anchor < 2; anchor++) {
        size_t cnt = anchor ? c->na : c->ns;
        const spring *sp = anchor ? c->anc : c->spr;
        for (size_t s = 0; s < cnt; s++) {
            double r[3], len, f;
            if (geometry(c, &sp[s], anchor, q, r, &len, &f)) return 1;
            double e = len - sp[s].L;
            V += 0.5 * sp[s].k * e * e;
            if (!(what & DTH_EVAL_GRAD)) continue;
            size_t bi = sp[s].i * dim, bj = second(c, &sp[s], anchor);
            for (size_t x = 0; x < dim; x++) {
                double F = sp[s].k * f * r[x];
                g[bi + x] += F;
                if (bj != SIZE_MAX) g[bj + x] -= F;
            }
        }
    }
    if (what & DTH_EVAL_H) {
        double T = 0;
        for (size_t i = 0; i < n; i++) T += 0.5 * p[i] * p[i] * c->minv[i / dim];
        *H = T + V;
    }
    if (what & DTH_EVAL_HESS) {
        memset(hs, 0, d * d * sizeof *hs);
        for (size_t i = 0; i < n; i++) hs[(n + 1 + i) * d + (n + 1 + i)] = c->minv[i / dim];
        if (add_q_hessian(c, q, hs, d, 1, 0)) return 1;
    }
    return 0;
}

/*
 * H(y1) - H(y0) spring by spring: k/2 ((|r1| - L)^2 - (|r0| - L)^2) = k/2 (|r1| - |r0|)(|r1| + |r0| - 2L)
 * with |r1| - |r0| = (r1 - r0).(r1 + r0) / (|r1| + |r0|), and the kinetic terms as (p1 - p0)(p1 + p0):
 * no cancellation of the energy's size, exactly antisymmetric in (y1, y0).
 */
static int hdiff(const void *self, const double *y1, const double *y0, double *dH)
{
    const coupled *c = self;
    size_t n = c->n, dim = c->dim;
    double s = 0;
    for (size_t i = 0; i < n; i++) {
        double a = y1[n + 1 + i], b = y0[n + 1 + i];
        s += 0.5 * (a - b) * (a + b) * c->minv[i / dim];
    }
    for (int anchor = 0; anchor < 2; anchor++) {
        size_t cnt = anchor ? c->na : c->ns;
        const spring *sp = anchor ? c->anc : c->spr;
        for (size_t k = 0; k < cnt; k++) {
            const double *x1 = y1 + sp[k].i * dim, *x0 = y0 + sp[k].i * dim;
            const double *z1 = anchor ? sp[k].a : y1 + sp[k].j * dim, *z0 = anchor ? sp[k].a : y0 + sp[k].j * dim;
            double l1 = 0, l0 = 0, dd = 0;
            for (size_t x = 0; x < dim; x++) {
                double r1 = x1[x] - z1[x], r0 = x0[x] - z0[x];
                l1 += r1 * r1;
                l0 += r0 * r0;
                dd += (r1 - r0) * (r1 + r0);
            }
            l1 = sqrt(l1);
            l0 = sqrt(l0);
            if (l1 + l0 == 0) continue;
            s += 0.5 * sp[k].k * (dd / (l1 + l0)) * ((l1 + l0) - 2 * sp[k].L);
        }
    }
    *dH = s;
    return 0;
}

static int hess_band(const void *self, const double *y, double *band)
{
    const coupled *c = self;
    size_t n = c->n, w = c->w, bw = 2 * w + 1;
    memset(band, 0, 2 * n * bw * sizeof *band);
    for (size_t i = 0; i < n; i++) band[(2 * i + 1) * bw + w] = c->minv[i / c->dim];
    return add_q_hessian(c, y, band, 2 * bw - 2, 2, w);
}

/*
 * D^3 H[u,u,u]: T is quadratic, so only the springs contribute. For one spring with
 * delta = u_i - u_j, s = |r|, a = r . delta: d^3/de^3 k/2 (|r + e delta| - L)^2 at e = 0 is
 * 3 k L a (|delta|^2 - a^2/s^2) / s^3 (the |r|^2 part is quadratic).
 */
static int third(const void *self, const double *y, const double *u, double *d3)
{
    const coupled *c = self;
    size_t dim = c->dim;
    double sum = 0;
    for (int anchor = 0; anchor < 2; anchor++) {
        size_t cnt = anchor ? c->na : c->ns;
        const spring *sp = anchor ? c->anc : c->spr;
        for (size_t s = 0; s < cnt; s++) {
            double r[3], len, f;
            if (geometry(c, &sp[s], anchor, y, r, &len, &f)) return 1;
            if (sp[s].L == 0) continue;
            size_t bi = sp[s].i * dim, bj = second(c, &sp[s], anchor);
            double a = 0, dd = 0;
            for (size_t x = 0; x < dim; x++) {
                double del = u[bi + x] - (bj == SIZE_MAX ? 0 : u[bj + x]);
                a += r[x] * del;
                dd += del * del;
            }
            sum += 3 * sp[s].k * sp[s].L * a * (dd - a * a / (len * len)) / (len * len * len);
        }
    }
    *d3 = sum;
    return 0;
}

static size_t n_invariants(const void *self)
{
    const coupled *c = self;
    return c->na ? 0 : inv_count[c->dim];
}

static const char *invariant_name(const void *self, size_t i)
{
    const coupled *c = self;
    return i < n_invariants(self) ? inv_names[c->dim][i] : NULL;
}

/* Total linear momentum per axis, then angular momentum sum x_i ^ p_i (no anchors only). */
static int invariants(const void *self, const double *y, double *out)
{
    const coupled *c = self;
    size_t n = c->n, dim = c->dim, ni = n_invariants(self);
    for (size_t j = 0; j < ni; j++) out[j] = 0;
    if (!ni) return 0;
    const double *q = y, *p = y + n + 1;
    for (size_t i = 0; i < c->N; i++) {
        const double *x = q + i * dim, *m = p + i * dim;
        for (size_t ax = 0; ax < dim; ax++) out[ax] += m[ax];
        if (dim == 2) out[2] += x[0] * m[1] - x[1] * m[0];
        if (dim == 3) {
            out[3] += x[1] * m[2] - x[2] * m[1];
            out[4] += x[2] * m[0] - x[0] * m[2];
            out[5] += x[0] * m[1] - x[1] * m[0];
        }
    }
    return 0;
}

/* A spring with rest length L > 0 whose ends coincide has no direction: name them. */
static int domain(const void *self, const double *y, char *why, size_t len)
{
    const coupled *c = self;
    for (int anchor = 0; anchor < 2; anchor++) {
        size_t cnt = anchor ? c->na : c->ns;
        const spring *sp = anchor ? c->anc : c->spr;
        for (size_t s = 0; s < cnt; s++) {
            double r[3], l, f;
            if (!geometry(c, &sp[s], anchor, y, r, &l, &f)) continue;
            if (anchor)
                snprintf(why, len, "particle %zu sits on the fixed end of its anchor spring (rest length %g > 0)",
                         sp[s].i + 1, sp[s].L);
            else
                snprintf(why, len, "particles %zu and %zu are at the same point (their spring has rest length %g > 0)",
                         sp[s].i + 1, sp[s].j + 1, sp[s].L);
            return 1;
        }
    }
    return 0;
}

const dth_model_type dth_model_coupled = {
DTH_MODEL_TYPE_HEAD,
    .name = "coupled",
    .doc = "coupled oscillators: N particles in 1-3 dimensions, springs k/2 (|x_i - x_j| - L)^2 (chain, ring, lattice or explicit)",
    .params = params,
    .n_params = sizeof params / sizeof params[0],
    .create = create,
    .destroy = destroy,
    .eval = eval,
    .third = third,
    .n_invariants = n_invariants,
    .invariant_name = invariant_name,
    .invariants = invariants,
    .hess_band = hess_band,
    .hdiff = hdiff,
    .domain = domain,
};
