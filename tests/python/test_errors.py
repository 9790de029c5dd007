"""Bad arguments raise Python exceptions with the command line's message (ValueError for
arguments, OSError for files), never a crash; the CLI is run with the same request and its
`error:` line must say the same thing."""

import numpy as np
import pytest

import tiltfield

# (CLI options, refocus keywords) that the library refuses; the messages must be the CLI's.
BAD_RENDERS = {
    "nan-plane": (["--plane", "0,0,NaN,0,0,1"], dict(plane=(0, 0, float("nan"), 0, 0, 1))),
    "short-plane": (["--plane", "0,0,3"], dict(plane=(0, 0, 3))),
    "zero-normal": (["--plane", "0,0,3,0,0,0"], dict(plane=(0, 0, 3, 0, 0, 0))),
    "plane-through-camera": (["--plane", "0,0,0,0,0,1"], dict(plane=(0, 0, 0, 0, 0, 1))),
    "negative-radius": (
        ["--disparity", "0.5", "--aperture-radius=-1"],
        dict(disparity=0.5, aperture_radius=-1),
    ),
    "view-outside": (["--disparity", "0.5", "--view", "9,1"], dict(disparity=0.5, view=(9, 1))),
    "size-zero": (["--disparity", "0.5", "--size", "0x10"], dict(disparity=0.5, size=(0, 10))),
    "size-huge": (["--disparity", "0.5", "--size", "9000x10"], dict(disparity=0.5, size=(9000, 10))),
    "click-three-numbers": (["--click", "1,2,3"], dict(click=(1, 2, 3))),
    "click-outside": (["--click", "500,30"], dict(click=(500, 30))),
    "collinear-points": (["--points", "1,1,2,2,3,3"], dict(points=(1, 1, 2, 2, 3, 3))),
    "antialias-samples": (
        ["--disparity", "0.5", "--antialias-samples", "0"],
        dict(disparity=0.5, antialias_samples=0),
    ),
    "slab-width": (["--focus", "3", "--slab", "-1"], dict(focus=3, slab=-1)),
    "nine-planes": (
        [a for i in range(9) for a in ("--plane", f"0,0,{2 + i * 0.1},0,0,1")],
        dict(plane=[(0, 0, 2 + i * 0.1, 0, 0, 1) for i in range(9)]),
    ),
    "tilt-count": (
        ["--focus", "2", "--focus", "3", "--focus", "4", "--tilt", "1", "--tilt", "2"],
        dict(focus=[2, 3, 4], tilt=[1, 2]),
    ),
    "swing-count": (["--focus", "2", "--swing", "1", "--swing", "2"], dict(focus=2, swing=[1, 2])),
    "nine-focus": (
        [a for i in range(9) for a in ("--focus", f"{2 + i * 0.1}")],
        dict(focus=[2 + i * 0.1 for i in range(9)]),
    ),
    "focus-planes-slab": (
        ["--focus", "2", "--focus", "3", "--slab", "0.1"],
        dict(focus=[2, 3], slab=0.1),
    ),
    "nan-nudge": (["--click", "20,30", "--nudge-tilt", "inf"], dict(click=(20, 30), nudge_tilt=float("inf"))),
}


@pytest.mark.parametrize("name", BAD_RENDERS)
def test_bad_render_arguments_raise_the_cli_message(name, cli, planes):
    args, kwargs = BAD_RENDERS[name]
    expected = cli.error("render", "builtin:planes", "-o", "/tmp/tiltfield-never-written.png", *args)
    with pytest.raises(ValueError) as e:
        planes.refocus(**kwargs)
    assert str(e.value) == expected


# Choices the CLI's argument parser checks with the same parser: its message wraps ours.
BAD_CHOICES = {
    "aperture": (["--disparity", "0.5", "--aperture", "hexagon"], dict(disparity=0.5, aperture="hexagon")),
    "average": (["--disparity", "0.5", "--average", "gamma"], dict(disparity=0.5, average="gamma")),
    "filter": (["--disparity", "0.5", "--filter", "lanczos"], dict(disparity=0.5, filter="lanczos")),
    "strategy": (["--disparity", "0.5", "--strategy", "magic"], dict(disparity=0.5, strategy="magic")),
}


@pytest.mark.parametrize("name", BAD_CHOICES)
def test_bad_choices_raise_the_parser_message(name, cli, planes):
    args, kwargs = BAD_CHOICES[name]
    r = cli.run("render", "builtin:planes", "-o", "/tmp/tiltfield-never-written.png", *args)
    assert r.returncode != 0
    with pytest.raises(ValueError) as e:
        planes.refocus(**kwargs)
    assert str(e.value) in r.stderr


def test_the_focus_must_be_given_once(planes):
    with pytest.raises(ValueError, match="give one of --disparity"):
        planes.refocus()
    with pytest.raises(ValueError, match="give one focus, got --disparity and --focus"):
        planes.refocus(disparity=0.5, focus=3)
    with pytest.raises(ValueError, match="--tilt and --swing turn the --focus plane"):
        planes.refocus(disparity=0.5, tilt=4)
    with pytest.raises(ValueError, match="a nudge adjusts a plane picked"):
        planes.refocus(disparity=0.5, nudge_distance=1)
    with pytest.raises(ValueError, match="--plane: expected 6 numbers"):
        planes.refocus(plane="0,0,3,0,0,1")
    with pytest.raises(ValueError, match="--focus: expected a number or a sequence of numbers"):
        planes.refocus(focus="3")
    with pytest.raises(ValueError, match="--tilt and --swing turn the --focus plane"):
        planes.refocus(plane=(0, 0, 3, 0, 0, 1), tilt=0)
    with pytest.raises(ValueError, match="give one focus, got --plane and --focus"):
        planes.refocus(plane=(0, 0, 3, 0, 0, 1), focus=[2, 3])


def test_wrong_array_shapes_and_types_name_the_cause(planes):
    with pytest.raises(ValueError, match=r"shape \(rows, cols, H, W, 3 or 4\), got shape \(5, 5, 64, 64\)"):
        tiltfield.from_array(np.zeros((5, 5, 64, 64), np.uint8))
    with pytest.raises(ValueError, match=r"got shape \(5, 5, 64, 64, 2\)"):
        tiltfield.from_array(np.zeros((5, 5, 64, 64, 2), np.uint8))
    with pytest.raises(ValueError, match=r"got shape \(0, 5, 64, 64, 3\)"):
        tiltfield.from_array(np.zeros((0, 5, 64, 64, 3), np.uint8))
    with pytest.raises(ValueError, match="dtype uint8 \\(sRGB\\) or float32 .* got dtype float64"):
        tiltfield.from_array(np.zeros((5, 5, 64, 64, 3)))
    with pytest.raises(ValueError, match="got a list"):
        tiltfield.from_array([[1, 2, 3]])
    bad = np.zeros((5, 5, 8, 8, 3), np.float32)
    bad[1, 1, 1, 1, 1] = np.nan
    with pytest.raises(ValueError, match="float32 views must be finite"):
        tiltfield.from_array(bad)
    views = planes.views()
    with pytest.raises(ValueError, match=r"depth must be a float32 array of shape \(H, W\) = \(64, 64\).*shape \(32, 32\)"):
        tiltfield.from_array(views, depth=np.zeros((32, 32), np.float32))
    with pytest.raises(ValueError, match="no finite value"):
        tiltfield.from_array(views, depth=np.full((64, 64), np.nan, np.float32))


def test_bad_camera_numbers_raise_the_cli_message(cli, grid_folder, planes):
    expected = cli.error("render", str(grid_folder), "-o", "/tmp/x.png", "--disparity", "1", "--focal-px=-2")
    with pytest.raises(ValueError) as e:
        tiltfield.from_array(planes.views(), focal_px=-2)
    assert str(e.value) == expected
    with pytest.raises(ValueError) as e:
        tiltfield.open(grid_folder, focal_px=-2)
    assert str(e.value) == expected


def test_missing_files_are_os_errors_with_the_cli_message(cli, tmp_path):
    missing = str(tmp_path / "no-such-light-field")
    expected = cli.error("render", missing, "-o", str(tmp_path / "x.png"), "--disparity", "1")
    with pytest.raises(OSError) as e:
        tiltfield.open(missing)
    assert str(e.value) == expected
    with pytest.raises(ValueError, match="no built-in scene 'nope'"):
        tiltfield.open("builtin:nope")
    with pytest.raises(ValueError, match="--frame 3: builtin:planes is a single light field"):
        tiltfield.open("builtin:planes", frame=3)


def test_bad_depth_options_raise_the_cli_message(cli, planes):
    for args, kwargs in [
        (["--planes", "1"], dict(planes=1)),
        (["--view", "1.5,2"], dict(view=(1.5, 2))),
        (["--kind", "height"], dict(kind="height")),
    ]:
        expected = cli.error("depth", "builtin:planes", "-o", "/tmp/x.pfm", *args)
        with pytest.raises(ValueError) as e:
            planes.depth(**kwargs)
        assert str(e.value) == expected


def test_a_failed_call_leaves_the_light_field_usable(planes):
    with pytest.raises(ValueError):
        planes.refocus(plane=(0, 0, 0, 0, 0, 1))
    assert planes.refocus(disparity=0.5).shape == (64, 64, 4)
