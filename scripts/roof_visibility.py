#!/usr/bin/env python3
"""How much of a labelled car's height the LiDAR shows: per labelled Car (occlusion <= 1, at least 10
returns inside its box grown by 0.1 m), how far below the label's top the highest return inside it
lies, by distance, for one or more KITTI-layout roots (the simulator's and real scans side by side).

A network reads a car's height from its highest returns; where the roof shows less in one set than
in another, the same network predicts shorter boxes there. A second table says how many of the points a
center gathers are on the roof: for a center at the car's middle, as high above the car's bottom as the
sensor is above the ground (the quickstart's `center_z = "ground"`), and --points drawn uniformly from the
--radius ball around it (the quickstart's 32 and 3 m), the expected count in the car's top 0.3 m, on the car
and on the ground around it (a probe on the labels, not on a model's centers; cars to 80 m). Usage (numpy):

  scripts/roof_visibility.py ../shared/kitti-real-dev data/sim --split val --frames 300
"""
import argparse
import os
import sys

import numpy as np

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from box_errors import read_objects  # noqa: E402
from onnx_detect import read_calib  # noqa: E402

BANDS = [(0, 20), (20, 40), (40, 80)]
SENSOR_HEIGHT = 1.73


def visible_cars(root, frame):
    """Per visible labelled car of one frame (occlusion <= 1, at least 10 returns inside its box grown by
    0.1 m): (car, the cloud in the rectified camera frame, x and z offsets from the car's centre, the grown
    footprint's mask, the grown box's mask)."""
    points = np.fromfile(f"{root}/training/velodyne/{frame}.bin", dtype=np.float32).reshape(-1, 4)[:, :3]
    _, velo_to_rect = read_calib(f"{root}/training/calib/{frame}.txt")
    cam = points @ velo_to_rect[:3, :3].T + velo_to_rect[:3, 3]  # rectified camera frame: x right, y down, z forward
    for car in read_objects(f"{root}/training/label_2/{frame}.txt"):
        if car["cls"] != "Car" or car["occ"] > 1:
            continue
        c, s = np.cos(car["ry"]), np.sin(car["ry"])
        dx, dz = cam[:, 0] - car["x"], cam[:, 2] - car["z"]
        along, across = c * dx - s * dz, s * dx + c * dz
        footprint = (np.abs(along) <= car["l"] / 2 + 0.1) & (np.abs(across) <= car["w"] / 2 + 0.1)
        inside = footprint & (cam[:, 1] <= car["y"]) & (cam[:, 1] >= car["y"] - car["h"] - 0.1)
        if inside.sum() >= 10:
            yield car, cam, dx, dz, footprint, inside


def frame_gaps(root, frame):
    """(distance, gap below the label's top, label height) for each visible labelled car of one frame."""
    return [(np.hypot(car["x"], car["z"]), cam[inside, 1].min() - (car["y"] - car["h"]), car["h"])
            for car, cam, _, _, _, inside in visible_cars(root, frame)]


def frame_draws(root, frame, points, radius):
    """(distance, roof, car, ground): per visible labelled car of one frame, the expected number of the
    `points` drawn from the ball around a center at its middle that lie in its top 0.3 m, inside it, and on
    the ground outside its footprint (no higher than 0.15 m above its bottom)."""
    out = []
    for car, cam, dx, dz, footprint, inside in visible_cars(root, frame):
        ball = dx**2 + dz**2 + (cam[:, 1] - (car["y"] - SENSOR_HEIGHT)) ** 2 <= radius**2
        if not ball.any():
            continue
        share = min(points, ball.sum()) / ball.sum()
        roof = ball & inside & (cam[:, 1] <= car["y"] - car["h"] + 0.3)
        ground = ball & ~footprint & (cam[:, 1] >= car["y"] - 0.15)
        out.append((np.hypot(car["x"], car["z"]), share * roof.sum(), share * (ball & inside).sum(),
                    share * ground.sum()))
    return out


def print_draws(root, frames, points, radius):
    rows = np.array([row for frame in frames for row in frame_draws(root, frame, points, radius)]).reshape(-1, 4)
    for lo, hi in BANDS:
        band = rows[(rows[:, 0] >= lo) & (rows[:, 0] < hi)]
        if len(band):
            roof, car, ground = band[:, 1:].mean(axis=0)
            print(f"| {root} | {lo}-{hi} m | {len(band)} | {roof:.1f} | {car:.1f} | {ground:.1f} |")


def read_frames(root, split, limit):
    path = f"{root}/ImageSets/{split}.txt"
    if os.path.exists(path):
        with open(path) as f:
            frames = [line.strip() for line in f if line.strip()]
    else:
        frames = sorted(f[:-4] for f in os.listdir(f"{root}/training/label_2"))
    return frames[:limit] if limit else frames


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("roots", nargs="+", help="KITTI-layout roots")
    ap.add_argument("--split", default="val", help="ImageSets split (all labelled frames if the file is absent)")
    ap.add_argument("--frames", type=int, default=0, help="at most this many frames of each root (0: all)")
    ap.add_argument("--points", type=int, default=32, help="points a center draws (the second table)")
    ap.add_argument("--radius", type=float, default=3.0, help="the ball's radius in metres (the second table)")
    args = ap.parse_args()
    if args.points < 1 or args.radius <= 0:
        sys.exit("--points must be at least 1 and --radius above 0")
    print("| root | distance | cars | gap below the top: p25 / median / p75 (m) | label height, mean (m) |")
    print("|---|---|---|---|---|")
    for root in args.roots:
        frames = read_frames(root, args.split, args.frames)
        rows = np.array([row for frame in frames for row in frame_gaps(root, frame)]).reshape(-1, 3)
        for lo, hi in BANDS:
            band = rows[(rows[:, 0] >= lo) & (rows[:, 0] < hi)]
            if len(band):
                p25, p50, p75 = np.percentile(band[:, 1], [25, 50, 75])
                print(f"| {root} | {lo}-{hi} m | {len(band)} | {p25:.2f} / {p50:.2f} / {p75:.2f} | {band[:, 2].mean():.2f} |")
    print()
    print(f"| root | distance | cars | of {args.points} points drawn: in the top 0.3 m | on the car | on the ground |")
    print("|---|---|---|---|---|---|")
    for root in args.roots:
        print_draws(root, read_frames(root, args.split, args.frames), args.points, args.radius)


if __name__ == "__main__":
    main()
