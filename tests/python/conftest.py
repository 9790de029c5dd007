"""Shared set-up of the Python module's tests: the CLI to compare with, validation on, a
private depth cache, and small light fields (5x5 views of 64 px) made once per session.

The environment is fixed before `tiltfield` starts Vulkan (it reads TILTFIELD_VALIDATION when
its one context is made), so every test runs under the Khronos validation layer, and the
session ends by asserting that the layer reported no error.
"""

import os
import subprocess
from pathlib import Path

import numpy as np
import pytest
from PIL import Image

os.environ["TILTFIELD_VALIDATION"] = "1"

import tiltfield  # noqa: E402  (after the environment it reads)


def cli_path() -> Path:
    """The `tiltfield` binary of the same tree (tools/test.sh builds it and sets TILTFIELD_CLI)."""
    given = os.environ.get("TILTFIELD_CLI")
    if given:
        return Path(given)
    target = os.environ.get("CARGO_TARGET_DIR", str(Path.home() / ".cache/tiltfield/target"))
    return Path(target) / "debug" / "tiltfield"


@pytest.fixture(scope="session", autouse=True)
def private_cache(tmp_path_factory):
    """Depth estimates cached in a folder of this run, shared by the CLI and the module."""
    os.environ["TILTFIELD_CACHE_DIR"] = str(tmp_path_factory.mktemp("depth-cache"))
    yield


@pytest.fixture(scope="session", autouse=True)
def no_validation_errors():
    """Every test runs with the validation layer on; none may draw an error."""
    yield
    assert tiltfield.validation_enabled()
    assert tiltfield.validation_errors() == 0


class Cli:
    """Runs the command line with validation on, as a user would."""

    def __init__(self, path: Path):
        if not path.exists():
            raise RuntimeError(f"no tiltfield binary at {path}; build it (cargo build) first")
        self.path = path

    def run(self, *args: str) -> subprocess.CompletedProcess:
        validate = ["--validate"] if args[0] in ("render", "depth") else []
        return subprocess.run(
            [str(self.path), *args, *validate],
            capture_output=True,
            text=True,
            env=os.environ.copy(),
            timeout=600,
        )

    def ok(self, *args: str) -> str:
        r = self.run(*args)
        assert r.returncode == 0, f"tiltfield {' '.join(args)} failed:\n{r.stderr}"
        return r.stderr

    def error(self, *args: str) -> str:
        """The message after `error: ` of a failing command."""
        r = self.run(*args)
        assert r.returncode != 0, f"tiltfield {' '.join(args)} succeeded; expected a failure"
        lines = [ln for ln in r.stderr.splitlines() if ln.startswith("error: ")]
        assert lines, f"no 'error:' line in:\n{r.stderr}"
        return lines[-1][len("error: "):]

    def png(self, source: str, *args: str, tmp: Path) -> np.ndarray:
        out = tmp / "cli.png"
        self.ok("render", source, "-o", str(out), *args)
        return np.asarray(Image.open(out).convert("RGBA"))

    def exr(self, source: str, *args: str, tmp: Path) -> np.ndarray:
        out = tmp / "cli.exr"
        self.ok("render", source, "-o", str(out), *args)
        return read_exr_rgba(out)


def read_exr_rgba(path: Path) -> np.ndarray:
    """An RGBA float EXR as (H, W, 4) float32 (OpenEXR's Python module)."""
    import OpenEXR

    with OpenEXR.File(str(path)) as f:
        channels = f.channels()
        if "RGBA" in channels:
            return np.asarray(channels["RGBA"].pixels, dtype=np.float32)
        return np.stack([np.asarray(channels[c].pixels, dtype=np.float32) for c in "RGBA"], axis=-1)


@pytest.fixture(scope="session")
def cli() -> Cli:
    return Cli(cli_path())


@pytest.fixture(scope="session")
def planes():
    """builtin:planes: 5x5 views of 64x64 with a depth map (anti-aliased by default)."""
    return tiltfield.open("builtin:planes")


@pytest.fixture(scope="session")
def grid_folder(tmp_path_factory, planes):
    """The views of builtin:planes written as a grid folder (row_col.png): no depth, nominal
    cameras, classic disparity -- what from_array reads its arrays as."""
    folder = tmp_path_factory.mktemp("grid")
    views = planes.views()
    rows, cols = views.shape[:2]
    for t in range(rows):
        for s in range(cols):
            Image.fromarray(views[t, s]).save(folder / f"{t:02d}_{s:02d}.png")
    return folder


def srgb_to_linear(u8: np.ndarray) -> np.ndarray:
    """8-bit sRGB -> linear light (IEC 61966-2-1), float32: the inverse of the module's encode."""
    c = u8.astype(np.float64) / 255.0
    lin = np.where(c <= 0.04045, c / 12.92, ((c + 0.055) / 1.055) ** 2.4)
    return lin.astype(np.float32)
