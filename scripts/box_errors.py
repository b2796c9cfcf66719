#!/usr/bin/env python3
"""Where a detector's 3D boxes go wrong: per-parameter errors and an oracle error budget.

Reads KITTI result files (one .txt per frame, as `starnet eval` writes them) and the KITTI labels
of the same frames, and pairs each moderate Car label (2D height >= 25 px, occlusion <= 1,
truncation <= 0.3) with the nearest detection scoring at least --score within 2 m in bird's-eye
view. For the pairs it prints

  * each box parameter's error (mean, median |e|, 80th percentile |e|), the centre error split
    along and across the labelled heading, and for the sizes the correlation of the predicted with
    the labelled value and the spread of each (a size the network cannot see is predicted near the
    class mean: a spread far below the labels' and a correlation near 0);
  * the share of pairs whose 3D (and BEV) IoU reaches --iou, as predicted and with one group of
    parameters replaced by the label's (the "oracle"): what each group costs at that IoU; the box's
    top and bottom also one at a time (the other edge kept where the prediction put it);
  * the 3D share once every box's bottom and height are moved by the pairs' mean errors: how much of
    what the label's bottom and height buy is a bias one constant would remove.

Standard library only. Usage:

  scripts/box_errors.py --results runs/quickstart/results --labels data/sim/training/label_2
"""
import argparse
import math
import os
import statistics


def replace(*keys):
    """The prediction with `keys` taken from the label."""
    return lambda d, g: dict(d, **{k: g[k] for k in keys})


def label_top(d, g):
    """The prediction with the label's top and its own bottom (camera y points down: top = y - h)."""
    return dict(d, h=d["y"] - (g["y"] - g["h"]))


def label_bottom(d, g):
    """The prediction with the label's bottom and its own top."""
    return dict(d, y=g["y"], h=g["y"] - (d["y"] - d["h"]))


ORACLES = {
    "as predicted": replace(),
    "length, width": replace("l", "w"),
    "centre x, z (camera)": replace("x", "z"),
    "bottom y, height": replace("y", "h"),
    "the top only (own bottom kept)": label_top,
    "the bottom only (own top kept)": label_bottom,
    "heading": replace("ry"),
    "centre x, z and length": replace("x", "z", "l"),
    "all but the heading": replace("x", "y", "z", "l", "w", "h"),
}


def read_objects(path):
    """KITTI label or result lines as dicts (camera frame; score 1 for labels; `box2d` is the image box
    [left, top, right, bottom])."""
    out = []
    if not os.path.exists(path):
        return out
    with open(path) as f:
        for line in f:
            v = line.split()
            if len(v) < 15:
                continue
            n = list(map(float, v[1:15]))
            out.append(dict(cls=v[0], trunc=n[0], occ=n[1], box2d=n[3:7], top=n[4], bottom=n[6], h=n[7], w=n[8], l=n[9],
                            x=n[10], y=n[11], z=n[12], ry=n[13], score=float(v[15]) if len(v) > 15 else 1.0))
    return out


def footprint(b):
    """Bird's-eye corners (x, z) counter-clockwise; KITTI: length along x at ry = 0."""
    c, s = math.cos(b["ry"]), math.sin(b["ry"])
    pts = []
    for u, v in ((1, 1), (1, -1), (-1, -1), (-1, 1)):
        du, dv = u * b["l"] / 2, v * b["w"] / 2
        pts.append((b["x"] + c * du + s * dv, b["z"] - s * du + c * dv))
    return pts if signed_area(pts) > 0 else pts[::-1]


def signed_area(p):
    return sum(p[i - 1][0] * p[i][1] - p[i][0] * p[i - 1][1] for i in range(len(p))) / 2


def clip(subject, clipper):
    """Sutherland-Hodgman for convex counter-clockwise polygons."""
    def inside(p, a, b):
        return (b[0] - a[0]) * (p[1] - a[1]) - (b[1] - a[1]) * (p[0] - a[0]) >= 0

    def cross(p, q, a, b):
        d = (p[0] - q[0]) * (a[1] - b[1]) - (p[1] - q[1]) * (a[0] - b[0])
        t = ((p[0] - a[0]) * (a[1] - b[1]) - (p[1] - a[1]) * (a[0] - b[0])) / d
        return (p[0] + t * (q[0] - p[0]), p[1] + t * (q[1] - p[1]))

    out = subject
    for i in range(len(clipper)):
        a, b = clipper[i], clipper[(i + 1) % len(clipper)]
        pts, out = out, []
        for j, e in enumerate(pts):
            s = pts[j - 1]
            if inside(e, a, b):
                if not inside(s, a, b):
                    out.append(cross(s, e, a, b))
                out.append(e)
            elif inside(s, a, b):
                out.append(cross(s, e, a, b))
        if not out:
            break
    return out


def ious(a, b):
    """(3D IoU, BEV IoU); boxes extend up from their bottom y (camera y points down)."""
    inter = clip(footprint(a), footprint(b))
    area = abs(signed_area(inter)) if len(inter) >= 3 else 0.0
    dy = max(0.0, min(a["y"], b["y"]) - max(a["y"] - a["h"], b["y"] - b["h"]))
    va, vb = a["l"] * a["w"] * a["h"], b["l"] * b["w"] * b["h"]
    bev = area / (a["l"] * a["w"] + b["l"] * b["w"] - area)
    return area * dy / (va + vb - area * dy), bev


def pairs(results, labels, score):
    for name in sorted(f for f in os.listdir(results) if f.endswith(".txt")):
        dets = [d for d in read_objects(os.path.join(results, name)) if d["score"] >= score]
        for g in read_objects(os.path.join(labels, name)):
            if g["cls"] != "Car" or g["bottom"] - g["top"] < 25 or g["occ"] > 1 or g["trunc"] > 0.3 or not dets:
                continue
            d = min(dets, key=lambda d: math.hypot(d["x"] - g["x"], d["z"] - g["z"]))
            if math.hypot(d["x"] - g["x"], d["z"] - g["z"]) <= 2.0:
                yield d, g


def wrap(a):
    return (a + math.pi) % (2 * math.pi) - math.pi


def describe(errors):
    a = sorted(abs(e) for e in errors)
    return f"{statistics.mean(errors):+.3f} | {a[len(a) // 2]:.3f} | {a[int(0.8 * len(a))]:.3f}"


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--results", required=True, help="folder of KITTI result files")
    ap.add_argument("--labels", required=True, help="folder of KITTI label files (label_2)")
    ap.add_argument("--score", type=float, default=0.3, help="lowest detection score paired")
    ap.add_argument("--iou", type=float, default=0.7)
    args = ap.parse_args()
    found = list(pairs(args.results, args.labels, args.score))
    if not found:
        raise SystemExit(f"no moderate Car label of {args.labels} has a detection within 2 m")
    print(f"{len(found)} moderate cars paired with a detection within 2 m\n")
    print("| parameter | mean error | median abs | 80th pct abs | corr (pred, label) | sd pred / sd label |")
    print("|---|---|---|---|---|---|")
    for k in ("x", "y", "z", "h", "w", "l"):
        pred, lab = [d[k] for d, _ in found], [g[k] for _, g in found]
        corr = statistics.correlation(pred, lab) if k in "hwl" else float("nan")
        spread = statistics.pstdev(pred) / statistics.pstdev(lab) if k in "hwl" else float("nan")
        extra = f"{corr:.2f} | {spread:.2f}" if k in "hwl" else " | "
        print(f"| {k} (m) | {describe([p - q for p, q in zip(pred, lab)])} | {extra} |")
    along = [(d["x"] - g["x"]) * math.cos(g["ry"]) - (d["z"] - g["z"]) * math.sin(g["ry"]) for d, g in found]
    across = [(d["x"] - g["x"]) * math.sin(g["ry"]) + (d["z"] - g["z"]) * math.cos(g["ry"]) for d, g in found]
    turn = [wrap(d["ry"] - g["ry"]) for d, g in found]
    print(f"| centre along the heading (m) | {describe(along)} | | |")
    print(f"| centre across the heading (m) | {describe(across)} | | |")
    print(f"| heading (rad) | {describe(turn)} | | |")
    backwards = sum(abs(t) > math.pi / 2 for t in turn) / len(turn)
    print(f"\npointing backwards (|heading error| > pi/2): {100 * backwards:.1f} %\n")
    print(f"| replaced by the label | 3D IoU >= {args.iou} | BEV IoU >= {args.iou} |")
    print("|---|---|---|")
    for name, oracle in ORACLES.items():
        hit3, hitb = 0, 0
        for d, g in found:
            i3, ib = ious(oracle(d, g), g)
            hit3 += i3 >= args.iou
            hitb += ib >= args.iou
        print(f"| {name} | {100 * hit3 / len(found):.1f} % | {100 * hitb / len(found):.1f} % |")
    print(f"\nbottom y and height less their mean errors (the shared bias alone removed): "
          f"{debiased_share(found, args.iou):.1f} % at 3D IoU >= {args.iou}")


def debiased_share(found, iou):
    """The share of pairs at 3D IoU >= iou once every prediction's bottom y and height are moved by the pairs' mean
    error: how much of what the label's bottom and height buy is a bias that one constant would remove."""
    bias = {k: statistics.mean(d[k] - g[k] for d, g in found) for k in ("y", "h")}
    hits = sum(ious(dict(d, **{k: d[k] - bias[k] for k in bias}), g)[0] >= iou for d, g in found)
    return 100 * hits / len(found)


if __name__ == "__main__":
    main()
