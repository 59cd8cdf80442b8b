#!/bin/sh
# SPDX-License-Identifier: MIT
# Issue 21: no function in cli/ is longer than 120 lines (a function body starts with '{' in column 1,
# the project's style, and ends with '}' in column 1). Exits 1 naming each longer one.
# usage: check_funclen.sh SOURCE_ROOT [LIMIT]
set -u
root=$1
limit=${2:-120}
awk -v lim="$limit" '
    FNR == 1 { inbody = 0 }
    /^[A-Za-z_].*\(/ && !/;[ \t]*$/ { head = $0; headline = FNR }
    /^\{/ && !inbody { inbody = 1; start = headline; name = head }
    /^\}/ && inbody { inbody = 0; n = FNR - start + 1; seen++
        if (n > lim) { printf "%s:%d: %d lines (limit %d): %s\n", FILENAME, start, n, lim, name; bad = 1 } }
    END { if (seen < 50) { print "only " seen " functions found: the scan is broken"; bad = 1 }
          if (!bad) print seen " functions in cli/, none longer than " lim " lines"; exit bad }' "$root"/cli/*.c
