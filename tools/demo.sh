#!/usr/bin/env bash
# Quick start 1: install what is missing, build, and render the built-in demo scene headless.
# Usage: tools/demo.sh [OUTPUT_DIR]   (default: tiltfield-demo)
set -euo pipefail
cd "$(dirname "$0")/.."
tools/setup.sh
. tools/env.sh
# Build in a step of its own with cargo's progress visible: on a fresh machine the first build
# compiles every dependency and would otherwise look like a hang.
echo "demo: building tiltfield in $CARGO_TARGET_DIR (the first build takes 3 to 7 minutes on" \
  "2 cores; later builds take seconds)" >&2
cargo build --bin tiltfield
echo "demo: rendering the built-in demo scene" >&2
"$CARGO_TARGET_DIR/debug/tiltfield" demo -o "${1:-tiltfield-demo}"
# The interactive window needs a display; say how to open it rather than failing on a server.
echo "demo: for the interactive viewer run: $CARGO_TARGET_DIR/debug/tiltfield view" \
  "(on a machine without a display: xvfb-run -a … view --script FILE)" >&2
