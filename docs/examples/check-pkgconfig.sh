#!/usr/bin/env bash
# Build the embedding example against an *installed* dth through pkg-config, as another project
# would, and run it. Usage: check-pkgconfig.sh BUILDDIR SRCDIR
set -euo pipefail
build=$(cd "$1" && pwd)
src=$(cd "$2" && pwd)
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
meson install -C "$build" --destdir "$tmp/root" --no-rebuild --quiet >/dev/null
pcdir=$(dirname "$(find "$tmp/root" -name dth.pc | head -n 1)")
export PKG_CONFIG_PATH="$pcdir" PKG_CONFIG_SYSROOT_DIR="$tmp/root"
cc -std=c11 -Wall -Wextra -Wpedantic -Werror "$src/docs/examples/embed.c" "$src/docs/examples/double_well.c" \
   -I"$src/docs/examples" $(pkg-config --cflags dth) $(pkg-config --libs dth) -lm -o "$tmp/embed"
libdir=$(pkg-config --variable=libdir dth)
LD_LIBRARY_PATH="$libdir"  # pkgconf already prefixes the sysroot "$tmp/embed" "$src/docs/examples/double-well.ini"
