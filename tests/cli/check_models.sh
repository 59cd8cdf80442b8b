#!/bin/sh
# SPDX-License-Identifier: MIT
# Misbehaving user models (tests/cli/bad_models.c, loaded with --model-lib) in dth sweep and dth run:
# never a crash; a derivative check that cannot run is a failure; a trajectory the model fails in
# is a row of the summary, the others are kept; a model without an instance, or with an invariant
# without a name, is refused naming the fault.
# Also the Henon-Heiles example plugin in dth run (issue 25): --model-lib in both commands, a file
# name without a slash found in the working folder.
# usage: check_models.sh PATH/TO/dth SOURCE_ROOT BAD_MODELS.so HH_PLUGIN.so
set -u
DTH=$(cd "$(dirname "$1")" && pwd)/$(basename "$1") # absolute: some checks run in the plugin's folder
ROOT=$2
BM=$3
HH=$4
T=$(mktemp -d /tmp/dth_models_test.XXXXXX)
trap 'rm -rf "$T"' EXIT
fails=0
fail() { echo "FAIL: $*" >&2; fails=$((fails + 1)); }
ok() { echo "ok: $*"; }
printf '[model]\nname = hard-fail\n[initial]\nq = 1\np = 0\n[integrator]\nh = 0.1\nsteps = 20\n' >"$T/osc.ini"

# ---- the derivative check cannot run (the model's third derivative fails): a failure, no summary
"$DTH" sweep "$T/osc.ini" --model-lib "$BM:test_third_fail" -s model.name=third-fail --vary initial.q=0.5:2:3 \
    -o "$T/third.csv" 2>"$T/third.err"
rc=$?
[ $rc -eq 1 ] || fail "sweep, check cannot run: exit $rc, want 1: $(cat "$T/third.err")"
grep -q "model 'third-fail': its derivative check cannot run at run 0's initial state: a model callback reported an error" \
    "$T/third.err" || fail "sweep, check cannot run: $(cat "$T/third.err")"
[ -e "$T/third.csv" ] && fail "sweep, check cannot run: a summary was written"
ok "a derivative check that cannot run fails the sweep"

# ---- run 0 cannot start (q = 2 beyond the model's qmax = 1.5: it fails hard there): its row says so,
# the other runs are in the summary, exit 2
"$DTH" sweep "$T/osc.ini" --model-lib "$BM:test_hard_fail" -s model.qmax=1.5 --vary initial.q=2:0.5:3 \
    -o "$T/hard0.csv" 2>"$T/hard0.err"
rc=$?
[ $rc -eq 2 ] || fail "sweep, run 0 cannot start: exit $rc, want 2: $(cat "$T/hard0.err")"
[ "$(cut -d, -f1-3 "$T/hard0.csv" | tr '\n' ' ')" = "run,initial.q,status 0,2,DTH_EINVAL 1,1.25,ok 2,0.5,ok " ] ||
    fail "sweep, run 0 cannot start: summary $(cat "$T/hard0.csv")"
grep -q "^dth: run 0 could not start: .*initial.q: the model 'hard-fail' cannot start here" "$T/hard0.err" ||
    fail "sweep, run 0 cannot start: $(cat "$T/hard0.err")"
# a bad key is still refused before any run (every run fails alike)
"$DTH" sweep "$T/osc.ini" --model-lib "$BM:test_hard_fail" -s model.qmx=1 --vary initial.q=2:0.5:3 -o "$T/key.csv" \
    2>"$T/key.err"
[ $? -eq 2 ] && [ ! -e "$T/key.csv" ] && grep -q "model.qmx" "$T/key.err" || fail "sweep, bad key: $(cat "$T/key.err")"
ok "a run the model cannot start is a row of the summary; a bad key is refused before the runs"

# ---- create succeeds without an instance (it crashed in the model's eval: SIGSEGV); an invariant
# without a name (it became the column "(null)_drift"): refused by dth_model_new, exit 2, one line
"$DTH" sweep "$T/osc.ini" --model-lib "$BM:test_null_self" -s model.name=null-self --vary initial.q=0:1:3 \
    -o "$T/null.csv" 2>"$T/null.err"
rc=$?
[ $rc -eq 2 ] || fail "null self: exit $rc, want 2: $(cat "$T/null.err")"
grep -q "model 'null-self': create succeeded without an instance (\*self = NULL)" "$T/null.err" ||
    fail "null self: $(cat "$T/null.err")"
"$DTH" sweep "$T/osc.ini" --model-lib "$BM:test_null_invname" -s model.name=null-invname --vary initial.q=0:1:3 \
    -o "$T/inv.csv" 2>"$T/inv.err"
rc=$?
[ $rc -eq 2 ] || fail "invariant without a name: exit $rc, want 2: $(cat "$T/inv.err")"
grep -q "model 'null-invname': invariant 1 of 1 has no name (invariant_name returned NULL)" "$T/inv.err" ||
    fail "invariant without a name: $(cat "$T/inv.err")"
[ -e "$T/inv.csv" ] && fail "invariant without a name: a summary was written: $(head -1 "$T/inv.csv")"
ok "a model without an instance, an invariant without a name: refused, naming the fault"

# ---- dth run --model-lib (issue 25): the Henon-Heiles plugin with a Poincare section q1 = 0
"$DTH" run "$ROOT/docs/examples/henon-heiles.ini" --model-lib "$HH:example_henon_heiles" -s events.section=q1 \
    -o "$T/out/hh.csv" 2>"$T/hh.err" || fail "run --model-lib: $(cat "$T/hh.err")"
[ "$(head -1 "$T/out/hh-events.csv")" = "i,event,direction,k,t,q1,q2,p1,p2,wp,H,E" ] || fail "run --model-lib: no events file"
awk -F, 'NR > 1 { n++; q = $6 < 0 ? -$6 : $6; if ($2 != "section" || q > 1e-12) bad = 1 } END { exit bad || n < 5 }' \
    "$T/out/hh-events.csv" || fail "run --model-lib: section events: $(head -3 "$T/out/hh-events.csv")"
# a file name without a slash: the file in the working folder (dlopen alone searched the library path)
hhdir=$(dirname "$HH") hhso=$(basename "$HH")
(cd "$hhdir" && "$DTH" run "$ROOT/docs/examples/henon-heiles.ini" --model-lib "$hhso:example_henon_heiles" \
    -s integrator.steps=5 -o "$T/hh5.csv" 2>"$T/hh5.err") || fail "run --model-lib $hhso: $(cat "$T/hh5.err")"
(cd "$hhdir" && "$DTH" sweep "$ROOT/docs/examples/henon-heiles.ini" --model-lib "$hhso:example_henon_heiles" \
    --vary 'initial.q[1]=0:0.1:2' -s integrator.steps=5 -o "$T/hhs.csv" 2>"$T/hhs.err") ||
    fail "sweep --model-lib $hhso: $(cat "$T/hhs.err")"
# the path tried is named
(cd "$T" && "$DTH" run "$ROOT/docs/examples/henon-heiles.ini" --model-lib "no-such.so:x" 2>"$T/ns.err")
[ $? -eq 2 ] && grep -q "cannot load 'no-such.so': no such file in the working folder, and the library path has none" \
    "$T/ns.err" || fail "missing plugin: $(cat "$T/ns.err")"
cp "$HH" "$T/copy.so"
(cd "$T" && "$DTH" run "$ROOT/docs/examples/henon-heiles.ini" --model-lib "copy.so:nothing" 2>"$T/ns.err")
[ $? -eq 2 ] && grep -q "'./copy.so' has no model table 'nothing'" "$T/ns.err" || fail "no such table: $(cat "$T/ns.err")"
# an output over the plugin is refused
"$DTH" run "$ROOT/docs/examples/henon-heiles.ini" --model-lib "$T/copy.so:example_henon_heiles" -o "$T/copy.so" 2>"$T/ns.err"
[ $? -eq 2 ] && grep -q "it is a model library (--model-lib)" "$T/ns.err" || fail "output over the plugin: $(cat "$T/ns.err")"
# the run's derivative check that cannot run fails dth run too (it was passed over)
"$DTH" run "$T/osc.ini" --model-lib "$BM:test_third_fail" -s model.name=third-fail -o "$T/third-run.csv" 2>"$T/tr.err"
rc=$?
[ $rc -eq 1 ] && grep -q "its derivative check cannot run at the initial state: a model callback reported an error (--no-model-check runs it anyway)" \
    "$T/tr.err" || fail "run, check cannot run: exit $rc: $(cat "$T/tr.err")"
ok "dth run --model-lib: section events; FILE without a slash found here; the path tried named"

[ $fails -eq 0 ] && echo "check_models: all passed"
exit $((fails != 0))
