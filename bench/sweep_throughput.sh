#!/bin/sh
# SPDX-License-Identifier: MIT
# Throughput of dth sweep on the pendulum grid (issue 14 item 4): runs per second for 1 and 2 OpenMP
# threads and for 1 and 2 MPI ranks (when the build has MPI and mpirun is installed), side by side in
# one invocation, MEGNO on (and off, for its cost, also on a grid of small librations where no step is
# regularized and MEGNO follows every step), the library's heap per run, and a check that
# every configuration wrote the same bytes. The machine's load average is printed with the figures:
# on a shared machine compare the ratios of one invocation, never absolute times across invocations.
# usage: bench/sweep_throughput.sh [BUILDDIR [N [T_END]]]   (default build, a 64 x 64 grid, t_end = 20)
set -eu
root=$(cd "$(dirname "$0")/.." && pwd)
bd=${1:-$root/build}
n=${2:-64}
tend=${3:-20}
dth=$bd/cli/dth
[ -x "$dth" ] || { echo "sweep_throughput.sh: no $dth (build first)" >&2; exit 2; }
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
set -- "$root/scenes/pendulum.ini" --vary "initial.q=-3:3:$n" --vary "initial.p=-2.5:2.5:$n" \
    -s "integrator.t_end=$tend" --stats
runs=$((n * n))
as_root=
[ "$(id -u)" -eq 0 ] && as_root=--allow-run-as-root
has_mpi=0
if command -v mpirun >/dev/null 2>&1 && ldd "$dth" | grep -q libmpi; then has_mpi=1; fi
echo "dth sweep throughput: pendulum grid $n x $n = $runs runs to t = $tend (h = 0.05), load average $(cut -d' ' -f1-3 /proc/loadavg)"
printf '%-34s %9s %11s %9s\n' configuration seconds runs/s speedup
base=
# one configuration: NAME THREADS RANKS(0: no mpirun) [extra sweep options]
conf() {
    name=$1 th=$2 rk=$3
    shift 3
    if [ "$rk" -eq 0 ]; then
        OMP_NUM_THREADS=$th "$dth" sweep "$@" -o "$tmp/$name.csv" 2>"$tmp/$name.err"
    else
        OMP_NUM_THREADS=$th mpirun $as_root --oversubscribe -n "$rk" "$dth" sweep "$@" -o "$tmp/$name.csv" \
            2>"$tmp/$name.err"
    fi
    line=$(grep '^dth sweep:' "$tmp/$name.err")
    secs=$(echo "$line" | sed 's/.* in \([0-9.]*\) s:.*/\1/')
    rate=$(echo "$line" | sed 's/.* s: \([0-9.]*\) runs\/s.*/\1/')
    [ -n "$base" ] || base=$rate
    printf '%-34s %9s %11s %9.2f\n' "$name" "$secs" "$rate" "$(awk -v a="$rate" -v b="$base" 'BEGIN { print a / b }')"
}
conf "1-thread" 1 0 "$@"
conf "2-threads" 2 0 "$@"
if [ $has_mpi -eq 1 ]; then
    conf "1-rank(mpirun)" 1 1 "$@"
    conf "2-ranks(mpirun)" 1 2 "$@"
    conf "2-ranks-x-2-threads(mpirun)" 2 2 "$@"
fi
conf "1-thread-no-megno" 1 0 "$@" --no-megno
# MEGNO's cost where every step has a tangent map: small librations (no regularized step)
lib() {
    OMP_NUM_THREADS=1 "$dth" sweep "$root/scenes/pendulum.ini" --vary "initial.q=-1:1:$n" --vary "initial.p=-0.5:0.5:$n" \
        -s "integrator.t_end=$tend" --stats "$@" -o /dev/null 2>&1 | sed -n 's/.* s: \([0-9.]*\) runs\/s.*/\1/p'
}
echo "libration grid |q| <= 1, |p| <= 0.5 (no regularized step), 1 thread: MEGNO on $(lib) runs/s, off $(lib --no-megno) runs/s"
status=0
for f in "$tmp"/*.csv; do
    case $f in *no-megno*) continue ;; esac
    cmp -s "$tmp/1-thread.csv" "$f" || { echo "sweep_throughput.sh: $(basename "$f") differs from 1-thread.csv" >&2; status=1; }
done
[ $has_mpi -eq 1 ] || echo "(no MPI: the build has no mpi feature or mpirun is missing)"
echo "memory: $(sed -n 's/.*\(library heap of one run: [^;]*\); \(summary record [0-9]* bytes per run\).*/\1; \2/p' "$tmp/1-thread.err") (MEGNO on)"
echo "memory: $(sed -n 's/.*\(library heap of one run: [^;]*\);.*/\1/p' "$tmp/1-thread-no-megno.err") (MEGNO off)"
# reference for what this machine gives two threads: dth map's grid (OpenMP, nothing shared)
for th in 1 2; do
    t0=$(date +%s.%N)
    OMP_NUM_THREADS=$th "$dth" map "$root/scenes/pendulum-rotation.ini" --q -3.5:3.5:160 --p -3:3:160 --out "$tmp/map$th" \
        >/dev/null 2>&1
    t1=$(date +%s.%N)
    eval "map$th=\$(awk -v a=\"\$t0\" -v b=\"\$t1\" 'BEGIN { print b - a }')"
done
echo "reference: dth map 160 x 160 (OpenMP): 1 thread $map1 s, 2 threads $map2 s, speedup $(awk -v a="$map1" -v b="$map2" 'BEGIN { printf "%.2f", a / b }')"
echo "load average after: $(cut -d' ' -f1-3 /proc/loadavg); all configurations wrote the same bytes: $([ $status -eq 0 ] && echo yes || echo NO)"
exit $status
