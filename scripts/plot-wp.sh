#!/bin/sh
# SPDX-License-Identifier: MIT
# Render the work-precision diagrams, energy-error-against-time and DTH step-size plots from the
# CSV files of bench/bench_wp (paper, section 1: DTH against symplectic and energy methods).
# Usage: scripts/plot-wp.sh [CSV_DIR [FIG_DIR]]   (defaults: bench-out, docs/figures)
set -eu
. "$(dirname "$0")/plot-lib.sh"   # plot_init, render
plot_init "$@"
floor=1e-17 # energy errors of exactly 0 (or below) are drawn at this floor on the log axes

# Split wp.csv into one data file per (scene, method): x_global y_cpu x_energy (successful runs only).
awk -F, -v d="$tmp" -v fl="$floor" 'NR > 1 && $10 == "DTH_OK" {
    e = $7 + 0; if (e < fl) e = fl;
    print $6, $5, e > (d "/" $1 "__" $2 ".dat") }' "$in/wp.csv"
awk -F, -v d="$tmp" -v fl="$floor" 'NR > 1 { e = $4 + 0; if (e < fl) e = fl;
    print $3, e > (d "/et__" $1 "__" $2 ".dat") }' "$in/energy_time.csv"
awk -F, -v d="$tmp" 'NR > 1 { print $2, $3 > (d "/steps__" $1 ".dat") }' "$in/steps.csv"

plot_set() { # $1 file pattern prefix, $2 using, $3 title-strip prefix
    first=1
    for f in "$tmp"/$1*.dat; do
        [ -e "$f" ] || continue
        name=$(basename "$f" .dat | sed "s/^$3//")
        if [ $first = 1 ]; then printf 'plot '; first=0; else printf ', '; fi
        printf '"%s" using %s with linespoints title "%s"' "$f" "$2" "$name"
    done
    echo
}

wp_render() { # $1 output base name, $2 gnuplot settings, $3 plot command (900 x 650, key outside)
    render "$1" "900,650" "set key outside right
$2
$3"
}

for scene in $(awk -F, 'NR > 1 { print $1 }' "$in/wp.csv" | sort -u); do
    wp_render "wp_${scene}_global" "set logscale xy; set xlabel 'global error at the end (max norm)'; set ylabel 'CPU seconds'; set title '$scene: work-precision (global error)'" \
        "$(plot_set "${scene}__" 1:2 "${scene}__")"
    wp_render "wp_${scene}_energy" "set logscale xy; set xlabel 'largest energy error (DTH: at midpoints; floor $floor)'; set ylabel 'CPU seconds'; set title '$scene: work-precision (energy error)'" \
        "$(plot_set "${scene}__" 3:2 "${scene}__")"
done
for scene in $(awk -F, 'NR > 1 { print $1 }' "$in/energy_time.csv" | sort -u); do
    wp_render "energy_time_${scene}" "set logscale y; set xlabel 't'; set ylabel '|H - E0| (floor $floor)'; set title '$scene: energy error against time, h = 0.01'" \
        "$(plot_set "et__${scene}__" 1:2 "et__${scene}__")"
done
wp_render "dth_steps" "set logscale y; set xlabel 't'; set ylabel 'DTH step lambda'; set title 'DTH step size against time (midpoint start)'" \
    "$(plot_set "steps__" 1:2 "steps__")"
echo "figures written to $out"
