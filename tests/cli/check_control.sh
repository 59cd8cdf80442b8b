#!/bin/sh
# SPDX-License-Identifier: MIT
# Step control by the run's constant (issue 26 items 1 and 3; control.h): integrator.h_max and
# integrator.tol on Kepler e = 0.9 from its pericentre, 10 orbits (scenes/kepler-e09-hmax.ini), the
# figures of the issue's done-when checked against the exact solution (Kepler's equation):
#  - h_max = 0.01: exit 0, every step <= 0.0105, final position error <= 1e-2, L at every vertex and
#    the energy at every midpoint constant to 1e-13 relative; the end line names the control and the
#    largest step;
#  - tol = 1e-4: the true final error within a factor 10 of 1e-4, with pilots to t_end and with a
#    pilot over one orbit (then stderr says the estimate is an extrapolation);
#  - a calibration that saw too little (pilot = 0.005) stops after the first step above 1.05 h_max:
#    exit 3, the rows kept, a message naming the fix;
#  - a checkpointed run resumed equals the run made at once (the calibrated first step is in the
#    checkpoint's scene; the resume takes no pilots);
#  - the plain h = 0.01 run warns (or stops) naming h_max and tol; what the keys refuse.
# usage: check_control.sh PATH/TO/dth SOURCE_ROOT
set -u
DTH=$1
SC=$2/scenes
T=$(mktemp -d /tmp/dth_control_test.XXXXXX)
trap 'rm -rf "$T"' EXIT
fails=0
fail() { echo "FAIL: $*" >&2; fails=$((fails + 1)); }
ok() { echo "ok: $*"; }
SCENE=$SC/kepler-e09-hmax.ini

# The figures of a Kepler e = 0.9 CSV (midpoint rows, diagnostics: columns t=2, lambda=3, q1=4, q2=5,
# E=10, L=12 (vertex rows: the same columns); orbit from the pericentre (0.1, 0), a = 1, period 2 pi): the largest step, the position
# error of the last row against Kepler's equation at its time, and the largest relative drifts of L
# (but on the last row: with vertex rows the end, by dense output at t_end) and E from the first row.
figures() {
    awk -F, 'NR == 2 { L0 = $12; E0 = $10 }
        NR > 1 { if ($3 > lm) lm = $3; dL = dLn; dl = $12 - L0; if (dl < 0) dl = -dl; if (dl > dLn) dLn = dl
                 de = $10 - E0; if (de < 0) de = -de; if (de > dE) dE = de; t = $2; x = $4; y = $5 }
        END { e = 0.9; M = t; E = M; for (i = 0; i < 100; i++) E -= (E - e * sin(E) - M) / (1 - e * cos(E))
              X = cos(E) - e; Y = sqrt(1 - e * e) * sin(E)
              printf "%.17g %.17g %.17g %.17g %d\n", lm, sqrt((x - X) ^ 2 + (y - Y) ^ 2), dL / (L0 < 0 ? -L0 : L0),
                     dE / (E0 < 0 ? -E0 : E0), NR - 1 }' "$1"
}
# awk's test of a condition over the figures: check NAME FILE 'CONDITION on lm, err, dL, dE, rows'
check() {
    f=$(figures "$2")
    echo "$f" | awk -v name="$1" '{ lm = $1; err = $2; dL = $3; dE = $4; rows = $5 }
        END { if (!('"$3"')) { printf "%s: largest step %.6g, error %.3g, dL %.2g, dE %.2g, %d rows: not %s\n", name, lm,
              err, dL, dE, rows, "'"$3"'"; exit 1 }
              printf "%s: largest step %.6g, error %.3g, dL %.2g, dE %.2g, %d rows\n", name, lm, err, dL, dE, rows }'
}

# ---- h_max = 0.01 (the scene)
"$DTH" run "$SCENE" -o "$T/hmax.csv" 2>"$T/hmax.err"
rc=$?
[ $rc -eq 0 ] || fail "h_max: exit $rc: $(cat "$T/hmax.err")"
m=$(check "h_max = 0.01" "$T/hmax.csv" 'lm <= 0.0105 && err <= 1e-2 && dE <= 1e-13 && rows > 1000') &&
    ok "$m" || fail "$m"
# L is exact at the vertices (a midpoint averages two): the same run with vertex rows
"$DTH" run "$SCENE" -s output.points=vertices -o "$T/hmaxv.csv" 2>"$T/hmaxv.err" || fail "h_max vertices: $(cat "$T/hmaxv.err")"
m=$(check "h_max = 0.01, vertex rows" "$T/hmaxv.csv" 'lm <= 0.0105 && dL <= 1e-13') && ok "$m" || fail "$m"
grep -q '^dth: integrator.h_max = 0.01: first step' "$T/hmax.err" && ok "h_max: the calibration is said" ||
    fail "h_max: no calibration line: $(cat "$T/hmax.err")"
grep -q 'largest step 0.00[0-9]* = 0.[0-9]* h_max (step control integrator.h_max = 0.01, first step' "$T/hmax.err" &&
    ok "h_max: the end line names the control and the largest step" || fail "h_max: end line: $(tail -1 "$T/hmax.err")"
grep -q 'warning' "$T/hmax.err" && fail "h_max: a warning: $(grep warning "$T/hmax.err")"
# the same with h given too (h gives the direction only) and without the scene's h_max but -s
"$DTH" run "$SC/kepler-e09.ini" -s initial.q=0.1,0 -s initial.p=0,4.358898943540674 -s integrator.t_end=62.83185307179586 \
    -s integrator.h_max=0.01 -o "$T/hmax2.csv" 2>"$T/hmax2.err" || fail "h_max by -s: $(cat "$T/hmax2.err")"
m=$(check "h_max = 0.01 by -s on kepler-e09.ini" "$T/hmax2.csv" 'lm <= 0.0105 && err <= 1e-2 && dE <= 1e-13') &&
    ok "$m" || fail "$m"

# ---- the plain run at h = 0.01: the steps run away (74 h); it must not end quietly, and names the keys
"$DTH" run "$SC/kepler-e09.ini" -s initial.q=0.1,0 -s initial.p=0,4.358898943540674 -s integrator.t_end=62.83185307179586 \
    -o "$T/h.csv" 2>"$T/h.err"
rc=$?
if [ $rc -eq 0 ]; then
    m=$(check "h = 0.01" "$T/h.csv" 'err <= 1e-2') && ok "$m" || fail "plain h = 0.01 exit 0 with $m"
fi
grep -q 'integrator.h_max=0.01' "$T/h.err" && grep -q 'integrator.tol=' "$T/h.err" &&
    ok "plain h = 0.01 (exit $rc): the warning names h_max and tol" || fail "plain h = 0.01: $(cat "$T/h.err")"

# ---- tol = 1e-4: pilots to t_end, and a pilot over the first orbit (an extrapolation, said)
"$DTH" run "$SCENE" -s integrator.h_max=0 -s integrator.tol=1e-4 -o "$T/tol.csv" 2>"$T/tol.err"
rc=$?
[ $rc -eq 0 ] || fail "tol: exit $rc: $(cat "$T/tol.err")"
m=$(check "tol = 1e-4" "$T/tol.csv" 'err >= 1e-5 && err <= 1e-3 && dE <= 1e-13') && ok "$m" || fail "$m"
grep -q '(a pilot run to t_end)' "$T/tol.err" && ok "tol: the estimate is a pilot's to t_end" ||
    fail "tol: $(cat "$T/tol.err")"
grep -q 'step control integrator.tol = 0.0001' "$T/tol.err" && ok "tol: the end line names the control" ||
    fail "tol: end line: $(tail -1 "$T/tol.err")"
"$DTH" run "$SCENE" -s integrator.h_max=0 -s integrator.tol=1e-4 -s integrator.pilot=6.283185307179586 \
    -o "$T/tolx.csv" 2>"$T/tolx.err"
rc=$?
[ $rc -eq 0 ] || fail "tol, pilot one orbit: exit $rc: $(cat "$T/tolx.err")"
m=$(check "tol = 1e-4, pilot one orbit" "$T/tolx.csv" 'err >= 1e-5 && err <= 1e-3') && ok "$m" || fail "$m"
grep -q 'is an EXTRAPOLATION' "$T/tolx.err" && ok "tol, pilot one orbit: stderr says the estimate is extrapolated" ||
    fail "tol, pilot one orbit: $(cat "$T/tolx.err")"

# ---- the guard: pilots that end before the first excursion see nothing to bind
"$DTH" run "$SCENE" -s integrator.pilot=0.005 -o "$T/guard.csv" 2>"$T/guard.err"
rc=$?
[ $rc -eq 3 ] && ok "guard: exit 3" || fail "guard: exit $rc: $(cat "$T/guard.err")"
grep -q 'exceeds 1.05 integrator.h_max = 0.0105.*fix: pilots over the whole run.*a smaller integrator.h_max' "$T/guard.err" &&
    ok "guard: the message names the fix" || fail "guard: $(cat "$T/guard.err")"
# the rows are kept, the last one the step that passed the bound
m=$(check "guard rows" "$T/guard.csv" 'lm > 0.0105 && lm < 0.02 && rows >= 2') && ok "$m" || fail "$m"

# ---- checkpoint and resume: the calibrated first step is recorded in the checkpoint's scene, and a
# resume (no pilots) continues with it: one orbit, resumed to two, equals a run to two orbits whose
# pilots ran to the same end (pilot = one orbit)
O1=6.283185307179586 O2=12.566370614359172
"$DTH" run "$SCENE" -s integrator.t_end=$O2 -s integrator.pilot=$O1 -o "$T/ref.csv" 2>"$T/ref.err" ||
    fail "resume: reference run: $(cat "$T/ref.err")"
"$DTH" run "$SCENE" -s integrator.t_end=$O1 -s integrator.pilot=$O1 -o "$T/part.csv" --checkpoint "$T/c.ckpt" \
    2>"$T/part.err" || fail "resume: first leg: $(cat "$T/part.err")"
"$DTH" run --resume "$T/c.ckpt" -s integrator.t_end=$O2 -o "$T/res.csv" 2>"$T/res.err" ||
    fail "resume: $(cat "$T/res.err")"
grep -q 'pilot run' "$T/res.err" && fail "resume: the resume ran pilots: $(cat "$T/res.err")"
cmp -s "$T/ref.csv" "$T/res.csv" && ok "resume: one orbit resumed to two equals the run to two, byte for byte" ||
    fail "resume: the resumed rows differ from the run's"

# ---- refusals (exit 2, one line naming the key)
refused() {
    "$DTH" run "$SCENE" "$@" -o "$T/bad.csv" 2>"$T/bad.err"
    rc=$?
    [ $rc -eq 2 ] && [ "$(wc -l <"$T/bad.err")" -eq 1 ] && [ ! -e "$T/bad.csv" ] && grep -q "$want" "$T/bad.err" &&
        ok "refused ($*): $(cat "$T/bad.err")" || fail "not refused as expected ($*): exit $rc: $(cat "$T/bad.err")"
}
want='integrator.h_max: .*method .rk4. takes the fixed step h' refused -s integrator.method=rk4 -s regularize.method=none
want='integrator.h_max: .*give \[integrator\] t_end= instead of steps=' refused -s integrator.steps=100
want='integrator.pilot: .*the pilots. end must lie after' refused -s integrator.pilot=100
want='integrator.pilot: .*give one of them' refused -s integrator.h_max=0 -s integrator.h=0.01 -s integrator.pilot=1
want='missing \[integrator\] h=' refused -s integrator.h_max=0
want='integrator.h_max: calibrates order 2.s step law; order 4' refused -s integrator.order=4

[ $fails -eq 0 ] && echo "all control checks passed"
exit $((fails > 0))
