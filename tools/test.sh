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
# Not --quiet: clippy builds the dependencies first (about 3 minutes on 2 cores the first time),
# and the progress shows that something is happening.
echo "   (the first build compiles the dependencies: a few minutes; later builds are incremental)" >&2
cargo clippy --all-targets -- -D warnings
echo "== cargo test" >&2
# Library, binary and integration tests (examples are checked by clippy above); the closing
# line sums every test binary's results.
log=$(mktemp)
set +e
cargo test --no-fail-fast --lib --bins --tests "$@" 2>&1 | tee "$log"
status=${PIPESTATUS[0]}
set -e
awk '/^test result:/ { p += $4; f += $6 } END { printf "tests: %d passed, %d failed\n", p, f }' "$log"
rm -f "$log"
exit "$status"
