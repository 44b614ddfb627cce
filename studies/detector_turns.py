"""MediaPipe in turn: one detector on every frame against two on every other frame.

`handvar.vision.detector` runs MediaPipe Hands in `DETECTOR_PROCESSES` processes that
take the frames in turn, each tracking its hand (video mode) over every other frame.
Does that cost accuracy?  On the realistic benchmark's rendered recordings (the cases
`studies/realistic.py --out DIR` writes: JPEG frames and the true 2D points), each
camera's frames are given to one `MediaPipeHands` in order and to two in turn; both are
scored against the truth: 2D PCK@0.2 (of the true wrist → middle-MCP length), the mean
2D error in pixels over the frames both found a hand on, and the frames without a hand.

    PYTHONPATH=src python studies/detector_turns.py --cases DIR
"""

from __future__ import annotations

import argparse
from pathlib import Path

import cv2
import numpy as np

from handvar.evaluation.metrics import mean_point_error, pck_2d
from handvar.vision.keypoints import choose
from handvar.vision.mediapipe import MediaPipeHands


def detect(frames: list[np.ndarray], side: str, turns: int) -> np.ndarray:
    """(T, 21, 2) MediaPipe's points of the hand of `side`, `turns` detectors in turn."""
    detectors = [MediaPipeHands() for _ in range(turns)]
    out = np.full((len(frames), 21, 2), np.nan)
    for t, image in enumerate(frames):
        points, _ = choose(detectors[t % turns](image), side)
        if points is not None:
            out[t] = points[:, :2]
    for d in detectors:
        d.close()
    return out


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--cases", required=True, help="the folder of studies/realistic.py --out")
    args = parser.parse_args()
    rows = []
    for case in sorted(p for p in Path(args.cases).iterdir() if (p / "truth.npz").is_file()):
        with np.load(case / "truth.npz") as z:
            truth, side = z["truth_2d"], str(z["side"])
        for j, cam_truth in enumerate(truth):
            files = sorted((case / f"cam{j}").iterdir())
            frames = [cv2.imread(str(f), cv2.IMREAD_COLOR) for f in files]
            one, two = detect(frames, side, 1), detect(frames, side, 2)
            both = np.isfinite(one).all(axis=(1, 2)) & np.isfinite(two).all(axis=(1, 2))
            rows.append((
                f"{case.name} cam{j}", pck_2d(cam_truth, one), pck_2d(cam_truth, two),
                mean_point_error(cam_truth[both], one[both])[0],
                mean_point_error(cam_truth[both], two[both])[0],
                int((~np.isfinite(one).all(axis=(1, 2))).sum()),
                int((~np.isfinite(two).all(axis=(1, 2))).sum()),
            ))  # fmt: skip
    print(f"{'case':<34} {'PCK one':>8} {'PCK two':>8} {'px one':>7} {'px two':>7} "
          f"{'none one':>8} {'none two':>8}")  # fmt: skip
    for name, *v in rows:
        print(f"{name:<34} {v[0]:>8.3f} {v[1]:>8.3f} {v[2]:>7.2f} {v[3]:>7.2f} {v[4]:>8d} "
              f"{v[5]:>8d}")  # fmt: skip
    a = np.array([r[1:] for r in rows], dtype=float)
    print(f"{'mean over cameras':<34} {a[:, 0].mean():>8.3f} {a[:, 1].mean():>8.3f} "
          f"{a[:, 2].mean():>7.2f} {a[:, 3].mean():>7.2f} {int(a[:, 4].sum()):>8d} "
          f"{int(a[:, 5].sum()):>8d}")  # fmt: skip


if __name__ == "__main__":
    main()
