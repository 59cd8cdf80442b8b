#!/bin/sh
# SPDX-License-Identifier: MIT
# Every bad scene under tests/cli/ (bad_*.ini) is refused by dth run with exit status exactly 2 (a
# crash or a hard error is not a refusal) and one line on stderr, "dth: FILE:LINE: KEY: reason",
# beginning with the text of the scene's first line "; expect: NAME.ini:LINE: ..." (NAME.ini as
# given on the command line); nothing on stdout, no output file, no temporary left.
# usage: check_bad.sh PATH/TO/dth SOURCE_ROOT
set -u
DTH=$1
BAD=$2/tests/cli
T=$(mktemp -d /tmp/dth_bad_test.XXXXXX)
trap 'rm -rf "$T"' EXIT
fails=0
n=0
fail() { echo "FAIL: $*" >&2; fails=$((fails + 1)); }
for f in "$BAD"/bad_*.ini; do
    name=$(basename "$f")
    want=$(sed -n '1s/^; expect: //p' "$f")
    case $want in
        "$name":[0-9]*:\ *) ;;
        *) fail "$name: its first line is not '; expect: $name:LINE: ...'"; continue ;;
    esac
    # -o would replace a bad [output] file=; elsewhere it checks that no output file appears
    if grep -q '^file' "$f"; then o=; else o="-o $T/bad.csv"; fi
    "$DTH" run "$f" $o >"$T/bad.out" 2>"$T/bad.err"
    rc=$?
    n=$((n + 1))
    [ $rc -eq 2 ] || fail "$name: exit $rc, want 2 ($(cat "$T/bad.err"))"
    [ "$(wc -l <"$T/bad.err")" -eq 1 ] || fail "$name: stderr is not one line: $(cat "$T/bad.err")"
    # the message starts with the file as given, its line and (where one is at fault) the key
    msg=$(cat "$T/bad.err")
    case $msg in
        "dth: $BAD/$want"*) ;;
        *) fail "$name: message '$msg' does not start with 'dth: $BAD/$want'" ;;
    esac
    [ -s "$T/bad.out" ] && fail "$name: wrote to stdout"
    [ -e "$T/bad.csv" ] && fail "$name: left an output file"
    [ -z "$(ls "$T" | grep '\.tmp\.')" ] || fail "$name: left a temporary file"
done
[ $n -ge 14 ] || fail "only $n bad scenes found in $BAD"
[ $fails -eq 0 ] && echo "$n bad scenes: exit 2, one line naming FILE:LINE"
exit $((fails != 0))
