"""How far back a run's first detection is carried: the frames before a late detection.

Usage: PYTHONPATH=src python studies/carry_back.py [--seeds N] [--cache DIR]
       [--lead-points none,0,2,6,11]

Carried both ways (`handvar.vision.carry.TwoWayCarrier`, a recording's default), the
first detection of a run (the recording's first, or the first after more than
`CarrySettings.max_frames` frames without one) is carried back to the frames before
it while the optical flow still follows at least `CarrySettings.lead_points` of its
points: a hand the detector finds late was there and the flow follows it back; a hand
that came into view, or a cut, the flow loses.  This study tries that rule where
hands do come into view and leave: the two-hand benchmark's cases
(`handvar.evaluation.two_hands`, one camera, 640×360) with MediaPipe Hands run on the
rendered frames (every frame; ``--cache DIR`` as for `studies/two_hands.py`), each true
hand's detections on its own as a one-hand track would get them (in each frame the
detection nearest that hand, within 0.5 of its size: `two_hands.nearest`), carried
both ways with each setting.  Per setting (``none``: only to the frames a detector on
every K-th frame skipped, the rule before), over the frames that get points the
setting ``none`` leaves without:

- frames added, and of them the frames where the hand is not in view (points drawn on
  no hand);
- PCK@0.2 of the added points against the truth (true wrist → middle-MCP length),
  where the hand is in view, beside what a user has without the flow: the run's first
  detection held back to those frames (as interpolating the detections does before
  the first one, `handvar.evaluation.metrics.thinned`);
- frames whose added points lie more than 0.5 hand sizes off the hand on average.
"""

from __future__ import annotations

import argparse
import dataclasses
import sys
from pathlib import Path

import cv2
import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))


def carried_back(case, detections, k: int, settings) -> tuple[np.ndarray, np.ndarray]:
    """(T, 21, 2) true hand k's nearest detections carried both ways with `settings`,
    and those detections (NaN where none)."""
    from handvar.vision.carry import carry_keypoints
    from handvar.vision.keypoints import Keypoints2D
    from two_hands import nearest

    given = np.full((case.n_frames, 21, 3), np.nan)
    for t, d in enumerate(nearest(case, detections, 0, k)):
        if d is not None:
            given[t, :, :2] = d.points[:, :2]
            given[t, :, 2] = 1.0
    grey = [cv2.cvtColor(f, cv2.COLOR_RGB2GRAY) for f in case.frames[0]]
    carried = carry_keypoints(grey, Keypoints2D.from_array(given), settings, both=True).xy
    return carried, given[..., :2]


def main() -> None:
    from handvar.evaluation.two_hands import SCENARIOS, two_hand_case
    from handvar.synth.keypoints import hand_size_px
    from handvar.vision.carry import CARRY_SETTINGS
    from two_hands import mediapipe_detections

    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seeds", type=int, default=2)
    parser.add_argument("--cache", default=None, help="a folder keeping MediaPipe's detections")
    parser.add_argument("--lead-points", default="none,0,2,6,11")
    args = parser.parse_args()
    leads = [None if v == "none" else int(v) for v in args.lead_points.split(",")]
    # added, no hand, kept, scored, off, kept held
    totals = {lead: np.zeros(6) for lead in leads}
    for scenario in SCENARIOS:
        for seed in range(args.seeds):
            case = two_hand_case(scenario, cameras=1, seed=seed, size=(640, 360))
            detections = mediapipe_detections(case, args.cache)
            for k in range(2):
                size = hand_size_px(case.rig.cameras[0], case.joints[k])
                before = None
                for lead in leads:
                    settings = dataclasses.replace(CARRY_SETTINGS, lead_points=lead)
                    xy, found = carried_back(case, detections, k, settings)
                    detected = np.flatnonzero(np.isfinite(found).any(axis=(1, 2)))
                    has = np.isfinite(xy).any(axis=(1, 2))
                    if before is None:  # the rule before, or the first setting asked
                        before = has if lead is None else np.zeros_like(has)
                    for t in np.flatnonzero(has & ~before):
                        row = totals[lead]
                        row[0] += 1
                        if not case.in_view[0, k, t]:
                            row[1] += 1
                            continue
                        d = np.linalg.norm(xy[t] - case.truth_2d[0, k, t], axis=1) / size[t]
                        row[2] += np.sum(d <= 0.2)
                        row[3] += 21
                        held = found[detected[detected > t][0]]  # the next detection
                        row[5] += np.sum(np.linalg.norm(held - case.truth_2d[0, k, t], axis=1)
                                         <= 0.2 * size[t])  # fmt: skip
                        row[4] += np.nanmean(d) > 0.5
            print(f"{case.name}: done", flush=True)
    print("| lead_points | frames added | of them without the hand | PCK@0.2 of the added, "
          "hand in view | the first detection held there | added > 0.5 hand sizes off "
          "|")  # fmt: skip
    print("|---|---:|---:|---:|---:|---:|")
    for lead, (added, gone, kept, scored, off, held) in totals.items():
        pck = f"{kept / scored:.3f}" if scored else "–"
        hold = f"{held / scored:.3f}" if scored else "–"
        print(f"| {'none' if lead is None else lead} | {added:.0f} | {gone:.0f} | {pck} | "
              f"{hold} | {off:.0f} |")  # fmt: skip


if __name__ == "__main__":
    main()
