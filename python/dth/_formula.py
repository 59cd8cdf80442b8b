# SPDX-License-Identifier: MIT
"""Models from a Hamiltonian's formula: SymPy derives the gradient, the Hessian, the directional third
derivative and an exact-difference hdiff, writes C source for a dth_model_type table, the system C
compiler builds a shared object (cached by a hash of everything that enters it), and the table is
loaded like any C model (dth.Model.from_hamiltonian; docs/python.md, "Models from a formula")."""
import hashlib
import os
import re
import shutil
import subprocess
import sys
import tempfile

GENERATOR_VERSION = 1  # part of the cache key: a new generator never reuses an old library
CFLAGS = ["-O2", "-shared", "-fPIC", "-ffp-contract=off", "-std=c11"]


def _sympy():
    try:
        import sympy
    except ImportError as e:
        raise ImportError("dth.Model.from_hamiltonian needs SymPy (Debian: apt-get install python3-sympy; "
                          "bash scripts/setup.sh installs it)") from e
    return sympy


# ---------------------------------------------------------------- C printing

def _printer(sympy):
    from sympy.printing.c import C99CodePrinter

    class Printer(C99CodePrinter):
        """C99 with small integer powers as products (x*x*x: what a hand-written model does, and no
        pow() call in the inner loop) and rationals as divisions of doubles."""

        def _print_Pow(self, e):
            b, x = e.base, e.exp
            if x.is_Integer and 1 <= abs(int(x)) <= 8:
                bs = self._print(b)
                if not (b.is_Symbol or b.is_Number):
                    bs = "(%s)" % bs
                prod = "*".join([bs] * abs(int(x)))
                return "(%s)" % prod if x > 0 else "(1.0/(%s))" % prod
            if x == sympy.Rational(1, 2):
                return "sqrt(%s)" % self._print(b)
            if x == sympy.Rational(-1, 2):
                return "(1.0/sqrt(%s))" % self._print(b)
            return "pow(%s, %s)" % (self._print(b), self._print(sympy.Float(x) if x.is_Rational else x))

        def _print_Rational(self, e):
            return "(%d.0/%d.0)" % (e.p, e.q)

        def _print_Integer(self, e):
            return "%d.0" % int(e)

    return Printer()


class _Gen:
    """The C source of one model."""

    def __init__(self, sympy, H, n, name, params, symbol, doc):
        self.sp, self.H, self.n, self.name, self.params, self.symbol, self.doc = sympy, H, n, name, params, symbol, doc
        self.P = _printer(sympy)
        self.q = [sympy.Symbol("q%d" % (i + 1)) for i in range(n)]
        self.p = [sympy.Symbol("p%d" % (i + 1)) for i in range(n)]
        self.t = sympy.Symbol("t")
        self.y = self.q + [self.t] + self.p
        self.psyms = [sympy.Symbol(k) for k in params]

    def c(self, e):
        return self.P.doprint(e)

    def block(self, exprs, targets, indent="        "):
        """C statements computing exprs into targets, with common subexpressions once (sympy.cse)."""
        sp = self.sp
        reps, red = sp.cse(exprs, symbols=sp.numbered_symbols("c"), optimizations=None)
        out = ["%sconst double %s = %s;" % (indent, s, self.c(v)) for s, v in reps]
        out += ["%s%s = %s;" % (indent, tg, self.c(v)) for tg, v in zip(targets, red)]
        return out

    def unpack(self, ptr="y", prefix="", indent="    "):
        names = [str(s) for s in self.y]
        return ["%sconst double %s%s = %s[%d];" % (indent, prefix, nm, ptr, i) for i, nm in enumerate(names)]

    def unpack_params(self, indent="    "):
        return ["%sconst double %s = m->par[%d];" % (indent, k, i) for i, k in enumerate(self.params)]

    # ---- hdiff: H(y1) - H(y0) without cancellation, exactly antisymmetric

    def hdiff_lines(self):
        sp = self.sp
        a = {s: sp.Symbol("a_" + str(s)) for s in self.y}
        b = {s: sp.Symbol("b_" + str(s)) for s in self.y}
        lines, count = [], [0]
        ys = set(self.y)

        def at(e, side):
            return "(%s)" % self.c(e.xreplace(side))

        def S(e):  # e(y1) + e(y0): symmetric under the swap
            return "(%s + %s)" % (at(e, a), at(e, b))

        def tmp(expr):
            count[0] += 1
            nm = "D%d" % count[0]
            lines.append("    const double %s = %s;" % (nm, expr))
            return nm

        def D(e):
            """A C variable holding e(y1) - e(y0), or None where e does not depend on y; odd under the
            swap of y1 and y0 operation by operation (so the result negates bit for bit)."""
            if not (e.free_symbols & ys):
                return None
            if e.is_Symbol:
                return "d_" + str(e)
            if e.is_Add:
                ts = [x for x in (D(t) for t in e.args) if x is not None]
                return tmp(" + ".join(ts))
            if e.is_Mul:
                const = [f for f in e.args if not (f.free_symbols & ys)]
                var = [f for f in e.args if f.free_symbols & ys]
                c = sp.Mul(*const)
                if len(var) == 1:
                    d = D(var[0])
                else:
                    h = len(var) // 2
                    L, R = sp.Mul(*var[:h]), sp.Mul(*var[h:])
                    d = tmp("0.5 * (%s * %s + %s * %s)" % (D(L), S(R), S(L), D(R)))
                return d if c == 1 else tmp("%s * %s" % (at(c, {}), d))
            if e.is_Pow:
                base, x = e.base, e.exp
                if x.free_symbols & ys:
                    return fallback(e)
                if x.is_Integer and x > 1:
                    k = int(x)
                    k1 = k // 2
                    L, R = base ** k1, base ** (k - k1)
                    return tmp("0.5 * (%s * %s + %s * %s)" % (D(L), S(R), S(L), D(R)))
                if x.is_Integer and x < 0:
                    pos = base ** (-int(x))
                    return tmp("-%s / (%s * %s)" % (D(pos), at(pos, a), at(pos, b)))
                if x == sp.Rational(1, 2):
                    return tmp("%s / (%s + %s)" % (D(base), at(e, a), at(e, b)))
                if x == sp.Rational(-1, 2):
                    sq = sp.sqrt(base)
                    return tmp("-%s / (%s * %s)" % (D(sq), at(sq, a), at(sq, b)))
                return fallback(e)
            f = e.func
            if len(e.args) == 1 and f in (sp.sin, sp.cos, sp.exp, sp.log, sp.sinh, sp.cosh):
                u = e.args[0]
                du, su = D(u), S(u)
                if f is sp.sin:
                    return tmp("2.0 * cos(0.5 * %s) * sin(0.5 * %s)" % (su, du))
                if f is sp.cos:
                    return tmp("-2.0 * sin(0.5 * %s) * sin(0.5 * %s)" % (su, du))
                if f is sp.exp:
                    return tmp("2.0 * exp(0.5 * %s) * sinh(0.5 * %s)" % (su, du))
                if f is sp.sinh:
                    return tmp("2.0 * cosh(0.5 * %s) * sinh(0.5 * %s)" % (su, du))
                if f is sp.cosh:
                    return tmp("2.0 * sinh(0.5 * %s) * sinh(0.5 * %s)" % (su, du))
                return tmp("2.0 * atanh(%s / %s)" % (du, su))  # log
            return fallback(e)

        def fallback(e):  # antisymmetric, not free of cancellation (docs/python.md)
            self.hdiff_exact = False
            return tmp("%s - %s" % (at(e, a), at(e, b)))

        self.hdiff_exact = True
        head = self.unpack("y1", "a_") + self.unpack("y0", "b_")
        head += ["    const double d_%s = a_%s - b_%s;" % (s, s, s) for s in self.y]
        d = D(sp.expand(self.H))
        body = lines + ["    *dH = %s;" % (d if d is not None else "0.0")]
        return head, body

    # ---- the whole source

    def source(self):
        sp, n, H = self.sp, self.n, self.H
        d = 2 * n + 1
        y = self.y
        grad = [sp.diff(H, v) for v in y]
        hess = {(i, j): sp.diff(grad[i], y[j]) for i in range(d) for j in range(i, d)}
        u = [sp.Symbol("u%d" % i) for i in range(d)]
        D1 = sum(grad[i] * u[i] for i in range(d))
        D2 = sum(sp.diff(D1, y[j]) * u[j] for j in range(d))
        D3 = sp.expand(sum(sp.diff(D2, y[k]) * u[k] for k in range(d)))
        auton = self.t not in H.free_symbols
        sep = all(not (g.free_symbols & set(self.q + [self.t])) for g in grad[n + 1:]) and \
            all(not (g.free_symbols & set(self.p)) for g in grad[:n + 1])
        esc = lambda s: s.replace("\\", "\\\\").replace('"', '\\"')  # noqa: E731
        L = ["/* Generated by dth.Model.from_hamiltonian (python/dth/_formula.py, generator %d): do not edit."
             % GENERATOR_VERSION,
             " * H = %s */" % str(H).replace("*/", "* /"),
             "#include <math.h>", "#include <stdio.h>", "#include <stdlib.h>", "#include <string.h>",
             "#include <dth/model.h>", "",
             "typedef struct fm { double par[%d]; } fm;" % max(len(self.params), 1), ""]
        specs = ["    {\"%s\", %s, \"parameter of the formula\"}," % (
            k, "NULL" if v is None else "\"%s\"" % repr(float(v))) for k, v in self.params.items()]
        L += ["static const dth_param_spec params[] = {"] + (specs or ["    {NULL, NULL, NULL},"]) + ["};", ""]
        L += ["static int arg_error(const dth_model_args *a, const char *msg, const char *key)",
              "{",
              "    if (a->err && a->errlen) snprintf(a->err, a->errlen, msg, key);",
              "    return DTH_EINVAL;",
              "}", "",
              "static int create(const dth_model_args *a, void **self, dth_model_info *info)",
              "{",
              "    double par[%d] = {0};" % max(len(self.params), 1)]
        for i, (k, v) in enumerate(self.params.items()):
            L += ["    {",
                  "        const char *s = NULL;",
                  "        for (size_t i = 0; i < a->nkv; i++)",
                  "            if (!strcmp(a->kv[i].key, \"%s\")) s = a->kv[i].value;" % k]
            if v is None:
                L += ["        if (!s) return arg_error(a, \"parameter '%s' is required\", \"" + k + "\");"]
                L += ["        {"]
            else:
                L += ["        par[%d] = %s;" % (i, repr(float(v))), "        if (s) {"]
            L += ["            char *end;",
                  "            par[%d] = strtod(s, &end);" % i,
                  "            while (*end == ' ' || *end == '\\t') end++;",
                  "            if (end == s || *end || !isfinite(par[%d]))" % i,
                  "                return arg_error(a, \"parameter '%s' is not a finite number\", \"" + k + "\");",
                  "        }", "    }"]
        L += ["    if (a->n_hint && a->n_hint != %d)" % n,
              "        return arg_error(a, \"model '%%s' has %d degrees of freedom\", \"%s\");" % (n, esc(self.name)),
              "    fm *m = a->alloc && a->alloc->alloc ? a->alloc->alloc(a->alloc->ctx, sizeof *m) : malloc(sizeof *m);",
              "    if (!m) return DTH_ENOMEM;",
              "    memcpy(m->par, par, sizeof par);",
              "    *self = m;",
              "    memset(info, 0, sizeof *info);",
              "    info->n = %d;" % n,
              "    info->autonomous = %d;" % int(auton),
              "    info->separable = %d;" % int(sep),
              "    info->hess_kind = DTH_HESS_DENSE;",
              "    return DTH_OK;",
              "}", "",
              "static void destroy(void *self, const dth_allocator *alloc)",
              "{",
              "    if (alloc && alloc->free) alloc->free(alloc->ctx, self);",
              "    else free(self);",
              "}", "",
              "static int eval(const void *self, const double *y, unsigned what, double *H, double *g, double *h)",
              "{",
              "    const fm *m = self;",
              "    (void)m;"]
        L += self.unpack() + self.unpack_params()
        L += ["    if (what & DTH_EVAL_H) {"] + self.block([H], ["*H"]) + ["    }"]
        L += ["    if (what & DTH_EVAL_GRAD) {"] + self.block(grad, ["g[%d]" % i for i in range(d)]) + ["    }"]
        keys = sorted(hess)
        L += ["    if (what & DTH_EVAL_HESS) {"]
        L += self.block([hess[k] for k in keys], ["h[%d]" % (i * d + j) for i, j in keys])
        L += ["        h[%d] = h[%d];" % (j * d + i, i * d + j) for i, j in keys if i != j]
        L += ["    }", "    return 0;", "}", "",
              "static int third(const void *self, const double *y, const double *u, double *d3)",
              "{",
              "    const fm *m = self;",
              "    (void)m;"]
        L += self.unpack() + self.unpack_params()
        L += ["    const double u%d = u[%d];" % (i, i) for i in range(d)]
        L += self.block([D3], ["*d3"], indent="    ")
        L += ["    return 0;", "}", "",
              "static int hdiff(const void *self, const double *y1, const double *y0, double *dH)",
              "{",
              "    const fm *m = self;",
              "    (void)m;"]
        head, body = self.hdiff_lines()
        L += head + self.unpack_params() + body
        L += ["    return 0;", "}", "",
              "const dth_model_type %s = {" % self.symbol,
              "    DTH_MODEL_TYPE_HEAD,",
              "    .name = \"%s\"," % esc(self.name),
              "    .doc = \"%s\"," % esc(self.doc),
              "    .params = params,",
              "    .n_params = %d," % len(self.params),
              "    .create = create,",
              "    .destroy = destroy,",
              "    .eval = eval,",
              "    .third = third,",
              "    .hdiff = hdiff,",
              "};", ""]
        # unused-variable warnings are expected in generated code (not every coordinate appears)
        return "\n".join(L)


# ---------------------------------------------------------------- headers, compiler, cache

def include_dirs():
    """Folders holding dth/model.h, first match first: DTH_INCLUDE, the package's own copy (pip and
    meson install ship the headers a generated model needs in dth/include), the checkout's
    lib/include (the package in <checkout>/python), pkg-config's dth, /usr/local/include."""
    here = os.path.dirname(os.path.abspath(__file__))
    cands = []
    if os.environ.get("DTH_INCLUDE"):
        cands.append(os.environ["DTH_INCLUDE"])
    cands += [os.path.join(here, "include"), os.path.join(here, "..", "..", "lib", "include")]
    try:
        out = subprocess.run(["pkg-config", "--cflags-only-I", "dth"], capture_output=True, text=True, timeout=30)
        if out.returncode == 0:
            cands += [x[2:] for x in out.stdout.split() if x.startswith("-I")]
    except (OSError, subprocess.SubprocessError):
        pass
    cands += ["/usr/local/include", "/usr/include"]
    return [os.path.realpath(c) for c in cands if os.path.isfile(os.path.join(c, "dth", "model.h"))]


def compiler():
    cc = os.environ.get("CC") or shutil.which("cc") or shutil.which("gcc") or shutil.which("clang")
    if not cc:
        raise RuntimeError("dth.Model.from_hamiltonian needs a C compiler (Debian: apt-get install gcc), or "
                           "CC=/path/to/cc")
    return cc


def cache_dir(given=None):
    d = given or os.environ.get("DTH_MODEL_CACHE") or os.path.join(
        os.environ.get("XDG_CACHE_HOME") or os.path.join(os.path.expanduser("~"), ".cache"), "dth", "models")
    os.makedirs(d, exist_ok=True)
    return d


def build(source, symbol, key, where=None):
    """The shared object of `source` (cached under `key`): its path."""
    inc = include_dirs()
    if not inc:
        raise RuntimeError("dth: cannot find dth/model.h (the package's dth/include, the checkout's lib/include, "
                           "pkg-config dth): set DTH_INCLUDE=/path/to/include")
    cc = compiler()
    d = cache_dir(where)
    so = os.path.join(d, "%s-%s.so" % (symbol, key[:24]))
    if os.path.exists(so):
        return so
    fd, tmp = tempfile.mkstemp(prefix=".build-", dir=d)
    os.close(fd)
    src = tmp + ".c"
    try:
        with open(src, "w") as f:
            f.write(source)
        cmd = [cc] + CFLAGS + ["-I" + inc[0], src, "-o", tmp, "-lm"]
        r = subprocess.run(cmd, capture_output=True, text=True)
        if r.returncode != 0:
            raise RuntimeError("dth: compiling the model failed:\n%s\n%s" % (" ".join(cmd), r.stderr[-4000:]))
        with open(so[:-3] + ".c", "w") as f:  # the source beside the library, for reading
            f.write(source)
        os.replace(tmp, so)
    finally:
        for p in (tmp, src):
            if os.path.exists(p):
                os.unlink(p)
    return so


def generate(formula, n, name, params=None, doc=None):
    """(sympy expression, C source, symbol, cache key) of a formula model."""
    sp = _sympy()
    params = dict(params or {})
    if not isinstance(n, int) or n < 1:
        raise ValueError("dth: from_hamiltonian: n is the number of degrees of freedom (>= 1), not %r" % (n,))
    if not re.fullmatch(r"[A-Za-z0-9_.+-]{1,48}", name or ""):
        raise ValueError("dth: from_hamiltonian: a model name of letters, digits and _.+- (at most 48), not %r"
                         % (name,))
    for k in params:
        if not re.fullmatch(r"[A-Za-z_][A-Za-z0-9_]{0,40}", k) or re.fullmatch(r"[qp]\d+|t|u\d+|[abd]_.*|c\d+", k):
            raise ValueError("dth: from_hamiltonian: %r cannot name a parameter" % (k,))
    names = ["q%d" % (i + 1) for i in range(n)] + ["p%d" % (i + 1) for i in range(n)] + ["t"] + list(params)
    loc = {k: sp.Symbol(k) for k in names}
    H = sp.sympify(formula, locals=loc) if isinstance(formula, str) else sp.sympify(formula)
    extra = sorted(str(s) for s in H.free_symbols if str(s) not in names)
    if extra:
        raise ValueError("dth: from_hamiltonian: the formula names %s: give them in params={name: default} or use "
                         "q1..q%d, p1..p%d, t" % (", ".join(extra), n, n))
    symbol = "dth_formula_" + re.sub(r"[^A-Za-z0-9_]", "_", name)
    text = "%r|%d|%s|%r|%r|%d|%s|%s" % (str(sp.srepr(H)), n, name, sorted(params.items()), doc, GENERATOR_VERSION,
                                       " ".join(CFLAGS), sys.platform)
    key = hashlib.sha256(text.encode()).hexdigest()
    g = _Gen(sp, H, n, name, params, symbol, doc or "H = %s (from a formula)" % H)
    return H, g.source(), symbol, key, g.hdiff_exact

