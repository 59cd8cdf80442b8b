# SPDX-License-Identifier: MIT
"""Scenes, runs through the library's driver dth_run, roots, checkpoints and user models (the
Python face of lib/include/dth/*.h; see docs/python.md)."""
import contextlib
import json
import math
import numbers
import threading

import numpy as np

from ._ffi import ffi, lib

__all__ = ["DthError", "OutsideDomain", "Scene", "Simulation", "Event", "Result", "Events", "Roots", "Map", "Model",
           "CModel", "FormulaModel", "load_model", "run", "roots", "map", "models", "strerror", "status_name"]

_ERRLEN = 1024


def _enum_names(ctype, prefix):
    """{value: name} of a C enum declared to cffi, the name without its prefix, in lower case (dth_run_stop:
    DTH_RUN_END -> "end"); read from the declarations, so the library need not be loaded."""
    return {v: k[len(prefix):].lower() for v, k in ffi.typeof(ctype).elements.items()}


_STOP = _enum_names("dth_run_stop", "DTH_RUN_")          # 0: "running", 1: "end", ...
_KIND = _enum_names("dth_sample_kind", "DTH_SAMPLE_")    # 0: "vertex", 1: "midpoint", ...
_STATUS = ffi.typeof("dth_status").relements
DTH_EMODEL = _STATUS["DTH_EMODEL"]

# Exceptions raised inside callbacks that C called: re-raised once control is back in Python.
_tls = threading.local()  # .pending: per thread, so that one thread never raises another's


def strerror(status):
    """The library's message for a status code."""
    return ffi.string(lib().dth_strerror(status)).decode()


def status_name(status):
    """The symbolic name of a status code, e.g. "DTH_ENOCONV"."""
    return ffi.string(lib().dth_status_name(status)).decode()


class DthError(Exception):
    """A hard error of the library (negative status) or bad input (scene, overrides, arguments).
    `result`: the samples a run returned before it stopped, where it has some (else None)."""

    def __init__(self, status, message=None, result=None):
        self.status = status
        self.name = status_name(status)
        self.result = result
        super().__init__(message or strerror(status))


class OutsideDomain(Exception):
    """Raise this in a Python model's callbacks where the point is outside the model's domain
    (the step then fails with DTH_EDOMAIN and the regularizer or the caller may react)."""


def _raise_pending():
    exc = getattr(_tls, "pending", None)
    if exc is not None:
        _tls.pending = None
        raise exc


def _onerror(exc_type, exc, tb):
    if getattr(_tls, "pending", None) is None:  # the first one of the call counts
        _tls.pending = exc.with_traceback(tb) if exc is not None else exc_type()


def _err(buf):
    return ffi.string(buf).decode(errors="replace")


# ---------------------------------------------------------------- scenes

def _fmt(v):
    if isinstance(v, bool):
        return "yes" if v else "no"
    if isinstance(v, numbers.Integral):
        return str(int(v))
    if isinstance(v, numbers.Real):
        return repr(float(v))  # the shortest text that reads back as the same double
    if isinstance(v, str):
        return v
    if isinstance(v, (list, tuple, np.ndarray)):
        # no blank after the commas: a long list may then be split over continuation lines at any
        # comma (what dth_scene_check_entry and dth_scene_set accept, scene.h)
        return ",".join(_fmt(x) for x in np.asarray(v, dtype=object).ravel())
    raise TypeError("dth: cannot write %r as a scene value" % (v,))


def _ini_lines(key, text):
    """key = text, split at commas over continuation lines (the reader's lines are short)."""
    lines, cur = [], "%s = " % key
    for i, item in enumerate(text.split(",")):
        piece = item if i == 0 else "," + item
        if len(cur) + len(piece) > 150 and cur.strip():
            lines.append(cur.rstrip(",") + ",")
            cur = "    " + item.strip()
        else:
            cur += piece
    lines.append(cur)
    # continuation lines carry more comma-separated items: each line but the last ends its item
    return [ln[:-1] if ln.endswith(",") else ln for ln in lines]


def _ini_from_dict(d):
    """INI text of a dict scene; every entry checked by the library's rule of what a scene file can
    hold (dth_scene_check_entry, the rule dth_scene_set applies), so that no value can add a line."""
    out = []
    err = ffi.new("char[]", _ERRLEN)
    for sec, keys in d.items():
        if not isinstance(keys, dict):
            raise TypeError("dth: scene section %r must be a dict of keys" % (sec,))
        out.append("[%s]" % sec)
        for k, v in keys.items():
            text = _fmt(v)
            rc = lib().dth_scene_check_entry(str(sec).encode(), str(k).encode(), text.encode(), err, _ERRLEN)
            if rc:
                raise DthError(rc, "dict scene: %s" % _err(err))
            out.extend(_ini_lines(k, text))
    return "\n".join(out) + "\n"


class Scene:
    """A scene: an INI file, INI text or a dict {section: {key: value}}, plus overrides.

        Scene("scenes/pendulum.ini", {"integrator.h": 0.01})
        Scene({"model": {"name": "pendulum"}, "initial": {"q": 1, "p": 0},
               "integrator": {"h": 0.05, "t_end": 20}})

    Values in dicts and overrides may be numbers (written with repr: the same double), bools
    (yes/no), strings or sequences (comma-separated lists). Nothing is read until a run needs it,
    and then messages name the file and line (or the override) like dth run's.
    """

    def __init__(self, source=None, set=None):
        self.path = None
        self.text = None
        self.name = "<dict>"
        self.overrides = []
        if isinstance(source, Scene):
            self.path, self.text, self.name = source.path, source.text, source.name
            self.overrides = list(source.overrides)
        elif isinstance(source, dict):
            self.text = _ini_from_dict(source)
        elif isinstance(source, str) and ("\n" in source or source.lstrip().startswith("[")):
            self.text, self.name = source, "<text>"
        elif isinstance(source, str) or hasattr(source, "__fspath__"):
            self.path = str(source)
            self.name = self.path
        elif source is not None:
            raise TypeError("dth: a scene is a path, INI text, a dict or a Scene")
        if set:
            for k, v in (set.items() if isinstance(set, dict) else set):
                self.set(k, v)

    def set(self, key, value):
        """Override section.key (applied after the file, in order, like dth run -s; messages name it
        as set={'section.key': value})."""
        if not isinstance(key, str) or "." not in key:
            raise ValueError("dth: an override names section.key, not %r" % (key,))
        origin = "set={%r: %r}" % (key, value)
        if len(origin) > 80:
            origin = origin[:76] + "...}"
        self.overrides.append((origin, "%s=%s" % (key, _fmt(value))))
        return self

    def __setitem__(self, key, value):
        self.set(key, value)

    def _load(self):
        """A new C scene (caller frees it) with the source and the overrides applied."""
        L = lib()
        sp = ffi.new("dth_scene **")
        rc = L.dth_scene_new(ffi.NULL, sp)
        if rc:
            raise DthError(rc)
        s = sp[0]
        err = ffi.new("char[]", _ERRLEN)
        try:
            if self.path is not None:
                rc = L.dth_scene_load(s, self.path.encode(), err, _ERRLEN)
            elif self.text is not None:
                t = self.text.encode()
                rc = L.dth_scene_load_mem(s, self.name.encode(), t, len(t), err, _ERRLEN)
            if rc:
                raise DthError(rc, _err(err))
            for origin, o in self.overrides:
                rc = L.dth_scene_set_from(s, origin.encode(), o.encode(), err, _ERRLEN)
                if rc:
                    raise DthError(rc, _err(err))
        except BaseException:
            L.dth_scene_free(s)
            raise
        return s

    def get(self, key):
        """The value of section.key after the overrides (text), or None."""
        sec, _, k = key.partition(".")
        s = self._load()
        try:
            v = lib().dth_scene_get(s, sec.encode(), k.encode())
            return None if v == ffi.NULL else ffi.string(v).decode()
        finally:
            lib().dth_scene_free(s)

    def ini(self):
        """The scene as INI text: every key after the overrides."""
        s = self._load()
        try:
            return _scene_text(s, None)
        finally:
            lib().dth_scene_free(s)


def _scene_text(s, has_t_end):
    """INI text of a C scene, grouped by section; of steps and t_end only the one in force."""
    L = lib()
    secs = {}
    p = [ffi.new("char **") for _ in range(4)]
    for i in range(L.dth_scene_count(s)):
        L.dth_scene_entry(s, i, p[0], p[1], p[2], p[3])
        sec, key, val = (ffi.string(x[0]).decode() for x in p[:3])
        if sec == "integrator" and has_t_end is not None and key == ("steps" if has_t_end else "t_end"):
            continue
        secs.setdefault(sec, []).append((key, val))
    out = []
    for sec, kv in secs.items():
        out.append("[%s]" % sec)
        for k, v in kv:
            out.extend(_ini_lines(k, v))
    return "\n".join(out) + "\n"


# ---------------------------------------------------------------- user models

class Model:
    """Base class of a model written in Python (slow: every evaluation is a Python call; for
    prototyping). H_phys(q, t, p) with y = (q_1..q_n, t, p_1..p_n):

        class HenonHeiles(dth.Model):
            name = "henon-heiles-py"
            params = {"lambda": 1.0}       # name -> default (None: required)
            n = 2                          # degrees of freedom (None: from the scene's q)
            separable = True
            def H(self, q, t, p): ...      # a float
            def grad(self, q, t, p): ...   # 2n+1 values: dH/dq, dH/dt, dH/dp
            def hess(self, q, t, p): ...   # (2n+1, 2n+1) over y

    Optional: invariant_names = ("L",) with invariants(self, q, t, p) (a sequence of floats), and
    the optional entries of the C table (model.h), used where a subclass defines them:
        def third(self, q, t, p, u): ...   # sum H_ijk u_i u_j u_k over y, u of 2n+1 values (psi')
        def hdiff(self, q1, t1, p1, q0, t0, p0): ...   # H(y1) - H(y0) without cancellation, exactly
                                           # antisymmetric (the step's compensated constraint uses it)
        def domain(self, q, t, p): ...     # None inside the domain, else a few words saying why not
    Parameters reach the instance as self.params (floats where the text is a number). Raise
    dth.OutsideDomain where the point is outside the model's domain. Pass the class to a run:
    dth.run(scene, models=[HenonHeiles]).
    """

    name = None
    doc = "a model written in Python"
    params = {}
    param_docs = {}
    n = None
    autonomous = True
    separable = False
    invariant_names = ()

    def __init__(self, params):
        self.params = params

    def H(self, q, t, p):
        raise NotImplementedError

    def grad(self, q, t, p):
        raise NotImplementedError

    def hess(self, q, t, p):
        raise NotImplementedError

    def invariants(self, q, t, p):
        return ()

    @staticmethod
    def from_hamiltonian(formula, n, name, params=None, doc=None, cache_dir=None):
        """A compiled model from the formula of H_phys (text SymPy reads, or a SymPy expression) in
        q1..qn, p1..pn, t and the parameters `params` {name: default, None: required}:

            hh = dth.Model.from_hamiltonian(
                "p1**2/2 + p2**2/2 + (q1**2 + q2**2)/2 + q1**2*q2 - q2**3/3", n=2, name="hh-formula")
            dth.run("docs/examples/henon-heiles.ini", models=[hh], set={"model.name": "hh-formula"})

        SymPy derives the gradient, the Hessian, the third derivative along u (sum H_ijk u_i u_j u_k) and
        hdiff (H(y1) - H(y0) by differences of monomials and of sin, cos, exp, log, sqrt, 1/x, exactly
        antisymmetric); the C source (m.source) is compiled by the system C compiler (cc -O2 -shared -fPIC
        -ffp-contract=off) into a shared object cached by a hash of everything that enters it (in
        $DTH_MODEL_CACHE, else $XDG_CACHE_HOME/dth/models, else ~/.cache/dth/models; or cache_dir), and
        loaded like dth.load_model. m.write_library(path) copies it for dth sweep --model-lib
        PATH:SYMBOL (returned). Needs SymPy (python3-sympy) and a C compiler."""
        from . import _formula
        return FormulaModel(_formula, formula, n, name, params, doc, cache_dir)

    # optional (model.h): defined by a subclass, they enter the C table; these stand for "absent"
    def third(self, q, t, p, u):
        raise NotImplementedError

    def hdiff(self, q1, t1, p1, q0, t0, p0):
        raise NotImplementedError

    def domain(self, q, t, p):
        raise NotImplementedError


def _overrides(mc, name):
    """Whether the Model subclass mc defines `name` itself (not the base class's stand-in)."""
    return getattr(mc, name, None) is not getattr(Model, name)


def _number(text):
    try:
        return float(text)
    except ValueError:
        return text


class _PyModelType:
    """The C table (dth_model_type) of a Python Model class, with cffi callbacks."""

    _cache = {}

    @classmethod
    def of(cls, mc):
        t = cls._cache.get(mc)
        if t is None:
            t = cls._cache[mc] = cls(mc)
        return t

    def __init__(self, mc):
        if not mc.name:
            raise ValueError("dth: a Model subclass needs a name")
        self.cls = mc
        self._keep = []
        self._live = {}

        def cstr(s):
            b = ffi.new("char[]", s.encode())
            self._keep.append(b)
            return b

        specs = list(mc.params.items())
        self.spec = ffi.new("dth_param_spec[]", max(len(specs), 1))
        for i, (k, d) in enumerate(specs):
            self.spec[i].key = cstr(k)
            setattr(self.spec[i], "def", ffi.NULL if d is None else cstr(_fmt(d)))
            self.spec[i].doc = cstr(mc.param_docs.get(k, ""))
        self.inames = [cstr(s) for s in mc.invariant_names]
        t = self.table = ffi.new("dth_model_type *")
        t.abi, t.size = lib().DTH_MODEL_TYPE_VERSION, ffi.sizeof("dth_model_type")
        t.name = cstr(mc.name)
        t.doc = cstr(mc.doc or "")
        t.params = self.spec
        t.n_params = len(specs)
        cb = self._callbacks()
        t.create, t.destroy, t.eval = cb["create"], cb["destroy"], cb["eval"]
        if mc.invariant_names:
            t.n_invariants, t.invariant_name, t.invariants = cb["n_inv"], cb["inv_name"], cb["inv"]
        for name in ("third", "hdiff", "domain"):
            if _overrides(mc, name):
                setattr(t, name, cb[name])
        self._keep.append(cb)

    def _callbacks(self):
        mc, live, spec_keys = self.cls, self._live, list(self.cls.params)
        ninv = len(mc.invariant_names)
        L = lib()
        _EVAL_H, _EVAL_GRAD, _EVAL_HESS = L.DTH_EVAL_H, L.DTH_EVAL_GRAD, L.DTH_EVAL_HESS

        @ffi.callback("int(const dth_model_args *, void **, dth_model_info *)", error=DTH_EMODEL, onerror=_onerror)
        def create(args, selfp, info):
            params = {}
            for k in spec_keys:
                v = lib().dth_args_get(args, k.encode())
                if v != ffi.NULL:
                    params[k] = _number(ffi.string(v).decode())
                elif mc.params[k] is not None:
                    params[k] = mc.params[k]
                else:
                    return _args_error(args, "parameter '%s' is required" % k)
            try:
                inst = mc(params)
            except (ValueError, TypeError) as e:
                return _args_error(args, str(e))
            n = inst.n if inst.n is not None else args.n_hint
            if not n or n < 1:
                return _args_error(args, "model '%s': give n or the initial q" % mc.name)
            if args.n_hint and args.n_hint != n:
                return _args_error(args, "model '%s' has %d degrees of freedom" % (mc.name, n))
            inst.n = int(n)
            h = ffi.new_handle(inst)
            live[int(ffi.cast("uintptr_t", h))] = h
            selfp[0] = h
            info.n = inst.n
            info.autonomous = 1 if inst.autonomous else 0
            info.separable = 1 if inst.separable else 0
            info.hess_kind = 0
            info.bandwidth = 0
            info.K = 0
            return 0

        @ffi.callback("void(void *, const dth_allocator *)", onerror=_onerror)
        def destroy(selfp, alloc):
            if selfp != ffi.NULL:
                live.pop(int(ffi.cast("uintptr_t", selfp)), None)

        def split(selfp, y):
            inst = ffi.from_handle(selfp)
            n = inst.n
            yv = np.frombuffer(ffi.buffer(y, 8 * (2 * n + 1)), dtype=np.float64)
            return inst, n, yv[:n], yv[n], yv[n + 1:]

        @ffi.callback("int(const void *, const double *, unsigned, double *, double *, double *)",
                      error=DTH_EMODEL, onerror=_onerror)
        def eval_(selfp, y, what, H, grad, hess):
            inst, n, q, t, p = split(selfp, y)
            m = 2 * n + 1
            try:
                if what & _EVAL_H:
                    H[0] = float(inst.H(q, t, p))
                if what & _EVAL_GRAD:
                    g = np.ascontiguousarray(inst.grad(q, t, p), dtype=np.float64)
                    if g.shape != (m,):
                        raise ValueError("%s.grad returned shape %s, not (%d,)" % (mc.__name__, g.shape, m))
                    ffi.memmove(grad, g, 8 * m)
                if what & _EVAL_HESS:
                    h = np.ascontiguousarray(inst.hess(q, t, p), dtype=np.float64)
                    if h.shape != (m, m):
                        raise ValueError("%s.hess returned shape %s, not (%d, %d)" % (mc.__name__, h.shape, m, m))
                    ffi.memmove(hess, h, 8 * m * m)
            except OutsideDomain:
                return 1
            return 0

        @ffi.callback("size_t(const void *)", error=0, onerror=_onerror)
        def n_inv(selfp):
            return ninv

        @ffi.callback("const char *(const void *, size_t)", onerror=_onerror)
        def inv_name(selfp, i):
            return self.inames[i] if i < ninv else ffi.NULL

        @ffi.callback("int(const void *, const double *, double *)", error=DTH_EMODEL, onerror=_onerror)
        def inv(selfp, y, out):
            inst, n, q, t, p = split(selfp, y)
            try:
                v = np.ascontiguousarray(inst.invariants(q, t, p), dtype=np.float64)
            except OutsideDomain:
                return 1
            if v.shape != (ninv,):
                raise ValueError("%s.invariants returned shape %s, not (%d,)" % (mc.__name__, v.shape, ninv))
            ffi.memmove(out, v, 8 * ninv)
            return 0

        @ffi.callback("int(const void *, const double *, const double *, double *)", error=DTH_EMODEL,
                      onerror=_onerror)
        def third(selfp, y, u, d3):
            inst, n, q, t, p = split(selfp, y)
            uv = np.frombuffer(ffi.buffer(u, 8 * (2 * n + 1)), dtype=np.float64)
            try:
                d3[0] = float(inst.third(q, t, p, uv))
            except OutsideDomain:
                return 1
            return 0

        @ffi.callback("int(const void *, const double *, const double *, double *)", error=DTH_EMODEL,
                      onerror=_onerror)
        def hdiff(selfp, y1, y0, dH):
            inst, n, q1, t1, p1 = split(selfp, y1)
            _, _, q0, t0, p0 = split(selfp, y0)
            try:
                dH[0] = float(inst.hdiff(q1, t1, p1, q0, t0, p0))
            except OutsideDomain:
                return 1
            return 0

        @ffi.callback("int(const void *, const double *, char *, size_t)", error=DTH_EMODEL, onerror=_onerror)
        def domain(selfp, y, why, length):
            inst, n, q, t, p = split(selfp, y)
            r = inst.domain(q, t, p)
            if not r:
                return 0
            if why != ffi.NULL and length > 0:
                b = str(r).encode()[: length - 1] + b"\0"
                ffi.memmove(why, b, len(b))
            return 1

        return {"create": create, "destroy": destroy, "eval": eval_, "n_inv": n_inv, "inv_name": inv_name,
                "inv": inv, "third": third, "hdiff": hdiff, "domain": domain}


def _args_error(args, msg):
    if args.err != ffi.NULL and args.errlen > 0:
        b = msg.encode()[: args.errlen - 1] + b"\0"
        ffi.memmove(args.err, b, len(b))
    return _STATUS["DTH_EINVAL"]


class CModel:
    """A model type compiled in C: a shared object exporting a `const dth_model_type` table.

        hh = dth.load_model("build/docs/examples/henon_heiles.so", "example_henon_heiles")
        dth.run("docs/examples/henon-heiles.ini", models=[hh])
    """

    def __init__(self, path, symbol):
        import ctypes
        self.path, self.symbol = path, symbol
        lib()  # libdth first, so the shared object's references to it resolve to this copy
        self._so = ctypes.CDLL(path)
        try:
            addr = ctypes.addressof(ctypes.c_char.in_dll(self._so, symbol))
        except ValueError:
            raise DthError(-7, "%s: no symbol '%s'" % (path, symbol)) from None
        self.table = ffi.cast("const dth_model_type *", addr)
        self.name = ffi.string(self.table.name).decode()


class FormulaModel(CModel):
    """A model compiled from a Hamiltonian's formula (Model.from_hamiltonian): a CModel with
    formula (the SymPy expression), n, source (the C text), path (the cached shared object),
    symbol, key (the cache hash) and hdiff_exact (False where a term had no cancellation-free
    difference and hdiff falls back to H(y1) - H(y0) for it)."""

    def __init__(self, gen, formula, n, name, params, doc, cache_dir):
        self.formula, self.source, symbol, self.key, self.hdiff_exact = gen.generate(formula, n, name, params, doc)
        self.n = n
        path = gen.build(self.source, symbol, self.key, cache_dir)
        super().__init__(path, symbol)

    def write_library(self, path):
        """Copy the shared object to `path` (and its C source to path + '.c'); returns
        'PATH:SYMBOL' for dth sweep --model-lib."""
        import shutil
        shutil.copyfile(self.path, path)
        with open(path + ".c", "w") as f:
            f.write(self.source)
        return "%s:%s" % (path, self.symbol)

    def __repr__(self):
        return "<dth.FormulaModel %s: H = %s>" % (self.name, self.formula)


def load_model(path, symbol):
    """Load a C model type (a `const dth_model_type` named `symbol`) from the shared object `path`."""
    return CModel(path, symbol)


def _table(m):
    if isinstance(m, CModel):
        return m.table
    if isinstance(m, type) and issubclass(m, Model):
        return _PyModelType.of(m).table
    raise TypeError("dth: models are dth.Model subclasses or dth.load_model(...) results, not %r" % (m,))


class _Registry:
    ptr = None  # a partly built one (an exception in __init__) is closed without errors

    def __init__(self, models=()):
        L = lib()
        rp = ffi.new("dth_registry **")
        rc = L.dth_registry_new(ffi.NULL, rp)
        if rc:
            raise DthError(rc)
        self.ptr = rp[0]
        self.models = list(models)
        rc = L.dth_registry_add_builtin(self.ptr)
        for m in self.models:
            if not rc:
                rc = L.dth_registry_add_model(self.ptr, _table(m))
        if rc:
            self.close()
            raise DthError(rc, "cannot register the models (a duplicate name?)")

    def close(self):
        if self.ptr is not None:
            lib().dth_registry_free(self.ptr)
            self.ptr = None

    def __del__(self):
        self.close()


def models(models=()):
    """The registered model types (built-in, plus `models`): a list of dicts with name, doc and
    params [(key, default or None, doc)]."""
    reg = _Registry(models)
    L = lib()
    out = []
    try:
        for i in range(L.dth_registry_model_count(reg.ptr)):
            t = L.dth_registry_model_at(reg.ptr, i)
            s = lambda c: None if c == ffi.NULL else ffi.string(c).decode()  # noqa: E731
            ps = [(s(t.params[j].key), s(getattr(t.params[j], "def")), s(t.params[j].doc)) for j in range(t.n_params)]
            out.append({"name": s(t.name), "doc": s(t.doc), "params": ps})
    finally:
        reg.close()
    return out


# ---------------------------------------------------------------- results

class Events:
    """Located events ([events] of the scene): arrays i, which (index into names), name,
    direction (+1 / -1), k (the step), t, q (m, n), p, wp, H, E, z (m, 2n+2)."""

    def __init__(self, n, rows, names):
        self.names = list(names)
        z = np.array([r[4] for r in rows], dtype=np.float64).reshape(len(rows), 2 * n + 2)
        self.i = np.array([r[0] for r in rows], dtype=np.int64)
        self.which = np.array([r[1] for r in rows], dtype=np.int64)
        self.direction = np.array([r[2] for r in rows], dtype=np.int64)
        self.k = np.array([r[3] for r in rows], dtype=np.int64)
        self.E = np.array([r[5] for r in rows], dtype=np.float64)
        self.name = [self.names[w] for w in self.which]
        self.z = z
        self.t, self.q, self.p, self.wp = z[:, n], z[:, :n], z[:, n + 1:2 * n + 1], z[:, -1]
        self.H = self.wp + self.E

    def __len__(self):
        return len(self.t)

    def to_pandas(self):
        """The events as a pandas DataFrame: i, name, which, direction, k, t, q1..qn, p1..pn, wp, H, E
        (needs pandas: Debian python3-pandas)."""
        pd = _pandas()
        n = self.q.shape[1]
        cols = {"i": self.i, "name": self.name, "which": self.which, "direction": self.direction, "k": self.k,
                "t": self.t}
        cols.update({"q%d" % (j + 1): self.q[:, j] for j in range(n)})
        cols.update({"p%d" % (j + 1): self.p[:, j] for j in range(n)})
        cols.update({"wp": self.wp, "H": self.H, "E": self.E})
        return pd.DataFrame(cols)


def _pandas():
    try:
        import pandas
    except ImportError as e:
        raise ImportError("to_pandas needs pandas (Debian: apt-get install python3-pandas; bash scripts/setup.sh "
                          "installs it)") from e
    return pandas


class Result:
    """What a run gives, as numpy arrays over its samples (rows as dth run writes them):
    k, t, lam (the step), q (m, n), p (m, n), wp, H (= wp + H_phys), E (= H_phys, the energy),
    z (m, 2n+2), kind (vertex, midpoint, time, end), invariants (m, ninv) with invariant_names
    (and inv: a dict name -> column); iters, branch, ordinary (1: an ordinary DTH step, 0: a
    regularizer's); reversible (1: the step is its own reverse, 0: not: dth run's diagnostics column);
    err_q, err_p (the estimated global error |dq|, |dp| at each sample, dth run's
    diagnostics columns; NaN without an estimate); with diagnostics: psi, dpsi, region (names).
    events: an Events. status (0 or a positive status: the trajectory could not go on),
    status_name, message, stop ("end", "event", "failed"), steps (vertex index at the end),
    t_stop, crossings, regularized, nonreversible (steps not their own reverse), max_ratio, lam_max
    (the largest step of the run so far) and t_lam_max (where it ended), err_q_end and err_p_end (the error
    estimate at the last vertex; NaN without one); megno, lyapunov, megno_span, megno_t_stop where
    asked for.
    """

    def to_pandas(self):
        """The samples as a pandas DataFrame, one row per sample with dth run's columns: k, kind, t,
        lam, q1..qn, p1..pn, wp, H, E, iters, branch, ordinary, reversible, err_q, err_p, the invariants by name and, with
        diagnostics, psi, dpsi, region (needs pandas: Debian python3-pandas). r.events.to_pandas()
        gives the events."""
        pd = _pandas()
        n = self.q.shape[1]
        cols = {"k": self.k, "kind": self.kind, "t": self.t, "lam": self.lam}
        cols.update({"q%d" % (j + 1): self.q[:, j] for j in range(n)})
        cols.update({"p%d" % (j + 1): self.p[:, j] for j in range(n)})
        cols.update({"wp": self.wp, "H": self.H, "E": self.E, "iters": self.iters, "branch": self.branch,
                     "ordinary": self.ordinary, "reversible": self.reversible, "err_q": self.err_q, "err_p": self.err_p})
        cols.update(self.inv)
        if hasattr(self, "psi"):
            cols.update({"psi": self.psi, "dpsi": self.dpsi, "region": self.region})
        return pd.DataFrame(cols)

    def plot(self, path=None, title=None):
        """A figure of the run (matplotlib; Debian python3-matplotlib): q and p against t, the orbit
        (q1, p1) for one degree of freedom, else (q1, q2), with the located events marked, and the
        relative energy error (E - E0)/|E0| against t. Returns the Figure; with `path`, also saves it."""
        import matplotlib.pyplot as plt
        n = self.q.shape[1]
        fig, ax = plt.subplots(1, 3, figsize=(14, 4))
        for j in range(n):
            ax[0].plot(self.t, self.q[:, j], lw=0.8, label="q%d" % (j + 1))
            ax[0].plot(self.t, self.p[:, j], lw=0.8, ls="--", label="p%d" % (j + 1))
        ax[0].set_xlabel("t")
        ax[0].set_title("coordinates and momenta")
        if 2 * n <= 8:
            ax[0].legend(fontsize=7)
        x, y, lx, ly = (self.q[:, 0], self.p[:, 0], "q1", "p1") if n == 1 else (self.q[:, 0], self.q[:, 1], "q1", "q2")
        ax[1].plot(x, y, lw=0.6)
        if len(self.events):
            ex, ey = (self.events.q[:, 0], self.events.p[:, 0]) if n == 1 else (self.events.q[:, 0], self.events.q[:, 1])
            ax[1].plot(ex, ey, "r.", ms=4, label="events")
            ax[1].legend(fontsize=7)
        ax[1].set_xlabel(lx)
        ax[1].set_ylabel(ly)
        ax[1].set_title("orbit")
        if len(self.E) and self.E[0] != 0:
            ax[2].plot(self.t, (self.E - self.E[0]) / abs(self.E[0]), lw=0.6)
            ax[2].set_ylabel("(E - E0) / |E0|")
        else:
            ax[2].plot(self.t, self.E - (self.E[0] if len(self.E) else 0), lw=0.6)
            ax[2].set_ylabel("E - E0")
        ax[2].set_xlabel("t")
        kinds = sorted(set(self.kind))
        ax[2].set_title("energy error at the %s samples" % "/".join(kinds))
        fig.suptitle(title or "%d samples to t = %.6g (stop: %s, status %s)" % (
            len(self.t), self.t[-1] if len(self.t) else math.nan, getattr(self, "stop", "?"),
            getattr(self, "status_name", "?")))
        fig.tight_layout()
        if path is not None:
            fig.savefig(path, dpi=100)
        return fig

    def __repr__(self):
        return "<dth.Result %d samples, t %.6g .. %.6g, stop %s, status %s>" % (
            len(self.t), self.t[0] if len(self.t) else math.nan, self.t[-1] if len(self.t) else math.nan,
            self.stop, self.status_name)


class _Collect:
    """The sample and event callbacks of one dth_run call: rows as Python lists."""

    def __init__(self, rs, diagnostics):
        self.rs = rs
        self.model = rs.model
        self.n = rs.n
        self.N = 2 * rs.n + 2
        self.diag = diagnostics
        L = lib()
        self.ninv = L.dth_model_n_invariants(self.model)
        self.inv_names = [ffi.string(L.dth_model_invariant_name(self.model, i)).decode() for i in range(self.ninv)]
        self.inv = ffi.new("double[]", max(self.ninv, 1))
        self.work = ffi.new("double[]", max(L.dth_model_work_size(self.model), 1))
        self.H = ffi.new("double *")
        self.d = ffi.new("dth_diag *")
        self.rows, self.evs = [], []

    def energy(self, z):
        L = lib()
        rc = L.dth_model_eval(self.model, z, L.DTH_EVAL_H, self.H, ffi.NULL, ffi.NULL)
        return self.H[0] if rc == 0 else math.nan

    def sample(self, s):
        L, N = lib(), self.N
        z = s.z
        k = s.index if s.kind == L.DTH_SAMPLE_TIME or (s.kind == L.DTH_SAMPLE_END and self.rs.dt > 0) else s.k
        lam = getattr(s.step, "lambda")
        row = [k, s.kind, lam, ffi.unpack(z, N), self.energy(z), s.step.iters, int(s.step.branch), s.step.flags,
               (s.err_q, s.err_p)]
        if self.ninv:
            if L.dth_model_invariants(self.model, z, self.inv) == 0:
                row.append(ffi.unpack(self.inv, self.ninv))
            else:
                row.append([math.nan] * self.ninv)
        if self.diag:
            # K and the root for the local K estimate as dth run's diagnostics take them
            lam_root, K = 0.0, self.rs.opt.K
            if s.kind == L.DTH_SAMPLE_VERTEX:
                lam_root = s.lambda_out
            elif s.za == ffi.NULL:
                lam_root = -lam
            elif s.kind != L.DTH_SAMPLE_MIDPOINT:
                if L.dth_diagnose(self.model, s.za, lam, K, self.d, self.work) == 0:
                    K = self.d.K
                else:
                    K = 0.0
            if L.dth_diagnose(self.model, z, lam_root, K, self.d, self.work) == 0:
                row.append((self.d.psi, self.d.dpsi, int(self.d.region)))
            else:
                row.append((math.nan, math.nan, 0))
        self.rows.append(row)
        return 0

    def event(self, s):
        self.evs.append((s.index, s.event, s.direction, s.k, ffi.unpack(s.z, self.N), self.energy(s.z)))
        return 0

    def result(self, names):
        n, N, rows = self.n, self.N, self.rows
        r = Result()
        m = len(rows)
        r.k = np.array([x[0] for x in rows], dtype=np.int64)
        r.kind = [_KIND[x[1]] for x in rows]
        r.lam = np.array([x[2] for x in rows], dtype=np.float64)
        r.z = np.array([x[3] for x in rows], dtype=np.float64).reshape(m, N)
        r.E = np.array([x[4] for x in rows], dtype=np.float64)
        r.iters = np.array([x[5] for x in rows], dtype=np.int64)
        r.branch_code = np.array([x[6] for x in rows], dtype=np.int64)
        r.branch = [ffi.string(lib().dth_branch_name(b)).decode() for b in r.branch_code]
        r.t, r.q, r.p, r.wp = r.z[:, n], r.z[:, :n], r.z[:, n + 1:2 * n + 1], r.z[:, N - 1]
        r.H = r.wp + r.E
        # 1: the step is an ordinary (symplectic) DTH step, 0: a regularizer's (dth run's column ordinary)
        reg = lib().DTH_STEP_REGULARIZED
        r.ordinary = np.array([0 if x[7] & reg else 1 for x in rows], dtype=np.int64)
        # 1: the step is its own reverse, 0: not (a regularizer's reset, clock correction or fallback;
        # dth run's diagnostics column reversible)
        nrev = lib().DTH_STEP_NONREVERSIBLE
        r.reversible = np.array([0 if x[7] & nrev else 1 for x in rows], dtype=np.int64)
        # the estimated global error |dq|, |dp| at each sample (NaN without [integrator] estimate)
        r.err_q = np.array([x[8][0] for x in rows], dtype=np.float64)
        r.err_p = np.array([x[8][1] for x in rows], dtype=np.float64)
        r.invariant_names = list(self.inv_names)
        c = 9
        if self.ninv:
            r.invariants = np.array([x[c] for x in rows], dtype=np.float64).reshape(m, self.ninv)
            c += 1
        else:
            r.invariants = np.zeros((m, 0))
        r.inv = {nm: r.invariants[:, i] for i, nm in enumerate(self.inv_names)}
        if self.diag:
            r.psi = np.array([x[c][0] for x in rows], dtype=np.float64)
            r.dpsi = np.array([x[c][1] for x in rows], dtype=np.float64)
            r.region = [ffi.string(lib().dth_region_name(x[c][2])).decode() for x in rows]
        r.events = Events(n, self.evs, names)
        return r


# ---------------------------------------------------------------- runs

class _Megno:
    """dth_megno (chaos.h) over the legs of a run."""

    g = None  # a partly built one (an exception in __init__) is closed without errors

    def __init__(self, it, delta0, N):
        L = lib()
        self.it = it
        gp = ffi.new("dth_megno **")
        if delta0 is None:
            d, nd = ffi.NULL, 0
        else:
            v = np.asarray(delta0, dtype=np.float64).ravel()
            if len(v) != N:
                raise ValueError("dth: megno: the deviation vector has %d values, not 2n+2 = %d (over q, t, p, wp)"
                                 % (len(v), N))
            d, nd = ffi.new("double[]", v.tolist()), len(v)
        rc = L.dth_megno_new_len(it, d, nd, ffi.NULL, gp)
        if rc:
            raise DthError(rc, "megno: cannot follow the deviation vector (2n+2 = %d finite values, not all zero)" % N)
        self.g = gp[0]

    def update(self):
        rc = lib().dth_megno_update(self.g, self.it)
        if rc:
            raise DthError(rc, "MEGNO: %s" % strerror(rc))

    def result(self):
        r = ffi.new("dth_megno_result *")
        lib().dth_megno_get(self.g, r)
        return r.megno, r.lyapunov, r.span, r.t_stop

    def close(self):
        if self.g is not None:
            lib().dth_megno_free(self.g)
            self.g = None

    def __del__(self):
        self.close()


_POINTS = {"vertices": 0, "midpoints": 1, "times": 2}


class Event:
    """An event function of the trajectory, located by the run driver like the scene's [events]:
    g(t, q, p) -> float is evaluated at every vertex, and where it changes sign over a step (in
    `direction`: +1 increasing, -1 decreasing, 0 both) the crossing is located on the dense output to
    round-off in t (run.h). `terminal`: the run ends at the first one. `name`: how r.events names it
    (default: the function's __name__).

        dth.run(scene, events=[dth.Event(lambda t, q, p: q[1], direction=+1, name="q2-up")])

    A plain callable is an Event with direction 0, not terminal. Exceptions raised by g end the run
    and are re-raised by run(); g must not call the Simulation it belongs to.
    """

    def __init__(self, g, direction=0, terminal=False, name=None):
        if not callable(g):
            raise TypeError("dth: an event is a callable g(t, q, p), not %r" % (g,))
        if direction not in (-1, 0, 1):
            raise ValueError("dth: an event's direction is +1, -1 or 0, not %r" % (direction,))
        self.g, self.direction, self.terminal = g, int(direction), bool(terminal)
        self.name = name or getattr(g, "__name__", "event")
        if self.name == "<lambda>":
            self.name = "event"


def _as_event(e):
    return e if isinstance(e, Event) else Event(e)


class Simulation:
    """One trajectory of a scene, run in legs: each run() continues where the last one ended
    (the library's run driver keeps its whole state in a dth_run_state), checkpoint() saves it,
    Simulation.resume() continues from a checkpoint bit for bit.

        sim = dth.Simulation("scenes/pendulum.ini")
        a = sim.run(t_end=10)
        blob = sim.checkpoint()            # bytes (or a file: sim.checkpoint("p.ckpt"))
        b = sim.run(t_end=20)
        c = dth.Simulation.resume(blob).run(t_end=20)    # c's samples are b's, bit for bit

    Threads: a Simulation holds a lock. A call from another thread while one runs (run, close,
    checkpoint, a property) waits until it returns; a call from inside the run (a model, event or
    progress callback of the same thread) raises DthError. After close() every method and property
    raises DthError ("the Simulation is closed").

    A scene with integrator.h_max or integrator.tol is calibrated when the Simulation is made: pilot runs
    to the scene's t_end choose the first step (control.h, dth_run_setup_control), and `control` holds
    what they found (h0, C, passes, steps, est, est_pred, extrapolated, ...; None without either key).
    Each run() stops with status DTH_ESTEPSIZE after a step above 1.05 h_max.
    """

    _lock = None  # a partly built one (an exception in __init__) closes without errors
    _it = ffi.NULL
    _rs = None
    _reg = None
    _megno = None
    _owner = None

    def __init__(self, scene, set=None, models=(), check_model=True, events=(), _restore=None):
        L = lib()
        self._lock = threading.Lock()
        self._keep = []
        self.scene = Scene(scene, set)
        self._reg = _Registry(models)
        self._rs = ffi.new("dth_run_setup *")
        self._st = ffi.new("dth_run_state *")
        err = ffi.new("char[]", _ERRLEN)
        s = self.scene._load()
        try:
            rc = L.dth_scene_setup(s, self._reg.ptr, self._rs, err, _ERRLEN)
            _raise_pending()
            if rc:
                self._rs = None
                raise DthError(rc, _err(err))
            self._text = _scene_text(s, bool(self._rs.has_t_end))
        except BaseException:
            self.close()
            raise
        finally:
            L.dth_scene_free(s)
        rs = self._rs
        self.n = rs.n
        self.method = ffi.string(rs.method).decode()
        self.model_name = ffi.string(L.dth_model_get_type(rs.model).name).decode()
        try:
            self._events_setup(events)
        except BaseException:
            self.close()
            raise
        if check_model and _restore is None and rs.n <= 200:
            y = ffi.new("double[]", 2 * rs.n + 1)
            ffi.memmove(y, rs.q0, 8 * rs.n)
            y[rs.n] = rs.t0
            ffi.memmove(y + rs.n + 1, rs.p0, 8 * rs.n)
            rep = ffi.new("dth_model_check_report *")
            rc = L.dth_model_check(rs.model, y, rep)
            try:
                _raise_pending()
            except BaseException:
                self.close()
                raise
            if rc == 0 and not getattr(rep, "pass"):
                self.close()
                raise DthError(-1, "%s: model '%s' fails its derivative check at the initial state: %s "
                               "(check_model=False runs it anyway)" % (self.scene.name, self.model_name,
                                                                      ffi.string(rep.message).decode()))
        self.control = None
        if _restore is None and (rs.h_max > 0 or rs.tol > 0):
            self._calibrate()
        why = ffi.new("char[]", 256)
        opt = ffi.new("dth_options *")
        opt[0] = rs.opt
        rc = L.dth_options_check(rs.model, opt, why, 256)
        if rc:
            self.close()
            raise DthError(rc, "method '%s': %s" % (self.method, _err(why)))
        ip = ffi.new("dth_integrator **")
        rc = L.dth_integrator_new(rs.model, ffi.addressof(rs, "opt"), ip)
        if rc:
            self.close()
            raise DthError(rc, "cannot create the integrator")
        self._it = ip[0]
        if _restore is not None:
            buf = _restore
            # the integrator and the run driver's state, all or nothing (its rules checked)
            rc = L.dth_checkpoint_restore_run(self._it, self._st, buf, len(buf), err, _ERRLEN)
            try:
                _raise_pending()
            except BaseException:
                self.close()
                raise
            if rc:
                self.close()
                raise DthError(rc, _err(err))
        else:
            rc = L.dth_integrator_start(self._it, rs.q0, rs.p0, rs.t0)
            try:
                _raise_pending()
            except BaseException:
                self.close()
                raise
            if rc:
                msg = ffi.string(L.dth_integrator_errmsg(self._it)).decode()
                self.close()
                raise DthError(rc, "%s: cannot start at the initial state: %s (%s)" % (
                    self.scene.name, strerror(rc), msg))

    def _calibrate(self):
        """integrator.h_max / tol (control.h): the run's constant chosen by pilot runs to the scene's t_end
        before the first step (dth_run_setup_control); self.control says what was found."""
        L, rs = lib(), self._rs
        rep = ffi.new("dth_control_report *")
        rep.size = ffi.sizeof("dth_control_report")
        err = ffi.new("char[]", _ERRLEN)
        rc = L.dth_run_setup_control(rs, rep, err, _ERRLEN)
        try:
            _raise_pending()
        except BaseException:
            self.close()
            raise
        if rc:
            self.close()
            raise DthError(rc, "%s: integrator.%s: %s" % (self.scene.name, "h_max" if rs.h_max > 0 else "tol",
                                                          _err(err)))
        self.control = {k: getattr(rep, k) for k in ("h0", "C", "C_hmax", "C_tol", "step_max", "passes", "steps",
                                                     "t_pilot", "est", "est_pred", "hmax_restarts", "t_excursion",
                                                     "pilot_status", "t_failed")}
        self.control["extrapolated"] = bool(rep.extrapolated)
        self.control["hmax_settled"] = bool(rep.hmax_settled)

    def _events_setup(self, events):
        """The run's events: the scene's [events], then the Python ones (cffi callbacks)."""
        rs = self._rs
        self.event_names = [ffi.string(rs.event_names[i]).decode() for i in range(rs.nevents)]
        self.py_events = [_as_event(e) for e in (events or ())]
        self._nevents = rs.nevents + len(self.py_events)
        self._events = rs.events
        if not self.py_events:
            return
        n = rs.n
        arr = ffi.new("dth_event[]", self._nevents)
        for i in range(rs.nevents):
            arr[i] = rs.events[i]
        pe = self.py_events

        @ffi.callback("int(void *, size_t, const double *, double *)", error=DTH_EMODEL, onerror=_onerror)
        def g_cb(user, nn, z, g):
            e = pe[int(ffi.cast("uintptr_t", user))]
            zv = np.frombuffer(ffi.buffer(z, 8 * (2 * n + 2)), dtype=np.float64)
            g[0] = float(e.g(zv[n], zv[:n], zv[n + 1:2 * n + 1]))
            return 0

        for j, e in enumerate(pe):
            a = arr[rs.nevents + j]
            a.g, a.user = g_cb, ffi.cast("void *", j)
            a.direction, a.terminal = e.direction, 1 if e.terminal else 0
            self.event_names.append(e.name)
        self._events = arr
        self._keep += [arr, g_cb]

    @contextlib.contextmanager
    def _use(self, closing=False):
        """Hold the Simulation's lock for a call (see the class: waits for another thread's call,
        refuses a call from inside its own run, and a closed Simulation)."""
        lock = self._lock
        if lock is None:  # partly built
            if closing:
                yield
                return
            raise DthError(_STATUS["DTH_EINVAL"], "the Simulation was not built")
        me = threading.get_ident()
        if self._owner == me:
            raise DthError(_STATUS["DTH_EINVAL"], "Simulation: called from inside its own run (a callback of "
                           "this thread): close() and the other methods wait for the run to return")
        with lock:
            self._owner = me
            try:
                if not closing and self._it == ffi.NULL:
                    raise DthError(_STATUS["DTH_EINVAL"], "the Simulation is closed")
                yield
            finally:
                self._owner = None

    def close(self):
        """Free the C objects (also done when the object is collected). From another thread during a
        run it waits for the run to return; after it, every method raises DthError."""
        with self._use(closing=True):
            L = lib()
            if self._megno is not None:
                self._megno.close()
                self._megno = None
            if self._it != ffi.NULL:
                L.dth_integrator_free(self._it)
                self._it = ffi.NULL
            if self._rs is not None:
                L.dth_run_setup_clear(self._rs)
                self._rs = None
            if self._reg is not None:
                self._reg.close()

    @property
    def closed(self):
        """True once close() ran (or the Simulation could not be built)."""
        return self._it == ffi.NULL

    def __del__(self):
        try:
            self.close()
        except Exception:  # noqa: BLE001  (never from a finalizer)
            pass

    def __enter__(self):
        return self

    def __exit__(self, *a):
        self.close()

    @property
    def vertex(self):
        """The current vertex z_k (q, t, p, wp) as a numpy array (DTH), or the state (q, t, p, wp)."""
        with self._use():
            N = 2 * self.n + 2
            return np.array(ffi.unpack(lib().dth_integrator_vertex(self._it), N))

    @property
    def steps(self):
        """Vertex index k (steps from the start)."""
        with self._use():
            return self._st.k

    @property
    def t(self):
        """Time of the current vertex."""
        with self._use():
            return float(lib().dth_integrator_vertex(self._it)[self.n])

    def check_model(self, y=None):
        """The model's derivatives against finite differences (dth_model_check, model.h) at y (2n+1
        values over q, t, p; default: the initial state): a dict with grad_err, hess_err, sym_err,
        third_err (0 without a third derivative), band_err, tol, pass and message."""
        with self._use():
            rs, L = self._rs, lib()
            yy = ffi.new("double[]", 2 * rs.n + 1)
            if y is None:
                ffi.memmove(yy, rs.q0, 8 * rs.n)
                yy[rs.n] = rs.t0
                ffi.memmove(yy + rs.n + 1, rs.p0, 8 * rs.n)
            else:
                v = np.asarray(y, dtype=np.float64).ravel()
                if len(v) != 2 * rs.n + 1:
                    raise ValueError("dth: check_model: y has %d values, not 2n+1 = %d" % (len(v), 2 * rs.n + 1))
                ffi.memmove(yy, np.ascontiguousarray(v), 8 * len(v))
            rep = ffi.new("dth_model_check_report *")
            rc = L.dth_model_check(rs.model, yy, rep)
            _raise_pending()
            if rc:
                raise DthError(rc, "check_model: the model's evaluation failed: %s" % strerror(rc))
            out = {k: getattr(rep, k) for k in ("grad_err", "hess_err", "sym_err", "third_err", "band_err", "tol")}
            out["pass"] = bool(getattr(rep, "pass"))
            out["message"] = ffi.string(rep.message).decode()
            return out

    def run(self, t_end=None, steps=None, points=None, every=None, dt=None, times=None, diagnostics=None,
            megno=False, progress=None):
        """Integrate to t_end (or to the vertex index `steps`) from where the last call ended, with the
        scene's output settings unless given: points ("vertices", "midpoints", "times" with dt or
        times), every, diagnostics. megno=True (or an initial deviation vector of 2n+2 values) also
        follows a deviation vector through the tangent maps (chaos.h: r.megno, r.lyapunov over
        r.megno_span; they end at the first regularized step, r.megno_t_stop; DTH only); the
        indicator continues over consecutive legs that all ask for it. progress: a callable(state)
        called every step, returning True to stop. Returns a Result holding this leg's samples
        and events. What the driver refuses (dth_run_check: times not finite or out of order,
        negative steps, t_end or steps behind where the run stands, a dt asking for more than 1e6
        rows per step) raises DthError with its message before anything runs."""
        with self._use():
            return self._run(t_end, steps, points, every, dt, times, diagnostics, megno, progress)

    def _run(self, t_end, steps, points, every, dt, times, diagnostics, megno, progress):
        L = lib()
        rs = self._rs
        cfg = ffi.new("dth_run_config *")
        L.dth_run_config_default(cfg)
        cfg.has_t_end, cfg.t_end, cfg.steps = rs.has_t_end, rs.t_end, rs.steps
        if t_end is not None and steps is not None:
            raise ValueError("dth: give t_end or steps, not both")
        if t_end is not None:
            cfg.has_t_end, cfg.t_end = 1, float(t_end)
        if steps is not None:
            if isinstance(steps, bool) or not isinstance(steps, numbers.Integral):
                raise TypeError("dth: steps is an integer (a vertex index), not %r" % (steps,))
            cfg.has_t_end, cfg.steps = 0, int(steps)
        cfg.t0 = rs.t0
        cfg.step_max = rs.step_max  # integrator.h_max's guard (1.05 h_max; 0: none)
        cfg.points, cfg.every, cfg.dt = rs.points, rs.every, rs.dt
        if dt is not None:
            cfg.points, cfg.dt = 2, float(dt)
        tbuf = None
        if times is not None:
            tv = np.asarray(times, dtype=np.float64).ravel()
            tbuf = ffi.new("double[]", max(len(tv), 1))
            ffi.memmove(tbuf, np.ascontiguousarray(tv), 8 * len(tv))
            cfg.points, cfg.times, cfg.ntimes = 2, tbuf, len(tv)
        if points is not None:
            if points not in _POINTS:
                raise ValueError("dth: points is one of %s" % ", ".join(_POINTS))
            cfg.points = _POINTS[points]
        if every is not None:
            cfg.every = int(every)
        cfg.events, cfg.nevents = self._events, self._nevents
        err = ffi.new("char[]", _ERRLEN)
        rc = L.dth_run_check(self._it, cfg, self._st, err, _ERRLEN)
        if rc:
            raise DthError(rc, "run: %s" % _err(err))
        col = _Collect(rs, bool(rs.diagnostics) if diagnostics is None else bool(diagnostics))

        @ffi.callback("int(void *, const dth_sample *)", error=-1, onerror=_onerror)
        def on_sample(user, s):
            return col.sample(s)

        @ffi.callback("int(void *, const dth_sample *)", error=-1, onerror=_onerror)
        def on_event(user, s):
            return col.event(s)

        cfg.sample, cfg.on_event = on_sample, on_event
        meg = None
        if megno is not False and megno is not None:
            if self.method != "dth":
                raise DthError(-8, "MEGNO needs the DTH tangent map (method = dth)")
            if self._megno is None or megno is not True:  # start (or restart with a given vector)
                if self._megno is not None:
                    self._megno.close()
                    self._megno = None
                self._megno = _Megno(self._it, None if megno is True else megno, 2 * self.n + 2)
            meg = self._megno
        elif self._megno is not None:  # a leg without it: the indicator cannot continue
            self._megno.close()
            self._megno = None
        if meg is not None or progress is not None:
            @ffi.callback("int(void *, const dth_run_state *)", error=-1, onerror=_onerror)
            def on_progress(user, st):
                if meg is not None:
                    meg.update()
                if progress is not None and progress(st):
                    return _STATUS["DTH_ESTOPPED"]
                return 0
            cfg.progress, cfg.progress_every = on_progress, 1
        st = self._st
        rc = L.dth_run(self._it, cfg, st)
        _raise_pending()
        if meg is not None:
            meg.update()  # the last step (no progress call follows it)
        r = col.result(self.event_names)
        r.status = rc
        r.status_name = status_name(rc)
        msg = ""
        if rc > 0:
            msg = ffi.string(L.dth_integrator_errmsg(self._it)).decode()
        r.message = msg
        r.stop = _STOP.get(st.stop, str(st.stop))
        r.steps, r.t_stop = st.k, st.t_stop
        r.crossings, r.regularized, r.max_ratio = st.crossings, st.regularized, st.max_ratio
        r.nonreversible = st.nonreversible
        r.lam_max, r.t_lam_max = st.lam_max, st.t_lam_max
        r.err_q_end, r.err_p_end = st.err_q, st.err_p
        if meg is not None:
            r.megno, r.lyapunov, r.megno_span, r.megno_t_stop = meg.result()
        if st.stop == L.DTH_RUN_SAMPLES:
            raise DthError(rc, "stopped at k=%d, t=%.17g: the output times asked for more than %d rows within one "
                           "step (a larger dt, or points='vertices'; the rows so far are in this exception's "
                           "result)" % (st.k, st.t, L.DTH_RUN_MAX_SAMPLES_PER_STEP), result=r)
        if rc < 0:
            raise DthError(rc, "%s at k=%d, t=%.17g" % (strerror(rc), st.k, st.t), result=r)
        return r

    # ---- checkpoints (checkpoint.h: the public save/restore API only)

    def checkpoint(self, path=None):
        """The integrator's checkpoint with the run driver's state (dth_checkpoint_save_run) and two
        blobs: "scene" (the scene as INI text, as dth run stores it) and "python" (the package's
        format version). Returns the bytes; with `path`, also writes them crash-safely."""
        with self._use():
            data = self._checkpoint()
        if path is not None:
            import os
            tmp = "%s.tmp" % path
            with open(tmp, "wb") as f:
                f.write(data)
                f.flush()
                os.fsync(f.fileno())
            os.replace(tmp, path)
        return data

    def _checkpoint(self):
        L = lib()
        scene = self._text.encode()
        # 2: the run state in the library's section "run" (1: its host bytes in a blob of their own)
        meta = json.dumps({"version": 2, "scene_name": self.scene.name}).encode()
        b = ffi.new("dth_blob[2]")
        keep = [ffi.new("char[]", x) for x in (b"scene", b"python")]
        datas = [ffi.from_buffer(x) if x else ffi.NULL for x in (scene, meta)]
        for i, (nm, d, x) in enumerate(zip(keep, datas, (scene, meta))):
            b[i].name, b[i].data, b[i].size = nm, d, len(x)
        ln = ffi.new("size_t *")
        rc = L.dth_checkpoint_save_run(self._it, self._st, b, 2, ffi.NULL, 0, ln)
        buf = ffi.new("char[]", ln[0])
        rc = L.dth_checkpoint_save_run(self._it, self._st, b, 2, buf, ln[0], ln)
        if rc:
            raise DthError(rc, "cannot save the checkpoint")
        return bytes(ffi.buffer(buf, ln[0]))

    @classmethod
    def resume(cls, source, models=(), set=None, events=()):
        """A Simulation continued from a checkpoint (bytes, or a file written by checkpoint()).
        User models and Python events must be given again (the checkpoint names its model type).
        `set` may change what the library lets a resume change (dth_scene_resume_check, scene.h,
        the rule dth run --resume follows): integrator.t_end, integrator.steps, the file names, and
        output.every and output.diagnostics (each leg's rows are their own Result); anything else
        would change the checkpointed run and raises DthError naming the key."""
        L = lib()
        data = source if isinstance(source, (bytes, bytearray)) else open(source, "rb").read()
        err = ffi.new("char[]", _ERRLEN)
        rc = L.dth_checkpoint_verify(data, len(data), err, _ERRLEN)
        if rc:
            raise DthError(rc, _err(err))
        p, sz = ffi.new("void **"), ffi.new("size_t *")

        def blob(name):
            rc = L.dth_checkpoint_blob(data, len(data), name.encode(), p, sz)
            if rc:
                raise DthError(rc, "the checkpoint has no '%s' blob (not written by dth.Simulation?)" % name)
            return bytes(ffi.buffer(p[0], sz[0])) if sz[0] else b""

        text = blob("scene").decode()
        meta = json.loads(blob("python").decode())
        if meta.get("version") != 2:
            raise DthError(-6, "the checkpoint is of another version of the package")
        name = meta.get("scene_name", "<checkpoint>")
        saved = Scene(text)
        saved.name = name
        sc = Scene(saved, set)
        if sc.overrides:
            a, b = saved._load(), sc._load()
            try:
                rc = L.dth_scene_resume_check(a, b, L.DTH_RESUME_ROWS, b"Simulation.resume", err, _ERRLEN)
            finally:
                L.dth_scene_free(a)
                L.dth_scene_free(b)
            if rc:
                raise DthError(rc, _err(err))
        return cls(sc, models=models, events=events, _restore=data)


def run(scene, set=None, models=(), check_model=True, events=(), **kw):
    """Run a scene (a path, INI text, a dict or a Scene) from its start through the library's
    driver dth_run and return a Result. `set`: overrides {"section.key": value}; `models`: user
    model types (dth.Model subclasses, dth.load_model results, dth.Model.from_hamiltonian results);
    `events`: Python event functions (dth.Event, or callables g(t, q, p)). Keywords of
    Simulation.run: t_end, steps, points, every, dt, times, diagnostics, megno, progress."""
    with Simulation(scene, set=set, models=models, check_model=check_model, events=events) as sim:
        return sim.run(**kw)


# ---------------------------------------------------------------- roots

class Roots:
    """Every real root of the step constraint at a vertex, classified (dth_find_roots): arrays
    lam, s, residual, slope, flags; cls (names: minus, plus, ghost, double, zero); the vertex's
    H, psi, dpsi, K, region; the range asked for [-L, L] and the range scanned lo, hi; truncated:
    the list may be incomplete (more roots than the library holds, or the scan stopped short of
    [-L, L]: lo > -L or hi < L)."""

    def __repr__(self):
        return "<dth.Roots %d roots at region %s: %s>" % (
            len(self.lam), self.region, ", ".join("%s %.6g" % (c, x) for c, x in zip(self.cls, self.lam)))


@contextlib.contextmanager
def _rootfinder(rs):
    """A root finder (dth_rootfinder_new) for a run setup's model, with dth_root_options_default and the
    scene's K; freed when the with block ends."""
    lb = lib()
    ro = ffi.new("dth_root_options *")
    lb.dth_root_options_default(ro)
    ro.K = rs.opt.K
    rfp = ffi.new("dth_rootfinder **")
    rc = lb.dth_rootfinder_new(rs.model, ro, ffi.NULL, rfp)
    if rc:
        raise DthError(rc)
    try:
        yield rfp[0]
    finally:
        lb.dth_rootfinder_free(rfp[0])


def roots(scene, set=None, models=(), L=None, z=None):
    """Classify the roots of the step at the scene's initial state taken as a vertex (as dth roots
    does: wp = -H_phys + psi h^2/8), or at the extended vertex z (2n+2 values), in [-L, L]
    (default 16 |h|)."""
    lb = lib()
    sc = Scene(scene, set)
    with Simulation(sc.set("integrator.start", "vertex"), models=models, check_model=False) as sim:
        rs = sim._rs
        if z is None:
            zz = ffi.new("double[]", ffi.unpack(lb.dth_integrator_vertex(sim._it), 2 * rs.n + 2))
        else:
            zz = ffi.new("double[]", [float(x) for x in z])
            if len(zz) != 2 * rs.n + 2:
                raise ValueError("dth: z has %d values, not 2n+2 = %d" % (len(zz), 2 * rs.n + 2))
        out = ffi.new("dth_root_set *")
        LL = float(L) if L else 16 * abs(rs.opt.h)
        if not (LL > 0 and math.isfinite(LL)):
            raise ValueError("dth: roots: L = %r is not a positive, finite range" % (L,))
        with _rootfinder(rs) as rf:
            rc = lb.dth_find_roots(rf, zz, LL, out)
            _raise_pending()
        if rc:
            raise DthError(rc, "root search failed at the vertex: %s" % strerror(rc))
        r = Roots()
        c = out.count
        rt = [out.root[i] for i in range(c)]
        r.lam = np.array([getattr(x, "lambda") for x in rt])
        r.s = np.array([x.s for x in rt])
        r.residual = np.array([x.residual for x in rt])
        r.slope = np.array([x.slope for x in rt])
        r.flags = np.array([x.flags for x in rt], dtype=np.int64)
        r.cls = [ffi.string(lb.dth_root_class_name(ffi.addressof(out.root[i]))).decode() for i in range(c)]
        v = out.vertex
        r.H, r.psi, r.dpsi, r.K = v.H, v.psi, v.dpsi, v.K
        r.region = ffi.string(lb.dth_region_name(v.region)).decode()
        r.L, r.lo, r.hi = LL, out.lo, out.hi
        # honest about a scan that stopped short of [-L, L], whatever the library's flag says
        r.truncated = bool(out.truncated) or out.lo > -LL or out.hi < LL
        r.z = np.array(ffi.unpack(zz, 2 * rs.n + 2))
        return r


# ---------------------------------------------------------------- map

class Map:
    """A phase-plane well-posedness map (as dth map writes it): arrays over the grid (nq, np) of
    psi, dpsi, region (names; "" where the root search failed), nroots, lambda_minus, lambda_plus,
    lambda_ghost (NaN: no such root), status; and the axes q, p."""

    def __repr__(self):
        return "<dth.Map %d x %d>" % self.psi.shape


def map(scene, q, p, set=None, models=(), dof=1, L=None):  # noqa: A001  (the CLI's name)
    """psi, [psi, H], the region and the classified roots at every point (q_i, p_i) of a grid taken as
    a vertex, the other degrees of freedom at the scene's initial values (dth map, cli/cmd_map.c):
    q = (a, b, n) and p = (c, d, m) are the axes, dof the degree of freedom mapped (1-based). Each
    point's offset is a vertex start's, wp = -H_phys + psi h^2/8. Roots in [-L, L], default 16 |h|."""
    lb = lib()
    with Simulation(scene, set=set, models=models, check_model=False) as sim:
        rs = sim._rs
        n = rs.n
        if not 1 <= dof <= n:
            raise ValueError("dth: dof %d: the model has %d degrees of freedom" % (dof, n))
        axis = lambda a, b, k: np.array([a] if k == 1 else  # noqa: E731  (symmetric in a and b, as dth map)
                                        [((k - 1 - i) * a + i * b) / (k - 1) for i in range(k)], dtype=np.float64)
        qs, ps = axis(float(q[0]), float(q[1]), int(q[2])), axis(float(p[0]), float(p[1]), int(p[2]))
        h = rs.opt.h
        LL = float(L) if L else 16 * abs(h)
        z = ffi.new("double[]", 2 * n + 2)
        work = ffi.new("double[]", lb.dth_model_work_size(rs.model) + 1)
        H, psi, dpsi = ffi.new("double *"), ffi.new("double *"), ffi.new("double *")
        out = ffi.new("dth_root_set *")
        shape = (len(qs), len(ps))
        m = Map()
        m.q, m.p = qs, ps
        m.psi, m.dpsi = np.full(shape, np.nan), np.full(shape, np.nan)
        m.lambda_minus, m.lambda_plus, m.lambda_ghost = (np.full(shape, np.nan) for _ in range(3))
        m.nroots = np.zeros(shape, dtype=np.int64)
        m.status = np.zeros(shape, dtype=np.int64)
        m.region = [["" for _ in ps] for _ in qs]
        with _rootfinder(rs) as rf:
            for i, qv in enumerate(qs):
                for j, pv in enumerate(ps):
                    ffi.memmove(z, rs.q0, 8 * n)
                    z[n] = rs.t0
                    ffi.memmove(z + n + 1, rs.p0, 8 * n)
                    z[dof - 1], z[n + dof] = qv, pv
                    psi[0] = dpsi[0] = math.nan
                    rc = lb.dth_model_eval(rs.model, z, lb.DTH_EVAL_H, H, ffi.NULL, ffi.NULL)
                    if not rc:
                        rc = lb.dth_model_psi(rs.model, z, psi, dpsi, work)
                    m.psi[i, j], m.dpsi[i, j] = psi[0], dpsi[0]
                    if not rc:
                        z[2 * n + 1] = -H[0] + psi[0] * h * h / 8
                        rc = lb.dth_find_roots(rf, z, LL, out)
                    _raise_pending()
                    m.status[i, j] = rc
                    if rc:
                        continue
                    v = out.vertex
                    m.psi[i, j], m.dpsi[i, j] = v.psi, v.dpsi
                    m.region[i][j] = ffi.string(lb.dth_region_name(v.region)).decode()
                    m.nroots[i, j] = out.count
                    for k in range(out.count):
                        r = out.root[k]
                        lam = getattr(r, "lambda")
                        if r.cls == lb.DTH_BRANCH_MINUS:
                            m.lambda_minus[i, j] = lam
                        elif r.cls == lb.DTH_BRANCH_PLUS:
                            m.lambda_plus[i, j] = lam
                        elif r.cls == lb.DTH_BRANCH_GHOST and not abs(lam) >= abs(m.lambda_ghost[i, j]):
                            m.lambda_ghost[i, j] = lam
        return m
