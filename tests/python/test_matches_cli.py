"""The module renders what `tiltfield render` writes: byte for byte against its PNG, value for
value against its EXR, for every focus form and render option, on the same light field."""

import numpy as np
import pytest

import tiltfield
from conftest import srgb_to_linear

# (CLI options, refocus keywords): every focus form, then the options that change the image.
# builtin:planes ships depth, so these are anti-aliased by default, and clicks use its map.
CASES = {
    "disparity": (["--disparity", "0.5"], dict(disparity=0.5)),
    "plane": (["--plane", "0,0,3,0,0.2,1"], dict(plane=(0, 0, 3, 0, 0.2, 1))),
    "focus-tilt-swing": (
        ["--focus", "3", "--tilt", "10", "--swing", "-5"],
        dict(focus=3, tilt=10, swing=-5),
    ),
    "click": (["--click", "20,30"], dict(click=(20, 30))),
    "click-nudged": (
        ["--click", "20,30", "--nudge-distance", "0.2", "--nudge-tilt", "3"],
        dict(click=(20, 30), nudge_distance=0.2, nudge_tilt=3),
    ),
    "points": (["--points", "8,8,56,10,30,56"], dict(points=(8, 8, 56, 10, 30, 56))),
    "points-3d": (
        ["--points-3d", "0,0,3,1,0,3.2,0,1,3"],
        dict(points_3d=(0, 0, 3, 1, 0, 3.2, 0, 1, 3)),
    ),
    "view": (["--disparity", "0.5", "--view", "1.5,2.25"], dict(disparity=0.5, view=(1.5, 2.25))),
    "size": (["--disparity", "0.5", "--size", "96x80"], dict(disparity=0.5, size=(96, 80))),
    "aperture": (
        ["--disparity", "0.5", "--aperture", "gaussian", "--aperture-radius", "1"],
        dict(disparity=0.5, aperture="gaussian", aperture_radius=1),
    ),
    "aperture-square": (
        ["--disparity", "0.5", "--aperture", "square", "--aperture-radius", "1"],
        dict(disparity=0.5, aperture="square", aperture_radius=1),
    ),
    "antialias-off": (
        ["--disparity", "0.5", "--antialias", "off"],
        dict(disparity=0.5, antialias=False),
    ),
    "antialias-untested": (
        ["--disparity", "0.5", "--antialias-focus-test", "off"],
        dict(disparity=0.5, antialias_focus_test=False),
    ),
    "antialias-bilinear": (
        ["--disparity", "0.5", "--antialias-focused-bicubic", "off"],
        dict(disparity=0.5, antialias_focused_bicubic=False),
    ),
    "antialias-open": (
        ["--disparity", "0.5", "--antialias-occlusion", "off"],
        dict(disparity=0.5, antialias_occlusion=False),
    ),
    "antialias-defocus": (
        ["--disparity", "0.5", "--antialias-defocus", "on"],
        dict(disparity=0.5, antialias_defocus=True),
    ),
    "antialias-layered": (
        ["--disparity", "0.5", "--antialias-layered", "on"],
        dict(disparity=0.5, antialias_layered=True),
    ),
    "antialias-layered-off": (
        ["--disparity", "0.5", "--antialias-layered", "off"],
        dict(disparity=0.5, antialias_layered="off"),
    ),
    "antialias-layered-auto": (
        ["--disparity", "0.5", "--antialias-layered", "auto"],
        dict(disparity=0.5, antialias_layered="auto"),
    ),
    "antialias-unboxed": (
        ["--disparity", "0.5", "--antialias-box", "off"],
        dict(disparity=0.5, antialias_box=False),
    ),
    "encoded": (
        ["--disparity", "0.5", "--average", "encoded"],
        dict(disparity=0.5, average="encoded"),
    ),
    "planes": (
        ["--plane", "0,0,4,0,0,1", "--plane", "0,0,2,0,0,1"],
        dict(plane=[(0, 0, 4, 0, 0, 1), (0, 0, 2, 0, 0, 1)]),
    ),
    # --focus repeated: a list, --tilt once per plane (paired by order), --swing once (all).
    "focus-planes": (
        ["--focus", "4", "--focus", "2", "--tilt", "0", "--tilt", "15", "--swing", "-5"],
        dict(focus=[4, 2], tilt=[0, 15], swing=-5),
    ),
    "disparity-planes": (
        ["--disparity", "0.5", "--disparity=-0.3"],
        dict(disparity=(0.5, -0.3)),
    ),
    "slab": (["--focus", "3", "--slab", "0.5"], dict(focus=3, slab=0.5)),
    "all-in-focus": (["--disparity", "0", "--all-in-focus"], dict(disparity=0, all_in_focus=True)),
    "compute-bicubic": (
        ["--disparity", "0.5", "--strategy", "compute", "--filter", "bicubic"],
        dict(disparity=0.5, strategy="compute", filter="bicubic"),
    ),
}


@pytest.mark.parametrize("name", CASES)
def test_png_bytes_equal_the_cli(name, cli, planes, tmp_path):
    args, kwargs = CASES[name]
    expected = cli.png("builtin:planes", *args, tmp=tmp_path)
    got = planes.refocus(**kwargs)
    assert got.dtype == np.uint8 and got.shape == expected.shape
    assert np.array_equal(got, expected), f"{name}: {np.count_nonzero(got != expected)} bytes differ"


@pytest.mark.parametrize("name", ["disparity", "focus-tilt-swing", "click", "encoded", "slab"])
def test_linear_output_equals_the_cli_exr(name, cli, planes, tmp_path):
    args, kwargs = CASES[name]
    expected = cli.exr("builtin:planes", *args, tmp=tmp_path)
    got = planes.refocus(linear=True, **kwargs)
    assert got.dtype == np.float32 and got.shape == expected.shape
    assert np.array_equal(got, expected)


def test_a_render_differs_between_focus_forms(planes):
    # Guards the comparisons above against a module that ignores its keywords.
    a = planes.refocus(disparity=0.5)
    b = planes.refocus(focus=3, tilt=20)
    assert not np.array_equal(a, b)


def test_a_list_of_focus_values_is_a_surface_of_their_planes(planes):
    """focus=[...] is the surface of the planes each value gives alone (as plane=[...] of
    those planes), and its second plane changes the image."""
    alone = [planes.plane(focus=z, tilt=t) for z, t in [(4, 0), (2, 15)]]
    as_planes = [(*p, *n) for p, n in alone]
    surface = planes.refocus(focus=[4, 2], tilt=[0, 15])
    assert np.array_equal(surface, planes.refocus(plane=as_planes))
    assert not np.array_equal(surface, planes.refocus(focus=4))
    # plane() gives the first plane of several: the render's own focus.
    assert planes.plane(focus=[4, 2], tilt=[0, 15]) == alone[0]


def test_grid_folder_and_arrays_render_alike(cli, planes, grid_folder, tmp_path):
    """from_array reads its views as a grid folder of the same images: uint8, linear float32,
    and a transposed (strided) plenpy-style array all give the folder's bytes."""
    views = planes.views()
    folder = tiltfield.open(grid_folder)
    assert folder.grid == (5, 5) and folder.view_size == (64, 64) and not folder.has_depth
    args, kwargs = ["--disparity", "-0.7"], dict(disparity=-0.7)
    expected = cli.png(str(grid_folder), *args, tmp=tmp_path)
    assert np.array_equal(folder.refocus(**kwargs), expected)
    from_u8 = tiltfield.from_array(views)
    assert np.array_equal(from_u8.refocus(**kwargs), expected)
    from_rgb = tiltfield.from_array(np.ascontiguousarray(views[..., :3]))
    assert np.array_equal(from_rgb.refocus(**kwargs), expected)
    linear = srgb_to_linear(views)
    linear[..., 3] = views[..., 3] / 255.0
    from_f32 = tiltfield.from_array(linear)
    assert np.array_equal(from_f32.views(), views)
    assert np.array_equal(from_f32.refocus(**kwargs), expected)
    # (cols, rows, W, H, C) in memory, handed over as a transposed view: strided, no copy.
    swapped = np.ascontiguousarray(views.transpose(1, 0, 3, 2, 4))
    plenpy_style = swapped.transpose(1, 0, 3, 2, 4)
    assert not plenpy_style.flags["C_CONTIGUOUS"]
    assert np.array_equal(tiltfield.from_array(plenpy_style).refocus(**kwargs), expected)


def test_grid_cameras_follow_focal_and_baseline(cli, planes, grid_folder, tmp_path):
    args = ["--focus", "40", "--tilt", "8", "--focal-px", "80", "--baseline", "0.5"]
    expected = cli.png(str(grid_folder), *args, tmp=tmp_path)
    lf = tiltfield.from_array(planes.views(), focal_px=80, baseline=0.5)
    assert np.array_equal(lf.refocus(focus=40, tilt=8), expected)
    assert np.array_equal(tiltfield.open(grid_folder, focal_px=80, baseline=0.5).refocus(focus=40, tilt=8), expected)


def test_a_click_on_a_grid_without_depth_estimates_it_as_the_cli_does(cli, grid_folder, tmp_path):
    """The click estimates depth (shared cache); a later plain render still sees the folder
    as loaded (no depth, so no default anti-aliasing, and the original cameras)."""
    lf = tiltfield.open(grid_folder)
    click = cli.png(str(grid_folder), "--click", "20,30", tmp=tmp_path)
    assert np.array_equal(lf.refocus(click=(20, 30)), click)
    plain = cli.png(str(grid_folder), "--focus", "40", "--tilt", "5", tmp=tmp_path)
    assert np.array_equal(lf.refocus(focus=40, tilt=5), plain)
    assert not lf.has_depth


def test_plane_reports_the_plane_the_render_uses(planes):
    point, normal = planes.plane(focus=3, tilt=10)
    assert point == pytest.approx((0, 0, 3))
    assert np.linalg.norm(normal) == pytest.approx(1)
    assert normal[1] == pytest.approx(np.sin(np.radians(10)))
    # A click on the frontoparallel plane at 4 m finds it (the centre pixel sees it).
    p, n = planes.plane(click=(32, 32))
    assert abs(n[2]) == pytest.approx(1, abs=0.02) and p[2] == pytest.approx(4, rel=0.02)
    # The resolved plane renders as its click.
    by_click = planes.refocus(click=(32, 32))
    by_plane = planes.refocus(plane=(*p, *n))
    assert np.abs(by_click.astype(int) - by_plane.astype(int)).max() <= 1
    assert tiltfield.open("builtin:planes").plane(disparity=0.5) is not None


def test_plane_reports_the_picks_confidence_as_the_cli_json(cli, planes, grid_folder, tmp_path):
    import json

    for source, lf, args, kwargs in [
        ("builtin:planes", planes, ["--click", "20,30"], dict(click=(20, 30))),
        (str(grid_folder), tiltfield.open(grid_folder), ["--click", "40,12"], dict(click=(40, 12))),
        ("builtin:planes", planes, ["--points", "10,10,50,12,30,50"], dict(points=(10, 10, 50, 12, 30, 50))),
    ]:
        r = cli.run("render", source, "-o", str(tmp_path / "c.png"), *args, "--json")
        assert r.returncode == 0, r.stderr
        expected = json.loads(r.stdout)["focus"]["confidence"]
        point, normal, confidence = lf.plane(**kwargs, confidence=True)
        assert confidence == pytest.approx(expected, abs=1e-12), (source, args)
        assert (point, normal) == lf.plane(**kwargs)
    # A focus given as numbers has no pick, so no confidence.
    assert planes.plane(focus=3, tilt=10, confidence=True)[2] is None


def test_classic_disparity_has_no_plane(planes):
    assert tiltfield.from_array(planes.views()).plane(disparity=0.5) is None


def test_depth_equals_the_cli_estimate(cli, planes, tmp_path):
    out = tmp_path / "d.pfm"
    cli.ok("depth", "builtin:planes", "-o", str(out), "--planes", "24")
    expected = read_pfm(out)
    got = planes.depth(planes=24)
    assert got.dtype == np.float32 and got.shape == (64, 64)
    assert np.array_equal(np.isnan(got), np.isnan(expected))
    assert np.array_equal(got[~np.isnan(got)], expected[~np.isnan(expected)])
    # The two planes are at 4 m and 2 m; depth puts the centre on the far one.
    z = planes.depth(planes=24, kind="depth")
    assert z[32, 32] == pytest.approx(4, rel=0.05)


def test_depth_without_the_refinement_equals_the_cli(cli, planes, tmp_path):
    out = tmp_path / "d.pfm"
    cli.ok("depth", "builtin:planes", "-o", str(out), "--planes", "24", "--no-smooth")
    expected = read_pfm(out)
    got = planes.depth(planes=24, no_smooth=True)
    assert np.array_equal(got, expected, equal_nan=True)
    # The refinement moves the weakly textured pixels: the default's map differs.
    assert not np.array_equal(got, planes.depth(planes=24), equal_nan=True)


def test_depth_without_the_plane_fill_equals_the_cli(cli, tmp_path):
    # The built-in demo's back wall and floor are planes the fill finds.
    out = tmp_path / "d.pfm"
    cli.ok("depth", "builtin:demo", "-o", str(out), "--no-plane-fill")
    expected = read_pfm(out)
    demo = tiltfield.open("builtin:demo")
    got = demo.depth(no_plane_fill=True)
    assert np.array_equal(got, expected, equal_nan=True)
    assert not np.array_equal(got, demo.depth(), equal_nan=True)


def test_depth_confidence_equals_the_cli_png(cli, planes, tmp_path):
    from PIL import Image

    out, conf_png = tmp_path / "d.pfm", tmp_path / "c.png"
    cli.ok("depth", "builtin:planes", "-o", str(out), "--planes", "24", "--confidence", str(conf_png))
    depth, conf = planes.depth(planes=24, confidence=True)
    assert np.array_equal(depth, planes.depth(planes=24), equal_nan=True)
    assert conf.dtype == np.float32 and conf.shape == depth.shape
    assert conf.min() >= 0 and conf.max() <= 1 and conf.max() > conf.min()
    # The CLI's PNG is the same confidence in 8 bits.
    png = np.asarray(Image.open(conf_png).convert("L"), dtype=np.float64) / 255
    assert np.abs(png - conf).max() <= 0.5 / 255 + 1e-6


def test_from_array_with_a_disparity_map_uses_it(planes):
    views = planes.views()
    disparity = planes.depth(planes=24)
    # Classic disparity: the estimate's HCI disparity with the sign of the shift turned.
    lf = tiltfield.from_array(views, depth=-disparity)
    assert lf.has_depth
    # Depth is used by default (anti-aliased), so a plane's render differs from the plain sum.
    assert not np.array_equal(lf.refocus(focus=40), lf.refocus(focus=40, antialias=False))
    # A click picks the plane under the pixel: frontoparallel there.
    _, n = lf.plane(click=(32, 32), normal_window=21)
    assert abs(n[2]) == pytest.approx(1, abs=0.05)


def test_hci_backgammon_matches_the_cli(cli, tmp_path):
    """The HCI scene this issue names, where the test machine has it."""
    from pathlib import Path

    folder = Path("/work/shared/data/hci/backgammon")
    if not (folder / "parameters.cfg").exists():
        pytest.skip("the HCI backgammon folder is not on this machine")
    lf = tiltfield.open(folder)
    args = ["--disparity", "0.8", "--size", "128x128", "--aperture-radius", "2"]
    expected = cli.png(str(folder), *args, tmp=tmp_path)
    assert np.array_equal(lf.refocus(disparity=0.8, size=(128, 128), aperture_radius=2), expected)


def read_pfm(path):
    """A one-channel PFM (rows bottom-up, negative scale: little-endian) as (H, W) float32."""
    with open(path, "rb") as f:
        assert f.readline().strip() == b"Pf"
        w, h = map(int, f.readline().split())
        scale = float(f.readline())
        data = np.frombuffer(f.read(), dtype="<f4" if scale < 0 else ">f4")
    return data.reshape(h, w)[::-1].astype(np.float32)
