#!/bin/sh
# SPDX-License-Identifier: MIT
# Plot a `dth run` CSV with gnuplot, three panels: q_i and p_i against t; the orbit (p against q
# for one degree of freedom, else the x-y orbit of each body: (q1, q2), (q3, q4), ... for planar
# models such as Kepler or a 2-D coupled chain, with --dim D for D coordinates per body); and the
# energy error E - E0 against t (E = H_phys: round-off on midpoint rows, the vertex offset
# psi h^2/8 on vertex rows). Uses the pngcairo terminal, or the libgd png terminal without cairo.
# usage: scripts/plot.sh [--dim D] TRAJECTORY.csv OUT.png [TITLE]
#        (all plot scripts take the data first and the picture second: plot-map.sh, plot-poincare.sh)
set -eu
dim=
if [ "${1:-}" = "--dim" ]; then
    [ $# -ge 2 ] || { echo "usage: $0 [--dim D] TRAJECTORY.csv OUT.png [TITLE]" >&2; exit 2; }
    dim=$2
    shift 2
    case $dim in 1 | 2 | 3) ;; *) echo "plot.sh: --dim must be 1, 2 or 3" >&2; exit 2 ;; esac
fi
if [ $# -lt 2 ] || [ $# -gt 3 ]; then
    echo "usage: $0 [--dim D] TRAJECTORY.csv OUT.png [TITLE]" >&2
    exit 2
fi
csv=$1
png=$2
title=${3:-$(basename "$csv")}
command -v gnuplot >/dev/null || { echo "plot.sh: gnuplot is not installed" >&2; exit 1; }
[ -r "$csv" ] || { echo "plot.sh: cannot read '$csv'" >&2; exit 1; }
header=$(head -1 "$csv")
case "$header" in
k,t,lambda,q1,*) ;;
*) echo "plot.sh: '$csv' is not a dth run CSV (header: $header)" >&2; exit 1 ;;
esac
# degrees of freedom: the number of q<digits> columns; the E column (absent in older files)
n=$(printf '%s\n' "$header" | tr ',' '\n' | grep -c '^q[0-9][0-9]*$')
ecol=$(printf '%s\n' "$header" | tr ',' '\n' | grep -n '^E$' | cut -d: -f1)
if [ "$(wc -l <"$csv")" -lt 2 ]; then
    echo "plot.sh: '$csv' has no rows" >&2
    exit 1
fi
# bodies in the orbit panel: planar when n is even (Kepler 2-D, 2-D chains), unless --dim says
[ -n "$dim" ] || { if [ "$n" -ge 2 ] && [ $((n % 2)) -eq 0 ]; then dim=2; else dim=1; fi; }
[ $((n % dim)) -eq 0 ] || { echo "plot.sh: $n coordinates are not a multiple of --dim $dim" >&2; exit 2; }
bodies=$((n / dim))
if gnuplot -e 'set terminal pngcairo' >/dev/null 2>&1; then
    term="pngcairo size 1650,500 noenhanced font 'sans,10'"
else
    term="png size 1650,500 noenhanced"
fi
e0=
[ -n "$ecol" ] && e0=$(sed -n 2p "$csv" | cut -d, -f"$ecol")
if [ "$dim" -eq 1 ]; then
    orbit="set xlabel 'q'; set ylabel 'p'
plot for [i=1:$n] '$csv' using (column(3 + i)):(column(3 + $n + i)) every ::1 with lines title sprintf('p%d vs q%d', i, i)"
else
    orbit="set xlabel 'x (q1, q$((dim + 1)), ...)'; set ylabel 'y (q2, q$((dim + 2)), ...)'
plot for [b=0:$((bodies - 1))] '$csv' using (column(4 + $dim * b)):(column(5 + $dim * b)) every ::1 with lines title sprintf('body %d', b + 1)"
fi
if [ -n "$ecol" ]; then
    energy="set xlabel 't'; set ylabel 'E - E0'; set size noratio; set autoscale
set format y '%.1e'
plot '$csv' using 2:(column($ecol) - ($e0)) every ::1 with lines lc rgb '#c0001a' title sprintf('E - E0 (E0 = %s)', '$e0')"
else
    energy="set label 1 'no E column' at graph 0.4, 0.5; plot NaN notitle"
fi
gnuplot <<EOF
set terminal $term
set output '$png'
set datafile separator ','
set key top right font ',8'
set multiplot layout 1,3 title '$title'
set xlabel 't'
set ylabel 'q, p'
set grid
set autoscale xfix
plot for [i=1:$n] '$csv' using 2:(column(3 + i)) every ::1 with lines title sprintf('q%d', i), \\
     for [i=1:$n] '$csv' using 2:(column(3 + $n + i)) every ::1 with lines dashtype 2 title sprintf('p%d', i)
set size ratio -1
set autoscale x
$orbit
$energy
unset multiplot
EOF
