"""A still hand before a calibrated stereo pair: the fit's 3D against triangulating the
detections, for hands of a person's own proportions from small to large.

Each case renders one frame of a realistic recording (`handvar.evaluation.realistic`,
``proportions`` σ: every bone and every digit base of the person's hand off the average
proportions) with a stereo pair of 640 × 480 cameras 120 mm apart, 450 mm from the hand,
and repeats it ``--repeat`` times (the hand held still while the tracker fits its
shape).  Its keypoints are the true points' projections with Gaussian noise of
``--noise`` pixels per coordinate, the same on every repeated frame (a detector run on
the same image twice gives the same points).  The user's stereo way runs on them::

    handvar init cam0 cam1 --calib calib.yml --hand SIDE --keypoints k0.npy --keypoints k1.npy
    handvar track cam0,cam1 --calib calib.yml --hand SIDE --init x0.txt \\
        --keypoints k0.npy --keypoints k1.npy --out DIR

and it prints per case and overall the absolute 3D error (mm, the 21 detector points,
fingertips at the pads) of the fit and of each point triangulated on its own
(``cv2.triangulatePoints``, what a user without handvar has), their ratio, the
wrist → middle-MCP length of the truth, the fit and the triangulated points, and the
hand's length (wrist → middle tip) true and fitted.  The last column is the same done
with the first camera alone (``--calib`` of that camera, one keypoint file): one
camera cannot tell the hand's size, so the hand keeps the given 185 mm and its depth
is off by the size's ratio.

``--labels mediapipe`` gives both the fit and the triangulation MediaPipe's points on
each camera's repeated frames instead (``handvar keypoints CAM --hand SIDE --out
mediapipe{j}.npz``, its points given to ``init`` and ``track`` as ``.npy`` files:
MediaPipe's handedness names the other side on some renders, and the study gives the
true one; with ``--npz`` the ``.npz`` files themselves and ``--hand auto``, MediaPipe's
3D and handedness included, as the README's stereo way has them), as a user with a
real stereo pair has them; its 21 points are scored
against the true ones, where it marks a joint elsewhere than the truth both estimates
carry that, and a case where it misses the hand in a view is reported and left out.
Last it prints how alike the keypoints err in the two views (their errors less the true
points' projections, in each view's hand size: the correlation across and along the
image rows, the spread in a view and of the two views' difference), what
`FrameFitSettings.view_correlation` stands for.

Run: ``PYTHONPATH=src .venv/bin/python studies/stereo_shape.py [--cases 8] [--out DIR]``.
"""

from __future__ import annotations

import argparse
import os
import subprocess
import sys
import tempfile
from pathlib import Path

import numpy as np

from handvar.camera import Rig
from handvar.evaluation.realistic import SceneSettings, realistic_case
from handvar.hand.anthropometry import MIDDLE_MCP, WRIST, HandLandmark
from handvar.pipeline import Track
from handvar.tracking.keypoint_cost import keypoint_points
from handvar.vision.keypoints import read_keypoints

ROOT = Path(__file__).resolve().parents[1]
HANDVAR = [sys.executable, "-m", "handvar"]
sys.path.insert(0, str(ROOT / "studies"))
from realistic import triangulated  # noqa: E402

SETTINGS = SceneSettings(size=(640, 480), baseline=120.0, distance=450.0)
MOTIONS = ("counting", "benchmark", "flexion", "flip")


def marked(joints: np.ndarray, labels: str) -> np.ndarray:
    """(21, 3) points a detector marks on a hand whose true points are `joints` (the
    thumb's base `THUMB_BASE` up its metacarpal, where MediaPipe marks it): ``"truth"``
    the same; ``"joint"`` the thumb's base at its carpometacarpal joint, as a labelling
    by the bones would mark it."""
    from handvar.tracking.keypoint_cost import THUMB_BASE

    out = joints.copy()
    if labels == "joint":
        cmc, mcp = HandLandmark.THUMB_CMC, HandLandmark.THUMB_MCP
        out[cmc] = (joints[cmc] - THUMB_BASE * joints[mcp]) / (1.0 - THUMB_BASE)
    return out


def make_case(k: int, spread: float, repeat: int, noise: float, labels: str,
              directory: Path, npz: bool = False):  # fmt: skip
    """Case `k`: one frame repeated, its noisy keypoints; the case and its files."""
    motion = MOTIONS[k % len(MOTIONS)]
    rng = np.random.default_rng([k, 7])
    frame = int(rng.integers(0, 60))
    side = ("right", "left")[k % 2]
    case = realistic_case(motion, cameras=2, side=side, seed=k, frames=(frame, frame + 1),
                          settings=SETTINGS, proportions=spread)  # fmt: skip
    case.write(directory / "one")
    keypoints = []
    for j in range(2):
        folder = directory / f"cam{j}"
        folder.mkdir(parents=True, exist_ok=True)
        image = (directory / "one" / f"cam{j}" / "00000.jpg").read_bytes()
        for t in range(repeat):
            (folder / f"{t:05d}.jpg").write_bytes(image)
        if labels == "mediapipe":
            found = detected(folder, side, directory / f"mediapipe{j}.npz")
            np.save(directory / f"mediapipe{j}.npy", points_2d(found))
            keypoints.append(found if npz else directory / f"mediapipe{j}.npy")
            continue
        points = case.rig.cameras[j].project(marked(case.joints[0], labels))
        points = points + noise * rng.standard_normal((21, 2))
        path = directory / f"keypoints{j}.npy"
        np.save(path, np.repeat(points[None], repeat, axis=0))
        keypoints.append(path)
    return case, keypoints


def detected(folder: Path, side: str, path: Path) -> Path:
    """MediaPipe's keypoints of the frames in `folder` (``handvar keypoints``), `path`."""
    cmd = [*HANDVAR, "keypoints", str(folder), "--hand", side, "--out", str(path)]
    done = subprocess.run(cmd, capture_output=True, text=True,
                          env=dict(os.environ, PYTHONPATH=str(ROOT / "src")))  # fmt: skip
    if done.returncode != 0:
        raise RuntimeError(f"{' '.join(cmd)}\n{done.stderr.strip()}")
    return path


def points_2d(path: Path) -> np.ndarray:
    """(T, 21, 2) pixels of a keypoint file, NaN where there is no point."""
    if path.suffix == ".npy":
        return np.load(path)
    return read_keypoints(path).xy  # NaN where missing


def run(directory: Path, side: str, keypoints: list[Path], name: str = "fit") -> Path:
    """The user's way on the cameras of `keypoints` (the first one alone when given
    one file: its calibration written beside the pair's); with ``.npz`` files the side
    is ``auto``."""
    env = dict(os.environ, PYTHONPATH=str(ROOT / "src"))
    calib = directory / "one" / "calib.yml"
    if len(keypoints) == 1:
        rig = Rig.load(calib)
        calib = directory / "one" / "calib-cam0.yml"
        Rig([rig.cameras[0]], [rig.names[0]]).save(calib)
    cams = [str(directory / f"cam{j}") for j in range(len(keypoints))]
    common = ["--calib", str(calib), "--hand", "auto" if keypoints[0].suffix == ".npz" else side]
    kps = [a for p in keypoints for a in ("--keypoints", str(p))]
    x0, out = directory / f"{name}-x0.txt", directory / name
    for cmd in ([*HANDVAR, "init", *cams, *common, *kps, "--out", str(x0)],
                [*HANDVAR, "track", ",".join(cams), *common, "--init", str(x0), *kps,
                 "--out", str(out), "--no-video"]):  # fmt: skip
        done = subprocess.run(cmd, capture_output=True, text=True, env=env)
        if done.returncode != 0:
            raise RuntimeError(f"{' '.join(cmd)}\n{done.stderr.strip()}")
    return out


def fitted(out: Path) -> tuple[np.ndarray, float]:
    """The track's scored points (T, 21, 3) and its hand's wrist → middle-tip length."""
    track = Track.load(out)
    shape = track.hand.shape
    points = np.stack([keypoint_points(track.hand, x, "pad") for x in track.poses])
    return points, float(shape.bases[2, 1] + shape.segments[2].sum())


def view_errors(case, xy: np.ndarray) -> np.ndarray:
    """(2, 21, 2) the keypoints `xy` (2, 21, 2) less the true points' projections, in
    each view's true wrist → middle-MCP length."""
    true = np.stack([cam.project(case.joints[0]) for cam in case.rig.cameras])
    size = np.linalg.norm(true[:, MIDDLE_MCP] - true[:, WRIST], axis=-1)[:, None, None]
    return (xy - true) / size


def palm(points: np.ndarray) -> float:
    return float(np.linalg.norm(points[..., MIDDLE_MCP, :] - points[..., WRIST, :], axis=-1).mean())


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--cases", type=int, default=8)
    parser.add_argument("--proportions", type=float, default=0.08)
    parser.add_argument("--repeat", type=int, default=15)
    parser.add_argument("--noise", type=float, default=1.5, help="pixels per coordinate")
    parser.add_argument(
        "--labels",
        choices=("truth", "joint", "mediapipe"),
        default="truth",
        help="where the keypoints mark the joints (function marked), or MediaPipe's points",
    )
    parser.add_argument(
        "--npz", action="store_true",
        help="with --labels mediapipe: give init and track MediaPipe's .npz files as "
        "handvar keypoints writes them (its 3D and handedness too) with --hand auto, the "
        "README's stereo way; by default its 2D points (.npy) and the true side",
    )  # fmt: skip
    parser.add_argument("--out", type=Path, default=None)
    args = parser.parse_args()
    if args.npz and args.labels != "mediapipe":
        parser.error("--npz: expected --labels mediapipe")
    base = args.out or Path(tempfile.mkdtemp(prefix="stereo-shape-"))
    points = ("MediaPipe's points" if args.labels == "mediapipe"
              else f"keypoint noise {args.noise} px, labels {args.labels}")  # fmt: skip
    print(f"{args.cases} still hands, proportions σ {args.proportions}, {args.repeat} "
          f"frames, {points}; absolute 3D error, mm")  # fmt: skip
    print(f"{'case':28s} {'length: true':>12s} {'fit':>6s} {'stereo fit':>10s} "
          f"{'tri.':>6s} {'ratio':>6s} {'palm: true':>10s} {'fit':>6s} {'tri.':>6s} "
          f"{'mono fit':>8s}")  # fmt: skip
    rows, joints, spread, errors = [], [], [], []
    for k in range(args.cases):
        directory = base / f"case{k}"
        case, keypoints = make_case(k, args.proportions, args.repeat, args.noise, args.labels,
                                    directory, args.npz)  # fmt: skip
        truth = case.joints[0]
        xy = np.stack([points_2d(p) for p in keypoints])
        if not np.isfinite(xy).all():
            missed = (~np.isfinite(xy).all(axis=(2, 3))).sum(axis=1).tolist()
            print(f"{case.name:28s} left out: frames without the hand per camera {missed}")
            continue
        fit, length = fitted(run(directory, case.side, keypoints))
        mono, _ = fitted(run(directory, case.side, keypoints[:1], "mono"))
        tri = triangulated(case, xy)
        e = [float(np.linalg.norm(p - truth, axis=-1).mean()) for p in (fit, tri, mono)]
        rows.append(e)
        joints.append([np.linalg.norm(p - truth, axis=-1).mean(axis=0) for p in (fit, tri)])
        spread.append(float(np.nanstd(tri, axis=0).mean()))
        errors.append(view_errors(case, xy[:, -1]))
        print(f"{case.name:28s} {case.hand_length:12.1f} {length:6.1f} {e[0]:10.1f} "
              f"{e[1]:6.1f} {e[0] / e[1]:6.2f} {palm(truth):10.1f} {palm(fit):6.1f} "
              f"{palm(tri):6.1f} {e[2]:8.1f}")  # fmt: skip
    f, t, m = np.mean(rows, axis=0)
    worst = max(r[0] / r[1] for r in rows)
    print(f"{'mean':28s} {'':12s} {'':6s} {f:10.1f} {t:6.1f} {f / t:6.2f} "
          f"{'':10s} {'':6s} {'':6s} {m:8.1f}")  # fmt: skip
    print(
        f"the fit over triangulation: {f / t:.2f} on average, {worst:.2f} at worst; "
        f"one camera (the given 185 mm hand): {m:.1f} mm"
    )
    print(
        "the triangulated points' spread over the repeated frames, per case (mean "
        "standard deviation, mm): " + " ".join(f"{v:.1f}" for v in spread)
    )
    for name, e in zip(("fit", "triangulated"), np.mean(joints, axis=0), strict=True):
        print(f"per joint (wrist, thumb CMC … little tip), {name}: "
              + " ".join(f"{v:.0f}" for v in e))  # fmt: skip
    e = np.concatenate(errors, axis=1)  # (2, n, 2): the views' errors, hand sizes
    corr = [np.corrcoef(e[0, :, c], e[1, :, c])[0, 1] for c in range(2)]
    print(f"the keypoints' errors in the two views (hand sizes): correlation {corr[0]:.2f} "
          f"across the rows, {corr[1]:.2f} along them; spread {e.std():.3f} in a view, "
          f"{(e[0] - e[1]).std():.3f} of their difference")  # fmt: skip


if __name__ == "__main__":
    main()
