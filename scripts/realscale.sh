#!/bin/bash
# Issue 48, item 5: the loader, `prepare` and the trainer on a KITTI-size root (7,481 frames).
# Writes into OUT: machine.txt, synth.log / prepare.log (/usr/bin/time -v), qs.log / kc.log (the
# training logs) and qs.rss / kc.rss (seconds, resident kB and the newest step, every 5 s).
# ROOT (default /tmp/kitti7481, 14 GB) is generated if absent. KC_SECONDS: how long the
# authors' car model trains (default 600; an epoch of it takes hours on 2 cores).
set -u
cd "$(dirname "$0")/.."
BIN=${BIN:-target/debug/starnet}
ROOT=${ROOT:-/tmp/kitti7481}
OUT=${OUT:-/tmp/realscale}
KC_SECONDS=${KC_SECONDS:-600}
mkdir -p "$OUT"
{ lscpu | grep "Model name"; date -u; } > "$OUT/machine.txt"
sample() { # PID LOG OUTFILE
  while kill -0 "$1" 2>/dev/null; do
    rss=$(awk '/VmRSS/{print $2}' "/proc/$1/status" 2>/dev/null)
    echo "$(date +%s) $rss $(tail -c 300 "$2" | grep step | tail -1 | cut -c1-40)" >> "$3"
    sleep 5
  done
}
if [ ! -e "$ROOT" ]; then
  /usr/bin/time -v "$BIN" synth --out "$ROOT" --frames 7481 --seed 0 --val-fraction 0.5038 > "$OUT/synth.log" 2>&1
fi
/usr/bin/time -v "$BIN" prepare --data "$ROOT" > "$OUT/prepare.log" 2>&1
# The quickstart's settings through one epoch of the train split, then its evaluation on val.
"$BIN" train --config configs/quickstart.toml --run "$OUT/run-quickstart" --set "data.root=\"$ROOT\"" \
  --set data.simulate_frames=0 --set train.epochs=1 --set train.decay_start_epoch=0.5 > "$OUT/qs.log" 2>&1 &
P=$!; sample $P "$OUT/qs.log" "$OUT/qs.rss"; wait $P
# The authors' car model for KC_SECONDS of its first epoch.
"$BIN" train --config configs/kitti-car.toml --run "$OUT/run-kitti-car" --set "data.root=\"$ROOT\"" \
  --set train.log_every=10 > "$OUT/kc.log" 2>&1 &
P=$!; ( sleep "$KC_SECONDS"; kill -9 $P ) & K=$!
sample $P "$OUT/kc.log" "$OUT/kc.rss"; kill $K 2>/dev/null
