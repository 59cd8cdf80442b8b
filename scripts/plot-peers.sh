#!/bin/sh
# SPDX-License-Identifier: MIT
# Render the work-precision figures of bench/bench_peers (issue 22 item 4: DTH of order 2 and 4
# against GSL odeiv2, Boost.Odeint and the baselines): one figure per scene, CPU seconds against the
# final position error, a line per method.
# Usage: scripts/plot-peers.sh [CSV_DIR [FIG_DIR]]   (defaults: bench-out, docs/figures)
set -eu
. "$(dirname "$0")/plot-lib.sh"   # plot_init, render
plot_init "$@"

for csv in "$in"/peers_*.csv; do
    [ -e "$csv" ] || { echo "$0: no peers_*.csv in $in (run bench_peers --out $in)" >&2; exit 2; }
    scene=$(basename "$csv" .csv | sed 's/^peers_//')
    # one data file per method: error, CPU (sorted by error)
    awk -F, -v d="$tmp" -v s="$scene" 'NR > 1 { f = $1; gsub(/ /, "_", f); print $4, $5 > (d "/" s "__" f ".dat") }' "$csv"
    cmd=""
    for f in "$tmp/${scene}__"*.dat; do
        [ -e "$f" ] || continue
        sort -g -o "$f" "$f"
        name=$(basename "$f" .dat | sed "s/^${scene}__//; s/_/ /g")
        style="linespoints"
        case "$name" in dth\ order*) style="linespoints lw 3 pt 7" ;; esac
        [ -z "$cmd" ] && cmd="plot " || cmd="$cmd, "
        cmd="$cmd\"$f\" using 1:2 with $style title \"$name\""
    done
    render "peers_$scene" "900,650" "set termoption noenhanced
set key outside right
set logscale xy
set format x '%.0e'
set format y '%.0e'
set xlabel 'final position error'
set ylabel 'CPU seconds'
set title '$scene: CPU against the final position error (bench_peers)'
$cmd"
done
echo "figures written to $out"
