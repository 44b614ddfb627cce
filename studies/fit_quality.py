"""Distributions of the tracker's fit quality, to set the lost-frame rule (design §13).

Prints percentiles of the per-frame mean silhouette IoU, the final cost and the
keypoint error (hand sizes) for:

- the synthetic benchmark (stereo, RVAR), with and without synthetic keypoints, beside
  the mean joint error of the frames;
- starts 2 m too far along the left camera's axis and 1 m behind it (frame 90 of the
  benchmark, repeated, no motion model): per frame the cost against the true pose's,
  the joint error and the flag;
- all-white masks and a 3×3 blob;
- the example video (monocular, scale 0.5) tracked with its MediaPipe keypoints from
  the keypoint initial pose (with ``--video``).

    python studies/fit_quality.py [--frames 175] [--video] [--video-frames 621]
"""

from __future__ import annotations

import argparse
import warnings

import numpy as np

from handvar.camera import Rig
from handvar.data import example_path
from handvar.hand import HandModel
from handvar.predictors import RVAR, NoMotion
from handvar.render import silhouettes
from handvar.synth import make_sequence, synthetic_keypoints
from handvar.synth.sequences import benchmark
from handvar.tracking import Tracker

Q = (0, 1, 5, 50, 95, 99, 100)


def pct(name: str, v) -> None:
    v = np.asarray(v, dtype=float)
    v = v[~np.isnan(v)]
    if v.size == 0:
        print(f"    {name:<22s} (none)")
        return
    q = np.percentile(v, Q)
    print(f"    {name:<22s} " + " ".join(f"{p:>3d}%:{x:8.3g}" for p, x in zip(Q, q, strict=True)))


def rates(mean_iou, kp_err) -> None:
    iou = np.asarray(mean_iou, dtype=float)
    ke = np.asarray(kp_err, dtype=float)
    f = " ".join(f"<{t}: {np.mean(iou < t):.3f}" for t in (0.5, 0.7, 0.75, 0.8))
    k = " ".join(f">{t}: {np.mean(ke > t):.3f}" for t in (0.2, 0.3, 0.5))
    print(f"    fraction of frames with mean IoU {f}; keypoint error {k}")


def synthetic(frames: int) -> None:
    seq = make_sequence("benchmark", n_frames=frames)
    hand = HandModel()
    kp_synth = synthetic_keypoints(seq, 3.0, 0.1, np.random.default_rng(1000))
    for label, kp in (("silhouettes", None), ("keypoints", kp_synth)):
        res = Tracker(seq.rig, hand, RVAR(), np.random.default_rng(0)).track(
            seq, seq.truth.poses[0], keypoints=kp
        )
        err = np.linalg.norm(res.joints - seq.truth.joints, axis=2).mean(axis=1)
        print(f"  synthetic benchmark, stereo, {label}: {res.lost.sum()} of {len(err)} lost")
        pct("mean IoU", res.mean_iou)
        pct("cost", res.cost)
        pct("keypoint error", res.keypoint_error)
        pct("joint error, mm", err)
        rates(res.mean_iou, res.keypoint_error)


def bad_starts() -> None:
    hand, rig = HandModel(), Rig.default()
    truth = benchmark(0)[90]
    masks = silhouettes(hand, truth, rig)
    axis = rig.cameras[0].axis
    for name, shift in (("2 m too far", 2000.0), ("1 m behind", -1000.0)):
        for seed in range(3):
            x0 = truth.copy()
            x0[:3] += shift * axis
            tracker = Tracker(rig, hand, NoMotion(), np.random.default_rng(seed))
            tracker.reset(x0)
            frame = tracker.prepare(masks)
            rng = np.random.default_rng(100 + seed)
            at_truth = max(
                tracker.cost.evaluate(truth, frame, tracker.cost.draw(frame, rng)).cost
                for _ in range(10)
            )
            rows = []
            for _ in range(6):
                r = tracker.step(masks)
                e = np.linalg.norm(hand.joints(r.pose) - hand.joints(truth), axis=1).mean()
                rows.append(f"{r.cost:.3g}/{e:.0f}mm/IoU {r.mean_iou:.2f}/{'L' if r.lost else '-'}")
            print(f"  start {name}, seed {seed}: truth cost ≤ {at_truth:.2g}; per frame "
                  f"cost/error/IoU/lost: " + ", ".join(rows))  # fmt: skip


def degenerate() -> None:
    hand, rig = HandModel(), Rig.default()
    truth = benchmark(0)[90]
    masks = silhouettes(hand, truth, rig)
    blob = np.zeros_like(masks)
    blob[:, 239:242, 319:322] = True
    for name, m in (("all-white masks", np.ones_like(masks)), ("3x3 blob", blob)):
        tracker = Tracker(rig, hand, NoMotion(), np.random.default_rng(0))
        tracker.reset(truth)
        r = tracker.step(m)
        e = np.linalg.norm(hand.joints(r.pose) - hand.joints(truth), axis=1).mean()
        print(f"  {name}: IoU {r.mean_iou:.3f}, cost {r.cost:.3g}, error {e:.0f} mm, "
              f"lost {r.lost}")  # fmt: skip


def video(n: int) -> None:
    from handvar.tracking.init import initial_pose
    from handvar.vision.keypoints import read_keypoints
    from handvar.vision.sources import open_source
    from handvar.vision.wrist import cut_wrist

    scale = 0.5
    hand = HandModel()
    source = open_source(example_path("video"), scale=scale)
    kp = read_keypoints(example_path("video-keypoints")).scaled(scale, (1280, 720))
    tracker = Tracker(source.rig, hand, RVAR(), np.random.default_rng(0))
    rows = []
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        for t, _, masks in source.silhouettes(0, n, wrist=False):
            k = kp.frame(t)
            cut = np.stack([cut_wrist(m, k if k[0, 2] > 0 else None) for m in masks])
            if t == 0:
                init = initial_pose(cut, source.rig, hand, keypoints=[k],
                                    rng=np.random.default_rng(0))  # fmt: skip
                tracker.reset(init.pose)
            r = tracker.step(cut, keypoints=[k])
            rows.append((r.mean_iou, r.cost, r.keypoint_error, r.lost))
    a = np.array(rows, dtype=float)
    print(f"  example video, monocular, scale {scale}, {len(a)} frames, keypoints: "
          f"{int(a[:, 3].sum())} lost")  # fmt: skip
    pct("mean IoU", a[:, 0])
    pct("cost", a[:, 1])
    pct("keypoint error", a[:, 2])
    rates(a[:, 0], a[:, 2])


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--frames", type=int, default=175)
    ap.add_argument("--video", action="store_true")
    ap.add_argument("--video-frames", type=int, default=621)
    args = ap.parse_args()
    print("percentiles " + " ".join(f"{p}%" for p in Q))
    synthetic(args.frames)
    bad_starts()
    degenerate()
    if args.video:
        video(args.video_frames)


if __name__ == "__main__":
    main()
