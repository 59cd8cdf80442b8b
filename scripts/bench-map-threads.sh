#!/usr/bin/env bash
# dth map's thread scaling (issue 12: independent grid points must not serialize on a library lock):
# the same phase-plane map of the pendulum with OMP_NUM_THREADS=1 and 2, runs interleaved, wall
# seconds (median of 5 each), the speed-up, and whether the outputs are the same bytes.
# Usage: bash scripts/bench-map-threads.sh [BUILD_DIR [GRID]]   (defaults: build, 150 x 150 points)
set -euo pipefail
cd "$(dirname "$0")/.."
bd=${1:-build}
g=${2:-150}
dth="$bd/cli/dth"
[ -x "$dth" ] || { echo "no $dth (build first)" >&2; exit 2; }
if ! ldd "$dth" | grep gomp >/dev/null; then # (grep -q would close the pipe early: pipefail)
  echo "$dth is built without OpenMP: dth map runs in one thread" >&2
  exit 2
fi
out=$(mktemp -d /tmp/dth_map_threads.XXXXXX)
trap 'rm -rf "$out"' EXIT
run() { # threads -> wall seconds
  local t0 t1
  t0=$(date +%s.%N)
  OMP_NUM_THREADS=$1 OPENBLAS_NUM_THREADS=1 "$dth" map scenes/pendulum.ini --q -3:3:"$g" --p -2.5:2.5:"$g" \
    --out "$out/map$1" >/dev/null
  t1=$(date +%s.%N)
  awk -v a="$t0" -v b="$t1" 'BEGIN { printf "%.4f\n", b - a }'
}
t1=(); t2=()
for r in 1 2 3 4 5; do
  t1+=("$(run 1)")
  t2+=("$(run 2)")
done
med() { printf '%s\n' "$@" | sort -g | sed -n 3p; }
m1=$(med "${t1[@]}"); m2=$(med "${t2[@]}")
same=no
cmp -s "$out/map1.csv" "$out/map2.csv" && cmp -s "$out/map1-traj.csv" "$out/map2-traj.csv" && same=yes
printf 'dth map, pendulum, %s x %s points, %s online CPUs, median of 5 interleaved runs\n' "$g" "$g" "$(nproc)"
printf '  1 thread   %7.3f s\n' "$m1"
printf '  2 threads  %7.3f s   speed-up %.2f   (target >= 1.8)   outputs byte-identical: %s\n' "$m2" \
  "$(awk -v a="$m1" -v b="$m2" 'BEGIN { print a / b }')" "$same"
[ "$same" = yes ]
