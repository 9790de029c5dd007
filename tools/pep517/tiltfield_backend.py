"""The PEP 517 build backend of `pip wheel .` / `pip install .`: maturin's, with one change.

maturin's backend tags a wheel built through pip `linux_x86_64` (it passes `--compatibility
off` unless told otherwise), a tag no package index accepts. tiltfield's module links only
glibc, libm and libgcc_s (Vulkan is loaded at run time), so maturin's own audit can give it
the lowest manylinux tag the build allows; `--compatibility pypi` asks for exactly that (and
fails, naming the library, if a build ever links something a manylinux wheel may not).
Arguments given by the user (`--config-settings build-args=...` or MATURIN_PEP517_ARGS)
are left as they are.
"""

import os

from maturin import *  # noqa: F401,F403  (the hooks this module does not change)
from maturin import build_wheel as _maturin_build_wheel


def build_wheel(wheel_directory, config_settings=None, metadata_directory=None):
    given = (config_settings or {}).get("maturin.build-args", (config_settings or {}).get("build-args"))
    if given is None and not os.environ.get("MATURIN_PEP517_ARGS"):
        config_settings = {**(config_settings or {}), "build-args": "--compatibility pypi"}
    return _maturin_build_wheel(wheel_directory, config_settings, metadata_directory)
