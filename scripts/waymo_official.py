#!/usr/bin/env python3
"""Waymo AP / APH of KITTI result files by the official Waymo Open Dataset metrics op.

A check of `starnet eval`'s Waymo-style table against the library it follows: the same boxes,
the same rules, the official `detection_metrics` op. The labels and result files (camera frame)
are turned into LiDAR boxes with each frame's calibration, as `starnet eval` does; a labelled Car
with more than 5 LiDAR returns inside its box is LEVEL_1, with 1 to 5 LEVEL_2; Vans and point-less
Cars are no-label zones (not matched; a prediction whose footprint overlaps one is flagged
`overlap_nlz`); other classes take no part. Hungarian matching, 3D IoU 0.7, score cutoffs 0, 0.01,
..., 1 (as OpenPCDet configures the op).

    python3.11 -m venv venv && venv/bin/pip install waymo-open-dataset-tf-2-12-0==1.6.7 "shapely<2.1"
    venv/bin/python scripts/waymo_official.py --root data/sim --split val \
        --results runs/quickstart/results

Prints LEVEL_1 and LEVEL_2 AP and APH in percent, to compare with `eval.json`'s `waymo`.
"""
import argparse
import math
import os

import numpy as np

from box_errors import read_objects  # the KITTI label / result reader beside this script

LEVEL_2_MAX_POINTS = 5


def read_calib(path):
    rows = {}
    with open(path) as f:
        for line in f:
            if ":" in line:
                k, v = line.split(":", 1)
                rows[k.strip()] = np.array([float(x) for x in v.split()])
    r0 = np.eye(4)
    r0[:3, :3] = rows["R0_rect"].reshape(3, 3)
    tr = np.eye(4)
    tr[:3, :4] = rows["Tr_velo_to_cam"].reshape(3, 4)
    return np.linalg.inv(r0 @ tr)  # rectified camera -> LiDAR


def read_boxes(path, rect_to_velo):
    """(class, [x, y, z, l, w, h, yaw] in the LiDAR frame, score) per object of a KITTI file."""
    out = []
    for o in read_objects(path):
        c = rect_to_velo @ np.array([o["x"], o["y"] - o["h"] / 2, o["z"], 1.0])  # KITTI's location is the bottom centre
        yaw = (-o["ry"] - math.pi / 2 + math.pi) % (2 * math.pi) - math.pi
        out.append((o["cls"], [c[0], c[1], c[2], o["l"], o["w"], o["h"], yaw], o["score"]))
    return out


def points_inside(points, b):
    c, s = math.cos(b[6]), math.sin(b[6])
    d = points[:, :3] - np.array(b[:3])
    u, v = c * d[:, 0] + s * d[:, 1], -s * d[:, 0] + c * d[:, 1]
    eps = 1e-5
    return int(np.sum((np.abs(u) <= b[3] / 2 + eps) & (np.abs(v) <= b[4] / 2 + eps) & (np.abs(d[:, 2]) <= b[5] / 2 + eps)))


def footprints_overlap(a, b):
    from shapely.geometry import Polygon

    def poly(b):
        c, s = math.cos(b[6]), math.sin(b[6])
        return Polygon([(b[0] + c * u - s * v, b[1] + s * u + c * v)
                        for u, v in ((b[3] / 2, b[4] / 2), (-b[3] / 2, b[4] / 2), (-b[3] / 2, -b[4] / 2), (b[3] / 2, -b[4] / 2))])
    return poly(a).intersection(poly(b)).area > 0.0


def gather(root, split, results):
    ids = [line.strip() for line in open(os.path.join(root, "ImageSets", f"{split}.txt")) if line.strip()]
    gt, pred = [], []
    for f, frame in enumerate(ids):
        base = os.path.join(root, "training")
        rect_to_velo = read_calib(os.path.join(base, "calib", frame + ".txt"))
        points = np.fromfile(os.path.join(base, "velodyne", frame + ".bin"), np.float32).reshape(-1, 4)
        zones = []
        for cls, b, _ in read_boxes(os.path.join(base, "label_2", frame + ".txt"), rect_to_velo):
            n = points_inside(points, b) if cls in ("Car", "Van") else 0
            if cls == "Van" or (cls == "Car" and n == 0):
                zones.append(b)
            elif cls == "Car":
                gt.append((f, b, 2 if n <= LEVEL_2_MAX_POINTS else 1))
        for cls, b, score in read_boxes(os.path.join(results, frame + ".txt"), rect_to_velo):
            if cls == "Car":
                pred.append((f, b, score, any(footprints_overlap(b, z) for z in zones)))
    return gt, pred


def official(gt, pred):
    import tensorflow as tf
    from waymo_open_dataset import label_pb2
    from waymo_open_dataset.metrics.ops import py_metrics_ops
    from waymo_open_dataset.protos import breakdown_pb2, metrics_pb2

    config = metrics_pb2.Config()
    config.breakdown_generator_ids.append(breakdown_pb2.Breakdown.ONE_SHARD)
    d = config.difficulties.add()
    d.levels.append(label_pb2.Label.LEVEL_1)
    d.levels.append(label_pb2.Label.LEVEL_2)
    config.matcher_type = metrics_pb2.MatcherProto.TYPE_HUNGARIAN
    config.iou_thresholds.extend([0.0, 0.7, 0.5, 0.5, 0.5])  # unknown, vehicle, pedestrian, sign, cyclist
    config.box_type = label_pb2.Label.Box.TYPE_3D
    config.score_cutoffs.extend([i * 0.01 for i in range(100)] + [1.0])
    vehicle = label_pb2.Label.TYPE_VEHICLE
    out = py_metrics_ops.detection_metrics(
        prediction_bbox=tf.constant([p[1] for p in pred], tf.float32),
        prediction_type=tf.constant([vehicle] * len(pred), tf.uint8),
        prediction_score=tf.constant([p[2] for p in pred], tf.float32),
        prediction_frame_id=tf.constant([p[0] for p in pred], tf.int64),
        prediction_overlap_nlz=tf.constant([p[3] for p in pred], tf.bool),
        ground_truth_bbox=tf.constant([g[1] for g in gt], tf.float32),
        ground_truth_type=tf.constant([vehicle] * len(gt), tf.uint8),
        ground_truth_frame_id=tf.constant([g[0] for g in gt], tf.int64),
        ground_truth_difficulty=tf.constant([g[2] for g in gt], tf.uint8),
        config=config.SerializeToString(),
    )
    # ONE_SHARD with one difficulty entry: one value per level, LEVEL_1 first.
    return out.average_precision.numpy(), out.average_precision_ha_weighted.numpy()


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--root", required=True, help="KITTI root (ImageSets/, training/)")
    ap.add_argument("--split", default="val")
    ap.add_argument("--results", required=True, help="folder of KITTI result files")
    args = ap.parse_args()
    gt, pred = gather(args.root, args.split, args.results)
    ap_, aph = official(gt, pred)
    print(f"{len(gt)} Car labels with a LiDAR return, {len(pred)} predictions")
    for i, level in enumerate(("LEVEL_1", "LEVEL_2")):
        print(f"{level}: AP {100 * ap_[i]:.2f}  APH {100 * aph[i]:.2f}")


if __name__ == "__main__":
    main()
