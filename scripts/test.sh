#!/usr/bin/env bash
# Every test: the lint gates (rustfmt, clippy, rustdoc), Rust unit, integration and doc tests
# (cargo test), then the FMUs in fmpy and the other hosts (pytest).
set -euo pipefail
cd "$(dirname "$0")/.."
scripts/setup.sh
scripts/lint.sh
cargo test --release
.venv/bin/python -m pytest -q tests/python
