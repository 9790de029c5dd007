"""tiltfield: GPU (Vulkan) tilt-shift refocus of light fields, numpy in and numpy out.

A light field is a grid of views taken by a camera array or a plenoptic camera. tiltfield
renders the refocus image: the weighted average of the views in a synthetic aperture, each
warped so that a chosen surface lines up -- a plane in any orientation (a tilt-shift lens), a
frontoparallel disparity, a plane picked by a click, several planes, a slab, or all in focus.

    >>> import tiltfield
    >>> lf = tiltfield.open("/data/hci/backgammon")          # or tiltfield.from_array(views)
    >>> img = lf.refocus(disparity=0.5)                       # uint8 (H, W, 4), sRGB
    >>> tilted = lf.refocus(focus=3.0, tilt=10, linear=True)  # float32 (H, W, 4), linear
    >>> pull = lf.animate(20, sweep="disparity=-1.5..1.5")    # uint8 (20, H, W, 4) frames
    >>> lf.animate(20, orbit=2, disparity=0, path="orbit.gif")  # written as tiltfield animate

Conventions (as the ``tiltfield`` command line's; see its README):

- grid position (s, t): s the column (to the right), t the row (downwards); ``view=(s, t)``
  may be fractional (a virtual camera between the real ones);
- pixel (u, v): u the column, v the row of the depth map's view (normally the centre view);
- arrays are numpy-ordered: images (H, W, channels), light fields (rows, cols, H, W, C);
- colour: ``uint8`` is sRGB-encoded, ``float32`` is linear light; views are averaged in linear
  light unless ``average="encoded"``;
- world units are those of the data (metres on HCI data, ``baseline`` units on grid folders).

Every keyword mirrors a ``tiltfield render`` option (``aperture_radius`` is
``--aperture-radius``) and is checked by the same code: a bad value raises ``ValueError``, a
wrong type ``TypeError``, naming the keyword (the command line's message with its options
spelled as keywords; ``OSError`` for files, ``RuntimeError`` for the GPU). Sequences (tuples,
lists, 1-D arrays) are taken wherever numbers come in groups. Ctrl-C raises
``KeyboardInterrupt`` at once in any call. One GPU context serves the whole process; each
LightField uploads its views once; pickling sends what made it (a path, or the arrays).
The package is typed (``py.typed``): ``mypy --strict`` checks calls against its stubs.
Set ``TILTFIELD_DEVICE`` to pick a device and ``TILTFIELD_VALIDATION=1`` (before the first GPU
call) to run under the Khronos validation layer.
"""

from os import PathLike
from typing import Optional, Union

import numpy as np
import numpy.typing as npt

from ._tiltfield import (  # noqa: F401  (re-exported API)
    LightField,
    __version__,
    device,
    from_array,
    open,
    validation_enabled,
    validation_errors,
)



# Pickling (LightField.__reduce__): a light field travels as what made it, never as GPU state.
def _reopen(
    source: Union[str, "PathLike[str]"], frame: Optional[int], focal_px: Optional[float], baseline: float
) -> LightField:
    return open(source, frame, focal_px=focal_px, baseline=baseline)


def _rebuild(
    views: npt.NDArray[np.uint8],
    focal_px: Optional[float],
    baseline: Optional[float],
    depth: Optional[npt.NDArray[np.float32]],
) -> LightField:
    return from_array(views, focal_px=focal_px, baseline=baseline, depth=depth)


__all__ = [
    "LightField",
    "__version__",
    "device",
    "from_array",
    "open",
    "validation_enabled",
    "validation_errors",
]
