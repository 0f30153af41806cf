#!/usr/bin/python3
"""Where a dfo_run's frame-to-frame error sits: steps into a keyframe against the others, and the
error of each keyframe's pose relative to the previous keyframe, split into the component along
the true direction of travel (scale) and the rest. For the frontend-only and the windowed
trajectory of one run.

  /usr/bin/python3 tools/keyframe_steps.py RUN_DIR GROUND_TRUTH_POSES

RUN_DIR: a dfo_run output folder (frontend_kitti.txt, windowed_kitti.txt, windowed_tum.txt,
keyframes_tum.txt); GROUND_TRUTH_POSES: the sequence's KITTI pose file (one 3 x 4 row-major
camera-to-world pose per frame, e.g. out/demo/synthetic/poses/00.txt). The trajectories are
compared frame by frame, so they must have a pose for every frame of the ground truth (they do
when dfo_run ran over the whole sequence). Needs numpy (Debian: python3-numpy).
"""
import sys

import numpy as np


def load_kitti(path):
    try:
        rows = np.loadtxt(path, ndmin=2)
    except (OSError, ValueError) as e:
        sys.exit(f"{path}: cannot read a KITTI pose file ({e})")
    if rows.shape[1] != 12:
        sys.exit(f"{path}: expected 12 values per line, found {rows.shape[1]}")
    poses = np.tile(np.eye(4), (len(rows), 1, 1))
    poses[:, :3, :] = rows.reshape(-1, 3, 4)
    return poses


def load_timestamps(path):
    stamps = []
    try:
        with open(path) as f:
            for number, line in enumerate(f, 1):
                if line.strip() and not line.startswith("#"):
                    stamps.append(float(line.split()[0]))
    except OSError as e:
        sys.exit(f"{path}: cannot read ({e})")
    except ValueError:
        sys.exit(f"{path}:{number}: not a TUM trajectory line")
    return stamps


def relative(poses, a, b):
    return np.linalg.inv(poses[a]) @ poses[b]


def rotation_deg(m):
    return np.degrees(np.arccos(np.clip((np.trace(m[:3, :3]) - 1.0) / 2.0, -1.0, 1.0)))


def rms(x):
    return float(np.sqrt(np.mean(np.square(x)))) if len(x) else float("nan")


def main():
    if len(sys.argv) != 3:
        sys.exit(__doc__)
    run, gt_path = sys.argv[1], sys.argv[2]
    gt = load_kitti(gt_path)
    estimates = {name: load_kitti(f"{run}/{name}_kitti.txt") for name in ("frontend", "windowed")}
    for name, est in estimates.items():
        if len(est) != len(gt):
            sys.exit(f"{run}/{name}_kitti.txt has {len(est)} poses, {gt_path} {len(gt)}")
    stamps = load_timestamps(f"{run}/windowed_tum.txt")
    keyframe_stamps = set(load_timestamps(f"{run}/keyframes_tum.txt"))
    if len(stamps) != len(gt):
        sys.exit(f"{run}/windowed_tum.txt has {len(stamps)} poses, {gt_path} {len(gt)}")
    is_keyframe = np.array([t in keyframe_stamps for t in stamps])
    keyframes = np.flatnonzero(is_keyframe)
    print(f"{len(gt)} frames, {len(keyframes)} keyframes")
    for name, est in estimates.items():
        errors = []
        for i in range(len(gt) - 1):
            d = np.linalg.inv(relative(gt, i, i + 1)) @ relative(est, i, i + 1)
            errors.append(np.linalg.norm(d[:3, 3]))
        errors = np.array(errors)
        into = is_keyframe[1:]
        print(f"{name:9s} frame step error (m): rms {rms(errors):.4f}, into a keyframe "
              f"{rms(errors[into]):.4f}, other steps {rms(errors[~into]):.4f}")
        trans, rot, along, across, lengths = [], [], [], [], []
        for a, b in zip(keyframes[:-1], keyframes[1:]):
            true_rel = relative(gt, a, b)
            est_rel = relative(est, a, b)
            d = np.linalg.inv(true_rel) @ est_rel
            trans.append(np.linalg.norm(d[:3, 3]))
            rot.append(rotation_deg(d))
            t_true = true_rel[:3, 3]
            length = np.linalg.norm(t_true)
            lengths.append(length)
            delta = est_rel[:3, 3] - t_true
            u = t_true / length if length > 0 else np.zeros(3)
            along.append(delta @ u)
            across.append(np.linalg.norm(delta - (delta @ u) * u))
        trans, rot, along, across = map(np.array, (trans, rot, along, across))
        print(f"{name:9s} keyframe to keyframe: translation error median {np.median(trans):.4f} m "
              f"(rms {rms(trans):.4f}), rotation median {np.median(rot):.3f} deg; along the "
              f"travel: mean {along.mean():+.4f} m, median |.| {np.median(np.abs(along)):.4f} m "
              f"({100 * np.median(np.abs(along)) / np.median(lengths):.2f}% of the median step "
              f"{np.median(lengths):.2f} m); across: median {np.median(across):.4f} m")


if __name__ == "__main__":
    main()
