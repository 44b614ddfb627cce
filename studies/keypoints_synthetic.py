"""Tracking the benchmark sequence with synthetic keypoints against silhouettes alone.

Keypoints are the projected true joints with 3 px noise and 10 % outliers (displaced
uniformly within ±1 hand size; `handvar.synth.synthetic_keypoints`), a fresh draw per
trial. For a monocular rig (the first camera) and the stereo rig, with and without the
keypoints, over `--trials` seeds, it prints the mean joint error over all frames and
trials, the maximum thumb-tip error over frames 160–175 per trial (the thumb's return,
which silhouettes lose), the frames flagged lost, the mean IoU and mean iterations.

The tracker refines every frame with keypoints after SMD (`handvar.tracking.refine`,
design §14.2); ``--refine steps=0`` tracks without the refinement, ``--refine
FIELD=VALUE,...`` sets other `RefineSettings` fields; ``--weight``, ``--huber``,
``--loss`` and ``--stop`` set SMD's keypoint term and stopping test.

    python studies/keypoints_synthetic.py [--trials 10] [--predictor rvar] [--rigs mono,stereo]
                                             [--frames T] [--refine steps=0]
"""

from __future__ import annotations

import argparse
import dataclasses
import time

import numpy as np

from handvar.camera import Rig
from handvar.hand import HandModel
from handvar.predictors.catalogue import make_predictor
from handvar.synth import make_sequence, synthetic_keypoints
from handvar.tracking import Tracker, TrackerSettings
from handvar.tracking.refine import RefineSettings

THUMB_TIP = 4
THUMB_FRAMES = slice(160, 176)


def mono(seq):
    """The sequence seen by its first camera only."""
    return dataclasses.replace(seq, rig=Rig([seq.rig.cameras[0]], [seq.rig.names[0]]),
                               masks=np.asarray(seq.masks)[:, :1])  # fmt: skip


def run(seq, hand, predictor, seed, keypoints, settings):
    tracker = Tracker(seq.rig, hand, make_predictor(predictor), np.random.default_rng(seed),
                      settings)  # fmt: skip
    t0 = time.perf_counter()
    res = tracker.track(seq, seq.truth.poses[0], keypoints=keypoints)
    wall = time.perf_counter() - t0
    err = np.linalg.norm(res.joints - seq.truth.joints, axis=2)  # (T, 21)
    thumb = err[THUMB_FRAMES, THUMB_TIP].max() if err.shape[0] > 160 else np.nan
    return err.mean(), thumb, res, wall


def scales(seq, hand, settings) -> None:
    """The sizes of the terms at frame 90 with every parameter 1 mm or 1° off."""
    from handvar.tracking import SilhouetteCost
    from handvar.tracking.keypoint_cost import hand_length

    cost = SilhouetteCost(hand, seq.rig, settings.cost)
    x = seq.truth.poses[90] + 1.0
    frame = cost.prepare(seq.masks[90])
    kp = synthetic_keypoints(seq, 0.0, 0.0)[90]
    rng = np.random.default_rng(0)
    terms = [cost.evaluate(x, frame, cost.draw(frame, rng), keypoints=kp) for _ in range(10)]
    sil = np.mean([t.cost - settings.cost.weight_keypoints * t.keypoints for t in terms])
    L = hand_length(hand)
    z = seq.rig.cameras[0].camera_from_world(seq.truth.joints[90, [0, 9]].mean(axis=0)[None])
    size = seq.rig.cameras[0].fx * L / z[0, 2]
    print(f"frame 90, every parameter 1 mm or 1 deg off: 1.7 C_s + 0.4 C_f = {sil:.3g}, "
          f"C_k = {terms[0].keypoints:.3g} (clean keypoints); L = {L:.1f} mm, hand size "
          f"{size:.0f} px in the first camera")  # fmt: skip


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--trials", type=int, default=10)
    ap.add_argument("--predictor", default="rvar")
    ap.add_argument("--frames", type=int, default=None)
    ap.add_argument("--rigs", default="mono,stereo")
    ap.add_argument("--weight", type=float, default=None, help="w_k (default: CostSettings)")
    ap.add_argument("--huber", type=float, default=None, help="δ (default: CostSettings)")
    ap.add_argument("--loss", default=None, help="C_k's loss, huber or tukey (CostSettings)")
    ap.add_argument(
        "--refine",
        default=None,
        help="RefineSettings fields, e.g. steps=0 or samples=2,weight_keypoints=5",
    )
    ap.add_argument("--stop", type=float, default=None, help="keypoint_stop (SMDSettings)")
    ap.add_argument("--modes", default="silhouettes,keypoints")
    ap.add_argument("--noise", type=float, default=3.0, help="keypoint noise, px")
    ap.add_argument("--outliers", type=float, default=0.1, help="fraction of outliers")
    args = ap.parse_args()

    stereo = make_sequence("benchmark", n_frames=args.frames)
    hand = HandModel()
    settings = TrackerSettings()
    cost = settings.cost
    if args.weight is not None:
        cost = dataclasses.replace(cost, weight_keypoints=args.weight)
    if args.huber is not None:
        cost = dataclasses.replace(cost, keypoint_huber=args.huber)
    if args.loss is not None:
        cost = dataclasses.replace(cost, keypoint_loss=args.loss)
    settings = dataclasses.replace(settings, cost=cost)
    if args.refine:
        fields = {f.name: f.type for f in dataclasses.fields(RefineSettings)}
        values = {}
        for item in args.refine.split(","):
            key, value = item.split("=")
            kind = {"int": int, "float": float, "bool": lambda v: v == "True"}.get(fields[key], str)
            values[key] = kind(value)
        settings = dataclasses.replace(
            settings, refine=dataclasses.replace(settings.refine, **values)
        )
    if args.stop is not None:
        settings = dataclasses.replace(
            settings, smd=dataclasses.replace(settings.smd, keypoint_stop=args.stop)
        )
    print(f"benchmark sequence, {stereo.n_frames} frames, predictor {args.predictor}, "
          f"{args.trials} trials, w_k {settings.cost.weight_keypoints}, "
          f"loss {settings.cost.keypoint_loss}, δ {settings.cost.keypoint_huber}, "
          f"keypoint_stop {settings.smd.keypoint_stop}, refine {settings.refine.steps} steps "
          f"x{settings.refine.samples} samples")  # fmt: skip
    scales(stereo, hand, settings)
    for rig_name in args.rigs.split(","):
        seq = stereo if rig_name == "stereo" else mono(stereo)
        for with_kp in [m == "keypoints" for m in args.modes.split(",")]:
            errs, thumbs, lost, ious, its, walls = [], [], [], [], [], []
            for trial in range(args.trials):
                kp = None
                if with_kp:
                    kp = synthetic_keypoints(
                        seq, args.noise, args.outliers, np.random.default_rng(1000 + trial)
                    )
                e, th, res, wall = run(seq, hand, args.predictor, trial, kp, settings)
                errs.append(e)
                thumbs.append(th)
                lost.append(int(res.lost.sum()))
                ious.append(np.nanmean(res.mean_iou))
                its.append(res.iterations.mean())
                walls.append(wall / res.poses.shape[0] * 1e3)
            label = f"{rig_name:6s} {'keypoints' if with_kp else 'silhouettes':11s}"
            print(f"{label} mean joint error {np.mean(errs):6.2f} mm "
                  f"(trials {' '.join(f'{v:.2f}' for v in errs)})")  # fmt: skip
            print(f"{label} max thumb-tip error, frames 160-175, per trial (mm): "
                  + " ".join(f"{v:.1f}" for v in thumbs))  # fmt: skip
            print(f"{label} frames lost per trial {lost}; mean IoU {np.mean(ious):.3f}; "
                  f"iterations/frame {np.mean(its):.1f}; "
                  f"ms/frame {np.median(walls):.1f}")  # fmt: skip


if __name__ == "__main__":
    main()
