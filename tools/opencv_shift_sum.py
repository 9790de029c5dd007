#!/usr/bin/python3
"""Generalized shift-and-sum with OpenCV's warpPerspective: the same work as tiltfield's
refocus pass, for a side-by-side speed comparison (tools/bench_vs_opencv.sh runs both).

Reads the per-view homographies that `tiltfield bench` writes (homographies.json: output pixel
-> view pixel, pixel centres at integers, which is also OpenCV's convention), so both programs
warp with identical matrices. Per frame, for every view: warpPerspective of the view (linear
light, float32, with an alpha channel of ones) with INTER_LINEAR and a constant zero border,
scaled by the view's aperture weight and added to an accumulator; then the colour sum is
divided by the alpha sum, i.e. by the weights actually used at each pixel (tiltfield's mask
normalisation; OpenCV's border is soft over the outermost half pixel where tiltfield's is
hard). Decoding the PNGs to linear light is done once, outside the timing, as tiltfield
uploads its views once.

Timed: the whole frame (all warps, the accumulation and the division), median of --frames
after one warm-up frame, with cv2.setNumThreads(1) and with all threads. Also timed, for
reference: the same on 8-bit encoded views (what many tools do; not the same work).

Needs Debian's python3-opencv (apt-get install python3-opencv); run with /usr/bin/python3.
"""

import argparse
import json
import os
import statistics
import sys
import time

try:
    import cv2
    import numpy as np
except ImportError as e:  # pragma: no cover - a usage error, not a test
    sys.exit(f"opencv_shift_sum.py needs python3-opencv and numpy ({e}): "
             "apt-get install python3-opencv, then run it with /usr/bin/python3")


def srgb_to_linear_table():
    c = np.arange(256, dtype=np.float64) / 255.0
    lin = np.where(c <= 0.04045, c / 12.92, ((c + 0.055) / 1.055) ** 2.4)
    return lin.astype(np.float32)


def linear_to_srgb8(x):
    x = np.clip(x, 0.0, 1.0)
    e = np.where(x <= 0.0031308, x * 12.92, 1.055 * np.power(x, 1.0 / 2.4) - 0.055)
    return np.floor(e * 255.0 + 0.5).astype(np.uint8)


def load_views(spec):
    table = srgb_to_linear_table()
    views = []
    for v in spec["views"]:
        path = v.get("image")
        if not path:
            sys.exit(f"view ({v['s']},{v['t']}) has no image file: run the bench on a light "
                     "field loaded from files (HCI, manifest or grid folder)")
        bgr = cv2.imread(path, cv2.IMREAD_COLOR)
        if bgr is None:
            sys.exit(f"{path}: cannot read the image")
        lin = table[bgr]  # exact sRGB decode, float32
        ones = np.ones(lin.shape[:2] + (1,), np.float32)
        bgra8 = np.dstack([bgr, np.full(bgr.shape[:2], 255, np.uint8)])
        views.append((np.ascontiguousarray(np.dstack([lin, ones])), bgra8,
                      np.array(v["h"], np.float64), float(v["weight"])))
    return views


def refocus(views, size, eight_bit=False):
    w, h = size
    acc = np.zeros((h, w, 4), np.float32)
    flags = cv2.INTER_LINEAR | cv2.WARP_INVERSE_MAP
    for lin, bgra8, hm, weight in views:
        src = bgra8 if eight_bit else lin
        warped = cv2.warpPerspective(src, hm, (w, h), flags=flags,
                                     borderMode=cv2.BORDER_CONSTANT, borderValue=0)
        if eight_bit:
            warped = warped.astype(np.float32)
        cv2.scaleAdd(warped, weight, acc, dst=acc)
    wsum = acc[..., 3:4]
    return np.where(wsum > 0, acc[..., :3] / np.maximum(wsum, 1e-30), 0.0)


def time_frames(views, size, frames, eight_bit):
    refocus(views, size, eight_bit)  # warm-up
    times = []
    for _ in range(frames):
        t0 = time.perf_counter()
        refocus(views, size, eight_bit)
        times.append((time.perf_counter() - t0) * 1e3)
    return {"median_ms": statistics.median(times), "min_ms": min(times), "max_ms": max(times),
            "frames": frames}


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("homographies", help="homographies.json written by tiltfield bench")
    ap.add_argument("--frames", type=int, default=5)
    ap.add_argument("--compare", help="tiltfield's 8-bit render of the same plan (PNG)")
    ap.add_argument("--json", action="store_true", help="print the results as JSON")
    args = ap.parse_args()
    with open(args.homographies) as f:
        spec = json.load(f)
    if not spec.get("exact", True):
        print("warning: part of the image lies beyond the plane's horizon; OpenCV's single "
              "homography differs from tiltfield's clamped warp there", file=sys.stderr)
    views = load_views(spec)
    size = (spec["width"], spec["height"])
    threads = os.cpu_count() or 1
    result = {"opencv": cv2.__version__, "views": len(views), "width": size[0],
              "height": size[1], "cpu_threads": threads}
    for name, n in [("single_thread", 1), ("all_threads", threads)]:
        cv2.setNumThreads(n)
        result[name] = time_frames(views, size, args.frames, False)
        result[name + "_8bit_encoded"] = time_frames(views, size, args.frames, True)
    if args.compare:
        ours = cv2.imread(args.compare, cv2.IMREAD_COLOR)
        if ours is None:
            sys.exit(f"{args.compare}: cannot read the image")
        cv_img = linear_to_srgb8(refocus(views, size))
        d = np.abs(cv_img.astype(np.float64) - ours.astype(np.float64))
        inner = d[2:-2, 2:-2]
        mse = np.mean(d ** 2)
        result["vs_tiltfield"] = {
            "psnr_db": float(10 * np.log10(255.0 ** 2 / mse)) if mse > 0 else None,
            "max_levels": float(d.max()),
            "max_levels_inside_2px_border": float(inner.max()),
            "mean_abs_levels": float(d.mean()),
        }
    if args.json:
        print(json.dumps(result, indent=2))
    else:
        for k, v in result.items():
            print(f"{k}: {v}")


if __name__ == "__main__":
    main()
