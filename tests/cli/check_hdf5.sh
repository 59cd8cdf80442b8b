#!/bin/sh
# SPDX-License-Identifier: MIT
# HDF5 output of dth run: the same run written as CSV and as HDF5 holds the same doubles, bit for
# bit (h5cmp reads both), for the trajectory (with diagnostics) and the events; the file carries
# the scene and the provenance; a failed run leaves no file; checkpoints refuse HDF5.
# usage: check_hdf5.sh PATH/TO/dth PATH/TO/h5cmp SOURCE_ROOT
set -u
DTH=$1
H5CMP=$2
SC=$3/scenes
T=$(mktemp -d /tmp/dth_h5_test.XXXXXX)
trap 'rm -rf "$T"' EXIT
fails=0
fail() { echo "FAIL: $*" >&2; fails=$((fails + 1)); }
for s in "pendulum.ini -s output.diagnostics=yes" "kepler-e06.ini -s events.section=q2 -s events.distance=1.2" \
         "harmonic.ini -s output.dt=0.1 -s output.diagnostics=yes" "pendulum-rotation-prescribed.ini -s integrator.t_end=5"; do
    set -- $s
    name=$(basename "$1" .ini)
    "$DTH" run "$SC/$@" -o "$T/$name.csv" 2>/dev/null || fail "$name: CSV run"
    "$DTH" run "$SC/$@" -o "$T/sub/$name.h5" 2>"$T/err" || fail "$name: HDF5 run: $(cat "$T/err")"
    "$H5CMP" "$T/sub/$name.h5" trajectory "$T/$name.csv" || fail "$name: trajectory differs"
    case "$s" in
        *events.*) [ -f "$T/$name-events.csv" ] || fail "$name: no events CSV ($name-events.csv)" ;;
    esac
    if [ -f "$T/$name-events.csv" ]; then
        "$H5CMP" "$T/sub/$name.h5" events "$T/$name-events.csv" || fail "$name: events differ"
    fi
done
[ -z "$(ls "$T/sub" | grep '\.tmp\.')" ] || fail "temporary file left"
"$DTH" run "$SC/pendulum.ini" -o "$T/x.h5" --checkpoint "$T/x.ckpt" 2>"$T/err"
[ $? -eq 2 ] && grep -q "checkpoints cover CSV output only" "$T/err" || fail "checkpoint with HDF5: $(cat "$T/err")"
"$DTH" run "$SC/pendulum-rotation.ini" -s regularize.method=none -o "$T/rot.h5" 2>/dev/null
[ $? -eq 3 ] && [ -s "$T/rot.h5" ] || fail "a stopped run keeps its HDF5 file"
[ $fails -eq 0 ] && echo "HDF5 and CSV hold the same doubles"
exit $((fails != 0))
