#!/usr/bin/env bash
# Builds the wheel (docs/wheel.md): `pip install` of it gives the `scm` command and the FMU binary
# it packs, with no Rust, compiler or apt on the user's machine.
#
#   scripts/wheel.sh [OUT_DIR]    # default target/wheels; prints the wheel's path last
#
# libscm.so is built, stripped of its symbol table (its exported fmi2* functions stay) and staged
# as target/wheel-stage/data/lib/scm/libscm.so; maturin (pyproject.toml, `bindings = "bin"`)
# builds the `scm` binary beside it in target/wheel-build (not target/release, which other
# programs may be running). Needs the venv of scripts/setup.sh (maturin is pinned in
# tests/python/requirements.txt).
set -euo pipefail
# OUT_DIR as the caller wrote it, relative to the caller's folder.
out=$(realpath -m "${1:-$(dirname "$0")/../target/wheels}")
cd "$(dirname "$0")/.."
if [ ! -x .venv/bin/maturin ]; then
  echo "wheel: .venv/bin/maturin is missing: run scripts/setup.sh first" >&2
  exit 1
fi
echo "wheel: building the release binaries (cargo build --release)" >&2
cargo build --release --locked -q
stage=target/wheel-stage
rm -rf "$stage"
mkdir -p "$stage/data/lib/scm"
cp target/release/libscm.so "$stage/data/lib/scm/libscm.so"
strip --strip-unneeded "$stage/data/lib/scm/libscm.so"
mkdir -p "$out"
echo "wheel: packing with maturin" >&2
# maturin builds the `scm` binary in a target folder of its own: building in target/release
# once relinked target/release/scm in place while a test was running it (CI, 2026-11-30). The
# folder starts as a copy of target/release, whose fingerprints match maturin's build, so cargo
# finds everything fresh (3 s, where a second compilation took 492 s of the suite on 2 cores);
# were maturin's flags to differ, cargo would rebuild in that folder only.
rm -rf target/wheel-build
mkdir -p target/wheel-build
cp -a target/release target/wheel-build/release
.venv/bin/maturin build --release --locked --quiet --target-dir target/wheel-build --out "$out" >&2
ls -t "$out"/scm_fmu-*.whl | head -1
