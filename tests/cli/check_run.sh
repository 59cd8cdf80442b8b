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
"$DTH" run "$SC/pendulum.ini" -s integrator.method=rk4 -s regularize.method=smooth 2>"$T/x.err"
[ $? -eq 2 ] && grep -q "method = dth only" "$T/x.err" || fail "regularizer with a baseline: $(cat "$T/x.err")"
ok "baseline methods"

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
    -s regularize.method=smooth -s output.diagnostics=yes
# a regularizer with state of its own (a constant fixed at its first step, its solver's seed)
resume_check prescribed "$SC/pendulum-rotation-prescribed.ini" "-s integrator.t_end=30" "-s integrator.t_end=11"
resume_check prescribed_kepler "$SC/kepler-e09-prescribed.ini" "-s integrator.t_end=40" "-s integrator.t_end=13"
crossings=$(awk -F, 'NR > 1 && $NF == "reg"' "$T/reg-ref.csv" | wc -l)
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
ok "kill -9 and resume"

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

[ $fails -eq 0 ] && echo "all run checks passed"
exit $((fails != 0))
