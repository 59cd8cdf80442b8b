#!/bin/sh
# SPDX-License-Identifier: MIT
# HDF5 output of dth run: the same run written as CSV and as HDF5 holds the same values, bit for
# bit (h5cmp reads both: a dataset per column, enum types for region, branch and event), for the
# trajectory (with diagnostics) and the events; the file carries the scene and the provenance; a
# failed run leaves no file; checkpoints refuse HDF5. With a Python that has h5py, the layout reads
# in one line each (h5py.File(out)['q1'][:], the enum names).
# usage: check_hdf5.sh PATH/TO/dth PATH/TO/h5cmp SOURCE_ROOT [PYTHON_WITH_H5PY]
set -u
DTH=$1
H5CMP=$2
SC=$3/scenes
PY=${4:-}
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
if [ -n "$PY" ]; then
    "$PY" - "$T/sub/kepler-e06.h5" "$T/kepler-e06.csv" "$T/kepler-e06-events.csv" <<'PYEOF' || fail "h5py reading"
import sys, h5py, numpy as np
f = h5py.File(sys.argv[1], "r")
csv = np.genfromtxt(sys.argv[2], delimiter=",", names=True, dtype=None, encoding="ascii")
cols = f.attrs["columns"].decode().split(",")
assert cols == list(csv.dtype.names), (cols, csv.dtype.names)
assert np.array_equal(f["q1"][:], csv["q1"]), "q1"                # one line per column
assert f["k"].dtype == np.int64 and np.array_equal(f["k"][:], csv["k"]), "k"
names = {v: k for k, v in h5py.check_enum_dtype(f["region"].dtype).items()}
assert [names[c] for c in f["region"][:]] == list(csv["region"]), "region names"
assert h5py.check_enum_dtype(f["branch"].dtype) == {"-": 0, "minus": 1, "plus": 2, "ghost": 3, "exact": 4, "reg": 5}
ev = np.genfromtxt(sys.argv[3], delimiter=",", names=True, dtype=None, encoding="ascii")
assert np.array_equal(f["events/t"][:], ev["t"]) and h5py.check_enum_dtype(f["events/event"].dtype) == {"section": 0, "distance": 1}
print("h5py: %d rows, columns %s; %d events" % (len(f["q1"]), ",".join(cols[:4]) + ",...", len(f["events/t"])))
PYEOF
fi
[ $fails -eq 0 ] && echo "HDF5 and CSV hold the same values"
exit $((fails != 0))
