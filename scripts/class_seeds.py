#!/usr/bin/env python3
"""Every class of a set of seeds, as BENCHMARKS.md quotes them: KITTI R40 moderate (3D, BEV, 2D, AOS)
and Waymo-style LEVEL_1 / LEVEL_2 AP and APH (and LEVEL_1 by distance band), each as mean ± half-range
over the runs, with the per-seed values.

    python3 scripts/class_seeds.py runs/ped-cyc-s0/eval.json runs/ped-cyc-s1/eval.json ...
    python3 scripts/class_seeds.py runs/ped-cyc-s*/real-dev/eval.json

Each argument is an eval.json that `starnet train` or `starnet eval` wrote (a folder holding one
works too). Standard library only.
"""
import json
import sys
from pathlib import Path

MODERATE = 1
KITTI = [("3D", "three_d"), ("BEV", "bev"), ("2D", "bbox"), ("AOS", "aos")]


def load(arg):
    p = Path(arg)
    return json.loads((p / "eval.json" if p.is_dir() else p).read_text())


def spread(values):
    """`mean ± half-range (v1/v2/...)`."""
    mean = sum(values) / len(values)
    half = (max(values) - min(values)) / 2
    each = "/".join(f"{v:.1f}" for v in values)
    return f"{mean:.1f} ± {half:.1f} ({each})" if len(values) > 1 else f"{mean:.1f}"


def unlabelled(e, name):
    """Whether the split has no object of the class (its AP is 0 by definition, not a result)."""
    w = next((w for w in e.get("waymo", []) if w["class"] == name), None)
    return w is not None and not any(w["num_objects"])


def kitti_rows(evals):
    classes = [c["class"] for c in evals[0]["classes"]]
    for name in classes:
        if unlabelled(evals[0], name):
            yield f"| {name} | no labelled objects | | | |"
            continue
        per = [next(c for c in e["classes"] if c["class"] == name) for e in evals]
        cells = [spread([c[key][MODERATE]["r40"] for c in per]) for _, key in KITTI]
        yield f"| {name} (IoU {per[0]['min_overlap']}) | " + " | ".join(cells) + " |"


def waymo_rows(evals):
    classes = [w["class"] for w in evals[0].get("waymo", [])]
    for name in classes:
        if unlabelled(evals[0], name):
            yield f"| {name} | no labelled objects | | | |"
            continue
        per = [next(w for w in e["waymo"] if w["class"] == name) for e in evals]
        cells = [spread([w["levels"][lv][key] for w in per]) for lv in (0, 1) for key in ("ap", "aph")]
        yield f"| {name} | " + " | ".join(cells) + " |"


def range_rows(evals):
    """LEVEL_1 AP / APH per Waymo distance band (0-30, 30-50, 50+ m)."""
    for w0 in evals[0].get("waymo", []):
        if unlabelled(evals[0], w0["class"]):
            continue
        per = [next(w for w in e["waymo"] if w["class"] == w0["class"]) for e in evals]
        cells = [
            spread([w["ranges"][0][band]["ap"] for w in per]) + " / " + spread([w["ranges"][0][band]["aph"] for w in per])
            for band in range(3)
        ]
        yield f"| {w0['class']} | " + " | ".join(cells) + " |"


def main(args):
    if not args:
        sys.exit(__doc__)
    evals = [load(a) for a in args]
    print(f"{len(evals)} runs: {', '.join(args)}\n")
    if evals[0]["classes"]:  # none with 360° labels: only the Waymo-style metrics apply
        print("| class | 3D AP R40 mod. | BEV | 2D | AOS |\n|---|---|---|---|---|")
        print("\n".join(kitti_rows(evals)))
    waymo = list(waymo_rows(evals))
    if waymo:
        print("\n| class | LEVEL_1 AP | LEVEL_1 APH | LEVEL_2 AP | LEVEL_2 APH |\n|---|---|---|---|---|")
        print("\n".join(waymo))
        print("\n| class | LEVEL_1 AP / APH 0-30 m | 30-50 m | 50+ m |\n|---|---|---|---|")
        print("\n".join(range_rows(evals)))


if __name__ == "__main__":
    main(sys.argv[1:])
