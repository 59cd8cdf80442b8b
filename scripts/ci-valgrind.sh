#!/bin/sh
# SPDX-License-Identifier: MIT
# Valgrind check: the CLI smoke runs under memcheck (definite and indirect leaks are errors) on
# an ordinary build. OpenBLAS noise is suppressed by scripts/ci-valgrind.supp (see there).
# Usage: scripts/ci-valgrind.sh   (from any checkout; builds in build-valgrind)
set -eu
root=$(cd "$(dirname "$0")/.." && pwd)
. "$root/scripts/ci-lib.sh"
ci_need meson meson ninja-build gcc pkg-config
ci_need valgrind valgrind
bd="$root/build-valgrind"
[ -f "$bd/build.ninja" ] || meson setup "$bd" "$root" -Dbench=false >/dev/null
ninja -C "$bd" >/dev/null
# one OpenBLAS thread: the tiny systems gain nothing from threads, and it keeps memcheck quiet
export OPENBLAS_NUM_THREADS=1
ci_cli_smoke "$root" "$bd/cli/dth" valgrind -q --error-exitcode=86 --leak-check=full \
    --errors-for-leak-kinds=definite,indirect --suppressions="$root/scripts/ci-valgrind.supp"
echo "ci-valgrind: OK"
