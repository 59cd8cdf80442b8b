#!/bin/sh
# SPDX-License-Identifier: MIT
# The user guide's key tables are the library's key table: every section dth keys lists has its
# block in docs/user-guide.md, and each block equals dth keys --markdown SECTION (keys-doc.sh
# --check); dth keys refuses an unknown section.
# usage: check_keys.sh PATH/TO/dth SOURCE_ROOT
set -u
DTH=$1
ROOT=$2
GUIDE=$ROOT/docs/user-guide.md
fails=0
fail() { echo "FAIL: $*" >&2; fails=$((fails + 1)); }
ok() { echo "ok: $*"; }

sections=$("$DTH" keys --markdown | sed -n 's/^\[\([a-z_]*\)\]$/\1/p')
[ -n "$sections" ] || fail "dth keys --markdown lists no sections"
for s in $sections; do
    grep -qx "<!-- keys $s -->" "$GUIDE" || fail "docs/user-guide.md has no <!-- keys $s --> block"
done
sh "$ROOT/scripts/keys-doc.sh" --check "$DTH" "$GUIDE" || fail "the guide's key tables differ from dth keys"
[ $fails -eq 0 ] && ok "the guide's key tables ($(echo $sections)) equal dth keys --markdown"

"$DTH" keys nosuch >/dev/null 2>&1
[ $? -eq 2 ] || fail "dth keys nosuch: want exit 2"
"$DTH" keys integrator | grep -q '^integrator.t_end ' || fail "dth keys integrator lacks t_end"

[ $fails -eq 0 ] || { echo "$fails failure(s)" >&2; exit 1; }
echo "all key checks passed"
