"""The tracker against a frame-by-frame keypoint fit, on the realistic benchmark's mono
cases.

The baseline is the simplest model-based fit on top of a detector: on every frame with
all 21 keypoints, `fit_frame` (the same robust 2D residuals, exact Jacobians and joint
limits as the tracker) from the previous frame's pose, with a weak temporal prior
towards it (σ = 50 mm, 30°, 30°, `PriorScale`'s start), the first frame from
`reinitialise`; the given hand (185 mm, the tracker's default), no shape fit, no
predictor, no rules.  The tracker's row is `handvar track` with keypoints on every frame,
read from the fits `studies/realistic.py --out DIR` left in ``DIR/fits``.  Both are
scored by `realistic.scores` on the frames where the detector gave all 21 points, so
that the rows compare the same frames; "px to keypoints" is the mean distance of the
projected joints to the detector's points (how well each explains them), "ms/frame" the
baseline's fitting time alone.

Run: ``PYTHONPATH=src python studies/frame_by_frame.py --cases DIR [--detector simulated]``
with DIR a ``--out`` directory of `studies/realistic.py` run with the same ``--detector``.
"""

from __future__ import annotations

import argparse
import dataclasses
import sys
import time
from pathlib import Path

import numpy as np

from handvar.evaluation.realistic import read_case
from handvar.hand import HandModel
from handvar.hand.anthropometry import HandShape
from handvar.tracking.frame_fit import fit_frame, reinitialise
from handvar.tracking.keypoint_cost import keypoint_points

sys.path.insert(0, str(Path(__file__).parent))
from realistic import fit_points, project, scores

COLUMNS = (("pck", "PCK@0.2", "{:.3f}"), ("px", "2D px", "{:.1f}"),
           ("to_kp", "px to keypoints", "{:.1f}"), ("mpjpe", "MPJPE", "{:.1f}"),
           ("pa", "PA-MPJPE", "{:.1f}"), ("auc", "AUC 20-50", "{:.3f}"),
           ("abs", "abs 3D", "{:.1f}"), ("ms", "ms/frame", "{:.1f}"))  # fmt: skip


def frame_by_frame(keypoints: np.ndarray, rig, hand) -> np.ndarray:
    """(T, 21, 3) joints of the baseline (module notes) on (T, 21, 2) pixel keypoints;
    NaN on frames without all 21 points."""
    out = np.full((len(keypoints), 21, 3), np.nan)
    x = None
    for t, k in enumerate(keypoints):
        if not np.isfinite(k).all():
            continue
        kp = [np.column_stack([k, np.ones(21)])]
        fit = reinitialise(kp, rig, hand) if x is None else fit_frame(kp, rig, hand, x, prior=x)
        if fit is not None:
            x = fit.pose
            out[t] = keypoint_points(hand, x, "pad")
    return out


def subset(case, frames: np.ndarray):
    """`case` on the frames of the (T,) bool mask `frames` only."""
    return dataclasses.replace(
        case, poses=case.poses[frames], joints=case.joints[frames],
        truth_2d=case.truth_2d[:, frames], keypoints=case.keypoints[:, frames],
        gross=case.gross[:, frames], missed=case.missed[:, frames],
        blurred=case.blurred[frames],
    )  # fmt: skip


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--cases", type=Path, required=True)
    parser.add_argument("--detector", choices=("mediapipe", "simulated"), default="mediapipe")
    args = parser.parse_args()
    name = "mediapipe0.npy" if args.detector == "mediapipe" else "keypoints0.npy"
    rows = []
    for case_dir in sorted(p for p in args.cases.iterdir() if "-mono-" in p.name):
        case = read_case(case_dir)
        keypoints = np.load(case_dir / name)
        complete = np.isfinite(keypoints).all(axis=(1, 2))
        fits = args.cases / "fits" / f"{case_dir.name}-{args.detector}-every1"
        shape = HandShape.from_size(185.0)
        shape = shape if case.side == "right" else shape.mirrored()
        start = time.perf_counter()
        points = frame_by_frame(keypoints, case.rig, HandModel(shape))
        seconds = time.perf_counter() - start
        tracked, _ = fit_points(fits, case.side)
        same = subset(case, complete)
        for run, p in (("frame by frame", points), ("tracker, every 1", tracked)):
            p = p[complete]
            pixels = project(case.rig, p)
            row = scores(same, pixels, p, None, seconds if run[0] == "f" else None)
            row["to_kp"] = float(
                np.nanmean(np.linalg.norm(pixels[0] - keypoints[complete], axis=-1))
            )
            rows.append((f"{case_dir.name} ({complete.sum()} fr)", run, row))
    for run in ("frame by frame", "tracker, every 1"):
        sel = [r for _, k, r in rows if k == run]
        w = np.array([r["frames"] for r in sel], dtype=float)
        mean = {key: float(np.average([r[key] for r in sel], weights=w)) for key, _, _ in COLUMNS}
        rows.append((f"**mono** ({len(sel)} cases, {int(w.sum())} fr)", run, mean))
    print("| case | run | " + " | ".join(c[1] for c in COLUMNS) + " |")
    print("|---|---|" + "---:|" * len(COLUMNS))
    for case, run, r in rows:
        cells = " | ".join("–" if not np.isfinite(r[k]) else f.format(r[k]) for k, _, f in COLUMNS)
        print(f"| {case} | {run} | {cells} |")


if __name__ == "__main__":
    main()
