#!/usr/bin/env python3
"""Which labelled cars the seeds agree on: for each clearly visible Car of a split (box height >= 25 px,
occlusion <= 1, truncation <= 0.3: `box_errors.py`'s filter), the best 3D IoU among each result folder's boxes
whose centre lies within 2 m of the car's, whatever their score (a result file holds the boxes a detector kept;
one box may serve two cars), and how many folders reach the threshold. Cars that only some seeds reach are where
a seed spread comes from; the mean of their best IoU over the folders, and its range, say how near the threshold
they sit.

One drive's labels come from its tracklets, so a car keeps its (height, width, length) in every frame: `--by-car`
groups the cars by those three values (and stops if one frame holds two cars with the same) and prints, per physical
car, its frames, its distances, how many of its frames each folder reaches, and the sizes and heading error of the
boxes that reach it. On a short drive the frames are not independent draws: a few cars seen in many frames decide
the figure.

    python3 scripts/seed_agreement.py --labels ../shared/kitti-real-dev/training/label_2 \
        runs/v5/quickstart-s{0,1,2,3,4}/real-budget/c512_p64
"""

import argparse
import math
import os
import statistics

from box_errors import ious, read_objects, wrap

RANGES = ((0, 20), (20, 40), (40, math.inf))


def visible_cars(labels, name):
    return [g for g in read_objects(os.path.join(labels, name))
            if g["cls"] == "Car" and g["bottom"] - g["top"] >= 25 and g["occ"] <= 1 and g["trunc"] <= 0.3]


def best_match(car, detections):
    """The highest 3D IoU of a detection whose centre lies within 2 m of the car's (ground plane), and that
    detection; (0, None) if none."""
    near = [d for d in detections if math.hypot(d["x"] - car["x"], d["z"] - car["z"]) <= 2.0]
    return max(((ious(d, car)[0], d) for d in near), key=lambda m: m[0], default=(0.0, None))


def frame_names(folders):
    """The result files every folder holds; folders that hold different frames are an error, not misses."""
    sets = [{f for f in os.listdir(folder) if f.endswith(".txt")} for folder in folders]
    for folder, names in zip(folders[1:], sets[1:]):
        if names != sets[0]:
            raise SystemExit(f"{folder}: holds other frames than {folders[0]} ({len(names ^ sets[0])} differ)")
    return sorted(sets[0])


def per_car(labels, folders):
    """One row per visible car: (distance in m, [best 3D IoU per folder], the label with its frame and the box
    giving each folder's IoU)."""
    names = [n for n in frame_names(folders) if os.path.exists(os.path.join(labels, n))]
    rows = []
    for name in names:
        dets = [read_objects(os.path.join(folder, name)) for folder in folders]
        for car in visible_cars(labels, name):
            car["frame"] = name
            matches = [best_match(car, d) for d in dets]
            car["matches"] = [m[1] for m in matches]
            rows.append((math.hypot(car["x"], car["z"]), [m[0] for m in matches], car))
    return rows


def report(rows, folders, threshold):
    n = len(folders)
    print(f"{len(rows)} visible cars; 3D IoU >= {threshold}")
    print("| folder | cars reached |\n|---|---|")
    for i, folder in enumerate(folders):
        print(f"| {folder} | {sum(r[1][i] >= threshold for r in rows)} |")
    print(f"\n| reached by k of {n} | " + " | ".join(f"{lo}-{hi if hi < math.inf else 'inf'} m" for lo, hi in RANGES)
          + " | all | best IoU, mean over folders | its range (max - min), median |")
    print("|---|" + "---|" * (len(RANGES) + 3))
    for k in range(n + 1):
        group = [r for r in rows if sum(b >= threshold for b in r[1]) == k]
        counts = [sum(lo <= d < hi for d, _, _ in group) for lo, hi in RANGES]
        mean = statistics.mean(statistics.mean(b) for _, b, _ in group) if group else float("nan")
        width = statistics.median(max(b) - min(b) for _, b, _ in group) if group else float("nan")
        print(f"| {k} | " + " | ".join(map(str, counts)) + f" | {len(group)} | {mean:.3f} | {width:.3f} |")
    some = [statistics.mean(b) for _, b, _ in rows if 0 < sum(x >= threshold for x in b) < n]
    near = sum(abs(m - threshold) <= 0.05 for m in some)
    print(f"\nreached by some folders but not all: {len(some)} cars, {near} of them with a mean best IoU within 0.05 "
          f"of {threshold}")
    spread = [statistics.pstdev(b) for _, b, _ in rows if max(b) > 0]
    print(f"per car, the population sd of its best IoU over the folders: median {statistics.median(spread):.3f}")


def identity(car):
    """A tracklet's car: its class and its labelled size, which a drive's labels keep from frame to frame."""
    return (car["cls"], car["h"], car["w"], car["l"])


def by_car(rows, folders, threshold):
    """Per physical car: its frames, its distances, the frames each folder reaches and each folder's median best IoU;
    then the boxes that give those IoUs: median length, width, height and heading error per folder."""
    cars = {}
    for dist, best, car in rows:
        cars.setdefault(identity(car), []).append((dist, best, car))
    for key, seen in cars.items():
        frames = [car["frame"] for _, _, car in seen]
        if len(set(frames)) < len(frames):
            raise SystemExit(f"two visible cars of size {key[1:]} in one frame: sizes do not identify cars here")
    ordered = sorted(cars.items(), key=lambda kv: -len(kv[1]))
    n = len(folders)
    print(f"\n{len(cars)} physical cars (one size each) among the {len(rows)} visible cars")
    print(f"| car (h x w x l, m) | frames | distance, m | frames at IoU >= {threshold}, per folder | best IoU, median "
          "per folder |\n|---|---|---|---|---|")
    for key, seen in ordered:
        dists = [d for d, _, _ in seen]
        reached = [sum(b[i] >= threshold for _, b, _ in seen) for i in range(n)]
        medians = [statistics.median(b[i] for _, b, _ in seen) for i in range(n)]
        print(f"| {size(key)} | {len(seen)} | {min(dists):.0f}-{max(dists):.0f} | "
              + " / ".join(map(str, reached)) + " | " + " / ".join(f"{m:.2f}" for m in medians) + " |")
    print("\nThose boxes, medians per folder (heading error: the box's ry less the label's, in degrees)")
    print("| car (h x w x l, m) | length | width | height | heading error |\n|---|---|---|---|---|")
    for key, seen in ordered:
        cells = [" / ".join(f"{median_of_known(box_value(car, i, k) for _, _, car in seen):{fmt}}" for i in range(n))
                 for k, fmt in (("l", ".2f"), ("w", ".2f"), ("h", ".2f"), ("ry", "+.1f"))]
        print(f"| {size(key)} | " + " | ".join(cells) + " |")


def size(key):
    return f"{key[1]:.2f} x {key[2]:.2f} x {key[3]:.2f}"


def box_value(car, i, key):
    """Folder i's box for the car: one of its sizes, or its heading error (degrees, wrapped into [-180, 180));
    NaN where no box came within 2 m."""
    box = car["matches"][i]
    if box is None:
        return math.nan
    if key == "ry":
        return math.degrees(wrap(box["ry"] - car["ry"]))
    return box[key]


def median_of_known(values):
    """The median of the values that are not NaN (a frame where no box came within 2 m); NaN if none."""
    known = [v for v in values if not math.isnan(v)]
    return statistics.median(known) if known else math.nan


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--labels", required=True, help="folder of KITTI label files (label_2)")
    parser.add_argument("--iou", type=float, default=0.7, help="the 3D IoU a box must reach (KITTI's Car: 0.7)")
    parser.add_argument("--by-car", action="store_true",
                        help="also group the cars by their labelled size (one drive: one tracklet each)")
    parser.add_argument("folders", nargs="+", help="result folders of the same split, one per seed")
    args = parser.parse_args()
    for folder in [args.labels, *args.folders]:
        if not os.path.isdir(folder):
            parser.error(f"{folder}: not a folder")
    if not 0 < args.iou <= 1:
        parser.error(f"--iou {args.iou}: not in (0, 1]")
    rows = per_car(args.labels, args.folders)
    if not rows:
        raise SystemExit(f"no visible Car label of {args.labels} in the folders' frames")
    report(rows, args.folders, args.iou)
    if args.by_car:
        by_car(rows, args.folders, args.iou)


if __name__ == "__main__":
    main()
