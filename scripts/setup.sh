#!/usr/bin/env bash
# Install what is missing (Debian 12 packages), then configure and build dth in ./build.
# Usage: bash scripts/setup.sh [builddir [meson options...]]   (idempotent; safe to run on every
# invocation). Options such as --prefix=/opt/dth reconfigure an existing build directory.
set -euo pipefail
cd "$(dirname "$0")/.."
builddir=${1:-build}
[ $# -gt 0 ] && shift

# python3-mesonpy, python3-venv, python3-pip: `pip install --no-build-isolation .` of the Python
# package (pyproject.toml, docs/python.md); python3-sympy: dth.Model.from_hamiltonian; python3-pandas:
# Result.to_pandas
# g++, libboost-dev: bench/bench_peers.cpp (Boost.Odeint, header-only; the C++ compiler for the bench only)
packages=(gcc g++ libboost-dev pkg-config meson ninja-build liblapacke-dev libopenblas-dev libcunit1-dev
          libinih-dev libgsl-dev gnuplot-nox libhdf5-dev
          python3-cffi python3-numpy python3-pytest python3-matplotlib python3-sympy python3-pandas
          python3-mesonpy python3-venv python3-pip libopenmpi-dev openmpi-bin python3-h5py)
missing=()
for p in "${packages[@]}"; do
  dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || missing+=("$p")
done

sudo=""
[ "$(id -u)" -eq 0 ] || sudo="sudo"
# apt-get waiting for another apt or dpkg (unattended-upgrades, a second setup.sh) instead of failing
# with status 100: DPkg::Lock::Timeout covers dpkg's locks only, so a run that still finds a lock
# busy (the package lists', the archives') is retried, for up to 10 minutes in all.
apt() {
  local deadline=$(( $(date +%s) + 600 )) err
  err=$(mktemp)
  while :; do
    if $sudo env DEBIAN_FRONTEND=noninteractive apt-get -o DPkg::Lock::Timeout=600 "$@" 2>"$err"; then
      rm -f "$err"; return 0
    fi
    if grep -q -e 'Could not get lock' -e 'Unable to lock' "$err" && [ "$(date +%s)" -lt "$deadline" ]; then
      [ -n "${waited:-}" ] || echo "setup: another apt or dpkg holds its lock; waiting" >&2
      waited=1
      sleep 5
      continue
    fi
    cat "$err" >&2; rm -f "$err"; return 1
  done
}
if [ ${#missing[@]} -gt 0 ]; then
  echo "setup: installing ${missing[*]}" >&2
  apt update -qq
  apt install -y -qq --no-install-recommends "${missing[@]}" >/dev/null
fi

if [ ! -f "$builddir/build.ninja" ]; then
  meson setup "$builddir" -Dhdf5=enabled -Dpython=enabled -Dmpi=enabled "$@" >/dev/null
elif [ $# -gt 0 ]; then
  meson setup --reconfigure "$builddir" "$@" >/dev/null
fi
ninja -C "$builddir" >/dev/null

# Earlier versions of this script wrote dth-checkout.pth (this checkout's python/) into the site
# directory of /usr/bin/python3, so that the last checkout set up won every `import dth` on the
# machine. Remove that file if it is ours (it names this checkout); another checkout's is left.
if [ -x /usr/bin/python3 ]; then
  for site in $(/usr/bin/python3 -c 'import site; print(*site.getsitepackages())' 2>/dev/null || true); do
    pth=$site/dth-checkout.pth
    if [ -f "$pth" ] && [ "$(cat "$pth")" = "$PWD/python" ]; then
      $sudo rm -f "$pth" && echo "setup: removed $pth (pip install the package instead: docs/python.md)" >&2
    fi
  done
fi
if [ -z "${DTH_SETUP_QUIET:-}" ]; then
  echo "setup: built in $builddir; the Python package: python3 -m venv --system-site-packages v &&" \
       "v/bin/pip install --no-build-isolation --no-index . (docs/python.md)" >&2
fi
