"""Ctrl-C within a call, from_array's limits, input kinds, value range and speed, and pickling by
source (issue 41)."""

import os
import pickle
import signal
import subprocess
import sys
import textwrap
import time

import numpy as np
import pytest

import tiltfield

# The child: its first calls (the GPU context, the upload, an anti-aliased 2048² refocus that
# takes seconds on lavapipe) interrupted by the test; then it checks that the module still
# works. numpy's API is set up at import, so no call can trip over a pending signal there.
CHILD = textwrap.dedent(
    """
    import tiltfield
    print("ready", flush=True)
    try:
        lf = tiltfield.open("builtin:planes")
        lf.refocus(disparity=0.5, size=(2048, 2048), antialias=True, antialias_samples=8)
        print("finished", flush=True)
    except KeyboardInterrupt:
        print("interrupted", flush=True)
    lf = tiltfield.open("builtin:planes")
    small = lf.refocus(disparity=0.5, antialias=False)
    print("usable", small.shape, flush=True)
    """
)


def test_ctrl_c_interrupts_the_first_call_of_a_process_within_a_second_and_a_half():
    child = subprocess.Popen(
        [sys.executable, "-c", CHILD],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
        env={**os.environ, "TILTFIELD_VALIDATION": "0"},
    )
    try:
        assert child.stdout.readline().strip() == "ready"
        time.sleep(1.0)  # well inside the refocus (several seconds)
        sent = time.monotonic()
        child.send_signal(signal.SIGINT)
        line = child.stdout.readline().strip()
        latency = time.monotonic() - sent
        rest, err = child.communicate(timeout=120)
    finally:
        child.kill()
    print(f"KeyboardInterrupt {latency * 1e3:.0f} ms after SIGINT")
    assert line == "interrupted", f"got {line!r}; stderr:\n{err}"
    assert latency < 1.5, f"KeyboardInterrupt took {latency:.2f} s"
    assert "PanicException" not in err and "panicked" not in err, err
    # The light field renders again after the interrupted call (which ended in the background).
    assert "usable (64, 64, 4)" in rest, (rest, err)


def test_a_huge_array_is_refused_from_its_shape_before_any_value_is_read():
    huge = np.broadcast_to(np.zeros((1, 1, 1, 1, 3), np.uint8), (100000, 100000, 1, 1, 3))
    start = time.monotonic()
    with pytest.raises(ValueError, match=r"^views: 100000×100000 = 10000000000 views, more than \d+"):
        tiltfield.from_array(huge)
    big = np.broadcast_to(np.zeros((1, 1, 1, 1, 3), np.float32), (16, 16, 8192, 8192, 3))
    with pytest.raises(ValueError, match=r"^views: 65536 MiB as 8-bit RGBA, more than"):
        tiltfield.from_array(big)
    assert time.monotonic() - start < 1.0


def test_float_views_out_of_range_are_refused_with_their_index():
    views = np.zeros((3, 3, 8, 8, 3), np.float32)
    views[...] = 1.0  # both ends of the range are fine
    views[0, 0, 0, 0, 0] = -0.0
    tiltfield.from_array(views)
    views[2, 1, 5, 6, 2] = 5.0
    with pytest.raises(ValueError, match=r"^views: float32 values are linear light from 0 to 1, got 5 at index \(2, 1, 5, 6, 2\)$"):
        tiltfield.from_array(views)
    views[2, 1, 5, 6, 2] = -0.25
    with pytest.raises(ValueError, match=r"got -0.25 at index \(2, 1, 5, 6, 2\)"):
        tiltfield.from_array(views)
    views[2, 1, 5, 6, 2] = 1.0
    alpha = np.concatenate([views, np.full((3, 3, 8, 8, 1), 1.5, np.float32)], axis=-1)
    with pytest.raises(ValueError, match=r"got 1.5 at index \(0, 0, 0, 0, 3\)"):
        tiltfield.from_array(alpha)


def test_the_table_encoder_equals_the_librarys_around_every_code():
    # The float32 path encodes with a table; it must give encode_srgb8's byte for every value.
    # Every bit pattern within 2^15 of each code's threshold, and a stride over the rest.
    codes = (np.arange(1, 256) - 0.5) / 255.0
    linear = np.where(codes <= 0.04045, codes / 12.92, ((codes + 0.055) / 1.055) ** 2.4)
    bits = linear.astype(np.float32).view(np.uint32)
    for b in bits:
        assert tiltfield._tiltfield._srgb_table_mismatches(int(b) - 2**15, int(b) + 2**15) == []
    one = int(np.float32(1.0).view(np.uint32))
    for lo in range(0, one, one // 64):
        assert tiltfield._tiltfield._srgb_table_mismatches(lo, lo + 2**14) == []


class WithArray:
    def __init__(self, a):
        self.a = a

    def __array__(self, dtype=None, copy=None):
        return self.a


class WithDlpack:
    def __init__(self, a):
        self.a = a

    def __dlpack__(self, **kwargs):
        return self.a.__dlpack__(**kwargs)

    def __dlpack_device__(self):
        return self.a.__dlpack_device__()


def test_from_array_takes_array_likes_and_dlpack(planes):
    views = planes.views()
    expected = tiltfield.from_array(views).refocus(disparity=0.5)
    for wrapped in (WithArray(views), WithDlpack(views)):
        assert np.array_equal(tiltfield.from_array(wrapped).refocus(disparity=0.5), expected)


def test_pickle_reopens_a_path_and_rebuilds_arrays(grid_folder, planes, tmp_path, monkeypatch):
    monkeypatch.chdir(grid_folder.parent)
    opened = tiltfield.open(grid_folder.name, focal_px=80, baseline=0.5)
    monkeypatch.chdir(tmp_path)  # the copy finds the folder from anywhere
    copy = pickle.loads(pickle.dumps(opened))
    assert (copy.name, copy.grid, copy.view_size) == (opened.name, opened.grid, opened.view_size)
    assert np.array_equal(copy.refocus(disparity=0.5), opened.refocus(disparity=0.5))
    assert not copy.uploaded or copy is not opened

    scene = pickle.loads(pickle.dumps(planes))
    assert scene.has_depth
    assert np.array_equal(scene.refocus(focus=3.0, tilt=5), planes.refocus(focus=3.0, tilt=5))

    depth = np.full((64, 64), 0.25, np.float32)
    arrays = tiltfield.from_array(planes.views()[..., :3], focal_px=70, depth=depth)
    again = pickle.loads(pickle.dumps(arrays))
    assert again.has_depth and again.name == "array"
    assert np.array_equal(again.views(), arrays.views())
    for kwargs in (dict(disparity=0.5), dict(click=(20, 30)), dict(focus=2.0, tilt=3)):
        assert np.array_equal(again.refocus(**kwargs), arrays.refocus(**kwargs)), kwargs
