#!/usr/bin/env bash
# Regenerates the regression references tests/reference/<scene>.csv (all scenes, or the ones
# named) from the current build: run it only after a change of behaviour you meant, then
# review the differences and commit the CSVs. See tests/python/references.py.
set -euo pipefail
cd "$(dirname "$0")/.."
scripts/setup.sh
.venv/bin/python tests/python/references.py "$@"
