#!/usr/bin/env bash
# Real labels, few frames (issue #48): Car 3D / BEV AP R40 moderate on `fewshot_val` against the number of
# real training frames, (a) from scratch on real frames only and (b) fine-tuned from a simulator-trained model
# (configs/finetune-real.toml), seeds 0-2. The first N frames of `fewshot_train` (ids in file order) train;
# every run takes the same number of steps as 30 epochs of all 26 (390 at batch 2), the decay starting halfway.
# Each size gets its own writable root under OUT (training/ linked to ROOT's, its own ImageSets/ and paste
# database), so ROOT may be read-only.
#
#   ROOT=../shared/kitti-real-dev SIM_RUNS=runs/v4 scripts/fewshot_curve.sh
#   scripts/fewshot_curve.sh --table
#
# SIM_RUNS holds the simulator-only models (quickstart-s0..s2/checkpoints/best, as scripts/transfer.sh leaves them);
# seed k fine-tunes from seed k's model, so the spread holds both. N = 0 is that model itself. Needs the built binary.
set -euo pipefail
cd "$(dirname "$0")/.."
bin=${BIN:-target/debug/starnet}
root=${ROOT:-../shared/kitti-real-dev}
sim=${SIM_RUNS:-runs/v4}
out=${OUT:-runs/fewshot}
sizes=${SIZES:-4 8 16 26}
seeds=${SEEDS:-0 1 2}

table() {
  python3 - "$out" <<'PY'
import glob, json, os, re, statistics, sys
rows = {}
for path in glob.glob(os.path.join(sys.argv[1], "*", "eval.json")) + glob.glob(os.path.join(sys.argv[1], "*", "*", "eval.json")):
    m = re.search(r"(scratch|finetune)-n(\d+)-s(\d+)", path)
    if not m:
        continue
    c = json.load(open(path))["classes"][0]
    rows.setdefault((m.group(1), int(m.group(2))), []).append((int(m.group(3)), c["three_d"][1]["r40"], c["bev"][1]["r40"]))
def stat(v):
    return f"{statistics.mean(v):.1f} ± {(max(v) - min(v)) / 2:.1f}" if len(v) > 1 else f"{v[0]:.1f}"
print("| training | real frames | seeds | 3D | BEV | 3D per seed |\n|---|---|---|---|---|---|")
for (kind, n), runs in sorted(rows.items()):
    runs.sort()
    cols = list(zip(*runs))
    print(f"| {kind} | {n} | {','.join(map(str, cols[0]))} | {stat(cols[1])} | {stat(cols[2])} | {' / '.join(f'{v:.1f}' for v in cols[1])} |")
PY
}

if [ "${1:-}" = "--table" ]; then table; exit 0; fi
[ -f "$root/ImageSets/fewshot_train.txt" ] || { echo "$root: no ImageSets/fewshot_train.txt (set ROOT to ../shared/kitti-real-dev)" >&2; exit 1; }
mkdir -p "$out"
for n in $sizes; do
  sized=$out/root-n$n
  mkdir -p "$sized/ImageSets"
  [ -e "$sized/training" ] || ln -s "$(cd "$root" && pwd)/training" "$sized/training"
  cp "$root/ImageSets/fewshot_val.txt" "$sized/ImageSets/"
  head -n "$n" "$root/ImageSets/fewshot_train.txt" > "$sized/ImageSets/fewshot_train_$n.txt"
  epochs=$(( (30 * 26 + n - 1) / n ))
  for s in $seeds; do
    common=(--set "data.root=\"$sized\"" --set "data.train_split=\"fewshot_train_$n\"" --set "seed=$s"
            --set "train.epochs=$epochs" --set "train.decay_start_epoch=$(( epochs / 2 ))")
    d=$out/finetune-n$n-s$s
    [ -f "$d/eval.json" ] || "$bin" train --config configs/finetune-real.toml --init "$sim/quickstart-s$s/checkpoints/best" \
      --run "$d" "${common[@]}" > "$d.log" 2>&1
    d=$out/scratch-n$n-s$s
    [ -f "$d/eval.json" ] || "$bin" train --config configs/finetune-real.toml --run "$d" "${common[@]}" \
      --set train.learning_rate=0.002 > "$d.log" 2>&1
  done
done
for s in $seeds; do
  d=$out/finetune-n0-s$s
  compgen -G "$d/*/eval.json" > /dev/null || "$bin" eval --checkpoint "$sim/quickstart-s$s/checkpoints/best" --data "$root" \
    --split fewshot_val --config configs/finetune-real.toml --out "$d" > "$d.log" 2>&1
done
table
