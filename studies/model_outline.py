"""How much of a hand's silhouette the sphere-mesh covers: filmed hands against renders.

Run: ``PYTHONPATH=src .venv/bin/python studies/model_outline.py [--realistic DIR]``.

The silhouette cost (paper §2.1, design §4) charges the model for pixels it puts off the
silhouette more than for silhouette it leaves uncovered, so a model thicker than the
hand it is fitted to sits farther away, smaller.  On the realistic benchmark's renders
the sphere-mesh at the true pose covers more pixels than the rendered skinned hand
(``studies/cleanup.py --fits``), and the silhouette tracker's monocular fits lie behind
the hand (docs/results/paper-real-video.md).  Whether filmed hands show the same is
asked here, where no truth is: each of the three real videos of ``examples/data`` is
tracked with its MediaPipe keypoints on every frame at 640 px on the long side
(``handvar.track``, as ``benchmarks/realvideos.py`` does), and on every 5th frame with a
pose and a detection the model's silhouette at the fitted pose (its joints on the
detector's points) is compared with the skin silhouette the tracker would be given
(`silhouettes_from_frames`, the forearm cut at the detected wrist, the skin component
the model overlaps): the model's pixels over the skin's, the share of the model's
pixels off the skin, the share of the skin's off the model, and their IoU (medians).

``--realistic DIR`` (cases made by ``studies/realistic.py --out DIR``) adds the mono
renders: the model of the case's true hand length at the true pose against the hand's
true silhouette and against its skin silhouette, every 5th frame.
"""

from __future__ import annotations

import argparse
from pathlib import Path

import cv2
import numpy as np

import handvar
from handvar.data import example_path
from handvar.render import silhouettes
from handvar.tracking.tracker import silhouette_iou
from handvar.vision.frames import open_frames
from handvar.vision.keypoints import read_keypoints
from handvar.vision.silhouette import EmptySilhouetteError, silhouettes_from_frames

VIDEOS = ("video", "fingerspelling", "counting")


def outline(model: np.ndarray, silhouette: np.ndarray) -> tuple[float, float, float, float]:
    """Model pixels / silhouette pixels, the model's share off the silhouette, the
    silhouette's share off the model, IoU."""
    m, s = model.astype(bool), silhouette.astype(bool)
    return ((m.sum() / s.sum()), (m & ~s).sum() / m.sum(), (s & ~m).sum() / s.sum(),
            float(silhouette_iou(m[None], s[None])[0]))  # fmt: skip


def real_video(name: str, every: int) -> np.ndarray:
    """(frames, 4) `outline` figures of one real video (module notes)."""
    video = example_path(name)
    detected = read_keypoints(example_path(f"{name}-keypoints"))
    reader = open_frames(video)
    size = reader.size
    scale = 640.0 / max(size)
    track = handvar.track(video, keypoints=detected, scale=scale)
    rig = track.rig.scaled(scale)
    keypoints = detected.scaled(scale, size)
    rows = []
    for t, frame in reader.frames(0, track.n_frames):
        pose = track.poses[t]
        if t % every or not np.isfinite(pose).all() or not keypoints.present[t].any():
            continue
        image = cv2.resize(frame, tuple(rig.cameras[0].size), interpolation=cv2.INTER_AREA)
        model = silhouettes(track.hand, pose, rig)[0]
        try:
            (skin,) = silhouettes_from_frames([image], wrist=True, keypoints=[keypoints.frame(t)],
                                              near=[model])  # fmt: skip
        except EmptySilhouetteError:
            continue
        if skin.any() and model.any():
            rows.append(outline(model, skin))
    return np.asarray(rows)


def renders(directory: Path, every: int) -> dict[str, np.ndarray]:
    """`outline` figures of the mono renders at the true pose, against the true and the
    skin silhouette."""
    from handvar.evaluation.realistic import read_case
    from handvar.hand import HandModel
    from handvar.hand.anthropometry import HandShape

    rows = {"true": [], "skin": []}
    for case_dir in sorted(d for d in directory.iterdir() if (d / "truth.npz").exists()):
        case = read_case(case_dir, frames=True)
        if len(case.rig) != 1:
            continue
        hand = HandModel(HandShape.from_size(case.hand_length, side=case.side))
        for t in range(0, case.n_frames, every):
            model = silhouettes(hand, case.poses[t], case.rig)[0]
            true = np.asarray(case.masks[0][t])
            image = cv2.cvtColor(np.asarray(case.frames[0][t]), cv2.COLOR_RGB2BGR)
            rows["true"].append(outline(model, true))
            try:
                (skin,) = silhouettes_from_frames([image], wrist=True, near=[true])
            except EmptySilhouetteError:
                continue
            if skin.any():
                rows["skin"].append(outline(model, skin))
    return {k: np.asarray(v) for k, v in rows.items()}


def line(label: str, rows: np.ndarray) -> str:
    area, model_off, skin_off, iou = np.median(rows, axis=0)
    return (f"{label}: {len(rows)} frames, model / silhouette pixels {area:.2f}, the model's "
            f"off the silhouette {model_off:.2f}, the silhouette's off the model "
            f"{skin_off:.2f}, IoU {iou:.2f}")  # fmt: skip


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--every", type=int, default=5, help="every N-th frame")
    parser.add_argument("--realistic", type=Path, default=None, metavar="DIR")
    args = parser.parse_args()
    for name in VIDEOS:
        print(line(f"{name}, at the pose fitted to MediaPipe's keypoints, against the skin",
                   real_video(name, args.every)), flush=True)  # fmt: skip
    if args.realistic is not None:
        for key, rows in renders(args.realistic, args.every).items():
            print(line(f"renders (mono), the true hand at the true pose, against the {key} "
                       "silhouette", rows))  # fmt: skip


if __name__ == "__main__":
    main()
