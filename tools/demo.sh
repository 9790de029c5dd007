#!/usr/bin/env bash
# Quick start 1: install what is missing, build, and render the built-in demo scene headless.
# Usage: tools/demo.sh [OUTPUT_DIR]   (default: tiltfield-demo)
set -euo pipefail
cd "$(dirname "$0")/.."
tools/setup.sh
. tools/env.sh
cargo run --quiet --bin tiltfield -- demo -o "${1:-tiltfield-demo}"
