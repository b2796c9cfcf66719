#!/usr/bin/env python3
"""The kill harness of issue #49: every command that writes, killed at a random moment and run again.

For each command (synth, train with its data generation, prepare, convert, eval --out, stream-eval,
export, detect) it first runs the command once, uninterrupted, as the reference. Then, per trial, in
a fresh folder: start the command, send SIGKILL or SIGINT (a seeded coin) at a seeded random moment
within the reference's run time (a run that ends first is not a trial and is drawn again), wait for it to end, run the same command again, and compare what it
leaves (every file under the trial folder, bytes; JSON with its timing fields taken out, and the
files a command fills with measured times left out) with the reference. A trial ends as

  recovered  the second run succeeded and left what the reference left;
  refused    the second run failed with an error that names the remedy (delete, --resume, ...);
  dead end   anything else: different output, a panic, an error without a remedy, a leftover file.

Prints a table per command and exits 1 when any trial is a dead end (the failing trials' stderr is
shown). The CI runs a short version (`--trials 2`); BENCHMARKS quotes the long one (`--trials 40`).

    python3 scripts/kill_test.py --bin target/debug/starnet --trials 40 --seed 0
"""

import argparse
import hashlib
import json
import os
import random
import re
import shutil
import signal
import subprocess
import sys
import tempfile
import time
from pathlib import Path

# Fields whose values are measured times: they differ between any two runs.
TIMING_KEY = re.compile(r"(second|secs|latency|elapsed|_ms$|ms_|per_s|fps|wall|date|time)", re.I)
# Phrases of an error that says what to do.
REMEDIES = ("delete", "--resume", "choose another", "choose a new", "run again", "wait for")

TINY = """seed = 2
[data]
root = "{data}"
simulate_frames = {frames}
classes = ["Car"]
[pipeline]
num_centers = 32
[pipeline.gather]
num_points = 8
radius = 2.0
[model]
d_fc0 = 8
blocks = [[16, 8], [16, 8]]
d_offset = 8
[nms]
iou = [0.1]
score = [0.3]
[train]
epochs = {epochs}
batch_size = 2
workers = 1
learning_rate = 0.002
[eval]
num_centers = 32
num_points = 8
"""


def strip_timing(value):
    if isinstance(value, dict):
        return {k: strip_timing(v) for k, v in value.items() if not TIMING_KEY.search(k)}
    if isinstance(value, list):
        return [strip_timing(v) for v in value]
    return value


def digest(root, ignore):
    """Every file under root (relative path -> sha256), JSON without its timing fields."""
    out = {}
    for path in sorted(Path(root).rglob("*")):
        rel = path.relative_to(root).as_posix()
        if path.is_dir() or any(re.search(p, rel) for p in ignore):
            continue
        data = path.read_bytes()
        if path.suffix in (".json", ".jsonl"):
            try:
                if path.suffix == ".json":
                    value = json.loads(data)
                else:
                    value = [json.loads(line) for line in data.decode().splitlines() if line.strip()]
                data = json.dumps(strip_timing(value), sort_keys=True).encode()
            except ValueError:
                pass
        out[rel] = hashlib.sha256(data).hexdigest()[:16]
    return out


class Command:
    """One writing command: its arguments in a trial folder, and what of its output to ignore."""

    def __init__(self, name, args, setup=lambda d: None, ignore=(), post=None):
        self.name, self.args, self.setup, self.ignore, self.post = name, args, setup, ignore, post

    def outcome(self, binary, d):
        """What the command left in `d`: its files' digests (after `post`, a command that turns
        what has no stable bytes into what has)."""
        if self.post:
            run(binary, self.post, d)
        return digest(d, self.ignore)


def commands(fx):
    """The writing commands, reading the fixtures in `fx` and writing into the trial folder, their
    working directory (relative paths there, so the configs a run records are the same in every trial)."""

    def tiny_config(d):
        (d / "tiny.toml").write_text(TINY.format(data="data", frames=16, epochs=3))

    def sim_copy(d):
        shutil.copytree(fx / "sim", d / "sim", ignore=shutil.ignore_patterns("gt_database*"))

    best = str(fx / "run/checkpoints/best")
    return [
        Command("synth", lambda d: ["synth", "--out", "sim", "--frames", "24", "--seed", "5"]),
        Command(
            "train (with its data)",
            lambda d: ["train", "--config", "tiny.toml", "--run", "run"],
            setup=tiny_config,
            # The log's lines carry wall times and rates. A burnpack file tags each tensor with a
            # parameter id drawn afresh when a run resumes: the weights are compared through
            # their export (safetensors), with the run's eval.json and state.json.
            ignore=(r"log\.jsonl$", r"\.png$", r"\.md$", r"\.bpk$", r"train\.lock$"),
            post=["export", "--checkpoint", "run/checkpoints/best", "--out", "run-export"],
        ),
        Command("prepare", lambda d: ["prepare", "--data", "sim"], setup=sim_copy),
        Command(
            "convert",
            lambda d: ["convert", "--from", str(fx / "sim"), "--to", "custom", "--layout", "custom"],
        ),
        Command(
            "eval --out",
            lambda d: ["eval", "--checkpoint", best, "--data", str(fx / "sim"), "--out", "eval"],
            ignore=(r"\.png$", r"\.md$"),
        ),
        Command(
            "stream-eval",
            lambda d: ["stream-eval", "--checkpoint", best, "--data", str(fx / "sim"), "--slices", "1,2,4",
                       "--out", "stream"],
            # Latency is measured: its plot and table differ between any two runs.
            ignore=(r"\.png$", r"\.md$"),
        ),
        Command("export", lambda d: ["export", "--checkpoint", best, "--out", "export"]),
        Command(
            "detect",
            lambda d: ["detect", "--model", str(fx / "export"), "--input", str(fx / "sim/training/velodyne"),
                       "--out", "detect"],
        ),
    ]


def run(binary, args, cwd, timeout=900):
    return subprocess.run([binary, *args], cwd=cwd, capture_output=True, text=True, timeout=timeout)


def fixtures(binary, fx):
    """A small simulated root, a tiny trained run and its export, read by the commands."""
    fx.mkdir(parents=True)
    (fx / "tiny.toml").write_text(TINY.format(data=fx / "sim", frames=24, epochs=1))
    for args in (["train", "--config", str(fx / "tiny.toml"), "--run", str(fx / "run")],
                 ["export", "--checkpoint", str(fx / "run/checkpoints/best"), "--out", str(fx / "export")]):
        r = run(binary, args, fx)
        if r.returncode != 0:
            sys.exit(f"fixture `{' '.join(args)}` failed:\n{r.stderr}")


def reference(binary, cmd, work):
    d = work / "reference"
    d.mkdir(parents=True)
    cmd.setup(d)
    start = time.monotonic()
    r = run(binary, cmd.args(d), d)
    seconds = time.monotonic() - start
    if r.returncode != 0:
        sys.exit(f"{cmd.name}: the uninterrupted run failed:\n{r.stderr}")
    return cmd.outcome(binary, d), seconds


def trial(binary, cmd, d, delay, sig):
    """Start, kill after `delay` s with `sig`, run again. None when the command ended before the
    kill (not a trial), else the second run's result."""
    d.mkdir(parents=True)
    cmd.setup(d)
    p = subprocess.Popen([binary, *cmd.args(d)], cwd=d, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    try:
        p.wait(timeout=delay)
        return None
    except subprocess.TimeoutExpired:
        p.send_signal(sig)
        p.wait()
    return run(binary, cmd.args(d), d)


def classify(r, got, expected):
    if r.returncode == 0 and got == expected:
        return "recovered", ""
    if r.returncode != 0 and "panicked" not in r.stderr and any(m in r.stderr for m in REMEDIES):
        return "refused", r.stderr.strip().splitlines()[-1]
    if r.returncode == 0:
        differ = sorted(set(got.items()) ^ set(expected.items()))
        return "dead end", f"output differs: {differ[:6]}"
    return "dead end", r.stderr.strip()[-600:]


def disk_full(binary, cmd, expected, work):
    """The simulator on a 1 MiB tmpfs: a clean error naming the file and nothing at the root;
    with the space grown (remount), the same command finishes the set as the reference wrote it."""
    mnt = work / "tmpfs"
    mnt.mkdir(parents=True)
    if subprocess.run(["mount", "-t", "tmpfs", "-o", "size=1m", "tmpfs", str(mnt)], capture_output=True).returncode:
        return "| synth, disk full | skipped: mounting a tmpfs needs root |"
    try:
        full = run(binary, cmd.args(mnt), mnt)
        clean = (full.returncode != 0 and "No space left on device" in full.stderr
                 and ".bin" in full.stderr and not (mnt / "sim").exists() and "panicked" not in full.stderr)
        subprocess.run(["mount", "-o", "remount,size=64m", str(mnt)], check=True)
        again = run(binary, cmd.args(mnt), mnt)
        recovered = again.returncode == 0 and cmd.outcome(binary, mnt) == expected
        first_line = full.stderr.strip().splitlines()[0] if full.stderr.strip() else "(no error)"
        return (f"| synth, disk full | {'clean error' if clean else 'DEAD END'}: `{first_line}` | "
                f"{'recovered' if recovered else 'DEAD END'} after the space grew |")
    finally:
        subprocess.run(["umount", str(mnt)])


def two_trainers(binary, work):
    """Two trainers started together on one absent data root: one generates it, the other waits
    for it (its note names the holder); both train on the same bytes to the same scores."""
    work.mkdir(parents=True)
    (work / "tiny.toml").write_text(TINY.format(data="data", frames=16, epochs=1))
    procs = [subprocess.Popen([binary, "train", "--config", "tiny.toml", "--run", run_dir], cwd=work,
                              stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
             for run_dir in ("run-a", "run-b")]
    outs = [p.communicate(timeout=900) for p in procs]
    waited = sum("waiting for process" in out for out, _ in outs)
    ok = all(p.returncode == 0 for p in procs)
    same = ok and digest(work / "run-a", (r"log\.jsonl$", r"\.bpk$", r"train\.lock$", r"\.md$", r"\.png$")) == digest(
        work / "run-b", (r"log\.jsonl$", r"\.bpk$", r"train\.lock$", r"\.md$", r"\.png$"))
    left = sorted(p.name for p in work.iterdir())
    verdict = "recovered" if ok and same and left == ["data", "run-a", "run-b", "tiny.toml"] else "DEAD END"
    return (f"| two trainers, one absent data root | {verdict}: both succeeded: {ok}, one waited: {waited == 1}, "
            f"same eval.json and config: {same}, left {left} |")


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--bin", default="target/debug/starnet")
    ap.add_argument("--trials", type=int, default=2, help="kills per command")
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--only", help="run only the commands whose name contains this")
    ap.add_argument("--disk-full", action="store_true", help="also the simulator on a full tmpfs (needs root)")
    args = ap.parse_args()
    # A process started in the background of a shell inherits SIGINT ignored, and an ignored signal
    # stays ignored across exec: with a handler of our own, the commands start with the default.
    signal.signal(signal.SIGINT, signal.default_int_handler)
    binary = str(Path(args.bin).resolve())
    rng = random.Random(args.seed)
    work = Path(tempfile.mkdtemp(prefix="starnet-kill-"))
    fixtures(binary, work / "fixtures")
    print("| command | kills | SIGKILL / SIGINT | ended before the kill (not counted) | recovered | refused (remedy named) | dead ends | reference run (s) |")
    print("|---|---|---|---|---|---|---|---|")
    dead, extra = [], []
    for k, cmd in enumerate(commands(work / "fixtures")):
        if args.only and args.only not in cmd.name:
            continue
        expected, seconds = reference(binary, cmd, work / f"c{k}")
        tally = {"recovered": 0, "refused": 0, "dead end": 0}
        sigs = {signal.SIGKILL: 0, signal.SIGINT: 0}
        early, t = 0, 0
        while sum(tally.values()) < args.trials and early < 3 * args.trials:
            sig = rng.choice([signal.SIGKILL, signal.SIGINT])
            delay = rng.uniform(0.0, seconds)
            d = work / f"c{k}" / f"t{t}"
            t += 1
            r = trial(binary, cmd, d, delay, sig)
            if r is None:
                early += 1
            else:
                sigs[sig] += 1
                outcome, detail = classify(r, cmd.outcome(binary, d), expected)
                tally[outcome] += 1
                if outcome == "dead end":
                    dead.append(f"{cmd.name}, trial {t - 1} ({sig.name} after {delay:.2f} s): {detail}")
            shutil.rmtree(d, ignore_errors=True)
        print(f"| {cmd.name} | {sum(tally.values())} | {sigs[signal.SIGKILL]} / {sigs[signal.SIGINT]} | {early} | "
              f"{tally['recovered']} | {tally['refused']} | {tally['dead end']} | {seconds:.2f} |", flush=True)
        if args.disk_full and cmd.name == "synth":
            row = disk_full(binary, cmd, expected, work / "disk")
            extra.append(row)
            if "DEAD END" in row:
                dead.append(row)
    if not args.only:
        row = two_trainers(binary, work / "two")
        extra.append(row)
        if "DEAD END" in row:
            dead.append(row)
    for row in extra:
        print(f"\n{row}")
    shutil.rmtree(work, ignore_errors=True)
    for line in dead:
        print(line, file=sys.stderr)
    sys.exit(1 if dead else 0)


if __name__ == "__main__":
    main()
