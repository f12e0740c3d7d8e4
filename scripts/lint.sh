#!/usr/bin/env bash
# The Rust habits, as gates: formatting (rustfmt), lints (clippy, warnings denied, every target)
# and the API documentation (rustdoc, warnings denied: broken or redundant links fail).
# Doc examples run with the tests (`cargo test --release` runs them).
set -euo pipefail
cd "$(dirname "$0")/.."

for tool in fmt clippy; do
  if ! cargo "$tool" --version >/dev/null 2>&1; then
    component=$([ "$tool" = fmt ] && echo rustfmt || echo clippy)
    if command -v rustup >/dev/null 2>&1; then
      echo "lint: installing the $component component"
      rustup component add "$component"
    else
      echo "lint: cargo $tool is missing and rustup is not on PATH: install the $component component" >&2
      exit 1
    fi
  fi
done

echo "lint: cargo fmt --check"
cargo fmt --check
echo "lint: cargo clippy --all-targets -- -D warnings"
cargo clippy --release --all-targets --locked -q -- -D warnings
echo "lint: cargo doc (warnings denied)"
RUSTDOCFLAGS="-D warnings" cargo doc --release --no-deps --locked -q
echo "lint: the engine, loader and simulation without features (no fmi2* symbols, no clap)"
cargo clippy --release --lib --no-default-features --locked -q -- -D warnings
