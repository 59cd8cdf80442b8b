#!/usr/bin/env bash
# Instruction counts per step (callgrind) of the figures of issue 12 whose wall-clock ratios are too
# noisy on a shared machine: the DTH step against its closed-form floor and GSL rk4imp (bench_floor's
# variants), and the N = 1000 chain with the banded Schur complement against the banded LU.
# Instructions are not time (a division or a sincos costs more than an add), so these ratios complement
# bench_floor's and bench_chain's timed ones; they do not move with the machine's load.
# Usage: bash scripts/bench-instr.sh [BUILD_DIR [STEPS]]   (defaults: build, 20000; needs valgrind)
set -euo pipefail
cd "$(dirname "$0")/.."
bd=${1:-build}
steps=${2:-20000}
command -v valgrind >/dev/null || { echo "bench-instr: valgrind is not installed" >&2; exit 2; }
tmp=$(mktemp -d /tmp/dth_instr.XXXXXX)
trap 'rm -rf "$tmp"' EXIT
export OPENBLAS_NUM_THREADS=1 # bench_floor would re-run itself otherwise (valgrind does not follow the exec)
count() { # out-name toggle-function command... -> instructions inside the toggled function
  local name=$1 fn=$2
  shift 2
  valgrind --tool=callgrind --callgrind-out-file="$tmp/$name" --toggle-collect="$fn" "$@" >/dev/null 2>"$tmp/$name.err" ||
    { cat "$tmp/$name.err" >&2; exit 1; }
  awk '/^summary:/ { print $2 }' "$tmp/$name"
}
per() { awk -v a="$1" -v n="$2" 'BEGIN { printf "%.0f", a / n }'; }
ratio() { awk -v a="$1" -v b="$2" 'BEGIN { printf "%.2f", a / b }'; }
f=$bd/bench/bench_floor
pl=$(per "$(count pl dth_integrator_step "$f" --only pend-lib "$steps")" "$steps")
pn=$(per "$(count pn dth_integrator_step "$f" --only pend-lib-nocomp "$steps")" "$steps")
pb=$(per "$(count pb dth_integrator_step "$f" --only pend-lib-nobranch "$steps")" "$steps")
pf=$(per "$(count pf pend_step "$f" --only pend-floor "$steps")" "$steps")
g=$(per "$(count g gsl_odeiv2_step_apply "$f" --only rk4imp "$steps")" "$steps")
kl=$(per "$(count kl dth_integrator_step "$f" --only kep-lib "$steps")" "$steps")
kf=$(per "$(count kf kep_step "$f" --only kep-floor "$steps")" "$steps")
echo "instructions per step (callgrind, $steps steps)"
echo "pendulum, h = 0.05, amplitude 1"
echo "  library DTH step      $pl"
echo "  same, compensate = 0  $pn   (the compensated finish: $(ratio $((pl - pn)) "$pl") of the step)"
echo "  same, branch_check = 0  $pb   (the cheap branch test: $(ratio $((pl - pb)) "$pl") of the step)"
echo "  closed-form floor     $pf   library / floor $(ratio "$pl" "$pf")"
echo "  GSL rk4imp step       $g   library / rk4imp $(ratio "$pl" "$g")"
echo "kepler e = 0.6, h = 0.01"
echo "  library DTH step      $kl"
echo "  2x2 Schur floor       $kf   library / floor $(ratio "$kl" "$kf")"
c=$bd/bench/bench_chain
cs=$((steps / 1000 > 5 ? steps / 1000 : 5))
cb=$(per "$(count cb dth_integrator_step "$c" --only banded 1000 "$cs")" "$cs")
cl=$(per "$(count cl dth_integrator_step "$c" --only banded-lu 1000 "$cs")" "$cs")
echo "chain N = 1000 (2-D, L = 1, h = 0.05), $cs steps"
echo "  banded (Schur)        $cb"
echo "  banded-lu             $cl   banded / banded-lu $(ratio "$cb" "$cl")"
