#!/bin/sh
# SPDX-License-Identifier: MIT
# End-to-end checks of dth run's baseline methods and of checkpoint/resume: a run interrupted
# (stopped at a step count, or killed) and resumed writes the same bytes as the uninterrupted
# run, also across psi = 0 crossings with a regularizer; corrupted checkpoints are refused.
# usage: check_run.sh PATH/TO/dth SOURCE_ROOT
set -u
DTH=$1
SC=$2/scenes
T=$(mktemp -d /tmp/dth_run_test.XXXXXX)
trap 'rm -rf "$T"' EXIT
fails=0
fail() { echo "FAIL: $*" >&2; fails=$((fails + 1)); }
ok() { echo "ok: $*"; }

# ---- integrator.reversible = yes: --roundtrip returns to the start vertex exactly (the reversible
# finish, docs/theory.md), on the small path and LAPACK's dense path; refused with a banded solver
for sc in pendulum kepler-e06 coupled-chain-50; do
    for ls in auto dense; do
        [ "$sc" = coupled-chain-50 ] && [ "$ls" = auto ] && continue
        "$DTH" run "$SC/$sc.ini" -s integrator.reversible=yes -s integrator.linsolve=$ls -s regularize.method=none \
            -o "$T/rev.csv" --roundtrip 2>"$T/rev.err" || fail "reversible $sc $ls: $(cat "$T/rev.err")"
        grep -q 'max |z - z_0| = 0 (relative 0)' "$T/rev.err" && ok "reversible round trip $sc ($ls)" ||
            fail "reversible $sc $ls: $(grep 'round trip' "$T/rev.err")"
    done
done
if "$DTH" run "$SC/coupled-chain-50.ini" -s integrator.reversible=yes -o "$T/rev.csv" 2>"$T/rev.err"; then
    fail "reversible with the banded solver was accepted"
else
    ok "reversible refused with the banded solver"
fi

# ---- baseline methods through the scene's [integrator] method=
for m in midpoint gauss4 rk4 verlet midpoint-proj; do
    "$DTH" run "$SC/pendulum.ini" -s integrator.method=$m -s integrator.steps=200 -o "$T/$m.csv" 2>"$T/$m.err" ||
        fail "method $m: $(cat "$T/$m.err")"
    # fixed step: t = k h exactly on every row, wp constant
    awk -F, -v m=$m 'NR > 2 && ($3 != 0.050000000000000003) { print m " row " NR ": lambda " $3; bad = 1 }
        END { exit bad }' "$T/$m.csv" || fail "method $m: lambda column"
    [ "$(wc -l <"$T/$m.csv")" -eq 202 ] || fail "method $m: rows"
done
# the energy column shows what each method conserves: midpoint-proj exactly, rk4 not
h_proj=$(tail -1 "$T/midpoint-proj.csv" | cut -d, -f7)
h_rk4=$(tail -1 "$T/rk4.csv" | cut -d, -f7)
awk -v a="$h_proj" -v b="$h_rk4" 'BEGIN { exit !(a < 1e-14 && a > -1e-14 && (b > 1e-12 || b < -1e-12)) }' ||
    fail "energy errors: midpoint-proj $h_proj, rk4 $h_rk4"
"$DTH" run "$SC/pendulum.ini" -s integrator.method=rk4 -s regularize.method=land 2>"$T/x.err"
[ $? -eq 2 ] && grep -q "method = dth only" "$T/x.err" || fail "regularizer with a baseline: $(cat "$T/x.err")"
ok "baseline methods"

# the default regularizer on a long banded chain: ordinary steps stay O(n) in memory (the dense
# changeover workspace, 2 (2n + 1)^2 doubles = 640 GB here, is allocated only at a changeover)
if command -v python3 >/dev/null 2>&1; then
    if python3 "$2/scripts/make-chain-scene.py" 100000 --t-end 1 -o "$T/chain.ini" >/dev/null &&
        "$DTH" run "$T/chain.ini" -s integrator.steps=3 -o "$T/chain.csv" 2>"$T/chain.err" &&
        [ "$(wc -l <"$T/chain.csv")" -eq 4 ]; then # the header and 3 midpoints
        ok "a chain of 10^5 particles runs with the default regularizer"
    else
        fail "chain of 10^5 with the default regularizer: $(cat "$T/chain.err")"
    fi
fi

# ---- checkpoint/resume, bit for bit
resume_check() { # name, scene, total overrides, partial overrides (then the common ones)
    name=$1 scene=$2 total=$3 part=$4
    shift 4
    "$DTH" run "$scene" $total "$@" -o "$T/$name-ref.csv" 2>/dev/null
    rc_ref=$?
    "$DTH" run "$scene" $part "$@" --checkpoint "$T/$name.ckpt" --checkpoint-every 37 -o "$T/$name-part.csv" 2>/dev/null
    "$DTH" run --resume "$T/$name.ckpt" $total -o "$T/$name-res.csv" 2>/dev/null
    rc_res=$?
    [ $rc_ref -eq $rc_res ] || fail "$name: exit $rc_res after resume, $rc_ref uninterrupted"
    cmp -s "$T/$name-ref.csv" "$T/$name-res.csv" || fail "$name: resumed output differs from the uninterrupted run"
    [ "$(wc -l <"$T/$name-ref.csv")" -gt 10 ] || fail "$name: reference too short"
}
resume_check steps "$SC/pendulum.ini" "-s integrator.steps=300" "-s integrator.steps=120" -s output.diagnostics=yes
resume_check t_end "$SC/kepler-e06.ini" "-s integrator.t_end=20" "-s integrator.t_end=7.5" -s output.diagnostics=yes
resume_check dense "$SC/pendulum.ini" "-s integrator.t_end=12" "-s integrator.t_end=5" -s output.dt=0.1
resume_check every "$SC/harmonic.ini" "-s integrator.steps=500" "-s integrator.steps=233" -s output.every=7
resume_check reg "$SC/pendulum-rotation.ini" "-s integrator.steps=600" "-s integrator.steps=250" \
    -s regularize.method=land -s output.diagnostics=yes
# a regularizer with state of its own (a constant fixed at its first step, its solver's seed)
resume_check prescribed "$SC/pendulum-rotation-prescribed.ini" "-s integrator.t_end=30" "-s integrator.t_end=11"
resume_check prescribed_kepler "$SC/kepler-e09-prescribed.ini" "-s integrator.t_end=40" "-s integrator.t_end=13"
crossings=$(awk -F, 'NR == 1 { for (i = 1; i <= NF; i++) if ($i == "branch") b = i } NR > 1 && $b == "reg"' "$T/reg-ref.csv" | wc -l)
[ "$crossings" -ge 4 ] || fail "reg: only $crossings regularized steps in the reference"
ok "resume is bit-identical (steps, t_end, dt, every, $crossings regularized steps, prescribed)"

# a run killed at any moment: resume from its last checkpoint
"$DTH" run "$SC/pendulum.ini" -s integrator.steps=400000 -o "$T/kill-ref.csv" 2>/dev/null
"$DTH" run "$SC/pendulum.ini" -s integrator.steps=400000 --checkpoint "$T/kill.ckpt" --checkpoint-every 5000 \
    -o "$T/kill.csv" 2>/dev/null &
pid=$!
i=0
while [ ! -f "$T/kill.ckpt" ] && [ $i -lt 100 ]; do sleep 0.05; i=$((i + 1)); done
sleep 0.1
kill -9 $pid 2>/dev/null
wait $pid 2>/dev/null
[ -f "$T/kill.ckpt" ] || fail "no checkpoint written before the kill"
"$DTH" run --resume "$T/kill.ckpt" -o "$T/kill-res.csv" 2>"$T/kill.err" || fail "resume after kill: $(cat "$T/kill.err")"
cmp -s "$T/kill-ref.csv" "$T/kill-res.csv" || fail "resumed output after kill -9 differs"
ls "$T" | grep -q '^kill\.csv\.tmp\.' && fail "the killed run's temporary is left after the resume"
ok "kill -9 and resume (the killed run's temporary removed)"

# corrupted and truncated inputs are refused with one line, exit 2
cp "$T/steps.ckpt" "$T/bad.ckpt"
printf 'X' | dd of="$T/bad.ckpt" bs=1 seek=100 conv=notrunc 2>/dev/null
"$DTH" run --resume "$T/bad.ckpt" -o "$T/bad.csv" 2>"$T/bad.err"
[ $? -eq 2 ] && [ "$(wc -l <"$T/bad.err")" -eq 1 ] || fail "corrupted checkpoint: $(cat "$T/bad.err")"
[ -f "$T/bad.csv" ] && fail "corrupted checkpoint left an output file"
head -c 200 "$T/steps.ckpt" >"$T/short.ckpt"
"$DTH" run --resume "$T/short.ckpt" -o "$T/bad.csv" 2>"$T/bad.err"
[ $? -eq 2 ] || fail "truncated checkpoint: $(cat "$T/bad.err")"
head -c 100 "$T/steps-part.csv" >"$T/steps-part2.csv" && mv "$T/steps-part2.csv" "$T/steps-part.csv"
"$DTH" run --resume "$T/steps.ckpt" -s integrator.steps=300 -o "$T/bad.csv" 2>"$T/bad.err"
[ $? -eq 2 ] && grep -q "shorter" "$T/bad.err" || fail "truncated output: $(cat "$T/bad.err")"
"$DTH" run "$SC/pendulum.ini" --checkpoint "$T/x.ckpt" >/dev/null 2>"$T/bad.err"
[ $? -eq 2 ] || fail "--checkpoint to standard output accepted"
ok "bad checkpoints refused"

# ---- events ([events]): their own CSV; a Poincare section p1 = 0 of the pendulum (turning points)
"$DTH" run "$SC/pendulum.ini" -s events.section=p1 -s events.section_direction=both -o "$T/ev/pend.csv" 2>"$T/ev.err" ||
    fail "section run: $(cat "$T/ev.err")"
[ "$(head -1 "$T/ev/pend-events.csv")" = "i,event,direction,k,t,q1,p1,wp,H,E" ] ||
    fail "events header: $(head -1 "$T/ev/pend-events.csv")"
# turning points every half period (3.35): 5 by t = 20, alternating direction, p1 = 0 to round-off
awk -F, 'NR > 1 { n++; p = $7 < 0 ? -$7 : $7; if (p > 1e-14 || $2 != "section") bad = 1
    if (NR > 2 && $3 == last) bad = 1; last = $3 } END { exit bad || n != 5 }' "$T/ev/pend-events.csv" ||
    fail "section events: $(cat "$T/ev/pend-events.csv")"
"$DTH" run "$SC/pendulum.ini" -s events.section=p1 -s events.section_direction=up -o "$T/ev/up.csv" 2>/dev/null
[ "$(awk -F, 'NR > 1 && $3 != 1' "$T/ev/up-events.csv" | wc -l)" -eq 0 ] && [ "$(wc -l <"$T/ev/up-events.csv")" -eq 4 ] ||
    fail "section_direction=up: $(cat "$T/ev/up-events.csv")"
# time events land exactly on their times; --events names the file
"$DTH" run "$SC/pendulum.ini" -s events.time=1.5,2.75 --events "$T/ev/times.csv" -o "$T/ev/t.csv" 2>/dev/null ||
    fail "time events"
[ "$(cut -d, -f5 "$T/ev/times.csv" | tr '\n' ' ')" = "t 1.5 2.75 " ] || fail "time events: $(cat "$T/ev/times.csv")"
# a terminal event ends the run there: the last trajectory row is at the event's time
"$DTH" run "$SC/pendulum.ini" -s output.points=vertices -s events.distance=0.5 -s events.distance_direction=down \
    -s events.distance_terminal=yes -o "$T/ev/term.csv" 2>"$T/ev.err" || fail "terminal event: $(cat "$T/ev.err")"
te=$(sed -n 2p "$T/ev/term-events.csv" | cut -d, -f5)
[ "$(wc -l <"$T/ev/term-events.csv")" -eq 2 ] && [ "$(tail -1 "$T/ev/term.csv" | cut -d, -f2)" = "$te" ] ||
    fail "terminal event: last row $(tail -1 "$T/ev/term.csv" | cut -d, -f2), event at $te"
grep -q "terminal event" "$T/ev.err" || fail "terminal event message: $(cat "$T/ev.err")"
# events with the trajectory on standard output need a file; bad keys name themselves
"$DTH" run "$SC/pendulum.ini" -s events.section=q1 >/dev/null 2>"$T/ev.err"
[ $? -eq 2 ] && grep -q "give the events file" "$T/ev.err" || fail "events to stdout: $(cat "$T/ev.err")"
"$DTH" run "$SC/pendulum.ini" -s events.section=q2 -o "$T/ev/x.csv" 2>"$T/ev.err"
[ $? -eq 2 ] && grep -q "events.section: 'q2': the model has 1 degree of freedom" "$T/ev.err" || fail "section q2: $(cat "$T/ev.err")"
"$DTH" run "$SC/pendulum.ini" -s events.section_value=1 -o "$T/ev/x.csv" 2>"$T/ev.err"
[ $? -eq 2 ] && grep -q "needs \[events\] section=" "$T/ev.err" || fail "orphan section_value: $(cat "$T/ev.err")"
"$DTH" run "$SC/pendulum.ini" -s events.section=p1 -o "$T/ev/same.csv" --events "$T/ev/same.csv" 2>"$T/ev.err"
[ $? -eq 2 ] && grep -q "it is the trajectory's output" "$T/ev.err" || fail "events = output: $(cat "$T/ev.err")"
# checkpoint/resume carries the events file too
resume_check events "$SC/kepler-e06.ini" "-s integrator.t_end=30" "-s integrator.t_end=11" -s events.section=q2
cmp -s "$T/events-ref-events.csv" "$T/events-res-events.csv" || fail "events: resumed events file differs"
[ "$(wc -l <"$T/events-ref-events.csv")" -ge 4 ] || fail "events: too few in the reference"
ok "events: sections, times, terminal, files, resume"

# ---- --progress: lines on stderr for a run whose stderr is not a terminal
"$DTH" run "$SC/pendulum.ini" -s integrator.steps=300000 -o "$T/prog.csv" --progress=0.1 2>"$T/prog.err" ||
    fail "--progress run"
grep -q '^dth run: t = .*steps/s.*ETA' "$T/prog.err" || fail "--progress: $(cat "$T/prog.err")"
"$DTH" run "$SC/pendulum.ini" -s integrator.steps=10 -o "$T/prog.csv" 2>"$T/prog.err" && [ ! -s "$T/prog.err" ] ||
    fail "without --progress, stderr: $(cat "$T/prog.err")"
"$DTH" run "$SC/pendulum.ini" --progress=0 2>"$T/prog.err"
[ $? -eq 2 ] || fail "--progress=0 accepted"
"$DTH" run "$SC/pendulum.ini" -s integrator.steps=10 --no-model-check >/dev/null || fail "--no-model-check"
ok "--progress, --no-model-check"

[ $fails -eq 0 ] && echo "all run checks passed"
exit $((fails != 0))
