#!/bin/sh
# SPDX-License-Identifier: MIT
# Symbol check: every dynamic symbol libdth.so defines starts with dth_ (no namespace pollution).
# Usage: scripts/ci-symbols.sh [path/to/libdth.so]
#   without an argument: configure build-ci-symbols from this checkout, build the library, check it.
set -eu
if [ $# -ge 1 ]; then
    lib=$1
else
    root=$(cd "$(dirname "$0")/.." && pwd)
    command -v nm >/dev/null || apt-get install -y binutils
    bd="$root/build-ci-symbols"
    [ -d "$bd" ] || meson setup "$bd" "$root" -Dtests=false -Dcli=false -Dbench=false >/dev/null
    ninja -C "$bd" >/dev/null
    lib=$(ls "$bd"/libdth.so.* | head -n 1)
fi
[ -f "$lib" ] || { echo "ci-symbols: no library at $lib" >&2; exit 1; }
# AddressSanitizer builds add an ODR-check alias __odr_asan.<global> per exported global.
bad=$(nm -D --defined-only "$lib" | awk 'NF >= 3 { print $3 }' | sed 's/^__odr_asan\.//' | grep -v '^dth_' || true)
count=$(nm -D --defined-only "$lib" | awk 'NF >= 3' | wc -l)
if [ -n "$bad" ]; then
    echo "ci-symbols: $lib exports symbols without the dth_ prefix:" >&2
    echo "$bad" >&2
    exit 1
fi
echo "ci-symbols: $count exported symbols, all dth_-prefixed ($lib)"
