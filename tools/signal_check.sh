#!/usr/bin/env bash
# Stops dfo_run N times in each of two ways and counts the runs that lost a result:
#   double   two SIGINTs 50 ms apart (an impatient Ctrl-C Ctrl-C), the first 1.0-3.0 s after start
#   timeout  coreutils `timeout` after 1.0-3.0 s (it signals dfo_run, then its process group)
# A run has lost a result when summary.json, windowed_kitti.txt, keyframes_tum.txt or frames.csv is
# missing or empty, or its exit status is not 130 (double) / 124 (timeout) or 0 (finished first).
# Usage: tools/signal_check.sh [N=100] [BUILD_DIR=build] [WORK_DIR=out/signal_check]
# Prints one line per lost run and, last, "double: X of N lost results" and the same for timeout;
# exits 1 when any run lost a result. The delays come from a fixed seed (repeatable schedule).
set -euo pipefail
N=${1:-100}
BUILD_DIR=${2:-build}
WORK=${3:-out/signal_check}
RUN="$BUILD_DIR/apps/dfo_run"
SYNTH="$BUILD_DIR/apps/dfo_synth"
for exe in "$RUN" "$SYNTH"; do
  [ -x "$exe" ] || { echo "signal_check: $exe not found: build first (make build)" >&2; exit 1; }
done
command -v timeout >/dev/null || { echo "signal_check: coreutils timeout not found" >&2; exit 1; }
mkdir -p "$WORK"
SEQ="$WORK/synthetic"
[ -d "$SEQ/sequences/00" ] || "$SYNTH" --output "$SEQ" --frames 150 --seed 1 > /dev/null
RANDOM=12345
delay() { printf '%d.%02d' $((1 + RANDOM % 2)) $((RANDOM % 100)); }
lost_total=0
for mode in double timeout; do
  lost=0
  for i in $(seq 1 "$N"); do
    out="$WORK/$mode/$i"
    rm -rf "$out" && mkdir -p "$(dirname "$out")"
    args=(--config configs/demo.yaml --set dataset.path="$SEQ" --set run.progress=none --output "$out")
    d=$(delay)
    if [ "$mode" = timeout ]; then
      set +e; timeout "$d" "$RUN" "${args[@]}" > "$out.log" 2>&1; rc=$?; set -e
      expected=124
    else
      "$RUN" "${args[@]}" > "$out.log" 2>&1 & p=$!
      sleep "$d"; kill -INT "$p" 2>/dev/null || true; sleep 0.05; kill -INT "$p" 2>/dev/null || true
      set +e; wait "$p"; rc=$?; set -e
      expected=130
    fi
    missing=""
    for f in summary.json windowed_kitti.txt keyframes_tum.txt frames.csv; do
      [ -s "$out/$f" ] || missing="$missing $f"
    done
    if [ -n "$missing" ] || { [ "$rc" != "$expected" ] && [ "$rc" != 0 ]; }; then
      lost=$((lost + 1))
      echo "$mode run $i (after ${d} s): exit $rc, missing:${missing:- none}; log $out.log"
    fi
  done
  echo "$mode: $lost of $N lost results"
  lost_total=$((lost_total + lost))
done
[ "$lost_total" = 0 ]
