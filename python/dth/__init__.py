# SPDX-License-Identifier: MIT
"""dth: symplectic-energy-momentum integration by discrete-time Hamiltonian dynamics, from Python.

A thin layer over the C library libdth (cffi, ABI mode: see _ffi.py for where the library is
found). The one call most users need:

    import dth
    r = dth.run("scenes/pendulum.ini")          # or a dict, or dth.Scene(...)
    r.t, r.q, r.p, r.E                           # numpy arrays over the samples

See docs/python.md for scenes from dicts, user models in Python or C, roots, checkpoints and
MEGNO.
"""
import sys as _sys

try:
    import cffi as _cffi  # noqa: F401  (the binding, _ffi.py)
    import numpy as _numpy  # noqa: F401  (the arrays, _core.py)
except ImportError as _e:
    raise ImportError(
        "dth needs the Python modules cffi and numpy, and this Python (%s) has no module %r. On Debian: "
        "apt-get install python3-cffi python3-numpy (bash scripts/setup.sh installs them), then run "
        "/usr/bin/python3, or a venv that sees them: /usr/bin/python3 -m venv --system-site-packages VENV "
        "(a pyenv or conda Python does not see Debian's modules: pip install cffi numpy there). See "
        "docs/python.md." % (_sys.executable, _e.name or str(_e)), name=_e.name) from _e

from ._core import (DthError, OutsideDomain, Scene, Simulation, Event, Result, Events, Roots, Map, Model, CModel,
                    FormulaModel, load_model, run, roots, map, models, strerror, status_name)

__version__ = "0.1.0"
__all__ = ["DthError", "OutsideDomain", "Scene", "Simulation", "Event", "Result", "Events", "Roots", "Map", "Model",
           "CModel", "FormulaModel", "load_model", "run", "roots", "map", "models", "strerror", "status_name"]
