# SPDX-License-Identifier: MIT
"""Tests of what the Python package refuses or survives (issue 24): closed and shared Simulations,
bad arguments to runs and MEGNO, dict scene values, resumes that would change the run, partly built
objects, and honest root ranges. Each of these crashed, hung or returned wrong rows silently before."""
import math
import os
import sys
import threading
import time
import unittest

import numpy as np

import dth

ROOT = os.environ.get("DTH_SOURCE_ROOT", os.path.join(os.path.dirname(__file__), "..", ".."))


def scene(name):
    return os.path.join(ROOT, "scenes", name)


class Unraisable:
    """Collects what Python would print as 'Exception ignored in ...' (sys.unraisablehook)."""

    def __enter__(self):
        self.seen = []
        self.old = sys.unraisablehook
        sys.unraisablehook = self.seen.append
        return self

    def __exit__(self, *a):
        import gc
        gc.collect()
        sys.unraisablehook = self.old


class TestSimulationLifetime(unittest.TestCase):
    def test_closed_simulation_raises_everywhere(self):
        s = dth.Simulation(scene("pendulum.ini"))
        s.close()
        self.assertTrue(s.closed)
        for what in (lambda: s.vertex, lambda: s.steps, lambda: s.t, lambda: s.run(), lambda: s.checkpoint(),
                     lambda: s.run(t_end=1, megno=True)):
            with self.assertRaises(dth.DthError) as cm:
                what()
            self.assertIn("closed", str(cm.exception))
        s.close()  # twice: nothing happens

    def test_close_from_another_thread_waits_for_the_run(self):
        sim = dth.Simulation(scene("pendulum.ini"))
        started, out = threading.Event(), {}

        def progress(st):
            started.set()
            time.sleep(0.0002)  # long enough for close() to be called during the run
            return False

        th = threading.Thread(target=lambda: out.setdefault("r", sim.run(t_end=20, progress=progress)))
        th.start()
        self.assertTrue(started.wait(30))
        sim.close()
        self.assertFalse(th.is_alive(), "close() returned while the run was still going")
        th.join()
        np.testing.assert_array_equal(out["r"].z, dth.run(scene("pendulum.ini")).z)
        self.assertTrue(sim.closed)

    def test_close_from_inside_the_run_raises(self):
        sim = dth.Simulation(scene("pendulum.ini"))
        with self.assertRaises(dth.DthError) as cm:
            sim.run(t_end=5, progress=lambda st: sim.close())
        self.assertIn("inside its own run", str(cm.exception))
        self.assertFalse(sim.closed)
        sim.run(t_end=6)  # still usable
        sim.close()

    def test_one_simulation_from_two_threads(self):
        sim = dth.Simulation(scene("pendulum.ini"))
        out, gate = [], threading.Barrier(2)

        def go():
            gate.wait()
            out.append(sim.run(t_end=20, progress=lambda st: time.sleep(0)))

        ths = [threading.Thread(target=go) for _ in range(2)]
        for t in ths:
            t.start()
        for t in ths:
            t.join()
        self.assertEqual(sorted(len(r.t) for r in out)[0], 0)  # the second finds the run at t_end
        self.assertEqual([r.status for r in out], [0, 0])
        whole = dth.run(scene("pendulum.ini"))
        np.testing.assert_array_equal(np.vstack([r.z for r in out]), whole.z)
        sim.close()

    def test_callback_errors_stay_in_their_thread(self):
        """An exception a callback raised is kept for the thread whose C call ran it: another thread's
        check after its own C call (dth._core._raise_pending) does not pick it up (it did, from a list
        shared by all threads)."""
        stored, out = threading.Event(), {}

        def a():
            try:
                raise RuntimeError("thread A's model")
            except RuntimeError as e:
                dth._core._onerror(type(e), e, e.__traceback__)  # what cffi calls for a failed callback
            stored.set()
            time.sleep(0.2)
            try:
                dth._core._raise_pending()
            except RuntimeError as e:
                out["a"] = str(e)

        def b():
            stored.wait(10)
            try:
                dth._core._raise_pending()
                out["b"] = "nothing"
            except RuntimeError as e:
                out["b"] = str(e)

        ths = [threading.Thread(target=f) for f in (a, b)]
        for t in ths:
            t.start()
        for t in ths:
            t.join()
        self.assertEqual(out, {"a": "thread A's model", "b": "nothing"})

    def test_partly_built_objects_close_quietly(self):
        with Unraisable() as u:
            with self.assertRaises(dth.DthError):
                dth.run(scene("pendulum.ini"), megno=[0, 0, 0, 0])
            with self.assertRaises(dth.DthError):
                dth.Simulation(scene("pendulum.ini"), set={"model.nope": 1})
            with self.assertRaises(dth.DthError):
                dth.Simulation(os.path.join(ROOT, "scenes", "no-such.ini"))
            with self.assertRaises(TypeError):
                dth.Simulation(scene("pendulum.ini"), models=[object()])
            with self.assertRaises(TypeError):
                dth.Simulation(scene("pendulum.ini"), events=[42])
        self.assertEqual(u.seen, [], [str(x.exc_value) for x in u.seen])


class TestRunArguments(unittest.TestCase):
    def check(self, message, **kw):
        with self.assertRaises(dth.DthError) as cm:
            dth.run(scene("pendulum.ini"), **kw)
        self.assertIn(message, str(cm.exception))
        self.assertEqual(cm.exception.status, -1)

    def test_times_finite_and_ordered(self):
        self.check("times[1] = nan: output times must be finite", times=[1, math.nan, 3])
        self.check("times[1] = 1 lies before times[0] = 5", times=[5, 1, 3])
        r = dth.run(scene("pendulum.ini"), times=[1, 1, 3])  # equal times are fine
        self.assertEqual(list(r.t[:3]), [1, 1, 3])

    def test_steps_and_t_end(self):
        self.check("steps = -5: must not be negative", steps=-5)
        self.check("t_end = -1 lies behind the run's start", t_end=-1)
        sim = dth.Simulation(scene("pendulum.ini"))
        sim.run(t_end=5)
        for kw, msg in (({"t_end": 2}, "t_end = 2 lies behind where the run stands"),
                        ({"steps": 3}, "steps = 3 lies behind where the run stands")):
            with self.assertRaises(dth.DthError) as cm:
                sim.run(**kw)
            self.assertIn(msg, str(cm.exception))
        self.assertEqual(len(sim.run(t_end=5).t), 0)  # where it stands: nothing to do
        sim.close()

    def test_dt_too_fine_is_refused_at_once(self):
        t = time.monotonic()
        self.check("asks for 5e+298 rows per step", dt=1e-300)
        self.assertLess(time.monotonic() - t, 5)

    def test_megno_vector_length(self):
        with self.assertRaises(ValueError) as cm:
            dth.run(scene("pendulum.ini"), megno=[1, 2])
        self.assertIn("2 values, not 2n+2 = 4", str(cm.exception))
        with self.assertRaises(dth.DthError):
            dth.run(scene("pendulum.ini"), megno=[0, 0, 0, 0])

    def test_megno_continues_over_legs(self):
        sim = dth.Simulation(scene("pendulum.ini"))
        sim.run(t_end=7, megno=True)
        b = sim.run(t_end=20, megno=True)
        sim.close()
        whole = dth.run(scene("pendulum.ini"), megno=True)
        self.assertEqual(b.megno_span, whole.megno_span)
        self.assertEqual(b.megno, whole.megno)


class TestScenesAndResume(unittest.TestCase):
    def test_dict_value_cannot_add_a_line(self):
        d = {"model": {"name": "pendulum\nomega2 = 4"}, "initial": {"q": 1, "p": 0},
             "integrator": {"h": 0.05, "t_end": 1}}
        with self.assertRaises(dth.DthError) as cm:
            dth.run(d)
        self.assertIn("model.name: a scene file cannot hold this (a control character)", str(cm.exception))
        for bad in ({"model]\n[x": {"a": 1}}, {"model": {"a=b": 1}}, {"model": {"name": "pendulum ; x"}}):
            with self.assertRaises(dth.DthError):
                dth.Scene(bad)

    def test_set_is_named_as_set(self):
        with self.assertRaises(dth.DthError) as cm:
            dth.run(scene("pendulum.ini"), set={"integrator.hh": 0.1})
        msg = str(cm.exception)
        self.assertTrue(msg.startswith("set={'integrator.hh': 0.1}: integrator.hh: unknown key"), msg)
        self.assertNotIn("-s ", msg)
        # a set= override of the run length replaces the file's other one, as -s does
        r = dth.run(scene("pendulum.ini"), set={"integrator.steps": 4})
        self.assertEqual(r.steps, 4)

    def test_resume_may_not_change_the_run(self):
        sim = dth.Simulation(scene("pendulum-rotation.ini"))
        sim.run(t_end=5)
        blob = sim.checkpoint()
        b = sim.run(t_end=8)
        sim.close()
        for key, value in (("model.omega2", 1.1), ("initial.q", 0.5), ("integrator.h", 0.01),
                           ("regularize.method", "none"), ("output.dt", 0.5)):
            with self.assertRaises(dth.DthError) as cm:
                dth.Simulation.resume(blob, set={key: value})
            self.assertIn("%s = '%s' would change the checkpointed run" % (key, value), str(cm.exception))
        c = dth.Simulation.resume(blob, set={"integrator.t_end": 8, "output.every": 1}).run()
        np.testing.assert_array_equal(b.z, c.z)


def _library_flags_the_cut():
    """Whether this libdth reports a scan cut short of [-L, L] itself (lib/branch.c with the range fix)."""
    lb = dth._ffi.lib()
    with dth.Simulation(dth.Scene(scene("pendulum.ini")).set("integrator.start", "vertex"), check_model=False) as sim:
        out = dth._ffi.ffi.new("dth_root_set *")
        with dth._core._rootfinder(sim._rs) as rf:
            lb.dth_find_roots(rf, lb.dth_integrator_vertex(sim._it), 1e308, out)
        return bool(out.truncated)


class TestRoots(unittest.TestCase):
    def test_a_range_not_scanned_is_reported(self):
        r = dth.roots(scene("pendulum.ini"), L=1e308)
        self.assertEqual(r.L, 1e308)
        self.assertTrue(r.truncated, "the scan stopped at [%g, %g] of [-1e308, 1e308]" % (r.lo, r.hi))
        self.assertTrue(r.hi < 1e308 and r.lo > -1e308)
        self.assertTrue(all(r.lo <= x <= r.hi for x in r.lam))
        full = dth.roots(scene("pendulum.ini"))
        self.assertFalse(full.truncated)
        self.assertEqual((full.lo, full.hi), (-full.L, full.L))
        with self.assertRaises(ValueError):
            dth.roots(scene("pendulum.ini"), L=math.inf)

    def test_a_huge_range_still_finds_the_roots(self):
        """The root finder's range handling (lib/branch.c, dth_find_roots: the grid cut to the vertex's
        root scale; branch 'cli', issue 24) finds the pendulum's two roots +-h in [-1e308, 1e308]. A
        library without that fix scans a grid too coarse to see them: there this test is an expected
        failure (decided by the library's own truncated flag), and it passes once the fix is in."""
        r = dth.roots(scene("pendulum.ini"), L=1e308)
        self.assertEqual(r.cls, ["minus", "plus"])
        np.testing.assert_allclose(r.lam, [-0.05, 0.05], rtol=1e-12)

    if not _library_flags_the_cut():
        test_a_huge_range_still_finds_the_roots = unittest.expectedFailure(test_a_huge_range_still_finds_the_roots)


if __name__ == "__main__":
    unittest.main()
