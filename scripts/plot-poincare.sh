#!/bin/sh
# SPDX-License-Identifier: MIT
# Poincare section plot with gnuplot: the points (q2, p2) where an orbit crosses q1 = 0 upward, as
# written by docs/examples/poincare.c ("t,q2,p2,E" rows, one file per orbit).
# usage: scripts/plot-poincare.sh SECTION.csv... OUT.png [TITLE]   (data first, the picture last,
#            as plot.sh and plot-map.sh; also writes OUT.svg)
#        scripts/plot-poincare.sh --figure BUILDDIR
#            runs BUILDDIR/docs/examples/example_poincare on docs/examples/henon-heiles.ini and on
#            five more orbits of the same energy E = 1/12, and regenerates
#            docs/figures/henon-heiles-section.png and .svg
set -eu
root=$(cd "$(dirname "$0")/.." && pwd)
command -v gnuplot >/dev/null || { echo "plot-poincare.sh: gnuplot is not installed" >&2; exit 1; }
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
if [ "${1:-}" = "--figure" ]; then
    [ $# -eq 2 ] || { echo "usage: $0 --figure BUILDDIR" >&2; exit 2; }
    prog=$2/docs/examples/example_poincare
    [ -x "$prog" ] || { echo "$0: no $prog (build first: ninja -C $2)" >&2; exit 2; }
    scene=$root/docs/examples/henon-heiles.ini
    set --
    i=0
    # orbits on the section q1 = 0 with p2 = 0 and p1 > 0 from the energy 1/12
    for q2 in 0.1 -0.3 -0.15 0.3 0.42 0.2; do
        p1=$(awk -v y="$q2" 'BEGIN { printf "%.17g", sqrt(2 * (1 / 12 - (y * y / 2 - y * y * y / 3))) }')
        "$prog" "$scene" -s "initial.q=0,$q2" -s "initial.p=$p1,0" >"$tmp/orbit$i.csv"
        set -- "$@" "$tmp/orbit$i.csv"
        i=$((i + 1))
    done
    set -- "$@" "$root/docs/figures/henon-heiles-section.png" "Henon-Heiles, E = 1/12: Poincare section q1 = 0 (p1 > 0), DTH h = 0.05, t = 2000 per orbit"
fi
[ $# -ge 2 ] || { echo "usage: $0 SECTION.csv... OUT.png [TITLE] | $0 --figure BUILDDIR" >&2; exit 2; }
# the arguments: data files, then OUT.png, then an optional title (not ending in .png)
title=
eval "last=\${$#}"
case $last in *.png) ;; *) title=$last; set -- $(i=1; for a in "$@"; do [ $i -lt $# ] && printf '%s\n' "$a"; i=$((i + 1)); done) ;; esac
eval "png=\${$#}"
files=$(i=1; for a in "$@"; do [ $i -lt $# ] && printf '%s ' "$a"; i=$((i + 1)); done)
[ -n "$title" ] || title="Poincare section"
plot=
k=0
for f in $files; do
    [ -r "$f" ] || { echo "plot-poincare.sh: cannot read '$f'" >&2; exit 1; }
    [ $k -eq 0 ] && style="pt 7 ps 0.45 lc rgb '#c0001a' title 'the scene orbit'" || style="pt 7 ps 0.25 lc rgb '#1f4e9a' notitle"
    plot="$plot${plot:+, }'$f' using 2:3 every ::1 with points $style"
    k=$((k + 1))
done
svg=${png%.png}.svg
for term in png svg; do
    if [ $term = png ]; then
        if gnuplot -e 'set terminal pngcairo' >/dev/null 2>&1; then t="pngcairo noenhanced size 900,800 font 'sans,11'"; else t="png noenhanced size 900,800"; fi
        out=$png
    else
        t="svg noenhanced size 900,800 font 'sans,11'"
        out=$svg
    fi
    gnuplot <<GP
set terminal $t
set output '$out'
set datafile separator ','
set title '$title'
set xlabel 'q2'
set ylabel 'p2'
set size ratio -1
set grid
set key top right
plot $plot
GP
done
echo "wrote $png and $svg"
