#!/bin/sh
# SPDX-License-Identifier: MIT
# Fuzzing check: build the libFuzzer targets of fuzz/ with clang + ASan + UBSan, the library with
# them instrumented for coverage (-fsanitize=fuzzer-no-link on every source), and run each for a
# bounded time (DTH_FUZZ_SECONDS, default 60) from its seed corpus fuzz/corpus/<target>/. Prints per
# target the executions, libFuzzer's final coverage figures (cov: edges, ft: features), the edges of
# the library covered (-print_coverage: lib/, models/, regularize/), and for fuzz_checkpoint those
# of the checkpoint code (lib/checkpoint.c, restore.c, restore_rules.c, fields.c) and the number of
# distinct restore refusals (messages with their numbers taken out: the restore paths taken). CI
# keeps the default 60 s per target; DTH_FUZZ_SECONDS=600 scripts/ci-fuzz.sh fuzz_checkpoint is the
# acceptance run of issue 24. Fails on any crash,
# leak, sanitizer report or broken invariant (the reproducer is saved as
# build-fuzz/artifacts/<target>-crash-*; turn it into a CUnit test).
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
# edges covered / total of the functions of the files matching $2 in a -print_coverage log $1
edges() {
    grep -E '^(UN)?COVERED_FUNC: ' "$1" | grep -E " [^ ]*($2):[0-9]+$" |
        awk '{ split($5, e, "/"); c += e[1]; n += e[2] } END { printf "%d of %d", c, n }'
}
for t in $targets; do
    # new inputs go to a scratch corpus: the seeds in the repository stay as they are
    work="$bd/corpus-$t"
    mkdir -p "$work"
    log="$bd/$t.log"
    refusals="$bd/$t.refusals"
    rm -f "$refusals"
    set +e
    DTH_FUZZ_REFUSALS="$refusals" "$bd/fuzz/$t" -max_total_time="$secs" -timeout=10 -rss_limit_mb=1024 \
        -print_final_stats=1 -print_coverage=1 -artifact_prefix="$bd/artifacts/$t-" "$work" "$root/fuzz/corpus/$t" \
        >"$log" 2>&1
    rc=$?
    set -e
    execs=$(sed -n 's/^stat::number_of_executed_units: *//p' "$log" | tail -n 1)
    cov=$(grep -E '^#[0-9]+.* cov: [0-9]+ ft: [0-9]+' "$log" | tail -n 1 | sed -E 's/.* cov: ([0-9]+) ft: ([0-9]+).*/cov \1, ft \2/')
    echo "ci-fuzz: $t: ${execs:-?} executions (time budget ${secs} s), ${cov:-no coverage figures}; library edges" \
        "covered (lib/, models/, regularize/): $(edges "$log" '/(lib|models|regularize)/[a-z_]+\.c'), exit $rc"
    if [ "$t" = fuzz_checkpoint ]; then
        echo "ci-fuzz: $t: checkpoint code (checkpoint.c, restore.c, restore_rules.c, fields.c) edges covered:" \
            "$(edges "$log" '/lib/(checkpoint|restore|restore_rules|fields)\.c'); distinct restore refusals:" \
            "$([ -f "$refusals" ] && sort -u "$refusals" | wc -l || echo 0)"
    fi
    if [ "$rc" -ne 0 ]; then
        status=1
        grep -E 'ERROR|invariant|SUMMARY|Test unit written|refused:' "$log" | head -n 20 >&2
    fi
done
[ "$status" -eq 0 ] && echo "ci-fuzz: OK"
exit "$status"
