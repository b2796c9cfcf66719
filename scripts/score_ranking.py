#!/usr/bin/env python3
"""Do a detector's scores rank real cars above clutter? (issue #47)

Reads KITTI result files (one .txt per frame, as `starnet eval` writes them) and the KITTI labels of
the same frames, and sorts every Car box of every frame by score, highest first. Within a frame,
a box is

  * **true** when its centre lies within 2 m (ground plane: camera x, z) of a labelled Car that no
    higher-scored box has taken yet (it then takes that Car);
  * **false** when its centre lies more than 2.5 m from every labelled object (any class: Car,
    Van, Truck, Tram, Misc, Pedestrian, Cyclist, Person_sitting) and its 2D box's centre lies
    outside every DontCare region of the image;
  * neither otherwise (a second box on a taken car, a box on a van, a near miss).

It prints, per results folder:

  * the operating point: the score that keeps 80 % (--keep) of the true boxes, and the false boxes
    per frame scoring at least that (the figure issue #47 asks to bring to <= 0.05);
  * the score histograms of true and false boxes (bins of 0.05);
  * precision and recall of the labelled cars per distance band (0-20, 20-40, 40+ m) at that score.

With --json FILE it also writes these figures as JSON; with --svg FILE a plot, one panel per distance band: the
labelled cars found (recall) against the false boxes per frame as the score threshold falls, one line per results
folder. Standard library only. Usage:

  scripts/score_ranking.py --labels ../shared/kitti-real-dev/training/label_2 runs/a/real/c256_p128/results ...
"""
import argparse
import json
import math
import os
import sys

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from box_errors import read_objects  # noqa: E402

TRUE_RADIUS = 2.0
FALSE_RADIUS = 2.5
BANDS = ((0.0, 20.0), (20.0, 40.0), (40.0, math.inf))


def ground_distance(a, b):
    return math.hypot(a["x"] - b["x"], a["z"] - b["z"])


def in_dontcare(box, regions):
    u = 0.5 * (box["box2d"][0] + box["box2d"][2])
    v = 0.5 * (box["box2d"][1] + box["box2d"][3])
    return any(r[0] <= u <= r[2] and r[1] <= v <= r[3] for r in regions)


def classify_frame(boxes, labels):
    """(score, kind, range) per Car box, kind 'true' / 'false' / 'other'; and the labelled cars'
    ranges with the score of the box that took each (None if none did)."""
    cars = [o for o in labels if o["cls"] == "Car"]
    objects = [o for o in labels if o["cls"] != "DontCare"]
    regions = [o["box2d"] for o in labels if o["cls"] == "DontCare"]
    taken = [None] * len(cars)
    out = []
    for b in sorted((b for b in boxes if b["cls"] == "Car"), key=lambda b: -b["score"]):
        free = [(ground_distance(b, c), i) for i, c in enumerate(cars) if taken[i] is None]
        near = min(free, default=(math.inf, None))
        rng = math.hypot(b["x"], b["z"])
        if near[0] <= TRUE_RADIUS:
            taken[near[1]] = b["score"]
            out.append((b["score"], "true", rng))
        elif all(ground_distance(b, o) > FALSE_RADIUS for o in objects) and not in_dontcare(b, regions):
            out.append((b["score"], "false", rng))
        else:
            out.append((b["score"], "other", rng))
    return out, [(math.hypot(c["x"], c["z"]), s) for c, s in zip(cars, taken)]


def analyse(results, labels, keep):
    frames = sorted(f[:-4] for f in os.listdir(results) if f.endswith(".txt"))
    boxes, cars = [], []
    for fid in frames:
        b, c = classify_frame(read_objects(os.path.join(results, fid + ".txt")),
                              read_objects(os.path.join(labels, fid + ".txt")))
        boxes += b
        cars += c
    true = sorted((s for s, k, _ in boxes if k == "true"), reverse=True)
    false = [s for s, k, _ in boxes if k == "false"]
    if not true:
        return dict(results=results, frames=len(frames), true_boxes=0, false_boxes=len(false))
    threshold = true[max(0, math.ceil(keep * len(true)) - 1)]
    bins = [round(0.05 * i, 2) for i in range(21)]
    hist = lambda v: [sum(1 for s in v if lo <= s < hi or (hi == 1.0 and s == 1.0)) for lo, hi in zip(bins, bins[1:])]
    bands = []
    for lo, hi in BANDS:
        kept = [(s, k) for s, k, r in boxes if lo <= r < hi and s >= threshold]
        found = sum(1 for r, s in cars if lo <= r < hi and s is not None and s >= threshold)
        labelled = sum(1 for r, _ in cars if lo <= r < hi)
        t = sum(1 for _, k in kept if k == "true")
        f = sum(1 for _, k in kept if k == "false")
        bands.append(dict(band=f"{lo:g}-{hi:g} m", cars=labelled, recall=found / labelled if labelled else None,
                          precision=t / (t + f) if t + f else None, false_boxes=f))
    curves = [band_curve(boxes, cars, lo, hi, len(frames)) for lo, hi in BANDS]
    return dict(results=results, frames=len(frames), true_boxes=len(true), false_boxes=len(false),
                keep=keep, threshold=threshold, curves=curves,
                false_per_frame=sum(1 for s in false if s >= threshold) / len(frames),
                bins=bins, true_hist=hist(true), false_hist=hist(false), bands=bands)


def band_curve(boxes, cars, lo, hi, frames):
    """[(false boxes per frame, recall)] in one distance band as the threshold falls through every score."""
    labelled = sum(1 for r, _ in cars if lo <= r < hi)
    scores = sorted({s for s, k, r in boxes if lo <= r < hi and k in ("true", "false")}, reverse=True)
    curve = [(0.0, 0.0)]
    for t in scores:
        found = sum(1 for r, s in cars if lo <= r < hi and s is not None and s >= t)
        false = sum(1 for s, k, r in boxes if lo <= r < hi and k == "false" and s >= t)
        curve.append((false / frames, found / labelled if labelled else 0.0))
    return curve


COLOURS = ["#1f77b4", "#d62728", "#2ca02c", "#ff7f0e", "#9467bd", "#8c564b", "#e377c2", "#7f7f7f"]


def write_svg(path, reports, x_max=0.5):
    """One panel per distance band: recall against false boxes per frame, a line per folder."""
    w, h, pad = 300, 260, 45
    out = [f'<svg xmlns="http://www.w3.org/2000/svg" width="{w * len(BANDS)}" height="{h + 20 * len(reports) + 10}" '
           'font-family="sans-serif" font-size="11"><rect width="100%" height="100%" fill="white"/>']
    for k, (lo, hi) in enumerate(BANDS):
        ox = k * w
        px = lambda v: ox + pad + min(v, x_max) / x_max * (w - pad - 10)
        py = lambda v: h - pad + 10 - v * (h - pad - 20)
        out.append(f'<text x="{ox + w / 2}" y="14" text-anchor="middle">cars at {lo:g}-{hi:g} m</text>'.replace("-inf", "+"))
        out.append(f'<rect x="{px(0)}" y="{py(1)}" width="{px(x_max) - px(0)}" height="{py(0) - py(1)}" fill="none" stroke="#999"/>')
        for i in range(6):
            v = i / 5
            out.append(f'<text x="{px(0) - 4}" y="{py(v) + 4}" text-anchor="end">{v:.1f}</text>')
            out.append(f'<text x="{px(v * x_max)}" y="{py(0) + 14}" text-anchor="middle">{v * x_max:.1f}</text>')
        out.append(f'<text x="{ox + w / 2 + 15}" y="{h - 2}" text-anchor="middle">false boxes per frame</text>')
        out.append(f'<text x="{ox + 12}" y="{py(0.5)}" transform="rotate(-90 {ox + 12} {py(0.5)})" text-anchor="middle">recall</text>')
        for j, r in enumerate(reports):
            if r.get("curves"):
                pts = " ".join(f"{px(x):.1f},{py(y):.1f}" for x, y in r["curves"][k] if x <= x_max)
                out.append(f'<polyline points="{pts}" fill="none" stroke="{COLOURS[j % len(COLOURS)]}" stroke-width="1.5"/>')
    for j, r in enumerate(reports):
        y = h + 20 * j + 15
        out.append(f'<line x1="10" y1="{y - 4}" x2="30" y2="{y - 4}" stroke="{COLOURS[j % len(COLOURS)]}" stroke-width="2"/>')
        out.append(f'<text x="36" y="{y}">{r["results"]}</text>')
    out.append("</svg>")
    with open(path, "w") as f:
        f.write("\n".join(out) + "\n")


def print_report(r):
    print(f"## {r['results']} ({r['frames']} frames)")
    if not r["true_boxes"]:
        print(f"no true box; {r['false_boxes']} false boxes")
        return
    print(f"{r['true_boxes']} true boxes, {r['false_boxes']} false; score keeping {r['keep']:.0%} of the true: "
          f"{r['threshold']:.3f}, false boxes per frame at it: **{r['false_per_frame']:.3f}**")
    print("| score | true | false |\n|---|---|---|")
    for lo, t, f in zip(r["bins"], r["true_hist"], r["false_hist"]):
        if t or f:
            print(f"| {lo:.2f}-{lo + 0.05:.2f} | {t} | {f} |")
    print("| distance | labelled cars | recall | precision | false boxes |\n|---|---|---|---|---|")
    fmt = lambda v: "-" if v is None else f"{v:.2f}"
    for b in r["bands"]:
        print(f"| {b['band']} | {b['cars']} | {fmt(b['recall'])} | {fmt(b['precision'])} | {b['false_boxes']} |")


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("results", nargs="+", help="folders of KITTI result files")
    ap.add_argument("--labels", required=True, help="the label_2 folder of the same frames")
    ap.add_argument("--keep", type=float, default=0.8, help="share of true boxes the operating point keeps")
    ap.add_argument("--json", help="also write the figures here")
    ap.add_argument("--svg", help="also plot recall against false boxes per frame, per distance band, here")
    args = ap.parse_args()
    reports = [analyse(r, args.labels, args.keep) for r in args.results]
    for r in reports:
        print_report(r)
    if len(reports) > 1:
        fpf = [r["false_per_frame"] for r in reports if r["true_boxes"]]
        if fpf:
            mean = sum(fpf) / len(fpf)
            print(f"\nfalse boxes per frame at {args.keep:.0%} of the true: mean {mean:.3f} "
                  f"± {(max(fpf) - min(fpf)) / 2:.3f} over {len(fpf)} folders ({' / '.join(f'{v:.3f}' for v in fpf)})")
    if args.json:
        with open(args.json, "w") as f:
            json.dump(reports, f, indent=1)
    if args.svg:
        write_svg(args.svg, reports)


if __name__ == "__main__":
    main()
