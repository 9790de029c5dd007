#!/usr/bin/env bash
# The Python release set: one wheel built by `pip wheel .`, abi3 (CPython 3.8 and every later version), tagged
# manylinux by maturin's own audit (the lowest manylinux_2_N the module's glibc symbols allow;
# it links only glibc, libm and libgcc_s, and loads Vulkan at run time). Then checks the wheel:
# its tag, the type stubs and py.typed inside, and that it installs into a fresh virtual
# environment and renders there (with Debian's python3-numpy, numpy 1.24, when installed).
#   tools/wheel.sh [OUT_DIR]     (default dist/)
# The build shows cargo's progress; the first one compiles every dependency in release
# (see README, Python), later ones only what changed.
set -euo pipefail
cd "$(dirname "$0")/.."
. tools/env.sh
out="${1:-dist}"
venv="${TILTFIELD_VENV:-$HOME/.cache/tiltfield/python-venv}"
[ -x "$venv/bin/maturin" ] || { echo "wheel: no maturin in $venv (tools/test.sh makes it)" >&2; exit 1; }
mkdir -p "$out"

# `pip wheel .`, as a user builds it (pyproject.toml and its backend, tools/pep517), with the
# build's progress shown (-v). No build isolation: maturin comes from the venv, so no index is
# needed.
echo "== pip wheel . -v" >&2
start=$(date +%s)
PATH="$venv/bin:$PATH" "$venv/bin/pip" wheel . --no-deps --no-build-isolation -v -w "$out" >&2
echo "   built in $(( $(date +%s) - start )) s" >&2

wheel=$(ls -t "$out"/tiltfield-*.whl | head -n 1)
case "$(basename "$wheel")" in
  *-cp38-abi3-manylinux_*_x86_64.whl|*-cp38-abi3-manylinux_*_aarch64.whl) ;;
  *) echo "wheel: $wheel is not an abi3 manylinux wheel" >&2; exit 1 ;;
esac
for f in tiltfield/__init__.py tiltfield/_tiltfield.pyi tiltfield/py.typed tiltfield/_tiltfield.abi3.so; do
  "$venv/bin/python" - "$wheel" "$f" <<'PY' || { echo "wheel: $f missing from $wheel" >&2; exit 1; }
import sys, zipfile
sys.exit(0 if sys.argv[2] in zipfile.ZipFile(sys.argv[1]).namelist() else 1)
PY
done

echo "== installing into a fresh virtual environment" >&2
fresh=$(mktemp -d)
trap 'rm -rf "$fresh"' EXIT
/usr/bin/python3 -m venv --system-site-packages "$fresh/v"
start=$(date +%s%N)
"$fresh/v/bin/pip" install --quiet --no-deps --no-index "$wheel"
echo "   installed in $(( ($(date +%s%N) - start) / 1000000 )) ms" >&2
if "$fresh/v/bin/python" -c "import numpy" 2>/dev/null; then
  "$fresh/v/bin/python" -m tiltfield >&2
  "$fresh/v/bin/python" -c 'import tiltfield; assert tiltfield.open("builtin:planes").refocus(disparity=0.5).shape == (64, 64, 4)'
else
  echo "   (no numpy for $(/usr/bin/python3 -V): the import test is skipped; apt-get install python3-numpy)" >&2
fi
echo "$wheel"
