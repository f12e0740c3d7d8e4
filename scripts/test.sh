#!/usr/bin/env bash
# Every test: the lint gates (rustfmt, clippy, rustdoc), Rust unit, integration and doc tests
# (cargo test), then the FMUs in fmpy and the other hosts (pytest, one worker per core; a
# module whose tests share one costly fixture runs on one worker: its `xdist_group` mark). The
# slowest tests' times end the log.
set -euo pipefail
cd "$(dirname "$0")/.."
scripts/setup.sh
scripts/lint.sh
cargo test --release
.venv/bin/python -m pytest -q -n auto --dist loadgroup --durations=20 tests/python
