"""Type stubs of the native module ``starnet._starnet``."""

import os
from typing import Any, Mapping, Optional, Sequence, Union

import numpy as np
import numpy.typing as npt

_Path = Union[str, "os.PathLike[str]"]

class StarnetError(Exception):
    """Bad input or a failed operation; the message names the file, line or key."""

class Detections:
    """The detections of one sweep."""

    id: str
    boxes: npt.NDArray[np.float32]
    """``[M, 7]``: ``x, y, z, dx, dy, dz, heading`` per box, LiDAR frame, best first."""
    scores: npt.NDArray[np.float32]
    """``[M]`` scores in [0, 1]."""
    classes: list[str]
    """The class name of each box."""
    num_points: int
    """Points detected on (rows without a return and beyond-range points dropped)."""
    wild_points_dropped: int
    """Points beyond ``pipeline.wild_points.limit``, dropped."""
    kitti_lines: Optional[list[str]]
    """KITTI result lines when a calibration was given, else None."""
    def __len__(self) -> int: ...

class Detector:
    """A trained StarNet model at one center/point budget.

    ``model``: an export folder (``model.safetensors``) or a checkpoint (folder or
    ``model.bpk``, with its run's ``config.toml`` or ``config``). ``centers``, ``points``: the
    budget (default: the config's evaluation budget). ``seed``: seeds the center sampling
    (default: the config's), as ``starnet detect`` does.
    """

    def __init__(
        self,
        model: _Path,
        *,
        config: Optional[_Path] = None,
        centers: Optional[int] = None,
        points: Optional[int] = None,
        seed: Optional[int] = None,
    ) -> None: ...
    @property
    def classes(self) -> list[str]: ...
    @property
    def centers(self) -> int: ...
    @property
    def points(self) -> int: ...
    @property
    def gflop_per_frame(self) -> float: ...
    def detect(
        self,
        points: npt.ArrayLike,
        *,
        calib: Optional[_Path] = None,
        index: int = 0,
        id: Optional[str] = None,
    ) -> Detections:
        """Detects one sweep: ``points`` ``[N, 4]`` (x, y, z, intensity) or ``[N, 3]``.

        With ``calib`` (a KITTI calib file) centers are sampled in camera 2's view and
        ``kitti_lines`` is filled; without, all around the sensor. ``index`` seeds the sampling
        (``starnet detect`` gives a folder's i-th file index i).
        """
    def detect_many(
        self,
        sweeps: Sequence[npt.ArrayLike],
        *,
        calibs: Optional[Sequence[Optional[_Path]]] = None,
    ) -> list[Detections]:
        """``detect`` on each sweep, ``index`` its place in the list."""

def read_cloud(path: _Path) -> npt.NDArray[np.float32]:
    """A point cloud file (.bin, .pcd, .ply, .npy) as ``[N, 4]`` (with intensity) or ``[N, 3]``."""

def score_folder(
    gt_root: _Path,
    results: _Path,
    *,
    split: str = "val",
    classes: Optional[Sequence[str]] = None,
    labels: str = "label_2",
    format: Optional[str] = None,
) -> dict[str, Any]: ...
def score_arrays(
    gt_root: _Path,
    results: Mapping[str, Any],
    *,
    split: str = "val",
    classes: Optional[Sequence[str]] = None,
    labels: str = "label_2",
) -> dict[str, Any]: ...
def kitti_folder(
    gt_root: _Path,
    results: _Path,
    *,
    split: str = "val",
    classes: Optional[Sequence[str]] = None,
    format: Optional[str] = None,
) -> list[dict[str, Any]]: ...
def kitti_arrays(
    gt_root: _Path,
    results: Mapping[str, Any],
    *,
    split: str = "val",
    classes: Optional[Sequence[str]] = None,
) -> list[dict[str, Any]]: ...
