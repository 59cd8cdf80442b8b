#!/bin/sh
# SPDX-License-Identifier: MIT
# Plot a `dth run` CSV with gnuplot: q_i and p_i against t (left) and the phase portraits
# p_i against q_i (right). Uses the pngcairo terminal, or the libgd png terminal without cairo.
# usage: scripts/plot.sh TRAJECTORY.csv OUT.png [TITLE]
set -eu
if [ $# -lt 2 ] || [ $# -gt 3 ]; then
    echo "usage: $0 TRAJECTORY.csv OUT.png [TITLE]" >&2
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
# degrees of freedom: the number of q<digits> columns
n=$(printf '%s\n' "$header" | tr ',' '\n' | grep -c '^q[0-9][0-9]*$')
if [ "$(wc -l <"$csv")" -lt 2 ]; then
    echo "plot.sh: '$csv' has no rows" >&2
    exit 1
fi
if gnuplot -e 'set terminal pngcairo' >/dev/null 2>&1; then
    term="pngcairo size 1200,500 noenhanced font 'sans,10'"
else
    term="png size 1200,500 noenhanced"
fi
# column of q_i is 3 + i, of p_i is 3 + n + i
gnuplot <<EOF
set terminal $term
set output '$png'
set datafile separator ','
set key top right font ',8'
set multiplot layout 1,2 title '$title'
set xlabel 't'
set ylabel 'q, p'
set grid
set autoscale xfix
plot for [i=1:$n] '$csv' using 2:(column(3 + i)) every ::1 with lines title sprintf('q%d', i), \\
     for [i=1:$n] '$csv' using 2:(column(3 + $n + i)) every ::1 with lines dashtype 2 title sprintf('p%d', i)
set xlabel 'q'
set ylabel 'p'
set size ratio -1
set autoscale x
plot for [i=1:$n] '$csv' using (column(3 + i)):(column(3 + $n + i)) every ::1 with lines title sprintf('p%d vs q%d', i, i)
unset multiplot
EOF
