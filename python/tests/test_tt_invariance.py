# SPDX-License-Identifier: MIT
"""Time-transformation invariance of the DTH step (docs/theory.md, "What h fixes"): for K = g(z) H with
g > 0, the DTH equations for K from the same vertex give the same vertices, the time advancing by
lambda_H = g(zbar) lambda_K, because H(zbar) = 0 at the midpoint makes grad K(zbar) = g(zbar) grad H(zbar).
So no time transformation can change DTH's steps: the run's constant C (lambda^6 psi^2) is the only lever.
A plain numpy DTH step (Newton on the bordered system) for Kepler e = 0.6 from its pericentre, 300 steps
from one vertex, g = 1, r, r^1.5, 1 + sin(q1)/2; the differences are compared with the round-off
sensitivity of the same run (q1(0) moved by one ulp), and g = 1 with the library's own steps."""
import math
import os
import unittest

import numpy as np

import dth

ROOT = os.environ.get("DTH_SOURCE_ROOT", os.path.join(os.path.dirname(__file__), "..", ".."))
N = 6  # z = (q1, q2, t, p1, p2, wp)
J = np.zeros((N, N))
J[:3, 3:] = np.eye(3)
J[3:, :3] = -np.eye(3)


def kepler(z):
    q, p, wp = z[:2], z[3:5], z[5]
    r = math.hypot(*q)
    H = wp + 0.5 * p @ p - 1 / r
    g = np.zeros(N)
    g[:2] = q / r ** 3
    g[3:5] = p
    g[5] = 1
    Hs = np.zeros((N, N))
    Hs[:2, :2] = np.eye(2) / r ** 3 - 3 * np.outer(q, q) / r ** 5
    Hs[3:5, 3:5] = np.eye(2)
    return H, g, Hs


def transform(kind):
    """g, grad g, Hess g of the time transformation `kind`."""
    def gfun(z):
        q = z[:2]
        r = math.hypot(*q)
        if kind == "1":
            return 1.0, np.zeros(N), np.zeros((N, N))
        if kind in ("r", "r^1.5"):
            a = 1.0 if kind == "r" else 1.5
            dg = np.zeros(N)
            dg[:2] = a * r ** (a - 2) * q
            G = np.zeros((N, N))
            G[:2, :2] = a * r ** (a - 2) * (np.eye(2) + (a - 2) * np.outer(q, q) / r ** 2)
            return r ** a, dg, G
        dg = np.zeros(N)
        dg[0] = 0.5 * math.cos(q[0])
        G = np.zeros((N, N))
        G[0, 0] = -0.5 * math.sin(q[0])
        return 1 + 0.5 * math.sin(q[0]), dg, G

    def K(z):
        H, gH, HH = kepler(z)
        gv, dg, G = gfun(z)
        return gv * H, gv * gH + H * dg, gv * HH + np.outer(dg, gH) + np.outer(gH, dg) + H * G, gv
    return K


def step(K, z, lam0, d0):
    """One DTH step for K: d = (lam/2) J grad K(z + d), K(z + d) = 0, by Newton."""
    x = np.concatenate([d0, [lam0]])
    for _ in range(60):
        d, lam = x[:N], x[N]
        k, gk, Kzz, _ = K(z + d)
        F = np.concatenate([d - 0.5 * lam * J @ gk, [k]])
        A = np.zeros((N + 1, N + 1))
        A[:N, :N] = np.eye(N) - 0.5 * lam * J @ Kzz
        A[:N, N] = -0.5 * J @ gk
        A[N, :N] = gk
        dx = np.linalg.solve(A, -F)
        x = x + dx
        if np.max(np.abs(dx[:N])) < 1e-16 * max(1, np.max(np.abs(z))) and abs(dx[N]) < 1e-15 * abs(x[N]):
            break
    d, lam = x[:N], x[N]
    return z + 2 * d, lam, d


def trajectory(kind, z0, h, steps):
    K = transform(kind)
    z = z0.copy()
    _, gk, _, gv = K(z)
    lam = h / gv
    d = 0.5 * lam * J @ gk
    Z = [z.copy()]
    for _ in range(steps):
        z, lam, d = step(K, z, lam, d)
        Z.append(z.copy())
    return np.array(Z)


class TimeTransformation(unittest.TestCase):
    q0, p0, h, steps = np.array([0.4, 0.0]), np.array([0.0, 2.0]), 0.01, 300

    def setUp(self):
        Hp = 0.5 * self.p0 @ self.p0 - 1 / 0.4
        # a vertex with the offset of the cubic model (psi h^2 / 8, psi = 101.5625 here): one z0 for every K
        self.z0 = np.array([0.4, 0.0, 0.0, 0.0, 2.0, -Hp + 101.5625 * self.h ** 2 / 8])
        self.Z1 = trajectory("1", self.z0, self.h, self.steps)
        zc = self.z0.copy()
        zc[0] = np.nextafter(zc[0], 1.0)
        self.noise = np.max(np.abs(trajectory("1", zc, self.h, self.steps) - self.Z1))

    def test_same_vertices(self):
        """K = g H for g = r, r^1.5, 1 + sin(q1)/2: every vertex (t included) within 10x the 1-ulp
        sensitivity of g = 1 (measured by the research report: 1.9e-12 .. 1.9e-11 against 2.5e-11)."""
        self.assertGreater(self.noise, 0)
        self.assertLess(self.noise, 1e-8)
        for kind in ("r", "r^1.5", "1+sin/2"):
            Z = trajectory(kind, self.z0, self.h, self.steps)
            diff = np.max(np.abs(Z - self.Z1))
            self.assertLess(diff, 10 * self.noise, "g = %s: %.3g against the 1-ulp sensitivity %.3g" % (kind, diff, self.noise))
        # a transformation that is not of this form (a different Hamiltonian) does move them
        z2 = self.z0.copy()
        z2[5] += 1e-6
        self.assertGreater(np.max(np.abs(trajectory("1", z2, self.h, self.steps) - self.Z1)), 1e3 * self.noise)

    def test_library_agrees(self):
        """g = 1 is the library's DTH step: dth run from the same vertex (start = vertex, the same wp)
        gives the same vertices to the round-off sensitivity."""
        r = dth.run(os.path.join(ROOT, "scenes", "kepler-e06.ini"),
                    set={"initial.q": [0.4, 0.0], "initial.p": [0.0, 2.0], "integrator.start": "vertex",
                         "initial.wp": repr(float(self.z0[5])), "integrator.h": self.h, "integrator.steps": self.steps,
                         "regularize.method": "none", "output.points": "vertices",
                         "output.diagnostics": "no"})
        self.assertEqual(r.status, 0)
        Zl = np.column_stack([r.q, r.t, r.p])[: self.steps + 1]
        diff = np.max(np.abs(Zl - self.Z1[:, :5]))
        self.assertLess(diff, 10 * self.noise, "library against numpy: %.3g (1-ulp sensitivity %.3g)" % (diff, self.noise))


if __name__ == "__main__":
    unittest.main()
