# SPDX-License-Identifier: MIT
# Sourced by scripts/plot-wp.sh and scripts/plot-symplectic.sh (not run by itself): their common
# set-up and gnuplot driver.
#   plot_init [CSV_DIR [FIG_DIR]]  sets in (default bench-out) and out (default docs/figures; created),
#                                  and tmp, a temporary folder removed when the script exits
#   render NAME SIZE COMMANDS      writes $out/NAME.png (pngcairo) and $out/NAME.svg at SIZE ("W,H")
#                                  from the gnuplot COMMANDS, with a grid
plot_init() {
    in=${1:-bench-out}
    out=${2:-docs/figures}
    command -v gnuplot >/dev/null || { echo "$0: gnuplot not found" >&2; exit 2; }
    mkdir -p "$out"
    tmp=$(mktemp -d)
    trap 'rm -rf "$tmp"' EXIT
}

render() {
    for term in png svg; do
        if [ "$term" = png ]; then t="pngcairo size $2"; else t="svg size $2"; fi
        gnuplot <<EOF2
set terminal $t
set output "$out/$1.$term"
set grid
$3
EOF2
    done
}
