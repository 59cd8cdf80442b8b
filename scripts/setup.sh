#!/usr/bin/env bash
# Install what is missing (Debian 12 packages), then configure and build dth in ./build.
# Usage: bash scripts/setup.sh [builddir [meson options...]]   (idempotent; safe to run on every
# invocation). Options such as --prefix=/opt/dth reconfigure an existing build directory.
set -euo pipefail
cd "$(dirname "$0")/.."
builddir=${1:-build}
[ $# -gt 0 ] && shift

packages=(gcc pkg-config meson ninja-build liblapacke-dev libopenblas-dev libcunit1-dev
          libinih-dev libgsl-dev gnuplot-nox libhdf5-dev
          python3-cffi python3-numpy python3-pytest python3-matplotlib libopenmpi-dev openmpi-bin python3-h5py)
missing=()
for p in "${packages[@]}"; do
  dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || missing+=("$p")
done
if [ ${#missing[@]} -gt 0 ]; then
  echo "setup: installing ${missing[*]}" >&2
  sudo=""
  [ "$(id -u)" -eq 0 ] || sudo="sudo"
  export DEBIAN_FRONTEND=noninteractive
  $sudo apt-get update -qq
  $sudo apt-get install -y -qq --no-install-recommends "${missing[@]}" >/dev/null
fi

if [ ! -f "$builddir/build.ninja" ]; then
  meson setup "$builddir" -Dhdf5=enabled -Dpython=enabled -Dmpi=enabled "$@" >/dev/null
elif [ $# -gt 0 ]; then
  meson setup --reconfigure "$builddir" "$@" >/dev/null
fi
ninja -C "$builddir" >/dev/null
# The Python package runs from the checkout (it finds build/libdth.so itself; another build
# directory: DTH_LIBRARY=BUILDDIR/libdth.so): a .pth file in Debian's site directory of the system
# python3 puts python/ on its path, so `python3 -c "import dth"` works after this script (meson
# install installs the package for good; remove the .pth file to undo).
pth_note="export PYTHONPATH=$PWD/python"
if [ "$builddir" = build ] && [ -x /usr/bin/python3 ]; then
  site=$(/usr/bin/python3 -c 'import site; print(site.getsitepackages()[0])' 2>/dev/null || true)
  if [ -n "$site" ]; then
    sudo=""
    [ "$(id -u)" -eq 0 ] || sudo="sudo"
    if $sudo mkdir -p "$site" 2>/dev/null && echo "$PWD/python" | $sudo tee "$site/dth-checkout.pth" >/dev/null 2>&1; then
      pth_note="python3 finds it through $site/dth-checkout.pth"
    fi
  fi
fi
if [ -z "${DTH_SETUP_QUIET:-}" ]; then
  echo "setup: built in $builddir; Python package: $pth_note (docs/python.md)" >&2
fi
