#!/usr/bin/env bash
# Builds what scripts/gpu_check.sh runs on a GPU machine without a Rust toolchain (issue #38): the
# release `starnet` binary with the `vulkan` feature and the comparison test's binary, stripped and
# xz-compressed into .gpu-bin/ (about 13 and 11 MB; scripts/gpu_check.sh unpacks them); with features
# (`fusion`, `autotune`), the variants with them beside those. A cold build takes about 40 minutes on
# 2 cores (the test binary builds starnet-model's dev-dependencies with other features); a variant
# with the same target folder, about 15.
#
#   scripts/gpu_build.sh                    # .gpu-bin/starnet.xz, .gpu-bin/vulkan-test.xz
#   scripts/gpu_build.sh autotune           # .gpu-bin/starnet-autotune.xz, .gpu-bin/vulkan-test-autotune.xz
#   scripts/gpu_build.sh fusion autotune    # .gpu-bin/starnet-fusion-autotune.xz, ...
#
# Copy .gpu-bin/, configs/, models/quickstart/ and scripts/ to the GPU machine (with the Vulkan
# loader's packages in .gl/ where it has no libvulkan.so.1) and run scripts/gpu_check.sh there.
set -euo pipefail
cd "$(dirname "$0")/.."
features=starnet-train/vulkan
suffix=
for feature in "$@"; do
  features+=,starnet-train/$feature
  suffix+=-$feature
done
export CARGO_TARGET_DIR=${CARGO_TARGET_DIR:-target/gpu}
mkdir -p .gpu-bin
cargo build --release --bin starnet --features "$features"
pack() { strip -o "$1.tmp" "$2" && xz -T0 -6 -c "$1.tmp" > "$1.xz" && rm "$1.tmp"; }
pack ".gpu-bin/starnet$suffix" "$CARGO_TARGET_DIR/release/starnet"
test_bin=$(cargo test --release -p starnet-model --features "${features//starnet-train/starnet-model}" \
  --test vulkan --no-run --message-format=json |
  python3 -c 'import json, sys
for line in sys.stdin:
    m = json.loads(line)
    if m.get("reason") == "compiler-artifact" and m["target"]["name"] == "vulkan" and m.get("executable"):
        print(m["executable"])')
pack ".gpu-bin/vulkan-test$suffix" "$test_bin"
ls -l .gpu-bin
