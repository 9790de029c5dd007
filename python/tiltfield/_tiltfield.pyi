"""Types of tiltfield's native module (re-exported by the package; see its docstrings)."""

from os import PathLike
from typing import Any, Callable, Dict, List, Literal, Optional, Sequence, Tuple, TypedDict, Union, overload

import numpy as np
import numpy.typing as npt

__version__: str

# A number, or several (a focus surface; a focal stack's values).
_Number = Union[float, int, np.floating[Any], np.integer[Any]]
_Numbers = Union[_Number, Sequence[_Number], npt.NDArray[np.floating[Any]]]
# n numbers given as any sequence (a tuple, list or 1-D array).
_Vector = Union[Sequence[_Number], npt.NDArray[np.floating[Any]], npt.NDArray[np.integer[Any]]]
_Switch = Union[bool, np.bool_, Literal["on", "off"]]
_AutoSwitch = Union[_Switch, Literal["auto"]]
_Aperture = Literal["disk", "square", "gaussian"]
_Average = Literal["linear", "encoded"]
_NormalMethod = Literal["inverse-depth", "pca"]
_Filter = Literal["hardware", "shader", "bicubic", "nearest"]
_Accumulation = Literal["rgba32f", "rgba16f"]
_Warps = Literal["ubo", "ssbo"]
_Storage = Literal["srgb8", "linear16"]
# "auto", "fragment", "compute" or "batched:N".
_Strategy = str
_Image8 = npt.NDArray[np.uint8]
_ImageF = npt.NDArray[np.float32]
_PointNormal = Tuple[Tuple[float, float, float], Tuple[float, float, float]]

class Cloud(TypedDict):
    """What :meth:`LightField.cloud` returns."""

    positions: npt.NDArray[np.float32]
    normals: npt.NDArray[np.float32]
    colours: _Image8
    quality: npt.NDArray[np.float32]
    points: int
    faces: List[List[int]]
    planes: List[_PointNormal]

class LightField:
    """A light field on the GPU: views uploaded once, refocused any number of times."""

    @property
    def name(self) -> str: ...
    @property
    def grid(self) -> Tuple[int, int]: ...
    @property
    def view_size(self) -> Tuple[int, int]: ...
    @property
    def has_depth(self) -> bool: ...
    @property
    def uploaded(self) -> bool: ...
    @property
    def last_gpu_ms(self) -> Optional[float]: ...
    @property
    def last_strategy(self) -> Optional[Tuple[str, Literal["auto", "option"]]]: ...
    def views(self) -> _Image8: ...
    def __reduce__(self) -> Tuple[Callable[..., "LightField"], Tuple[Any, ...]]: ...
    @overload
    def refocus(
        self,
        *,
        disparity: Optional[_Numbers] = None,
        plane: Optional[Union[_Vector, Sequence[_Vector]]] = None,
        focus: Optional[_Numbers] = None,
        tilt: Optional[_Numbers] = None,
        swing: Optional[_Numbers] = None,
        click: Optional[_Vector] = None,
        points: Optional[_Vector] = None,
        points_3d: Optional[_Vector] = None,
        nudge_distance: Optional[float] = None,
        nudge_tilt: Optional[float] = None,
        nudge_swing: Optional[float] = None,
        normal_window: Optional[int] = None,
        normal_method: _NormalMethod = "inverse-depth",
        slab: Optional[float] = None,
        all_in_focus: bool = False,
        aperture: _Aperture = "disk",
        aperture_radius: Optional[float] = None,
        view: Optional[_Vector] = None,
        size: Optional[Sequence[int]] = None,
        average: _Average = "linear",
        include_dark: bool = False,
        antialias: Optional[_Switch] = None,
        antialias_samples: Optional[int] = None,
        antialias_prefilter: Optional[_Switch] = None,
        antialias_focus_test: Optional[_Switch] = None,
        antialias_focused_bicubic: Optional[_Switch] = None,
        antialias_occlusion: Optional[_Switch] = None,
        antialias_defocus: Optional[_Switch] = None,
        antialias_layered: Optional[_AutoSwitch] = None,
        antialias_box: Optional[_Switch] = None,
        strategy: Optional[_Strategy] = None,
        views_per_draw: Optional[int] = None,
        filter: Optional[_Filter] = None,
        accumulation: Optional[_Accumulation] = None,
        warps: Optional[_Warps] = None,
        storage: Optional[_Storage] = None,
        linear: Literal[False] = False,
    ) -> _Image8: ...
    @overload
    def refocus(
        self,
        *,
        disparity: Optional[_Numbers] = None,
        plane: Optional[Union[_Vector, Sequence[_Vector]]] = None,
        focus: Optional[_Numbers] = None,
        tilt: Optional[_Numbers] = None,
        swing: Optional[_Numbers] = None,
        click: Optional[_Vector] = None,
        points: Optional[_Vector] = None,
        points_3d: Optional[_Vector] = None,
        nudge_distance: Optional[float] = None,
        nudge_tilt: Optional[float] = None,
        nudge_swing: Optional[float] = None,
        normal_window: Optional[int] = None,
        normal_method: _NormalMethod = "inverse-depth",
        slab: Optional[float] = None,
        all_in_focus: bool = False,
        aperture: _Aperture = "disk",
        aperture_radius: Optional[float] = None,
        view: Optional[_Vector] = None,
        size: Optional[Sequence[int]] = None,
        average: _Average = "linear",
        include_dark: bool = False,
        antialias: Optional[_Switch] = None,
        antialias_samples: Optional[int] = None,
        antialias_prefilter: Optional[_Switch] = None,
        antialias_focus_test: Optional[_Switch] = None,
        antialias_focused_bicubic: Optional[_Switch] = None,
        antialias_occlusion: Optional[_Switch] = None,
        antialias_defocus: Optional[_Switch] = None,
        antialias_layered: Optional[_AutoSwitch] = None,
        antialias_box: Optional[_Switch] = None,
        strategy: Optional[_Strategy] = None,
        views_per_draw: Optional[int] = None,
        filter: Optional[_Filter] = None,
        accumulation: Optional[_Accumulation] = None,
        warps: Optional[_Warps] = None,
        storage: Optional[_Storage] = None,
        linear: Literal[True],
    ) -> _ImageF: ...
    @overload
    def focal_stack(
        self,
        *,
        disparity: Optional[_Numbers] = None,
        focus: Optional[_Numbers] = None,
        progress: Optional[Callable[[int, int], object]] = None,
        linear: Literal[False] = False,
        **options: Any,
    ) -> _Image8: ...
    @overload
    def focal_stack(
        self,
        *,
        disparity: Optional[_Numbers] = None,
        focus: Optional[_Numbers] = None,
        progress: Optional[Callable[[int, int], object]] = None,
        linear: Literal[True],
        **options: Any,
    ) -> _ImageF: ...
    @overload
    def animate(
        self,
        frames: int,
        *,
        sweep: Optional[Union[str, Tuple[str, float, float], Sequence[Union[str, float]]]] = None,
        orbit: Optional[float] = None,
        bounce: bool = False,
        fps: float = 20.0,
        path: None = None,
        **options: Any,
    ) -> _Image8: ...
    @overload
    def animate(
        self,
        frames: int,
        *,
        sweep: Optional[Union[str, Tuple[str, float, float], Sequence[Union[str, float]]]] = None,
        orbit: Optional[float] = None,
        bounce: bool = False,
        fps: float = 20.0,
        path: Union[str, PathLike[str]],
        **options: Any,
    ) -> None: ...
    @overload
    def plane(
        self,
        *,
        disparity: Optional[_Numbers] = None,
        plane: Optional[Union[_Vector, Sequence[_Vector]]] = None,
        focus: Optional[_Numbers] = None,
        tilt: Optional[_Numbers] = None,
        swing: Optional[_Numbers] = None,
        click: Optional[_Vector] = None,
        points: Optional[_Vector] = None,
        points_3d: Optional[_Vector] = None,
        nudge_distance: Optional[float] = None,
        nudge_tilt: Optional[float] = None,
        nudge_swing: Optional[float] = None,
        normal_window: Optional[int] = None,
        normal_method: _NormalMethod = "inverse-depth",
        aperture: _Aperture = "disk",
        aperture_radius: Optional[float] = None,
        view: Optional[_Vector] = None,
        include_dark: bool = False,
        confidence: Literal[False] = False,
    ) -> Optional[_PointNormal]: ...
    @overload
    def plane(
        self,
        *,
        disparity: Optional[_Numbers] = None,
        plane: Optional[Union[_Vector, Sequence[_Vector]]] = None,
        focus: Optional[_Numbers] = None,
        tilt: Optional[_Numbers] = None,
        swing: Optional[_Numbers] = None,
        click: Optional[_Vector] = None,
        points: Optional[_Vector] = None,
        points_3d: Optional[_Vector] = None,
        nudge_distance: Optional[float] = None,
        nudge_tilt: Optional[float] = None,
        nudge_swing: Optional[float] = None,
        normal_window: Optional[int] = None,
        normal_method: _NormalMethod = "inverse-depth",
        aperture: _Aperture = "disk",
        aperture_radius: Optional[float] = None,
        view: Optional[_Vector] = None,
        include_dark: bool = False,
        confidence: Literal[True],
    ) -> Optional[Tuple[Tuple[float, float, float], Tuple[float, float, float], Optional[float]]]: ...
    def cloud(
        self,
        path: Optional[Union[str, PathLike[str]]] = None,
        *,
        stride: Optional[int] = None,
        cameras: bool = False,
        plane_size: Optional[float] = None,
        slab: Optional[float] = None,
        disparity: Optional[_Numbers] = None,
        plane: Optional[Union[_Vector, Sequence[_Vector]]] = None,
        focus: Optional[_Numbers] = None,
        tilt: Optional[_Numbers] = None,
        swing: Optional[_Numbers] = None,
        click: Optional[_Vector] = None,
        points: Optional[_Vector] = None,
        points_3d: Optional[_Vector] = None,
        nudge_distance: Optional[float] = None,
        nudge_tilt: Optional[float] = None,
        nudge_swing: Optional[float] = None,
        normal_window: Optional[int] = None,
        normal_method: _NormalMethod = "inverse-depth",
        view: Optional[_Vector] = None,
    ) -> Cloud: ...
    @overload
    def depth(
        self,
        *,
        kind: Optional[Literal["disparity", "depth"]] = None,
        planes: Optional[int] = None,
        range: Optional[_Vector] = None,
        views: str = "cross",
        view: Optional[_Vector] = None,
        cost: Optional[Literal["robust", "mean", "drop-worst"]] = None,
        aggregation: Optional[Literal["guided", "box", "none"]] = None,
        radius: Optional[int] = None,
        naive: bool = False,
        no_fit: bool = False,
        no_snap: bool = False,
        no_smooth: bool = False,
        no_plane_fill: bool = False,
        median: Optional[int] = None,
        include_dark: bool = False,
        confidence: Literal[False] = False,
    ) -> _ImageF: ...
    @overload
    def depth(
        self,
        *,
        kind: Optional[Literal["disparity", "depth"]] = None,
        planes: Optional[int] = None,
        range: Optional[_Vector] = None,
        views: str = "cross",
        view: Optional[_Vector] = None,
        cost: Optional[Literal["robust", "mean", "drop-worst"]] = None,
        aggregation: Optional[Literal["guided", "box", "none"]] = None,
        radius: Optional[int] = None,
        naive: bool = False,
        no_fit: bool = False,
        no_snap: bool = False,
        no_smooth: bool = False,
        no_plane_fill: bool = False,
        median: Optional[int] = None,
        include_dark: bool = False,
        confidence: Literal[True],
    ) -> Tuple[_ImageF, _ImageF]: ...

def open(
    source: Union[str, PathLike[str]],
    frame: Optional[int] = None,
    *,
    focal_px: Optional[float] = None,
    baseline: float = 1.0,
) -> LightField: ...
def from_array(
    views: Union[npt.NDArray[np.uint8], npt.NDArray[np.float32], Any],
    *,
    focal_px: Optional[float] = None,
    baseline: Optional[float] = None,
    depth: Optional[npt.NDArray[np.float32]] = None,
) -> LightField: ...
def device() -> Dict[str, str]: ...
def validation_errors() -> int: ...
def validation_enabled() -> bool: ...
def _srgb_table_mismatches(lo: int, hi: int) -> list[int]: ...
