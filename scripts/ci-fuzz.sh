#!/bin/sh
# SPDX-License-Identifier: MIT
# Fuzzing check: build the libFuzzer targets of fuzz/ with clang + ASan + UBSan and run each for a
# bounded time (DTH_FUZZ_SECONDS, default 60) from its seed corpus fuzz/corpus/<target>/. Prints the
# executions per target; fails on any crash, leak, sanitizer report or broken invariant (the
# reproducer is saved as build-fuzz/artifacts/<target>-crash-*; turn it into a CUnit test).
# Usage: scripts/ci-fuzz.sh [target...]   (from any checkout; builds in build-fuzz)
set -eu
root=$(cd "$(dirname "$0")/.." && pwd)
. "$root/scripts/ci-lib.sh"
ci_need meson meson ninja-build gcc pkg-config
ci_need clang clang
probe=$(mktemp -d)
printf '#include <stdint.h>\n#include <stddef.h>\nint LLVMFuzzerTestOneInput(const uint8_t *d, size_t n);\nint LLVMFuzzerTestOneInput(const uint8_t *d, size_t n) { (void)d; (void)n; return 0; }\n' >"$probe/p.c"
if ! clang -fsanitize=fuzzer,address "$probe/p.c" -o "$probe/p" 2>/dev/null; then
    # libFuzzer's runtime lives in compiler-rt
    sudo=""
    [ "$(id -u)" -eq 0 ] || sudo="sudo"
    ver=$(clang -dumpversion | cut -d. -f1)
    DEBIAN_FRONTEND=noninteractive $sudo apt-get install -y -qq --no-install-recommends "libclang-rt-$ver-dev" >/dev/null
fi
rm -rf "$probe"
bd="$root/build-fuzz"
if [ ! -f "$bd/build.ninja" ]; then
    CC=clang meson setup "$bd" "$root" -Dfuzz=true -Dtests=false -Dcli=false -Dbench=false \
        -Db_sanitize=address,undefined -Db_lundef=false \
        "-Dc_args=-fsanitize=fuzzer-no-link -fno-sanitize-recover=all" >/dev/null
fi
ninja -C "$bd" >/dev/null
secs=${DTH_FUZZ_SECONDS:-60}
targets=${*:-fuzz_scene fuzz_override fuzz_integrator fuzz_checkpoint}
export ASAN_OPTIONS=halt_on_error=1:print_stacktrace=1:detect_leaks=1
export UBSAN_OPTIONS=halt_on_error=1:print_stacktrace=1
mkdir -p "$bd/artifacts"
status=0
for t in $targets; do
    # new inputs go to a scratch corpus: the seeds in the repository stay as they are
    work="$bd/corpus-$t"
    mkdir -p "$work"
    log="$bd/$t.log"
    set +e
    "$bd/fuzz/$t" -max_total_time="$secs" -timeout=10 -rss_limit_mb=1024 -print_final_stats=1 \
        -artifact_prefix="$bd/artifacts/$t-" "$work" "$root/fuzz/corpus/$t" >"$log" 2>&1
    rc=$?
    set -e
    execs=$(sed -n 's/^stat::number_of_executed_units: *//p' "$log" | tail -n 1)
    echo "ci-fuzz: $t: ${execs:-?} executions (time budget ${secs} s), exit $rc"
    if [ "$rc" -ne 0 ]; then
        status=1
        grep -E 'ERROR|invariant|SUMMARY|Test unit written' "$log" | head -n 20 >&2
    fi
done
[ "$status" -eq 0 ] && echo "ci-fuzz: OK"
exit "$status"
