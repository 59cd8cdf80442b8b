#!/bin/sh
# SPDX-License-Identifier: MIT
# meson install into a temporary root, then import the *installed* Python package and run the
# installed pendulum scene with it: the package (with its scenes/), its _config.py and the library
# land where the Python module of meson says. Usage: check-install.sh BUILDDIR PYTHON
set -eu
build=$1
py=$2
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
meson install -C "$build" --destdir "$tmp/root" --no-rebuild --quiet >/dev/null
cfg=$(find "$tmp/root" -path '*/dth/_config.py' | head -n 1)
[ -n "$cfg" ] || { echo "check-install: the Python package was not installed" >&2; exit 1; }
site=$(dirname "$(dirname "$cfg")")
for f in __init__.py _core.py _ffi.py _formula.py include/dth/model.h include/dth/status.h scenes/pendulum.ini; do
    [ -f "$site/dth/$f" ] || { echo "check-install: dth/$f not installed" >&2; exit 1; }
done
# _config.LIBRARY names the library at its final place (prefix/libdir): here under the destdir
lib=$(sed -n 's/^LIBRARY = "\(.*\)"$/\1/p' "$cfg")
[ -f "$tmp/root$lib" ] || { echo "check-install: _config.LIBRARY '$lib' is not the installed library" >&2; exit 1; }
scene=$(find "$tmp/root" -path '*/share/dth/scenes/pendulum.ini' | head -n 1)
cd "$tmp"
PYTHONPATH="$site" DTH_LIBRARY="$tmp/root$lib" "$py" -c '
import sys, dth
assert dth.__file__.startswith(sys.argv[1]), dth.__file__
r = dth.run(sys.argv[2])
assert abs(r.t[-1] - 19.978106240192535) < 1e-12, r.t[-1]
' "$site" "$scene"
echo "check-install: the installed package (${site#"$tmp/root"}) ran the installed pendulum scene"
