# Sourced by the tools/ scripts: one fixed cargo target directory, so the first build (a few
# minutes on 2 cores) is reused by every later build, test and CI run.
export CARGO_TARGET_DIR="${CARGO_TARGET_DIR:-$HOME/.cache/tiltfield/target}"
export PATH="$HOME/.cargo/bin:$PATH"
mkdir -p "$CARGO_TARGET_DIR"
