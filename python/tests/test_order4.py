# SPDX-License-Identifier: MIT
"""The DTH method of order 4 (issue 22) from Python: the scene keys integrator.order and
integrator.table pass through set=, the run's end converges at order 4 against the pendulum's exact
solution, dth run's rows are the same doubles, order 6 is refused with the measured reason."""
import csv
import io
import math
import os
import subprocess
import unittest

import dth

ROOT = os.environ.get("DTH_SOURCE_ROOT", os.path.join(os.path.dirname(__file__), "..", ".."))
CLI = os.environ.get("DTH_CLI")
PENDULUM = os.path.join(ROOT, "scenes", "pendulum.ini")


def pendulum_at(t):
    """The exact pendulum (omega2 = 1) from q = 1, p = 0 at time t: by the library's model."""
    r = dth.run(PENDULUM, set={"integrator.order": 4, "integrator.h": 0.0025, "integrator.t_end": t,
                               "integrator.table": "suzuki4"})
    return r.q[-1, 0], r.p[-1, 0]


class Order4(unittest.TestCase):
    def test_order_at_fixed_time(self):
        ref_q, ref_p = pendulum_at(10.0)
        errs = []
        for h in (0.1, 0.05):
            r = dth.run(PENDULUM, set={"integrator.order": 4, "integrator.h": h, "integrator.t_end": 10.0})
            self.assertEqual(r.stop, "end")
            self.assertEqual(r.t[-1], 10.0)
            errs.append(math.hypot(r.q[-1, 0] - ref_q, r.p[-1, 0] - ref_p))
        order = math.log2(errs[0] / errs[1])
        self.assertGreater(order, 3.8, errs)
        self.assertLess(order, 4.5, errs)

    def test_yoshida_table_and_no_midpoints(self):
        r = dth.run(PENDULUM, set={"integrator.order": 4, "integrator.table": "yoshida4", "integrator.t_end": 1.0})
        self.assertEqual(r.stop, "end")
        self.assertEqual(set(r.kind), {"vertex", "end"})  # order 2 writes midpoints by default here
        with self.assertRaises(Exception) as e:
            dth.run(PENDULUM, set={"integrator.order": 4, "output.points": "midpoints"})
        self.assertIn("order 2 only", str(e.exception))

    def test_order_6_refused(self):
        with self.assertRaises(Exception) as e:
            dth.run(PENDULUM, set={"integrator.order": 6})
        self.assertIn("order 4", str(e.exception))

    def test_regularizers(self):
        # land (the default) carries the rotating pendulum's crossings by the band; prescribed is refused
        rot = os.path.join(ROOT, "scenes", "pendulum-rotation.ini")
        r = dth.run(rot, set={"integrator.order": 4})
        self.assertEqual(r.stop, "end")
        with self.assertRaises(Exception) as e:
            dth.run(rot, set={"integrator.order": 4, "regularize.method": "prescribed"})
        self.assertIn("order = 4 with regularizer 'prescribed': not supported", str(e.exception))

    @unittest.skipUnless(CLI, "DTH_CLI not set")
    def test_rows_as_cli(self):
        r = dth.run(PENDULUM, set={"integrator.order": 4, "integrator.t_end": 2.0})
        out = subprocess.run([CLI, "run", PENDULUM, "-s", "integrator.order=4", "-s", "integrator.t_end=2"],
                             check=True, capture_output=True, text=True).stdout
        rows = list(csv.reader(io.StringIO(out)))
        q = [float(x[rows[0].index("q1")]) for x in rows[1:]]
        self.assertEqual(len(q), len(r.q))
        self.assertEqual(q, [float(x) for x in r.q[:, 0]])


if __name__ == "__main__":
    unittest.main()
