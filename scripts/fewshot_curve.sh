#!/usr/bin/env bash
# Real labels, few frames (issue #48): Car 3D / BEV AP R40 moderate on `fewshot_val` against the number of
# real training frames, (a) from scratch on real frames only, (b) fine-tuned from a simulator-trained model
# (configs/finetune-real.toml) and (c) fine-tuned on the real frames mixed with simulated ones, seeds 0-2. The
# first N frames of `fewshot_train` (ids in file order) train; every run takes the same number of steps as 30
# epochs of all 26 (390 at batch 2), the decay starting halfway. Each size gets its own writable root under OUT
# (training/ linked to ROOT's, its own ImageSets/ and paste database), so ROOT may be read-only.
#
#   ROOT=../shared/kitti-real-dev SIM_RUNS=runs/v4 scripts/fewshot_curve.sh
#   KINDS="finetune mixed" INIT=models/quickstart OUT=runs/mixed scripts/fewshot_curve.sh
#   scripts/fewshot_curve.sh --table [--svg docs/fewshot.svg]
#
# SIM_RUNS holds the simulator-only models (quickstart-s0..s2/checkpoints/best, as scripts/transfer.sh leaves them);
# seed k fine-tunes from seed k's model, so the spread holds both; INIT names one model for every seed instead
# (then the spread is the fine-tuning's alone). N = 0 is that model itself. KINDS picks among scratch, finetune
# and mixed. A mixed root also links MIX simulated frames per real frame from SIM_ROOT's train split (its ids
# renumbered 5xxxxx beside the real ones), so that every epoch is MIX + 1 parts simulation to one part real and
# the paste database holds both. Needs the built binary.
set -euo pipefail
cd "$(dirname "$0")/.."
bin=${BIN:-target/debug/starnet}
root=${ROOT:-../shared/kitti-real-dev}
sim=${SIM_RUNS:-runs/v4}
out=${OUT:-runs/fewshot}
sizes=${SIZES:-4 8 16 26}
seeds=${SEEDS:-0 1 2}
kinds=${KINDS:-scratch finetune}
sim_root=${SIM_ROOT:-data/sim}
mix=${MIX:-1}
init_of() { if [ -n "${INIT:-}" ]; then echo "$INIT"; else echo "$sim/quickstart-s$1/checkpoints/best"; fi; }
has() { [[ " $kinds " == *" $1 "* ]]; }

# A root holding every frame of ROOT and, renumbered, the first `mix * n` frames of SIM_ROOT's train split;
# its fewshot_train_mix_N split lists the first N real training frames and those simulated ones.
mixed_root() {
  local n=$1 dir=$2 kind id real simulated
  real=$(cd "$root" && pwd)/training
  simulated=$(cd "$sim_root" && pwd)/training
  mkdir -p "$dir/ImageSets"
  for kind in velodyne label_2 calib; do
    mkdir -p "$dir/training/$kind"
    ln -sf "$real/$kind"/* "$dir/training/$kind/"
  done
  cp "$root/ImageSets/fewshot_val.txt" "$dir/ImageSets/"
  head -n "$n" "$root/ImageSets/fewshot_train.txt" > "$dir/ImageSets/.split"
  for id in $(head -n $(( mix * n )) "$sim_root/ImageSets/train.txt"); do
    for kind in velodyne:bin label_2:txt calib:txt; do
      ln -sf "$simulated/${kind%%:*}/$id.${kind##*:}" "$dir/training/${kind%%:*}/5${id:1}.${kind##*:}"
    done
    echo "5${id:1}" >> "$dir/ImageSets/.split"
  done
  mv "$dir/ImageSets/.split" "$dir/ImageSets/fewshot_train_mix_$n.txt"
}

# Fine-tunes seed $2's starting model into run folder $1 on split $4 of root $3 for 390 steps of $5 frames an
# epoch (the decay from halfway), unless that run already evaluated.
finetune() {
  local d=$1 s=$2 data=$3 split=$4 frames=$5 epochs
  epochs=$(( (30 * 26 + frames - 1) / frames ))
  [ -f "$d/eval.json" ] || "$bin" train --config configs/finetune-real.toml --init "$(init_of "$s")" --run "$d" \
    --set "data.root=\"$data\"" --set "data.train_split=\"$split\"" --set "seed=$s" \
    --set "train.epochs=$epochs" --set "train.decay_start_epoch=$(( epochs / 2 ))" > "$d.log" 2>&1
}

table() {
  python3 - "$out" "${1:-}" <<'PY'
import glob, json, os, re, statistics, sys
rows = {}
for path in glob.glob(os.path.join(sys.argv[1], "*", "eval.json")) + glob.glob(os.path.join(sys.argv[1], "*", "*", "eval.json")):
    m = re.search(r"(scratch|finetune|mixed)-n(\d+)-s(\d+)", path)
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
if sys.argv[2]:
    # 3D AP against real frames, one line per kind through the seeds' mean, a bar from their min to max; every
    # fine-tuned curve starts at N = 0, the simulator-only model.
    w, h, left, top, colours = 560, 340, 50, 30, {"finetune": "#1f77b4", "mixed": "#d62728", "scratch": "#7f7f7f"}
    names = {"finetune": "fine-tuned on the real frames", "mixed": "fine-tuned on them and simulated ones (MIX per real)",
             "scratch": "from scratch on the real frames"}
    xs = sorted({n for _, n in rows})
    px = lambda n: left + 20 + (w - left - 40) * xs.index(n) / max(len(xs) - 1, 1)
    lo = max(0, 10 * int(min(v[1] for runs in rows.values() for v in runs) // 10) - 10)
    py = lambda ap: top + (h - top - 40) * (100 - ap) / (100 - lo)
    out = [f'<svg xmlns="http://www.w3.org/2000/svg" width="{w}" height="{h}" font-family="sans-serif" font-size="12">',
           f'<text x="{w / 2}" y="18" text-anchor="middle">Car 3D AP R40 moderate on fewshot_val against real training frames</text>']
    for ap in range(lo, 101, 10):
        out.append(f'<line x1="{left}" x2="{w - 10}" y1="{py(ap)}" y2="{py(ap)}" stroke="#ddd"/><text x="{left - 6}" y="{py(ap) + 4}" text-anchor="end">{ap}</text>')
    for n in xs:
        out.append(f'<text x="{px(n)}" y="{h - 22}" text-anchor="middle">{n}</text>')
    out.append(f'<text x="{w / 2}" y="{h - 6}" text-anchor="middle">real frames (N = 0: the simulator-only model)</text>')
    for i, kind in enumerate(k for k in colours if any(r[0] == k for r in rows)):
        pts = sorted((n, [v[1] for v in runs]) for (k, n), runs in rows.items() if k == kind or (n == 0 and kind != "scratch"))
        c = colours[kind]
        out.append(f'<polyline fill="none" stroke="{c}" stroke-width="2" points="{" ".join(f"{px(n)},{py(statistics.mean(v))}" for n, v in pts)}"/>')
        out += [f'<line x1="{px(n)}" x2="{px(n)}" y1="{py(min(v))}" y2="{py(max(v))}" stroke="{c}"/><circle cx="{px(n)}" cy="{py(statistics.mean(v))}" r="3" fill="{c}"/>' for n, v in pts]
        out.append(f'<text x="{left + 10}" y="{h - 60 - 16 * i}" fill="{c}">{names[kind]}</text>')
    open(sys.argv[2], "w").write("\n".join(out + ["</svg>"]) + "\n")
PY
}

if [ "${1:-}" = "--table" ]; then table "${3:-}"; exit 0; fi
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
    has finetune && finetune "$out/finetune-n$n-s$s" "$s" "$sized" "fewshot_train_$n" "$n"
    d=$out/scratch-n$n-s$s
    has scratch && { [ -f "$d/eval.json" ] || "$bin" train --config configs/finetune-real.toml --run "$d" "${common[@]}" \
      --set train.learning_rate=0.002 > "$d.log" 2>&1; }
    if has mixed; then
      mixed=$out/root-mix-n$n
      [ -f "$mixed/ImageSets/fewshot_train_mix_$n.txt" ] || mixed_root "$n" "$mixed"
      finetune "$out/mixed-n$n-s$s" "$s" "$mixed" "fewshot_train_mix_$n" $(( n * (mix + 1) ))
    fi
  done
done
for s in $seeds; do
  d=$out/finetune-n0-s$s
  compgen -G "$d/*/eval.json" > /dev/null || "$bin" eval --checkpoint "$(init_of "$s")" --data "$root" \
    --split fewshot_val --config configs/finetune-real.toml --out "$d" > "$d.log" 2>&1
done
table
