"""MediaPipe on every K-th frame: one look at each frame, or two where the last one it saw
is far back.

Run: ``PYTHONPATH=src .venv/bin/python studies/detector_gaps.py [--every 10] [--realistic DIR]``.

MediaPipe Hands in video mode crops each frame around where the hand was in the last
frame it saw.  A detector on every K-th frame of a video (``--keypoint-every K``; two
MediaPipe processes detect in turn, so each sees every 2K-th frame) crops around the
hand as it was 2K frames before, and a fast hand has moved out of that crop.
`handvar.vision.mediapipe.MediaPipeHands` therefore looks twice at a frame more than
`STALE_FRAMES` frames after the last one it saw, the second time cropped around the
hands the first look found (module notes, "frames far apart").  This study runs one
MediaPipe on every `--every`-th frame (default 10, what each process sees with
``--keypoint-every 5``), once without the frames' indices (one look) and once with them
(two looks; with ``--always`` at every frame it sees, however near the last: what a
second look does to frames close together), and scores the hand found nearest the
reference on each of those frames:

- on the three real videos of ``examples/data``, against MediaPipe's own points on
  every frame (the shipped keypoint files; no truth there): PCK@0.2 of that reference's
  wrist → middle-MCP length, the median distance in those lengths, and the frames where
  no hand is found that the reference has;
- with ``--realistic DIR`` (cases made by ``studies/realistic.py --out DIR [--fast]``),
  on camera 0 of each case, against the truth.

The whole pipeline with the rule is measured by ``studies/realistic.py --detector
inside [--fast]`` (docs/results/realistic-benchmark.md).
"""

from __future__ import annotations

import argparse
from pathlib import Path

import cv2
import numpy as np

from handvar.data import example_path
from handvar.hand.anthropometry import MIDDLE_MCP, WRIST
from handvar.vision.frames import open_frames
from handvar.vision.keypoints import read_keypoints
from handvar.vision.mediapipe import STALE_FRAMES, MediaPipeHands

VIDEOS = ("video", "fingerspelling", "counting")


def looks(frames, every: int, indexed: bool, spread: int = 1) -> dict[int, list[np.ndarray]]:
    """The hands (21, 2) one MediaPipe finds on every `every`-th of `frames` (BGR
    images, in order), given the frames' indices times `spread` (`indexed`: two looks
    where the last frame seen is far back) or not (one look)."""
    detect = MediaPipeHands()
    found = {}
    for t, image in enumerate(frames):
        if t % every == 0:
            hands = detect(image, frame=t * spread if indexed else None)
            found[t] = [h.points[:, :2] for h in hands]
    detect.close()
    return found


def scores(pairs) -> tuple[float, float, int, int]:
    """PCK@0.2, median distance (hand sizes), misses and frames scored of `pairs`, each
    the hands found on a frame and its reference (21, 2; NaN where it has none): the
    hand found nearest the reference is scored."""
    hits, distances, missed, scored = [], [], 0, 0
    for hands, ref in pairs:
        if not np.isfinite(ref).all():
            continue
        scored += 1
        size = np.linalg.norm(ref[MIDDLE_MCP] - ref[WRIST])
        if not hands:
            missed += 1
            hits.append(np.zeros(21, dtype=bool))
            continue
        d = min((np.linalg.norm(h - ref, axis=1) / size for h in hands), key=np.mean)
        hits.append(d <= 0.2)
        distances.append(float(np.median(d)))
    pck = float(np.mean(hits)) if hits else np.nan
    return pck, float(np.median(distances)) if distances else np.nan, missed, scored


def row(label: str, pairs: dict) -> str:
    """One line: the scores of one look and of two (`pairs[False]`, `pairs[True]`)."""
    cells = []
    for indexed in (False, True):
        pck, median, missed, scored = scores(pairs[indexed])
        cells.append(f"PCK {pck:.3f}, median {median:.3f}, missed {missed} of {scored}")
    return f"{label}: one look {cells[0]}; two looks {cells[1]}"


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--every", type=int, default=10, help="MediaPipe on every N-th frame")
    parser.add_argument("--realistic", type=Path, default=None, metavar="DIR")
    parser.add_argument("--always", action="store_true",
                        help="two looks at every frame seen (its index spread out), "
                             "however near the last")  # fmt: skip
    args = parser.parse_args()
    spread = STALE_FRAMES + 1 if args.always else 1
    for name in VIDEOS:
        detected = read_keypoints(example_path(f"{name}-keypoints"))
        reference = detected.xy  # NaN where MediaPipe found no hand
        pairs = {}
        for indexed in (False, True):
            frames = (image for _, image in open_frames(example_path(name)).frames())
            found = looks(frames, args.every, indexed, spread)
            pairs[indexed] = [(hands, reference[t]) for t, hands in found.items()]
        print(row(f"{name}, against MediaPipe on every frame", pairs), flush=True)
    if args.realistic is not None:
        from handvar.evaluation.realistic import read_case

        pairs = {False: [], True: []}
        cases = sorted(d for d in args.realistic.iterdir() if (d / "truth.npz").exists())
        for case_dir in cases:
            case = read_case(case_dir, frames=True)
            frames = [cv2.cvtColor(np.asarray(f), cv2.COLOR_RGB2BGR) for f in case.frames[0]]
            for indexed in (False, True):
                found = looks(frames, args.every, indexed, spread)
                pairs[indexed] += [(hands, case.truth_2d[0][t]) for t, hands in found.items()]
        print(row(f"{len(cases)} realistic cases, camera 0, against the truth", pairs))


if __name__ == "__main__":
    main()
