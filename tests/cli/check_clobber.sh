#!/bin/sh
# SPDX-License-Identifier: MIT
# No subcommand writes over its own inputs (issue 24): dth sweep's summary over the scene, the list
# or a trajectory of its own; dth map's outputs over the scene; a resumed dth run's trajectory over
# the checkpointed run's events file. Each is refused before any work: exit 2, one line naming the
# input, the input unchanged.
# usage: check_clobber.sh PATH/TO/dth SOURCE_ROOT
set -u
DTH=$(cd "$(dirname "$1")" && pwd)/$(basename "$1") # absolute: the commands run in the test folder
SC=$2/scenes
T=$(mktemp -d /tmp/dth_clobber_test.XXXXXX)
trap 'rm -rf "$T"' EXIT
fails=0
fail() { echo "FAIL: $*" >&2; fails=$((fails + 1)); }
# refused WANT FILE ARGS...: exit 2, one line containing WANT, FILE unchanged, no temporary next to it
refused() {
    want=$1 file=$2
    shift 2
    cp "$file" "$T/before"
    (cd "$T" && "$@") >/dev/null 2>"$T/err"
    rc=$?
    [ $rc -eq 2 ] || fail "$*: exit $rc, want 2 ($(cat "$T/err"))"
    [ "$(wc -l <"$T/err")" -eq 1 ] && grep -q -- "$want" "$T/err" || fail "$*: message: $(cat "$T/err")"
    cmp -s "$T/before" "$file" || fail "$*: $file was overwritten"
    [ -z "$(ls "$T" | grep '\.tmp\.')" ] || fail "$*: a temporary was left: $(ls "$T")"
}
cp "$SC/pendulum.ini" "$T/S.ini"
refused "refusing to write the summary to 'S.ini': it is the scene file" "$T/S.ini" \
    "$DTH" sweep S.ini --vary initial.q=0:1:2 -o S.ini
refused "refusing to write the summary to './S.ini': it is the scene file" "$T/S.ini" \
    "$DTH" sweep "$T/S.ini" --vary initial.q=0:1:2 -o ./S.ini
printf 'initial.q\n0.5\n1\n' >"$T/L.csv"
refused "refusing to write the summary to 'L.csv': it is the list (--list)" "$T/L.csv" \
    "$DTH" sweep S.ini --list L.csv -o L.csv
# the summary as one of the trajectories (run 0: T-0.csv; of 12 runs: T-03.csv)
echo keep >"$T/T-0.csv"
refused "refusing to write the summary to 'T-0.csv': it is the trajectory of run 0 (--trajectories T)" "$T/T-0.csv" \
    "$DTH" sweep S.ini --vary initial.q=0:1:2 --trajectories T -o T-0.csv
mkdir -p "$T/tr"
echo keep >"$T/tr/T-03.csv"
refused "it is the trajectory of run 3 (--trajectories tr/T)" "$T/tr/T-03.csv" \
    "$DTH" sweep S.ini --vary initial.q=0:1:12 --trajectories tr/T -o "$T/tr/T-03.csv"
# (not a trajectory: another width, or a run beyond the sweep)
(cd "$T" && "$DTH" sweep S.ini --vary initial.q=0:1:2 -s integrator.steps=3 --trajectories T -o T-00.csv 2>/dev/null) ||
    fail "T-00.csv is no trajectory of 2 runs"
# dth map: the scene M.csv under --out M
cp "$SC/pendulum.ini" "$T/M.csv"
refused "refusing to write the map to 'M.csv': it is the scene file" "$T/M.csv" \
    "$DTH" map M.csv --q 0:1:2 --p 0:1:2 --out M
cp "$SC/pendulum.ini" "$T/M-traj.csv"
refused "refusing to write the trajectory to 'M-traj.csv': it is the scene file" "$T/M-traj.csv" \
    "$DTH" map M-traj.csv --q 0:1:2 --p 0:1:2 --out M
# dth run --resume: the trajectory over the checkpointed run's events file (and the events over its trajectory)
(cd "$T" && "$DTH" run "$SC/pendulum.ini" -s integrator.steps=200 -s events.section=p1 --checkpoint b.ckpt \
    --checkpoint-every 50 -o b.csv 2>/dev/null) || fail "checkpointed run with events"
refused "refusing to write the output to 'b-events.csv': it is the checkpointed run's events file" "$T/b-events.csv" \
    "$DTH" run --resume b.ckpt -s integrator.steps=300 -o b-events.csv
refused "refusing to write events to 'b.csv': it is the checkpointed run's output" "$T/b.csv" \
    "$DTH" run --resume b.ckpt -s integrator.steps=300 -o c.csv --events b.csv
# continuing the same files stays allowed
(cd "$T" && "$DTH" run --resume b.ckpt -s integrator.steps=300 -o b.csv 2>/dev/null) || fail "resume onto its own files"
[ "$(wc -l <"$T/b.csv")" -eq 301 ] || fail "resume onto its own files: $(wc -l <"$T/b.csv") lines"
[ $fails -eq 0 ] && echo "check_clobber: no input overwritten"
exit $((fails != 0))
