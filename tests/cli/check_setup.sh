#!/bin/sh
# SPDX-License-Identifier: MIT
# scripts/setup.sh reconfigures an existing build directory: a fresh one is configured and built
# (with -Dtests=false -Dbench=false, to keep the build short), a second run with --prefix=DIR
# reconfigures it (meson introspect shows the new prefix, the first run's options stay), and a third
# run without options keeps all of it and succeeds. The build directory is a temporary one, never
# the checkout's `build` (the one the other tests run from). The package check of setup.sh
# must find everything installed: if it would install packages (apt-get, sudo), the test is skipped.
# usage: check_setup.sh SOURCE_ROOT
set -u
SRC=$1
T=$(mktemp -d "${TMPDIR:-/tmp}/dth-setup-XXXXXX")
trap 'rm -rf "$T"' EXIT
fails=0
fail() { echo "FAIL: $*" >&2; fails=$((fails + 1)); }
f0=0
ok() { [ $fails -eq $f0 ] && echo "ok: $*"; f0=$fails; } # only if the block since the last ok passed
command -v python3 >/dev/null 2>&1 || { echo "no python3 (for meson introspect's JSON): skipped"; exit 77; }

# no package is installed from a test: apt-get and sudo stop setup.sh with exit 77 (skipped)
mkdir "$T/shim"
for p in apt-get sudo; do
    printf '#!/bin/sh\necho "check_setup: setup.sh would install packages ($0 $*): skipped" >&2\nexit 77\n' >"$T/shim/$p"
    chmod +x "$T/shim/$p"
done
PATH=$T/shim:$PATH
export PATH

B=$T/b
# setup [ARGS...]: run scripts/setup.sh on $B; its output goes to $T/log
setup() {
    DTH_SETUP_QUIET=1 bash "$SRC/scripts/setup.sh" "$B" "$@" >"$T/log" 2>&1
    rc=$?
    [ $rc -eq 77 ] && { cat "$T/log"; exit 77; }
    return $rc
}
# option NAME: its value in $B (meson introspect --buildoptions)
option() {
    meson introspect "$B" --buildoptions |
        python3 -c 'import json, sys; print(*[o["value"] for o in json.load(sys.stdin) if o["name"] == sys.argv[1]])' "$1"
}

setup -Dtests=false -Dbench=false || { fail "first run (configure and build): $(cat "$T/log")"; exit 1; }
[ -f "$B/build.ninja" ] && [ -e "$B/libdth.so" ] || fail "first run: no build.ninja or libdth.so in $B"
first_prefix=$(option prefix)
ok "a fresh build directory is configured and built (prefix $first_prefix)"

setup --prefix="$T/inst" || fail "second run (--prefix): $(cat "$T/log")"
[ "$(option prefix)" = "$T/inst" ] || fail "second run: prefix is '$(option prefix)', want '$T/inst'"
[ "$(option bench)" = False ] && [ "$(option tests)" = False ] ||
    fail "second run: the first run's options are lost (bench '$(option bench)', tests '$(option tests)')"
ok "setup.sh --prefix=DIR reconfigures the existing build directory"

setup || fail "third run (no options): $(cat "$T/log")"
[ "$(option prefix)" = "$T/inst" ] || fail "third run: prefix is '$(option prefix)', want '$T/inst' kept"
[ "$(option bench)" = False ] || fail "third run: bench is '$(option bench)', want False kept"
ok "setup.sh without options keeps the configuration"

[ $fails -eq 0 ] && echo "check_setup: all passed"
[ $fails -eq 0 ]
