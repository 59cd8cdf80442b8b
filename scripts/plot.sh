#!/bin/sh
# SPDX-License-Identifier: MIT
# Plot a `dth run` CSV with gnuplot, three panels: q_i and p_i against t; the orbit (p against q
# for one degree of freedom, else the x-y orbit of each body: (q1, q2), (q3, q4), ... for planar
# models such as Kepler or a 2-D coupled chain, with --dim D for D coordinates per body); and the
# energy error E - E0 against t (E = H_phys: round-off on midpoint rows, the vertex offset
# psi h^2/8 on vertex rows). Uses the pngcairo terminal, or the libgd png terminal without cairo.
# Rotations: with one coordinate per body, a q that runs one way over more than 2 pi (a rotating
# pendulum) is an angle, wrapped into [-pi, pi) in the orbit panel (its line broken at each wrap).
# Long runs (more than DTH_PLOT_ROWS rows, default 5000) are thinned: every S-th row, as points; the
# energy panel as the least and largest E - E0 of each block of S rows (no spike is lost); a note
# on stderr says so. The keys sit below the panels, clear of the curves.
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
    term="pngcairo size 1650,560 noenhanced font 'sans,10'"
else
    term="png size 1650,560 noenhanced"
fi
tmp=$(mktemp -d /tmp/dth_plot.XXXXXX)
trap 'rm -rf "$tmp"' EXIT
e0=
[ -n "$ecol" ] && e0=$(sed -n 2p "$csv" | cut -d, -f"$ecol")
# rotations: 1 per q column that runs one way over more than 2 pi (with one coordinate per body)
wrap=$(awk -F, -v n="$n" -v dim="$dim" '
    NR == 2 { for (i = 1; i <= n; i++) { f[i] = p[i] = $(3 + i); up[i] = dn[i] = 1 } }
    NR > 2 { for (i = 1; i <= n; i++) { x = $(3 + i); if (x < p[i]) up[i] = 0; if (x > p[i]) dn[i] = 0; p[i] = x } }
    END { pi = atan2(0, -1)
          for (i = 1; i <= n; i++) { d = p[i] - f[i]; if (d < 0) d = -d; printf "%d ", (dim == 1 && (up[i] || dn[i]) && d > 2 * pi) } }' "$csv")
i=1
for w in $wrap; do
    [ "$w" = 1 ] && echo "plot.sh: q$i runs one way over more than 2 pi (a rotation): the orbit panel wraps it into [-pi, pi)" >&2
    i=$((i + 1))
done
# long runs: every S-th row (and the last), and the energy's least and largest value in each block
rows=$(($(wc -l <"$csv") - 1))
limit=${DTH_PLOT_ROWS:-5000}
step=$(((rows + limit - 1) / limit))
data=$csv style="with lines" thin=
if [ "$step" -gt 1 ]; then
    data=$tmp/rows.csv style="with points pt 7 ps 0.2"
    awk -v s="$step" 'NR == 1 || (NR - 2) % s == 0 { print; next } { last = $0 } END { if ((NR - 2) % s) print last }' \
        "$csv" >"$data"
    thin=" (every $step-th of $rows rows)"
    echo "plot.sh: $rows rows: drawn as every $step-th row; the energy panel as each block's least and largest E - E0" >&2
fi
if [ "$dim" -eq 1 ]; then
    # a phase portrait: q and p keep their own scales; a rotation's q wrapped, its line broken there
    orbit="set xlabel 'q'; set ylabel 'p'; set size noratio
wrapped(x) = x - 2 * pi * floor((x + pi) / (2 * pi))
W = '$wrap'
pw = 0
x(i) = word(W, i) eq '1' ? (w = wrapped(column(3 + i)), jump = abs(w - pw) > pi, pw = w, jump ? NaN : w) : column(3 + i)
plot for [i=1:$n] '$data' using (x(i)):(column(3 + $n + i)) every ::1 $style title sprintf('p%d vs q%d', i, i)"
else
    orbit="set xlabel 'x (q1, q$((dim + 1)), ...)'; set ylabel 'y (q2, q$((dim + 2)), ...)'; set size ratio -1
plot for [b=0:$((bodies - 1))] '$data' using (column(4 + $dim * b)):(column(5 + $dim * b)) every ::1 $style title sprintf('body %d', b + 1)"
fi
if [ -n "$ecol" ] && [ -n "$thin" ]; then
    edata=$tmp/energy.csv
    awk -F, -v s="$step" -v c="$ecol" -v e0="$e0" '
        function flush() { if (tlo <= thi) { print tlo "," lo; print thi "," hi } else { print thi "," hi; print tlo "," lo } }
        NR == 1 { next }
        { j = (NR - 2) % s; e = $c - e0; if (!j || e < lo) { lo = e; tlo = $2 } if (!j || e > hi) { hi = e; thi = $2 }
          if (j == s - 1) flush() }
        END { if ((NR - 2) % s != 0) flush() }' "$csv" >"$edata"
    eplot="'$edata' using 1:2 with lines"
elif [ -n "$ecol" ]; then
    eplot="'$csv' using 2:(column($ecol) - ($e0)) every ::1 with lines"
fi
if [ -n "$ecol" ]; then
    energy="set xlabel 't'; set ylabel 'E - E0'; set size noratio; set autoscale
set format y '%.1e'
plot $eplot lc rgb '#c0001a' title sprintf('E - E0 (E0 = %s)', '$e0')"
else
    energy="set label 1 'no E column' at graph 0.4, 0.5; plot NaN notitle"
fi
gnuplot <<EOF
set terminal $term
set output '$png'
set datafile separator ','
set key outside below center horizontal font ',8'
set multiplot layout 1,3 title '$title$thin'
set xlabel 't'
set ylabel 'q, p'
set grid
set autoscale xfix
plot for [i=1:$n] '$data' using 2:(column(3 + i)) every ::1 $style title sprintf('q%d', i), \\
     for [i=1:$n] '$data' using 2:(column(3 + $n + i)) every ::1 $style dashtype 2 title sprintf('p%d', i)
set autoscale x
$orbit
$energy
unset multiplot
EOF
