#!/usr/bin/env bash
# The main job: build the FMUs of every bundled scene into out/fmus/, simulate sphere_drop in
# fmpy, and write its results (out/sphere_drop.csv) and a plot of height and contact force
# (out/sphere_drop.png).
set -euo pipefail
cd "$(dirname "$0")/.."
scripts/setup.sh
mkdir -p out/fmus
for scene in resources/scenes/*.xml; do
  name=$(basename "$scene" .xml)
  target/release/scm pack "$scene" -o "out/fmus/$name.fmu"
done
.venv/bin/python scripts/simulate_sphere_drop.py out/fmus/sphere_drop.fmu out/sphere_drop.csv out/sphere_drop.png
