#!/bin/sh
# SPDX-License-Identifier: MIT
# Render the figures of docs/regularization.md's "What losing symplecticity costs" from the CSV files
# of bench/bench_symplectic (paper, section 7: regularized DTH against symplectic and projected methods).
# Usage: scripts/plot-symplectic.sh [CSV_DIR [FIG_DIR]]   (defaults: bench-out, docs/figures)
set -eu
. "$(dirname "$0")/plot-lib.sh"   # plot_init, render
plot_init "$@"
methods="none land prescribed gauss4 midpoint midpoint-proj"

# one data file per (case, method): fput e1 series, time-averaged mode energies
# (every 4th sample of e1: one per period of mode 1, enough for the plot and 4 times smaller)
awk -F, -v d="$tmp" 'NR > 1 && (n[$1 $2]++ % 4) == 0 { print $3, $4 > (d "/e1__" $1 "__" $2 ".dat") }' "$in/fput_e1.csv"
awk -F, -v d="$tmp" 'NR > 1 { print $3, $4 > (d "/modes__" $1 "__" $2 ".dat") }' "$in/fput_modes.csv"
# sections: reference, and each method's first and last 10 % of points (by count), thinned to at
# most 300 points each (reference: 400) so that the SVG files stay small
awk -F, -v d="$tmp" 'NR > 1 { n[$1 "__" $2]++; x[$1 "__" $2, n[$1 "__" $2]] = $4 " " $5 }
    END { for (k in n) { m = n[k]; w = int(m / 10);
        if (k ~ /__reference$/) { s = int((m + 399) / 400); for (i = 1; i <= m; i += s) print x[k, i] > (d "/ref__" k ".dat"); continue }
        s = int((w + 299) / 300); if (s < 1) s = 1;
        for (i = 1; i <= w; i += s) print x[k, i] > (d "/early__" k ".dat");
        for (i = m - w + 1; i <= m; i += s) print x[k, i] > (d "/late__" k ".dat") } }' "$in/section_points.csv"
awk -F, -v d="$tmp" 'NR > 1 { print $3, $4, $5 > (d "/dist__" $1 "__" $2 ".dat") }' "$in/section_dist.csv"

lines() { # $1 prefix, $2 case, $3 using, $4 style
    first=1
    for m in $methods; do
        f="$tmp/$1__$2__$m.dat"
        [ -e "$f" ] || continue
        if [ $first = 1 ]; then printf 'plot '; first=0; else printf ', '; fi
        printf '"%s" using %s with %s title "%s"' "$f" "$3" "$4" "$m"
    done
    echo
}

for c in $(awk -F, 'NR > 1 { print $1 }' "$in/fput_modes.csv" | sort -u); do
    render "symplectic_fput_e1_$c" "1000,500" "set key outside right; set xlabel 't'; set ylabel 'E_1 / E'; set title 'FPUT beta chain, N = 16, $c: energy in mode 1'
$(lines e1 "$c" 1:2 lines)"
    render "symplectic_fput_modes_$c" "800,500" "set key outside right; set logscale y; set xlabel 'mode k'; set ylabel 'time-averaged E_k / E, t in [T/2, T]'; set title 'FPUT beta chain, N = 16, $c: time-averaged mode energies'
$(lines modes "$c" 1:2 linespoints)"
done

for o in $(awk -F, 'NR > 1 { print $1 }' "$in/section_dist.csv" | sort -u); do
    render "symplectic_dist_$o" "1000,550" "set key outside right; set logscale y; set format y '%.0e'; set xlabel 't'; set ylabel 'distance to the reference curve (median per bin)'; set title '$o: Poincare section points, distance from the reference curve (gauss4, small step)'
$(lines dist "$o" 1:2 linespoints)"
    panels=""
    for m in $methods; do
        e="$tmp/early__${o}__$m.dat"; l="$tmp/late__${o}__$m.dat"; r="$tmp/ref__${o}__reference.dat"
        [ -e "$e" ] || continue
        panels="$panels
set title '$m'
plot '$r' using 1:2 with dots lc rgb '#999999' title 'reference', '$e' using 1:2 with points pt 7 ps 0.25 lc rgb '#1f77b4' title 'first 10 % (at most 300 shown)', '$l' using 1:2 with points pt 7 ps 0.25 lc rgb '#d62728' title 'last 10 %'"
    done
    render "symplectic_section_$o" "1500,900" "set key top right font ',8'; set xlabel 'section coordinate 1 (x or q1)'; set ylabel 'px or p1'
set multiplot layout 2,3 title '$o: Poincare section, first and last 10 % of the points of each method'
$panels
unset multiplot"
done
echo "figures written to $out"
