# SPDX-License-Identifier: MIT
"""A chaos map of the Henon-Heiles system with dth sweep: MEGNO (from the DTH tangent map, chaos.h)
over the Poincare section q1 = 0 at one energy, one orbit per grid point (q2, p2) with p1 > 0 from the
energy; Henon-Heiles is a user model loaded from a shared object (--model-lib).

usage: python3 docs/examples/chaos_map.py BUILDDIR [OUT.png] [--n N] [--t T] [--energy E] [--mpi RANKS]
  BUILDDIR  a build of this checkout (BUILDDIR/cli/dth, BUILDDIR/docs/examples/henon_heiles.so)
  OUT.png   default docs/figures/henon-heiles-megno.png
  --n N     grid points per axis (default 64)   --t T   time per orbit (default 500)
  --energy  default 1/8 (a mixed phase space)   --mpi R run the sweep under mpirun -n R
Prints the sweep's statistics and the share of chaotic orbits (MEGNO > 4).
"""
import argparse
import csv
import math
import os
import subprocess
import sys
import tempfile

import numpy as np
import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402

ROOT = os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "..")

ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
ap.add_argument("build")
ap.add_argument("out", nargs="?", default=os.path.join(ROOT, "docs", "figures", "henon-heiles-megno.png"))
ap.add_argument("--n", type=int, default=64)
ap.add_argument("--t", type=float, default=500)
ap.add_argument("--energy", type=float, default=1 / 8)
ap.add_argument("--mpi", type=int, default=0)
a = ap.parse_intermixed_args()

E, n = a.energy, a.n
dth = os.path.join(a.build, "cli", "dth")
plugin = os.path.join(a.build, "docs", "examples", "henon_heiles.so")
for f in (dth, plugin):
    if not os.path.exists(f):
        sys.exit("chaos_map.py: no %s (build first: bash scripts/setup.sh %s)" % (f, a.build))

# the grid on the section, over the allowed region: V(0, q2) = q2^2/2 - q2^3/3 <= E bounds q2 (the two
# roots around 0), p2^2 <= 2 (E - V) <= 2 E
rts = sorted(r.real for r in np.roots([-1 / 3, 1 / 2, 0, -E]) if abs(r.imag) < 1e-12)
lo, hi = max(r for r in rts if r < 0), min(r for r in rts if r > 0)
q2s = np.linspace(lo, hi, n + 2)[1:-1]
pm = math.sqrt(2 * E)
p2s = np.linspace(-pm, pm, n + 2)[1:-1]
with tempfile.TemporaryDirectory() as tmp:
    lst = os.path.join(tmp, "orbits.csv")
    cells = []
    with open(lst, "w") as f:
        f.write("initial.q[2],initial.p\n")
        for i, q2 in enumerate(q2s):
            for j, p2 in enumerate(p2s):
                r = 2 * E - p2 * p2 - q2 * q2 + 2 * q2 ** 3 / 3
                if r > 0:
                    f.write('%r,"%r, %r"\n' % (q2, math.sqrt(r), p2))
                    cells.append((i, j))
    out = os.path.join(tmp, "megno.csv")
    cmd = [dth, "sweep", os.path.join(ROOT, "docs", "examples", "henon-heiles.ini"),
           "--model-lib", plugin + ":example_henon_heiles", "--list", lst, "-s", "integrator.t_end=%r" % a.t,
           "--stats", "-o", out]
    if a.mpi:
        cmd = ["mpirun", "--oversubscribe", "-n", str(a.mpi)] + (["--allow-run-as-root"] if os.geteuid() == 0
                                                                else []) + cmd
    subprocess.run(cmd, check=True)
    rows = list(csv.DictReader(open(out)))

megno = np.full((n, n), np.nan)
for (i, j), r in zip(cells, rows):
    if r["status"] == "ok" and r["megno"]:
        megno[j, i] = float(r["megno"])
ok = ~np.isnan(megno)
chaotic = np.sum(megno[ok] > 4)
print("chaos_map: E = %.6g, %d orbits to t = %g: %d chaotic (MEGNO > 4, %.1f %%), median MEGNO of the others %.3f"
      % (E, ok.sum(), a.t, chaotic, 100.0 * chaotic / max(ok.sum(), 1), np.median(megno[ok][megno[ok] <= 4])))

fig, ax = plt.subplots(figsize=(7.2, 6))
im = ax.imshow(np.log10(np.clip(megno, 1, None)), origin="lower", aspect="auto", cmap="inferno",
               extent=(q2s[0], q2s[-1], p2s[0], p2s[-1]), vmin=0, vmax=np.log10(max(np.nanmax(megno), 10)))
cb = fig.colorbar(im, ax=ax)
cb.set_label("log10 MEGNO  (regular: 2, i.e. 0.30)")
ax.set_xlabel("q2")
ax.set_ylabel("p2")
ax.set_title("Henon-Heiles, E = %.4g: MEGNO on the section q1 = 0 (p1 > 0)\n"
             "dth sweep, DTH h = 0.05, t = %g per orbit, %d orbits" % (E, a.t, ok.sum()), fontsize=10)
fig.tight_layout()
os.makedirs(os.path.dirname(os.path.abspath(a.out)), exist_ok=True)
fig.savefig(a.out, dpi=110)
print("chaos_map: wrote %s" % a.out)
