# SPDX-License-Identifier: MIT
"""Tests of the Python package (run by meson test 'python'; by hand: DTH_LIBRARY=build/libdth.so
PYTHONPATH=python python3 -m unittest discover -s python/tests). The rows a run returns are compared
with dth run's CSV bit for bit (the same driver, the same doubles); a Python user model with a C
model's arithmetic gives the C model's trajectory bit for bit; checkpoints resume bit for bit."""
import csv
import io
import math
import os
import subprocess
import tempfile
import unittest

import numpy as np

import dth

ROOT = os.environ.get("DTH_SOURCE_ROOT", os.path.join(os.path.dirname(__file__), "..", ".."))
CLI = os.environ.get("DTH_CLI")
HH_SO = os.environ.get("DTH_TEST_HH_SO")


def scene(name):
    return os.path.join(ROOT, "scenes", name)


def cli_rows(*args):
    """dth run's CSV as a dict column -> list of texts."""
    out = subprocess.run([CLI, "run"] + list(args), check=True, capture_output=True, text=True).stdout
    rows = list(csv.reader(io.StringIO(out)))
    return {h: [r[i] for r in rows[1:]] for i, h in enumerate(rows[0])}


def floats(col):
    return np.array([float(x) for x in col])


class HenonHeiles(dth.Model):
    """docs/examples/henon_heiles.c in Python, with the same operations in the same order (so the
    same doubles: Python floats are IEEE doubles and nothing is fused)."""
    name = "henon-heiles-py"
    doc = "Henon-Heiles in Python"
    params = {"lambda": 1.0}
    n = 2
    separable = True

    def H(self, q, t, p):
        x, v, px, pv, l = float(q[0]), float(q[1]), float(p[0]), float(p[1]), self.params["lambda"]
        return 0.5 * (px * px + pv * pv) + 0.5 * (x * x + v * v) + l * (x * x * v - v * v * v / 3)

    def grad(self, q, t, p):
        x, v, l = float(q[0]), float(q[1]), self.params["lambda"]
        return (x + 2 * l * x * v, v + l * (x * x - v * v), 0.0, p[0], p[1])

    def hess(self, q, t, p):
        x, v, l = float(q[0]), float(q[1]), self.params["lambda"]
        h = np.zeros((5, 5))
        h[0, 0] = 1 + 2 * l * v
        h[0, 1] = h[1, 0] = 2 * l * x
        h[1, 1] = 1 - 2 * l * v
        h[3, 3] = h[4, 4] = 1
        return h


def hh_initial(E, q2, p2):
    """q1 = 0 and p1 > 0 from the energy E."""
    return [0.0, q2], [math.sqrt(2 * E - p2 * p2 - q2 * q2 + 2 * q2 ** 3 / 3), p2]


HH_SCENE = os.path.join(ROOT, "docs", "examples", "henon-heiles.ini")


class TestRunMatchesCli(unittest.TestCase):
    @unittest.skipUnless(CLI, "the dth CLI is not built")
    def test_pendulum_rows_bit_for_bit(self):
        r = dth.run(scene("pendulum.ini"))
        c = cli_rows(scene("pendulum.ini"))
        self.assertEqual(len(r.t), len(c["t"]))
        for name, arr in (("t", r.t), ("lambda", r.lam), ("q1", r.q[:, 0]), ("p1", r.p[:, 0]), ("wp", r.wp),
                          ("H", r.H), ("E", r.E)):
            np.testing.assert_array_equal(arr, floats(c[name]), err_msg=name)
        np.testing.assert_array_equal(r.k, [int(x) for x in c["k"]])
        self.assertEqual(r.status, 0)
        self.assertEqual(r.stop, "end")

    @unittest.skipUnless(CLI, "the dth CLI is not built")
    def test_kepler_diagnostics_invariants_times(self):
        over = ["-s", "output.diagnostics=yes", "-s", "output.dt=0.25", "-s", "integrator.t_end=5"]
        r = dth.run(scene("kepler-e06.ini"), set={"output.diagnostics": True, "output.dt": 0.25,
                                                  "integrator.t_end": 5})
        c = cli_rows(scene("kepler-e06.ini"), *over)
        self.assertEqual(len(r.t), len(c["t"]))
        np.testing.assert_array_equal(r.z[:, :2], np.column_stack([floats(c["q1"]), floats(c["q2"])]))
        for nm in r.invariant_names:
            np.testing.assert_array_equal(r.inv[nm], floats(c[nm]), err_msg=nm)
        np.testing.assert_array_equal(r.psi, floats(c["psi"]))
        np.testing.assert_array_equal(r.dpsi, floats(c["dpsi"]))
        self.assertEqual(r.region, c["region"])
        self.assertEqual(r.branch, c["branch"])
        np.testing.assert_array_equal(r.iters, [int(x) for x in c["iters"]])
        self.assertEqual(r.t[-1], 5.0)
        self.assertEqual(r.kind[-1], "time")  # the end falls on an output time: no separate end row

    @unittest.skipUnless(CLI, "the dth CLI is not built")
    def test_regularized_rotation(self):
        r = dth.run(scene("pendulum-rotation.ini"))
        c = cli_rows(scene("pendulum-rotation.ini"))
        np.testing.assert_array_equal(r.z[:, [0, 1, 2, 3]], np.column_stack(
            [floats(c[x]) for x in ("q1", "t", "p1", "wp")]))
        np.testing.assert_array_equal(r.ordinary, [int(x) for x in c["ordinary"]])
        # land's reset and clock-corrected steps are not reversible: dth run's column, and the run's count
        np.testing.assert_array_equal(r.reversible, [int(x) for x in c["reversible"]])
        self.assertIn(0, r.reversible)
        self.assertGreater(r.nonreversible, 0)
        np.testing.assert_array_equal(r.psi, floats(c["psi"]))
        # the estimated global error, dth run's err_q, err_p columns
        np.testing.assert_array_equal(r.err_q, floats(c["err_q"]))
        np.testing.assert_array_equal(r.err_p, floats(c["err_p"]))
        self.assertTrue(np.all(np.isfinite(r.err_q[1:])))
        self.assertGreater(r.regularized, 0)
        self.assertIn(0, r.ordinary)

    @unittest.skipUnless(CLI, "the dth CLI is not built")
    def test_events_match_the_events_file(self):
        with tempfile.TemporaryDirectory() as d:
            out = os.path.join(d, "k.csv")
            subprocess.run([CLI, "run", scene("kepler-e06.ini"), "-s", "events.section=q2", "-s",
                            "integrator.t_end=30", "-o", out], check=True, capture_output=True)
            rows = list(csv.reader(open(os.path.join(d, "k-events.csv"))))
        c = {h: [r[i] for r in rows[1:]] for i, h in enumerate(rows[0])}
        r = dth.run(scene("kepler-e06.ini"), set={"events.section": "q2", "integrator.t_end": 30})
        self.assertGreaterEqual(len(r.events), 4)
        np.testing.assert_array_equal(r.events.t, floats(c["t"]))
        np.testing.assert_array_equal(r.events.q[:, 1], floats(c["q2"]))
        np.testing.assert_array_equal(r.events.direction, [int(x) for x in c["direction"]])
        self.assertTrue(all(n == "section" for n in r.events.name))
        # the section q2 = 0 located to round-off
        self.assertLess(np.abs(r.events.q[:, 1]).max(), 1e-12)


class TestScenes(unittest.TestCase):
    def test_dict_scene_equals_file(self):
        a = dth.run(scene("pendulum.ini"))
        b = dth.run({"model": {"name": "pendulum", "omega2": 1}, "initial": {"q": 1, "p": 0, "t": 0},
                     "integrator": {"method": "dth", "start": "midpoint", "h": 0.05, "t_end": 20}})
        np.testing.assert_array_equal(a.z, b.z)

    def test_long_list_in_dict(self):
        # 60 degrees of freedom: the list values exceed the reader's line length and are split
        n = 60
        r = dth.run({"model": {"name": "harmonic", "mass": [1.0] * n, "omega": [1.0 + i / n for i in range(n)]},
                     "initial": {"q": [0.1 * (i % 7) for i in range(n)], "p": [0.0] * n},
                     "integrator": {"h": 0.01, "steps": 20}})
        self.assertEqual(r.q.shape[1], n)
        self.assertEqual(r.q[0, 6], 0.1 * 6)

    def test_overrides_and_get(self):
        s = dth.Scene(scene("pendulum.ini"), {"integrator.h": 0.01})
        self.assertEqual(s.get("integrator.h"), "0.01")
        self.assertIn("h = 0.01", s.ini())
        r = dth.run(s, t_end=1)
        self.assertAlmostEqual(float(np.median(r.lam)), 0.01, delta=1e-4)

    def test_bad_key_names_it(self):
        with self.assertRaises(dth.DthError) as cm:
            dth.run(scene("pendulum.ini"), set={"model.nope": 1})
        self.assertIn("nope", str(cm.exception))
        with self.assertRaises(dth.DthError):
            dth.run(os.path.join(ROOT, "scenes", "no-such.ini"))

    def test_models_lists_builtins_and_user(self):
        names = [m["name"] for m in dth.models([HenonHeiles])]
        for n in ("pendulum", "harmonic", "kepler", "coupled", "henon-heiles-py"):
            self.assertIn(n, names)

    def test_baseline_method(self):
        r = dth.run(scene("pendulum.ini"), set={"integrator.method": "gauss4"})
        self.assertEqual(r.kind[0], "vertex")
        self.assertLess(np.abs(r.E - r.E[0]).max(), 1e-6)


class TestUserModels(unittest.TestCase):
    def test_python_henon_heiles_energy(self):
        """The done-when: a Python user model integrates Henon-Heiles with midpoint energy <= 1e-14."""
        q, p = hh_initial(1 / 12, 0.1, 0.0)
        r = dth.run(HH_SCENE, models=[HenonHeiles], set={"model.name": "henon-heiles-py", "initial.q": q,
                                                          "initial.p": p, "integrator.t_end": 200})
        self.assertEqual(r.status, 0)
        self.assertTrue(all(k == "midpoint" for k in r.kind))
        self.assertGreater(len(r.t), 3800)
        rel = np.abs(r.E - r.E[0]).max() / abs(r.E[0])
        self.assertLessEqual(rel, 1e-14, "midpoint energy error %.3g" % rel)
        self.assertAlmostEqual(r.E[0], 1 / 12, delta=1e-15)

    @unittest.skipUnless(HH_SO, "the henon_heiles shared module is not built")
    def test_python_model_equals_c_model_bit_for_bit(self):
        hh = dth.load_model(HH_SO, "example_henon_heiles")
        self.assertEqual(hh.name, "henon-heiles")
        a = dth.run(HH_SCENE, models=[hh], set={"integrator.t_end": 50})
        b = dth.run(HH_SCENE, models=[HenonHeiles], set={"model.name": "henon-heiles-py", "integrator.t_end": 50})
        np.testing.assert_array_equal(a.z, b.z)
        self.assertEqual(len(a.events), len(b.events))
        np.testing.assert_array_equal(a.events.z, b.events.z)

    @unittest.skipUnless(HH_SO, "the henon_heiles shared module is not built")
    def test_load_model_missing_symbol(self):
        with self.assertRaises(dth.DthError):
            dth.load_model(HH_SO, "no_such_table")

    def test_exception_in_model_propagates(self):
        class Broken(HenonHeiles):
            name = "broken-py"

            def grad(self, q, t, p):
                raise RuntimeError("boom")
        with self.assertRaises(RuntimeError):
            dth.run(HH_SCENE, models=[Broken], set={"model.name": "broken-py"}, check_model=False)

    def test_outside_domain(self):
        class Wall(HenonHeiles):
            name = "wall-py"

            def H(self, q, t, p):
                if q[1] > 0.2:
                    raise dth.OutsideDomain()
                return HenonHeiles.H(self, q, t, p)
        r = dth.run(HH_SCENE, models=[Wall], set={"model.name": "wall-py", "regularize.method": "none"})
        self.assertGreater(r.status, 0)
        self.assertLess(r.t[-1], 2000)

    def test_wrong_gradient_fails_the_model_check(self):
        class Wrong(HenonHeiles):
            name = "wrong-py"

            def hess(self, q, t, p):
                return -HenonHeiles.hess(self, q, t, p)
        with self.assertRaises(dth.DthError) as cm:
            dth.run(HH_SCENE, models=[Wrong], set={"model.name": "wrong-py"})
        self.assertIn("derivative check", str(cm.exception))

    def test_model_parameter(self):
        q, p = hh_initial(1 / 12, 0.1, 0.0)
        r = dth.run(HH_SCENE, models=[HenonHeiles], set={"model.name": "henon-heiles-py", "model.lambda": 0,
                                                          "initial.q": q, "initial.p": p, "integrator.t_end": 5})
        # lambda = 0: two harmonic oscillators, energy (p^2 + q^2)/2
        E = 0.5 * (p[0] ** 2 + p[1] ** 2 + q[1] ** 2)
        self.assertAlmostEqual(r.E[0], E, delta=1e-15)


class TestRootsCheckpointsMegno(unittest.TestCase):
    @unittest.skipUnless(CLI, "the dth CLI is not built")
    def test_roots_match_cli(self):
        for sc in ("pendulum.ini", "pendulum-rotation.ini"):
            r = dth.roots(scene(sc))
            out = subprocess.run([CLI, "roots", scene(sc)], check=True, capture_output=True, text=True).stdout
            rows = list(csv.reader(io.StringIO(out)))[1:]
            self.assertEqual(len(r.lam), len(rows))
            np.testing.assert_array_equal(r.lam, [float(x[0]) for x in rows])
            self.assertEqual(r.cls, [x[1] for x in rows])
            self.assertTrue(all(r.region == x[3] for x in rows))

    @unittest.skipUnless(CLI, "the dth CLI is not built")
    def test_map_matches_cli(self):
        m = dth.map(scene("pendulum-rotation.ini"), q=(-3.5, 3.5, 9), p=(-3, 3, 7))
        with tempfile.TemporaryDirectory() as d:
            subprocess.run([CLI, "map", scene("pendulum-rotation.ini"), "--q", "-3.5:3.5:9", "--p", "-3:3:7", "--out",
                            os.path.join(d, "m")], check=True, capture_output=True)
            rows = list(csv.DictReader(open(os.path.join(d, "m.csv"))))
        self.assertEqual(len(rows), 63)
        for k, r in enumerate(rows):
            i, j = divmod(k, 7)
            self.assertEqual(float(r["q"]), m.q[i])
            self.assertEqual(float(r["p"]), m.p[j])
            for col, arr in (("psi", m.psi), ("dpsi", m.dpsi), ("lambda_minus", m.lambda_minus),
                             ("lambda_plus", m.lambda_plus), ("lambda_ghost", m.lambda_ghost)):
                want = float(r[col]) if r[col] else math.nan
                self.assertTrue(want == arr[i, j] or (math.isnan(want) and math.isnan(arr[i, j])), (col, k))
            self.assertEqual(r["region"], m.region[i][j])
            self.assertEqual(r["nroots"], str(m.nroots[i, j]) if r["nroots"] else "")

    def test_roots_pendulum_symmetric_pair(self):
        r = dth.roots(scene("pendulum.ini"))
        self.assertEqual(r.cls, ["minus", "plus"])
        self.assertEqual(r.lam[0], -r.lam[1])  # p = 0: the constraint is even in lambda

    def check_resume(self, sc, **over):
        sim = dth.Simulation(scene(sc), set=over)
        a = sim.run(t_end=10)
        blob = sim.checkpoint()
        b = sim.run(t_end=20)
        sim2 = dth.Simulation.resume(blob)
        c = sim2.run(t_end=20)
        self.assertGreater(len(b.t), 10)
        np.testing.assert_array_equal(b.z, c.z)
        np.testing.assert_array_equal(b.lam, c.lam)
        # the whole run driver's state too: counts, the error estimate (its shadow is in the
        # checkpoint), the largest step
        ffi = dth._ffi.ffi
        self.assertEqual(bytes(ffi.buffer(sim._st)), bytes(ffi.buffer(sim2._st)))
        self.assertFalse(math.isnan(sim2._st.err_q))
        # and the two legs are the one run to 20 (but for the first leg's end sample at t = 10)
        whole = dth.run(scene(sc), set=over, t_end=20)
        if a.kind[-1] == "end":
            self.assertEqual(a.t[-1], 10.0)
            a.z = a.z[:-1]
        np.testing.assert_array_equal(np.vstack([a.z, b.z]), whole.z)
        return whole

    def test_checkpoint_resume_bit_for_bit(self):
        self.check_resume("pendulum.ini")
        w = self.check_resume("pendulum-rotation.ini")  # the land regularizer's state travels too
        self.assertGreater(w.regularized, 0)

    def test_checkpoint_file(self):
        with tempfile.TemporaryDirectory() as d:
            path = os.path.join(d, "p.ckpt")
            sim = dth.Simulation(scene("pendulum.ini"))
            sim.run(t_end=5)
            sim.checkpoint(path)
            b = sim.run(t_end=8)
            c = dth.Simulation.resume(path).run(t_end=8)
            np.testing.assert_array_equal(b.z, c.z)
            with open(path, "r+b") as f:
                f.seek(40)
                x = f.read(1)
                f.seek(40)
                f.write(bytes([x[0] ^ 1]))
            with self.assertRaises(dth.DthError):
                dth.Simulation.resume(path)

    def test_megno_henon_heiles(self):
        """MEGNO tends to 2 on a regular orbit (E = 1/12) and grows on a chaotic one (E = 1/6)."""
        res = {}
        for tag, (E, q2) in {"regular": (1 / 12, 0.1), "chaotic": (1 / 6, -0.1)}.items():
            q, p = hh_initial(E, q2, 0.0)
            r = dth.run(HH_SCENE, models=[HenonHeiles], set={"model.name": "henon-heiles-py", "initial.q": q,
                                                              "initial.p": p, "integrator.t_end": 300,
                                                              "output.every": 1000}, megno=True)
            self.assertTrue(math.isnan(r.megno_t_stop))
            self.assertAlmostEqual(r.megno_span, 300, delta=0.1)
            res[tag] = r
        self.assertLess(abs(res["regular"].megno - 2), 0.05)
        self.assertGreater(res["chaotic"].megno, 10)
        self.assertGreater(res["chaotic"].lyapunov, 0.05)

    def test_megno_ends_at_a_regularized_step(self):
        r = dth.run(scene("pendulum-rotation.ini"), megno=True)
        self.assertGreater(r.regularized, 0)
        self.assertFalse(math.isnan(r.megno_t_stop))
        self.assertLess(r.megno_span, 10)


if __name__ == "__main__":
    unittest.main()
