#!/usr/bin/env python3
"""Which labelled cars the seeds agree on: for each clearly visible Car of a split (box height >= 25 px,
occlusion <= 1, truncation <= 0.3, as `box_errors.py` pairs them), the best 3D IoU that each result folder's
boxes within 2 m reach, and how many folders reach the threshold. Cars that only some seeds find at it are
where a seed spread comes from; their best IoU across seeds says how near the threshold they sit.

    python3 scripts/seed_agreement.py --labels ../shared/kitti-real-dev/training/label_2 \
        runs/v5/quickstart-s{0,1,2,3,4}/real-budget/c512_p64
"""

import argparse
import math
import os
import statistics

from box_errors import ious, read_objects

RANGES = ((0, 20), (20, 40), (40, math.inf))


def visible_cars(labels, name):
    return [g for g in read_objects(os.path.join(labels, name))
            if g["cls"] == "Car" and g["bottom"] - g["top"] >= 25 and g["occ"] <= 1 and g["trunc"] <= 0.3]


def best_iou(car, detections):
    """The highest 3D IoU of a detection whose centre lies within 2 m of the car's (ground plane); 0 if none."""
    near = [d for d in detections if math.hypot(d["x"] - car["x"], d["z"] - car["z"]) <= 2.0]
    return max((ious(d, car)[0] for d in near), default=0.0)


def per_car(labels, folders):
    """One row per visible car: (distance in m, [best 3D IoU per folder])."""
    names = sorted(f for f in os.listdir(labels) if f.endswith(".txt") and os.path.exists(os.path.join(folders[0], f)))
    rows = []
    for name in names:
        dets = [read_objects(os.path.join(folder, name)) for folder in folders]
        for car in visible_cars(labels, name):
            rows.append((math.hypot(car["x"], car["z"]), [best_iou(car, d) for d in dets]))
    return rows


def report(rows, folders, threshold):
    n = len(folders)
    print(f"{len(rows)} visible cars; 3D IoU >= {threshold}")
    print("| folder | cars reached |\n|---|---|")
    for i, folder in enumerate(folders):
        print(f"| {folder} | {sum(r[1][i] >= threshold for r in rows)} |")
    print(f"\n| reached by k of {n} | " + " | ".join(f"{lo}-{hi if hi < math.inf else 'inf'} m" for lo, hi in RANGES)
          + " | all | mean best IoU (mean over folders) |")
    print("|---|" + "---|" * (len(RANGES) + 2))
    for k in range(n + 1):
        group = [r for r in rows if sum(b >= threshold for b in r[1]) == k]
        counts = [sum(lo <= d < hi for d, _ in group) for lo, hi in RANGES]
        mean = statistics.mean(statistics.mean(b) for _, b in group) if group else float("nan")
        print(f"| {k} | " + " | ".join(map(str, counts)) + f" | {len(group)} | {mean:.3f} |")
    spread = [statistics.pstdev(b) for _, b in rows if max(b) > 0]
    if spread:
        print(f"\nper car, the spread (sd) of its best IoU over the folders: median {statistics.median(spread):.3f}")


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--labels", required=True, help="folder of KITTI label files (label_2)")
    parser.add_argument("--iou", type=float, default=0.7, help="the 3D IoU a box must reach (KITTI's Car: 0.7)")
    parser.add_argument("folders", nargs="+", help="result folders of the same split, one per seed")
    args = parser.parse_args()
    for folder in [args.labels, *args.folders]:
        if not os.path.isdir(folder):
            parser.error(f"{folder}: not a folder")
    if not 0 < args.iou <= 1:
        parser.error(f"--iou {args.iou}: not in (0, 1]")
    report(per_car(args.labels, args.folders), args.folders, args.iou)


if __name__ == "__main__":
    main()
