"""Where a detector marks the 21 joints, against the model's joints (design §14.6).

The keypoint fit pulls the model's points (G(x) with the fingertips at the pad centres
and the thumb's base up its metacarpal: ``keypoint_points`` with "pad") towards the
detector's keypoints.  Where the detector places a joint elsewhere on the hand (a
wrist further up the palm, a distal joint nearer the middle one), the fit bends or
tilts the model to reach it.  For each joint k this prints the median offset of the
detector's point from the model's along the bone that ends at k (parent → k, in the
image; the wrist along wrist → middle MCP), in units of that bone's length in the
image: +0.1 is a tenth of the bone beyond the model's joint, −0.1 short of it.

- ``--cases DIR``: the realistic benchmark's cases kept by ``studies/realistic.py
  --detector mediapipe --out DIR``: MediaPipe on the rendered frames against the true
  joints (what the rendered mesh shows the detector, exactly).
- ``--videos``: the three real videos, MediaPipe's shipped keypoints against the joints
  of the track fitted to them (keypoints on every frame): the offsets the fit could not
  absorb, so smaller than the detector's own, but on real hands.

Below the table, the thumb's base: where the detector marks it along the thumb's
metacarpal (model CMC → MCP in the image), as a fraction of it: 0 at the CMC, 1 at
the MCP (the model's point lies at `THUMB_BASE`, which this measure chose).  On the
real videos the track is fitted without the detected thumb base (its confidence set to
0), so that the model's metacarpal is placed by the other points alone and the
fraction is not pulled towards the detector's.

Run: ``PYTHONPATH=src .venv/bin/python studies/detector_joints.py [--cases DIR]
[--videos]``
"""

from __future__ import annotations

import argparse
from pathlib import Path

import numpy as np

from handvar.hand.anthropometry import JOINTS

#: The joint each bone starts from (the wrist's "bone" runs to the middle MCP).
PARENT = (9, 0, 1, 2, 3, 0, 5, 6, 7, 0, 9, 10, 11, 0, 13, 14, 15, 0, 17, 18, 19)


def along_bone(detected: np.ndarray, model: np.ndarray) -> np.ndarray:
    """(T, 21) offset of each detected point from the model's along its bone, in bone
    lengths (module notes); NaN where either is missing or the bone is under 5 px."""
    a, b = model[:, list(PARENT)], model.copy()
    a[:, 0], b[:, 0] = model[:, 0], model[:, 9]
    u = b - a
    length = np.linalg.norm(u, axis=-1)
    with np.errstate(invalid="ignore", divide="ignore"):
        out = np.einsum("tkc,tkc->tk", detected - model, u / length[..., None]) / length
    out[length < 5.0] = np.nan
    return out


def along_metacarpal(detected: np.ndarray, model: np.ndarray) -> np.ndarray:
    """(T,) the detected thumb base projected onto the model's thumb metacarpal, in its
    lengths from the CMC (the model's point 1 lies `THUMB_BASE` up it, point 2 at the
    MCP); NaN where missing or under 5 px."""
    from handvar.tracking.keypoint_cost import THUMB_BASE

    u = model[:, 2] - model[:, 1]
    length2 = np.einsum("tc,tc->t", u, u)
    with np.errstate(invalid="ignore", divide="ignore"):
        out = np.einsum("tc,tc->t", detected[:, 1] - model[:, 1], u) / length2
    out[length2 < 25.0] = np.nan
    return THUMB_BASE + (1.0 - THUMB_BASE) * out


def benchmark_offsets(directory: Path) -> tuple[np.ndarray, np.ndarray]:
    """Offsets of MediaPipe on the rendered frames against the truth, every camera, and
    its thumb base along the true metacarpal."""
    from handvar.evaluation.realistic import read_case

    rows, thumb = [], []
    for case_dir in sorted(p for p in directory.iterdir() if (p / "mediapipe0.npy").exists()):
        case = read_case(case_dir)
        for j in range(len(case.rig)):
            detected = np.load(case_dir / f"mediapipe{j}.npy")
            rows.append(along_bone(detected, case.truth_2d[j]))
            thumb.append(along_metacarpal(detected, case.truth_2d[j]))
    return np.concatenate(rows), np.concatenate(thumb)


def video_offsets(name: str, without: tuple[int, ...] = ()) -> tuple[np.ndarray, np.ndarray]:
    """Offsets of the shipped MediaPipe keypoints against the track fitted to them (the
    points `without` left out of the fit), and the thumb base along its metacarpal."""
    from handvar.data import example_path
    from handvar.pipeline import track
    from handvar.tracking.keypoint_cost import keypoint_points
    from handvar.vision.keypoints import read_keypoints
    from handvar.vision.sources import open_source

    path = example_path(name)
    detected = read_keypoints(example_path(f"{name}-keypoints"))
    given = detected.to_array()
    given[:, list(without), 2] = 0.0
    w, h = open_source(path).image_size
    tracked = track(path, keypoints=given, scale=640.0 / max(w, h))
    camera = tracked.rig.cameras[0]  # the recording's own pixels, as the keypoints
    model = np.full((tracked.n_frames, 21, 2), np.nan)
    for t, x in enumerate(tracked.poses):
        if np.isfinite(x).all():
            model[t] = camera.project(keypoint_points(tracked.hand, x, "pad"))
    points = np.where(detected.present[: tracked.n_frames, :, None],
                      detected.xy[: tracked.n_frames], np.nan)  # fmt: skip
    return along_bone(points, model), along_metacarpal(points, model)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--cases", type=Path, default=None, help="realistic cases with MediaPipe")
    parser.add_argument("--videos", action="store_true", help="the three real videos")
    args = parser.parse_args()
    columns: list[tuple[str, np.ndarray]] = []
    thumbs: list[tuple[str, np.ndarray]] = []
    if args.cases is not None:
        offsets, thumb = benchmark_offsets(args.cases)
        columns.append(("rendered (truth)", offsets))
        thumbs.append(("rendered (truth)", thumb))
    if args.videos:
        for name in ("video", "fingerspelling", "counting"):
            offsets, _ = video_offsets(name)
            columns.append((f"{name} (fit)", offsets))
            thumbs.append((f"{name} (fit without it)", video_offsets(name, (1,))[1]))
    if not columns:
        parser.error("expected --cases DIR and/or --videos")
    print("| joint | " + " | ".join(c for c, _ in columns) + " |")
    print("|---|" + "---:|" * len(columns))
    for k, joint in enumerate(JOINTS):
        cells = " | ".join(f"{np.nanmedian(o[:, k]):+.2f}" for _, o in columns)
        print(f"| {joint} | {cells} |")
    print("frames: " + ", ".join(f"{c} {int(np.isfinite(o).any(axis=1).sum())}"
                                 for c, o in columns))  # fmt: skip
    print("the thumb's base along its metacarpal (0 the CMC, 1 the MCP), median [quartiles]: "
          + "; ".join(f"{c} {np.nanmedian(f):+.2f} [{np.nanquantile(f, 0.25):+.2f}, "
                      f"{np.nanquantile(f, 0.75):+.2f}]" for c, f in thumbs))  # fmt: skip


if __name__ == "__main__":
    main()
