#!/bin/sh
# SPDX-License-Identifier: MIT
# Determinism check: the same scene gives byte-identical CSV from `dth run` across runs and across
# builds: gcc -O0 (buildtype=debug), gcc -O2 (release) and, when present, clang -O2. Every shipped
# scene is run with vertex output and with resampled output plus diagnostics.
# Usage: scripts/ci-determinism.sh   (from any checkout; builds in build-det-*)
set -eu
root=$(cd "$(dirname "$0")/.." && pwd)
. "$root/scripts/ci-lib.sh"
ci_need meson meson ninja-build gcc pkg-config
opts="-Dtests=false -Dbench=false"
builds="O0 O2"
[ -f "$root/build-det-O0/build.ninja" ] || meson setup "$root/build-det-O0" "$root" $opts --buildtype=debug >/dev/null
[ -f "$root/build-det-O2/build.ninja" ] || meson setup "$root/build-det-O2" "$root" $opts --buildtype=release >/dev/null
if command -v clang >/dev/null 2>&1; then
    builds="$builds clang"
    [ -f "$root/build-det-clang/build.ninja" ] ||
        CC=clang meson setup "$root/build-det-clang" "$root" $opts --buildtype=release >/dev/null
fi
out=$(mktemp -d)
status=0
files=0
for b in $builds; do
    ninja -C "$root/build-det-$b" >/dev/null
    for s in "$root"/scenes/*.ini; do
        name=$(basename "$s" .ini)
        for mode in vertices resampled; do
            set -- run "$s"
            [ "$mode" = resampled ] && set -- "$@" -s output.dt=0.0625 -s output.diagnostics=yes
            for rep in 1 2; do
                set +e
                "$root/build-det-$b/cli/dth" "$@" >"$out/$name.$mode.$b.$rep.csv" 2>/dev/null
                rc=$?
                set -e
                # 3 = trajectory stopped early (raw rotating pendulum): its output is still compared
                if [ "$rc" -ne 0 ] && [ "$rc" -ne 3 ]; then
                    echo "ci-determinism: $b: dth $* exited $rc" >&2
                    status=1
                fi
                echo "$rc" >>"$out/$name.$mode.$b.$rep.csv"
            done
            files=$((files + 2))
            cmp -s "$out/$name.$mode.$b.1.csv" "$out/$name.$mode.$b.2.csv" ||
                { echo "ci-determinism: $b: two runs of $name ($mode) differ" >&2; status=1; }
            cmp -s "$out/$name.$mode.O0.1.csv" "$out/$name.$mode.$b.1.csv" || {
                echo "ci-determinism: $name ($mode): build $b differs from O0:" >&2
                diff "$out/$name.$mode.O0.1.csv" "$out/$name.$mode.$b.1.csv" | head -n 6 >&2
                status=1
            }
        done
    done
done
rm -rf "$out"
[ "$status" -eq 0 ] && echo "ci-determinism: $files CSV outputs byte-identical across runs and builds ($builds)"
exit "$status"
