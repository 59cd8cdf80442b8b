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
from ._core import (DthError, OutsideDomain, Scene, Simulation, Result, Events, Roots, Map, Model, CModel,
                    load_model, run, roots, map, models, strerror, status_name)

__version__ = "0.1.0"
__all__ = ["DthError", "OutsideDomain", "Scene", "Simulation", "Result", "Events", "Roots", "Map", "Model", "CModel",
           "load_model", "run", "roots", "map", "models", "strerror", "status_name"]
