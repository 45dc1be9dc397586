# Type stubs of the rangeseg module (pybind11), for IDEs and type checkers: installed beside
# the extension module. tests/python/test_stubs.py checks them against the module's names and
# signatures.
import os
from typing import Any, Optional, Union

import numpy as np
import numpy.typing as npt

__version__: str

PathLike = Union[str, os.PathLike[str]]

class Cloud:
    """A point cloud: organized (a pixel grid, height > 1) or unorganized (height 1)."""

    def __init__(
        self,
        points: npt.ArrayLike,
        intensity: Optional[npt.ArrayLike] = None,
        colors: Optional[npt.ArrayLike] = None,
        labels: Optional[npt.ArrayLike] = None,
    ) -> None: ...
    @property
    def points(self) -> npt.NDArray[np.float32]:
        """(H, W, 3) or (N, 3) [m], NaN where there is no point (a new copy each time)."""
    @property
    def intensity(self) -> Optional[npt.NDArray[np.float32]]: ...
    @property
    def colors(self) -> Optional[npt.NDArray[np.uint8]]: ...
    @property
    def labels(self) -> Optional[npt.NDArray[np.int32]]: ...
    @property
    def width(self) -> int: ...
    @property
    def height(self) -> int: ...
    @property
    def is_organized(self) -> bool: ...
    def count_valid(self) -> int: ...

class Result:
    """One frame's results (copies: they stay valid after the next frame)."""

    def __init__(
        self,
        width: int,
        height: int,
        organized: bool,
        labels: npt.ArrayLike,
        points: npt.ArrayLike,
        normals: npt.ArrayLike,
        raw_normals: npt.ArrayLike,
        curvature: npt.ArrayLike,
        segments: list[dict[str, Any]],
        times: dict[str, float],
    ) -> None:
        """A result from its fields, as pickle rebuilds one (Pipeline.process makes them)."""
    @property
    def points(self) -> npt.NDArray[np.float32]: ...
    @property
    def normals(self) -> npt.NDArray[np.float32]: ...
    @property
    def raw_normals(self) -> npt.NDArray[np.float32]: ...
    @property
    def curvature(self) -> npt.NDArray[np.float32]: ...
    @property
    def labels(self) -> npt.NDArray[np.int32]:
        """Segment label per point: 0 = no segment, label i is segments[i - 1]."""
    @property
    def segments(self) -> list[dict[str, Any]]:
        """One dict per segment with the keys of segments.json."""
    @property
    def times(self) -> dict[str, float]:
        """Milliseconds per stage of this frame."""
    @property
    def organized(self) -> bool: ...
    @property
    def width(self) -> int: ...
    @property
    def height(self) -> int: ...

class Pipeline:
    """Mesh, normals, smoothing, segmentation and polygons of frame after frame."""

    def __init__(
        self,
        preset: Optional[str] = None,
        model: Optional[str] = None,
        smooth: Optional[bool] = None,
        track: Optional[bool] = None,
        threads: int = 1,
        config: Union[None, PathLike, dict[str, Any]] = None,
    ) -> None: ...
    def process(
        self,
        points: Union[Cloud, npt.ArrayLike],
        intensity: Optional[npt.ArrayLike] = None,
        colors: Optional[npt.ArrayLike] = None,
        *,
        fx: float = 0.0,
    ) -> Result: ...
    def process_depth(
        self,
        depth: npt.ArrayLike,
        *,
        fx: float,
        fy: float,
        cx: float,
        cy: float,
        depth_scale: Optional[float] = None,
        width: int = 0,
        height: int = 0,
    ) -> Result: ...
    def reset_tracks(self) -> None: ...
    @property
    def settings(self) -> dict[str, Any]: ...
    @property
    def model(self) -> str: ...
    @property
    def smooth(self) -> bool: ...
    @property
    def track(self) -> bool: ...
    @property
    def threads(self) -> int: ...

def read_cloud(path: PathLike) -> Cloud: ...
def read_depth_png(path: PathLike) -> npt.NDArray[np.uint16]: ...
def read_label_png(path: PathLike) -> npt.NDArray[np.int32]: ...
def read_camera(path: PathLike) -> dict[str, Any]: ...
def read_camera_json(path: PathLike) -> dict[str, Any]: ...
def evaluate(
    ground_truth: npt.ArrayLike,
    segmentation: npt.ArrayLike,
    tolerance: float = 0.8,
    min_gt_label: int = 1,
    points: Optional[npt.ArrayLike] = None,
) -> dict[str, Any]: ...
