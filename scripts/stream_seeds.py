#!/usr/bin/env python3
"""Streaming tables over seeds: mean +- half-range of `starnet stream-eval` runs.

Reads one or more stream.json files (written by `starnet stream-eval --out DIR`), groups the runs
whose labels differ only in a trailing seed (`sweep-car-s0`, `sweep-car-s1`, ... -> `sweep-car`),
and prints the paper's tables as markdown: the first class's LEVEL_1 AP per slice count and NMS
mode (table 2), and its AP by subtended angle at the largest slice count against the first
group's whole-sweep AP (table 1). Standard library only.

    python3 scripts/stream_seeds.py runs/stream-table/stream.json
"""
import argparse
import json
import re
import statistics
from collections import OrderedDict

MODES = ["localized", "stateful", "global"]
MODE_NAMES = {"localized": "localized", "stateful": "+ stateful NMS", "global": "global NMS"}


def ap(report, mode):
    m = next(m for m in report["modes"] if m["mode"] == mode)
    return m["waymo"][0]["levels"][0]["ap"] if m["waymo"] else 0.0


def by_angle(report, mode):
    m = next(m for m in report["modes"] if m["mode"] == mode)
    return [(b["ap"], b["num_objects"]) for b in m["by_angle"]]


def fmt(values):
    if len(values) == 1:
        return f"{values[0]:.1f}"
    return f"{statistics.mean(values):.1f} ± {(max(values) - min(values)) / 2:.1f}"


def groups(paths):
    out = OrderedDict()
    for path in paths:
        for run in json.load(open(path)):
            name = re.sub(r"-s\d+$", "", run["label"])
            out.setdefault(name, []).append(run)
    return out


def variant(runs, mode):
    lstm = " + LSTM" if runs[0]["reports"][0]["lstm"] else ""
    return MODE_NAMES[mode] + lstm


def slice_table(grouped):
    first = next(iter(grouped.values()))[0]
    ns = [r["slices"] for r in first["reports"]]
    lines = ["| model (seeds) | variant | " + " | ".join(f"n = {n}" for n in ns) + " |"]
    lines.append("|---|---|" + "---|" * len(ns))
    for name, runs in grouped.items():
        for mode in MODES:
            cells = [fmt([ap(run["reports"][i], mode) for run in runs]) for i in range(len(ns))]
            lines.append(f"| {name} ({len(runs)}) | {variant(runs, mode)} | " + " | ".join(cells) + " |")
    return "\n".join(lines)


def angle_table(grouped):
    base_runs = next(iter(grouped.values()))
    base = [statistics.mean(v) for v in zip(*[[a for a, _ in by_angle(r["reports"][0], "global")] for r in base_runs])]
    counts = [n for _, n in by_angle(base_runs[0]["reports"][0], "global")]
    edges = [0, 5, 15, 25, 35]
    heads = [f"{lo}-{hi}° ({n})" for lo, hi, n in zip(edges, edges[1:], counts)] + [f"{edges[-1]}+° ({counts[-1]})"]
    last_n = base_runs[0]["reports"][-1]["slices"]
    lines = [f"| model | variant (n = {last_n}) | " + " | ".join(heads) + " |", "|---|---|" + "---|" * len(heads)]
    lines.append(f"| {next(iter(grouped))} | whole sweep (n = 1) | " + " | ".join(f"{b:.1f}" for b in base) + " |")
    for name, runs in grouped.items():
        for mode in MODES:
            per_bin = list(zip(*[[a for a, _ in by_angle(r["reports"][-1], mode)] for r in runs]))
            cells = []
            for values, b in zip(per_bin, base):
                m = statistics.mean(values)
                change = f" ({100 * (m - b) / b:+.0f} %)" if b > 0 else ""
                cells.append(f"{m:.1f}{change}")
            lines.append(f"| {name} | {variant(runs, mode)} | " + " | ".join(cells) + " |")
    return "\n".join(lines)


def main():
    ap_ = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap_.add_argument("stream_json", nargs="+")
    args = ap_.parse_args()
    grouped = groups(args.stream_json)
    print("LEVEL_1 3D AP by slices per sweep, mean ± half-range over seeds\n")
    print(slice_table(grouped))
    print("\nLEVEL_1 AP by subtended angle at the largest n, mean over seeds (change from the first model's whole sweep)\n")
    print(angle_table(grouped))


if __name__ == "__main__":
    main()
