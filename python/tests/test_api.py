# SPDX-License-Identifier: MIT
"""Tests of the Python API of issue 25: events as Python callables located like the built-in ones,
Python models with the optional table entries (third, hdiff, domain), models from a Hamiltonian's
formula (SymPy -> C -> a shared object), Result.to_pandas and Result.plot; and of issue 26:
integrator.h_max and tol in a Simulation."""
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

HH_FORMULA = "p1**2/2 + p2**2/2 + (q1**2 + q2**2)/2 + q1**2*q2 - q2**3/3"


@unittest.skipUnless(has("sympy"), "no SymPy (Debian python3-sympy)")
class TestFormulaModels(unittest.TestCase):
    @classmethod
    def setUpClass(cls):
        cls.cache = tempfile.mkdtemp(prefix="dth-formula-")
        t = time.perf_counter()
        cls.hh = dth.Model.from_hamiltonian(HH_FORMULA, n=2, name="hh-formula", cache_dir=cls.cache)
        cls.build_s = time.perf_counter() - t

    @classmethod
    def tearDownClass(cls):
        import shutil
        shutil.rmtree(cls.cache, ignore_errors=True)

    @unittest.skipUnless(HH_SO, "the henon_heiles shared module is not built")
    def test_henon_heiles_from_its_formula(self):
        """The done-when of issue 25: the formula's model follows docs/examples/henon_heiles.c's trajectory to
        round-off (its hdiff is not the C model's Gauss-Legendre difference, so the bits differ at that level),
        passes dth_model_check with its third derivative, and its step time is printed beside the C model's."""
        c = dth.load_model(HH_SO, "example_henon_heiles")
        over = {"integrator.t_end": 200}
        a = dth.run(HH_SCENE, models=[c], set=over)
        b = dth.run(HH_SCENE, models=[self.hh], set=dict(over, **{"model.name": "hh-formula"}))
        self.assertEqual(len(a.t), len(b.t))
        self.assertLess(np.abs(a.z - b.z).max(), 1e-9)
        self.assertEqual(len(a.events), len(b.events))
        self.assertLess(np.abs(a.events.t - b.events.t).max(), 1e-9)
        rel = np.abs(b.E - b.E[0]).max() / abs(b.E[0])
        self.assertLessEqual(rel, 1e-14)
        with dth.Simulation(HH_SCENE, models=[self.hh], set={"model.name": "hh-formula"}) as sim:
            rep = sim.check_model([0.1, 0.2, 0.0, 0.3, -0.2])
        self.assertTrue(rep["pass"], rep["message"])
        self.assertTrue(0 < rep["third_err"] < 1e-6, rep)
        # step time: the driver's loop in C (one sample per run), best of 3
        times = {}
        for tag, m, o in (("C model", c, {}), ("formula", self.hh, {"model.name": "hh-formula"})):
            best = math.inf
            for _ in range(3):
                t = time.perf_counter()
                r = dth.run(HH_SCENE, models=[m], set=dict(o, **{"integrator.t_end": 1000}), points="vertices",
                            every=10 ** 9, check_model=False)
                best = min(best, (time.perf_counter() - t) / r.steps)
            times[tag] = best
        print("\n  Henon-Heiles step: C model (henon_heiles.c) %.3f us, from the formula %.3f us (%.2fx); "
              "formula compiled in %.2f s" % (times["C model"] * 1e6, times["formula"] * 1e6,
                                              times["formula"] / times["C model"], self.build_s))
        self.assertLess(times["formula"], 1.5 * times["C model"])

    def _instance(self, m):
        """(create, the C table) of a formula model, for calling its callbacks directly."""
        ffi = dth._ffi.ffi
        args, selfp, info = ffi.new("dth_model_args *"), ffi.new("void **"), ffi.new("dth_model_info *")
        self.assertEqual(m.table.create(args, selfp, info), 0)
        self.addCleanup(m.table.destroy, selfp[0], ffi.NULL)
        return selfp[0], info

    def test_hdiff_is_exact_and_antisymmetric(self):
        from fractions import Fraction as F
        ffi = dth._ffi.ffi
        m = dth.Model.from_hamiltonian("p1**2/2 + cos(q1) + q1**3*q2 + exp(q2)/7 + 1/(1 + q1**2)", n=2,
                                       name="mixed", cache_dir=self.cache)
        self.assertTrue(m.hdiff_exact)
        me, info = self._instance(m)
        self.assertEqual((info.n, info.autonomous, info.separable), (2, 1, 1))
        rng = np.random.default_rng(5)
        out, back, H1, H0 = (ffi.new("double *") for _ in range(4))
        exact_poly = lambda y: F(y[3]) ** 2 / 2 + F(y[0]) ** 3 * F(y[1])  # noqa: E731
        for k in range(200):
            y0 = rng.uniform(-1, 1, 5)
            y1 = y0 + rng.uniform(-1, 1, 5) * 10.0 ** -rng.integers(3, 12)
            a, b = ffi.new("double[]", y1.tolist()), ffi.new("double[]", y0.tolist())
            self.assertEqual(m.table.hdiff(me, a, b, out), 0)
            self.assertEqual(m.table.hdiff(me, b, a, back), 0)
            self.assertEqual(out[0], -back[0])  # antisymmetric, bit for bit
            # the error scales with |y1 - y0|, not with H: against exact arithmetic (the transcendental
            # terms by their derivative bound: |d| <= 1e-3 makes their part small but nonzero)
            m.table.eval(me, a, 1, H1, ffi.NULL, ffi.NULL)
            m.table.eval(me, b, 1, H0, ffi.NULL, ffi.NULL)
            step = float(np.abs(y1 - y0).max())
            naive_err_scale = 4e-16 * max(abs(H1[0]), abs(H0[0]))
            self.assertLess(abs(out[0] - (H1[0] - H0[0])), 10 * naive_err_scale + 1e-12 * step)
        # a polynomial alone: its error is round-off of |y1 - y0| times the gradient's size (|grad H| <= 34 on
        # [-2, 2]^5), where H(y1) - H(y0) would carry round-off of H's size (~16) whatever the step
        p = dth.Model.from_hamiltonian("p1**2/2 + q1**3*q2", n=2, name="poly", cache_dir=self.cache)
        pe, _ = self._instance(p)
        worst = 0.0
        for k in range(200):
            y0 = rng.uniform(-2, 2, 5)
            y1 = y0 + rng.uniform(-1, 1, 5) * 10.0 ** -rng.integers(4, 14)
            a, b = ffi.new("double[]", y1.tolist()), ffi.new("double[]", y0.tolist())
            p.table.hdiff(pe, a, b, out)
            ex = exact_poly(y1.tolist()) - exact_poly(y0.tolist())
            step = float(np.abs(y1 - y0).max())
            worst = max(worst, abs(float(F(out[0]) - ex)) / (step * 34 * 2.0 ** -52))
        self.assertLess(worst, 16)  # ulps of the step's scale

    def test_cache_by_hash_and_parameters(self):
        path, mtime = self.hh.path, os.path.getmtime(self.hh.path)
        again = dth.Model.from_hamiltonian(HH_FORMULA, n=2, name="hh-formula", cache_dir=self.cache)
        self.assertEqual(again.path, path)
        self.assertEqual(os.path.getmtime(path), mtime)  # not compiled again
        other = dth.Model.from_hamiltonian(HH_FORMULA + " + 0", n=2, name="hh-formula2", cache_dir=self.cache)
        self.assertNotEqual(other.key, self.hh.key)
        lam = dth.Model.from_hamiltonian("p1**2/2 + p2**2/2 + (q1**2 + q2**2)/2 + lam*(q1**2*q2 - q2**3/3)", n=2,
                                         name="hh-lam", params={"lam": 1.0}, cache_dir=self.cache)
        base = {"model.name": "hh-lam", "integrator.t_end": 20}
        a = dth.run(HH_SCENE, models=[lam], set=base)
        b = dth.run(HH_SCENE, models=[self.hh], set={"model.name": "hh-formula", "integrator.t_end": 20})
        np.testing.assert_array_equal(a.z[:, :2].shape, b.z[:, :2].shape)
        self.assertLess(np.abs(a.z - b.z).max(), 1e-12)
        c = dth.run(HH_SCENE, models=[lam], set=dict(base, **{"model.lam": 0}))
        self.assertFalse(c.z.shape == a.z.shape and np.allclose(c.z, a.z))
        with self.assertRaises(dth.DthError) as cm:
            dth.run(HH_SCENE, models=[lam], set=dict(base, **{"model.lam": "x"}))
        self.assertIn("lam", str(cm.exception))
        with self.assertRaises(ValueError) as cm:
            dth.Model.from_hamiltonian("p1**2/2 + k*q1**2", n=1, name="osc", cache_dir=self.cache)
        self.assertIn("k", str(cm.exception))

    @unittest.skipUnless(CLI, "the dth CLI is not built")
    def test_library_for_the_cli(self):
        with tempfile.TemporaryDirectory() as d:
            spec = self.hh.write_library(os.path.join(d, "hh.so"))
            self.assertEqual(spec, os.path.join(d, "hh.so") + ":dth_formula_hh_formula")
            with open(os.path.join(d, "list.csv"), "w") as f:
                f.write("initial.q[2]\n0.1\n")
            out = subprocess.run([CLI, "sweep", HH_SCENE, "--model-lib", spec, "--list", os.path.join(d, "list.csv"),
                                  "-s", "model.name=hh-formula", "-s", "integrator.t_end=50"],
                                 capture_output=True, text=True)
            self.assertEqual(out.returncode, 0, out.stderr)
            rows = [r.split(",") for r in out.stdout.strip().splitlines()]
            self.assertEqual(rows[1][rows[0].index("status")], "ok")


class TestResultViews(unittest.TestCase):
    @unittest.skipUnless(has("pandas"), "no pandas (Debian python3-pandas)")
    def test_to_pandas(self):
        r = dth.run(scene("kepler-e06.ini"), set={"integrator.t_end": 5, "events.section": "q2"})
        df = r.to_pandas()
        self.assertEqual(len(df), len(r.t))
        for col in ("t", "q1", "q2", "p1", "p2", "wp", "H", "E", "lam", "kind", "L", "psi"):
            self.assertIn(col, df.columns)
        np.testing.assert_array_equal(df["q2"].to_numpy(), r.q[:, 1])
        ev = r.events.to_pandas()
        self.assertEqual(list(ev["name"]), r.events.name)
        np.testing.assert_array_equal(ev["t"].to_numpy(), r.events.t)

    @unittest.skipUnless(has("matplotlib"), "no matplotlib (Debian python3-matplotlib)")
    def test_plot(self):
        import matplotlib
        matplotlib.use("Agg")
        r = dth.run(scene("pendulum.ini"))
        fig = r.plot()
        self.assertEqual(len(fig.axes), 3)
        titles = [a.get_title() for a in fig.axes]
        self.assertTrue(any("energy" in t for t in titles), titles)
        with tempfile.TemporaryDirectory() as d:
            path = os.path.join(d, "p.png")
            r.plot(path)
            self.assertGreater(os.path.getsize(path), 1000)


class TestStepControl(unittest.TestCase):
    """integrator.h_max and integrator.tol (issue 26): the Simulation calibrates before the first step."""

    def test_h_max_bounds_every_step(self):
        """Kepler e = 0.9 from its pericentre, one orbit, h_max = 0.01: every step <= 1.05 h_max, exit 0,
        the calibration in sim.control; without the calibration's first step the same run's steps reach
        74 times h."""
        over = {"integrator.t_end": 2 * math.pi}
        with dth.Simulation(scene("kepler-e09-hmax.ini"), set=over) as sim:
            c = sim.control
            r = sim.run()
        self.assertTrue(c["hmax_settled"])
        self.assertGreaterEqual(c["passes"], 2)
        self.assertLess(c["h0"], 1e-3)
        self.assertEqual(c["step_max"], 1.05 * 0.01)
        self.assertEqual(r.status, 0)
        self.assertLessEqual(r.lam_max, 0.0105)
        self.assertLessEqual(float(np.max(r.lam)), 0.0105)
        self.assertLess(r.err_q_end, 1e-3)

    def test_tol_and_the_guard(self):
        """tol = 1e-3: the estimate at the end within 10x of tol; a pilot too short for h_max leaves the run
        to its guard (status DTH_ESTEPSIZE after the first step above 1.05 h_max)."""
        over = {"integrator.t_end": 2 * math.pi, "integrator.h_max": 0, "integrator.tol": 1e-3}
        with dth.Simulation(scene("kepler-e09-hmax.ini"), set=over) as sim:
            self.assertFalse(sim.control["extrapolated"])
            r = sim.run()
        self.assertEqual(r.status, 0)
        self.assertTrue(1e-4 <= r.err_q_end <= 1e-2, r.err_q_end)
        over = {"integrator.t_end": 2 * math.pi, "integrator.pilot": 0.005}
        with dth.Simulation(scene("kepler-e09-hmax.ini"), set=over) as sim:
            r = sim.run()
        self.assertEqual(r.status_name, "DTH_ESTEPSIZE")
        self.assertGreater(r.lam_max, 0.0105)

    def test_no_control_no_report(self):
        with dth.Simulation(scene("kepler-e06.ini"), set={"integrator.t_end": 1}) as sim:
            self.assertIsNone(sim.control)


if __name__ == "__main__":
    unittest.main()
