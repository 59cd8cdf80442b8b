#!/bin/sh
# SPDX-License-Identifier: MIT
# The README's Python one-liner, on a copy of this checkout (a second checkout on the machine):
# python3 -m venv --system-site-packages, pip install --no-build-isolation --no-index (meson-python
# builds libdth into the package: pyproject.toml), then from a folder outside both checkouts the
# venv's python imports its own copy (dth.__file__ and the loaded libdth.so inside the venv), runs
# the absolute path of scenes/pendulum.ini and the scene shipped in the package, both to the bits
# the build's library gives. Skipped (77) without python3-mesonpy or python3-venv (setup.sh installs
# them). Usage: check-pip.sh SOURCE_ROOT BUILDDIR PYTHON
set -eu
src=$(cd "$1" && pwd)
build=$(cd "$2" && pwd)
py=$3
"$py" -c 'import mesonpy' 2>/dev/null || { echo "check-pip: no meson-python (Debian python3-mesonpy): skipped"; exit 77; }
tmp=$(mktemp -d "${TMPDIR:-/tmp}/dth-pip-XXXXXX")
trap 'rm -rf "$tmp"' EXIT
"$py" -m venv --system-site-packages "$tmp/v" >"$tmp/venv.log" 2>&1 || {
    cat "$tmp/venv.log"; echo "check-pip: $py -m venv failed (Debian python3-venv): skipped"; exit 77; }

# the copy: what pip reads of a checkout (no build directories, git, figures, or the README's venv v/)
mkdir "$tmp/checkout"
(cd "$src" && tar --exclude='./build*' --exclude=./.git --exclude='./.mesonpy-*' --exclude=./out \
    --exclude=./docs/figures --exclude=./v -cf - .) | tar -C "$tmp/checkout" -xf -
# as on a fresh machine: no pip configuration of this one (index, find-links), no DTH_LIBRARY, no
# LD_LIBRARY_PATH (meson test points it at the build directory)
unset DTH_LIBRARY PYTHONPATH LD_LIBRARY_PATH
export PIP_CONFIG_FILE=/dev/null PIP_DISABLE_PIP_VERSION_CHECK=1
start=$(date +%s)
(cd "$tmp/checkout" && "$tmp/v/bin/pip" install --no-build-isolation --no-index .) >"$tmp/pip.log" 2>&1 || {
    tail -n 40 "$tmp/pip.log"; echo "check-pip: pip install failed" >&2; exit 1; }
echo "check-pip: pip install --no-build-isolation --no-index . took $(( $(date +%s) - start )) s"

# the reference: this checkout's package on the build's library
ref=$(cd "$tmp" && DTH_LIBRARY="$build/libdth.so" PYTHONPATH="$src/python" "$py" -c \
    'import dth, sys; print(repr(dth.run(sys.argv[1]).t[-1]))' "$src/scenes/pendulum.ini")

mkdir "$tmp/elsewhere"
cd "$tmp/elsewhere"
"$tmp/v/bin/python" - "$tmp/v" "$src/scenes/pendulum.ini" "$ref" "$src" "$tmp/checkout" <<'EOF'
import importlib.resources, os, sys
venv, scene, ref, src, copy = sys.argv[1:]
import dth
here = os.path.realpath(dth.__file__)
assert here.startswith(os.path.realpath(venv) + os.sep), "dth imported from %s, not the venv %s" % (here, venv)
r = dth.run(scene)                                             # an absolute path from outside the checkout
assert repr(r.t[-1]) == ref, "t[-1] %r, the build's library gives %s" % (r.t[-1], ref)
shipped = importlib.resources.files("dth") / "scenes" / "pendulum.ini"
assert repr(dth.run(shipped).t[-1]) == ref, "the package's own scenes/pendulum.ini differs"
libs = {line.split()[-1] for line in open("/proc/self/maps") if "libdth" in line}
assert len(libs) == 1 and next(iter(libs)).startswith(os.path.realpath(venv) + os.sep), "loaded %s" % libs
for p in [here] + list(libs):      # neither checkout: not this one, not the copy pip built from
    for c in (src, copy):
        assert not p.startswith(os.path.realpath(c) + os.sep), "%s is in the checkout %s" % (p, c)
# a model from a formula compiles against the package's own headers (dth/include), not a checkout's
try:
    import sympy  # noqa: F401  (Debian python3-sympy, seen through --system-site-packages)
except ImportError:
    sympy = None
if sympy is not None:
    import tempfile
    from dth import _formula
    inc = _formula.include_dirs()[0]
    assert inc.startswith(os.path.realpath(venv) + os.sep), "from_hamiltonian's headers from %s" % inc
    m = dth.Model.from_hamiltonian("p1**2/2 + q1**2/2", n=1, name="osc-pip", cache_dir=tempfile.mkdtemp())
    r = dth.run({"model": {"name": "osc-pip"}, "initial": {"q": 1, "p": 0}, "integrator": {"h": 0.1, "steps": 10}},
                models=[m])
    assert r.status == 0 and len(r.t) == 10, r
print("check-pip: the venv's dth (%s) ran %s and its own scenes/pendulum.ini: t[-1] = %s, as the build's "
      "library; libdth from %s" % (os.path.dirname(here), scene, ref, next(iter(libs))))
EOF
