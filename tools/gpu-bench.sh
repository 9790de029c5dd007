#!/usr/bin/env bash
# What to run on a GPU server to measure tiltfield there: the strategy calibration, the
# strategies with and without anti-aliasing (the ladder), the compute shader's pixels per
# invocation, the full bench (JSON, CSV, SVG/PNG charts), depth estimation times and the
# anti-aliasing test set, into one folder per device (docs/bench/gpu/DEVICE/ by default).
#
#   tools/gpu-bench.sh [OUTDIR] [--quick]
#
# TILTFIELD names the binary (default: `tiltfield` on PATH, else this checkout's release or
# debug build). Light fields are made on the machine with `synth` (81 views of 512², the
# figures the README quotes), so no data has to travel. Each step is capped by `timeout` and
# logged; a failed step is recorded and the rest still run. About 3 minutes on an NVIDIA H200.
# --quick: 5×5 views of 96², a dry run of every step in well under a minute on a CPU driver.
set -u
here=$(cd "$(dirname "$0")/.." && pwd)
out=""; quick=""
for a in "$@"; do
  case "$a" in
    --quick) quick=1 ;;
    -h|--help) sed -n '2,13p' "$0"; exit 0 ;;
    *) out=$a ;;
  esac
done
T=${TILTFIELD:-}
if [ -z "$T" ]; then
  T=$(command -v tiltfield || true)
  for c in "${CARGO_TARGET_DIR:-$HOME/.cache/tiltfield/target}"/release/tiltfield \
           "${CARGO_TARGET_DIR:-$HOME/.cache/tiltfield/target}"/debug/tiltfield; do
    [ -z "$T" ] && [ -x "$c" ] && T=$c
  done
fi
[ -x "$T" ] || { echo "no tiltfield binary: set TILTFIELD=/path/to/tiltfield" >&2; exit 2; }

device=$(timeout 60 "$T" devices 2>/dev/null | head -1 | sed 's/^[0-9]*: //; s/ \[.*//')
[ -n "$device" ] || { echo "no usable Vulkan device ('$T devices' printed nothing)" >&2; exit 1; }
slug=$(echo "$device" | tr -c 'A-Za-z0-9\n' '-' | sed 's/--*/-/g; s/^-//; s/-$//')
out=${out:-$here/docs/bench/gpu/$slug}
mkdir -p "$out"
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
log=$out/log.txt
: >"$log"
if [ -n "$quick" ]; then grid=5x5; size=96x96; frames=5; bench_frames=(--quick); else
  grid=9x9; size=512x512; frames=50; bench_frames=(--frames 50); fi

step() { echo "== $(date +%T) $*" | tee -a "$log" >&2; }
# run SECONDS OUTFILE CMD...: stdout to OUTFILE, stderr to the log; status and wall time logged.
run() {
  local t=$1 o=$2; shift 2
  local s; s=$(date +%s%N)
  timeout "$t" "$@" >"$o" 2>>"$log"
  local rc=$?
  echo "rc=$rc wall_ms=$(( ($(date +%s%N) - s) / 1000000 )) :: $*" >>"$log"
  return $rc
}

step "device: $device ($T)"
run 60 "$out/devices.txt" "$T" devices
command -v nvidia-smi >/dev/null && nvidia-smi -L >>"$out/devices.txt" 2>/dev/null

step "calibrating --strategy auto"
run 120 "$out/calibration.json" "$T" devices --calibrate --json

step "synth demo $grid $size"
lf=$work/lf
run 300 /dev/null "$T" synth builtin:demo --out "$lf" --grid "$grid" --size "$size"

# The ladder: every strategy (and auto) × plain, anti-aliased (default) and defocused views.
ladder=$out/ladder.jsonl
: >"$ladder"
for strategy in auto fragment compute batched:16; do
  for aa in off on defocus; do
    case $aa in
      off) flags=(--antialias off) ;;
      on) flags=(--antialias on) ;;
      defocus) flags=(--antialias on --antialias-defocus on) ;;
    esac
    step "render --strategy $strategy, anti-aliasing $aa"
    if run 300 "$work/r.json" "$T" render "$lf" -o "$work/r.png" --disparity 0.5 \
        --strategy "$strategy" "${flags[@]}" --repeat "$frames" --json; then
      printf '{"strategy":"%s","antialias":"%s","render":%s}\n' "$strategy" "$aa" \
        "$(cat "$work/r.json")" >>"$ladder"
    fi
  done
done
# The compute shader's shapes (tools/gpu_bench_summary.py tabulates them): output pixels per
# invocation of the plain sum (0: the per-pixel loop), views per loop iteration, workgroup
# shape, and the view storage (linear16 is render's default; srgb8 halves the bytes read).
for shape in "0 1 8x8 linear16" "1 1 8x8 linear16" "2 1 8x8 linear16" "4 1 8x8 linear16" \
             "1 2 8x8 linear16" "1 4 8x8 linear16" "1 8 8x8 linear16" "2 4 8x8 linear16" \
             "1 4 16x16 linear16" "1 4 32x8 linear16" "1 4 16x8 linear16" "1 4 32x4 linear16" \
             "1 1 8x8 srgb8" "1 4 8x8 srgb8" "1 4 16x16 srgb8"; do
  read -r px un tile storage <<<"$shape"
  step "render --strategy compute, plain: $px pixels, $un views per iteration, $tile, $storage"
  if TILTFIELD_COMPUTE_PIXELS=$px TILTFIELD_COMPUTE_UNROLL=$un TILTFIELD_COMPUTE_TILE=$tile \
      run 300 "$work/r.json" "$T" render "$lf" -o "$work/r.png" --disparity 0.5 \
      --strategy compute --antialias off --storage "$storage" --repeat "$frames" --json; then
    printf '{"strategy":"compute","antialias":"off","compute_shape":"%s","render":%s}\n' \
      "$shape" "$(cat "$work/r.json")" >>"$ladder"
  fi
done

step "bench (every variant, the scaling sweep, the anti-aliasing study)"
run 600 "$out/bench-stdout.json" "$T" bench "$lf" --disparity 0.5 "${bench_frames[@]}" \
  --out "$out/bench" --json

step "depth (three runs, each with an empty cache)"
for i in 1 2 3; do
  RUST_LOG=info TILTFIELD_CACHE_DIR=$work/depth-cache-$i run 300 "$out/depth-$i.json" "$T" depth "$lf" \
    -o "$work/depth.pfm" --json
done

step "antialias-set"
if [ -n "$quick" ]; then set_size=(--size 48); else set_size=(); fi
run 600 "$out/antialias-set.json" "$T" antialias-set "${set_size[@]}" --json \
  --markdown "$out/antialias-set.md"
run 600 "$out/antialias-set-defocus.json" "$T" antialias-set "${set_size[@]}" --json \
  --antialias-defocus on --markdown "$out/antialias-set-defocus.md"

step "summary"
if command -v python3 >/dev/null; then
  python3 "$here/tools/gpu_bench_summary.py" "$out" >"$out/summary.md" 2>>"$log" \
    && cat "$out/summary.md"
else
  echo "python3 not found: summary.md not written (the JSON files hold every figure)" | tee -a "$log"
fi
step "done: $out"
