"""KITTI AP as the official devkit computes it, and Waymo-style AP/APH, over a KITTI split.

Each function scores either a result folder (``{id}.txt`` in KITTI's result format, or
``{id}.json`` as ``starnet detect`` writes them) or a dict from every frame id of the split to
that frame's detections (a :class:`starnet.Detections`, or a dict or object with ``boxes``
``[M, 7]`` in the LiDAR frame, ``scores`` ``[M]`` and ``classes``, M names). The figures are
those of ``starnet eval --results``, as plain Python objects.
"""

from __future__ import annotations

import os
from typing import Any, Mapping, Optional, Sequence, Union

from . import _starnet

Results = Union[str, "os.PathLike[str]", Mapping[str, Any]]


def score(
    gt_root: Union[str, "os.PathLike[str]"],
    results: Results,
    *,
    split: str = "val",
    classes: Optional[Sequence[str]] = None,
    labels: str = "label_2",
    format: Optional[str] = None,
) -> dict:
    """Every metric, as ``starnet eval --results ... --out`` writes ``eval.json``.

    ``gt_root``: the KITTI root (``training/label_2``, ``calib``, ``velodyne``,
    ``ImageSets/{split}.txt``). ``classes``: those to score (default: Car, Pedestrian and
    Cyclist, those with a detection). ``labels``: ``"label_2"`` (camera view) or
    ``"label_360"`` (the simulator's all-around labels; Waymo-style metrics only). ``format``
    (folders only): ``"kitti"`` or ``"detect"``, default whichever the first frame has.

    Returns a dict: ``frames``; ``classes``, per class its KITTI AP (``three_d``, ``bev``,
    ``bbox`` (2D), ``aos``: a list over easy, moderate, hard of ``r40`` and ``r11``); ``waymo``,
    per class LEVEL_1 / LEVEL_2 AP and APH; ``by_range``.
    """
    if isinstance(results, Mapping):
        if format is not None:
            raise ValueError("format applies to a result folder, not to arrays")
        return _starnet.score_arrays(gt_root, dict(results), split=split, classes=classes, labels=labels)
    return _starnet.score_folder(
        gt_root, results, split=split, classes=classes, labels=labels, format=format
    )


def kitti(
    gt_root: Union[str, "os.PathLike[str]"],
    results: Results,
    *,
    split: str = "val",
    classes: Optional[Sequence[str]] = None,
    format: Optional[str] = None,
) -> list:
    """KITTI AP per class (camera-view labels), as the devkit computes it: ``score(...)["classes"]``,
    from the labels and calibrations alone (the scans are not read, no other metric is computed)."""
    if isinstance(results, Mapping):
        if format is not None:
            raise ValueError("format applies to a result folder, not to arrays")
        return _starnet.kitti_arrays(gt_root, dict(results), split=split, classes=classes)
    return _starnet.kitti_folder(gt_root, results, split=split, classes=classes, format=format)


def waymo(
    gt_root: Union[str, "os.PathLike[str]"],
    results: Results,
    *,
    split: str = "val",
    classes: Optional[Sequence[str]] = None,
    labels: str = "label_2",
    format: Optional[str] = None,
) -> list:
    """Waymo-style AP / APH per class and level: ``score(...)["waymo"]``."""
    return score(gt_root, results, split=split, classes=classes, labels=labels, format=format)["waymo"]


__all__ = ["score", "kitti", "waymo"]
