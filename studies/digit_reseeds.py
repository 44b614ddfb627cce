"""Digit re-seeding against ground truth: a digit started in the wrong posture (design §14.3).

For an open and a spread hand seen by the default stereo rig and by its first camera
alone, each digit in turn starts the fit in another named shape's posture (fist, thumb
across, pinch) while the silhouettes are the true pose's.  The frame is fitted by
`track_with_recovery` (no motion, seed 0) without re-seeding (``reseed_digits=0``) and
with it (4 starts); `refine_iou` is raised to 0.97 so that every case is judged poor and
re-seeding runs, whatever its IoU.  Printed per case: the distance of that digit's tip
to the truth, mm, and the silhouette IoU, without and with; then how many cases got
farther from the truth with re-seeding, and the time of `digit_reseeds` (the starts
rendered and scored) per call.

Run: ``PYTHONPATH=src .venv/bin/python studies/digit_reseeds.py``
"""

from __future__ import annotations

import time

import numpy as np

from handvar.camera import Rig
from handvar.hand import HandModel, named_pose
from handvar.params import DIGITS, digit_angles
from handvar.predictors import NoMotion
from handvar.render import silhouettes
from handvar.tracking.recovery import RecoverySettings, digit_reseeds, track_with_recovery
from handvar.tracking.tracker import Tracker

TIPS = (4, 8, 12, 16, 20)


def main() -> None:
    hand = HandModel()
    rigs = {"stereo": Rig.default(), "one camera": Rig([Rig.default()[0]])}
    worse = {name: [0, 0] for name in rigs}
    seconds = []
    print("rig, hand, digit, start: tip off (mm) and IoU without -> with re-seeding")
    for rig_name, rig in rigs.items():
        for shape in ("open", "spread"):
            truth = named_pose(shape)
            masks = silhouettes(hand, truth, rig)
            for d in range(len(DIGITS)):
                for wrong in ("fist", "thumb_across", "pinch"):
                    x0 = truth.copy()
                    x0[digit_angles(d)] = named_pose(wrong)[digit_angles(d)]
                    if np.allclose(x0, truth):
                        continue
                    t0 = time.perf_counter()
                    digit_reseeds(x0, hand, rig, masks, 4)
                    seconds.append(time.perf_counter() - t0)
                    out = []
                    for n in (0, 4):
                        tracker = Tracker(rig, hand, NoMotion(), np.random.default_rng(0))
                        settings = RecoverySettings(reseed_digits=n, refine_iou=0.97)
                        r = track_with_recovery(tracker, [masks], x0, settings=settings)
                        off = np.linalg.norm(
                            r.track.joints[0, TIPS[d]] - hand.joints(truth)[TIPS[d]]
                        )
                        out.append((off, r.quality.iou[0]))
                    worse[rig_name][0] += out[1][0] > out[0][0] + 1.0
                    worse[rig_name][1] += 1
                    print(
                        f"  {rig_name:10} {shape:6} {DIGITS[d]:6} from {wrong:12}: "
                        f"{out[0][0]:6.1f} mm, IoU {out[0][1]:.3f} -> {out[1][0]:6.1f} mm, "
                        f"IoU {out[1][1]:.3f}"
                    )
    for name, (n_worse, n) in worse.items():
        print(
            f"{name}: {n_worse} of {n} cases more than 1 mm farther from the truth with re-seeding"
        )
    print(
        f"digit_reseeds: {1e3 * np.median(seconds):.1f} ms per call (median; "
        f"{rigs['stereo'][0].width}x{rigs['stereo'][0].height} px per camera)"
    )


if __name__ == "__main__":
    main()
