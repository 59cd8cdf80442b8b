#!/bin/sh
# SPDX-License-Identifier: MIT
# Phase-plane well-posedness map like the paper's Figure 1 (section 1; regions of section 5), drawn
# with gnuplot from the files `dth map SCENE --out PREFIX` writes (PREFIX.csv and PREFIX-traj.csv):
# regions I / II shaded, the curves psi = 0 (region III) and [psi, H] = 0, and the scene's DTH
# trajectory with its end point marked. Writes OUT.png and OUT.svg.
# usage: scripts/plot-map.sh MAP.csv OUT.png [TITLE]
#            (MAP-traj.csv beside MAP.csv; the data first and the picture second, as plot.sh)
#        scripts/plot-map.sh --figure BUILDDIR
#            runs BUILDDIR/cli/dth map on scenes/pendulum-rotation.ini (raw DTH) and regenerates
#            docs/figures/map-pendulum.{png,svg}
set -eu
root=$(cd "$(dirname "$0")/.." && pwd)
usage="usage: $0 MAP.csv OUT.png [TITLE] | $0 --figure BUILDDIR"
command -v gnuplot >/dev/null || { echo "$0: gnuplot not found" >&2; exit 2; }
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
h=
L=
if [ "${1:-}" = "--figure" ]; then
    [ $# -eq 2 ] || { echo "$usage" >&2; exit 2; }
    dth=$2/cli/dth
    [ -x "$dth" ] || { echo "$0: no dth executable at $dth (build first: ninja -C $2)" >&2; exit 2; }
    scene=$root/scenes/pendulum-rotation.ini
    fig=$root/docs/figures/map-pendulum
    data=$tmp/map
    # One thread unless told otherwise: with Debian's pthread OpenBLAS every LAPACK call takes a
    # global lock (blas_memory_alloc), and the map's tiny factorizations from two threads run slower.
    OMP_NUM_THREADS=${OMP_NUM_THREADS:-1} "$dth" map "$scene" --out "$data" --q -3.6:3.6:361 --p -3.2:3.2:321 \
        -s regularize.method=none
    h=$(awk -F= '/^[ \t]*h[ \t]*=/ { v = $2; sub(/;.*/, "", v); gsub(/[ \t]/, "", v) } END { print v }' "$scene")
    L=$(awk -v h="$h" 'BEGIN { print 16 * (h < 0 ? -h : h) }')
    title="$(basename "$scene"): well-posedness of the DTH step at each (q, p) taken as a vertex (h = $h)"
else
    [ $# -ge 2 ] && [ $# -le 3 ] || { echo "$usage" >&2; exit 2; }
    data=${1%.csv}
    case $2 in *.png) fig=${2%.png} ;; *) echo "$usage" >&2; exit 2 ;; esac
    title=${3:-$(basename "$1")}
    [ -r "$data.csv" ] && [ -r "$data-traj.csv" ] || { echo "$0: need $data.csv and $data-traj.csv (dth map --out $data)" >&2; exit 1; }
fi

# grid for gnuplot: "q p psi dpsi code", one block per q value (region code 0 "-", 1 I, 2 II, 3 III,
# 4 root search failed), and the trajectory's last row (where it ended, and why)
awk -F, 'NR == 1 { next }
    $1 != last && NR > 2 { print "" }
    { last = $1
      code = $5 == "I" ? 1 : $5 == "II" ? 2 : $5 == "III" ? 3 : $5 == "-" ? 0 : 4
      print $1, $2, ($3 == "" ? "NaN" : $3), ($4 == "" ? "NaN" : $4), code }' "$data.csv" >"$tmp/grid.dat"
awk -F, 'NR > 1 { print $3, $4 }' "$data-traj.csv" >"$tmp/traj.dat"
tail -1 "$data-traj.csv" | awk -F, '{ print $3, $4, "\"" ($6 == "t_end" || $6 == "steps" || $6 == "limit" ? "end" : "stop: " $6) "\"" }' >"$tmp/end.dat"
if [ -n "$L" ]; then kest="(K estimated on |lambda| <= $L)"; else kest="(K as dth map estimated it)"; fi

# the two zero sets as gnuplot contour lines
gnuplot <<EOF
set contour base
unset surface
set cntrparam levels discrete 0
set table "$tmp/psi0.dat"
splot "$tmp/grid.dat" using 1:2:3 with lines
set table "$tmp/dpsi0.dat"
splot "$tmp/grid.dat" using 1:2:4 with lines
unset table
EOF

for term in png svg; do
    if [ $term = png ]; then t='pngcairo noenhanced size 1100,760 font "sans,12"'; else t='svg noenhanced size 1100,760 font "sans,12"'; fi
    gnuplot <<EOF
set terminal $t
set output "$fig.$term"
set title "$title"
set xlabel "q"
set ylabel "p"
set size ratio -1
set key outside right top vertical box opaque spacing 1.3
stats "$tmp/grid.dat" using 1:2 nooutput
set xrange [STATS_min_x:STATS_max_x]
set yrange [STATS_min_y:STATS_max_y]
set cbrange [-0.5:4.5]
set palette maxcolors 5
set palette defined (0 "#9e9e9e", 1 "#e8f1fa", 2 "#fdd8a8", 3 "#d7301f", 4 "#404040")
unset colorbox
set style fill solid 1.0 noborder
set label 1 "vertex offset psi h^2/8 at every point\nregion I: [psi,H]^2 <= 24 K |psi|, II: >\n$kest\ncircle: where the trajectory ends" at screen 0.705, screen 0.68 left font "sans,11"
plot "$tmp/grid.dat" using 1:2:5 with image notitle, \
     NaN with boxes fc rgb "#e8f1fa" title "region I", \
     NaN with boxes fc rgb "#fdd8a8" title "region II", \
     "$tmp/psi0.dat" using 1:2 with lines lw 2.5 lc rgb "#c0001a" title "psi = 0 (region III)", \
     "$tmp/dpsi0.dat" using 1:2 with lines lw 1.5 dt 2 lc rgb "#1f4e9a" title "[psi, H] = 0", \
     "$tmp/traj.dat" using 1:2 with linespoints lw 1.5 pt 7 ps 0.5 lc rgb "black" title "DTH trajectory (vertices)", \
     "$tmp/end.dat" using 1:2 with points pt 6 ps 2.5 lw 2 lc rgb "black" notitle, \
     "$tmp/end.dat" using 1:2:3 with labels left offset 1.6,0.4 font "sans,11" notitle
EOF
done
echo "wrote $fig.png and $fig.svg"
