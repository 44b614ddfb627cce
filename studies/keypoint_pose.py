"""A frame's pose from its keypoints alone, against the truth of the realistic benchmark.

`handvar.tracking.frame_fit.reinitialise` (the palm's perspective-n-point poses, then
the keypoint-first fit from each with the fingers in a few named postures) gives the
first pose of `handvar init` and `handvar track` and the tracker's re-initialisations.
On every 3rd frame of every case of a `studies/realistic.py --out DIR` directory, each
frame on its own (no prediction, no shape fit: the given 185 mm hand), this prints per
rig and per set of starting postures the wrist-relative 3D error of the 21 joints
(mean, and the frames beyond 30 mm), the absolute 3D error (median: one camera's depth
rests on the hand's assumed size), the palm's orientation error (mean, and the frames
beyond 30°) and the time per frame.

Run: ``PYTHONPATH=src python studies/keypoint_pose.py --cases DIR [--detector mediapipe]``
with DIR a ``--out`` directory of `studies/realistic.py` run with the same ``--detector``.
"""

from __future__ import annotations

import argparse
import time
from pathlib import Path

import numpy as np

from handvar.evaluation.realistic import read_case
from handvar.hand import HandModel
from handvar.hand.anthropometry import HandShape
from handvar.hand.kinematics import world_from_hand_rotation
from handvar.tracking.frame_fit import reinitialise
from handvar.tracking.init import INIT_SETTINGS

#: The starting postures compared: the tracker's, and `handvar init`'s.
POSTURES = {
    "open (the tracker)": ("open",),
    "open, fist, point (handvar init)": INIT_SETTINGS.keypoint_shapes,
}


def turn(a, b) -> float:
    """Angle between the palm orientations of poses `a` and `b`, degrees."""
    Ra, Rb = world_from_hand_rotation(a[3:6])[0], world_from_hand_rotation(b[3:6])[0]
    return float(np.degrees(np.arccos(np.clip((np.trace(Ra.T @ Rb) - 1) / 2, -1, 1))))


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--cases", type=Path, required=True)
    parser.add_argument("--detector", choices=("mediapipe", "simulated"), default="simulated")
    parser.add_argument("--step", type=int, default=3, help="every STEP-th frame")
    args = parser.parse_args()
    prefix = "mediapipe" if args.detector == "mediapipe" else "keypoints"
    rows: dict[tuple[int, str], list] = {}
    for case_dir in sorted(p for p in args.cases.iterdir() if (p / "truth.npz").exists()):
        case = read_case(case_dir)
        shape = HandShape.from_size(185.0)
        hand = HandModel(shape if case.side == "right" else shape.mirrored())
        files = [np.load(case_dir / f"{prefix}{j}.npy") for j in range(len(case.rig))]
        for t in range(0, len(case.poses), args.step):
            kps = [np.column_stack([k[t], np.isfinite(k[t]).all(axis=1)]) for k in files]
            kps = [np.nan_to_num(k) for k in kps]
            for name, shapes in POSTURES.items():
                start = time.perf_counter()
                fit = reinitialise(kps, case.rig, hand, shapes=shapes)
                seconds = time.perf_counter() - start
                if fit is None:
                    continue
                G, J = hand.joints(fit.pose), case.joints[t]
                relative = np.linalg.norm((G - G[0]) - (J - J[0]), axis=1).mean()
                absolute = np.linalg.norm(G - J, axis=1).mean()
                row = (relative, absolute, turn(fit.pose, case.poses[t]), seconds)
                rows.setdefault((len(case.rig), name), []).append(row)
    print("| rig | starting postures | frames | wrist-relative 3D, mm | > 30 mm | absolute 3D "
          "(median), mm | orientation, ° | > 30° | ms/frame |")  # fmt: skip
    print("|---|---|---:|---:|---:|---:|---:|---:|---:|")
    for (cams, name), r in sorted(rows.items()):
        a = np.asarray(r)
        print(f"| {'mono' if cams == 1 else 'stereo'} | {name} | {len(a)} | {a[:, 0].mean():.1f} | "
              f"{(a[:, 0] > 30).sum()} | {np.median(a[:, 1]):.1f} | {a[:, 2].mean():.1f} | "
              f"{(a[:, 2] > 30).sum()} | {1000 * a[:, 3].mean():.0f} |")  # fmt: skip


if __name__ == "__main__":
    main()
