#!/bin/sh
# SPDX-License-Identifier: MIT
# dth run --resume refuses what it cannot honour, and the output files and signals (issue 16):
# overrides that would change the run, a length behind the checkpoint, an output changed since the
# checkpoint, a folder as checkpoint; resume from another directory and at an arbitrary step is
# byte-identical; SIGHUP stops like SIGTERM; stop requests reach the dense-output loop; output
# times far denser than the steps are refused; temporaries of dead runs are removed, a running
# one's are not; two runs may share a checkpoint path; a write error names its real reason; bad
# inputs (a time steps cannot advance, counts too large, singular starts, a step too large) are
# refused naming the key; crafted checkpoints with a valid checksum are refused naming the field.
# usage: check_resume.sh PATH/TO/dth SOURCE_ROOT
set -u
DTH=$(cd "$(dirname "$1")" && pwd)/$(basename "$1") # absolute: one check runs from another folder
SC=$2/scenes
ROOT=$2
T=$(mktemp -d /tmp/dth_resume_test.XXXXXX)
trap 'rm -rf "$T"' EXIT
fails=0
fail() { echo "FAIL: $*" >&2; fails=$((fails + 1)); }
ok() { echo "ok: $*"; }
# expect CODE WANT_IN_MESSAGE ARGS...: exit code, one line on stderr containing the text
expect() {
    code=$1 want=$2
    shift 2
    "$@" >/dev/null 2>"$T/e"
    rc=$?
    [ $rc -eq "$code" ] || fail "$*: exit $rc, want $code ($(cat "$T/e"))"
    [ "$(wc -l <"$T/e")" -eq 1 ] || fail "$*: not one line: $(cat "$T/e")"
    grep -q -- "$want" "$T/e" || fail "$*: message lacks '$want': $(cat "$T/e")"
}

P="$SC/pendulum.ini"
"$DTH" run "$P" -s integrator.steps=300 -o "$T/ref.csv" 2>/dev/null || fail "reference run"
"$DTH" run "$P" -s integrator.steps=120 -o "$T/part.csv" --checkpoint "$T/c.ckpt" --checkpoint-every 37 2>/dev/null ||
    fail "checkpointed run"

# ---- what a resume may not change: one line each, exit 2, no output written
for s in model.omega2=2 output.diagnostics=yes integrator.h=0.1 initial.q=0.3 regularize.method=prescribed \
         output.dt=0.1 integrator.branch_check=no; do
    expect 2 "-s $s: .* would change the checkpointed run" "$DTH" run --resume "$T/c.ckpt" -s "$s" -o "$T/x.csv"
    [ -e "$T/x.csv" ] && fail "-s $s: an output was written"
done
expect 2 "integrator.steps = 100 lies behind the checkpoint" "$DTH" run --resume "$T/c.ckpt" -s integrator.steps=100 -o "$T/x.csv"
expect 2 "integrator.t_end = 1 lies behind" "$DTH" run --resume "$T/c.ckpt" -s integrator.t_end=1 -o "$T/x.csv"
expect 2 "Is a directory" "$DTH" run --resume "$T" -o "$T/x.csv"
ok "a resume refuses overrides that change the run and a length behind the checkpoint"

# ---- resumed from another directory (the checkpoint records absolute paths), to a new name
mkdir "$T/elsewhere"
(cd "$T/elsewhere" && "$DTH" run --resume ../c.ckpt -s integrator.steps=300 -o moved.csv 2>"$T/moved.err") ||
    fail "resume from another directory: $(cat "$T/moved.err")"
cmp -s "$T/ref.csv" "$T/elsewhere/moved.csv" || fail "resume from another directory differs"
# ... and the output changed since the checkpoint (another scene's longer CSV in its place): refused
"$DTH" run "$P" -s integrator.steps=500 -s output.diagnostics=yes -o "$T/part.csv" 2>/dev/null
expect 2 "was changed since the checkpoint" "$DTH" run --resume "$T/c.ckpt" -s integrator.steps=300 -o "$T/y.csv"
[ -e "$T/y.csv" ] && fail "changed output: an output was written"
ok "resume from another directory; an output changed since the checkpoint is refused"

# ---- crafted checkpoints that pass the checksum (issue 24, tests/cli/ckpt_patch.py recomputes it):
# each was resumed with exit 0 and output that differed from the straight run; now refused (exit 2),
# the message naming the field, no output written
if command -v python3 >/dev/null 2>&1; then
    "$DTH" run "$P" -s integrator.steps=120 -o "$T/cr.csv" --checkpoint "$T/cr.ckpt" --checkpoint-every 37 \
        2>/dev/null || fail "checkpointed run for the crafted checkpoints"
    crafted() { # crafted WANT [patch args ;]...: the patches applied to a copy of cr.ckpt
        want=$1
        shift
        cp "$T/cr.ckpt" "$T/bad.ckpt"
        while [ $# -gt 0 ]; do
            args=""
            while [ $# -gt 0 ] && [ "$1" != ";" ]; do args="$args $1"; shift; done
            [ $# -gt 0 ] && shift
            # shellcheck disable=SC2086
            python3 "$ROOT/tests/cli/ckpt_patch.py" "$T/bad.ckpt" $args || fail "ckpt_patch.py$args"
        done
        rm -f "$T/x.csv"
        expect 2 "$want" "$DTH" run --resume "$T/bad.ckpt" -s integrator.steps=300 -o "$T/x.csv"
        [ -e "$T/x.csv" ] && fail "crafted ($want): an output was written"
    }
    cp "$T/cr.ckpt" "$T/same.ckpt"
    python3 "$ROOT/tests/cli/ckpt_patch.py" "$T/same.ckpt" state steps 120 || fail "ckpt_patch.py: same value"
    cmp -s "$T/cr.ckpt" "$T/same.ckpt" || fail "ckpt_patch.py rewrites an unchanged checkpoint differently"
    crafted "field 'steps' holds 9223372036854775807" state steps 9223372036854775807
    crafted "field 'samples' holds 9223372036854775807" run samples 9223372036854775807
    crafted "field 'out.bytes' counts 0 bytes of .*, fewer than its header line" cli out.bytes 0 ";" cli out.hash 14695981039346656037
    crafted "'lam_hint' = .* points against field 'dir' = -1" state dir -1.0
    crafted "field 'lam' = 0 is no step" state lam 0.0
    crafted "field 'nhist' = 3 exceeds field 'steps' = 2" state steps 2
    crafted "field 'lam_hint' holds inf" state lam_hint inf # (1e308 is a step: the integrator takes any finite h)
    crafted "field 'pending_exact' = 1" state pending_exact 1
    crafted "field 't_stop' = 1e+308 lies outside the run's span" run t_stop 1e308
    crafted "field 't_stop' = -1e+308 lies outside the run's span" run t_stop -1e308
    crafted "does not begin with the header line this scene writes" scene output.diagnostics=yes
    ok "crafted checkpoints with a valid checksum are refused naming the field"
else
    echo "skip: crafted checkpoints (no python3)"
fi

# ---- the issue's reproduction: a rotating pendulum through psi = 0 (regularized), stopped at
# step 2278 and resumed to 2400, against the straight run
R="$SC/pendulum-rotation.ini"
"$DTH" run "$R" -s integrator.steps=2400 -s output.diagnostics=yes -o "$T/rot.csv" 2>"$T/rot.err"
"$DTH" run "$R" -s integrator.steps=2278 -s output.diagnostics=yes -o "$T/rotp.csv" --checkpoint "$T/rot.ckpt" 2>/dev/null
"$DTH" run --resume "$T/rot.ckpt" -s integrator.steps=2400 --checkpoint "$T/rot.ckpt" 2>/dev/null ||
    fail "rotation: resume"
cmp -s "$T/rot.csv" "$T/rotp.csv" || fail "rotation: resumed at 2278 differs from the straight run"
ok "rotating pendulum resumed at step 2278: byte-identical"
# and at the vertices around one of land's crossings past 2000 (the row with ordinary = 0 is the
# replaced step): the one before, the one it lands on (its offset reset), the one after
col=$(head -n 1 "$T/rot.csv" | tr ',' '\n' | grep -n '^ordinary$' | cut -d: -f1)
[ -n "$col" ] || fail "rotation: no column 'ordinary'"
kc=$(awk -F, -v c="$col" 'NR > 1 && $c == 0 && $1 > 2000 { print $1; exit }' "$T/rot.csv")
[ -n "$kc" ] || fail "rotation: no replaced (crossing) step past 2000"
for k in $((kc - 1)) "$kc" $((kc + 1)); do
    "$DTH" run "$R" -s integrator.steps="$k" -s output.diagnostics=yes -o "$T/rotc.csv" --checkpoint "$T/rotc.ckpt" \
        2>/dev/null || fail "rotation: run to $k"
    "$DTH" run --resume "$T/rotc.ckpt" -s integrator.steps=2400 2>"$T/rotc.err" || fail "rotation: resume at $k"
    cmp -s "$T/rot.csv" "$T/rotc.csv" || fail "rotation: resumed at vertex $k (crossing step $kc) differs"
    # the end line too: the counts and the error estimate continue (the estimate's shadow is restored)
    [ "$(sed 's/ rows to [^;]*;/;/' "$T/rot.err")" = "$(sed 's/ rows to [^;]*;/;/' "$T/rotc.err")" ] ||
        fail "rotation: resumed at vertex $k, the end line differs: $(cat "$T/rotc.err") against $(cat "$T/rot.err")"
done
ok "rotating pendulum resumed at vertices $((kc - 1)), $kc, $((kc + 1)) around a crossing: byte-identical, same end line"

# ---- signals: SIGHUP like SIGTERM (exit 129, rows kept); a stop request inside the dense output
"$DTH" run "$P" -s integrator.t_end=1e7 -o "$T/hup.csv" 2>"$T/hup.err" &
pid=$!
sleep 1
kill -HUP $pid
wait $pid
rc=$?
[ $rc -eq 129 ] || fail "SIGHUP: exit $rc, want 129"
grep -q '^dth: interrupted at k=' "$T/hup.err" || fail "SIGHUP message: $(cat "$T/hup.err")"
[ -s "$T/hup.csv" ] || fail "SIGHUP: no file"
ls "$T" | grep -q '^hup\.csv\.tmp' && fail "SIGHUP: a temporary file is left"
# with --checkpoint the message says how to continue (issue 25), and that continues it
"$DTH" run "$P" -s integrator.steps=100000000 -o "$T/int.csv" --checkpoint "$T/int.ckpt" 2>"$T/int.err" &
pid=$!
sleep 1
kill -INT $pid
wait $pid
rc=$?
[ $rc -eq 130 ] || fail "SIGINT with --checkpoint: exit $rc, want 130"
k=$(sed -n "s/.*; to continue: dth run --resume .*int\.ckpt (its checkpoint of step \([0-9]*\))$/\1/p" "$T/int.err")
[ -n "$k" ] || fail "SIGINT with --checkpoint: no resume advice: $(cat "$T/int.err")"
"$DTH" run --resume "$T/int.ckpt" -s integrator.steps=$((k + 10)) 2>"$T/int2.err" >/dev/null &&
    [ "$(tail -1 "$T/int.csv" | cut -d, -f1)" -ge $((k - 1)) ] || fail "the advised resume: $(cat "$T/int2.err")"
# 5e5 rows per step: the request is seen between rows, not after the step
"$DTH" run "$P" -s integrator.t_end=1e5 -s output.dt=1e-7 -o "$T/dense.csv" 2>"$T/dense.err" &
pid=$!
sleep 1
start=$(date +%s)
kill -TERM $pid
wait $pid
rc=$?
[ $rc -eq 143 ] || fail "dense SIGTERM: exit $rc, want 143"
[ $(( $(date +%s) - start )) -le 2 ] || fail "dense SIGTERM: took more than 2 s to stop"
rm -f "$T/dense.csv"
expect 2 "output.dt: 1e-12 asks for 5e+10 rows per step" "$DTH" run "$P" -s output.dt=1e-12 -o "$T/x.csv"
ok "SIGHUP; stop requests inside the dense output; output times bounded per step"

# ---- temporaries: a dead run's are removed (and said), a running process's and other files stay
: >"$T/s.csv.tmp.999999.AbCdEf"   # no such process
: >"$T/s.csv.tmp.999998"          # the form before unique temporaries
: >"$T/s.csv.tmp.$$.XyZxyZ"       # this shell: running
: >"$T/s.csv.keep"
"$DTH" run "$P" -s integrator.steps=10 -o "$T/s.csv" 2>"$T/s.err" || fail "stale temporaries: run"
grep -q "removed 2 temporaries of '$T/s.csv'" "$T/s.err" || fail "stale temporaries: message $(cat "$T/s.err")"
[ -e "$T/s.csv.tmp.999999.AbCdEf" ] && fail "a dead run's temporary stays"
[ -e "$T/s.csv.tmp.999998" ] && fail "a dead run's old-style temporary stays"
[ -e "$T/s.csv.tmp.$$.XyZxyZ" ] || fail "a running process's temporary was removed"
[ -e "$T/s.csv.keep" ] || fail "another file was removed"
# two runs writing one checkpoint path at once (their temporaries are their own)
"$DTH" run "$P" -s integrator.steps=20000 -o "$T/a1.csv" --checkpoint "$T/shared.ckpt" --checkpoint-every 50 2>"$T/a1.err" &
p1=$!
"$DTH" run "$P" -s integrator.steps=20000 -o "$T/a2.csv" --checkpoint "$T/shared.ckpt" --checkpoint-every 50 2>"$T/a2.err"
rc2=$?
wait $p1
rc1=$?
[ $rc1 -eq 0 ] && [ $rc2 -eq 0 ] || fail "two runs sharing a checkpoint path: exit $rc1, $rc2 ($(cat "$T/a1.err" "$T/a2.err"))"
ls "$T" | grep -q '^shared\.ckpt\.tmp' && fail "shared checkpoint path: a temporary is left"
# a killed run's checkpoint temporary (killed while writing it) is removed by a successful resume,
# with or without --checkpoint of its own (issue 24: it survived)
"$DTH" run "$P" -s integrator.steps=100 -o "$T/k.csv" --checkpoint "$T/k.ckpt" --checkpoint-every 30 2>/dev/null ||
    fail "checkpointed run for the stale checkpoint temporary"
for ck in "" "--checkpoint $T/k2.ckpt"; do
    : >"$T/k.ckpt.tmp.999997.QwErTy"   # no such process
    "$DTH" run --resume "$T/k.ckpt" -s integrator.steps=150 -o "$T/k-res.csv" $ck 2>"$T/k.err" || fail "resume: $(cat "$T/k.err")"
    [ -e "$T/k.ckpt.tmp.999997.QwErTy" ] && fail "resume ${ck:-without --checkpoint}: the killed run's checkpoint temporary stays"
    grep -q "removed 1 temporary of '$T/k.ckpt'" "$T/k.err" || fail "resume ${ck:-without --checkpoint}: $(cat "$T/k.err")"
done
ok "temporaries: a dead run's removed, a running one's kept; a shared checkpoint path; a resumed checkpoint's"

# ---- inputs refused up front, naming the key (exit 2), or the first step's failure naming h (exit 3)
expect 2 "initial.t: the time t = 1.0000000000000001e+300 does not advance" "$DTH" run "$P" -s initial.t=1e300 -s integrator.steps=3
expect 2 "integrator.t_end: t_end = 1.0000000000000001e+300 cannot be reached" "$DTH" run "$P" -s integrator.t_end=1e300 -s integrator.h=1e-300
expect 2 "integrator.steps: '1e20' is too large" "$DTH" run "$P" -s integrator.steps=1e20
expect 2 "initial.q: the model 'kepler' cannot start here (initial.q, initial.p): the centre r = 0 is singular (q1 = 0, q2 = 0)" \
    "$DTH" run "$SC/kepler-e09.ini" -s initial.q=0,0
expect 2 "initial.q: .* particles 1 and 2 are at the same point" "$DTH" run "$SC/coupled-chain3-prescribed.ini" -s initial.q=0,0,0,0,1,0
expect 2 "integrator.h = 1e+300 may be too large for this model" "$DTH" run "$P" -s integrator.h=1e300 -s integrator.steps=3
expect 3 "the first step failed: a smaller step may pass: -s integrator.h=25" "$DTH" run "$P" -s integrator.h=100 -s integrator.steps=3
ok "inputs refused up front with the key named; a failed first step names h"

# ---- a write error names its reason (it said 'Success' when a checkpoint write had failed)
if [ -w /dev/full ]; then
    expect 1 "cannot write '/dev/full': No space left on device" "$DTH" run "$P" -s integrator.steps=100000 -o /dev/full
    ok "a write error names its reason"
fi

[ $fails -eq 0 ] || { echo "$fails failure(s)" >&2; exit 1; }
echo "all resume checks passed"
