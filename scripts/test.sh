#!/usr/bin/env bash
# Every test: Rust unit and integration tests (cargo test), then the FMUs in fmpy (pytest).
set -euo pipefail
cd "$(dirname "$0")/.."
scripts/setup.sh
cargo test --release
.venv/bin/python -m pytest -q tests/python
