#!/usr/bin/env python3
"""Where FPS puts a frame's centers: on the cars, or on the road (issue #47).

For each frame of a KITTI-layout root's split, draws N centers by farthest point sampling in bird's-eye
view from the authors' camera-view pool (x >= 0, |y| <= 40, z >= --floor, camera frustum), once with the
z band in the sensor frame (`flat`) and once measured from the local ground (`levelled`, `pipeline.ground`
at its defaults), and counts

  * the share of centers lying within 0.3 m of the local ground (road), and
  * per labelled Car, the centers inside its footprint grown by 0.5 m, by distance (0-20, 20-40, 40+ m),
    and the share of cars with none.

The pool, FPS and ground estimate are `scripts/onnx_detect.py`'s (numpy ports of starnet's; FPS from
numpy's generator, so the picks are not the binary's, their statistics are). Needs numpy. Usage:

  scripts/center_placement.py ../shared/kitti-real-dev --split val --centers 256 512
"""
import argparse
import os
import sys

import numpy as np

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from onnx_detect import center_pool, fps_bev, ground_rise, read_calib  # noqa: E402

GROUND = dict(cell=2.0, window=2, rank=2, max_drop=1.0, extent=80.0, reference_z=-1.73)
ROAD_BAND = 0.3
MARGIN = 0.5
BANDS = ((0.0, 20.0), (20.0, 40.0), (40.0, np.inf))


def cars(label_path, velo_to_rect):
    """Labelled cars as (x, y, length, width, heading) in the LiDAR frame."""
    rect_to_velo = np.linalg.inv(velo_to_rect)
    out = []
    for line in open(label_path):
        f = line.split()
        if f and f[0] == "Car":
            h, w, l = map(float, f[8:11])
            x, y, z = map(float, f[11:14])
            v = rect_to_velo @ np.array([x, y - h / 2, z, 1.0])
            out.append((v[0], v[1], l, w, -(float(f[14]) + np.pi / 2)))
    return out


def centers_inside(centers, car):
    x, y, l, w, heading = car
    dx, dy = centers[:, 0] - x, centers[:, 1] - y
    c, s = np.cos(heading), np.sin(heading)
    along, across = dx * c + dy * s, -dx * s + dy * c
    return int(((np.abs(along) < l / 2 + MARGIN) & (np.abs(across) < w / 2 + MARGIN)).sum())


def measure(root, ids, n, floor, levelled, seed):
    rng = np.random.default_rng(seed)
    pool_cfg = dict(x_range=[0.0, None], y_range=[-40.0, 40.0], z_range=[floor, None], camera_frustum=True)
    road, total, per_car = 0, 0, []
    for fid in ids:
        points = np.fromfile(os.path.join(root, "training/velodyne", fid + ".bin"), np.float32).reshape(-1, 4)
        calib = read_calib(os.path.join(root, "training/calib", fid + ".txt"))
        rise = ground_rise(points, GROUND)
        pool = center_pool(points, pool_cfg, calib, rise if levelled else None)
        chosen = pool[fps_bev(points[pool, :2].astype(np.float64), n, rng)]
        c = points[chosen]
        above = c[:, 2] - (rise(c[:, 0], c[:, 1]) + GROUND["reference_z"])
        road += int((above < ROAD_BAND).sum())
        total += len(c)
        for car in cars(os.path.join(root, "training/label_2", fid + ".txt"), calib[1]):
            per_car.append((np.hypot(car[0], car[1]), centers_inside(c, car)))
    return road / max(total, 1), np.array(per_car).reshape(-1, 2)


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("root", help="a KITTI-layout root")
    ap.add_argument("--split", default="val")
    ap.add_argument("--centers", type=int, nargs="+", default=[256, 512])
    ap.add_argument("--floor", type=float, default=-1.35, help="the pool's z floor (sensor frame, or levelled)")
    ap.add_argument("--frames", type=int, help="at most this many frames, the first of the split")
    ap.add_argument("--seed", type=int, default=0)
    args = ap.parse_args()
    ids = open(os.path.join(args.root, "ImageSets", args.split + ".txt")).read().split()[: args.frames]
    print(f"{args.root} ({len(ids)} frames of {args.split}), pool floor z >= {args.floor}")
    head = " | ".join(f"centers per car {lo:g}-{hi:g} m (none)" for lo, hi in BANDS)
    print(f"| pool | centers | on the road | {head} |\n|---|---|---|" + "---|" * len(BANDS))
    for n in args.centers:
        for levelled in (False, True):
            share, per_car = measure(args.root, ids, n, args.floor, levelled, args.seed)
            cells = []
            for lo, hi in BANDS:
                v = per_car[(per_car[:, 0] >= lo) & (per_car[:, 0] < hi), 1] if len(per_car) else np.zeros(0)
                cells.append(f"{v.mean():.1f} ({(v == 0).mean():.0%})" if len(v) else "-")
            print(f"| {'levelled' if levelled else 'flat'} | {n} | {share:.1%} | " + " | ".join(cells) + " |")


if __name__ == "__main__":
    main()
