#!/usr/bin/env bash
# Step cost against MuJoCo in one run (issue 20): every bundled scene and generated ones
# (bodies out of reach, 2/8/32 resting boxes), SCM through the FMU's C ABI, MuJoCo's mj_step on
# the same file. Writes reports/bench.md and reports/bench.png (or --out DIR).
#   scripts/bench.sh [--out DIR] [--boxes 2,8,32]
set -euo pipefail
cd "$(dirname "$0")/.."
scripts/setup.sh
cargo build --release -q --bin scm --example step_cost
exec .venv/bin/python scripts/bench.py "$@"
