#!/bin/sh
# SPDX-License-Identifier: MIT
# The plot scripts take the same arguments, the data first and the picture second
# (SCRIPT DATA OUT.png [TITLE]), and draw what they say: plot.sh for a pendulum (phase portrait)
# and a Kepler run (x-y orbit), plot-map.sh for a dth map, plot-poincare.sh for a section file;
# a missing argument is a usage error (exit 2); a rotation is wrapped, a long run thinned. Skipped
# (77) without gnuplot.
# usage: check_plots.sh PATH/TO/dth SOURCE_ROOT
set -u
DTH=$1
ROOT=$2
command -v gnuplot >/dev/null || exit 77
T=$(mktemp -d /tmp/dth_plot_test.XXXXXX)
trap 'rm -rf "$T"' EXIT
fails=0
fail() { echo "FAIL: $*" >&2; fails=$((fails + 1)); }
png() { [ -s "$1" ] && [ "$(head -c 4 "$1" | od -An -c | tr -d ' ')" = '211PNG' ]; }
"$DTH" run "$ROOT/scenes/pendulum.ini" -o "$T/p.csv" 2>/dev/null
sh "$ROOT/scripts/plot.sh" "$T/p.csv" "$T/p.png" "pendulum" && png "$T/p.png" || fail "plot.sh pendulum"
"$DTH" run "$ROOT/scenes/kepler-e06.ini" -s output.diagnostics=no -o "$T/k.csv" 2>/dev/null
sh "$ROOT/scripts/plot.sh" "$T/k.csv" "$T/k.png" && png "$T/k.png" || fail "plot.sh kepler"
"$DTH" map "$ROOT/scenes/pendulum-rotation.ini" --q -3:3:31 --p -3:3:31 --out "$T/m" -s regularize.method=none 2>/dev/null
sh "$ROOT/scripts/plot-map.sh" "$T/m.csv" "$T/m.png" "map" >/dev/null && png "$T/m.png" && [ -s "$T/m.svg" ] || fail "plot-map.sh"
printf 't,q2,p2,E\n1,0.1,0,0.08\n2,0.2,0.1,0.08\n3,0.1,0.2,0.08\n' >"$T/s.csv"
sh "$ROOT/scripts/plot-poincare.sh" "$T/s.csv" "$T/s.png" >/dev/null && png "$T/s.png" || fail "plot-poincare.sh"
# a rotation (issue 25): the rotating pendulum's q is wrapped in the orbit panel, and gnuplot has
# nothing to warn about (the unwrapped panel was flat: an extreme aspect ratio)
"$DTH" run "$ROOT/scenes/pendulum-rotation.ini" -s integrator.t_end=40 -o "$T/rot.csv" 2>/dev/null
sh "$ROOT/scripts/plot.sh" "$T/rot.csv" "$T/rot.png" 2>"$T/rot.err" && png "$T/rot.png" || fail "plot.sh rotation"
[ "$(cat "$T/rot.err")" = "plot.sh: q1 runs one way over more than 2 pi (a rotation): the orbit panel wraps it into [-pi, pi)" ] ||
    fail "plot.sh rotation: $(cat "$T/rot.err")"
# an oscillation is not wrapped, even one wider than 2 pi
"$DTH" run "$ROOT/scenes/harmonic.ini" -s initial.q=5,0 -o "$T/h.csv" 2>/dev/null
sh "$ROOT/scripts/plot.sh" "$T/h.csv" "$T/h.png" 2>"$T/h.err" && png "$T/h.png" && [ ! -s "$T/h.err" ] || fail "plot.sh harmonic: $(cat "$T/h.err")"
# a long run (issue 25: 1000 Kepler orbits were a solid block): thinned to every S-th row, said on stderr
"$DTH" run "$ROOT/scenes/kepler-e06.ini" -s output.diagnostics=no -s integrator.t_end=400 -o "$T/kl.csv" 2>/dev/null
rows=$(($(wc -l <"$T/kl.csv") - 1))
DTH_PLOT_ROWS=1000 sh "$ROOT/scripts/plot.sh" "$T/kl.csv" "$T/kl.png" 2>"$T/kl.err" && png "$T/kl.png" || fail "plot.sh long run"
[ "$(cat "$T/kl.err")" = "plot.sh: $rows rows: drawn as every $(((rows + 999) / 1000))-th row; the energy panel as each block's least and largest E - E0" ] ||
    fail "plot.sh long run: $(cat "$T/kl.err")"
for s in plot.sh plot-map.sh plot-poincare.sh; do
    sh "$ROOT/scripts/$s" "$T/p.csv" 2>/dev/null
    [ $? -eq 2 ] || fail "$s with one argument: not a usage error"
done
[ $fails -eq 0 ] && echo "plot scripts: same arguments, pictures written"
exit $((fails != 0))
