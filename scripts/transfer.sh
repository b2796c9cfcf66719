#!/usr/bin/env bash
# Simulator-to-real transfer (issue #33): trains configs/quickstart.toml per variant and seed on the
# built-in simulator data, evaluates each checkpoint on the simulator's val split (the run's own
# eval.json) and on a real KITTI root (REAL, default ../shared/kitti-real-dev, every frame of its
# val split) at the real budgets (`REAL_CENTERS` × `REAL_POINTS`, default 256,512 × 64,128), and tabulates Car
# R40 moderate as mean ± half-range over the seeds, one row per variant and real budget. A run that has its
# evaluations is not redone. The real frames are only evaluated on, never trained on.
#
#   scripts/transfer.sh quickstart reflectance  # those variants, seeds 0 1 2, one run at a time
#   SEEDS="0" scripts/transfer.sh reflectance-augmented
#   scripts/transfer.sh --table                 # the table of the runs already done
#
# Needs the built binary (cargo build --bin starnet) and python3 (standard library only).
set -euo pipefail
cd "$(dirname "$0")/.."
bin=${BIN:-target/debug/starnet}
seeds=${SEEDS:-0 1 2}
real=${REAL:-../shared/kitti-real-dev}
out=${OUT:-runs/transfer}
real_centers=${REAL_CENTERS:-256,512}
real_points=${REAL_POINTS:-64,128}

# name | overrides (space-separated KEY=VALUE). `quickstart` is the shipped config (geometry only, each
# object turned by up to ±45°, the pool and the centers levelled by the local ground); `rotation-9` turns objects by
# lingvo's ±9° instead; `reflectance` feeds the measured reflectance, `reflectance-augmented` also augments it;
# `ground-pool` keeps the levelled pool but puts the centers at z = 0 (issue #47).
variants() {
  cat <<'V'
quickstart|
ground-pool|pipeline.center_z="zero"
rotation-9|augment.box_rotation.max=0.15707964
reflectance|pipeline.gather.reflectance="measured"
reflectance-augmented|pipeline.gather.reflectance="measured" augment.reflectance.enabled=true
V
}

run_one() {
  local name=$1 sets=$2 seed=$3 args=()
  for s in $sets; do args+=(--set "$s"); done
  local dir=$out/$name-s$seed
  [ -f "$dir/eval.json" ] || "$bin" train --config configs/quickstart.toml --run "$dir" --set "seed=$seed" "${args[@]}" \
    > "$out/$name-s$seed.log" 2>&1
  compgen -G "$dir/real/c*_p*/eval.json" > /dev/null || "$bin" eval --checkpoint "$dir/checkpoints/best" --data "$real" --split val \
    --centers "$real_centers" --points "$real_points" --out "$dir/real" > "$out/$name-s$seed.real.log" 2>&1
}

table() {
  python3 - "$out" <<'PY'
import glob, json, os, sys, statistics
root = sys.argv[1]
rows = {}
def car(path):
    r = json.load(open(path))
    c = r["classes"][0]
    return c["three_d"][1]["r40"], c["bev"][1]["r40"]
for d in sorted(os.listdir(root)):
    sim = os.path.join(root, d, "eval.json")
    if not os.path.isfile(sim) or not os.path.isdir(os.path.join(root, d)):
        continue
    name, seed = d.rsplit("-s", 1)
    for real in sorted(glob.glob(os.path.join(root, d, "real", "c*_p*", "eval.json"))):
        budget = os.path.basename(os.path.dirname(real)).replace("c", "").replace("_p", " × ")
        rows.setdefault((name, budget), []).append((int(seed), *car(sim), *car(real)))
def stat(v):
    return f"{statistics.mean(v):.1f} ± {(max(v) - min(v)) / 2:.1f}" if len(v) > 1 else f"{v[0]:.1f}"
print("| variant | real budget | seeds | sim 3D | sim BEV | real 3D | real BEV | real 3D per seed |")
print("|---|---|---|---|---|---|---|---|")
for (name, budget), runs in sorted(rows.items(), key=lambda kv: (kv[0][0], [int(v) for v in kv[0][1].split(" × ")])):
    runs.sort()
    cols = list(zip(*runs))
    seeds = ",".join(str(s) for s in cols[0])
    per_seed = " / ".join(f"{v:.1f}" for v in cols[3])
    print(f"| {name} | {budget} | {seeds} | " + " | ".join(stat(c) for c in cols[1:]) + f" | {per_seed} |")
PY
}

if [ "${1:-}" = "--table" ]; then table; exit 0; fi
[ -x "$bin" ] || { echo "build first: cargo build --bin starnet" >&2; exit 1; }
[ -f "$real/ImageSets/val.txt" ] || { echo "$real: no ImageSets/val.txt (set REAL to a KITTI root)" >&2; exit 1; }
mkdir -p "$out"
wanted=("$@")
while IFS='|' read -r name sets; do
  if [ ${#wanted[@]} -gt 0 ] && [[ ! " ${wanted[*]} " == *" $name "* ]]; then continue; fi
  for seed in $seeds; do
    run_one "$name" "$sets" "$seed"
  done
done < <(variants)
table
