#!/usr/bin/python3
"""Does the camera model given with a KITTI-layout sequence agree with its frames? With the
ground-truth poses held fixed, long feature tracks are explained by one depth per track; the
reprojection error is then measured over a grid of focal-length scales s (fx, fy times s) and
radial distortion coefficients k1 (the frames treated as distorted by x_d = x (1 + k1 r^2), r in
normalised coordinates). A calibration that is right has its smallest error at s = 1, k1 = 0;
a pure rotation (a turn) constrains both, forward motion hardly.

  /usr/bin/python3 tools/calibration_check.py KITTI_ROOT SEQUENCE FIRST LAST [SPAN]

KITTI_ROOT holds sequences/NN/image_0/*.png, sequences/NN/calib.txt (a P0: row) and
poses/NN.txt. Tracks: up to 600 Shi-Tomasi corners every SPAN/2 frames from FIRST, followed by
pyramidal Lucas-Kanade through SPAN consecutive frames (default 10), kept where the backward
track returns within 0.3 px. Prints, per (s, k1), the mean squared error truncated at 3 px, the
median error and the median over tracks farther than 30 m (px). Needs numpy and OpenCV
(Debian: python3-numpy python3-opencv).
"""
import sys

import numpy as np

try:
    import cv2
except ImportError:
    sys.exit("calibration_check.py needs OpenCV for Python (Debian: python3-opencv)")


def main():
    if len(sys.argv) not in (5, 6):
        sys.exit(__doc__)
    root, seq, first, last = sys.argv[1], sys.argv[2], int(sys.argv[3]), int(sys.argv[4])
    span = int(sys.argv[5]) if len(sys.argv) == 6 else 10
    calib = f"{root}/sequences/{seq}/calib.txt"
    try:
        row = next(line for line in open(calib) if line.startswith("P0:"))
    except (OSError, StopIteration):
        sys.exit(f"{calib}: no P0: row")
    P = np.array(row.split()[1:], float).reshape(3, 4)
    f0, cx, cy = P[0, 0], P[0, 2], P[1, 2]
    poses = np.loadtxt(f"{root}/poses/{seq}.txt").reshape(-1, 3, 4)
    if last >= len(poses):
        sys.exit(f"{root}/poses/{seq}.txt has {len(poses)} poses; LAST = {last} is beyond it")

    def world_from_cam(i):
        m = np.eye(4)
        m[:3] = poses[i]
        return m

    def image(i):
        path = f"{root}/sequences/{seq}/image_0/{i:06d}.png"
        im = cv2.imread(path, cv2.IMREAD_GRAYSCALE)
        if im is None:
            sys.exit(f"cannot read {path}")
        return im

    tracks = []  # (first frame, (SPAN + 1) x 2 pixel positions)
    for s0 in range(first, last - span, max(1, span // 2)):
        prev = image(s0)
        pts = cv2.goodFeaturesToTrack(prev, 600, 0.01, 8)
        if pts is None:
            continue
        cur = pts.reshape(-1, 2).astype(np.float32)
        history, ok = [cur.copy()], np.ones(len(cur), bool)
        for j in range(1, span + 1):
            nxt = image(s0 + j)
            fwd, st, _ = cv2.calcOpticalFlowPyrLK(prev, nxt, cur, None, winSize=(21, 21), maxLevel=3)
            back, st2, _ = cv2.calcOpticalFlowPyrLK(nxt, prev, fwd, None, winSize=(21, 21), maxLevel=3)
            h, w = nxt.shape
            ok &= (st[:, 0] == 1) & (st2[:, 0] == 1) & (np.linalg.norm(back - cur, axis=1) < 0.3)
            ok &= (fwd[:, 0] > 2) & (fwd[:, 0] < w - 3) & (fwd[:, 1] > 2) & (fwd[:, 1] < h - 3)
            cur, prev = fwd, nxt
            history.append(cur.copy())
        tracks += [(s0, t) for t in np.stack(history, 1)[ok]]
    if not tracks:
        sys.exit("no feature tracks")
    print(f"{len(tracks)} tracks of {span + 1} frames over frames {first}-{last} of {seq}")

    relative = {}
    for s0, _ in tracks:
        for j in range(1, span + 1):
            if (s0, j) not in relative:
                relative[(s0, j)] = np.linalg.inv(world_from_cam(s0 + j)) @ world_from_cam(s0)

    def undistort(uv, s, k1):
        xd = (uv - [cx, cy]) / (f0 * s)
        xu = xd.copy()
        for _ in range(5):
            xu = xd / (1 + k1 * (xu ** 2).sum(-1, keepdims=True))
        return xu

    def squared_errors(xu, s0, inverse_depths):
        ray = np.array([xu[0, 0], xu[0, 1], 1.0])
        points = ray[None] / inverse_depths[:, None]
        e = np.zeros(len(inverse_depths))
        for j in range(1, len(xu)):
            m = relative[(s0, j)]
            y = points @ m[:3, :3].T + m[:3, 3]
            behind = y[:, 2] <= 0.1
            d = y[:, :2] / np.where(behind, 1.0, y[:, 2])[:, None] - xu[j]
            e += (d ** 2).sum(1) + behind * 1e9
        return e

    coarse = np.concatenate([[1e-4], np.geomspace(1e-3, 1.0, 120)])
    print("     s      k1   mean sq (<3 px)  median px  median px beyond 30 m")
    for s in (0.97, 0.985, 1.0, 1.015, 1.03):
        for k1 in (-0.02, 0.0, 0.01, 0.02, 0.03, 0.04):
            err, depth = [], []
            for s0, t in tracks:
                xu = undistort(t, s, k1)
                e = squared_errors(xu, s0, coarse)
                fine = coarse[np.argmin(e)] * np.linspace(0.94, 1.06, 25)
                e = squared_errors(xu, s0, fine)
                i = np.argmin(e)
                err.append(min((e[i] / (len(t) - 1)) ** 0.5 * f0 * s, 3.0) ** 2)
                depth.append(1 / fine[i])
            err, depth = np.array(err), np.array(depth)
            far = np.sqrt(np.median(err[depth > 30])) if (depth > 30).any() else float("nan")
            print(f"{s:6.3f} {k1:+7.3f}  {err.mean():15.4f}  {np.sqrt(np.median(err)):9.3f}  {far:9.3f}")


if __name__ == "__main__":
    main()
