#!/bin/sh
# SPDX-License-Identifier: MIT
# Reversibility stated per run (issue 23 item 4): dth run's end line says how many steps are not their own
# reverse (or that the run is exactly reversible), --roundtrip and integrator.reversible = yes warn on
# stderr when such a step was taken, and the diagnostics' `reversible` column marks each step; a resumed run
# reports the whole run. prescribed with integrator.reversible = yes retraces >= 100 crossings: the
# rotating pendulum exactly, Kepler e = 0.9 to within 1e-13 (the midpoint start's exact first step is the
# integrator's, not a segment of the step law: about an ulp; every later vertex bit for bit).
# usage: check_reversible.sh PATH/TO/dth SOURCE_ROOT
set -u
DTH=$1
SC=$2/scenes
T=$(mktemp -d /tmp/dth_rev_test.XXXXXX)
trap 'rm -rf "$T"' EXIT
fails=0
fail() { echo "FAIL: $*" >&2; fails=$((fails + 1)); }
ok() { echo "ok: $*"; }
# the relative distance of a round trip, from its stderr line
rel() { sed -n 's/.*round trip of .*(relative \([^)]*\)).*/\1/p' "$1"; }
# the forward crossings: the end line counts both legs
crossings() { sed -n 's/.*; \([0-9]*\) psi = 0 crossings*.*/\1/p' "$1"; }

# ---- prescribed, integrator.reversible = yes: >= 100 crossings there and back, no warning
for c in "pendulum-rotation-prescribed 220 0" "kepler-e09-prescribed 163.4 1e-13"; do
    set -- $c
    "$DTH" run "$SC/$1.ini" -s integrator.t_end=$2 -s integrator.reversible=yes --roundtrip -o "$T/p.csv" 2>"$T/p.err" ||
        fail "$1: $(cat "$T/p.err")"
    r=$(rel "$T/p.err")
    x=$(crossings "$T/p.err")
    awk -v r="$r" -v b=$3 -v x="$x" 'BEGIN { exit !(r != "" && r + 0 <= b && x >= 200) }' &&
        ok "$1 reversible: round trip $r (bound $3) through $x crossings (both legs)" ||
        fail "$1 reversible: round trip '$r' (bound $3), $x crossings: $(cat "$T/p.err")"
    grep -q '; 0 non-reversible steps: exactly reversible' "$T/p.err" || fail "$1 end line: $(cat "$T/p.err")"
    grep -q 'warning' "$T/p.err" && fail "$1: a warning: $(cat "$T/p.err")"
done
# the compensated finish: to round-off, and the end line says so
"$DTH" run "$SC/pendulum-rotation-prescribed.ini" -s integrator.t_end=220 --roundtrip -o "$T/p.csv" 2>"$T/p.err" ||
    fail "prescribed compensated: $(cat "$T/p.err")"
awk -v r="$(rel "$T/p.err")" 'BEGIN { exit !(r != "" && r + 0 <= 1e-10) }' || fail "prescribed compensated: $(cat "$T/p.err")"
grep -q '; 0 non-reversible steps: reversible to round-off' "$T/p.err" && ! grep -q warning "$T/p.err" &&
    ok "prescribed compensated: round trip $(rel "$T/p.err"), reversible to round-off" ||
    fail "prescribed compensated end line: $(cat "$T/p.err")"

# ---- land: its reset and clock-corrected steps are counted, and --roundtrip and reversible = yes warn
for opt in "--roundtrip" "-s integrator.reversible=yes" "--roundtrip -s integrator.reversible=yes"; do
    # shellcheck disable=SC2086
    "$DTH" run "$SC/pendulum-rotation.ini" $opt -o "$T/l.csv" 2>"$T/l.err" || fail "land $opt: $(cat "$T/l.err")"
    grep -q "warning: [0-9]* of the [0-9]* steps are not reversible (regularizer 'land'" "$T/l.err" ||
        fail "land $opt: no warning: $(cat "$T/l.err")"
    grep -q '; [1-9][0-9]* non-reversible steps;' "$T/l.err" || fail "land $opt: end line: $(cat "$T/l.err")"
done
[ $fails -eq 0 ] && ok "land: counted, and warned about under --roundtrip and reversible = yes"
# without either, no warning, but the end line counts them
"$DTH" run "$SC/pendulum-rotation.ini" -o "$T/l.csv" 2>"$T/l.err" || fail "land: $(cat "$T/l.err")"
grep -q 'not reversible' "$T/l.err" && fail "land without --roundtrip: a warning: $(cat "$T/l.err")"
grep -q '; [1-9][0-9]* non-reversible steps;' "$T/l.err" || fail "land end line: $(cat "$T/l.err")"

# order 4: its band exits are counted, and the warning names them (prescribed is refused there)
"$DTH" run "$SC/pendulum-rotation.ini" -s integrator.order=4 --roundtrip -o "$T/o.csv" 2>"$T/o.err" ||
    fail "order 4: $(cat "$T/o.err")"
grep -q "steps are not reversible (order 4's crossing band left there by a projection)" "$T/o.err" &&
    grep -q '; [1-9][0-9]* non-reversible steps;' "$T/o.err" && ok "order 4: band exits counted and warned" ||
    fail "order 4 warning: $(cat "$T/o.err")"
"$DTH" run "$SC/pendulum.ini" -s integrator.order=4 -s integrator.reversible=yes -o "$T/o.csv" 2>"$T/o.err" ||
    fail "order 4 reversible: $(cat "$T/o.err")"
grep -q 'exactly reversible' "$T/o.err" && fail "order 4 claims exact reversibility: $(cat "$T/o.err")"

# ---- the diagnostics column: 0 exactly on the counted steps (a row per vertex: the step that arrived)
"$DTH" run "$SC/pendulum-rotation.ini" -s output.points=vertices -s output.diagnostics=yes -o "$T/d.csv" 2>"$T/d.err" ||
    fail "diagnostics run: $(cat "$T/d.err")"
n=$(sed -n 's/.*; \([0-9]*\) non-reversible steps*;.*/\1/p' "$T/d.err")
awk -F, -v n="$n" 'NR == 1 { for (i = 1; i <= NF; i++) if ($i == "reversible") c = i; if (!c) exit 1; next }
    $c != 0 && $c != 1 { exit 1 } $c == 0 { z++ } END { exit !(c && z == n && n > 0) }' "$T/d.csv" &&
    ok "reversible column: $n rows of 0, as the end line counts" || fail "reversible column against the end line's $n"
# the reset steps are regularized (ordinary = 0) and not reversible; reversible = 1 where ordinary = 1 and
# no clock correction: at least the rows far from crossings
awk -F, 'NR == 1 { for (i = 1; i <= NF; i++) { if ($i == "reversible") c = i; if ($i == "ordinary") o = i } next }
    $o == 0 && $c != 0 { bad = 1 } $c == 1 { one++ } END { exit bad || one < 10 }' "$T/d.csv" ||
    fail "reversible column against ordinary"

# ---- a resumed run reports the whole run's count
"$DTH" run "$SC/pendulum-rotation.ini" -s integrator.steps=120 -o "$T/a.csv" 2>"$T/a.err" || fail "straight run"
"$DTH" run "$SC/pendulum-rotation.ini" -s integrator.steps=60 -o "$T/b.csv" --checkpoint "$T/b.ckpt" 2>"$T/b1.err" ||
    fail "first half: $(cat "$T/b1.err")"
"$DTH" run --resume "$T/b.ckpt" -s integrator.steps=120 -o "$T/b.csv" 2>"$T/b.err" || fail "resume: $(cat "$T/b.err")"
na=$(sed -n 's/.*; \([0-9]*\) non-reversible steps*;.*/\1/p' "$T/a.err")
nb=$(sed -n 's/.*; \([0-9]*\) non-reversible steps*;.*/\1/p' "$T/b.err")
[ -n "$na" ] && [ "$na" = "$nb" ] && [ "$na" -gt 0 ] && ok "resumed run: $nb non-reversible steps, as the straight run" ||
    fail "resumed run counts '$nb', the straight run '$na'"

# ---- prescribed's fallback (no kicked segment on the 2-D oscillator: both energies are quadratic
# invariants): the kept ordinary steps are counted, and reversible = yes warns naming fallback
"$DTH" run "$SC/harmonic.ini" -s regularize.method=prescribed -s integrator.reversible=yes -o "$T/h.csv" 2>"$T/h.err" ||
    fail "harmonic prescribed: $(cat "$T/h.err")"
grep -q "steps are ordinary steps that regularizer 'prescribed' kept where it found no segment of its own (fallback = yes)" \
    "$T/h.err" && grep -q '; [1-9][0-9]* non-reversible steps;' "$T/h.err" && ok "prescribed fallback counted and warned" ||
    fail "prescribed fallback: $(cat "$T/h.err")"

[ $fails -eq 0 ] || { echo "$fails failure(s)" >&2; exit 1; }
echo "all reversibility checks passed"
