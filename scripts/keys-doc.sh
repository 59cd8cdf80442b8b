#!/bin/sh
# SPDX-License-Identifier: MIT
# The key tables of docs/user-guide.md, made from the library's table (dth keys --markdown SECTION):
# each block between "<!-- keys SECTION -->" and "<!-- /keys -->" is replaced by the generated one.
# usage: scripts/keys-doc.sh [--check] PATH/TO/dth [GUIDE]
#   rewrites GUIDE (default docs/user-guide.md next to this script) in place; with --check it only
#   compares, printing the difference and exiting 1 when the guide is out of date.
set -u
check=0
[ "${1:-}" = --check ] && { check=1; shift; }
[ $# -ge 1 ] || { echo "usage: $0 [--check] PATH/TO/dth [GUIDE]" >&2; exit 2; }
dth=$1
guide=${2:-$(dirname "$0")/../docs/user-guide.md}
new=$(mktemp)
trap 'rm -f "$new"' EXIT
# awk runs `dth keys --markdown SECTION` for each block (the path passed through the environment)
DTH_KEYS_BIN=$dth awk '
    function q(s) { gsub(/\047/, "\047\\\047\047", s); return "\047" s "\047" }
    skip && /^<!-- \/keys -->$/ { skip = 0 }
    skip { next }
    { print }
    /^<!-- keys [a-z_]+ -->$/ {
        sec = $3; blocks++
        cmd = q(ENVIRON["DTH_KEYS_BIN"]) " keys --markdown " sec
        n = 0
        while ((cmd | getline line) > 0) { print line; n++ }
        if (close(cmd) != 0 || n == 0) { print "keys-doc: " cmd " failed" > "/dev/stderr"; bad = 1 }
        skip = 1
    }
    END {
        if (skip) { print "keys-doc: a <!-- keys --> block without <!-- /keys -->" > "/dev/stderr"; bad = 1 }
        if (!blocks) { print "keys-doc: no <!-- keys SECTION --> block" > "/dev/stderr"; bad = 1 }
        exit bad
    }' "$guide" >"$new" || exit 1
if [ $check -eq 1 ]; then
    diff -u "$guide" "$new" && echo "keys-doc: $guide matches dth keys" && exit 0
    echo "keys-doc: $guide differs from dth keys --markdown: run scripts/keys-doc.sh $dth" >&2
    exit 1
fi
cmp -s "$guide" "$new" || cat "$new" >"$guide"
