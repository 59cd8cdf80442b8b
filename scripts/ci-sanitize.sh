#!/bin/sh
# SPDX-License-Identifier: MIT
# Sanitizer check: build with AddressSanitizer + UndefinedBehaviorSanitizer (no recovery, leak
# detection on), run the whole meson test suite and the CLI smoke runs. Any report fails.
# Usage: scripts/ci-sanitize.sh   (from any checkout; builds in build-asan)
set -eu
root=$(cd "$(dirname "$0")/.." && pwd)
. "$root/scripts/ci-lib.sh"
ci_need meson meson ninja-build gcc pkg-config
bd="$root/build-asan"
if [ ! -f "$bd/build.ninja" ]; then
    # b_lundef=false: the sanitizer runtimes resolve some symbols of libdth.so at load time
    meson setup "$bd" "$root" -Db_sanitize=address,undefined -Db_lundef=false -Dbench=false \
        -Dc_args=-fno-sanitize-recover=all -Dc_link_args=-fno-sanitize-recover=all >/dev/null
fi
ninja -C "$bd" >/dev/null
export ASAN_OPTIONS=halt_on_error=1:print_stacktrace=1:detect_leaks=1:exitcode=86
export UBSAN_OPTIONS=halt_on_error=1:print_stacktrace=1:exitcode=86
export LSAN_OPTIONS=exitcode=86
meson test -C "$bd" --print-errorlogs --no-rebuild
ci_cli_smoke "$root" "$bd/cli/dth"
echo "ci-sanitize: OK"
