"""The realistic benchmark: generated recordings with ground truth, tracked as a user would.

Each case is a recording made by `handvar.evaluation.realistic.realistic_case` (the skinned
mesh hand with a forearm, in a skin tone, over a real or generated background, with a
skin-coloured distractor, motion blur and brightness changes; detector-like keypoints
with AR(1) noise, gross errors and missed frames; docs/realistic-benchmark.md), written
to disk as JPEG image folders, ``keypoints{j}.npy`` and ``calib.yml``.  The fit runs the
user's commands on those files::

    handvar init cam0[ cam1] --calib calib.yml --hand SIDE --keypoints keypoints0.npy ...
    handvar track cam0[,cam1] --calib calib.yml --hand SIDE --init x0.txt \\
        --keypoints keypoints0.npy ... --keypoint-every K --out DIR --no-video

with keypoints on every frame (K = 1) and on every 5th (K = 5), and reads DIR/poses.csv
and DIR/quality.csv.  Against the truth it prints, per case and overall, for the raw
keypoints and for each fit:

- 2D PCK@0.2 (of the true wrist → middle-MCP length in the image) and the mean 2D
  error (px), over every camera;
- wrist-relative MPJPE, PA-MPJPE (similarity Procrustes per frame), the AUC of 3D PCK
  over 20–50 mm (of the wrist-relative errors) and the absolute 3D error (world frame,
  the cameras are calibrated), mm; for the raw keypoints "–" (no 3D in mono), beside
  them what a user has without the fit: with two cameras the keypoints triangulated
  point by point, and their every 5th frame held or interpolated;
- lost frames (quality.csv's ``lost``; for the raw keypoints, the missed frames of
  camera 0);
- the keypoint check (docs/keypoint-fit.md) over the frames whose detection the fit was
  given: the frames failing it, and the keypoints the fit rejected;
- ms/frame all-in: as ``handvar track`` reports it (its "frames/s all-in": reading,
  silhouettes, keypoints, fit, recovery and searches), and the wall time of ``init``
  plus ``track`` over the frames (each process's start-up included).

The scored points are the detector's (G(x) with the fingertips at the pad centres,
design §14.6) for the truth, the raw keypoints and the fit (its poses through a hand
model of the shape the track fitted, `handvar.tracking.shape_fit`, read back with
`handvar.Track.load`).

With ``--detector mediapipe`` the keypoints are MediaPipe Hands' on the rendered
frames instead (``handvar keypoints CAM --hand SIDE``, run by ``--mediapipe-python``, the
Python of an environment with ``handvar[mediapipe]``, by default this one), given to the
fit as (T, 21, 2) pixel files as a user with a detector's points only would; the first
row scores the detector: its 2D points, and its 3D (the world landmarks, hand-centred,
in camera 0's axes) in the wrist-relative columns; beside it what a user has without
the fit: with two cameras its points triangulated, and its every 5th frame held or
interpolated (the detections the fit with every 5th frame is given).  ``--world`` gives the
detector's ``.npz`` instead, its world landmarks as the fit's weak 3D cue.
``--side auto`` leaves the side to the commands as a user may (``handvar keypoints CAM
--hand auto``, its ``.npz`` with the handedness given to ``init`` and ``track --hand
auto``), the track's side scored as it is ("wrong side").
``--detector inside`` runs the one command instead (``handvar track CAMS --calib
calib.yml --out DIR``: the detector inside, nothing else given) and prints beside it
what a user has without the fit: the detector's points and 3D, its points triangulated
(two cameras), the detections of the run with the detector on every 5th frame held or
interpolated (`handvar.evaluation.metrics.thinned`; MediaPipe follows the hand from
frame to frame, so its detections on every 5th frame are not those of every frame
thinned) or carried by optical flow both ways (what the fit is given between them),
and every 3D estimate's jitter (acceleration error) and lag (the frames it
trails the truth by, `handvar.evaluation.metrics.lag`).  The one command decides the
side from the detector's handedness (two cameras: the hand's 3D shape); a track of
the other side than the case's is scored as it is, as the detector's points are
whatever their label, and counted under "wrong side".  A run that fails scores every
frame lost and every point wrong.  Below the table, per rig, the 2D PCK of the
detections interpolated, the points carried by optical flow and the fit with the
detector on every 5th frame, by the frames since the detector's (0 on its frames):
where they lose between detections.

Run: ``PYTHONPATH=src .venv/bin/python studies/realistic.py`` (about 5–10 minutes on
two cores); ``--quick`` for a one-minute subset; ``--fast`` for the four cases of the
fast gestures instead (``fast``: the counting and spread gestures at three times the
pace, twice over, the palm moving with them); ``--faster`` for them at twice that
pace (four times over); each case's line says how far its joints
move in 5 frames; ``--out DIR`` keeps the generated cases
(and the fits) in DIR; ``--cases`` to run only the cases whose name contains a string;
``--silhouette-term S`` tracks with the keypoint fit's silhouette term at σ S;
``--predictor P`` with ``handvar track``'s predictor P.
"""

from __future__ import annotations

import argparse
import os
import re
import subprocess
import sys
import tempfile
import time
from dataclasses import dataclass
from pathlib import Path

import cv2
import numpy as np

from handvar.evaluation.metrics import (
    acceleration_error,
    auc_pck_3d,
    joint_errors,
    lag,
    mean_point_error,
    pck_2d,
    thinned,
)
from handvar.evaluation.realistic import SKIN_TONES, read_case, realistic_case
from handvar.pipeline import Track
from handvar.tracking.keypoint_cost import keypoint_points
from handvar.vision.keypoints import read_keypoints

ROOT = Path(__file__).resolve().parents[1]
VIDEO = ROOT / "examples" / "data" / "dex-human-hand-video.mp4"
VIDEO_KEYPOINTS = ROOT / "examples" / "data" / "dex-human-hand-video-keypoints.npy"
HANDVAR = [sys.executable, "-m", "handvar"]
#: The model the commands are given: the default hand length (the user does not know
#: the true one, which the generator draws from 172–198 mm).
HAND_LENGTH = 185.0


@dataclass(frozen=True)
class Spec:
    """One case: motion, cameras, side, seed, frames, background, distractor, skin."""

    motion: str
    cameras: int
    side: str
    seed: int
    frames: tuple[int, int]
    background: str
    distractor: str
    skin: str

    @property
    def name(self) -> str:
        rig = "mono" if self.cameras == 1 else "stereo"
        return f"{self.motion}-{rig}-{self.side}-s{self.seed}"


#: Frames of each motion: a window with its fast events (benchmark: the little finger
#: at 73, the global rotation at 100; flexion: the single digits; flip: the whole turn).
WINDOWS = {
    "benchmark": (50, 110),
    "flexion": (20, 80),
    "flip": (10, 70),
    "counting": (0, 60),
    "fast": (0, 60),
    "faster": (0, 60),
}
#: The motions of the benchmark's 16 cases, and of its fast gestures' four (``--fast``;
#: ``--faster``: twice as fast).
CASE_MOTIONS = ("benchmark", "flip", "flexion", "counting")
FAST_MOTIONS = ("fast",)
FASTER_MOTIONS = ("faster",)


def specs(quick: bool, motions: tuple[str, ...] = CASE_MOTIONS) -> list[Spec]:
    """The cases: every motion, mono and stereo, right and left (quick: one of each motion)."""
    backgrounds = ("video", "fridge", "rectangles", "gradient")
    distractors = ("arm", "face", "none")
    skins = tuple(SKIN_TONES)
    out = []
    k = 0
    combos = [(1, "right"), (2, "left"), (1, "left"), (2, "right")] if not quick else [(1, "right")]
    for m, motion in enumerate(motions):
        for c, (cameras, side) in enumerate(combos):
            if quick:
                cameras, side = ((1, "right"), (2, "left"), (1, "left"), (2, "right"))[m]
            start, stop = WINDOWS[motion]
            if quick:
                stop = start + 30
            out.append(Spec(
                motion, cameras, side, seed=c, frames=(start, stop),
                background=backgrounds[k % 4], distractor=distractors[k % 3],
                skin=skins[k % len(skins)],
            ))  # fmt: skip
            k += 1
    return out


def video_background(seed: int) -> np.ndarray:
    """A crop of a frame of the example video where the hand never is (RGB).

    The hand and forearm of that video stay right of the leftmost detected keypoint
    (less a margin of 40 px); the crop, 16:9, lies left of it at a seeded place, in a
    seeded frame, flipped left-right for odd seeds.
    """
    rng = np.random.default_rng([seed, 30])
    kp = np.load(VIDEO_KEYPOINTS)
    free = int(np.nanmin(np.where(kp[..., 2] > 0, kp[..., 0], np.nan))) - 40
    cap = cv2.VideoCapture(str(VIDEO))
    n = int(cap.get(cv2.CAP_PROP_FRAME_COUNT))
    cap.set(cv2.CAP_PROP_POS_FRAMES, int(rng.integers(0, max(n, 1))))
    ok, bgr = cap.read()
    cap.release()
    if not ok:
        raise OSError(f"{VIDEO}: cannot read a frame")
    h = bgr.shape[0]
    cw = int(rng.uniform(0.75, 1.0) * free)
    ch = min(h, cw * 9 // 16)
    x0 = int(rng.integers(0, free - cw + 1))
    y0 = int(rng.integers(0, h - ch + 1))
    crop = cv2.cvtColor(bgr[y0 : y0 + ch, x0 : x0 + cw], cv2.COLOR_BGR2RGB)
    return crop[:, ::-1].copy() if seed % 2 else crop


def generate(spec: Spec, directory: Path):
    """Generate the case of `spec` into `directory` (kept if it is already there)."""
    if (directory / "truth.npz").exists():
        return read_case(directory)
    background = video_background(spec.seed) if spec.background == "video" else spec.background
    case = realistic_case(
        spec.motion, cameras=spec.cameras, side=spec.side, seed=spec.seed,
        background=background, skin=spec.skin, distractor=spec.distractor, frames=spec.frames,
    )  # fmt: skip
    case.write(directory)
    return case


def run_fit(
    case_dir: Path,
    spec: Spec,
    every: int,
    out: Path,
    keypoints: list[Path] | None = None,
    extra: tuple[str, ...] = (),
    side: str = "given",
) -> tuple[float, Path]:
    """``handvar init`` then ``handvar track`` on the case's files; wall time (s), out dir.
    `keypoints`: one file per camera (default: the simulated detector's); `extra`: more
    options of ``handvar track``; `side` "auto": ``--hand auto``, else the case's side.
    Where the first frame has neither keypoints nor a silhouette (`init` says so),
    ``track`` runs without ``--init``, as that message advises."""
    cams = [str(case_dir / f"cam{j}") for j in range(spec.cameras)]
    if keypoints is None:
        keypoints = [case_dir / f"keypoints{j}.npy" for j in range(spec.cameras)]
    kps = []
    for path in keypoints:
        kps += ["--keypoints", str(path)]
    hand = "auto" if side == "auto" else spec.side
    common = ["--calib", str(case_dir / "calib.yml"), "--hand", hand,
              "--hand-length", str(HAND_LENGTH)]  # fmt: skip
    out.parent.mkdir(parents=True, exist_ok=True)
    x0 = out.parent / f"{out.name}-x0.txt"
    env = dict(os.environ, PYTHONPATH=str(ROOT / "src"))
    start = time.perf_counter()
    init = [*HANDVAR, "init", *cams, *common, *kps, "--out", str(x0)]
    done = subprocess.run(init, capture_output=True, text=True, env=env)
    start_at = ["--init", str(x0)]
    if done.returncode != 0 and "expected keypoints or a hand's silhouette" in done.stderr:
        start_at = []
    elif done.returncode != 0:
        raise RuntimeError(f"{' '.join(init)}\n{done.stderr.strip()}")
    cmd = [*HANDVAR, "track", ",".join(cams), *common, *start_at, *kps,
           "--keypoint-every", str(every), "--out", str(out), "--no-video", *extra]  # fmt: skip
    done = subprocess.run(cmd, capture_output=True, text=True, env=env)
    if done.returncode != 0:
        raise RuntimeError(f"{' '.join(cmd)}\n{done.stderr.strip()}")
    rate = re.search(r"([0-9.]+) frames/s all-in", done.stdout)
    (out / "rate.txt").write_text(rate.group(1) if rate else "nan")
    return time.perf_counter() - start, out


def run_inside(
    case_dir: Path, spec: Spec, every: int, out: Path, extra: tuple[str, ...] = ()
) -> tuple[float, Path, dict]:
    """The one command a user types first: ``handvar track CAMS --calib calib.yml --out
    OUT --no-video [--keypoint-every K]`` (no keypoints, first pose, side or hand length
    given: the detector inside finds them; `extra`: more options); wall time (s), out
    dir, and the detector's own estimate as `mediapipe_keypoints` gives it, from what the
    track kept of it."""
    cams = [str(case_dir / f"cam{j}") for j in range(spec.cameras)]
    out.parent.mkdir(parents=True, exist_ok=True)
    env = dict(os.environ, PYTHONPATH=str(ROOT / "src"))
    cmd = [*HANDVAR, "track", ",".join(cams), "--calib", str(case_dir / "calib.yml"),
           "--keypoint-every", str(every), "--out", str(out), "--no-video", *extra]  # fmt: skip
    start = time.perf_counter()
    done = subprocess.run(cmd, capture_output=True, text=True, env=env)
    if done.returncode != 0:
        raise RuntimeError(f"{' '.join(cmd)}\n{done.stderr.strip()}")
    seconds = time.perf_counter() - start
    rate = re.search(r"([0-9.]+) frames/s all-in", done.stdout)
    (out / "rate.txt").write_text(rate.group(1) if rate else "nan")
    files = [out / "keypoints.npz"] if spec.cameras == 1 else [
        out / f"keypoints-{j}.npz" for j in range(spec.cameras)]  # fmt: skip
    xy, world = [], None
    for j, path in enumerate(files):
        kp = read_keypoints(path)
        xy.append(kp.xy)  # NaN where missing
        if j == 0 and kp.world is not None:
            world = np.where(kp.present[..., None], kp.world, np.nan)
    return seconds, out, {"xy": np.stack(xy), "world": world}


def mediapipe_keypoints(
    case_dir: Path, spec: Spec, python: str, with_world: bool = False, side: str = "given"
) -> tuple[list[Path], dict]:
    """MediaPipe Hands on the case's frames, as a user would run it (``handvar keypoints``
    in an environment with the ``mediapipe`` extra, `python`): per camera the (T, 21, 2)
    pixel file the tracker is given, ``mediapipe{j}.npy`` (`with_world`: the detector's
    ``.npz``: its world landmarks the fit's weak 3D cue), and the detector's own
    estimate: ``xy`` (n_cams, T, 21, 2) and camera 0's world landmarks ``world``
    (T, 21, 3) mm, NaN where no hand was found.  `side` "auto": ``--hand auto`` (the
    ``.npz``, with its handedness, given to the fit).  Kept in `case_dir` once made."""
    paths, xy, world = [], [], None
    auto = side == "auto"
    for j in range(spec.cameras):
        npz = case_dir / f"mediapipe{j}{'-auto' if auto else ''}.npz"
        if not npz.exists():
            cmd = [python, "-m", "handvar", "keypoints", str(case_dir / f"cam{j}"),
                   "--out", str(npz), "--hand", "auto" if auto else spec.side]  # fmt: skip
            done = subprocess.run(cmd, capture_output=True, text=True)
            if done.returncode != 0:
                raise RuntimeError(f"{' '.join(cmd)}\n{done.stderr.strip()}")
        kp = read_keypoints(npz)
        points = kp.xy  # NaN where missing
        np.save(case_dir / f"mediapipe{j}.npy", points)
        paths.append(npz if with_world or auto else case_dir / f"mediapipe{j}.npy")
        xy.append(points)
        if j == 0 and kp.world is not None:
            world = np.where(kp.present[..., None], kp.world, np.nan)
    return paths, {"xy": np.stack(xy), "world": world}


def project(rig, points: np.ndarray) -> np.ndarray:
    """(n_cams, T, 21, 2) pixels of (T, 21, 3) points; NaN on frames without a pose (a
    frame flagged without a hand: its points count as wrong in PCK)."""
    out = np.full((len(rig), *points.shape[:2], 2), np.nan)
    ok = np.isfinite(points).all(axis=(1, 2))
    for j, cam in enumerate(rig):
        out[j, ok] = cam.project(points[ok].reshape(-1, 3)).reshape(-1, 21, 2)
    return out


def fit_points(out: Path, side: str | None) -> tuple[np.ndarray, np.ndarray | None]:
    """The fit's scored points (T, 21, 3) mm from its poses through the hand it tracked
    with (`side` checked against it, unless None), and its lost flags (`check` for its
    keypoint check)."""
    track = Track.load(out)
    hand = track.hand  # the shape the track fitted (shape_fit), not the given one
    if side is not None and hand.shape.side != side:
        raise RuntimeError(f"{out}: tracked a {hand.shape.side} hand; expected {side}")
    lost = None if track.quality is None else np.asarray(track.quality.lost, dtype=bool)
    return scored_points(hand, track.poses), lost


def scored_points(hand, poses) -> np.ndarray:
    """(T, 21, 3) mm: the scored points of each pose (the detector's, fingertips at the
    pads) through `hand`; NaN where a pose is missing."""
    return np.stack([keypoint_points(hand, x, "pad") if np.isfinite(x).all()
                     else np.full((21, 3), np.nan) for x in poses])  # fmt: skip


def check(out: Path, every: int, gross: np.ndarray | None = None) -> dict[str, float]:
    """The fit's keypoint check (docs/keypoint-fit.md, "the check") over the frames whose
    detection it was given: frames failing it, and the keypoints it rejected; with
    `gross` ((T,) bool: a gross error in some camera), also the failing frames among
    those."""
    quality = Track.load(out).quality
    if quality is None:
        return {"fail": np.nan, "rej": np.nan}
    given = quality.keypoints & (np.arange(len(quality.lost)) % every == 0)
    _, _, rejected = quality.check(frames=given)
    row = {"fail": float(quality.failing(frames=given)), "rej": float(rejected)}
    if gross is not None:
        row["fail_gross"] = float(quality.failing(frames=given & gross[: len(given)]))
    return row


def scores(
    case, points_2d, points_3d, lost, seconds, truth_axes=None, out: Path | None = None
) -> dict[str, float]:
    """The table's figures of one estimate (module docstring).  `truth_axes`: a rotation
    the true joints are turned by before the 3D figures (a detector's 3D in the axes of
    camera 0); frames where the estimate has no point are left out of the 3D figures."""
    truth_2d = case.truth_2d.reshape(-1, 21, 2)
    est_2d = points_2d.reshape(-1, 21, 2)
    row = {"pck": pck_2d(truth_2d, est_2d), "px": mean_point_error(truth_2d, est_2d)[0]}
    row["frame_pck"] = frame_pck(case.truth_2d, points_2d)
    if points_3d is None:
        row.update(mpjpe=np.nan, pa=np.nan, auc=np.nan, abs=np.nan, accel=np.nan, lag=np.nan)
    else:
        truth = case.joints if truth_axes is None else case.joints @ np.asarray(truth_axes).T
        row["accel"] = acceleration_error(truth, points_3d)
        row["lag"] = lag(truth, points_3d)
        row["motion"] = (truth, points_3d)  # the overall lag pools the cases
        seen = np.isfinite(points_3d).all(axis=(1, 2))
        truth, points_3d = truth[seen], points_3d[seen]
        wrist = joint_errors(truth, points_3d, alignment="wrist")
        row.update(
            mpjpe=float(np.nanmean(wrist)),
            pa=float(np.nanmean(joint_errors(truth, points_3d, alignment="procrustes"))),
            auc=auc_pck_3d(wrist),
            abs=float(np.nanmean(joint_errors(truth, points_3d, alignment="none"))),
        )
    row["lost"] = float(np.sum(lost)) if lost is not None else np.nan
    row["ms"] = 1000.0 * seconds / case.n_frames if seconds is not None else np.nan
    rate = np.nan if out is None else float((out / "rate.txt").read_text())
    row["track_ms"] = 1000.0 / rate
    row["frames"] = case.n_frames
    return row


def frame_pck(truth_2d, points_2d) -> np.ndarray:
    """(T,) each frame's 2D PCK@0.2 over its cameras ((n_cams, T, 21, 2) pixels)."""
    truth = np.asarray(truth_2d).reshape(-1, *np.shape(truth_2d)[-3:])
    est = np.asarray(points_2d).reshape(truth.shape)
    hits = [[pck_2d(truth[j, t : t + 1], est[j, t : t + 1]) for j in range(len(truth))]
            for t in range(truth.shape[1])]  # fmt: skip
    return np.mean(hits, axis=1)


def print_by_offset(rows, every: int = 5) -> None:
    """2D PCK@0.2 by the frames since the detector's last frame (0 … `every` − 1), per
    rig, of the runs with the detector on every `every`-th frame: where the fit, the
    points carried by optical flow and the detections interpolated lose between the
    detections."""
    for rig in ("mono", "stereo"):
        for run in ("interpolated every 5", "carried every 5", "fit every 5"):
            hits = [r["frame_pck"] for c, k, r in rows
                    if k == run and f"-{rig}-" in c and "frame_pck" in r]  # fmt: skip
            if not hits:
                continue
            cells = ", ".join(f"{np.mean(np.concatenate([h[o::every] for h in hits])):.3f}"
                              for o in range(every))  # fmt: skip
            print(
                f"{rig}, {run}: PCK@0.2 on the frames 0, 1, ..., {every - 1} after the "
                f"detector's: {cells}"
            )


def failed_row(case) -> dict[str, float]:
    """The figures of a run that gave nothing: every frame lost, every point wrong."""
    return {"frames": case.n_frames, "lost": float(case.n_frames), "pck": 0.0, "failed": True}


def triangulated(case, xy: np.ndarray) -> np.ndarray:
    """(T, 21, 3) mm: each point of the first two cameras' detections triangulated on
    its own (``cv2.triangulatePoints``, the baseline of a user with two calibrated
    cameras); NaN where a camera has none."""
    import cv2

    a, b = case.rig.cameras[:2]
    P = [cam.K @ np.hstack([cam.R, cam.t.reshape(3, 1)]) for cam in (a, b)]
    pa, pb = xy[0].reshape(-1, 2), xy[1].reshape(-1, 2)
    ok = np.isfinite(pa).all(axis=1) & np.isfinite(pb).all(axis=1)
    out = np.full((len(pa), 3), np.nan)
    if ok.any():
        X = cv2.triangulatePoints(P[0], P[1], pa[ok].T.astype(float), pb[ok].T.astype(float))
        out[ok] = (X[:3] / X[3]).T
    return out.reshape(xy.shape[1], -1, 3)


RUNS = ("keypoints", "triangulated", "held every 5", "interpolated every 5", "carried every 5",
        "fit every 1", "fit every 5")  # fmt: skip
COLUMNS = (("pck", "PCK@0.2", "{:.3f}"), ("px", "2D px", "{:.1f}"), ("mpjpe", "MPJPE", "{:.1f}"),
           ("pa", "PA-MPJPE", "{:.1f}"), ("auc", "AUC 20-50", "{:.3f}"),
           ("abs", "abs 3D", "{:.1f}"), ("accel", "accel", "{:.2f}"),
           ("lag", "lag", "{:.1f}"), ("lost", "lost", "{:.0f}"), ("wrong", "wrong side", "{:.0f}"),
           ("fail", "check fails", "{:.0f}"), ("rej", "rejected", "{:.0f}"),
           ("track_ms", "ms/frame", "{:.1f}"), ("ms", "with start-up", "{:.0f}"))  # fmt: skip


def _print_gross_failures(rows) -> None:
    """With the simulated detector: of the frames failing the keypoint check, how many
    carry a gross error (`GROSS_KINDS`) in some camera, per rig and run."""
    for rig in ("mono", "stereo"):
        for run in RUNS[1:]:
            sel = [r for c, k, r in rows if k == run and f"-{rig}-" in c and "fail_gross" in r]
            if sel:
                gross = sum(r["fail_gross"] for r in sel)
                fail = sum(r["fail"] for r in sel)
                print(f"{rig}, {run}: {gross:.0f} of the {fail:.0f} frames failing the "
                      "keypoint check have a gross detector error in some camera")  # fmt: skip


def _cell(value, fmt: str) -> str:
    return "–" if value is None or not np.isfinite(value) else fmt.format(value)


def print_table(rows: list[tuple[str, str, dict]]) -> None:
    """Markdown table: case, run, then `COLUMNS`."""
    head = "| case | run | " + " | ".join(c[1] for c in COLUMNS) + " |"
    print(head)
    print("|---|---|" + "---:|" * len(COLUMNS))
    for case, run, r in rows:
        cells = " | ".join(_cell(r.get(k), f) for k, _, f in COLUMNS)
        print(f"| {case} | {run} | {cells} |", flush=True)


def overall(rows, label: str, keep) -> list[tuple[str, str, dict]]:
    """Frame-weighted means of the rows of each run whose case passes `keep`."""
    out = []
    for run in RUNS:
        sel = [r for c, k, r in rows if k == run and keep(c)]
        if not sel:
            continue
        w = np.array([r["frames"] for r in sel], dtype=float)
        agg = {}
        for key, _, _ in COLUMNS:
            v = np.array([r.get(key, np.nan) for r in sel], dtype=float)
            if key in ("lost", "fail", "rej", "wrong"):
                agg[key] = float(v.sum()) if np.isfinite(v).all() else np.nan
            elif key == "lag":  # one shift for all the cases' frames
                motion = [r["motion"] for r in sel if "motion" in r]
                truths, estimates = [m[0] for m in motion], [m[1] for m in motion]
                agg[key] = lag(truths, estimates) if motion else np.nan
            else:
                ok = np.isfinite(v)
                agg[key] = float(np.average(v[ok], weights=w[ok])) if ok.any() else np.nan
        out.append((f"**{label}** ({len(sel)} cases, {int(w.sum())} frames)", run, agg))
    return out


def baseline_rows(case, detector: dict, label: str, every_5th: bool = True) -> list:
    """What a user could do with the detector's output alone: its points and 3D, its
    points triangulated (two cameras), and (`every_5th`) its every 5th frame held or
    interpolated."""
    xy = detector["xy"]
    raw_lost = ~np.isfinite(xy[0]).all(axis=(1, 2))
    raw = scores(case, xy, detector["world"], raw_lost, None, truth_axes=case.rig.cameras[0].R)
    raw["abs"] = np.nan  # hand-centred: no absolute position
    rows = [(label, "keypoints", raw)]
    if xy.shape[0] > 1:
        points = triangulated(case, xy)
        lost = ~np.isfinite(points).all(axis=(1, 2))
        rows.append((label, "triangulated", scores(case, project(case.rig, points), points,
                                                   lost, None)))  # fmt: skip
    return rows if every_5th is False else rows + sparse_rows(case, xy, label)


def sparse_rows(case, xy: np.ndarray, label: str) -> list:
    """The detections (n_cams, T, 21, 2) of every 5th frame held, or interpolated between
    (`thinned`), as a user of a detector run on every 5th frame has them."""
    runs = (("held every 5", False), ("interpolated every 5", True))
    return [(label, run, scores(case, thinned(xy, 5, interpolate), None, None, None))
            for run, interpolate in runs]  # fmt: skip


def carried_row(case, case_dir: Path, xy: np.ndarray, label: str) -> tuple:
    """The detections (n_cams, T, 21, 2) of every 5th frame carried by optical flow to
    the frames between, both ways (`handvar.vision.carry.carry_keypoints`): what the fit
    is given there on a file."""
    from handvar.vision.carry import carry_keypoints
    from handvar.vision.keypoints import Keypoints2D

    frames = read_case(case_dir, frames=True).frames
    carried = np.full_like(xy, np.nan)
    for j, images in enumerate(frames):
        given = np.full((*xy.shape[1:3], 3), np.nan)
        given[::5] = np.concatenate([xy[j, ::5], np.ones((*xy[j, ::5].shape[:2], 1))], axis=2)
        bgr = (cv2.cvtColor(image, cv2.COLOR_RGB2BGR) for image in images)
        carried[j] = carry_keypoints(bgr, Keypoints2D.from_array(given), both=True, every=5).xy
    return label, "carried every 5", scores(case, carried, None, None, None)


def inside_rows(
    case, case_dir: Path, spec: Spec, base: Path, label: str, extra: tuple[str, ...] = ()
) -> list:
    """The rows of the one command (``--detector inside``; `extra`: more options): the
    detector's own points and 3D as the track kept them, and the fit, with the detector
    on every frame and on every 5th."""
    rows = []
    for every in (1, 5):
        out = base / "fits" / "-".join([spec.name, "inside", *extra[1::2], f"every{every}"])
        try:
            seconds, out, detector = run_inside(case_dir, spec, every, out, extra)
            if every == 1:
                rows += baseline_rows(case, detector, label, every_5th=False)
            else:  # the detections this run got: the detector's tracking sees every 5th
                rows += sparse_rows(case, detector["xy"], label)
                rows.append(carried_row(case, case_dir, detector["xy"], label))
            pts, lost = fit_points(out, None)  # the side it chose, scored as it is
            row = scores(case, project(case.rig, pts), pts, lost, seconds, out=out)
            row |= check(out, every)
            row["wrong"] = float(Track.load(out).hand.shape.side != spec.side)
        except RuntimeError as exc:  # scored as every frame lost
            print(f"{spec.name} every {every}: failed: {exc}", file=sys.stderr)
            row = failed_row(case)
        rows.append((label, f"fit every {every}", row))
    return rows


def pace(case) -> str:
    """How far the true joints move in 5 frames, in hand sizes (the wrist → middle-MCP
    length in camera 0's image): the mean over the joints and frames, and the mean of
    each frame's fastest joint."""
    p = case.truth_2d[0]
    size = np.linalg.norm(p[:-5, 9] - p[:-5, 0], axis=1)
    moved = np.linalg.norm(p[5:] - p[:-5], axis=2) / size[:, None]
    return f"{moved.mean():.2f} hand sizes (the fastest joint {moved.max(axis=1).mean():.2f})"


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--quick", action="store_true", help="four 30-frame cases (~1 min)")
    parser.add_argument("--out", type=Path, default=None, help="keep the cases in DIR")
    parser.add_argument("--cases", default="", help="only cases whose name contains this")
    motion = parser.add_mutually_exclusive_group()
    motion.add_argument(
        "--fast", action="store_true",
        help="the fast gestures' four cases instead (counting and spread at three times "
        "the pace, the palm moving with them)",
    )  # fmt: skip
    motion.add_argument(
        "--faster", action="store_true",
        help="the fast gestures' four cases at twice their pace instead",
    )  # fmt: skip
    parser.add_argument("--no-fit", action="store_true", help="score the raw keypoints only")
    parser.add_argument(
        "--detector", choices=("simulated", "mediapipe", "inside"), default="simulated",
        help="the keypoints given to the fit: the simulated detector's, or MediaPipe Hands "
        "run on the rendered frames (its 3D, the world landmarks, scored in the first row); "
        "inside: the one command, handvar track with the detector inside the pipeline and "
        "nothing else given (the detector's points as the track kept them in the first row)",
    )  # fmt: skip
    parser.add_argument(
        "--world", action="store_true",
        help="with --detector mediapipe: give the fit the detector's world landmarks too",
    )  # fmt: skip
    parser.add_argument(
        "--side", choices=("given", "auto"), default="given",
        help="auto: handvar keypoints, init and track with --hand auto (the detector's "
        ".npz with its handedness; with two cameras the hand's shape decides), the "
        "track's side scored as it is (wrong side)",
    )  # fmt: skip
    parser.add_argument(
        "--mediapipe-python", default=sys.executable,
        help="the Python of an environment with handvar[mediapipe] (default: this one)",
    )  # fmt: skip
    parser.add_argument(
        "--silhouette-term", type=float, default=0.0,
        help="σ of the keypoint fit's silhouette term, hand sizes (handvar track's option); "
        "0: off, the default",
    )  # fmt: skip
    parser.add_argument(
        "--predictor", default="",
        help="handvar track's motion predictor (default: its own default)",
    )  # fmt: skip
    args = parser.parse_args()
    extra = ("--silhouette-term", str(args.silhouette_term)) if args.silhouette_term else ()
    if args.predictor:
        extra += ("--predictor", args.predictor)

    motions = FASTER_MOTIONS if args.faster else FAST_MOTIONS if args.fast else CASE_MOTIONS
    todo = [s for s in specs(args.quick, motions) if args.cases in s.name]
    with tempfile.TemporaryDirectory() as tmp:
        base = args.out if args.out is not None else Path(tmp)
        base.mkdir(parents=True, exist_ok=True)
        rows: list[tuple[str, str, dict]] = []
        started = time.perf_counter()
        for spec in todo:
            case_dir = base / spec.name
            t0 = time.perf_counter()
            case = generate(spec, case_dir)
            gen = time.perf_counter() - t0
            print(f"{spec.name}: the joints move {pace(case)} in 5 frames")
            label = (f"{spec.name} ({spec.background}, {spec.distractor}, {spec.skin}, "
                     f"{case.n_frames} fr)")  # fmt: skip
            given = None  # the simulated detector's keypoints files
            if args.detector == "inside":
                rows += inside_rows(case, case_dir, spec, base, label, extra)
                continue
            if args.detector == "mediapipe":
                given, detector = mediapipe_keypoints(case_dir, spec, args.mediapipe_python,
                                                      args.world, args.side)  # fmt: skip
                # the fit every 5th frame is given these detections thinned
                rows += baseline_rows(case, detector, label)
            else:  # the simulated detector: its points, triangulated, every 5th frame
                rows += baseline_rows(case, {"xy": case.keypoints, "world": None}, label)
            if not args.no_fit:
                for every in (1, 5):
                    world = "-world" if args.world else ""
                    auto = ["auto"] if args.side == "auto" else []
                    name = "-".join([spec.name, args.detector + world, *auto, *extra[1::2]])
                    out = base / "fits" / f"{name}-every{every}"
                    try:
                        seconds, out = run_fit(case_dir, spec, every, out, given, extra,
                                               args.side)  # fmt: skip
                        pts, lost = fit_points(out, None if auto else spec.side)
                        proj = project(case.rig, pts)
                        row = scores(case, proj, pts, lost, seconds, out=out)
                        gross = None if given is not None else case.gross.any(axis=0)
                        row |= check(out, every, gross)
                        if auto:  # the side the commands chose, scored as it is
                            row["wrong"] = float(Track.load(out).hand.shape.side != spec.side)
                    except RuntimeError as exc:  # scored as every frame lost
                        print(f"{spec.name} every {every}: failed: {exc}", file=sys.stderr)
                        row = failed_row(case)
                    rows.append((label, f"fit every {every}", row))
            print(
                f"# {spec.name}: generated in {gen:.1f} s; "
                f"{time.perf_counter() - started:.0f} s so far",
                file=sys.stderr,
                flush=True,
            )
        rows += overall(rows, "mono", lambda c: "-mono-" in c)
        rows += overall(rows, "stereo", lambda c: "-stereo-" in c)
        rows += overall([r for r in rows if not r[0].startswith("**")], "all", lambda c: True)
        print_table(rows)
        _print_gross_failures(rows)
        print_by_offset([r for r in rows if not r[0].startswith("**")])
        print(f"\n{len(todo)} cases in {time.perf_counter() - started:.0f} s")


if __name__ == "__main__":
    main()
