# SPDX-License-Identifier: MIT
"""Tests of the Python API of issue 25: events as Python callables located like the built-in ones,
Python models with the optional table entries (third, hdiff, domain), models from a Hamiltonian's
formula (SymPy -> C -> a shared object), Result.to_pandas and Result.plot."""
import math
import os
import subprocess
import tempfile
import time
import unittest

import numpy as np

import dth

ROOT = os.environ.get("DTH_SOURCE_ROOT", os.path.join(os.path.dirname(__file__), "..", ".."))
CLI = os.environ.get("DTH_CLI")
HH_SO = os.environ.get("DTH_TEST_HH_SO")
HH_SCENE = os.path.join(ROOT, "docs", "examples", "henon-heiles.ini")


def scene(name):
    return os.path.join(ROOT, "scenes", name)


def has(module):
    try:
        __import__(module)
        return True
    except ImportError:
        return False


class TestPythonEvents(unittest.TestCase):
    def test_callable_section_equals_the_builtin_section(self):
        """A Python g(t, q, p) = q2 crossed upward is located at the built-in section's times, bit for bit
        (the same dense output, the same values of g, the same bracketing)."""
        over = {"events.section": "q2", "events.section_direction": "up", "integrator.t_end": 30}
        a = dth.run(scene("kepler-e06.ini"), set=over)
        b = dth.run(scene("kepler-e06.ini"), set={"integrator.t_end": 30},
                    events=[dth.Event(lambda t, q, p: q[1], direction=+1, name="q2-up")])
        self.assertGreaterEqual(len(a.events), 4)
        np.testing.assert_array_equal(a.events.t, b.events.t)
        np.testing.assert_array_equal(a.events.z, b.events.z)
        self.assertEqual(set(b.events.name), {"q2-up"})
        self.assertTrue(all(d == 1 for d in b.events.direction))

    def test_terminal_event_and_both_kinds(self):
        def q1_zero(t, q, p):
            return q[0]
        r = dth.run(scene("kepler-e06.ini"), set={"events.section": "q2"}, points="vertices",
                    events=[dth.Event(q1_zero, direction=-1, terminal=True)])
        self.assertEqual(r.stop, "event")
        self.assertEqual(r.events.name[-1], "q1_zero")
        self.assertEqual(r.events.direction[-1], -1)
        self.assertEqual(r.kind[-1], "end")
        self.assertEqual(r.t[-1], r.events.t[-1])
        self.assertLess(abs(r.events.q[-1, 0]), 1e-12)
        self.assertEqual(r.events.names, ["section", "q1_zero"])  # the scene's events first
        # a plain callable: both directions, not terminal
        r2 = dth.run(scene("kepler-e06.ini"), set={"integrator.t_end": 20}, events=[lambda t, q, p: t - 3.25])
        self.assertEqual(list(r2.events.t), [3.25])
        self.assertEqual(r2.events.name, ["event"])

    def test_exception_in_event_propagates(self):
        def bad(t, q, p):
            raise KeyError("boom")
        with self.assertRaises(KeyError):
            dth.run(scene("pendulum.ini"), events=[bad])


class Kepler(dth.Model):
    """models/kepler.c (n = 2) in Python with the C model's operations in the C model's order,
    including its hdiff and third."""
    name = "kepler-py"
    params = {"mu": 1.0}
    n = 2
    separable = True

    def H(self, q, t, p):
        q0, q1, p0, p1, mu = float(q[0]), float(q[1]), float(p[0]), float(p[1]), self.params["mu"]
        r2 = 0.0 + q0 * q0 + q1 * q1
        if not r2 > 0:
            raise dth.OutsideDomain()
        r = math.sqrt(r2)
        return 0.5 * (0.0 + p0 * p0 + p1 * p1) - mu / r

    def grad(self, q, t, p):
        q0, q1, mu = float(q[0]), float(q[1]), self.params["mu"]
        r2 = 0.0 + q0 * q0 + q1 * q1
        if not r2 > 0:
            raise dth.OutsideDomain()
        r = math.sqrt(r2)
        mr3 = mu / (r2 * r)
        return (mr3 * q0, mr3 * q1, 0.0, p[0], p[1])

    def hess(self, q, t, p):
        qq, mu = (float(q[0]), float(q[1])), self.params["mu"]
        r2 = 0.0 + qq[0] * qq[0] + qq[1] * qq[1]
        r = math.sqrt(r2)
        mr3 = mu / (r2 * r)
        h = np.zeros((5, 5))
        for i in range(2):
            for j in range(i + 1):
                h[i, j] = h[j, i] = -3 * mr3 * qq[i] * qq[j] / r2
            h[i, i] += mr3
            h[3 + i, 3 + i] = 1
        return h

    def hdiff(self, q1, t1, p1, q0, t0, p0):
        mu = self.params["mu"]
        r1 = math.sqrt(0.0 + q1[0] * q1[0] + q1[1] * q1[1])
        r0 = math.sqrt(0.0 + q0[0] * q0[0] + q0[1] * q0[1])
        dd = kin = 0.0
        for i in range(2):
            dd += (q1[i] - q0[i]) * (q1[i] + q0[i])
            kin += (p1[i] - p0[i]) * (p1[i] + p0[i])
        return 0.5 * kin + mu * (dd / (r1 + r0)) / (r1 * r0)

    def third(self, q, t, p, u):
        mu = self.params["mu"]
        r2 = 0.0 + q[0] * q[0] + q[1] * q[1]
        r = math.sqrt(r2)
        qv = 0.0 + q[0] * u[0] + q[1] * u[1]
        vv = 0.0 + u[0] * u[0] + u[1] * u[1]
        return mu * qv * (15 * qv * qv / r2 - 9 * vv) / (r2 * r2 * r)

    def domain(self, q, t, p):
        return None if (q[0], q[1]) != (0, 0) else "r = 0 (q1 = q2 = 0)"


class KeplerNoHdiff(Kepler):
    name = "kepler-py-plain"
    hdiff = dth.Model.hdiff
    third = dth.Model.third


class TestPythonModelEntries(unittest.TestCase):
    def test_kepler_with_hdiff_equals_the_c_model(self):
        over = {"integrator.t_end": 20}
        c = dth.run(scene("kepler-e06.ini"), set=over)
        py = dth.run(scene("kepler-e06.ini"), models=[Kepler], set=dict(over, **{"model.name": "kepler-py"}))
        np.testing.assert_array_equal(c.z, py.z)
        np.testing.assert_array_equal(c.psi, py.psi)
        np.testing.assert_array_equal(c.dpsi, py.dpsi)  # psi' from `third`, as the C model's
        # without hdiff the step's constraint is evaluated otherwise (a Gauss-Legendre rule of the
        # gradient): not the C model's bits any more; and without third psi' is a difference
        plain = dth.run(scene("kepler-e06.ini"), models=[KeplerNoHdiff],
                        set=dict(over, **{"model.name": "kepler-py-plain"}))
        self.assertFalse(np.array_equal(c.z, plain.z))
        self.assertFalse(np.array_equal(c.dpsi, plain.dpsi))

    def test_model_check_passes_third(self):
        with dth.Simulation(scene("kepler-e06.ini"), models=[Kepler], set={"model.name": "kepler-py"}) as sim:
            rep = sim.check_model([0.3, 0.5, 0, -0.4, 0.9])  # a generic point (third is 0 at pericentre)
            self.assertTrue(rep["pass"], rep["message"])
            self.assertGreater(rep["third_err"], 0)
            self.assertLess(rep["third_err"], 1e-5)

        class WrongThird(Kepler):
            name = "kepler-py-wrong"

            def third(self, q, t, p, u):
                return 2 * Kepler.third(self, q, t, p, u)
        with dth.Simulation(scene("kepler-e06.ini"), models=[WrongThird], set={"model.name": "kepler-py-wrong"}) as sim:
            rep = sim.check_model([0.3, 0.5, 0, -0.4, 0.9])
            self.assertFalse(rep["pass"])
            self.assertIn("third", rep["message"])

    def test_domain_names_the_reason(self):
        with self.assertRaises(dth.DthError) as cm:
            dth.run(scene("kepler-e06.ini"), models=[Kepler], set={"model.name": "kepler-py", "initial.q": [0, 0]})
        self.assertIn("r = 0 (q1 = q2 = 0)", str(cm.exception))


if __name__ == "__main__":
    unittest.main()
