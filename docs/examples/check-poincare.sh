#!/bin/sh
# SPDX-License-Identifier: MIT
# The Poincare section q1 = 0 (upward) of a regular Henon-Heiles orbit at E = 1/12 is one closed
# curve: its points, ordered by angle around their centroid, leave no angular gap wider than
# 0.3 rad and their distance to the centroid changes by less than 5 % between neighbours; the
# energy at the section points (dense output, whose energy error is that of the vertices,
# about |psi| h^2/8) stays within 1.5e-4 of 1/12.
# usage: check-poincare.sh POINCARE SCENE
set -u
T=$(mktemp -d /tmp/dth_poincare.XXXXXX)
trap 'rm -rf "$T"' EXIT
"$1" "$2" >"$T/sec.csv" 2>"$T/err" || { echo "FAIL: poincare: $(cat "$T/err")"; exit 1; }
cat "$T/err"
n=$(($(wc -l <"$T/sec.csv") - 1))
[ $n -ge 200 ] || { echo "FAIL: only $n section points"; exit 1; }
awk -F, 'NR > 1 { x[NR] = $2; y[NR] = $3; cx += $2; cy += $3; m++; e = $4 - 1 / 12; if (e < 0) e = -e; if (e > de) de = e }
    END { cx /= m; cy /= m
          for (i in x) print atan2(y[i] - cy, x[i] - cx), sqrt((x[i] - cx)^2 + (y[i] - cy)^2)
          print "E", de > "/dev/stderr" }' "$T/sec.csv" 2>"$T/de" | sort -g >"$T/polar"
awk 'NR == 1 { a0 = $1; r0 = $2 } NR > 1 { g = $1 - a; if (g > gap) gap = g; d = ($2 - r) / r; if (d < 0) d = -d; if (d > dr) dr = d }
    { a = $1; r = $2 }
    END { g = a0 + 2 * 3.141592653589793 - a; if (g > gap) gap = g
          d = (r0 - r) / r; if (d < 0) d = -d; if (d > dr) dr = d
          printf "section: %d points, largest angular gap %.3f rad, largest radius jump %.3f\n", NR, gap, dr
          exit !(gap < 0.3 && dr < 0.05) }' "$T/polar" || { echo "FAIL: the section is not one closed curve"; exit 1; }
de=$(cut -d' ' -f2 "$T/de")
awk -v d="$de" 'BEGIN { printf "max |E - 1/12| at the section points: %.2e\n", d; exit !(d < 1.5e-4) }' ||
    { echo "FAIL: energy at the section points"; exit 1; }
echo "ok: a closed invariant curve"
