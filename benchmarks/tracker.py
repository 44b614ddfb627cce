"""Frames per second of the tracker on the benchmark sequence with the paper's settings.

Prints the median wall time per frame split into preprocessing (distance fields and the
fit-quality check), optimisation (SMD iterations) and prediction, the mean iterations per
frame, the mean joint error, and with ``--profile`` the top functions of a cProfile run.

With ``--keypoints`` it tracks the same frames again with synthetic keypoints (3 px
noise, 10 % outliers, `handvar.synth.synthetic_keypoints`) and prints the same figures
and the ratios of the times with keypoints to those without, per SMD iteration and per
frame. Frames with keypoints are refined after SMD (`handvar.tracking.refine`); its time
counts as optimisation, so the time "per iteration" with keypoints includes it. The two
runs alternate ``--repeats`` times and the medians are compared, since the machine may
be shared.

With ``--model mesh`` the tracker fits the skinned mesh hand (design §15) to the same
sphere-mesh-rendered frames (model mismatch; the mesh's costs are not compiled, so this
is the slow path).

    python benchmarks/tracker.py [--frames 175] [--predictor rvar] [--model spheres|mesh]
                                 [--profile] [--keypoints]
"""

from __future__ import annotations

import argparse
import cProfile
import pstats
import time

import numpy as np

from handvar.evaluation.metrics import mean_joint_error
from handvar.hand import HandModel
from handvar.predictors.catalogue import make_predictor
from handvar.synth import synthetic_keypoints
from handvar.synth.sequences import make_sequence
from handvar.tracking import Tracker
from handvar.tracking.tracker import TIMING_PARTS


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--frames", type=int, default=175)
    ap.add_argument("--predictor", default="rvar")
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--profile", action="store_true")
    ap.add_argument("--keypoints", action="store_true")
    ap.add_argument("--repeats", type=int, default=3)
    ap.add_argument("--model", choices=("spheres", "mesh"), default="spheres")
    args = ap.parse_args()
    if args.keypoints:
        compare_keypoints(args)
        return

    seq = make_sequence("benchmark", n_frames=args.frames)
    hand = HandModel(surface=args.model)
    # warm-up: compile the kernels, build the surface pool
    Tracker(seq.rig, hand, make_predictor("none")).track(seq, seq.truth.poses[0], frames=3)

    tracker = Tracker(seq.rig, hand, make_predictor(args.predictor),
                      np.random.default_rng(args.seed))  # fmt: skip
    t0 = time.perf_counter()
    if args.profile:
        prof = cProfile.Profile()
        prof.enable()
    result = tracker.track(seq, seq.truth.poses[0])
    if args.profile:
        prof.disable()
    wall = time.perf_counter() - t0
    T = result.poses.shape[0]
    med = np.median(result.seconds, axis=0) * 1e3
    per_frame = np.median(result.seconds.sum(axis=1)) * 1e3
    per_iter = np.median(result.seconds[:, 1] / result.iterations) * 1e6
    err = mean_joint_error(seq.truth.joints, result.joints)
    print(f"benchmark sequence, {T} frames, predictor {args.predictor}, seed {args.seed}, "
          f"tracked with the {args.model} model")  # fmt: skip
    print(f"  frames/s (wall, whole run)       {T / wall:8.1f}")
    print(f"  median ms/frame                  {per_frame:8.2f}")
    for name, ms in zip(TIMING_PARTS, med, strict=True):
        print(f"    {name:<30s} {ms:8.3f}")
    print(f"  median µs per SMD iteration      {per_iter:8.1f}")
    print(f"  mean iterations/frame            {result.iterations.mean():8.1f}")
    print(f"  frames stopped below threshold   {np.mean(result.iterations < 50):8.2f}")
    print(f"  mean joint error, mm             {err.mean():8.2f}  (max {err.max():.2f})")
    if args.profile:
        pstats.Stats(prof).sort_stats("tottime").print_stats(15)


def compare_keypoints(args) -> None:
    """Silhouettes alone against silhouettes + keypoints, alternating runs."""
    seq = make_sequence("benchmark", n_frames=args.frames)
    hand = HandModel()
    kp = synthetic_keypoints(seq, 3.0, 0.1, np.random.default_rng(1000))
    Tracker(seq.rig, hand, make_predictor("none")).track(
        seq, seq.truth.poses[0], frames=3, keypoints=kp
    )  # warm-up
    runs: dict[str, list] = {"silhouettes": [], "keypoints": []}
    for _ in range(args.repeats):
        for label, k in (("silhouettes", None), ("keypoints", kp)):
            tracker = Tracker(seq.rig, hand, make_predictor(args.predictor),
                              np.random.default_rng(args.seed))  # fmt: skip
            runs[label].append(tracker.track(seq, seq.truth.poses[0], keypoints=k))
    print(f"benchmark sequence, {seq.n_frames} frames, predictor {args.predictor}, "
          f"seed {args.seed}, {args.repeats} alternating runs each")  # fmt: skip
    figures = {}
    for label, results in runs.items():
        r = results[0]
        # whole-run optimisation time over whole-run iterations (a per-frame median would
        # weigh the fixed cost of frames that stop after one or two iterations)
        opt_iter = np.median([x.seconds[:, 1].sum() / x.iterations.sum() for x in results])
        frame = np.median([np.median(x.seconds.sum(axis=1)) for x in results])
        opt_frame = np.median([np.median(x.seconds[:, 1]) for x in results])
        err = mean_joint_error(seq.truth.joints, r.joints)
        figures[label] = (opt_iter, frame, opt_frame)
        print(f"  {label:<12s} µs/iteration {opt_iter * 1e6:8.1f}  ms/frame {frame * 1e3:7.2f} "
              f"(optimisation {opt_frame * 1e3:6.2f})  iterations/frame "
              f"{r.iterations.mean():5.1f}  joint error {err.mean():5.2f} mm")  # fmt: skip
    # one cost evaluation (draw + evaluate, as in an SMD iteration) at frame 90
    tracker = Tracker(seq.rig, hand)
    frame = tracker.prepare(seq.masks[90])
    x, kp90, rng = seq.truth.poses[90] + 1.0, kp[90], np.random.default_rng(0)
    times: dict[str, list] = {"silhouettes": [], "keypoints": []}
    for _ in range(5):
        for label, k in (("silhouettes", None), ("keypoints", kp90)):
            t0 = time.perf_counter()
            for _ in range(200):
                tracker.cost.evaluate(x, frame, tracker.cost.draw(frame, rng), keypoints=k)
            times[label].append((time.perf_counter() - t0) / 200)
    ev = {label: np.median(v) for label, v in times.items()}
    print(f"  one cost evaluation at frame 90: {ev['silhouettes'] * 1e6:.1f} µs without, "
          f"{ev['keypoints'] * 1e6:.1f} µs with keypoints "
          f"({ev['keypoints'] / ev['silhouettes']:.2f}x)")  # fmt: skip
    a, b = figures["silhouettes"], figures["keypoints"]
    print(f"  keypoints / silhouettes: per iteration {b[0] / a[0]:.2f}x, per frame "
          f"{b[1] / a[1]:.2f}x, optimisation per frame {b[2] / a[2]:.2f}x")  # fmt: skip


if __name__ == "__main__":
    main()
