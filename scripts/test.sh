#!/usr/bin/env bash
# Every test: the lint gates (rustfmt, clippy, rustdoc), Rust unit, integration and doc tests
# (cargo test), then the FMUs in fmpy and the other hosts (pytest, one worker per core; a
# module whose tests share one costly fixture runs on one worker: its `xdist_group` mark). The
# slowest tests' times end the log. CI runs this.
#
#   scripts/test.sh           # the whole suite (CI; under 45 minutes on 2 cores)
#   scripts/test.sh --quick   # the inner loop: rustfmt, the tests but the slow ones (scripts/lint.sh
#                             # runs clippy and rustdoc)
#
# The quick tier leaves out the Rust tests below (each over 20 s) and the Python tests marked
# `slow` (tests/python/conftest.py says which and why); CI runs them all.
set -euo pipefail
cd "$(dirname "$0")/.."
quick=false
if [ $# -gt 1 ]; then echo "usage: scripts/test.sh [--quick]" >&2; exit 2; fi
case "${1:-}" in
  --quick) quick=true ;;
  "") ;;
  *) echo "usage: scripts/test.sh [--quick]" >&2; exit 2 ;;
esac
if $quick; then
  # Incremental release builds: after an edit, only the changed code is compiled again (about
  # 2 minutes of the tier's rebuild saved; the same code, so the same results). CI builds afresh.
  export CARGO_INCREMENTAL=1
fi
scripts/setup.sh
if $quick; then
  cargo fmt --check
  # 10⁵ steps of t_push (about a minute), 10⁴ random FMI call sequences, two fine pruned-vs-naive pairs.
  # The examples are not built here (about 25 s of the rebuild after an engine edit): clippy
  # and the full suite build them, and no quick test runs one.
  cargo test --release --lib --bins --tests -- --skip long_run::t_push \
    --skip fmi_fuzz::random_call_sequences --skip geometry_pruning::pruned_pair_with_fine \
    --skip geometry_pruning::pruned_pair_with_a_fine
  cargo test --release --doc
  .venv/bin/python -m pytest -q -n auto --dist loadgroup --durations=10 -m "not slow" tests/python
else
  scripts/lint.sh
  cargo test --release
  .venv/bin/python -m pytest -q -n auto --dist loadgroup --durations=20 tests/python
fi
