#!/usr/bin/env python3
"""Measures the Python module on a light field: a focal stack of N planes through one loaded
light field, each call's wall time against its GPU time (the per-call overhead), the first call
(which uploads the views) against the later ones, the images against the command line's and
against `from_array` of the same views, and `from_array`'s float32 conversion against uint8's.

    python tools/python_focal_stack.py /work/shared/data/hci/backgammon --planes 20 \
        --cli ~/.cache/tiltfield/target/debug/tiltfield

Run it with the Python of an environment the module is installed in (`pip install .`).
"""

import argparse
import statistics
import subprocess
import tempfile
import time
from pathlib import Path

import numpy as np

import tiltfield


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("source")
    ap.add_argument("--planes", type=int, default=20)
    ap.add_argument("--range", type=float, nargs=2, default=(-1.5, 1.5), metavar=("MIN", "MAX"))
    ap.add_argument("--cli", help="a tiltfield binary: compare the first and last images with it")
    ap.add_argument("--antialias", choices=["on", "off"], default="off")
    ap.add_argument(
        "--antialias-layered",
        choices=["auto", "on", "off"],
        default="auto",
        help="layered footprints (auto: where the light field ships its depth; off: sub-samples)",
    )
    a = ap.parse_args()
    aa = a.antialias == "on"

    t = time.perf_counter()
    lf = tiltfield.open(a.source)
    open_s = time.perf_counter() - t
    print(f"{lf!r} on {tiltfield.device()['name']}; open {open_s * 1e3:.0f} ms")

    walls, gpus, stack = [], [], []
    for d in np.linspace(*a.range, a.planes):
        t = time.perf_counter()
        stack.append(lf.refocus(disparity=float(d), antialias=aa, antialias_layered=a.antialias_layered))
        walls.append(time.perf_counter() - t)
        gpus.append(lf.last_gpu_ms / 1e3)
    over = [w - g for w, g in zip(walls, gpus)]
    later = slice(1, None)
    print(
        f"first call: wall {walls[0] * 1e3:.1f} ms, GPU {gpus[0] * 1e3:.1f} ms, "
        f"overhead {over[0] * 1e3:.1f} ms (upload and set-up)"
    )
    print(
        f"later {len(walls) - 1} calls (median): wall {statistics.median(walls[later]) * 1e3:.1f} ms, "
        f"GPU {statistics.median(gpus[later]) * 1e3:.1f} ms, overhead "
        f"{statistics.median(over[later]) * 1e3:.1f} ms (max wall {max(walls[later]) * 1e3:.1f} ms, "
        f"{max(walls[later]) / walls[0]:.2f} of the first call)"
    )

    # from_array of the same views: a grid folder's conventions (classic disparity D = -d of
    # HCI's), so the same focus is the opposite disparity.
    t = time.perf_counter()
    views = lf.views()
    arr = tiltfield.from_array(views)
    same = [arr.refocus(disparity=-float(d)) for d in (a.range[0], a.range[1])]
    for x, y in zip(same, (stack[0], stack[-1])):
        diff = np.abs(x.astype(int) - y.astype(int))
        print(
            f"from_array of the same views: mean difference {diff.mean():.2e} levels, largest "
            f"{diff.max()}, {np.count_nonzero(diff > 1)} values differ by more than 1"
        )
    print(f"  (from_array and its two renders: {time.perf_counter() - t:.2f} s)")

    # from_array's conversion of float32 linear views against uint8 ones of the same shape
    # (the float path encodes with a table; a per-value conversion took 27x uint8's time).
    # Process CPU time (every thread), the best of seven: what the conversion costs, not what
    # other processes take from it.
    rng = np.random.default_rng(1)
    shape = (*views.shape[:4], 3)
    u8 = rng.integers(0, 256, shape, dtype=np.uint8)
    f32 = rng.random(shape, dtype=np.float32)

    def best(x: np.ndarray) -> float:
        times = []
        for _ in range(7):
            start = time.process_time()
            tiltfield.from_array(x)
            times.append(time.process_time() - start)
        return min(times)

    t8, t32 = best(u8), best(f32)
    print(
        f"from_array {'x'.join(map(str, shape))}: uint8 {t8 * 1e3:.1f} ms, float32 "
        f"{t32 * 1e3:.1f} ms of CPU time ({t32 / t8:.2f}x)"
    )

    if a.cli:
        from PIL import Image

        with tempfile.TemporaryDirectory() as tmp:
            for i, d in [(0, a.range[0]), (len(stack) - 1, a.range[1])]:
                out = Path(tmp) / "cli.png"
                t = time.perf_counter()
                subprocess.run(
                    [a.cli, "render", a.source, "-o", str(out), f"--disparity={d}", "--antialias", a.antialias,
                     "--antialias-layered", a.antialias_layered],
                    check=True,
                    capture_output=True,
                )
                cli_s = time.perf_counter() - t
                cli = np.asarray(Image.open(out).convert("RGBA"))
                print(f"plane {i}: CLI {cli_s:.2f} s per image, equal to the module's: {np.array_equal(cli, stack[i])}")


if __name__ == "__main__":
    main()
