#!/usr/bin/env bash
# The GPU path on a machine with a GPU (issue #19): builds the `vulkan` feature, runs the comparison
# test (StarNet's forward, loss, backward and an Adam step on the Vulkan device against flex, to
# 1e-4, then a short run on the GPU that must converge), then times the quickstart's training step
# on the GPU and on the CPU with the same binary (frames/s of the first STEPS steps, from the logs).
#
#   scripts/gpu_check.sh                 # wgpu's default adapter (the high-power GPU)
#   DEVICE=vulkan:1 STEPS=300 scripts/gpu_check.sh
#
# Needs libvulkan.so.1 and the GPU's Vulkan driver (NVIDIA's, or Mesa's radv / anv); without a GPU,
# Mesa's lavapipe (Debian mesa-vulkan-drivers) stands in and crashes (BENCHMARKS.md); CI only
# checks that the feature compiles. Runs go to runs/gpu-check/.
set -euo pipefail
cd "$(dirname "$0")/.."
device=${DEVICE:-vulkan}
steps=${STEPS:-200}
export CARGO_TARGET_DIR=${CARGO_TARGET_DIR:-target/vulkan}

# The test takes wgpu's default adapter (CUBECL_WGPU_DEFAULT_DEVICE=DiscreteGpu(1) picks another).
echo "== comparison test"
cargo test --release --workspace --features starnet-model/vulkan,starnet-train/vulkan --test vulkan -- --nocapture
cargo build --release --bin starnet --features starnet-train/vulkan
bin=$CARGO_TARGET_DIR/release/starnet

mean_rate() {
  python3 - "$1" <<'PY'
import json, sys
rates = [json.loads(l)["frames_per_s"] for l in open(sys.argv[1]) if '"frames_per_s"' in l][5:]
print(f"{len(rates) / sum(1 / r for r in rates):.1f}" if rates else "n/a")
PY
}

mkdir -p runs/gpu-check
for d in "$device" flex; do
  run=runs/gpu-check/$d
  rm -rf "$run"
  echo "== quickstart, $steps steps on $d"
  "$bin" train --config configs/quickstart.toml --device "$d" --run "$run" --max-steps "$steps" \
    --set train.eval_every=0 > "$run.out" 2>&1 || { tail -20 "$run.out"; exit 1; }
  echo "$d: $(mean_rate "$run/log.jsonl") frames/s (harmonic mean after step 5)"
done
lscpu | grep 'Model name' || true
