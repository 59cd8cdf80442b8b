#!/usr/bin/env bash
# Set up (packages, build), integrate the default scene, write results and a plot into out/:
# the README's main command.
set -euo pipefail
cd "$(dirname "$0")/.."
bash scripts/setup.sh build
mkdir -p out
scene=${1:-scenes/pendulum.ini}
name=$(basename "$scene" .ini)
build/cli/dth run "$scene" -s output.diagnostics=yes -o "out/$name.csv"
bash scripts/plot.sh "out/$name.csv" "out/$name.png"
echo "wrote out/$name.csv and out/$name.png"
