#!/bin/sh
# SPDX-License-Identifier: MIT
# The embedding example and `dth run` both use the library's run driver: on the same scene they
# write the same bytes (midpoint rows, vertex rows, output times; to t_end and for N steps).
# usage: check-embed.sh EMBED DTH SOURCE_ROOT
set -u
EMBED=$1
DTH=$2
SC=$3/scenes
T=$(mktemp -d /tmp/dth_embed_test.XXXXXX)
trap 'rm -rf "$T"' EXIT
fails=0
check() { # name scene overrides...
    name=$1 scene=$2
    shift 2
    "$EMBED" "$SC/$scene" "$@" >"$T/$name-embed.csv" 2>"$T/$name.err" || { echo "FAIL: $name: embed: $(cat "$T/$name.err")"; fails=$((fails + 1)); }
    "$DTH" run "$SC/$scene" "$@" >"$T/$name-cli.csv" 2>>"$T/$name.err" || { echo "FAIL: $name: dth run"; fails=$((fails + 1)); }
    if cmp -s "$T/$name-embed.csv" "$T/$name-cli.csv" && [ "$(wc -l <"$T/$name-cli.csv")" -gt 10 ]; then
        echo "ok: $name ($(wc -l <"$T/$name-cli.csv") lines identical)"
    else
        echo "FAIL: $name: embed and dth run differ"
        fails=$((fails + 1))
    fi
}
check pendulum-midpoints pendulum.ini
check pendulum-vertices pendulum.ini -s output.points=vertices -s output.every=3
check pendulum-times pendulum.ini -s output.dt=0.3
check kepler-steps kepler-e06.ini -s output.diagnostics=no -s integrator.steps=500 -s output.points=vertices
check kepler-times kepler-e06.ini -s output.diagnostics=no -s integrator.t_end=12.345 -s output.dt=0.1
[ $fails -eq 0 ] && echo "embed and dth run write the same bytes"
exit $((fails != 0))
