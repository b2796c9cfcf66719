#!/usr/bin/env bash
# The quickstart ablation (issue #15): trains configs/quickstart.toml with one setting changed at
# a time (`--set` overrides: a change undone, or one not in the quickstart tried), three seeds
# each, and tabulates each run's final evaluation (runs/ablation/<variant>-s<seed>/eval.json) as
# mean ± half-range. A run that has its eval.json is not trained again.
#
#   scripts/ablate.sh quickstart no-vote   # those variants, seeds 0 1 2, two runs at a time
#   SEEDS="0" JOBS=1 scripts/ablate.sh cylinder
#   scripts/ablate.sh                      # every variant below (39 runs: most of a day on 2 cores)
#   scripts/ablate.sh --table              # only the table of the runs already done
#
# Needs the built binary (cargo build --bin starnet) and python3 (standard library only).
set -euo pipefail
cd "$(dirname "$0")/.."
bin=target/debug/starnet
seeds=${SEEDS:-0 1 2}
jobs=${JOBS:-2}
out=runs/ablation

# name | overrides (space-separated KEY=VALUE, none for the quickstart itself). `previous` is the
# quickstart before box voting and the later decay; the `early-decay-*` rows are changes tried on
# the quickstart with the earlier decay (epoch 5).
variants() {
  cat <<'V'
quickstart|
no-vote|nms.vote_iou=[]
early-decay|train.decay_start_epoch=5
previous|train.decay_start_epoch=5 nms.vote_iou=[]
early-decay-cylinder|train.decay_start_epoch=5 pipeline.gather.metric="cylinder"
early-decay-shared-size|train.decay_start_epoch=5 model.shared_size=true
early-decay-ignore-band|train.decay_start_epoch=5 assign.fg_iou=0.6 assign.bg_iou=0.45
cylinder|pipeline.gather.metric="cylinder"
shared-size|model.shared_size=true
ignore-band|assign.fg_iou=0.6 assign.bg_iou=0.45
no-direction|model.direction_classifier=false
tight-boxes|augment.object_margin=0.0
points-64|pipeline.gather.num_points=64
V
}

run_one() {
  local name=$1 sets=$2 seed=$3 args=()
  for s in $sets; do args+=(--set "$s"); done
  local dir=$out/$name-s$seed
  [ -f "$dir/eval.json" ] && return 0
  "$bin" train --config configs/quickstart.toml --run "$dir" --set "seed=$seed" "${args[@]}" \
    > "$out/$name-s$seed.log" 2>&1
}

table() {
  python3 - "$out" <<'PY'
import json, os, sys, statistics
root = sys.argv[1]
rows = {}
for d in sorted(os.listdir(root)):
    f = os.path.join(root, d, "eval.json")
    if not os.path.isfile(f):
        continue
    name, seed = d.rsplit("-s", 1)
    r = json.load(open(f))
    car = r["classes"][0]
    w = r["waymo"][0]["levels"][0]
    rows.setdefault(name, []).append((int(seed), car["three_d"][1]["r40"], car["bev"][1]["r40"],
                                      car["bbox"][1]["r40"], (car.get("aos") or [{"r40": 0}] * 3)[1]["r40"],
                                      w["ap"], w["aph"]))
def stat(v):
    return f"{statistics.mean(v):.1f} ± {(max(v) - min(v)) / 2:.1f}" if len(v) > 1 else f"{v[0]:.1f}"
print("| variant | seeds | 3D R40 mod | BEV | 2D | AOS | LEVEL_1 AP | APH |")
print("|---|---|---|---|---|---|---|---|")
for name, runs in rows.items():
    cols = list(zip(*runs))
    seeds = ",".join(str(s) for s in cols[0])
    print(f"| {name} | {seeds} | " + " | ".join(stat(c) for c in cols[1:]) + " |")
PY
}

if [ "${1:-}" = "--table" ]; then table; exit 0; fi
[ -x "$bin" ] || { echo "build first: cargo build --bin starnet" >&2; exit 1; }
mkdir -p "$out"
wanted=("$@")
while IFS='|' read -r name sets; do
  if [ ${#wanted[@]} -gt 0 ] && [[ ! " ${wanted[*]} " == *" $name "* ]]; then continue; fi
  for seed in $seeds; do
    while [ "$(jobs -rp | wc -l)" -ge "$jobs" ]; do sleep 5; done
    run_one "$name" "$sets" "$seed" &
  done
done < <(variants)
wait
table
