"""LightField.animate (issue 44): the frames are refocus images of their states, the files are
the CLI's, and bad motions raise the CLI's messages."""

import numpy as np
import pytest
from PIL import Image, ImageSequence

import tiltfield


def frames_of(path):
    """Every frame of an animated PNG or GIF as RGBA arrays."""
    with Image.open(path) as im:
        return [np.asarray(f.convert("RGBA")) for f in ImageSequence.Iterator(im)]


def test_animate_returns_each_frame_as_its_refocus(planes):
    pull = planes.animate(3, sweep="disparity=-1..1", antialias=False)
    assert pull.shape == (3, 64, 64, 4) and pull.dtype == np.uint8
    assert np.array_equal(pull[1], planes.refocus(disparity=0, antialias=False))
    assert not np.array_equal(pull[0], pull[2])
    # Forward then back, the ends shown once.
    bounced = planes.animate(3, sweep="disparity=-1..1", antialias=False, bounce=True)
    assert bounced.shape[0] == 4 and np.array_equal(bounced[3], pull[1])
    # The sweep as a tuple, Python's spelling of the key, backwards, anti-aliased.
    opening = planes.animate(3, sweep=("aperture_radius", 2, 1), disparity=0.5)
    assert np.array_equal(opening[1], planes.refocus(disparity=0.5, aperture_radius=1.5))
    # The orbit starts on the +s axis of the grid centre (2, 2).
    orbit = planes.animate(4, orbit=1, disparity=0.5, size=(48, 40))
    assert orbit.shape == (4, 40, 48, 4)
    assert np.array_equal(orbit[0], planes.refocus(disparity=0.5, view=(3, 2), size=(48, 40)))


def test_animate_writes_what_the_cli_writes(planes, cli, tmp_path):
    args = ["--sweep", "disparity=-1..1", "--frames", "3", "--antialias", "off"]
    for name in ("a.png", "a.gif"):
        mine, theirs = tmp_path / f"py_{name}", tmp_path / f"cli_{name}"
        assert planes.animate(3, sweep="disparity=-1..1", antialias=False, path=mine) is None
        cli.ok("animate", "builtin:planes", *args, "-o", str(theirs))
        assert mine.read_bytes() == theirs.read_bytes(), name
    frames = frames_of(tmp_path / "py_a.png")
    assert len(frames) == 3
    assert np.array_equal(frames[1], planes.refocus(disparity=0, antialias=False))


@pytest.mark.parametrize(
    "kwargs, message",
    [
        ({"frames": 0, "sweep": "disparity=0..1"}, "frames must be an integer from 1 to 10000, got 0"),
        ({"frames": -2, "sweep": "disparity=0..1"}, "frames must be an integer from 1 to 10000, got -2"),
        ({"frames": 3, "sweep": "blur=0..1"}, "unknown key 'blur'"),
        ({"frames": 3, "sweep": "disparity=0..nan"}, "finite"),
        ({"frames": 3, "orbit": 1}, "give one of disparity, plane"),
        ({"frames": 3, "orbit": 3, "disparity": 0}, "at most 2"),
        ({"frames": 3, "orbit": 1, "sweep": "disparity=0..1"}, "not both"),
        ({"frames": 3, "disparity": 0}, "give one motion"),
        ({"frames": 3, "sweep": "disparity=0..1", "path": "a.webm"}, ".gif"),
        ({"frames": 3, "sweep": "disparity=0..1", "path": "a.gif", "fps": 60}, "fps=60: a GIF plays at most 50"),
    ],
)
def test_bad_animations_raise_the_clis_messages(planes, kwargs, message):
    with pytest.raises(ValueError) as e:
        planes.animate(**kwargs)
    assert message in str(e.value)


def test_a_sweep_of_the_wrong_type_is_a_type_error(planes):
    with pytest.raises(TypeError, match=r'^sweep must be "KEY=A..B" or \(KEY, A, B\), got \(\'disparity\', 0\)$'):
        planes.animate(3, sweep=("disparity", 0))


def test_animate_refuses_an_unknown_keyword_naming_itself(planes):
    with pytest.raises(TypeError, match="animate.*'linear'"):
        planes.animate(3, sweep="disparity=0..1", linear=True)

