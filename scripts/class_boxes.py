#!/usr/bin/env python3
"""How many boxes of a class does a detector put on frames, beyond the labelled objects? (issue #47)

Reads KITTI result folders (one .txt per frame, as `starnet eval` writes them) and the labels of the same frames.
Within a frame the boxes of --class are sorted by score, highest first; a box **takes** a labelled object of that
class whose centre lies within --radius metres (ground plane: camera x, z) and that no higher-scored box took.
Every other box is **extra**: on `kitti-real-dev`, which has no pedestrian, every Pedestrian box is extra.

It prints per results folder the extra boxes per frame at each --thresholds score: issue #47 asks for <= 1
Pedestrian and <= 2 Cyclist per frame at score >= 0.3.

A fixed score is also a statement about calibration: how high the model scores what it is unsure of (focal alpha
moves it). With --reference RESULTS (one per folder, in the same order; the same model on a labelled split, as the
simulator's val split) and --reference-labels, it also prints the score at which that model finds --keep (80 %) of
the reference split's labelled objects of the class, and the extra boxes per frame on each folder at that score
(and the labelled objects taken there): a figure of ranking, whatever the scale of the scores; and per score band
of 0.1, the share of the reference's boxes that take a labelled object (a calibrated score reads as that share).
Standard library only. Usage:

  scripts/class_boxes.py --class Pedestrian --labels ../shared/kitti-real-dev/training/label_2 \\
      --reference runs/pc/results --reference-labels data/sim/training/label_2 runs/pc/real/c512_p128
"""
import argparse
import math
import os
import sys

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from box_errors import read_objects  # noqa: E402


def frame_boxes(boxes, labels, cls, radius):
    """(score, took) per box of `cls`, highest score first; the number of labelled objects of `cls`."""
    objects = [o for o in labels if o["cls"] == cls]
    taken = [False] * len(objects)
    out = []
    for b in sorted((b for b in boxes if b["cls"] == cls), key=lambda b: -b["score"]):
        free = [(math.hypot(b["x"] - o["x"], b["z"] - o["z"]), i) for i, o in enumerate(objects) if not taken[i]]
        d, i = min(free, default=(math.inf, None))
        took = d <= radius
        if took:
            taken[i] = True
        out.append((b["score"], took))
    return out, len(objects)


def read_folder(results, labels, cls, radius):
    """Every frame's (score, took) pairs, and the labelled objects of `cls` over all frames."""
    frames = sorted(f[:-4] for f in os.listdir(results) if f.endswith(".txt"))
    if not frames:
        sys.exit(f"{results}: no result files (*.txt)")
    # A wrong --labels would make every box extra: every frame must have its label file.
    missing = [fid for fid in frames if not os.path.exists(os.path.join(labels, fid + ".txt"))]
    if missing:
        sys.exit(f"{labels}: no label file for {len(missing)} of the {len(frames)} frames of {results}"
                 f" ({missing[0]}.txt, ...)")
    scored, labelled = [], 0
    for fid in frames:
        s, n = frame_boxes(read_objects(os.path.join(results, fid + ".txt")),
                           read_objects(os.path.join(labels, fid + ".txt")), cls, radius)
        scored.append(s)
        labelled += n
    return scored, labelled


def extra_per_frame(scored, threshold):
    return sum(1 for frame in scored for s, took in frame if not took and s >= threshold) / len(scored)


def taken(scored, threshold):
    return sum(1 for frame in scored for s, took in frame if took and s >= threshold)


def reliability(scored):
    """Per score band of 0.1, the share of boxes that take a labelled object, and the boxes there."""
    out = []
    for k in range(10):
        lo, hi = k / 10, (k + 1) / 10
        band = [took for frame in scored for s, took in frame if lo <= s < hi or (k == 9 and s == 1.0)]
        if band:
            out.append(f"{lo:.1f}-{hi:.1f}: {sum(band) / len(band):.2f} ({len(band)})")
    return " | ".join(out)


def keep_score(scored, labelled, keep):
    """The score at which `keep` of the labelled objects are taken; None if they never are."""
    took = sorted((s for frame in scored for s, t in frame if t), reverse=True)
    need = max(1, math.ceil(keep * labelled - 1e-9))
    return took[need - 1] if labelled and len(took) >= need else None


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("folders", nargs="+", help="KITTI result folders")
    ap.add_argument("--labels", required=True, help="label_2 folder of the folders' frames")
    ap.add_argument("--class", dest="cls", default="Pedestrian")
    ap.add_argument("--radius", type=float, default=1.0, help="metres between a box and the object it takes")
    ap.add_argument("--thresholds", default="0.3,0.4,0.5,0.6")
    ap.add_argument("--reference", nargs="*", default=[],
                    help="per folder, the same model's results on a labelled split")
    ap.add_argument("--reference-labels", help="label_2 folder of the reference split")
    ap.add_argument("--keep", type=float, default=0.8)
    a = ap.parse_args()
    if a.reference and (len(a.reference) != len(a.folders) or not a.reference_labels):
        sys.exit("--reference takes one folder per results folder, with --reference-labels")
    if not 0.0 < a.keep <= 1.0:
        sys.exit(f"--keep {a.keep}: a share in (0, 1]")
    try:
        thresholds = [float(t) for t in a.thresholds.split(",") if t.strip()]
    except ValueError:
        sys.exit(f"--thresholds {a.thresholds!r}: scores separated by commas, as 0.3,0.4")
    print(f"{a.cls}: extra boxes per frame (not taking a labelled {a.cls} within {a.radius:g} m)")
    for k, folder in enumerate(a.folders):
        scored, labelled = read_folder(folder, a.labels, a.cls, a.radius)
        cells = " | ".join(f">= {t:g}: {extra_per_frame(scored, t):.2f}" for t in thresholds)
        line = f"{folder} ({len(scored)} frames, {labelled} labelled): {cells}"
        if a.reference:
            ref, ref_labelled = read_folder(a.reference[k], a.reference_labels, a.cls, a.radius)
            t = keep_score(ref, ref_labelled, a.keep)
            if t is None:
                line += f" | reference never takes {a.keep:.0%} of its {ref_labelled} objects"
            else:
                line += (f" | at {t:.3f} (reference keeps {a.keep:.0%}; its own extra {extra_per_frame(ref, t):.2f}"
                         f" per frame): {extra_per_frame(scored, t):.2f}")
                if labelled:
                    line += f", taking {taken(scored, t)} of {labelled}"
        print(line)
        if a.reference:
            print(f"  reference, share of boxes taking a labelled {a.cls} per score band: {reliability(ref)}")


if __name__ == "__main__":
    main()
