#!/usr/bin/env bash
# Quick start 2: install what is missing and run the whole test suite (unit, integration and
# GPU tests under the Khronos validation layer on lavapipe), plus format and lint checks.
set -euo pipefail
cd "$(dirname "$0")/.."
tools/setup.sh
. tools/env.sh
echo "== cargo fmt --check" >&2
cargo fmt --all -- --check
echo "== cargo clippy --all-targets -- -D warnings" >&2
cargo clippy --quiet --all-targets -- -D warnings
echo "== cargo test" >&2
cargo test --all-targets "$@"
