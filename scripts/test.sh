#!/usr/bin/env bash
# Set up (packages, build) and run the whole test suite: the README's test command.
set -euo pipefail
cd "$(dirname "$0")/.."
bash scripts/setup.sh build
meson test -C build --print-errorlogs "$@"
