"""The time of the keypoint fit of one frame (`handvar.tracking.frame_fit.fit_frame`).

The fit the tracker runs on every frame with keypoints (docs/keypoint-fit.md, "the fit
of one frame"), timed on a hand in a few named poses before the paper's stereo pair
(`Rig.default`, 640 × 480) and before its first camera alone, its keypoints the exact
projections with 2 px of noise per coordinate, from a start 2 mm and 2° off in every
parameter.  With two cameras, a joint's views taken to err alike where they agree
(`FrameFitSettings.view_correlation`, the default 0.9) and taken as independent (0):
median ms per fit over the poses and repeats, and the mean joint error of the fit (mm).

    python benchmarks/frame_fit.py
"""

from __future__ import annotations

import dataclasses
import time

import numpy as np

from handvar.camera import Rig
from handvar.hand import HandModel, named_pose
from handvar.tracking.frame_fit import FRAME_FIT_DEFAULTS, fit_frame

POSES = ("open", "point", "fist", "pinch")
REPEATS = 20


def timed(rig, hand, settings) -> tuple[float, float]:
    """Median ms per fit and mean joint error (mm) over `POSES` × `REPEATS`."""
    rng = np.random.default_rng(0)
    seconds, errors = [], []
    for name in POSES:
        x = named_pose(name)
        truth = hand.joints(x)
        for _ in range(REPEATS):
            kps = [np.column_stack([cam.project(truth) + rng.normal(0.0, 2.0, (21, 2)),
                                    np.ones(21)]) for cam in rig]  # fmt: skip
            start = time.perf_counter()
            fit = fit_frame(kps, rig, hand, x + 2.0, settings=settings)
            seconds.append(time.perf_counter() - start)
            errors.append(np.linalg.norm(hand.joints(fit.pose) - truth, axis=1).mean())
    return 1e3 * float(np.median(seconds)), float(np.mean(errors))


def main() -> None:
    hand, stereo = HandModel(), Rig.default()
    mono = Rig([stereo.cameras[0]], [stereo.names[0]])
    independent = dataclasses.replace(FRAME_FIT_DEFAULTS, view_correlation=0.0)
    timed(stereo, hand, FRAME_FIT_DEFAULTS)  # kernels compiled or loaded first
    print("rig | a joint's views | ms per fit (median) | mean joint error (mm)")
    for label, rig, settings, views in (
        ("one camera", mono, FRAME_FIT_DEFAULTS, "–"),
        ("stereo pair", stereo, independent, "independent"),
        ("stereo pair", stereo, FRAME_FIT_DEFAULTS, "alike where they agree (default)"),
    ):
        ms, error = timed(rig, hand, settings)
        print(f"{label} | {views} | {ms:.2f} | {error:.2f}")


if __name__ == "__main__":
    main()
