#!/usr/bin/env bash
# SPDX-License-Identifier: MIT
# The README's link lines, verbatim: dth built and installed into $HOME/.local of a temporary HOME
# (the README's prefix), then every ```sh block that follows a line "<!-- run by check-readme-link.sh -->"
# in README.md runs, in order, in one shell, in a folder holding a copy of docs/examples: the pkg-config
# path, the embedding example built against the installed library with and without an rpath, and run.
# Then the program built without rpath must fail to start without LD_LIBRARY_PATH (so the prefix is not
# one the dynamic linker searches anyway, and the rpath is what made the first build start).
# Usage: check-readme-link.sh SOURCE_ROOT
set -euo pipefail
src=$(cd "$1" && pwd)
tmp=$(mktemp -d "${TMPDIR:-/tmp}/dth-readme-link-XXXXXX")
trap 'rm -rf "$tmp"' EXIT
export HOME=$tmp/home
unset PKG_CONFIG_PATH LD_LIBRARY_PATH
mkdir -p "$HOME" "$tmp/work/docs"

# the library, its headers and dth.pc under $HOME/.local (nothing else is needed to link)
meson setup "$tmp/b" "$src" --prefix="$HOME/.local" -Dcli=false -Dtests=false -Dbench=false -Dfuzz=false \
    -Dpython=disabled >"$tmp/setup.log" 2>&1 || { cat "$tmp/setup.log"; exit 1; }
ninja -C "$tmp/b" >"$tmp/build.log" 2>&1 || { cat "$tmp/build.log"; exit 1; }
meson install -C "$tmp/b" --quiet >/dev/null

# the README's blocks
awk '/^<!-- run by check-readme-link.sh -->$/ { want = 1; next }
     want && /^```sh$/ { inside = 1; next }
     inside && /^```$/ { inside = 0; want = 0; n++; next }
     inside { print }
     END { if (n < 2) { print "check-readme-link: fewer than 2 marked sh blocks in README.md" > "/dev/stderr"; exit 1 } }' \
    "$src/README.md" >"$tmp/work/readme.sh"
cp -r "$src/docs/examples" "$tmp/work/docs/examples"
cd "$tmp/work"
echo "check-readme-link: running, in a folder with docs/examples, HOME=$HOME:"
sed 's/^/    /' readme.sh
bash -euo pipefail readme.sh || { echo "check-readme-link: the README's lines failed" >&2; exit 1; }
[ "$(wc -l <out/double-well.csv)" -gt 100 ] || { echo "check-readme-link: out/double-well.csv is short" >&2; exit 1; }
if out/embed docs/examples/double-well.ini >/dev/null 2>"$tmp/err"; then
    echo "check-readme-link: out/embed (no rpath) started without LD_LIBRARY_PATH: the test proves nothing" >&2
    exit 1
fi
grep -q 'libdth.so.0' "$tmp/err" || { cat "$tmp/err"; exit 1; }
echo "check-readme-link: the README's link lines built and ran the embedding example against $HOME/.local"
