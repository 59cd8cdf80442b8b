#!/bin/sh
# SPDX-License-Identifier: MIT
# The DTH method of order 4 from the CLI (issue 22): the scene keys integrator.order and table; the
# crossing scenes (rotating pendulum, Kepler e = 0.9) run to their ends under the default regularizer;
# order 6 and midpoint rows are refused naming the line; none ends the run at the first crossing,
# prescribed and land's parameters are refused; a run carried by the band with an orbit-sized error
# stops with exit 3; a checkpointed run resumed to a later t_end
# gives the rows of a run made at once (the cut segment rebuilt from the vertex before: order 4 has
# no midpoint), times and events on the quintic dense output; dth sweep takes the order as a key.
# usage: check_order4.sh PATH/TO/dth SOURCE_ROOT
set -u
DTH=$1
SC=$2/scenes
T=$(mktemp -d /tmp/dth_order4_test.XXXXXX)
trap 'rm -rf "$T"' EXIT
fails=0
fail() { echo "FAIL: $*" >&2; fails=$((fails + 1)); }
ok() { echo "ok: $*"; }

# ---- the crossing scenes run to their ends, every crossing carried by the band
for s in pendulum-rotation kepler-e09; do
    "$DTH" run "$SC/$s.ini" -s integrator.order=4 -s output.diagnostics=no -o "$T/$s.csv" 2>"$T/$s.err" ||
        fail "$s with order 4: exit $? ($(cat "$T/$s.err"))"
    grep -q "psi = 0 crossings" "$T/$s.err" || fail "$s: no crossings reported: $(cat "$T/$s.err")"
    last=$(tail -n 1 "$T/$s.csv" | cut -d, -f2)
    want=$(sed -n 's/^t_end *= *\([0-9.]*\).*/\1/p' "$SC/$s.ini")
    [ "$(awk -v a="$last" -v b="$want" 'BEGIN { print (a == b) }')" = 1 ] || fail "$s: ends at t = $last, not $want"
done
ok "the rotating pendulum and Kepler e = 0.9 run to their ends with order 4"

# ---- refusals name the line
"$DTH" run "$SC/pendulum.ini" -s integrator.order=6 >/dev/null 2>"$T/e" && fail "order 6 accepted"
grep -q "integrator.order: order = 6: not offered.*order = 4" "$T/e" || fail "order 6 message: $(cat "$T/e")"
"$DTH" run "$SC/pendulum.ini" -s integrator.order=4 -s output.points=midpoints >/dev/null 2>"$T/e" &&
    fail "midpoints accepted for order 4"
grep -q "midpoints exist for order 2 only" "$T/e" || fail "midpoints message: $(cat "$T/e")"
"$DTH" run "$SC/pendulum.ini" -s integrator.table=yoshida4 >/dev/null 2>"$T/e" && fail "a table for order 2 accepted"
grep -q "table applies to order = 4 only" "$T/e" || fail "table message: $(cat "$T/e")"
"$DTH" run "$SC/pendulum.ini" -s integrator.order=4 -s integrator.table=nope >/dev/null 2>"$T/e" && fail "table nope accepted"
grep -q "integrator.table: 'nope' is not one of suzuki4, yoshida4" "$T/e" || fail "table nope message: $(cat "$T/e")"
ok "order 6, midpoints with order 4 and unknown tables are refused naming the key"

# ---- the regularizer: land (the default) carries crossings by the band, none ends the run at the first
# crossing, prescribed and land's own parameters are refused naming the line
P="$SC/pendulum-rotation.ini"
"$DTH" run "$P" -s integrator.order=4 -s output.diagnostics=no -o "$T/band.csv" 2>"$T/e" || fail "band run: $(cat "$T/e")"
grep -q "psi = 0 crossings, [0-9]* band steps ([1-9][0-9]* band exits)" "$T/e" || fail "band end line: $(cat "$T/e")"
grep -q "regularized" "$T/e" && fail "order 4's end line speaks of regularized steps: $(cat "$T/e")"
"$DTH" run "$P" -s integrator.order=4 -s regularize.method=none -o "$T/none.csv" 2>"$T/e"
rc=$?
[ $rc -eq 3 ] || fail "order 4 with regularize.method=none: exit $rc, not 3 ($(cat "$T/e"))"
"$DTH" run "$P" -s integrator.order=4 -s regularize.method=prescribed >/dev/null 2>"$T/e" && fail "prescribed accepted"
grep -q "regularize.method: order = 4 with regularizer 'prescribed': not supported" "$T/e" ||
    fail "prescribed message: $(cat "$T/e")"
"$DTH" run "$P" -s integrator.order=4 -s regularize.kappa=0.02 >/dev/null 2>"$T/e" && fail "land's kappa accepted"
grep -q "regularize.kappa: the parameters of regularizer 'land' apply to order 2" "$T/e" ||
    fail "kappa message: $(cat "$T/e")"
ok "order 4 takes land (its band) and none; prescribed and land's parameters are refused naming the line"

# ---- the stop rule: Kepler e = 0.9 from its pericentre at h = 0.01 is carried by the band with steps near h
# and an orbit-sized error: exit 3 naming the band (order 2 stops there too, on run-away steps)
"$DTH" run "$SC/kepler-e09.ini" -s initial.q=0.1,0 -s initial.p=0,4.358898943540674 -s integrator.t_end=62.83 \
    -s integrator.order=4 -s output.diagnostics=no -o "$T/peri.csv" 2>"$T/e"
rc=$?
[ $rc -eq 3 ] || fail "Kepler e = 0.9 from pericentre, order 4, h = 0.01: exit $rc, not 3 ($(cat "$T/e"))"
grep -q "steps were order 4's band steps around psi = 0 (prescribed, not solved for)" "$T/e" ||
    fail "band stop message: $(cat "$T/e")"
ok "a run carried by the band with an orbit-sized error stops (exit 3)"
# Kepler e = 0.6 from its pericentre: steps up to 21.8 h at the apocentre, below order 4's bound 16^(3/2) h
"$DTH" run "$SC/kepler-e06.ini" -s integrator.order=4 -o "$T/e06.csv" 2>"$T/e" || fail "Kepler e = 0.6 with order 4: $(cat "$T/e")"
[ -s "$T/e" ] && fail "Kepler e = 0.6 with order 4 warns: $(cat "$T/e")"
"$DTH" run "$SC/kepler-e09.ini" -s initial.q=0.1,0 -s initial.p=0,4.358898943540674 -s integrator.t_end=62.83 \
    -s integrator.order=4 -s integrator.h=0.003 -s output.diagnostics=no -o "$T/peri.csv" 2>"$T/e"
rc=$?
[ $rc -eq 3 ] || fail "Kepler e = 0.9 from pericentre, order 4, h = 0.003: exit $rc, not 3 ($(cat "$T/e"))"
grep -q "more than integrator.warn_ratio^(3/2) for order 4 = 64 h" "$T/e" || fail "order 4's warning: $(cat "$T/e")"
ok "order 4's steps count as run away beyond warn_ratio^(3/2) h"

# ---- resume: rows of the cut segment (output times) from the vertex before, as a run made at once
K="$SC/kepler-e06.ini"
"$DTH" run "$K" -s integrator.order=4 -s integrator.t_end=20 -s output.dt=0.1 -s output.diagnostics=no \
    -o "$T/once.csv" 2>/dev/null || fail "order 4 run to t = 20"
"$DTH" run "$K" -s integrator.order=4 -s integrator.t_end=7.05 -s output.dt=0.1 -s output.diagnostics=no \
    -o "$T/part.csv" --checkpoint "$T/c.ckpt" 2>/dev/null || fail "order 4 run to t = 7.05"
"$DTH" run --resume "$T/c.ckpt" -s integrator.t_end=20 -o "$T/part.csv" 2>"$T/e" || fail "resume: $(cat "$T/e")"
[ "$(wc -l <"$T/once.csv")" -eq "$(wc -l <"$T/part.csv")" ] || fail "resumed rows: $(wc -l <"$T/part.csv"), at once $(wc -l <"$T/once.csv")"
# the same times; states within round-off of the run made at once
paste -d, "$T/once.csv" "$T/part.csv" | awk -F, -v n="$(head -1 "$T/once.csv" | awk -F, '{ print NF }')" '
    NR > 1 { for (j = 2; j <= n; j++) { d = $j - $(j + n); if (d < 0) d = -d; if (d > 1e-12) bad++ } }
    END { exit bad > 0 }' || fail "resumed rows differ from the run made at once beyond 1e-12"
ok "a resumed order-4 run (t_end cut a segment) gives the rows of a run made at once"

# ---- dth sweep over the order key
"$DTH" sweep "$K" --vary integrator.h=0.02:0.01:2 -s integrator.order=4 -s integrator.t_end=10 -o "$T/sw.csv" 2>/dev/null ||
    fail "sweep with order 4"
[ "$(grep -c ',ok,' "$T/sw.csv")" -eq 2 ] || fail "sweep rows: $(cat "$T/sw.csv")"
ok "dth sweep takes integrator.order = 4"

[ $fails -eq 0 ] && echo "all order-4 CLI checks passed"
exit $fails
