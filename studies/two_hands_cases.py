"""The two-hand benchmark's cases: what each scenario gives a tracker, and a contact sheet.

Renders one case of each scenario of `handvar.evaluation.two_hands` (two hands of one
person, one camera, 640 × 360) into ``--out/<scenario>/`` (`TwoHandCase.write`) and prints
per scenario:

- frames, and the fraction of frames with both hands in view;
- the fraction of detections whose handedness label is the wrong side;
- the fraction of the frames with both hands in view on which the detector gives one
  hand only (a hand mostly hidden, a merge of overlapping hands, a miss);
- the mean fraction of a hand's points that the other hand leaves visible (over the
  frames where the hand is in view);
- the raw detections scored as a user of their labels would track them
  (`detections_as_tracks`, `score_two_hands`): identity switches, 2D PCK@0.2 and lost
  frames of each hand (left / right).

It writes ``--out/contact_sheet.png``: five frames of each scenario (a row each) with the
true points drawn (left hand blue, right hand red; a point hidden by the other hand as a
hollow circle) and the detections' labels.

Run: ``PYTHONPATH=src .venv/bin/python studies/two_hands_cases.py --out DIR [--seed S]``
(about a minute on two cores).
"""

from __future__ import annotations

import argparse
import time
from pathlib import Path

import cv2
import numpy as np

from handvar.evaluation.two_hands import (
    SCENARIOS,
    detections_as_tracks,
    score_two_hands,
    two_hand_case,
)
from handvar.render.overlay import SKELETON

COLOURS = ((60, 120, 255), (255, 70, 60))  # RGB: left hand blue, right hand red


def draw(case, t: int, scale: float = 0.5) -> np.ndarray:
    """Frame t of camera 0 with the true points, the visibility and the detections."""
    img = case.frames[0, t].copy()
    for k in range(2):
        uv = case.truth_2d[0, k, t]
        colour = COLOURS[k]
        for a, b in SKELETON:
            cv2.line(img, tuple(np.rint(uv[a]).astype(int)), tuple(np.rint(uv[b]).astype(int)),
                     colour, 1, cv2.LINE_AA)  # fmt: skip
        for i, p in enumerate(uv):
            fill = -1 if case.visible[0, k, t, i] else 1
            cv2.circle(img, tuple(np.rint(p).astype(int)), 3, colour, fill, cv2.LINE_AA)
    found = case.detections[0][t]
    text = f"t={t} " + " ".join(f"{d.side[0].upper()}{d.score:.2f}" for d in found)
    if case.merged[0, t]:
        text += " merged"
    img = cv2.resize(img, None, fx=scale, fy=scale, interpolation=cv2.INTER_AREA)
    cv2.putText(img, text, (4, 14), cv2.FONT_HERSHEY_SIMPLEX, 0.4, (255, 255, 255), 1,
                cv2.LINE_AA)  # fmt: skip
    return img


def figures(case) -> dict:
    view = case.in_view[0]
    both = view.all(0)
    det = case.detected[0]
    vis = case.visible[0].mean(-1)
    score = score_two_hands(case, detections_as_tracks(case))
    return {
        "frames": case.n_frames,
        "both in view": both.mean(),
        "wrong label": case.wrong_label[0][det].mean() if det.any() else np.nan,
        "one detection": (det.sum(0)[both] == 1).mean() if both.any() else np.nan,
        "visible points": vis[view].mean(),
        "switches": score.switches,
        "pck": score.pck,
        "lost": score.lost,
    }


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", type=Path, required=True)
    parser.add_argument("--seed", type=int, default=0)
    args = parser.parse_args()
    args.out.mkdir(parents=True, exist_ok=True)
    rows = []
    print(f"{'scenario':9s} {'frames':>6s} {'both':>5s} {'wrong':>6s} {'one det':>7s} "
          f"{'visible':>7s} {'switch':>6s} {'PCK L/R':>11s} {'lost L/R':>9s} "
          f"{'s':>5s}")  # fmt: skip
    for scenario in SCENARIOS:
        start = time.perf_counter()
        case = two_hand_case(scenario, seed=args.seed)
        seconds = time.perf_counter() - start
        case.write(args.out / scenario)
        f = figures(case)
        print(f"{scenario:9s} {f['frames']:6d} {f['both in view']:5.2f} {f['wrong label']:6.2f} "
              f"{f['one detection']:7.2f} {f['visible points']:7.2f} {f['switches']:6d} "
              f"{f['pck'][0]:5.2f}/{f['pck'][1]:4.2f} {f['lost'][0]:4d}/{f['lost'][1]:3d} "
              f"{seconds:5.1f}")  # fmt: skip
        T = case.n_frames
        picks = np.linspace(0.12, 0.9, 5) * (T - 1)
        if scenario in ("cross", "clap", "occlude"):  # the frame where the hands overlap most
            hidden = 1.0 - case.visible[0].mean(-1).min(0)
            picks[2] = int(np.argmax(hidden))
        tiles = [draw(case, int(t)) for t in picks]
        row = np.concatenate(tiles, axis=1)
        cv2.putText(row, scenario, (4, row.shape[0] - 8), cv2.FONT_HERSHEY_SIMPLEX, 0.6,
                    (255, 255, 0), 2, cv2.LINE_AA)  # fmt: skip
        rows.append(row)
    sheet = np.concatenate(rows, axis=0)
    path = args.out / "contact_sheet.png"
    cv2.imwrite(str(path), cv2.cvtColor(sheet, cv2.COLOR_RGB2BGR))
    print(f"contact sheet: {path}")


if __name__ == "__main__":
    main()
