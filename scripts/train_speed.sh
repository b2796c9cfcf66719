#!/usr/bin/env bash
# Training speed of one or more `starnet` binaries on the quickstart, alternating (issue #16):
# each run trains `configs/quickstart.toml` (or CONFIG) for SECONDS_PER_RUN (default 70) with the data in the page
# cache, is stopped by SIGINT, and reports the harmonic mean of `frames_per_s` in its log after
# step 50 and each thread's CPU over seconds 35-55. Machines of one kind differ from day to day:
# compare binaries within one call, never across calls.
#
#   scripts/train_speed.sh old=/tmp/starnet-old new=target/debug/starnet
#   ROUNDS=3 SECONDS_PER_RUN=90 scripts/train_speed.sh a=bin1 b=bin2 -- --set train.workers=2
#   ENV="RAYON_NUM_THREADS=1" scripts/train_speed.sh new=target/debug/starnet
#   CONFIG=configs/sim-car-paper.toml scripts/train_speed.sh new=target/debug/starnet
#   scripts/train_speed.sh old=/tmp/starnet-old@/tmp/old-quickstart.toml new=target/release/starnet
#     (label=binary@config: that binary trains that config, e.g. an old binary its own tree's)
#   cp -r data/sim /dev/shm/ && DATA=/dev/shm/sim scripts/train_speed.sh ...
#
# This VM's memory reclaim evicts idle page cache within minutes, and a run whose frames come from
# the disk is IO-bound (the cores column then sums well below 2): with DATA on a tmpfs it cannot.
#
# Runs go to runs/speed/<label>-<round> (replaced). Needs python3 (standard library only) and
# data/sim (any quickstart run generates it).
set -euo pipefail
cd "$(dirname "$0")/.."
rounds=${ROUNDS:-2}
data=${DATA:-data/sim}
seconds=${SECONDS_PER_RUN:-70}
bins=()
while [[ $# -gt 0 && $1 != "--" ]]; do bins+=("$1"); shift; done
[[ $# -gt 0 ]] && shift
extra=("$@")
[[ ${#bins[@]} -gt 0 ]] || { echo "usage: $0 label=binary... [-- train args]" >&2; exit 2; }
[[ -d $data/training/velodyne ]] || { echo "$data is missing: run the quickstart once" >&2; exit 2; }
mkdir -p runs/speed

thread_ticks() { for t in /proc/"$1"/task/*; do echo "$(cat "$t"/comm) $(awk '{print $14 + $15}' "$t"/stat)"; done; }

one_run() {
  local label=$1 bin=${2%%@*} dir=$3 config=${CONFIG:-configs/quickstart.toml}
  [[ $2 == *@* ]] && config=${2#*@}
  # The VM's memory reclaim evicts idle page cache: read the frames back in first.
  cat "$data"/training/velodyne/*.bin "$data"/training/label_2/*.txt > /dev/null
  rm -rf "$dir"
  env ${ENV:-} "$bin" train --config "$config" --run "$dir" \
    --set "data.root=\"$data\"" "${extra[@]}" > "$dir.out" 2>&1 &
  local pid=$!
  sleep 35
  local before; before=$(thread_ticks "$pid")
  sleep 20
  local after; after=$(thread_ticks "$pid")
  sleep $(( seconds > 55 ? seconds - 55 : 0 ))
  kill -INT "$pid"; wait "$pid" || true
  python3 - "$dir" "$label" "$before" "$after" <<'PY'
import json, sys
dir, label, before, after = sys.argv[1:5]
steps = [json.loads(l) for l in open(dir + "/log.jsonl") if '"frames_per_s"' in l]
fps = [r["frames_per_s"] for r in steps if r["step"] > 50]
hmean = len(fps) / sum(1 / f for f in fps) if fps else 0.0
t0 = [l.rsplit(" ", 1) for l in before.splitlines()]
t1 = [l.rsplit(" ", 1) for l in after.splitlines()]
cores = " ".join(f"{n}:{(int(b) - int(a)) / 100 / 20:.2f}" for (n, a), (_, b) in zip(t0, t1))
print(f"{label:12} {dir:28} steps {steps[-1]['step'] if steps else 0:5}  {hmean:5.1f} frames/s  cores {cores}")
PY
}

echo "$(lscpu | grep 'Model name' | sed 's/  */ /g'); $(date -u +%FT%TZ)"
for round in $(seq 1 "$rounds"); do
  for pair in "${bins[@]}"; do
    one_run "${pair%%=*}" "${pair#*=}" "runs/speed/${pair%%=*}-$round"
  done
done
