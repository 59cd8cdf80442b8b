#!/bin/sh
# SPDX-License-Identifier: MIT
# End-to-end checks of `dth map` (the paper's Figure 1 as data): CSV shape, psi and [psi, H] against
# the pendulum's closed forms, regions (section 5), roots near +-h in region I (Theorem EU_1), the
# point map equal to `dth roots` at the scene's vertex, the trajectory's stop, bit-identical output
# for 1 and 2 OpenMP threads, a slice of a two-degree-of-freedom model, and usage errors.
# usage: check_map.sh PATH/TO/dth SOURCE_ROOT
set -u
DTH=$1
ROOT=$2
SC=$ROOT/scenes
T=$(mktemp -d /tmp/dth_map_test.XXXXXX)
trap 'rm -rf "$T"' EXIT
fails=0
fail() { echo "FAIL: $*" >&2; fails=$((fails + 1)); }
ok() { echo "ok: $*"; }
HDR="q,p,psi,dpsi,region,nroots,lambda_minus,lambda_plus,lambda_ghost"

# ---- a 21 x 21 map of the rotating pendulum, one thread and two
OMP_NUM_THREADS=1 "$DTH" map "$SC/pendulum-rotation.ini" --q -3.5:3.5:21 --p -3:3:21 --out "$T/m1" 2>"$T/m1.err"
rc=$?
[ $rc -eq 0 ] || fail "map exit $rc: $(cat "$T/m1.err")"
OMP_NUM_THREADS=2 "$DTH" map "$SC/pendulum-rotation.ini" --q -3.5:3.5:21 --p -3:3:21 --out "$T/m2" 2>/dev/null ||
    fail "map with 2 threads"
[ "$(head -1 "$T/m1.csv")" = "$HDR" ] || fail "header: $(head -1 "$T/m1.csv")"
[ "$(wc -l <"$T/m1.csv")" -eq 442 ] || fail "rows: $(wc -l <"$T/m1.csv") lines, want 442"
cmp -s "$T/m1.csv" "$T/m2.csv" || fail "map differs between OMP_NUM_THREADS=1 and 2"
cmp -s "$T/m1-traj.csv" "$T/m2-traj.csv" || fail "trajectory differs between OMP_NUM_THREADS=1 and 2"
[ -z "$(ls "$T" | grep '\.tmp\.')" ] || fail "temporary file left: $(ls "$T")"
ok "shape; 1 and 2 threads byte-identical"

# grid order (q-major) and the closed forms psi = p^2 cos q + sin^2 q, [psi, H] = -p^3 sin q (omega2 = 1)
awk -F, 'function abs(x) { return x < 0 ? -x : x }
    NR == 1 { next }
    NF != 9 { print "row " NR ": " NF " fields"; bad = 1 }
    { i = int((NR - 2) / 21); j = (NR - 2) % 21
      if (abs($1 - (-3.5 + 0.35 * i)) > 1e-12 || abs($2 - (-3 + 0.3 * j)) > 1e-12) { print "row " NR ": grid " $1 "," $2; bad = 1 }
      q = $1; p = $2
      psi = p * p * cos(q) + sin(q) ^ 2; dpsi = -p ^ 3 * sin(q)
      if (abs($3 - psi) > 1e-12 * (1 + p * p)) { print "row " NR ": psi " $3 " want " psi; bad = 1 }
      if (abs($4 - dpsi) > 1e-12 * (1 + abs(p) ^ 3)) { print "row " NR ": dpsi " $4 " want " dpsi; bad = 1 } }
    END { exit bad }' "$T/m1.csv" || fail "grid values, psi or [psi, H]"
ok "psi and [psi, H] match the closed forms at all 441 points"

# regions: "-" exactly at the equilibrium (0, 0); I wherever [psi, H] = 0 and psi != 0 (dpsi^2 = 0 <=
# 24 K |psi|); II (or III) where psi is small and [psi, H] is not; both I and II occur
awk -F, 'function abs(x) { return x < 0 ? -x : x }
    NR == 1 { next }
    { n[$5]++ }
    $5 == "-" && ($1 != 0 || $2 != 0) { print "region - at " $1 "," $2; bad = 1 }
    $4 == 0 && $3 != 0 && $5 != "I" { print "dpsi = 0, psi != 0 at " $1 "," $2 ": region " $5; bad = 1 }
    abs($3) < 0.5 && abs($4) > 0.5 && $5 != "II" && $5 != "III" { print "small psi, large dpsi at " $1 "," $2 ": region " $5; bad = 1 }
    END { if (n["I"] < 100 || n["II"] < 40 || n["-"] != 1) { print "region counts I " n["I"] " II " n["II"] " - " n["-"]; bad = 1 }
          exit bad }' "$T/m1.csv" || fail "regions"
# Theorem EU_1 (iii): in region I the offset H_k/psi_k = h^2/8 gives one root on each side, and its
# bound (g_bound_5 with |psi'/psi lambda| <= 1/2) puts it at 0.894 h <= |lambda| <= 1.155 h (h = 0.05)
awk -F, 'function abs(x) { return x < 0 ? -x : x }
    NR == 1 || $5 != "I" { next }
    $7 == "" || $8 == "" || !($7 < 0 && $8 > 0) { print "region I at " $1 "," $2 ": roots " $7 ", " $8; bad = 1 }
    abs($7) < 0.0447 || abs($7) > 0.0578 || $8 < 0.0447 || $8 > 0.0578 { print "region I at " $1 "," $2 ": roots " $7 ", " $8; bad = 1 }
    END { exit bad }' "$T/m1.csv" || fail "region I roots"
# where psi is small and [psi, H] large (region II) the physical root ahead meets the ghost: some points
# have a single physical root
[ "$(awk -F, '$5 == "II" && ($7 == "" || $8 == "")' "$T/m1.csv" | wc -l)" -gt 0 ] || fail "no region II point lost a root"
ok "regions I / II and the roots of Theorem EU_1"

# ---- a one-point map at the scene's own vertex gives the roots `dth roots` gives (same vertex offset)
"$DTH" map "$SC/pendulum-rotation.ini" --q 0:0:1 --p 2.2:2.2:1 --out "$T/one" 2>/dev/null || fail "one-point map"
"$DTH" roots "$SC/pendulum-rotation.ini" >"$T/roots.csv" || fail "dth roots"
want=$(awk -F, '$2 == "minus" { m = $1 } $2 == "plus" { p = $1 } END { print m "," p }' "$T/roots.csv")
got=$(sed -n 2p "$T/one.csv" | cut -d, -f7,8)
[ "$got" = "$want" ] || fail "one-point map roots $got, dth roots $want"
ok "one-point map = dth roots at the initial vertex"

# ---- the trajectory: starts at the scene's (q, p); with the default regularizer it reaches t_end
# through the psi = 0 crossings, raw DTH stops with DTH_EFOLD at the first one
[ "$(head -1 "$T/m1-traj.csv")" = "k,t,q,p,lambda,end" ] || fail "trajectory header: $(head -1 "$T/m1-traj.csv")"
[ "$(sed -n 2p "$T/m1-traj.csv" | cut -d, -f1,3,4)" = "0,0,2.2000000000000002" ] || fail "trajectory start: $(sed -n 2p "$T/m1-traj.csv")"
[ "$(tail -1 "$T/m1-traj.csv" | cut -d, -f6)" = "t_end" ] || fail "trajectory end: $(tail -1 "$T/m1-traj.csv")"
"$DTH" map "$SC/pendulum-rotation.ini" --q 0:0:1 --p 2.2:2.2:1 --out "$T/raw" -s regularize.method=none 2>"$T/raw.err" ||
    fail "raw map: $(cat "$T/raw.err")"
[ "$(tail -1 "$T/raw-traj.csv" | cut -d, -f1,6)" = "15,DTH_EFOLD" ] || fail "raw trajectory end: $(tail -1 "$T/raw-traj.csv")"
grep -q "note: the trajectory stopped at k=15" "$T/raw.err" || fail "no note on the stop: $(cat "$T/raw.err")"
awk -F, 'NR > 2 && $6 == "" && !($5 > 0) { print "row " NR ": lambda " $5; bad = 1 } END { exit bad }' "$T/m1-traj.csv" ||
    fail "trajectory steps"
ok "trajectory and its end"

# ---- a slice of the two-degree-of-freedom harmonic oscillator: --dof 2, the first mode at q1 = 1,
# p1 = 0; psi = sum omega_i^2 (p_i^2 + omega_i^2 q_i^2) = 1 + 3 (p^2 + 3 q^2), [psi, H] = 0, region I
"$DTH" map "$SC/harmonic.ini" --dof 2 --q -1:1:5 --p -2:2:5 --out "$T/h" 2>"$T/h.err" || fail "harmonic map: $(cat "$T/h.err")"
awk -F, 'function abs(x) { return x < 0 ? -x : x }
    NR == 1 { next }
    { psi = 1 + 3 * ($2 * $2 + 3 * $1 * $1) }
    abs($3 - psi) > 1e-12 * psi || $4 != 0 || $5 != "I" || $7 == "" || $8 == "" { print "row " NR ": " $0; bad = 1 }
    END { if (NR != 26) { print NR " lines"; bad = 1 } exit bad }' "$T/h.csv" || fail "harmonic slice"
[ "$(sed -n 2p "$T/h-traj.csv" | cut -d, -f1)" = "0" ] || fail "harmonic trajectory"
ok "two-degree-of-freedom slice"

# ---- usage errors: exit 2, one line naming the problem, no output files
expect_usage() { # $1 what it must mention, then the arguments
    what=$1
    shift
    "$DTH" map "$@" >"$T/u.out" 2>"$T/u.err"
    rc=$?
    [ $rc -eq 2 ] || fail "dth map $*: exit $rc, want 2"
    [ "$(wc -l <"$T/u.err")" -eq 1 ] && grep -q -- "$what" "$T/u.err" ||
        fail "dth map $*: message '$(cat "$T/u.err")' should be one line naming '$what'"
}
expect_usage "--p" "$SC/pendulum.ini" --q 0:1:3 --out "$T/bad"
expect_usage "a:b:n" "$SC/pendulum.ini" --q 0:1 --p 0:1:3 --out "$T/bad"
expect_usage "number of points" "$SC/pendulum.ini" --q 0:1:0 --p 0:1:3 --out "$T/bad"
expect_usage "finite" "$SC/pendulum.ini" --q 0:x:3 --p 0:1:3 --out "$T/bad"
expect_usage "--dof 2" "$SC/pendulum.ini" --q 0:1:3 --p 0:1:3 --dof 2 --out "$T/bad"
expect_usage "--range" "$SC/pendulum.ini" --q 0:1:3 --p 0:1:3 --range -1 --out "$T/bad"
expect_usage "unknown option" "$SC/pendulum.ini" --q 0:1:3 --p 0:1:3 --bogus --out "$T/bad"
expect_usage "no-such.ini" "$T/no-such.ini" --q 0:1:3 --p 0:1:3 --out "$T/bad"
expect_usage "model.omega2" "$SC/pendulum.ini" --q 0:1:3 --p 0:1:3 -s model.omega2=-1 --out "$T/bad"
expect_usage "cannot write" "$SC/pendulum.ini" --q 0:1:3 --p 0:1:3 --out /dev/null/x
[ -z "$(ls "$T" | grep '^bad')" ] || fail "output left after a usage error: $(ls "$T")"
ok "usage errors"

[ $fails -eq 0 ] || { echo "$fails check(s) failed" >&2; exit 1; }
echo "all map checks passed"
