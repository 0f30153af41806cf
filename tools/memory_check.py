#!/usr/bin/env python3
"""Peak memory of dfo_run against its up-front estimate (dfo_backend/memory_estimate.h).

Runs dfo_run on 60 frames of the synthetic street (rendered by dfo_synth once) with the demo and
the KITTI settings at several frame sizes, and prints for each run summary.json's
memory_estimate_mb and peak_rss_mb and their ratio. Exits 1 when a run's peak exceeds its
estimate.

Usage: tools/memory_check.py [--build build] [--work out/memory_check] [--quick]
  --quick  only the sizes up to 832 x 256 (about a minute)
"""
import argparse
import json
import os
import subprocess
import sys

DEMO = ["--config", "configs/demo.yaml"]
KITTI = ["--config", "configs/kitti.yaml", "--set", "dataset.sequence=00",
         "--set", "frontend.depth=learned", "--set", "learned.require_input_size=false"]
RUNS = [
    # name, settings, width, height, quick
    ("demo", DEMO, 416, 128, True),
    ("demo", DEMO, 832, 256, True),
    ("demo", DEMO, 1664, 512, False),
    ("demo", DEMO, 3328, 1024, False),
    ("demo, 1 channel", DEMO + ["--set", "frontend.handmade_descriptor=intensity"], 1664, 512,
     False),
    ("demo, 5 channels", DEMO + ["--set", "frontend.handmade_descriptor=rich"], 1664, 512, False),
    ("demo, 12 keyframes", DEMO + ["--set", "window.max_keyframes=12"], 1664, 512, False),
    ("demo, frontend only", DEMO + ["--set", "run.mode=frontend"], 1664, 512, False),
    ("kitti, network at model size", KITTI + ["--set", "learned.depth_at_model_size=true"], 832,
     256, True),
    ("kitti, network at model size", KITTI + ["--set", "learned.depth_at_model_size=true"], 1664,
     512, False),
    ("kitti, network at frame size", KITTI + ["--set", "learned.depth_at_model_size=false"], 1664,
     512, False),
]


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--build", default="build")
    parser.add_argument("--work", default="out/memory_check")
    parser.add_argument("--quick", action="store_true")
    args = parser.parse_args()
    run_exe = os.path.join(args.build, "apps", "dfo_run")
    synth_exe = os.path.join(args.build, "apps", "dfo_synth")
    for exe in (run_exe, synth_exe):
        if not os.access(exe, os.X_OK):
            sys.exit(f"memory_check: {exe} not found: build first (make build)")
    sequence = os.path.join(args.work, "synthetic")
    if not os.path.isdir(os.path.join(sequence, "sequences", "00")):
        subprocess.run([synth_exe, "--output", sequence, "--frames", "60", "--seed", "1"],
                       check=True, stdout=subprocess.DEVNULL)
    print(f"{'settings':32} {'frames':>11} {'estimate MiB':>13} {'peak MiB':>9} {'ratio':>6}")
    over = 0
    for i, (name, settings, width, height, quick) in enumerate(RUNS):
        if args.quick and not quick:
            continue
        out = os.path.join(args.work, f"run_{i}")
        command = [run_exe] + settings + [
            "--set", f"dataset.path={sequence}", "--set", "dataset.last=59",
            "--set", f"dataset.image_width={width}", "--set", f"dataset.image_height={height}",
            "--set", "run.progress=none", "--set", "run.plot=false", "--set", "run.threads=1",
            "--set", "run.memory_limit_mb=0", "--output", out]
        result = subprocess.run(command, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE,
                                text=True)
        if result.returncode != 0:
            sys.exit(f"memory_check: {name} at {width} x {height} failed: {result.stderr}")
        with open(os.path.join(out, "summary.json")) as f:
            summary = json.load(f)
        estimate, peak = summary["memory_estimate_mb"], summary["peak_rss_mb"]
        flag = "" if peak <= estimate else "  PEAK ABOVE THE ESTIMATE"
        over += 1 if flag else 0
        print(f"{name:32} {width:5d}x{height:<5d} {estimate:13.0f} {peak:9.0f} "
              f"{estimate / peak:6.2f}{flag}")
    return 1 if over else 0


if __name__ == "__main__":
    sys.exit(main())
