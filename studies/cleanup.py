"""The skin mask's clean-up radii, chosen against the hand's true silhouettes.

Run:  PYTHONPATH=src .venv/bin/python studies/cleanup.py --realistic DIR

The silhouette tracker sees the hand through the published skin model and a clean-up
(`handvar.vision.silhouette.clean_mask`: an opening, a closing, the component where the
hand is expected, holes filled).  This study scores the clean-up's opening and closing
radii on the realistic benchmark (``studies/realistic.py``: DIR as made by ``--out DIR``,
the cases generated if missing), every 4th frame of each of its 16 cases and each
camera, as the tracker makes them without keypoints (the forearm cut at the wrist,
`cut_wrist`), with the component kept where the true silhouette lies (the tracker keeps
the one its predicted pose overlaps): the IoU of the cleaned silhouette with the hand's
true silhouette, per case and its median and mean over all frames.  A case whose skin
model never finds the hand scores 0 with every radius.

What the radii do to the tracking is measured with the tracker itself, by
``studies/paper_real_video.py --realistic DIR --predictors rvar`` (docs/results/
paper-real-video.md).

``--fits`` asks instead how much of the silhouette tracker's error is its silhouette:
on every 10th frame of each case, one frame fitted by the tracker (SMD from the true
pose, no motion) on the hand's true silhouette and on the skin silhouette (the
default clean-up), scored against the truth, in mono and in stereo: PCK@0.2 in camera
0, the wrist-relative 3D error (mm), the median depth error (mm along the ray from
camera 0 to the wrist; positive: farther), and the pixels the sphere-mesh covers at the
true pose over the true silhouette's.
"""

from __future__ import annotations

import argparse
from pathlib import Path

import cv2
import numpy as np

from handvar.evaluation.metrics import joint_errors, pck_2d
from handvar.evaluation.realistic import read_case
from handvar.tracking.tracker import silhouette_iou
from handvar.vision.silhouette import (
    CLEANUP_SETTINGS,
    EmptySilhouetteError,
    silhouettes_from_frames,
)
from realistic import generate, specs

# (opening, closing) radii in pixels; the first pair is the default.
RADII = ((CLEANUP_SETTINGS.open_radius, CLEANUP_SETTINGS.close_radius),
         (2, 4), (1, 2), (0, 2), (1, 1), (1, 0), (2, 2), (2, 0), (0, 0))  # fmt: skip


def case_ious(case, radii, every: int) -> dict[tuple[int, int], list[float]]:
    """Per radius pair, the IoU of every scored frame and camera of `case`."""
    out = {r: [] for r in radii}
    for t in range(0, case.n_frames, every):
        for j in range(len(case.rig)):
            image = cv2.cvtColor(case.frames[j][t], cv2.COLOR_RGB2BGR)
            true = case.masks[j][t]
            for r in radii:
                cleanup = {"open_radius": r[0], "close_radius": r[1]}
                try:
                    (mask,) = silhouettes_from_frames([image], wrist=True, near=[true],
                                                      cleanup=cleanup)  # fmt: skip
                except EmptySilhouetteError:  # no skin, or skin on every border
                    mask = np.zeros_like(true)
                out[r].append(float(silhouette_iou(mask[None], true[None])[0]))
    return out


def one_frame_fits(case, every: int) -> dict[str, list[tuple[float, float, float, float]]]:
    """Per silhouette ("true", "skin"), (PCK, 3D, depth error, area ratio) of each fit."""
    from handvar.hand import HandModel
    from handvar.hand.anthropometry import HandShape
    from handvar.predictors import NoMotion
    from handvar.render import silhouettes
    from handvar.tracking import Tracker
    from realistic import scored_points

    hand = HandModel(HandShape.from_size(case.hand_length, side=case.side))
    cam = case.rig.cameras[0]
    out = {"true": [], "skin": []}
    for t in range(0, case.n_frames, every):
        x = case.poses[t]
        true = np.asarray(case.masks)[:, t]
        images = [cv2.cvtColor(case.frames[j][t], cv2.COLOR_RGB2BGR) for j in range(len(true))]
        try:
            skin = np.stack(silhouettes_from_frames(images, wrist=True, near=list(true)))
        except EmptySilhouetteError:
            continue
        area = silhouettes(hand, x, case.rig).sum() / true.sum()
        ray = (x[:3] - cam.center) / np.linalg.norm(x[:3] - cam.center)
        for name, masks in (("true", true), ("skin", skin)):
            tracker = Tracker(case.rig, hand, NoMotion(), np.random.default_rng(t))
            tracker.reset(x)
            fit = tracker.step(masks).pose
            points = scored_points(hand, fit[None])
            error = float(joint_errors(case.joints[t][None], points, alignment="wrist").mean())
            pck = pck_2d(case.truth_2d[0][t][None], cam.project(points[0])[None], 0.2)
            out[name].append((pck, error, float((fit[:3] - x[:3]) @ ray), float(area)))
    return out


def fits(directory: Path) -> None:
    """The one-frame fits of every case (module notes), summed up in mono and stereo."""
    rows = {}
    for spec in specs(quick=False):
        generate(spec, directory / spec.name)
        case = read_case(directory / spec.name, frames=True)
        for name, values in one_frame_fits(case, 10).items():
            rows.setdefault((spec.cameras, name), []).extend(values)
        print(f"{spec.name}: fitted", flush=True)
    for (cameras, name), values in sorted(rows.items()):
        pck, error, depth, area = np.asarray(values).T
        print(f"{'mono' if cameras == 1 else 'stereo'}, {name} silhouette ({len(values)} "
              f"frames): PCK@0.2 {pck.mean():.3f}, 3D {error.mean():.1f} mm, depth error "
              f"median {np.median(depth):+.1f} mm; the model's pixels / the true "
              f"silhouette's at the true pose {area.mean():.2f}")  # fmt: skip


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--realistic", type=Path, required=True, metavar="DIR")
    parser.add_argument("--every", type=int, default=4, help="score every N-th frame")
    parser.add_argument("--fits", action="store_true", help="the one-frame fits instead")
    args = parser.parse_args()
    if args.fits:
        fits(args.realistic)
        return
    radii = list(dict.fromkeys(RADII))
    print("IoU with the true silhouette, median per case; columns: (opening, closing) px")
    print(f"{'case':26s}" + "".join(f"{r!s:>9s}" for r in radii))
    every = {r: [] for r in radii}
    for spec in specs(quick=False):
        generate(spec, args.realistic / spec.name)
        case = read_case(args.realistic / spec.name, frames=True)
        scores = case_ious(case, radii, args.every)
        print(f"{spec.name:26s}" + "".join(f"{np.median(scores[r]):9.3f}" for r in radii),
              flush=True)  # fmt: skip
        for r in radii:
            every[r] += scores[r]
    print(f"{'median, all frames':26s}" + "".join(f"{np.median(every[r]):9.3f}" for r in radii))
    print(f"{'mean, all frames':26s}" + "".join(f"{np.mean(every[r]):9.3f}" for r in radii))


if __name__ == "__main__":
    main()
