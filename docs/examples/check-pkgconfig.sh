#!/usr/bin/env bash
# Build the embedding example against an *installed* dth through pkg-config, as another project
# would, and run it. Usage: check-pkgconfig.sh BUILDDIR SRCDIR [SANITIZERS]
# (SANITIZERS: the build's b_sanitize, e.g. address,undefined; the consumer is compiled with them)
set -euo pipefail
build=$(cd "$1" && pwd)
src=$(cd "$2" && pwd)
san=()
[ -n "${3:-}" ] && [ "${3:-}" != none ] && san=(-fsanitize="$3")
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
meson install -C "$build" --destdir "$tmp/root" --no-rebuild --quiet >/dev/null
pcdir=$(dirname "$(find "$tmp/root" -name dth.pc | head -n 1)")
# the install carries the plot scripts, the documentation with its figures, and the examples
for f in share/dth/scripts/plot.sh share/dth/scripts/plot-map.sh share/dth/scripts/plot-poincare.sh \
         share/doc/dth/user-guide.md share/doc/dth/figures/henon-heiles-section.png share/doc/dth/examples/embed.c \
         share/doc/dth/examples/poincare.c share/dth/scenes/pendulum.ini include/dth/run.h include/dth/version.h; do
    [ -n "$(find "$tmp/root" -path "*/$f" | head -n 1)" ] || { echo "check-pkgconfig: $f not installed" >&2; exit 1; }
done
export PKG_CONFIG_PATH="$pcdir" PKG_CONFIG_SYSROOT_DIR="$tmp/root"
cc -std=c11 -Wall -Wextra -Wpedantic -Werror "${san[@]}" "$src/docs/examples/embed.c" "$src/docs/examples/double_well.c" \
   -I"$src/docs/examples" $(pkg-config --cflags dth) $(pkg-config --libs dth) -o "$tmp/embed"
libdir=$(pkg-config --variable=libdir dth)
# pkgconf already prefixes the sysroot to libdir (the run used to sit in this comment: it never ran)
LD_LIBRARY_PATH="$libdir" "$tmp/embed" "$src/docs/examples/double-well.ini" >/dev/null
echo "check-pkgconfig: embed built against the installed dth and ran; scripts, docs and examples installed"
