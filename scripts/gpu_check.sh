#!/usr/bin/env bash
# The GPU path on a machine with a GPU and no Rust toolchain (issue #38), in one run of a few minutes:
# the comparison test (StarNet's forward, loss, backward and an Adam step on the Vulkan device against
# flex to 1e-4, then a short run on the GPU that must converge), then the quickstart's training for a
# fixed time on the GPU and on the machine's CPU (stopped as Ctrl-C stops it), then the PyTorch peer's training step
# (scripts/torch_forward.py --train) on the same GPU and CPU. Every stage has its own time limit and a
# failing stage does not stop the others; the figures go to OUT/summary.txt, each run's output beside it.
#
# Prepared where cargo is (scripts/gpu_build.sh builds the binaries into .gpu-bin/, xz-compressed:
# they are unpacked here):
#   .gpu-bin/starnet             release, --features starnet-train/vulkan
#   .gpu-bin/vulkan-test         the comparison test (starnet-model/tests/vulkan.rs), release
#   .gpu-bin/starnet-VARIANT     with more features (`scripts/gpu_build.sh fusion` -> starnet-fusion),
#   .gpu-bin/vulkan-test-VARIANT likewise; optional, each trained and tested beside the first
# and, where the machine has no libvulkan.so.1, the loader's Debian packages in .gl/ (unpacked into /).
#
#   scripts/gpu_check.sh [OUT]                       # OUT defaults to runs/gpu-check
#   SECONDS_PER_RUN=60 BATCHES="2 16" scripts/gpu_check.sh
#   LAYOUTS="grouped flat" CONFIG=configs/sim-car-paper.toml scripts/gpu_check.sh
# LAYOUTS: the GPU runs' `model.row_layout` values, each trained (issue #50: "grouped", the default
# on a GPU, against "flat", the layout before it); CONFIG: the experiment trained.
set -uo pipefail
cd "$(dirname "$0")/.."
out=${1:-runs/gpu-check}
bin=${BIN:-.gpu-bin}
seconds=${SECONDS_PER_RUN:-30}
batches=${BATCHES:-2 16}
data=${DATA:-data/sim}
layouts=${LAYOUTS:-grouped flat}
config=${CONFIG:-configs/quickstart.toml}
mkdir -p "$out"
summary=$out/summary.txt
stage() { echo "== $* (+${SECONDS} s)" | tee -a "$summary"; }
say() { echo "$*" | tee -a "$summary"; }

for packed in "$bin"/*.xz; do
  [[ -e $packed && ! -e ${packed%.xz} ]] && xz -dc "$packed" > "${packed%.xz}" && chmod +x "${packed%.xz}"
done

# The Vulkan loader and NVIDIA's driver manifest (the driver's folder is mounted read-only).
if ! ldconfig -p | grep -q 'libvulkan.so.1'; then
  for f in .gl/*.deb; do dpkg -x "$f" /; done
  ldconfig
fi
icd=/usr/local/nvidia/share/vulkan/icd.d/nvidia_icd.json
[[ -f $icd && -z ${VK_DRIVER_FILES:-} ]] && export VK_DRIVER_FILES=$icd
stage "machine"
say "gpu: $(nvidia-smi --query-gpu=name,driver_version,memory.total --format=csv,noheader 2>&1 | head -1)"
say "cpu: $(lscpu | grep 'Model name' | sed 's/ \+/ /g'), $(nproc) cores"

# The harmonic mean of a run's frames/s after its first fifth (at least 5 steps: shader compilation
# and autotuning land in the first steps), and its median.
rate() {
  python3 - "$1" <<'PY'
import json, statistics, sys
rates = [json.loads(l)["frames_per_s"] for l in open(sys.argv[1]) if '"frames_per_s"' in l]
rates = rates[max(5, len(rates) // 5):]
if rates:
    print(f"{len(rates) / sum(1 / r for r in rates):7.1f} frames/s (harmonic mean of {len(rates)} steps), median {statistics.median(rates):7.1f}")
else:
    print("too few steps logged")
PY
}

# The variants built: "" and each suffix of a .gpu-bin/starnet-SUFFIX.
variants=("")
for exe in "$bin"/starnet-*; do
  [[ -x $exe && $exe != *.xz ]] && variants+=("-${exe##*/starnet-}")
done

for variant in "${variants[@]}"; do
  [[ -x $bin/vulkan-test$variant ]] || continue
  stage "comparison test$variant"
  if timeout 100 "$bin/vulkan-test$variant" --nocapture --test-threads 1 > "$out/test$variant.log" 2>&1; then
    say "passed"
  else
    say "FAILED ($?): $(tail -5 "$out/test$variant.log" | tr '\n' ' ')"
  fi
done

stage "simulator data"
if [[ ! -d $data/training/velodyne ]]; then
  timeout 120 "$bin/starnet" synth --out "$data" --frames 1200 --seed 0 > "$out/synth.log" 2>&1 || say "synth failed"
  timeout 60 "$bin/starnet" prepare --data "$data" >> "$out/synth.log" 2>&1 || say "prepare failed"
fi
# A 16-frame validation split: the runs' final evaluation is not what is measured.
head -16 "$data/ImageSets/val.txt" > "$data/ImageSets/val16.txt"

# One training run: label, binary, device, batch size, loader workers, step threads, row layout.
train() {
  local label=$1 exe=$2 device=$3 batch=$4 workers=$5 threads=$6 layout=$7
  [[ -x $exe ]] || return 0
  stage "train $label: $device, batch $batch, $workers loader workers, $threads step threads, ${seconds} s"
  local run=$out/runs/$label
  rm -rf "$run"
  # Stopped by SIGINT after $seconds s (the run saves a checkpoint, evaluates on 16 frames and ends).
  if timeout -s INT -k 30 "$seconds" "$exe" train --config "$config" --device "$device" --run "$run" \
      --set model.row_layout=\"$layout\" \
      --set "data.root=\"$data\"" --set data.val_split=\"val16\" \
      --set train.log_every=1 --set train.eval_every=0 --set train.batch_size="$batch" \
      --set train.workers="$workers" --set train.step_threads="$threads" > "$out/$label.out" 2>&1; then
    say "$label: $(rate "$run/log.jsonl")"
  elif [[ -f $run/log.jsonl ]] && grep -q frames_per_s "$run/log.jsonl"; then
    say "$label: $(rate "$run/log.jsonl") (stopped at ${seconds} s)"
  else
    say "$label FAILED ($?): $(tail -3 "$out/$label.out" | tr '\n' ' ')"
  fi
  cp "$run/log.jsonl" "$out/$label.jsonl" 2>/dev/null
}

cores=$(nproc)
step_threads=$(( cores > 8 ? cores - 4 : cores / 2 ))
for b in $batches; do
  [[ ${TRAIN:-1} == 1 ]] || break
  for variant in "${variants[@]}"; do
    for layout in $layouts; do
      train "gpu$variant-$layout-b$b" "$bin/starnet$variant" vulkan "$b" 8 1 "$layout"
    done
  done
  train "cpu-b$b" "$bin/starnet" flex "$b" $(( cores - step_threads )) "$step_threads" auto
done

# Where a GPU step's time goes (PROFILE=1): CubeCL's profiler times every kernel (each then runs
# alone, so the step is slower than above) and logs one line per kernel; the summary gets each
# kernel family's share of the GPU time, the process's wall and CPU time and the last steps' rates.
if [[ -n ${PROFILE:-} ]]; then
  for variant in "${variants[@]}"; do
  for b in ${PROFILE_BATCHES:-16}; do
    [[ -x $bin/starnet$variant ]] || continue
    stage "kernel profile$variant: vulkan, batch $b, 12 steps"
    log=$(cd "$out" && pwd)/cubecl-profile$variant-b$b.log
    printf '[profiling.logger]\nlevel = "basic"\nfile = "%s"\n' "$log" > cubecl.toml
    ( time timeout 150 "$bin/starnet$variant" train --config "$config" --device vulkan \
        --run "$out/runs/profile$variant-b$b" --max-steps 12 --set "data.root=\"$data\"" \
        --set data.val_split=\"val16\" --set train.log_every=1 --set train.batch_size="$b" \
        --set train.workers=8 > "$out/profile$variant-b$b.out" 2>&1 ) 2>> "$summary"
    rm -f cubecl.toml
    say "steps: $(grep -o '[0-9.]* frames/s' "$out/profile$variant-b$b.out" | tail -3 | tr '\n' ' ')"
    python3 - "$log" <<'PY' | tee -a "$summary"
import collections, re, sys
def seconds(d):
    m = re.match(r"([0-9.]+)(ns|µs|ms|s)$", d.strip())
    return float(m.group(1)) * {"ns": 1e-9, "µs": 1e-6, "ms": 1e-3, "s": 1.0}[m.group(2)] if m else None
total, count, longest = collections.Counter(), collections.Counter(), collections.Counter()
for line in open(sys.argv[1], errors="replace"):  # "| 43.3ms | MatmulEntry | ...": one line per kernel
    parts = line.split("|")
    t = seconds(parts[1]) if line.startswith("| ") and len(parts) > 2 else None
    if t is not None:
        name = re.sub(r"_[0-9a-f]{8}\b", "", parts[2].strip())  # the family, without its hash
        total[name] += t
        count[name] += 1
        longest[name] = max(longest[name], t)
all_time = sum(total.values())
print(f"{sum(count.values()) / 12:.0f} kernels and {all_time / 12 * 1e3:.1f} ms of GPU time a step (12 steps)")
for name, t in total.most_common(6):
    print(f"  {100 * t / all_time:5.1f} %  {count[name] / 12:6.1f} a step, longest {longest[name] * 1e3:6.2f} ms  {name}")
PY
  done
  done
fi

stage "PyTorch peer"
if [[ ${TORCH:-1} != 1 ]]; then
  say "skipped"
elif python3 -c 'import torch, safetensors' 2> /dev/null; then
  # shellcheck disable=SC2086
  timeout 60 python3 scripts/torch_forward.py models/quickstart --train --device cuda --batch $batches 2>&1 | tee -a "$summary"
  # shellcheck disable=SC2086
  timeout 60 python3 scripts/torch_forward.py models/quickstart --train --device cpu --threads "$cores" \
    --batch $batches --steps 30 2>&1 | tee -a "$summary"
else
  say "no torch here"
fi
stage "done"
