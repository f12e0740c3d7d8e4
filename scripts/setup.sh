#!/usr/bin/env bash
# Installs what the build and the tests need, from nothing, and builds the release binaries:
#   - Debian: libclang-dev (bindgen in the fmi-sys dev-dependency), gcc, make and libc6-dev (the
#     C host tests compile tests/c_host/cs_host.c and examples/c/push.c), python3 with venv;
#   - Python: a venv in .venv with the pinned packages of tests/python/requirements.txt
#     (fmpy, numpy, pytest with pytest-xdist, matplotlib, libcosimpy, scipy, and mujoco with gymnasium as the oracle of the
#     MJCF differential tests, maturin (scripts/wheel.sh) and dask.distributed (examples/dask):
#     all wheels, no compiler needed);
#   - the MJCF files of dm_control (its suite, walkers, props; from its wheel, unpacked in
#     .venv/dm_control_assets)
#     and gymnasium-robotics' models (from its wheel, in .venv/gymnasium_robotics_assets),
#     robosuite's robots and grippers (from its wheel, in .venv/robosuite_assets);
#   - cargo build --release: target/release/scm (CLI) and target/release/libscm.so (FMU binary).
# Idempotent: a second run only checks (the venv is refreshed when requirements.txt changes).
set -euo pipefail
cd "$(dirname "$0")/.."

if ! command -v cargo >/dev/null 2>&1; then
  echo "setup: cargo is not on PATH: install Rust (rustup, https://rustup.rs) first" >&2
  exit 1
fi

need_apt=()
dpkg -s libclang-dev >/dev/null 2>&1 || need_apt+=(libclang-dev)
command -v gcc >/dev/null 2>&1 || need_apt+=(gcc)
command -v make >/dev/null 2>&1 || need_apt+=(make)
command -v strip >/dev/null 2>&1 || need_apt+=(binutils)
dpkg -s libc6-dev >/dev/null 2>&1 || need_apt+=(libc6-dev)
command -v python3 >/dev/null 2>&1 || need_apt+=(python3)
python3 -c "import ensurepip, venv" >/dev/null 2>&1 || need_apt+=(python3-venv)
if [ ${#need_apt[@]} -gt 0 ]; then
  echo "setup: installing ${need_apt[*]}"
  SUDO=""; [ "$(id -u)" -ne 0 ] && SUDO=sudo
  $SUDO apt-get update -qq
  DEBIAN_FRONTEND=noninteractive $SUDO apt-get install -y -qq "${need_apt[@]}" >/dev/null
fi

# The venv records the requirements it was made from; a change reinstalls.
if [ ! -x .venv/bin/python ] || ! cmp -s tests/python/requirements.txt .venv/requirements.txt \
   || ! .venv/bin/python -c "import fmpy, numpy, pytest, xdist, matplotlib, libcosimpy, mujoco, gymnasium, scipy, distributed" 2>/dev/null \
   || [ ! -x .venv/bin/maturin ]; then
  echo "setup: creating .venv"
  python3 -m venv .venv
  .venv/bin/pip install -q --upgrade pip
  .venv/bin/pip install -q -r tests/python/requirements.txt
  cp tests/python/requirements.txt .venv/requirements.txt
fi

# The MJCF corpora of the differential tests beyond gymnasium's: only the model files (and
# meshes) of a package's wheel, unpacked, not installed (dm_control pins a MuJoCo of its own,
# and the tests need no code of either). Once per pinned version.
wheel_files() { # SPEC DIR PREFIX: the files under PREFIX (no Python) of SPEC's wheel, in DIR
  local spec=$1 dir=$2 prefix=$3 tmp
  if [ "$(cat "$dir/.version" 2>/dev/null)" != "$spec $prefix" ]; then
    echo "setup: fetching the MJCF files of $spec"
    tmp=$(mktemp -d)
    .venv/bin/pip download -q --no-deps "$spec" -d "$tmp"
    rm -rf "$dir"
    .venv/bin/python - "$tmp"/*.whl "$dir" "$prefix" <<'PY'
import sys, zipfile
wheel, out, prefix = sys.argv[1:4]
with zipfile.ZipFile(wheel) as z:
    for n in z.namelist():
        if n.startswith(prefix) and not n.endswith(".py"):
            z.extract(n, out)
PY
    echo "$spec $prefix" > "$dir/.version"
    rm -rf "$tmp"
  fi
}
# dm_control's suite (a second corpus) and gymnasium-robotics' models (hands, Fetch, the
# Franka kitchen: a third).
wheel_files dm_control==1.0.50 .venv/dm_control_assets dm_control/
wheel_files gymnasium-robotics==1.4.2 .venv/gymnasium_robotics_assets gymnasium_robotics/envs/assets/
# robosuite's robots and grippers (dense CAD collision meshes: the peak-memory tests).
wheel_files robosuite==1.5.2 .venv/robosuite_assets robosuite/models/assets/

echo "setup: building the release binaries (cargo build --release: a few minutes on a fresh machine)"
cargo build --release --locked -q
echo "setup: done"
