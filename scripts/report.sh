#!/usr/bin/env bash
# The report (issue 7): error against run time, stability maps, force profile and planar pushing
# side by side with MuJoCo, derivative cost and the speed targets, written to reports/ as Markdown
# and PNG. Installs its own environment from nothing:
#   - scripts/setup.sh (Debian packages, .venv, release build), valgrind for the profiles;
#   - .venv-report: the packages of tests/python/requirements.txt plus scripts/report/requirements.txt
#     (the pinned mujoco from PyPI, tqdm); the test venv has the same mujoco, as the oracle of the MJCF tests;
#   - the benches it runs: examples/report_host.rs (an FMI host over the crate's C ABI) and
#     examples/step_cost.rs (step, fmi2DoStep, Jacobian timings).
# Then packs the FMUs it needs and runs every study. Arguments go to the report:
#   scripts/report.sh                 # full run into reports/ (resumable: results are cached in out/report-work/)
#   scripts/report.sh --quick --out /tmp/r   # every study on a small grid, a few minutes
#   scripts/report.sh --only pushing,stability
set -euo pipefail
cd "$(dirname "$0")/.."
scripts/setup.sh
if ! command -v valgrind >/dev/null 2>&1; then
  echo "report: installing valgrind (profiles)"
  SUDO=""; [ "$(id -u)" -ne 0 ] && SUDO=sudo
  $SUDO apt-get update -qq && DEBIAN_FRONTEND=noninteractive $SUDO apt-get install -y -qq valgrind >/dev/null
fi
if [ ! -x .venv-report/bin/python ] || ! .venv-report/bin/python -c "import fmpy, numpy, matplotlib, mujoco, tqdm, scipy, distributed" 2>/dev/null; then
  echo "report: creating .venv-report"
  python3 -m venv .venv-report
  .venv-report/bin/pip install -q --upgrade pip
  .venv-report/bin/pip install -q -r tests/python/requirements.txt -r scripts/report/requirements.txt
fi
echo "report: building the report's hosts (cargo build --release)"
cargo build --release -q --example report_host --example step_cost
PYTHONPATH=scripts exec .venv-report/bin/python -m report "$@"
