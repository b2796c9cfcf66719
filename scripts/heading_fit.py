#!/usr/bin/env python3
"""Whether a heading error lies in the detector or in the labels (issue #47): per clearly visible labelled Car
(`box_errors.py`'s filter), the heading of the rectangle that best fits the car's own LiDAR returns in bird's-eye
view (L-shape fitting by the closeness criterion of Zhang et al., "Efficient L-shape fitting for vehicle detection
using laser scanners", 2017; searched within 20 degrees of the label, every 0.25 degrees), against the label's
heading and, with result folders, against the heading of the detection that overlaps the car best (3D IoU, centre
within 2 m).

The returns are those inside the label's box grown by 0.3 m sideways, from 0.3 m above its bottom (not the road) to
0.2 m above its top; cars with fewer than 30 are skipped. A rectangle has four-fold symmetry, so every difference
is taken in (-45, 45] degrees. On a simulator's labels, exact by construction, the fit's median difference from the
label says how far the fit itself is biased. A last table gives the medians by how far the car is turned from
end-on, signed so that a positive difference turns the first box nearer to end-on (towards the line of sight).

    python3 scripts/heading_fit.py --root ../shared/kitti-real-dev runs/v5/quickstart-s{0,1,2}/real-budget/c512_p64
    python3 scripts/heading_fit.py --root data/sim --split val --frames 200

numpy only.
"""
import argparse
import math
import os
import statistics

import numpy as np

from seed_agreement import best_match, median_of_known, visible_cars
from box_errors import read_objects
from waymo_official import read_calib  # rectified camera -> LiDAR

STEP = math.radians(0.25)
SEARCH = math.radians(20.0)
BANDS = ((0, 15), (15, 30), (30, 45), (45, 91))


def to_lidar(cam_to_lidar, car):
    """The car's bottom centre (x, y, z) and the heading of its length axis in the LiDAR frame."""
    centre = cam_to_lidar @ np.array([car["x"], car["y"], car["z"], 1.0])
    axis = cam_to_lidar[:3, :3] @ np.array([math.cos(car["ry"]), 0.0, -math.sin(car["ry"])])
    return centre[:3], math.atan2(axis[1], axis[0])


def car_points(points, centre, yaw, car):
    """The returns on the car, in its label's frame turned back to LiDAR axes: `[N, 2]` (x, y) about its centre."""
    d = points[:, :2] - centre[:2]
    c, s = math.cos(yaw), math.sin(yaw)
    u = d[:, 0] * c + d[:, 1] * s
    v = -d[:, 0] * s + d[:, 1] * c
    dz = points[:, 2] - centre[2]
    keep = (np.abs(u) <= car["l"] / 2 + 0.3) & (np.abs(v) <= car["w"] / 2 + 0.3) & (dz >= 0.3) & (dz <= car["h"] + 0.2)
    return d[keep]


def closeness(xy, theta):
    """Zhang et al.'s closeness criterion of a rectangle at heading `theta` around the points."""
    e1 = xy @ np.array([math.cos(theta), math.sin(theta)])
    e2 = xy @ np.array([-math.sin(theta), math.cos(theta)])
    d1 = np.minimum(e1.max() - e1, e1 - e1.min())
    d2 = np.minimum(e2.max() - e2, e2 - e2.min())
    return float(np.sum(1.0 / np.maximum(np.minimum(d1, d2), 0.01)))


def fitted_heading(xy, around):
    """The heading within SEARCH of `around` whose rectangle fits the points closest."""
    thetas = np.arange(around - SEARCH, around + SEARCH + STEP / 2, STEP)
    return max(thetas, key=lambda t: closeness(xy, t))


def quarter(a):
    """An angle difference folded into (-45, 45] degrees: a rectangle's symmetry."""
    d = math.degrees(a) % 90.0
    return d - 90.0 if d > 45.0 else d


def frame_ids(root, split, frames):
    """The split's frame ids, the first `frames` of them if not 0."""
    with open(os.path.join(root, "ImageSets", f"{split}.txt")) as f:
        ids = [line.strip() for line in f if line.strip()]
    return ids[:frames] if frames else ids


def measure(root, ids, folders):
    """Per car with enough returns: (fit - label, [detection - fit per folder or NaN], degrees from end-on)."""
    rows = []
    for fid in ids:
        base = os.path.join(root, "training")
        cam_to_lidar = read_calib(os.path.join(base, "calib", f"{fid}.txt"))
        points = np.fromfile(os.path.join(base, "velodyne", f"{fid}.bin"), dtype=np.float32).reshape(-1, 4)
        dets = [read_objects(os.path.join(folder, f"{fid}.txt")) for folder in folders]
        for car in visible_cars(os.path.join(base, "label_2"), f"{fid}.txt"):
            centre, yaw = to_lidar(cam_to_lidar, car)
            xy = car_points(points, centre, yaw, car)
            if len(xy) < 30:
                continue
            fit = fitted_heading(xy, yaw)
            diffs = [detection_minus_fit(cam_to_lidar, car, d, fit) for d in dets]
            rows.append((quarter(fit - yaw), diffs, off_end_on(car)))
    return rows


def off_end_on(car):
    """How far (degrees, in (-90, 90]) the car is turned from being seen end-on: its length axis against the line of
    sight, both in the camera's (x, z) plane (KITTI's length axis at heading ry is (cos ry, -sin ry)). LiDAR headings
    turn the same way as this angle, so a heading difference of the opposite sign turns a box towards end-on."""
    d = math.degrees(-car["ry"] - math.atan2(car["z"], car["x"])) % 180.0
    return d - 180.0 if d > 90.0 else d


def detection_minus_fit(cam_to_lidar, car, dets, fit):
    """The heading of the detection that overlaps the car best, less the fitted heading (degrees); NaN if none."""
    _, det = best_match(car, dets)
    if det is None:
        return math.nan
    return quarter(to_lidar(cam_to_lidar, det)[1] - fit)


def describe(values):
    known = [v for v in values if not math.isnan(v)]
    if len(known) < 2:
        return f"{len(known)} pair(s)"
    q = statistics.quantiles(known, n=4)
    return f"median {statistics.median(known):+.2f}, quartiles {q[0]:+.2f} / {q[2]:+.2f} (n = {len(known)})"


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--root", required=True, help="KITTI-layout root (training/{velodyne,calib,label_2})")
    parser.add_argument("--split", default="val", help="ImageSets split")
    parser.add_argument("--frames", type=int, default=0, help="the split's first N frames (0: all)")
    parser.add_argument("folders", nargs="*", help="result folders of the same frames (KITTI result files)")
    args = parser.parse_args()
    for folder in [os.path.join(args.root, "training"), *args.folders]:
        if not os.path.isdir(folder):
            parser.error(f"{folder}: not a folder")
    rows = measure(args.root, frame_ids(args.root, args.split, args.frames), args.folders)
    if not rows:
        raise SystemExit(f"{args.root}: no visible Car with 30 returns in the split")
    print(f"{len(rows)} visible cars with >= 30 returns; heading differences in degrees")
    print(f"fitted - label: {describe([r[0] for r in rows])}; more than 10 degrees apart (the fit failing on a "
          f"partial view, more likely than the label): {sum(abs(r[0]) > 10 for r in rows)}")
    for i, folder in enumerate(args.folders):
        print(f"{folder}: detection - fitted: {describe([r[1][i] for r in rows])}; detection - label: "
              f"{describe([r[1][i] + r[0] for r in rows])}")
    print("\nTowards the line of sight (positive: the first box turned nearer to end-on than the second), medians:")
    print("| turned from end-on | cars | fitted against label | detection against fitted, per folder |")
    print("|---|---|---|---|")
    for lo, hi in BANDS:
        band = [r for r in rows if lo <= abs(r[2]) < hi]
        if band:
            toward = [-math.copysign(1.0, r[2]) for r in band]
            medians = [median_of_known(t * r[1][i] for t, r in zip(toward, band)) for i in range(len(args.folders))]
            print(f"| {lo}-{min(hi, 90)} deg | {len(band)} | {statistics.median(t * r[0] for t, r in zip(toward, band)):+.2f} | "
                  + " / ".join(f"{m:+.2f}" for m in medians) + " |")


if __name__ == "__main__":
    main()
