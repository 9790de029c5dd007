"""The type stubs (tiltfield/_tiltfield.pyi, py.typed): mypy --strict accepts the README's
Python examples and a typical session, and flags wrong types, unknown keywords and choices
outside their Literal."""

import re
import shutil
import subprocess
import sys
import textwrap
from pathlib import Path

import pytest

import tiltfield

ROOT = Path(__file__).resolve().parents[2]


def mypy_command() -> list:
    """mypy from this interpreter, else Debian's python3-mypy (tools/setup.sh installs it)."""
    try:
        import mypy  # noqa: F401

        return [sys.executable, "-m", "mypy"]
    except ImportError:
        pass
    for python in ("/usr/bin/python3",):
        if Path(python).exists() and subprocess.run([python, "-c", "import mypy"], capture_output=True).returncode == 0:
            return [python, "-m", "mypy"]
    if shutil.which("mypy"):
        return [shutil.which("mypy")]
    pytest.skip("mypy is not installed (tools/setup.sh installs Debian's python3-mypy)")


def readme_examples() -> str:
    text = (ROOT / "README.md").read_text()
    section = text.split("## Python: `import tiltfield`", 1)[1].split("\n## ", 1)[0]
    blocks = re.findall(r"```python\n(.*?)```", section, re.S)
    assert blocks, "no Python example in the README's Python section"
    return "\n".join(blocks)


GOOD = """
import numpy as np
import numpy.typing as npt
import tiltfield

lf = tiltfield.open("builtin:planes")
img: npt.NDArray[np.uint8] = lf.refocus(disparity=0.5)
same = lf.refocus(disparity=[0.5, -0.5], size=[32, 32], antialias="off", aperture="square")
lin: npt.NDArray[np.float32] = lf.refocus(focus=3.0, tilt=5, linear=True)
stack: npt.NDArray[np.uint8] = lf.focal_stack(disparity=np.linspace(-1, 1, 5), antialias=False)
depth, confidence = lf.depth(confidence=True)
plane = lf.plane(click=(20, 30))
found = lf.plane(click=(20, 30), confidence=True)
if found is not None:
    (px, py, pz), normal, pick_confidence = found
    sure: float = pick_confidence if pick_confidence is not None else 0.0
rows, cols = lf.grid
copy = tiltfield.from_array(lf.views(), depth=depth)
"""

BAD = {
    'lf.refocus(disparity="far")': 'Argument "disparity" to "refocus" of "LightField" has incompatible type "str"',
    "lf.refocus(disparity=0.5, no_such_option=3)": 'No overload variant of "refocus"',
    'lf.refocus(disparity=0.5, aperture="hexagon")': 'No overload variant of "refocus"',
    "x: int = lf.refocus(disparity=0.5)": "Incompatible types in assignment",
    'lf.depth(kind="height")': 'No overload variant of "depth"',
    "tiltfield.open(3.5)": 'Argument 1 to "open" has incompatible type "float"',
}


def test_mypy_strict_passes_the_readme_and_good_calls_and_flags_bad_ones(tmp_path):
    command = mypy_command()
    (tmp_path / "readme_examples.py").write_text(readme_examples())
    (tmp_path / "good.py").write_text(GOOD)
    header = 'import tiltfield\nlf = tiltfield.open("builtin:planes")\n'
    (tmp_path / "bad.py").write_text(header + "\n".join(BAD) + "\n")
    r = subprocess.run(
        [*command, "--strict", "--no-incremental", "--python-executable", sys.executable,
         "readme_examples.py", "good.py", "bad.py"],
        cwd=tmp_path, capture_output=True, text=True, timeout=600,
    )
    errors = [ln for ln in r.stdout.splitlines() if ": error:" in ln]
    assert not [e for e in errors if not e.startswith("bad.py")], r.stdout
    for line, (call, message) in enumerate(BAD.items(), start=3):
        flagged = [e for e in errors if e.startswith(f"bad.py:{line}:")]
        assert flagged and message in flagged[0], (call, flagged, r.stdout)


def test_the_stubs_and_the_marker_ship_with_the_package():
    package = Path(tiltfield.__file__).parent
    assert (package / "py.typed").exists()
    stubs = (package / "_tiltfield.pyi").read_text()
    # Every public name of the native module is typed.
    for name in ("LightField", "open", "from_array", "device", "validation_errors", "validation_enabled"):
        assert re.search(rf"^(class|def) {name}\b", stubs, re.M), name
    for method in dir(tiltfield.LightField):
        if not method.startswith("_"):
            assert re.search(rf"def {method}\(|def {method}\b", stubs), method
