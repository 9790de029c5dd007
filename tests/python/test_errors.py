"""Bad arguments raise Python exceptions (ValueError for values, TypeError for types, OSError
for files), never a crash, and the message names the Python keyword: the library decides as
the command line does (the CLI is run with the same request), and its `error:` line reads the
same with each `--option` spelled as the keyword (`--aperture-radius` -> `aperture_radius`).
Numbers the module checks itself (counts, finiteness, integer ranges, sizes) say so in
Python's terms before any conversion."""

import re

import numpy as np
import pytest

import tiltfield


def as_keywords(cli_message: str) -> str:
    """The CLI's message with its options spelled as the module's keywords, a value that
    follows joined with `=` (`--frame 3:` -> `frame=3:`) and a pair as a tuple (`--view 1.5,2:`
    -> `view=(1.5, 2):`, `--size 9000x10` -> `size=(9000, 10)`)."""

    def keyword(m: re.Match) -> str:
        name, value = m[1].replace("-", "_"), m[2]
        if value is None:
            return name
        parts = re.split(r"[,x]", value.rstrip(":"))
        joined = f"({', '.join(parts)})" if len(parts) > 1 else parts[0]
        return f"{name}={joined}" + (":" if value.endswith(":") else "")

    number = r"-?[\d.]+"
    pattern = rf"--([a-z][a-z0-9-]*)(?: ({number}(?:[,x]{number})+:?|{number}:))?"
    return re.sub(pattern, keyword, cli_message)

# (CLI options, refocus keywords) that the library refuses; the messages must be the CLI's in
# keywords.
BAD_RENDERS = {
    "zero-normal": (["--plane", "0,0,3,0,0,0"], dict(plane=(0, 0, 3, 0, 0, 0))),
    "plane-through-camera": (["--plane", "0,0,0,0,0,1"], dict(plane=(0, 0, 0, 0, 0, 1))),
    "negative-radius": (
        ["--disparity", "0.5", "--aperture-radius=-1"],
        dict(disparity=0.5, aperture_radius=-1),
    ),
    "view-outside": (["--disparity", "0.5", "--view", "9,1"], dict(disparity=0.5, view=(9, 1))),
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
def test_bad_render_arguments_raise_the_cli_message_in_keywords(name, cli, planes):
    args, kwargs = BAD_RENDERS[name]
    expected = cli.error("render", "builtin:planes", "-o", "/tmp/tiltfield-never-written.png", *args)
    with pytest.raises(ValueError) as e:
        planes.refocus(**kwargs)
    assert "--" not in str(e.value)
    assert str(e.value) == as_keywords(expected)


# Values the module checks before the library sees them: the CLI refuses the same request, and
# the Python message names the keyword and what it takes (no `--size`, `AxB`, `comma-separated`).
PYTHON_CHECKED = {
    "nan-plane": (
        ["--plane", "0,0,NaN,0,0,1"],
        dict(plane=(0, 0, float("nan"), 0, 0, 1)),
        ValueError,
        "plane must be 6 finite numbers (px, py, pz, nx, ny, nz), got (0, 0, nan, 0, 0, 1)",
    ),
    "short-plane": (
        ["--plane", "0,0,3"],
        dict(plane=[0, 0, 3]),
        ValueError,
        "plane must be 6 finite numbers (px, py, pz, nx, ny, nz), got [0, 0, 3]",
    ),
    "size-zero": (
        ["--disparity", "0.5", "--size", "0x10"],
        dict(disparity=0.5, size=(0, 10)),
        ValueError,
        "size must be (w, h), two integers of at least 1 (pixels), got (0, 10)",
    ),
    "size-huge": (
        ["--disparity", "0.5", "--size", "9000x10"],
        dict(disparity=0.5, size=[9000, 10]),
        ValueError,
        "size=(9000, 10): at most",
    ),
    "click-three-numbers": (
        ["--click", "1,2,3"],
        dict(click=(1, 2, 3)),
        ValueError,
        "click must be 2 finite numbers (u, v), got (1, 2, 3)",
    ),
    "antialias-samples-negative": (
        ["--disparity", "0.5", "--antialias-samples=-1"],
        dict(disparity=0.5, antialias_samples=-1),
        ValueError,
        "antialias_samples must be an integer from 0 to 4294967295, got -1",
    ),
    "antialias-word": (
        ["--disparity", "0.5", "--antialias", "yes"],
        dict(disparity=0.5, antialias="yes"),
        ValueError,
        'antialias must be True, False, "on" or "off", got \'yes\'',
    ),
    "antialias-layered-word": (
        ["--disparity", "0.5", "--antialias-layered", "maybe"],
        dict(disparity=0.5, antialias_layered="maybe"),
        ValueError,
        'antialias_layered must be "auto", True, False, "on" or "off", got \'maybe\'',
    ),
}


@pytest.mark.parametrize("name", PYTHON_CHECKED)
def test_values_checked_in_python_name_the_keyword(name, cli, planes):
    args, kwargs, kind, message = PYTHON_CHECKED[name]
    assert cli.run("render", "builtin:planes", "-o", "/tmp/tiltfield-never-written.png", *args).returncode != 0
    with pytest.raises(kind) as e:
        planes.refocus(**kwargs)
    assert type(e.value) is kind
    assert str(e.value).startswith(message)


def test_sequences_are_taken_where_tuples_are_asked(planes):
    assert np.array_equal(planes.refocus(disparity=0.5, size=[32, 24]), planes.refocus(disparity=0.5, size=(32, 24)))
    assert planes.refocus(disparity=0.5, size=[32, 24]).shape == (24, 32, 4)
    assert np.array_equal(planes.refocus(click=[20, 30]), planes.refocus(click=(20, 30)))
    assert np.array_equal(planes.refocus(disparity=0.5, view=np.array([1.5, 2.0])), planes.refocus(disparity=0.5, view=(1.5, 2)))
    assert np.array_equal(planes.refocus(plane=[0, 0, 3, 0, 0, 1]), planes.refocus(plane=(0, 0, 3, 0, 0, 1)))
    assert planes.animate(2, sweep=["disparity", 0, 1]).shape[0] == 2


def test_switches_take_the_cli_words_too(planes):
    on = planes.refocus(disparity=0.5, antialias=True, size=(24, 24))
    assert np.array_equal(planes.refocus(disparity=0.5, antialias="on", size=(24, 24)), on)
    off = planes.refocus(disparity=0.5, antialias=False, size=(24, 24))
    assert np.array_equal(planes.refocus(disparity=0.5, antialias="off", size=(24, 24)), off)
    assert np.array_equal(planes.refocus(disparity=0.5, antialias=np.bool_(False), size=(24, 24)), off)
    with pytest.raises(TypeError, match='antialias_prefilter must be True, False, "on" or "off", got 1.5'):
        planes.refocus(disparity=0.5, antialias_prefilter=1.5)


def test_integers_are_range_checked_before_conversion(planes):
    with pytest.raises(ValueError, match="^frame must be an integer of at least 0, got -1$"):
        tiltfield.open("builtin:planes", frame=-1)
    with pytest.raises(ValueError, match="^frame must be an integer of at least 0, got 10{30}$"):
        tiltfield.open("builtin:planes", frame=10**30)
    with pytest.raises(TypeError, match="^frame must be an integer of at least 0, got 1.5$"):
        tiltfield.open("builtin:planes", frame=1.5)
    with pytest.raises(ValueError, match="^normal_window must be an integer from 0 to 4294967295, got -3$"):
        planes.refocus(click=(20, 30), normal_window=-3)
    with pytest.raises(ValueError, match="^views_per_draw must be an integer from 0 to"):
        planes.refocus(disparity=0.5, views_per_draw=-1)
    with pytest.raises(ValueError, match="^radius must be an integer from 0 to 4294967295, got -1$"):
        planes.depth(radius=-1)
    with pytest.raises(ValueError, match="^frames must be an integer from 1 to"):
        planes.animate(-2, sweep="disparity=0..1")


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
    with pytest.raises(ValueError, match="^give one of disparity, plane, focus, click, points or points_3d$"):
        planes.refocus()
    with pytest.raises(ValueError, match="^give one focus, got disparity and focus$"):
        planes.refocus(disparity=0.5, focus=3)
    with pytest.raises(ValueError, match="^tilt and swing turn the focus plane"):
        planes.refocus(disparity=0.5, tilt=4)
    with pytest.raises(ValueError, match="a nudge adjusts a plane picked"):
        planes.refocus(disparity=0.5, nudge_distance=1)
    with pytest.raises(TypeError, match=r"^plane must be 6 numbers \(px, py, pz, nx, ny, nz\) or a sequence"):
        planes.refocus(plane="0,0,3,0,0,1")
    with pytest.raises(TypeError, match="^focus must be a number or a sequence of numbers"):
        planes.refocus(focus="3")
    with pytest.raises(TypeError, match="^disparity must be a number or a sequence of numbers"):
        planes.refocus(disparity="far")
    with pytest.raises(ValueError, match="^tilt and swing turn the focus plane"):
        planes.refocus(plane=(0, 0, 3, 0, 0, 1), tilt=0)
    with pytest.raises(ValueError, match="^give one focus, got plane and focus$"):
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
    with pytest.raises(TypeError, match="views must be an array .*__array__ or __dlpack__.* got a list"):
        tiltfield.from_array([[1, 2, 3]])
    bad = np.zeros((5, 5, 8, 8, 3), np.float32)
    bad[1, 1, 1, 1, 1] = np.nan
    with pytest.raises(ValueError, match=r"^views: float32 values are linear light from 0 to 1, got NaN at index \(1, 1, 1, 1, 1\)$"):
        tiltfield.from_array(bad)
    views = planes.views()
    with pytest.raises(ValueError, match=r"depth must be a float32 array of shape \(H, W\) = \(64, 64\).*shape \(32, 32\)"):
        tiltfield.from_array(views, depth=np.zeros((32, 32), np.float32))
    with pytest.raises(ValueError, match="no finite value"):
        tiltfield.from_array(views, depth=np.full((64, 64), np.nan, np.float32))


def test_bad_camera_numbers_raise_the_cli_message(cli, grid_folder, planes):
    expected = as_keywords(cli.error("render", str(grid_folder), "-o", "/tmp/x.png", "--disparity", "1", "--focal-px=-2"))
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
    with pytest.raises(ValueError, match="^frame=3: builtin:planes is a single light field"):
        tiltfield.open("builtin:planes", frame=3)


def test_bad_depth_options_raise_the_cli_message(cli, planes):
    for args, kwargs in [
        (["--planes", "1"], dict(planes=1)),
        (["--view", "1.5,2"], dict(view=(1.5, 2))),
        (["--kind", "height"], dict(kind="height")),
    ]:
        expected = as_keywords(cli.error("depth", "builtin:planes", "-o", "/tmp/x.pfm", *args))
        with pytest.raises(ValueError) as e:
            planes.depth(**kwargs)
        assert str(e.value) == expected


def test_a_failed_call_leaves_the_light_field_usable(planes):
    with pytest.raises(ValueError):
        planes.refocus(plane=(0, 0, 0, 0, 0, 1))
    assert planes.refocus(disparity=0.5).shape == (64, 64, 4)
