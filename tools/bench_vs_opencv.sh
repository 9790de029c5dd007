#!/usr/bin/env bash
# Side by side in one run: tiltfield's refocus variants (GPU timestamps) and OpenCV's
# warpPerspective shift-and-sum on the same light field with the same homographies
# (tools/opencv_shift_sum.py), then the ratios.
#   tools/bench_vs_opencv.sh LF [focus options…]      e.g.
#   tools/bench_vs_opencv.sh /path/to/hci/backgammon --disparity 0.5
# Environment: OUT (default bench-vs-opencv), FRAMES (5), VARIANTS (a bench --variants list),
# TILTFIELD (a built binary; default: build it in $CARGO_TARGET_DIR, see tools/env.sh),
# LP_NUM_THREADS (lavapipe's threads). Installs python3-opencv if missing (root or sudo).
set -euo pipefail
cd "$(dirname "$0")/.."
[ $# -ge 1 ] || { echo "usage: $0 LF [focus options…]" >&2; exit 2; }
lf=$1
shift
out=${OUT:-bench-vs-opencv}
frames=${FRAMES:-5}
variants=${VARIANTS:-default,compute,batched:9,srgb8,shader,bicubic,nearest,rgba16f}
if ! /usr/bin/python3 -c "import cv2" 2>/dev/null; then
  sudo=""
  [ "$(id -u)" -eq 0 ] || sudo="sudo"
  echo "bench_vs_opencv: installing python3-opencv" >&2
  $sudo apt-get update -qq
  DEBIAN_FRONTEND=noninteractive $sudo apt-get install -y -qq --no-install-recommends python3-opencv >&2
fi
if [ -n "${TILTFIELD:-}" ]; then
  bin=$TILTFIELD
else
  . tools/env.sh
  cargo build --quiet
  bin="$CARGO_TARGET_DIR/debug/tiltfield"
fi
mkdir -p "$out"
"$bin" render "$lf" "$@" -o "$out/tiltfield.png" >&2
# The homographies first (a one-frame bench of the default), then OpenCV, the full tiltfield
# bench, and OpenCV again: machine load that drifts during the run shows up as a difference
# between the two OpenCV timings, and the ratios use their mean.
"$bin" bench "$lf" "$@" --variants default --no-scaling --frames 1 --out "$out/h" >&2
/usr/bin/python3 tools/opencv_shift_sum.py "$out/h/homographies.json" --frames "$frames" \
  --compare "$out/tiltfield.png" --json > "$out/opencv_before.json"
status=0
"$bin" bench "$lf" "$@" --variants "$variants" --no-scaling --frames "$frames" --out "$out" >&2 || status=$?
/usr/bin/python3 tools/opencv_shift_sum.py "$out/h/homographies.json" --frames "$frames" \
  --json > "$out/opencv_after.json"
/usr/bin/python3 - "$out" <<'PY'
import json, sys
out = sys.argv[1]
b = json.load(open(f"{out}/bench.json"))
o = json.load(open(f"{out}/opencv_before.json"))
o2 = json.load(open(f"{out}/opencv_after.json"))
print("OpenCV single-threaded before/after the bench: "
      f"{o['single_thread']['median_ms']:.1f} / {o2['single_thread']['median_ms']:.1f} ms")
one = (o["single_thread"]["median_ms"] + o2["single_thread"]["median_ms"]) / 2
allt = (o["all_threads"]["median_ms"] + o2["all_threads"]["median_ms"]) / 2
print(f"device: {b['device']['name']}  LP_NUM_THREADS={b['device']['lp_num_threads']}")
print(f"OpenCV {o['opencv']} warpPerspective, float32 linear: {one:.1f} ms single-threaded, "
      f"{allt:.1f} ms with {o['cpu_threads']} threads (means of before and after); 8-bit encoded: "
      f"{o['single_thread_8bit_encoded']['median_ms']:.1f} / {o['all_threads_8bit_encoded']['median_ms']:.1f} ms")
if "vs_tiltfield" in o:
    print(f"OpenCV vs tiltfield's PNG: {o['vs_tiltfield']}")
print(f"{'variant':<44} {'median ms':>10} {'÷ OpenCV 1 thread':>18} {'÷ all threads':>14}")
for v in b["variants"]:
    m = v["gpu_ms_median"]
    print(f"{v['name']:<44} {m:>10.1f} {m / one:>18.2f} {m / allt:>14.2f}")
PY
exit "$status"
