#!/bin/sh
# SPDX-License-Identifier: MIT
# End-to-end checks of `dth sweep`: a 64 x 64 pendulum grid byte-identical for 1 and 2 OpenMP
# threads (and, when MPIRUN is given, for 2 MPI ranks with the dynamic and the static schedule);
# grid order and values; each run's energy error at round-off; a --list with element keys and a
# quoted list value; each --trajectories file equal to `dth run` with the same overrides, byte for
# byte; MEGNO of Henon-Heiles as a user model (--model-lib) near 2 at E = 1/12 and growing at
# E = 1/6; MEGNO ending at the first regularized step; usage errors.
# usage: check_sweep.sh PATH/TO/dth SOURCE_ROOT HH_PLUGIN.so [MPIRUN [MPI_SHIM.so]]
#   (with MPIRUN: only the grid, for 1 thread against 2 ranks; with the shim (tests/cli/mpi_shim.c)
#   also an MPI that provides no thread support, and a failed allocation on rank 0)
set -u
DTH=$1
ROOT=$2
HH=$3
MPIRUN=${4:-}
SHIM=${5:-}
SC=$ROOT/scenes
T=$(mktemp -d /tmp/dth_sweep_test.XXXXXX)
trap 'rm -rf "$T"' EXIT
fails=0
fail() { echo "FAIL: $*" >&2; fails=$((fails + 1)); }
ok() { echo "ok: $*"; }
GRID="--vary initial.q=-3:3:64 --vary initial.p=-2.5:2.5:64"

# ---- 64 x 64 pendulum grid (4096 runs to t = 20, MEGNO on): 1 and 2 threads
OMP_NUM_THREADS=1 "$DTH" sweep "$SC/pendulum.ini" $GRID -o "$T/s1.csv" 2>"$T/s1.err"
rc=$?
[ $rc -eq 0 ] || fail "sweep exit $rc: $(cat "$T/s1.err")"
OMP_NUM_THREADS=2 "$DTH" sweep "$SC/pendulum.ini" $GRID -o "$T/s2.csv" 2>/dev/null || fail "sweep with 2 threads"
[ "$(wc -l <"$T/s1.csv")" -eq 4097 ] || fail "rows: $(wc -l <"$T/s1.csv") lines, want 4097"
cmp -s "$T/s1.csv" "$T/s2.csv" || fail "the summary differs between OMP_NUM_THREADS=1 and 2"
ok "64 x 64 grid: 1 and 2 threads byte-identical ($(wc -c <"$T/s1.csv") bytes)"
if [ -n "$MPIRUN" ]; then
    as_root=
    [ "$(id -u)" -eq 0 ] && as_root=--allow-run-as-root
    for sched in dynamic static; do
        OMP_NUM_THREADS=1 "$MPIRUN" $as_root --oversubscribe -n 2 "$DTH" sweep "$SC/pendulum.ini" $GRID \
            --schedule $sched --chunk 7 -o "$T/m-$sched.csv" 2>"$T/m.err" || fail "mpirun -n 2 ($sched): $(cat "$T/m.err")"
        cmp -s "$T/s1.csv" "$T/m-$sched.csv" || fail "the summary differs between 1 thread and 2 MPI ranks ($sched)"
    done
    # ranks with 2 threads each
    OMP_NUM_THREADS=2 "$MPIRUN" $as_root --oversubscribe -n 2 "$DTH" sweep "$SC/pendulum.ini" $GRID -o "$T/m22.csv" \
        2>/dev/null || fail "mpirun -n 2 with 2 threads"
    cmp -s "$T/s1.csv" "$T/m22.csv" || fail "the summary differs between 1 thread and 2 ranks x 2 threads"
    ok "2 MPI ranks (dynamic, static; 1 and 2 threads each) byte-identical to 1 thread"
    if [ -n "$SHIM" ]; then
        G16="--vary initial.q=-3:3:16 --vary initial.p=-2.5:2.5:16"
        OMP_NUM_THREADS=1 "$DTH" sweep "$SC/pendulum.ini" $G16 -o "$T/g16.csv" --stats 2>"$T/g16.err" || fail "16 x 16 grid"
        # MPI_THREAD_SINGLE with 2 OpenMP threads: a note, one thread per rank, the same bytes
        OMP_NUM_THREADS=2 "$MPIRUN" $as_root --oversubscribe -n 2 -x LD_PRELOAD="$SHIM" -x DTH_SHIM_THREAD_SINGLE=1 \
            "$DTH" sweep "$SC/pendulum.ini" $G16 -o "$T/single.csv" 2>"$T/single.err" || fail "thread level SINGLE: $(cat "$T/single.err")"
        grep -q "provides thread support MPI_THREAD_SINGLE, below the MPI_THREAD_FUNNELED that 2 OpenMP threads per rank need: each rank runs 1 thread" \
            "$T/single.err" || fail "no note on the thread level: $(cat "$T/single.err")"
        cmp -s "$T/g16.csv" "$T/single.csv" || fail "thread level SINGLE: the summary differs"
        # rank 0 cannot allocate the gathered records (runs x (record + index)): exit 1, a message, no hang
        rec=$(sed -n 's/.*summary record \([0-9]*\) bytes per run.*/\1/p' "$T/g16.err")
        [ -n "$rec" ] || fail "no record size in --stats: $(cat "$T/g16.err")"
        timeout 120 "$MPIRUN" $as_root --oversubscribe -n 2 -x LD_PRELOAD="$SHIM" -x DTH_SHIM_FAIL_MALLOC=$((256 * (rec + 8))) \
            "$DTH" sweep "$SC/pendulum.ini" $G16 -o "$T/nomem.csv" >/dev/null 2>"$T/nomem.err"
        rc=$?
        [ $rc -eq 1 ] || fail "rank 0 out of memory: exit $rc, want 1: $(head -3 "$T/nomem.err")"
        grep -q "^dth: out of memory (rank 0): no summary written" "$T/nomem.err" || fail "rank 0 out of memory: $(head -3 "$T/nomem.err")"
        [ -e "$T/nomem.csv" ] && fail "rank 0 out of memory: a summary was written"
        ok "MPI below MPI_THREAD_FUNNELED runs one thread per rank; rank 0 out of memory before the gather: exit 1"
    fi
    # the MPI test stops here; the rest runs in the test without MPIRUN
    [ $fails -eq 0 ] && echo "check_sweep (MPI): all passed"
    exit $((fails != 0))
fi
HDR="run,initial.q,initial.p,status,steps,t,energy_error,psi_crossings,regularized_share,events,megno,lyapunov,megno_t,err_q,err_p"
[ "$(head -1 "$T/s1.csv")" = "$HDR" ] || fail "header: $(head -1 "$T/s1.csv")"
# grid order (q slowest), status, end time, energy at round-off, MEGNO only where it ran
awk -F, -v OFS=, 'function abs(x) { return x < 0 ? -x : x }
    NR == 1 { next }
    { r = NR - 2; i = int(r / 64); j = r % 64
      if ($1 != r) { print "row " NR ": run " $1; bad = 1 }
      if (abs($2 - (-3 + 6 * i / 63)) > 1e-12 || abs($3 - (-2.5 + 5 * j / 63)) > 1e-12) { print "row " NR ": grid " $2 "," $3; bad = 1 }
      if ($4 != "ok" || $6 != 20) { print "row " NR ": status " $4 " t " $6; bad = 1 }
      # relative to |E0|, which may be near 0; S: the size of the terms the step constraint of the
      # library weighs its round-off by (|wp| + |H_phys| + |q dH/dq| + |p dH/dp|), the midpoint energy
      # being exact to 4 eps S (docs/performance.md); 8 eps S allows the Newton residual on top
      E0 = $3 * $3 / 2 - cos($2); S = 2 * abs(E0) + abs($2 * sin($2)) + $3 * $3
      if ($7 * abs(E0) > 1.8e-15 * S) { print "row " NR ": energy error " $7 " of E0 = " E0; bad = 1 }
      # megno_t: from the first vertex (h/2 before t = 0) to the vertex at or past t_end = 20, at most
      # one step past it (raw DTH steps near the separatrix grow to about 5 h = 0.25)
      if ($13 == "" || $13 > 20.3) { print "row " NR ": megno_t " $13; bad = 1 }
      # megno and lyapunov are left empty when their window is under half of the run (issue 24)
      if (($11 == "") != ($13 < 10) || ($12 == "") != ($13 < 10)) { print "row " NR ": megno " $11 " over " $13; bad = 1 }
      if ($9 == 0 && !($13 >= 20.025 && $13 < 20.3)) { print "row " NR ": no regularized step but megno_t " $13; bad = 1 }
      if ($9 > 0 && !($13 < 20)) { print "row " NR ": regularized steps but megno_t " $13; bad = 1 }
      # the estimated global error at t = 20: finite and below the orbit size (h = 0.05)
      if (!($14 > 0 && $14 < 0.5 && $15 > 0 && $15 < 0.5)) { print "row " NR ": estimate " $14 ", " $15; bad = 1 }
      if ($9 == 0) nfull++
      if ($8 > 0 && $9 == 0) { print "row " NR ": crossings without regularized steps"; bad = 1 } }
    END { if (nfull < 500) { print "only " nfull " runs without regularized steps"; bad = 1 } exit bad }' "$T/s1.csv" >"$T/aw" ||
    fail "summary rows: $(head -5 "$T/aw")"
ok "grid order, status, t = 20, energy error |E - E0| <= 8 eps S, MEGNO over the whole run unless a step was regularized"

# ---- references at the right points (issue 24): a vertex start's energy error against the energy its
# midpoints conserve (-wp, 13.8 % off H at the initial state of the rotating pendulum scene), and
# invariant drifts at vertices against the first vertex (Kepler's L is exact at vertices: a midpoint
# start's initial state is half a step off them and read 3.9e-4)
"$DTH" sweep "$SC/pendulum-rotation.ini" --vary initial.q=0:0:1 -o "$T/vs.csv" 2>"$T/vs.err" || fail "vertex-start sweep: $(cat "$T/vs.err")"
awk -F, 'NR == 2 && !($3 == "ok" && $6 < 1e-14) { print; bad = 1 } END { exit bad }' "$T/vs.csv" >"$T/aw" ||
    fail "vertex start: energy error $(cat "$T/aw")"
printf 'initial.q[1]\n1.0\n' >"$T/kl.csv"
"$DTH" sweep "$SC/kepler-e06.ini" --list "$T/kl.csv" -o "$T/kl-out.csv" 2>"$T/kl.err" || fail "Kepler sweep: $(cat "$T/kl.err")"
awk -F, 'NR == 1 { for (i = 1; i <= NF; i++) c[$i] = i; if (!c["L_drift"]) { print "no L_drift: " $0; bad = 1 } next }
    !($c["status"] == "ok" && $c["L_drift"] < 1e-13 && $c["energy_error"] < 1e-14) { print; bad = 1 } END { exit bad }' \
    "$T/kl-out.csv" >"$T/aw" || fail "Kepler drifts: $(cat "$T/aw")"
ok "energy error against the conserved energy, invariant drifts at vertices"

# ---- --list with element keys and -s; trajectories equal to dth run's rows
cat >"$T/list.csv" <<EOF
# pendulum amplitudes, two ways
initial.q,integrator.h
0.5,0.05
"2.5",0.02
EOF
"$DTH" sweep "$SC/pendulum.ini" --list "$T/list.csv" -s integrator.t_end=3 --trajectories "$T/tr/run" -o "$T/l.csv" \
    2>"$T/l.err" || fail "sweep --list: $(cat "$T/l.err")"
[ "$(sed -n 2p "$T/l.csv" | cut -d, -f1-4)" = "0,0.5,0.05,ok" ] || fail "list row 0: $(sed -n 2p "$T/l.csv")"
[ "$(sed -n 3p "$T/l.csv" | cut -d, -f1-4)" = "1,2.5,0.02,ok" ] || fail "list row 1: $(sed -n 3p "$T/l.csv")"
"$DTH" run "$SC/pendulum.ini" -s integrator.t_end=3 -s initial.q=2.5 -s integrator.h=0.02 >"$T/r1.csv" 2>/dev/null
cmp -s "$T/tr/run-1.csv" "$T/r1.csv" || fail "trajectory of run 1 differs from dth run's rows"
"$DTH" run "$SC/pendulum.ini" -s integrator.t_end=3 -s initial.q=0.5 >"$T/r0.csv" 2>/dev/null
cmp -s "$T/tr/run-0.csv" "$T/r0.csv" || fail "trajectory of run 0 differs from dth run's rows"
"$DTH" sweep "$SC/pendulum.ini" -s initial.q=0 -s integrator.t_end=10 --vary initial.p=2.1:2.3:3 --trajectories "$T/rot" \
    -o "$T/rot.csv" 2>/dev/null || fail "rotation sweep"
"$DTH" run "$SC/pendulum.ini" -s initial.q=0 -s integrator.t_end=10 -s initial.p=2.2000000000000002 >"$T/rr.csv" 2>/dev/null
cmp -s "$T/rot-1.csv" "$T/rr.csv" || fail "rotation trajectory (with the ordinary column) differs from dth run's"
# events (issue 25): with --trajectories each run's events go to P-RUN-events.csv, byte for byte dth run's
# events file; the summary counts them
"$DTH" sweep "$SC/pendulum.ini" --vary initial.q=0.5:1.5:3 -s events.section=p1 -s events.section_direction=both \
    --trajectories "$T/ev/r" -o "$T/ev.csv" 2>"$T/ev.err" || fail "sweep with events: $(cat "$T/ev.err")"
for i in 0 1 2; do
    q=$(sed -n "$((i + 2))p" "$T/ev.csv" | cut -d, -f2)
    "$DTH" run "$SC/pendulum.ini" -s events.section=p1 -s events.section_direction=both -s initial.q="$q" \
        -o "$T/ev/run$i.csv" 2>/dev/null
    cmp -s "$T/ev/run$i-events.csv" "$T/ev/r-$i-events.csv" || fail "run $i's events differ from dth run's"
    cmp -s "$T/ev/run$i.csv" "$T/ev/r-$i.csv" || fail "run $i's trajectory differs from dth run's"
    [ "$(sed -n "$((i + 2))p" "$T/ev.csv" | cut -d, -f9)" = "$(($(wc -l <"$T/ev/r-$i-events.csv") - 1))" ] ||
        fail "run $i: the summary's events column against $(($(wc -l <"$T/ev/r-$i-events.csv") - 1)) rows"
done
[ "$(head -1 "$T/ev/r-0-events.csv")" = "i,event,direction,k,t,q1,p1,wp,H,E" ] || fail "events header: $(head -1 "$T/ev/r-0-events.csv")"
# MEGNO ends at the first regularized step: megno_t is short, the run is not
awk -F, 'NR > 1 && !($3 == "ok" && $5 == 10 && $7 > 0 && $12 < 3 && $10 == "" && $11 == "") { print; bad = 1 } END { exit bad }' "$T/rot.csv" >"$T/aw" ||
    fail "rotation: MEGNO should end at the first crossing: $(cat "$T/aw")"
ok "--list (quoted value, -s), trajectories byte-identical to dth run, MEGNO ends at a regularized step"

# ---- Henon-Heiles as a user model: MEGNO near 2 (regular, E = 1/12) and large (chaotic, E = 1/6)
printf 'initial.q[2],initial.p\n0.1,"0.39665266081716044, 0"\n-0.1,"0.56803755744375446, 0"\n' >"$T/hh.csv"
"$DTH" sweep "$ROOT/docs/examples/henon-heiles.ini" --model-lib "$HH:example_henon_heiles" --list "$T/hh.csv" \
    -s integrator.t_end=1000 -o "$T/hh-out.csv" 2>"$T/hh.err" || fail "HH sweep: $(cat "$T/hh.err")"
# fields counted from the end (a quoted list value holds commas): err_p, err_q, megno_t, lyapunov, megno, events, ...
awk 'function abs(x) { return x < 0 ? -x : x }
    NR == 1 { next }
    { n = split($0, f, ","); m = f[n - 4]; l = f[n - 3]; ev = f[n - 5]; e = f[n - 8] }
    NR == 2 && !(abs(m - 2) < 0.02) { print "regular orbit: megno " m; bad = 1 }
    NR == 3 && !(m > 20 && l > 0.05) { print "chaotic orbit: megno " m " lyapunov " l; bad = 1 }
    !(e < 1e-14 && ev > 100) { print "energy error " e ", events " ev; bad = 1 }
    END { exit bad }' "$T/hh-out.csv" >"$T/aw" || fail "Henon-Heiles MEGNO: $(cat "$T/aw"; cat "$T/hh-out.csv")"
ok "Henon-Heiles (--model-lib): MEGNO $(awk -F, 'NR > 1 { n = split($0, f, ","); printf "%s ", f[n - 4] }' "$T/hh-out.csv")"

# ---- usage errors (exit 2, one line naming the problem)
expect2() {
    "$DTH" sweep "$@" >"$T/e.out" 2>"$T/e.err"
    rc=$?
    [ $rc -eq 2 ] || fail "dth sweep $*: exit $rc, want 2"
    [ "$(wc -l <"$T/e.err")" -ge 1 ] || fail "dth sweep $*: no message"
}
expect2 "$SC/pendulum.ini"
expect2 "$SC/pendulum.ini" --vary initial.q=0:1
expect2 "$SC/pendulum.ini" --vary initial.q=0:1:0
expect2 "$SC/pendulum.ini" --vary initialq=0:1:3
expect2 "$SC/pendulum.ini" --vary model.nope=0:1:3
grep -q "nope" "$T/e.err" || fail "unknown key not named: $(cat "$T/e.err")"
expect2 "$SC/pendulum.ini" --vary 'initial.q[2]=0:1:3'
grep -q "initial.q\[2\]" "$T/e.err" || fail "element beyond the list not named: $(cat "$T/e.err")"
expect2 "$SC/pendulum.ini" --vary initial.q=0:1:3 --list "$T/list.csv"
expect2 "$SC/pendulum.ini" --list "$T/no-such.csv"
expect2 "$SC/pendulum.ini" --vary initial.q=0:1:3 --model-lib /no/such.so:x
if [ -n "${DTH_TEST_OLD_PLUGIN:-}" ]; then
    expect2 "$SC/pendulum.ini" --vary initial.q=0:1:3 --model-lib "$DTH_TEST_OLD_PLUGIN:old_table"
    grep -q "old_table.*no layout version.*DTH_MODEL_TYPE_HEAD" "$T/e.err" || fail "old plugin table not refused by name: $(cat "$T/e.err")"
fi
expect2 "$SC/pendulum.ini" --vary initial.q=0:1:3 --schedule sometimes
expect2 "$SC/pendulum.ini" --vary initial.q=0:1:3 -o /dev/null/x.csv
# a key varied twice (a repeated --list column, a whole list and its element, two --vary) is refused:
# the last value silently won
printf 'initial.q,integrator.h,initial.q\n0.5,0.05,1\n' >"$T/dup.csv"
expect2 "$SC/pendulum.ini" --list "$T/dup.csv" -o "$T/dup-out.csv"
grep -q "dup.csv:1: column 3 (initial.q) sets what column 1 (initial.q) sets" "$T/e.err" || fail "duplicate column: $(cat "$T/e.err")"
[ -e "$T/dup-out.csv" ] && fail "duplicate column: a summary was written"
printf 'initial.q,initial.q[1]\n0.5,1\n' >"$T/dup.csv"
expect2 "$SC/pendulum.ini" --list "$T/dup.csv"
grep -q "column 2 (initial.q\[1\]) sets what column 1 (initial.q) sets" "$T/e.err" || fail "element of a varied list: $(cat "$T/e.err")"
expect2 "$SC/pendulum.ini" --vary initial.q=0:1:2 --vary initial.q=1:2:2
grep -q "^dth: --vary 2 (initial.q) sets what --vary 1 (initial.q) sets" "$T/e.err" || fail "--vary twice: $(cat "$T/e.err")"
# a varied key's messages name where it was varied (issue 25: they said "-s ...")
expect2 "$SC/pendulum.ini" --vary initial.qq=0:1:2
grep -q "^dth: --vary initial.qq=0: initial.qq: unknown key" "$T/e.err" || fail "--vary origin: $(cat "$T/e.err")"
printf 'initial.q,integrator.hh\n0.5,0.05\n' >"$T/hh2.csv"
expect2 "$SC/pendulum.ini" --list "$T/hh2.csv"
grep -q "^dth: $T/hh2.csv:2: integrator.hh: unknown key" "$T/e.err" || fail "--list origin: $(cat "$T/e.err")"
"$DTH" sweep --help | grep -q "megno_t" || fail "--help does not describe the columns"
ok "usage errors"

[ $fails -eq 0 ] && echo "check_sweep: all passed"
exit $((fails != 0))
