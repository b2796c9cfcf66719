#!/usr/bin/env python3
"""KITTI AP with `starnet.metrics` against the numba port people use (issue #52).

The port is second.pytorch's `kitti_object_eval_python` as mmdetection3d 1.4 carries it
(`mmdet3d/evaluation/functional/kitti_utils/{eval,rotate_iou}.py`). This script imports those two
files from an unpacked `mmdet3d` wheel (`pip download mmdet3d --no-deps`, then unzip; nothing of
mmdet3d is copied into this repository and no other part of mmdet3d is imported), reads the
ground truth and a result folder in KITTI's format as mmdet3d's `get_label_anno` does, and scores
both ways on the same files: time (first call, then the median of `--repeat` calls) and the
largest difference over every figure both report (3D, BEV and 2D; R40 and R11; easy,
moderate, hard; the strict overlaps).

The port's rotated IoU is a CUDA kernel (numba.cuda). Without a GPU it runs in one of two ways,
chosen by `--rotate-iou`:
  cpu      the same device functions compiled for the CPU by numba (`njit`, a `prange` over boxes):
           what the port would cost if it ran natively here (the fair comparison);
  cudasim  numba's CUDA simulator (NUMBA_ENABLE_CUDASIM=1, set by this script before numba loads):
           what a CPU-only machine runs when it calls mmdet3d's `kitti_eval` unchanged.

Run it in a venv with the starnet wheel, numpy and numba:
  python scripts/metric_bench.py --mmdet3d /tmp/mm --gt data/sim --results RESULTS_DIR --split val
"""

from __future__ import annotations

import argparse
import importlib.util
import json
import os
import re
import statistics
import sys
import time
import types
from pathlib import Path


def parse_args() -> argparse.Namespace:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--mmdet3d", required=True, type=Path, help="an unpacked mmdet3d wheel (holds mmdet3d/)")
    parser.add_argument("--gt", required=True, type=Path, help="the KITTI root of the ground truth")
    parser.add_argument("--results", required=True, type=Path, help="a folder of {id}.txt in KITTI's result format")
    parser.add_argument("--split", default="val")
    parser.add_argument("--classes", default="Car", help="comma-separated KITTI class names")
    parser.add_argument("--repeat", type=int, default=3, help="timed calls after the first")
    parser.add_argument("--rotate-iou", choices=["cpu", "cudasim"], default="cpu")
    parser.add_argument("--json", type=Path, help="write the timings and differences here")
    return parser.parse_args()


def load_port(mmdet3d: Path, rotate_iou: str) -> types.ModuleType:
    """The port's `eval` module, with its `rotate_iou` as `--rotate-iou` chooses."""
    folder = mmdet3d / "mmdet3d" / "evaluation" / "functional" / "kitti_utils"
    package = types.ModuleType("kitti_port")
    package.__path__ = [str(folder)]
    sys.modules["kitti_port"] = package
    if rotate_iou == "cpu":
        sys.modules["kitti_port.rotate_iou"] = cpu_rotate_iou(folder / "rotate_iou.py")
    spec = importlib.util.spec_from_file_location("kitti_port.eval", folder / "eval.py")
    module = importlib.util.module_from_spec(spec)
    sys.modules["kitti_port.eval"] = module
    spec.loader.exec_module(module)
    return module


CPU_DRIVER = '''

@numba.njit(parallel=True)
def _rotate_iou_cpu(boxes, query_boxes, criterion):
    iou = np.zeros((boxes.shape[0], query_boxes.shape[0]), dtype=np.float32)
    for n in numba.prange(boxes.shape[0]):
        for k in range(query_boxes.shape[0]):
            # The kernel's argument order: the query box first.
            iou[n, k] = devRotateIoUEval(query_boxes[k], boxes[n], criterion)
    return iou


def rotate_iou_gpu_eval(boxes, query_boxes, criterion=-1, device_id=0):
    boxes = boxes.astype(np.float32)
    query_boxes = query_boxes.astype(np.float32)
    return _rotate_iou_cpu(boxes, query_boxes, criterion).astype(boxes.dtype)
'''


def cpu_rotate_iou(path: Path) -> types.ModuleType:
    """`rotate_iou.py` with its device functions compiled by numba for the CPU.

    The text up to the kernel is kept as it is but for two substitutions: `cuda.jit(device=True)`
    becomes `numba.njit`, and a thread-local `cuda.local.array` a numpy array of the same shape
    and type (uninitialised, as on the device). The kernel and its launcher are replaced by a loop
    over the same pairs in the same argument order.
    """
    source = path.read_text()
    source = source[: source.index("@cuda.jit(\n    '(int64")]
    source = source.replace("@cuda.jit(device=True, inline=True)", "@numba.njit")
    source = re.sub(r"cuda\.local\.array\(", "np.empty(", source)
    source = source.replace("dtype=numba.float32", "dtype=np.float32")
    module = types.ModuleType("kitti_port.rotate_iou")
    exec(compile(source + CPU_DRIVER, str(path), "exec"), module.__dict__)
    return module


def read_anno(path: Path, np) -> dict:
    """One label or result file as mmdet3d's `get_label_anno` reads it (dimensions l, h, w)."""
    rows = [line.split() for line in path.read_text().splitlines() if line.strip()]
    anno = {
        "name": np.array([r[0] for r in rows]),
        "truncated": np.array([float(r[1]) for r in rows]),
        "occluded": np.array([int(float(r[2])) for r in rows]),
        "alpha": np.array([float(r[3]) for r in rows]),
        "bbox": np.array([[float(v) for v in r[4:8]] for r in rows]).reshape(-1, 4),
        "dimensions": np.array([[float(v) for v in r[8:11]] for r in rows]).reshape(-1, 3)[:, [2, 0, 1]],
        "location": np.array([[float(v) for v in r[11:14]] for r in rows]).reshape(-1, 3),
        "rotation_y": np.array([float(r[14]) for r in rows]).reshape(-1),
    }
    if rows and len(rows[0]) == 16:
        anno["score"] = np.array([float(r[15]) for r in rows])
    else:
        anno["score"] = np.zeros(len(rows))
    return anno


def read_split(args: argparse.Namespace, np) -> tuple[list, list]:
    ids = (args.gt / "ImageSets" / f"{args.split}.txt").read_text().split()
    labels = args.gt / "training" / "label_2"
    gt = [read_anno(labels / f"{i}.txt", np) for i in ids]
    dt = [read_anno(args.results / f"{i}.txt", np) for i in ids]
    return gt, dt


def timed(call, repeat: int) -> tuple[object, float, float]:
    """(result, seconds of the first call, median seconds of the next `repeat`)."""
    start = time.perf_counter()
    result = call()
    first = time.perf_counter() - start
    times = []
    for _ in range(repeat):
        start = time.perf_counter()
        call()
        times.append(time.perf_counter() - start)
    return result, first, statistics.median(times) if times else first


METRICS = {"three_d": "3D", "bev": "BEV", "bbox": "2D"}
DIFFICULTIES = ["easy", "moderate", "hard"]


def starnet_figures(classes_out: list) -> dict:
    """starnet's per-class AP as the port's keys (`KITTI/Car_3D_AP40_moderate_strict`)."""
    figures = {}
    for entry in classes_out:
        for ours, theirs in METRICS.items():
            for recall in ("r40", "r11"):
                for difficulty, ap in zip(DIFFICULTIES, entry[ours]):
                    key = f"KITTI/{entry['class']}_{theirs}_AP{recall[1:]}_{difficulty}_strict"
                    figures[key] = ap[recall]
    return figures


def main() -> None:
    args = parse_args()
    if args.rotate_iou == "cudasim":
        os.environ["NUMBA_ENABLE_CUDASIM"] = "1"
    import numpy as np
    import starnet.metrics

    port = load_port(args.mmdet3d, args.rotate_iou)
    classes = args.classes.split(",")
    ours, ours_first, ours_median = timed(
        lambda: starnet.metrics.kitti(args.gt, args.results, split=args.split, classes=classes, format="kitti"),
        args.repeat,
    )
    (gt, dt), load_first, load_median = timed(lambda: read_split(args, np), args.repeat)
    (_, theirs), port_first, port_median = timed(lambda: port.kitti_eval(gt, dt, classes, ["bbox", "bev", "3d"]), args.repeat)
    ours_figures = starnet_figures(ours)
    diffs = {k: abs(float(theirs[k]) - v) for k, v in ours_figures.items() if k in theirs}
    worst = max(diffs, key=diffs.get)
    report = {
        "frames": len(gt),
        "rotate_iou": args.rotate_iou,
        "starnet_s": {"first": ours_first, "median": ours_median},
        "port_read_s": {"first": load_first, "median": load_median},
        "port_eval_s": {"first": port_first, "median": port_median},
        "speedup_median": (load_median + port_median) / ours_median,
        "figures_compared": len(diffs),
        "max_abs_diff": diffs[worst],
        "max_abs_diff_key": worst,
        "moderate_3d_r40": {
            c: {"starnet": ours_figures[f"KITTI/{c}_3D_AP40_moderate_strict"],
                "port": float(theirs[f"KITTI/{c}_3D_AP40_moderate_strict"])}
            for c in classes
        },
    }
    text = json.dumps(report, indent=2)
    print(text)
    if args.json:
        args.json.write_text(text + "\n")


if __name__ == "__main__":
    main()
