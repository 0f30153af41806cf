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

RUN="$BUILD_DIR/apps/dfo_run"
if [ ! -x "$RUN" ]; then
  echo "run_demo: $RUN not found: build first (make demo does)" >&2
  exit 1
fi
echo
echo "== dfo demo: frontend (hand-made features, ground-truth depth) over the sequence =="
CONFIG="$(cd "$(dirname "$0")/.." && pwd)/configs/demo.yaml"
"$RUN" --config "$CONFIG" --set dataset.path="$OUT_DIR/synthetic" --output "$OUT_DIR/run"

# A few figures from summary.json (pretty-printed: one key per line).
SUMMARY="$OUT_DIR/run/summary.json"
value() { grep -m1 "\"$1\":" "$SUMMARY" | sed -e 's/.*: *//' -e 's/,$//'; }
# value rounded to $2 decimals ("null" and other non-numbers as they are).
fixed() {
  local v
  v=$(value "$1")
  if [[ "$v" =~ ^-?[0-9.]+([eE][-+]?[0-9]+)?$ ]]; then LC_ALL=C printf "%.$2f" "$v"; else printf "%s" "$v"; fi
}
echo
echo "== done =="
echo "frames:                   $(value frames) ($(value frames_lost) lost)"
echo "ATE (Sim3 aligned):       $(fixed ate_rmse 4) m rmse = $(fixed ate_rmse_pct_of_path 3) % of the $(fixed gt_path_length_m 1) m path"
echo "speed:                    $(fixed fps 1) frames/s (whole run: loading PNGs + frontend)"
echo "sequence (KITTI layout):  $OUT_DIR/synthetic/sequences/00  (image_0, image_2, depth_0, calib.txt, times.txt)"
echo "ground truth poses:       $OUT_DIR/synthetic/poses/00.txt"
echo "estimated poses:          $OUT_DIR/run/frontend_kitti.txt, $OUT_DIR/run/frontend_tum.txt"
echo "summary:                  $SUMMARY"
echo "pictures:                 $OUT_DIR/synthetic_preview.png (sequence), $OUT_DIR/run/frontend_trajectory.png (trajectory vs ground truth)"
