# SPDX-License-Identifier: MIT
# %% [markdown]
# # dth from Python: a notebook-style tour (docs/python.md)
#
# Run it as a script (cells are marked `# %%` for editors that run them one by one):
#
#     python3 docs/python_example.py [OUTDIR]       # OUTDIR/python-example.png and .txt (default: a new
#                                                   # temporary folder, printed)
#     python3 docs/python_example.py --docs         # regenerate docs/figures/python-example.png and the
#                                                   # numbers quoted in docs/python.md
#     python3 docs/python_example.py --check-docs DIR   # run into DIR; fail if docs/python.md quotes
#                                                   # other numbers (meson test python-example)
#
# from a checkout whose library is built (bash scripts/setup.sh), or with dth installed.
# It integrates the pendulum scene, a Henon-Heiles model written in Python (its Poincare section
# from the run driver's events) and follows MEGNO on a regular and a chaotic orbit, then draws
# the figure.

# %%
import math
import os
import sys
import tempfile

try:
    import dth
except ImportError:  # a checkout without PYTHONPATH: the package next to this file
    sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "python"))
    import dth
import numpy as np
import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402

ROOT = os.path.join(os.path.dirname(os.path.abspath(__file__)), "..")
DOC = os.path.join(ROOT, "docs", "python.md")
BEGIN, END = "<!-- python_example.py --docs: begin -->", "<!-- python_example.py --docs: end -->"
args = sys.argv[1:]
mode = args.pop(0) if args and args[0] in ("--docs", "--check-docs") else None
if mode == "--docs":
    outdir = os.path.join(ROOT, "docs", "figures")
elif args:
    outdir = args[0]
else:
    outdir = tempfile.mkdtemp(prefix="dth-python-example-")
os.makedirs(outdir, exist_ok=True)
out = os.path.join(outdir, "python-example.png")
report = []  # the numbers docs/python.md quotes


def say(line):
    print(line)
    report.append(line)


# %% [markdown]
# ## 1. A scene file, and the same run at its vertices
# Midpoint samples (the default for a midpoint start) carry the exact energy; the vertices
# carry an O(h^2) offset that oscillates with the motion.

# %%
pend = os.path.join(ROOT, "scenes", "pendulum.ini")
mid = dth.run(pend)
ver = dth.run(pend, points="vertices")
E0 = mid.E[0]
say("pendulum: %d midpoints to t = %.4f, max |E - E0|/|E0| = %.2e (vertices: %.2e)" % (
    len(mid.t), mid.t[-1], np.abs(mid.E - E0).max() / abs(E0), np.abs(ver.E - E0).max() / abs(E0)))


# %% [markdown]
# ## 2. A model written in Python: Henon-Heiles
# H = (p1^2 + p2^2)/2 + (q1^2 + q2^2)/2 + lambda (q1^2 q2 - q2^3/3). Gradient and Hessian are
# over y = (q1, q2, t, p1, p2). Slow (every evaluation is a Python call) but fine for prototyping.

# %%
class HenonHeiles(dth.Model):
    name = "henon-heiles-py"
    params = {"lambda": 1.0}
    n = 2
    separable = True

    def H(self, q, t, p):
        x, v, l = q[0], q[1], self.params["lambda"]
        return 0.5 * (p[0] ** 2 + p[1] ** 2) + 0.5 * (x * x + v * v) + l * (x * x * v - v ** 3 / 3)

    def grad(self, q, t, p):
        x, v, l = q[0], q[1], self.params["lambda"]
        return (x + 2 * l * x * v, v + l * (x * x - v * v), 0.0, p[0], p[1])

    def hess(self, q, t, p):
        x, v, l = q[0], q[1], self.params["lambda"]
        h = np.zeros((5, 5))
        h[0, 0], h[0, 1], h[1, 0], h[1, 1] = 1 + 2 * l * v, 2 * l * x, 2 * l * x, 1 - 2 * l * v
        h[3, 3] = h[4, 4] = 1
        return h


def hh_scene(E, q2, p2, t_end):
    """q1 = 0, p1 > 0 from the energy; the section q1 = 0 crossed upward as an event."""
    p1 = math.sqrt(2 * E - p2 * p2 - q2 * q2 + 2 * q2 ** 3 / 3)
    return {"model": {"name": "henon-heiles-py"}, "initial": {"q": [0.0, q2], "p": [p1, p2]},
            "integrator": {"h": 0.05, "t_end": t_end}, "output": {"every": 20},
            "events": {"section": "q1", "section_direction": "up"}}


sections = []
for q2, p2 in ((-0.2, 0.0), (-0.1, 0.0), (0.05, 0.0), (0.15, 0.0), (0.3, 0.0), (0.4, 0.0)):
    r = dth.run(hh_scene(1 / 12, q2, p2, 600), models=[HenonHeiles])
    err = np.abs(r.E - r.E[0]).max() / abs(r.E[0])
    say("Henon-Heiles E = 1/12, q2 = %+.2f: %d section points, midpoint energy error %.1e" % (
        q2, len(r.events), err))
    sections.append((q2, r.events.q[:, 1], r.events.p[:, 1]))

# %% [markdown]
# ## 3. MEGNO: 2 on a regular orbit, growing on a chaotic one
# The deviation vector follows the DTH tangent map of every step (chaos.h).

# %%
megno = {}
for tag, E, q2 in (("regular, E = 1/12", 1 / 12, 0.1), ("chaotic, E = 1/6", 1 / 6, -0.1)):
    ts, ys = [], []
    with dth.Simulation(hh_scene(E, q2, 0.0, 400), models=[HenonHeiles]) as sim:
        for T in np.linspace(25, 400, 16):  # legs of one run: the indicator continues over them
            r = sim.run(t_end=T, megno=True, points="vertices", every=10 ** 6)
            ts.append(T)
            ys.append(r.megno)
    megno[tag] = (np.array(ts), np.array(ys))
    say("MEGNO %s: %.3f at t = %g (Lyapunov estimate %.3f)" % (tag, ys[-1], ts[-1], r.lyapunov))

# %%
fig, ax = plt.subplots(1, 3, figsize=(14, 4.4))
a = ax[0]
a.plot(ver.t, (ver.E - E0) / abs(E0), lw=0.8, label="vertices")
a.plot(mid.t, (mid.E - E0) / abs(E0), lw=1.2, label="midpoints (exact)")
a.set_xlabel("t")
a.set_ylabel("(E - E0)/|E0|")
a.set_title("pendulum: energy at vertices and midpoints")
a.legend(loc="upper right", fontsize=8)
a = ax[1]
for q2, x, y in sections:
    a.plot(x, y, ".", ms=2, label="q2(0) = %+.2f" % q2)
a.set_xlabel("q2")
a.set_ylabel("p2")
a.set_title("Henon-Heiles (Python model), E = 1/12:\nsection q1 = 0, p1 > 0")
a.legend(loc="upper right", fontsize=7, markerscale=4)
a = ax[2]
for tag, (t, y) in megno.items():
    a.plot(t, y, "o-", ms=3, label=tag)
a.axhline(2, color="gray", lw=0.6, ls="--")
a.set_yscale("log")
a.set_xlabel("t")
a.set_ylabel("MEGNO <Y>")
a.set_title("Henon-Heiles: MEGNO\nfrom the DTH tangent map")
a.legend(fontsize=8)
fig.tight_layout()
fig.savefig(out, dpi=110)
if mode != "--docs":  # the documentation quotes them instead
    with open(os.path.join(outdir, "python-example.txt"), "w") as f:
        f.write("\n".join(report) + "\n")
print("wrote %s%s" % (out, "" if mode == "--docs" else " and python-example.txt beside it"))

# %% [markdown]
# ## 4. The documentation's copy of these numbers (docs/python.md, between two markers)


# %%
def quoted():
    text = open(DOC).read()
    if BEGIN not in text or END not in text:
        sys.exit("python_example.py: %s has no %s ... %s block" % (DOC, BEGIN, END))
    a, b = text.index(BEGIN) + len(BEGIN), text.index(END)
    return text, a, b


block = "\n```\n" + "\n".join(report) + "\n```\n"
if mode == "--docs":
    text, a, b = quoted()
    with open(DOC, "w") as f:
        f.write(text[:a] + block + text[b:])
    print("updated the numbers in %s" % DOC)
elif mode == "--check-docs":
    text, a, b = quoted()
    if text[a:b] != block:
        sys.exit("python_example.py: docs/python.md quotes other numbers than this run printed; regenerate them with "
                 "python3 docs/python_example.py --docs\n--- docs/python.md:%s\n--- this run:%s" % (text[a:b], block))
    print("docs/python.md quotes these numbers")
