#!/usr/bin/env bash
# The demo on the embedded default: dfo's own synthetic street sequence.
# Usage: tools/run_demo.sh [BUILD_DIR] [OUT_DIR]   (make demo calls it after building)
set -euo pipefail
BUILD_DIR=${1:-build}
OUT_DIR=${2:-out/demo}
SEED=${DFO_DEMO_SEED:-1}
FRAMES=${DFO_DEMO_FRAMES:-500}

SYNTH="$BUILD_DIR/apps/dfo_synth"
if [ ! -x "$SYNTH" ]; then
  echo "run_demo: $SYNTH not found: build first (make demo does)" >&2
  exit 1
fi

mkdir -p "$OUT_DIR"
echo "== dfo demo: rendering the default synthetic sequence (seed $SEED, $FRAMES frames) =="
"$SYNTH" --output "$OUT_DIR/synthetic" --sequence 00 --seed "$SEED" --frames "$FRAMES" \
  --preview "$OUT_DIR/synthetic_preview.png"

echo
echo "== done =="
echo "sequence (KITTI layout):  $OUT_DIR/synthetic/sequences/00  (image_0, image_2, depth_0, calib.txt, times.txt)"
echo "ground truth poses:       $OUT_DIR/synthetic/poses/00.txt"
echo "picture:                  $OUT_DIR/synthetic_preview.png"
