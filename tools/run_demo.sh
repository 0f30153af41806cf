#!/usr/bin/env bash
# The demo on the embedded default: dfo's own synthetic street sequence.
# Usage: tools/run_demo.sh [BUILD_DIR] [OUT_DIR]   (make demo calls it after building)
set -euo pipefail
BUILD_DIR=${1:-build}
OUT_DIR=${2:-out/demo}
SEED=${DFO_DEMO_SEED:-1}
FRAMES=${DFO_DEMO_FRAMES:-500}
# DFO_DEMO_LCM_LIVE=1 also publishes the run live over LCM (lcm.enable; watch it with
# dfo_lcm_listen in another terminal). The LCM event log is written either way.
LCM_LIVE=${DFO_DEMO_LCM_LIVE:-0}

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
echo "== dfo demo: frontend (hand-made features, ground-truth depth), keyframes, sliding-window BA =="
echo "   (run.mode both: the frontend-only and the windowed trajectory from the same frontend pass)"
CONFIG="$(cd "$(dirname "$0")/.." && pwd)/configs/demo.yaml"
LCM_LOG="$OUT_DIR/run/dfo_run.lcmlog"
mkdir -p "$OUT_DIR/run"
LCM_ARGS=(--set lcm.log_path="$LCM_LOG")
if [ "$LCM_LIVE" = 1 ]; then LCM_ARGS+=(--set lcm.enable=true); fi
"$RUN" --config "$CONFIG" --set dataset.path="$OUT_DIR/synthetic" --output "$OUT_DIR/run" \
  "${LCM_ARGS[@]}"

echo
echo "== dfo demo: the same sequence with the depth of the default learned model =="
echo "   (models/default.dfo, trained by dfo_train on other synthetic seeds; frames at its 208 x 64)"
ROOT="$(cd "$(dirname "$0")/.." && pwd)"
mkdir -p "$OUT_DIR/run_learned"
"$RUN" --config "$ROOT/configs/demo_learned.yaml" --set dataset.path="$OUT_DIR/synthetic" \
  --set learned.model="$ROOT/models/default.dfo" --output "$OUT_DIR/run_learned"

# A few figures from summary.json (pretty-printed: one key per line).
SUMMARY="$OUT_DIR/run/summary.json"
# value KEY [OBJECT]: the first "KEY": value, after the line that opens "OBJECT": { when given.
value() {
  local obj=""
  if [ -n "${2:-}" ]; then obj="\"$2\": {"; fi
  awk -v key="\"$1\":" -v obj="$obj" '
    obj != "" && !inside { if (index($0, obj)) inside = 1; next }
    index($0, key) { sub(/.*": */, ""); sub(/,$/, ""); print; exit }' "$SUMMARY"
}
# value rounded to $3 decimals ("null" and other non-numbers as they are).
fixed() {
  local v
  v=$(value "$1" "$2")
  if [[ "$v" =~ ^-?[0-9.]+([eE][-+]?[0-9]+)?$ ]]; then LC_ALL=C printf "%.$3f" "$v"; else printf "%s" "$v"; fi
}
echo
echo "== done =="
echo "frames:                   $(value frames) ($(value frames_lost) lost), $(value count keyframes) keyframes"
for which in frontend windowed; do
  printf "%-25s %s m rmse = %s %% of the %s m path; SE3 ATE %s m; RPE %s m/frame\n" \
    "ATE $which (Sim3):" "$(fixed ate_rmse $which 4)" "$(fixed ate_rmse_pct_of_path $which 3)" \
    "$(fixed gt_path_length_m $which 1)" "$(fixed ate_rmse_se3 $which 4)" \
    "$(fixed rpe_trans_rmse $which 4)"
done
SUMMARY="$OUT_DIR/run_learned/summary.json"
for which in frontend windowed; do
  printf "%-25s %s m rmse = %s %% of the path; SE3 ATE %s m; RPE %s m/frame\n" \
    "learned depth, $which:" "$(fixed ate_rmse $which 4)" "$(fixed ate_rmse_pct_of_path $which 3)" \
    "$(fixed ate_rmse_se3 $which 4)" "$(fixed rpe_trans_rmse $which 4)"
done
echo "                          (208 x 64; ground-truth depth at that size: see docs/window.md; pictures in $OUT_DIR/run_learned/)"
SUMMARY="$OUT_DIR/run/summary.json"
echo "speed:                    $(fixed fps '' 1) frames/s (whole run: loading PNGs + frontend + window); window per keyframe median $(fixed median backend_per_keyframe 1) ms"
echo "sequence (KITTI layout):  $OUT_DIR/synthetic/sequences/00  (image_0, image_2, depth_0, calib.txt, times.txt)"
echo "ground truth poses:       $OUT_DIR/synthetic/poses/00.txt"
echo "estimated poses:          $OUT_DIR/run/frontend_kitti.txt (frontend-only), $OUT_DIR/run/windowed_kitti.txt (windowed), $OUT_DIR/run/keyframes_tum.txt"
echo "summary:                  $SUMMARY"
echo "pictures:                 $OUT_DIR/synthetic_preview.png (sequence), $OUT_DIR/run/comparison_trajectory.png (both vs ground truth),"
echo "                          $OUT_DIR/run/frontend_trajectory.png, $OUT_DIR/run/windowed_trajectory.png (coloured by ATE)"
echo "LCM event log:            $LCM_LOG (every frame's poses, keyframe updates, status, stop)"
echo "                          read it:  $BUILD_DIR/apps/dfo_lcm_listen --log $LCM_LOG --tum $OUT_DIR/from_log_tum.txt"
echo "watch a run live over LCM (two terminals; README, \"Streaming poses over LCM\"):"
echo "  terminal 1:  $BUILD_DIR/apps/dfo_lcm_listen --tum $OUT_DIR/live_tum.txt"
echo "  terminal 2:  $BUILD_DIR/apps/dfo_run --config configs/demo.yaml --set dataset.path=$OUT_DIR/synthetic --output $OUT_DIR/run_live --set lcm.enable=true"
echo "               (or replay the demo's log: lcm-logplayer $LCM_LOG; or DFO_DEMO_LCM_LIVE=1 make demo)"
