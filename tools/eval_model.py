#!/usr/bin/python3
"""The held-out figures of a dfo depth model (a .dfo file), the ones models/README.md compares
models by, from one command:

  /usr/bin/python3 tools/eval_model.py --model M.dfo --output DIR [--build build] [--skip-real]
                                        [--trained-on 00,03]

- synthetic: depth of the held-out synthetic sequence (dfo_synth sequence 01, seed 1, 200 frames,
  rendered into DIR) against its true depth: `dfo_eval depth --median-scaling` AbsRel and
  median_scale_cv;
- demo: `configs/demo_learned.yaml` with the model on the demo's sequence (sequence 00, seed 1,
  500 frames, as `make demo`): windowed and frontend-only Sim3 ATE;
- tum: depth of the TUM fr3_cabinet keyframes (../shared/data), AbsRel and median_scale_cv;
- kitti06_depth, kitti03_depth: depth of real KITTI frames (06: every 5th of the held-out
  extract; 03: every 20th) against the stereo depth of their ground-truth poses (`dfo_eval
  stereo-depth`, made into DIR), AbsRel and median_scale_cv with median scaling;
- kitti06: `configs/kitti.yaml` (its keyframe stereo included, `learned.model` set to the model)
  on KITTI 06 started at each of frames 0-7 to frame 50 (held out):
  geometric means of the windowed and frontend-only Sim3 ATE, frames lost;
- kitti03: `configs/kitti.yaml` on all 801 frames of KITTI 03: Sim3 ATE and KITTI t_rel of both
  trajectories;
- kitti00_depth, kitti00: the same for KITTI 00 frames 0-159 (depth: every 10th frame; the run
  from frame 0 to 159).

A figure of a real sequence the model was trained on (--trained-on, e.g. `--trained-on 00,03`
for a model taught by runs of KITTI 00 and 03) is marked as such in the table and in
figures.json (`held_out: false`): only held-out figures say how the model carries over.

Everything runs with `run.threads` 1 (deterministic). The real sets are skipped, saying so, when
../shared/data is absent or with --skip-real. Prints a table and writes DIR/figures.json. Exits
with status 1 when a command fails (its output is in DIR/logs).
"""
import argparse
import json
import math
import os
import subprocess
import sys

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
SHARED = os.path.join(os.path.dirname(ROOT), "shared", "data")


class Runner:
    def __init__(self, build, output):
        self.build = build
        self.logs = os.path.join(output, "logs")
        os.makedirs(self.logs, exist_ok=True)

    def run(self, name, app, args):
        exe = os.path.join(self.build, "apps", app)
        if not os.access(exe, os.X_OK):
            raise RuntimeError(f"{exe} not found: build first (cmake --build {self.build})")
        log = os.path.join(self.logs, name + ".log")
        with open(log, "w") as out:
            rc = subprocess.call([exe] + args, cwd=ROOT, stdout=out, stderr=subprocess.STDOUT)
        if rc != 0:
            with open(log) as f:
                tail = f.read()[-600:]
            raise RuntimeError(f"{app} {' '.join(args)}: exit status {rc} (log {log}):\n{tail}")
        return log


def read_json(path):
    with open(path) as f:
        return json.load(f)


def depth_figures(runner, model, output, name, sequence, gt, gt_scale):
    pred = os.path.join(output, name + "_depth")
    runner.run(name + "_write_depth", "dfo_train",
               ["--config", "configs/train_default.yaml", "--output",
                os.path.join(output, "no_checkpoint"), "--write-depth", pred, "--sequence",
                sequence, "--model", model])
    result = os.path.join(output, name + "_depth.json")
    args = ["depth", "--gt", gt, "--pred", pred, "--median-scaling", "--json"]
    if gt_scale:
        args += ["--gt-scale", str(gt_scale)]
    log = runner.run(name + "_eval", "dfo_eval", args)
    with open(log) as f:
        text = f.read()
    figures = json.loads(text[text.index("{"):])
    with open(result, "w") as f:
        json.dump(figures, f, indent=2)
    return {"abs_rel": figures["abs_rel"], "median_scale_cv": figures["median_scale_cv"]}


def run_figures(runner, name, config, output, sets):
    out = os.path.join(output, name)
    args = ["--config", config, "--output", out, "--set", "run.threads=1", "--set",
            "run.plot=false", "--set", "run.progress=none"]
    for s in sets:
        args += ["--set", s]
    runner.run(name, "dfo_run", args)
    summary = read_json(os.path.join(out, "summary.json"))
    figures = {"frames_lost": summary["frames_lost"]}
    for trajectory in ("frontend", "windowed"):
        t = summary.get(trajectory)
        if t:
            figures[trajectory + "_ate_rmse"] = t["ate_rmse"]
            if t.get("kitti_t_rel_pct") is not None:
                figures[trajectory + "_t_rel_pct"] = t["kitti_t_rel_pct"]
    return figures


def geometric_mean(values):
    return math.exp(sum(math.log(v) for v in values) / len(values))


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--model", required=True, help="the .dfo model file")
    parser.add_argument("--output", required=True, help="folder for the runs and figures.json")
    parser.add_argument("--build", default=os.path.join(ROOT, "build"), help="build folder")
    parser.add_argument("--skip-real", action="store_true", help="synthetic figures only")
    parser.add_argument("--synthetic-frames", type=int, default=200,
                        help="frames of the held-out synthetic sequence (200 for the figures of "
                        "models/README.md)")
    parser.add_argument("--demo-frames", type=int, default=500,
                        help="frames of the demo sequence (500 as make demo)")
    parser.add_argument("--trained-on", default="",
                        help="comma-separated KITTI sequences the model was trained on (e.g. 03 "
                        "for models/kitti.dfo): their figures are marked as not held out")
    a = parser.parse_args()
    trained_on = {t.strip() for t in a.trained_on.split(",") if t.strip()}
    unknown = trained_on - {"00", "03", "06"}
    if unknown:
        sys.exit(f"eval_model: --trained-on {a.trained_on}: {', '.join(sorted(unknown))} is not "
                 "one of the measured sequences 00, 03, 06")
    model = os.path.abspath(a.model)
    output = os.path.abspath(a.output)
    build = os.path.abspath(a.build)
    if not os.path.isfile(model):
        sys.exit(f"eval_model: model file {model} does not exist")
    runner = Runner(build, output)
    figures = {"model": model}
    try:
        synth = os.path.join(output, "synthetic")
        runner.run("synth_heldout", "dfo_synth", ["--output", synth, "--sequence", "01", "--seed",
                                                  "1", "--frames", str(a.synthetic_frames)])
        seq = os.path.join(synth, "sequences", "01")
        figures["synthetic"] = depth_figures(runner, model, output, "synthetic", seq,
                                             os.path.join(seq, "depth_0"), None)
        demo = os.path.join(output, "demo_sequence")
        runner.run("synth_demo", "dfo_synth", ["--output", demo, "--sequence", "00", "--seed", "1",
                                               "--frames", str(a.demo_frames)])
        figures["demo_learned"] = run_figures(
            runner, "demo_learned", "configs/demo_learned.yaml", output,
            [f"dataset.path={demo}", f"learned.model={model}"])
        if a.skip_real:
            print("eval_model: real sets skipped (--skip-real)")
        elif not os.path.isdir(SHARED):
            print(f"eval_model: real sets skipped: {SHARED} is absent")
        else:
            tum = os.path.join(SHARED, "tum", "fr3_cabinet_keyframes")
            figures["tum"] = depth_figures(runner, model, output, "tum", tum,
                                           os.path.join(tum, "depth"), 5000)
            kitti = os.path.join(SHARED, "kitti")
            for seq, every, frames in (("06", 5, None), ("03", 20, None), ("00", 10, "0-159")):
                reference = os.path.join(output, f"kitti{seq}_stereo")
                stereo = ["stereo-depth", "--path", kitti, "--sequence", seq, "--every",
                          str(every), "--threads", "2", "--output", reference]
                if frames:
                    stereo += ["--frames", frames]
                runner.run(f"kitti{seq}_stereo", "dfo_eval", stereo)
                figures[f"kitti{seq}_depth"] = depth_figures(
                    runner, model, output, f"kitti{seq}", os.path.join(kitti, "sequences", seq),
                    reference, 256)
                figures[f"kitti{seq}_depth"]["held_out"] = seq not in trained_on
            starts = [run_figures(runner, f"kitti06_{f}-50", "configs/kitti.yaml", output,
                                  [f"dataset.path={kitti}", "dataset.sequence=06",
                                   f"dataset.first={f}", "dataset.last=50",
                                   f"learned.model={model}"]) for f in range(8)]
            figures["kitti06_8_starts"] = {
                "windowed_ate_rmse_gm": geometric_mean([s["windowed_ate_rmse"] for s in starts]),
                "frontend_ate_rmse_gm": geometric_mean([s["frontend_ate_rmse"] for s in starts]),
                "windowed_ate_rmse": [s["windowed_ate_rmse"] for s in starts],
                "frames_lost": sum(s["frames_lost"] for s in starts),
                "held_out": "06" not in trained_on}
            figures["kitti03"] = run_figures(
                runner, "kitti03", "configs/kitti.yaml", output,
                [f"dataset.path={kitti}", "dataset.sequence=03", f"learned.model={model}"])
            figures["kitti03"]["held_out"] = "03" not in trained_on
            figures["kitti00"] = run_figures(
                runner, "kitti00", "configs/kitti.yaml", output,
                [f"dataset.path={kitti}", "dataset.sequence=00", "dataset.last=159",
                 f"learned.model={model}"])
            figures["kitti00"]["held_out"] = "00" not in trained_on
    except (RuntimeError, KeyError, ValueError, OSError) as e:
        print(f"eval_model: {e}", file=sys.stderr)
        with open(os.path.join(output, "figures.json"), "w") as f:
            json.dump(figures, f, indent=2)  # what was measured before the failure
        return 1
    with open(os.path.join(output, "figures.json"), "w") as f:
        json.dump(figures, f, indent=2)

    def fmt(v, d=3):
        return "-" if v is None else f"{v:.{d}f}"

    s, dl = figures["synthetic"], figures["demo_learned"]
    print(f"model {model}")
    print(f"synthetic depth (seed 1, held out): AbsRel {fmt(s['abs_rel'])}, "
          f"cv {fmt(s['median_scale_cv'])}")
    print(f"demo learned: windowed {fmt(dl.get('windowed_ate_rmse'))} m, frontend-only "
          f"{fmt(dl.get('frontend_ate_rmse'))} m, lost {dl['frames_lost']}")
    def what(seq):
        return "held out" if seq not in trained_on else "TRAINED ON: not a held-out figure"

    if "tum" in figures:
        t, k6 = figures["tum"], figures["kitti06_8_starts"]
        print(f"TUM depth (held out): AbsRel {fmt(t['abs_rel'])}, cv {fmt(t['median_scale_cv'])}")
        for seq in ("06", "03", "00"):
            d = figures[f"kitti{seq}_depth"]
            print(f"KITTI {seq} depth against ground-truth-pose stereo ({what(seq)}): AbsRel "
                  f"{fmt(d['abs_rel'])}, cv {fmt(d['median_scale_cv'])}")
        print(f"KITTI 06, 8 starts ({what('06')}): windowed {fmt(k6['windowed_ate_rmse_gm'])} m, "
              f"frontend-only {fmt(k6['frontend_ate_rmse_gm'])} m (geometric means), "
              f"lost {k6['frames_lost']}")
        for seq, frames in (("03", "801 frames"), ("00", "frames 0-159")):
            k = figures[f"kitti{seq}"]
            print(f"KITTI {seq}, {frames} ({what(seq)}): windowed "
                  f"{fmt(k.get('windowed_ate_rmse'), 2)} m, t_rel "
                  f"{fmt(k.get('windowed_t_rel_pct'), 2)} %; frontend-only "
                  f"{fmt(k.get('frontend_ate_rmse'), 2)} m, t_rel "
                  f"{fmt(k.get('frontend_t_rel_pct'), 2)} %, lost {k['frames_lost']}")
    print(f"figures: {os.path.join(output, 'figures.json')}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
