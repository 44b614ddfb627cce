"""The keypoint-first fit against ground truth on realistic recordings.

The recordings: `handvar.evaluation.realistic`.

For each case (motion, cameras, side, seed), the recording's simulated detector keypoints
(every frame, or every 5th with the frames between left to the prediction and the
silhouettes) are tracked by `handvar.tracking.recovery.Recovery` (RVAR predictor, a
185 mm model hand of the case's side, the first pose fitted to the first keypoints) and
scored with `handvar.evaluation.metrics` against the truth, beside the raw keypoints:
2D PCK@0.2 and mean 2D error (pixels) of camera 0, wrist-relative MPJPE, PA-MPJPE, AUC
of 3D PCK over 20-50 mm, absolute 3D error, frames lost, ms per frame (fit and rules).

Run: ``PYTHONPATH=src python benchmarks/keypoint_fit_realistic.py [--frames 150]``
"""

from __future__ import annotations

import argparse
import time

import numpy as np

from handvar.evaluation.metrics import (
    auc_pck_3d,
    joint_errors,
    mean_point_error,
    mpjpe,
    pa_mpjpe,
    pck_2d,
)
from handvar.evaluation.realistic import motion_poses, realistic_case
from handvar.hand import HandModel
from handvar.hand.anthropometry import HandShape
from handvar.predictors.catalogue import make_predictor
from handvar.tracking.costs import CostSettings
from handvar.tracking.keypoint_cost import keypoint_points
from handvar.tracking.recovery import Recovery, _assemble
from handvar.tracking.tracker import Tracker, TrackerSettings

CASES = (
    ("counting", 1, "right", 0),
    ("benchmark", 1, "left", 1),
    ("flip", 1, "right", 2),
    ("flexion", 1, "left", 3),
    ("counting", 2, "right", 4),
    ("benchmark", 2, "left", 5),
)


def run(case, every: int):
    n_cams = len(case.rig)
    hand = HandModel(HandShape.from_size(185.0, side=case.side))
    settings = TrackerSettings(cost=CostSettings(keypoint_tips="pad"))
    tracker = Tracker(case.rig, hand, make_predictor("rvar"), np.random.default_rng(0), settings)
    recovery = Recovery(tracker)
    frames, seconds = [], []
    T = case.n_frames
    for t in range(T):
        kps = None
        if t % every == 0:
            kps = [np.column_stack([case.keypoints[j, t], np.ones(21)]) for j in range(n_cams)]
            if not any(np.isfinite(k[:, :2]).all(axis=1).any() for k in kps):
                kps = None
        t0 = time.perf_counter()
        frames.append(recovery.frame(lambda t=t: case.masks[:, t], kps, with_keypoints=True))
        seconds.append(time.perf_counter() - t0)
    hand = recovery.hand  # the shape adapted to the first frames
    res = _assemble(
        frames,
        hand,
        n_cams,
        settings.smd.max_iterations,
        recovery.init_seconds,
        np.asarray(seconds),
    )
    poses = res.track.poses
    P = np.stack(
        [
            keypoint_points(hand, x, "pad") if np.isfinite(x).all() else np.full((21, 3), np.nan)
            for x in poses
        ]
    )
    proj = np.stack([case.rig.cameras[0].project(p.reshape(-1, 3)).reshape(21, 2) for p in P])
    return P, proj, res, np.asarray(seconds)


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--frames", type=int, default=150)
    args = ap.parse_args()
    print(
        "case | keypoints | 2D PCK@0.2 | 2D mean px | MPJPE mm | PA-MPJPE mm | AUC 20-50 | "
        "abs 3D mm | lost | ms/frame"
    )
    for motion, cams, side, seed in CASES:
        n = len(motion_poses(motion, seed)[0])
        case = realistic_case(
            motion, cameras=cams, side=side, seed=seed, frames=(0, min(n, args.frames))
        )
        rig_name = "mono" if cams == 1 else "stereo"
        label = f"{motion} {rig_name} {side} seed {seed} ({case.hand_length:.0f} mm)"
        raw, truth = case.keypoints[0], case.truth_2d[0]
        print(
            f"{label} | raw | {pck_2d(truth, raw):.3f} | "
            f"{mean_point_error(truth, raw)[0]:.1f} | - | - | - | - | - | -"
        )
        for every in (1, 5):
            P, proj, res, sec = run(case, every)
            err = joint_errors(case.joints, P)
            absolute = np.nanmean(np.linalg.norm(P - case.joints, axis=2))
            print(
                f"{label} | fit, every {every} | {pck_2d(truth, proj):.3f} | "
                f"{mean_point_error(truth, proj)[0]:.1f} | {mpjpe(case.joints, P):.1f} | "
                f"{pa_mpjpe(case.joints, P):.1f} | {auc_pck_3d(err):.3f} | {absolute:.1f} | "
                f"{int(res.quality.lost.sum())} | {1e3 * np.median(sec):.1f}",
                flush=True,
            )


if __name__ == "__main__":
    main()
