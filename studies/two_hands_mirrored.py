"""Both hands on real pixels: each real video beside its mirror image, by the one command.

Usage: PYTHONPATH=src python studies/two_hands_mirrored.py --out DIR [--video NAME ...]
       [--scale S] [--gap PX] [--pasted]

No real recording of two hands with ground truth ships with handvar.  This study makes
one whose identities are known without labelling: each real one-hand video of
``examples/data`` is put beside its own mirror image (frame | ``--gap`` grey columns |
flipped frame), so the real hand is on one half and a hand of the other side, the same motion
mirrored, on the other; they never cross the middle.  Each half is the frame as the
wider camera would film the scene turned towards it (`mirrored_video`: warped by the
rotation's homography), or with ``--pasted`` the frame as it is.  It is tracked as a user would,
``handvar track VIDEO --hands 2 --scale S --fov F --out DIR --no-video`` (MediaPipe
inside; F gives each half the focal length assumed for the video alone), and read
back with `handvar.pipeline.HandsTrack.load`.  Printed per video:

- identity switches: per hand, the changes of the half its fitted points lie in (mean
  x), over the frames it is drawn; beside them the detector alone's, MediaPipe run on
  the full-size composite with its handedness label taken as the identity;
- hands drawn on the wrong half: frames where both hands (or both labels) lie on one
  half, and frames
  where a hand is drawn though MediaPipe found no hand on the video alone (its points
  shipped beside the video, ``*-mediapipe.npz``; the dex video has none and is
  skipped for this);
- each hand's keypoint check (`handvar.tracking.recovery.TrackQuality.check`: on
  every frame with a detection the joints within 0.2 hand sizes of 98 % of the
  keypoints kept), the frames it fails on, the farthest keypoint and the one most
  often beyond 0.2 hand sizes;
- mirror agreement: the composite is its own mirror image about its middle column and
  the assumed camera's principal point lies on it, so the scene is symmetric about the
  camera's x = 0 plane; the right hand's joints against the left hand's with x negated
  (mm, mean over joints and the frames both are drawn), wrist-relative and absolute.
  It measures how differently the pipeline treats one image and its mirror (MediaPipe
  included), not accuracy;
- the command's frames/s all-in (start to exit, as a process).

The shipped videos are sanity checks: no rule or constant is chosen here.
"""

from __future__ import annotations

import argparse
import subprocess
import sys
import time
from pathlib import Path

import cv2
import numpy as np

DATA = Path(__file__).resolve().parents[1] / "examples" / "data"
VIDEOS = {
    "dex": "dex-human-hand-video.mp4",
    "fingerspelling": "tfjs-asl-hand.mp4",
    "counting": "boreep-counting.mp4",
}


def mirrored_video(src: Path, dst: Path, gap: int = 0, pasted: bool = False) -> int:
    """Write `src` beside its mirror image, `gap` grey columns between, to `dst` (MP4);
    its width.

    By default each half is what the composite's camera (the video's assumed focal
    length, `handvar.vision.sources.SOURCE_SETTINGS`) sees of the scene when the video's
    own camera is turned by the angle of that half's centre: the frame warped by the
    rotation's homography K R K⁻¹, as a wider camera would film the same hand off its
    axis.  With `pasted` the frames are placed side by side as they are, which no
    pinhole camera films: an off-axis hand is stretched by up to 1 / cos² of its angle.
    """

    cap = cv2.VideoCapture(str(src))
    fps = cap.get(cv2.CAP_PROP_FPS) or 30.0
    writer, width, warp = None, 0, None
    while True:
        ok, frame = cap.read()
        if not ok:
            break
        h, w = frame.shape[:2]
        width = 2 * w + gap
        if pasted:
            middle = np.full((h, gap, 3), 128, np.uint8)
            both = np.hstack([frame, middle, cv2.flip(frame, 1)])
        else:
            if warp is None:
                warp = turned_homography((w, h), width)
            left = cv2.warpPerspective(frame, warp, (width, h), flags=cv2.INTER_LINEAR,
                                       borderValue=(128, 128, 128))  # fmt: skip
            both = np.where(np.arange(width)[None, :, None] < w, left, 128).astype(np.uint8)
            both[:, w + gap :] = cv2.flip(both, 1)[:, w + gap :]
        if writer is None:
            fourcc = cv2.VideoWriter_fourcc(*"mp4v")
            writer = cv2.VideoWriter(str(dst), fourcc, fps, (width, both.shape[0]))
        writer.write(both)
    cap.release()
    writer.release()
    return width


def wide_fov(w: int, width: int) -> float:
    """Horizontal field of view (degrees) of a frame `width` wide whose focal length is
    the one assumed for a frame `w` wide (`SOURCE_SETTINGS.fov`)."""
    from handvar.vision.sources import SOURCE_SETTINGS

    return float(2 * np.degrees(np.arctan(width / w * np.tan(np.radians(SOURCE_SETTINGS.fov) / 2))))


def turned_homography(size: tuple[int, int], width: int) -> np.ndarray:
    """(3, 3) the homography K_wide R K⁻¹ from a frame of `size` (w, h) to the left half
    of a frame `width` wide, both cameras as handvar assumes them (`Camera.assumed`, one
    focal length): the camera turned about its centre by the angle at which the wide
    one sees its left half's centre (the frame's centre lands there)."""
    from handvar.camera import Camera
    from handvar.vision.sources import SOURCE_SETTINGS

    w, h = size
    alone = Camera.assumed((w, h), fov=SOURCE_SETTINGS.fov)
    wide = Camera.assumed((width, h), fov=wide_fov(w, width))
    angle = np.arctan((wide.cx - alone.cx) / wide.fx)
    c, s = np.cos(angle), np.sin(angle)
    turn = np.array([[c, 0.0, -s], [0.0, 1.0, 0.0], [s, 0.0, c]])
    return wide.K @ turn @ np.linalg.inv(alone.K)


def reference_presence(name: str, n: int) -> np.ndarray | None:
    """(n,) bool: frames where MediaPipe found a hand on the video alone, or None."""
    path = DATA / VIDEOS[name].replace(".mp4", "-mediapipe.npz")
    if not path.exists():
        return None
    with np.load(path, allow_pickle=False) as z:
        seen = np.isfinite(z["landmarks_px"]).any(axis=(1, 2))
    return seen[:n] if len(seen) >= n else None


def label_halves(video: Path, width: int) -> dict:
    """MediaPipe Hands on every frame of `video` (full size), each detection's label
    taken as its identity, as a user of the detector alone would: per label, (T,) the
    half its points lie on (0 left, 1 right, -1 without a detection of that label; of
    two, the higher score's)."""
    from handvar.vision.mediapipe import MediaPipeHands

    rows = []
    detect = MediaPipeHands()
    cap = cv2.VideoCapture(str(video))
    while True:
        ok, frame = cap.read()
        if not ok:
            break
        best: dict = {}
        for d in detect(frame):
            if d.side and d.score > best.get(d.side, (-1.0, 0))[0]:
                best[d.side] = (d.score, int(np.nanmean(d.points[:, 0]) >= width / 2))
        rows.append({side: h for side, (_, h) in best.items()})
    cap.release()
    detect.close()
    return {side: np.array([r.get(side, -1) for r in rows]) for side in ("left", "right")}


def identity_errors(half: dict) -> tuple[int, int]:
    """Identity switches (per identity, the changes of its half over the frames it is
    drawn, gaps bridged) and frames with both identities on one half, of `half`: per
    identity, (T,) 0 / 1 / -1 (not drawn)."""
    switches = 0
    for h in half.values():
        seen = h[h >= 0]
        switches += int(np.count_nonzero(seen[1:] != seen[:-1]))
    same_half = 0
    if len(half) == 2:
        a, b = half.values()
        same_half = int(np.count_nonzero((a >= 0) & (a == b)))
    return switches, same_half


def study(name: str, out: Path, scale: float, gap: int, pasted: bool = False,
          silhouette_term: float = 0.0) -> None:  # fmt: skip
    from handvar.pipeline import HandsTrack
    from handvar.tracking.frame_fit import CHECK_THRESHOLD
    from handvar.vision.keypoints import KEYPOINT_NAMES

    video = out / f"{name}-mirrored.mp4"
    width = mirrored_video(DATA / VIDEOS[name], video, gap, pasted)
    target = out / name
    # each half seen by the camera assumed for the video alone (its focal length)
    fov = wide_fov((width - gap) // 2, width)
    command = [sys.executable, "-m", "handvar", "track", str(video), "--hands", "2",
               "--scale", str(scale), "--fov", f"{fov:.4f}", "--out", str(target),
               "--no-video", "--silhouette-term", str(silhouette_term)]  # fmt: skip
    t0 = time.perf_counter()
    run = subprocess.run(command, capture_output=True, text=True)
    seconds = time.perf_counter() - t0
    if run.returncode:
        print(f"{name}: the command failed: {run.stderr.strip().splitlines()[-1:]}")
        return
    hands = HandsTrack.load(target)
    T = hands.n_frames
    half, drawn = {}, {}
    for track in hands.tracks.values():
        side = track.shape.side
        u = track.projected[0, :, :, 0]  # full-resolution pixels
        seen = np.isfinite(u).any(axis=1)
        x = np.full(len(u), np.nan)
        x[seen] = np.nanmean(u[seen], axis=1)
        drawn[side] = np.isfinite(x) & ~track.quality.no_hand
        half[side] = np.where(drawn[side], (x >= width / 2).astype(int), -1)
    switches, same_half = identity_errors(half)
    label_switches, label_same = identity_errors(label_halves(video, width))
    reference = reference_presence(name, T)
    phantom = "-"
    if reference is not None:
        phantom = str(sum(int(np.count_nonzero(d & ~reference)) for d in drawn.values()))
    checks = []
    for side, track in sorted((t.shape.side, t) for t in hands.tracks.values()):
        frames = track.quality.keypoints  # every frame with keypoints: all detected here
        ok, worst, _ = track.quality.check(frames=frames)
        failing = track.quality.failing(frames=frames)
        d = track.quality.distances[frames]  # (n, n_cams, 21) hand sizes
        far = (np.nan_to_num(d, nan=0.0) > CHECK_THRESHOLD).sum(axis=(0, 1))
        most = f"; most often off: {KEYPOINT_NAMES[int(far.argmax())]}" if far.any() else ""
        checks.append(f"{side} {'holds' if ok else 'FAILS'} (fails on {failing} of "
                      f"{int(frames.sum())} frames with a detection; worst "
                      f"{100 * worst:.1f} %; farthest keypoint {np.nanmax(d):.2f} hand "
                      f"sizes{most})")  # fmt: skip
    mirror = "-"
    if len(hands.tracks) == 2:
        left, right = hands.side("left").joints, hands.side("right").joints
        m = left * np.array([-1.0, 1.0, 1.0])
        both = drawn["left"] & drawn["right"]
        both &= np.isfinite(m).all(axis=(1, 2)) & np.isfinite(right).all(axis=(1, 2))
        if both.any():
            absolute = np.linalg.norm(m[both] - right[both], axis=-1).mean()
            rel = np.linalg.norm((m[both] - m[both, :1]) - (right[both] - right[both, :1]),
                                 axis=-1).mean()  # fmt: skip
            mirror = f"{rel:.1f} / {absolute:.1f} mm over {int(both.sum())} frames"
    print(
        f"{name}: {T} frames, {width} px wide, {T / seconds:.1f} frames/s all-in; "
        f"hands {sorted(half)}; identity switches: MediaPipe's labels {label_switches}, "
        f"fit {switches}; frames with both on one half: labels {label_same}, fit "
        f"{same_half}; drawn where MediaPipe found no hand alone {phantom}; keypoint "
        f"check: {'; '.join(checks)}; mirror disagreement wrist-relative / absolute "
        f"{mirror}",
        flush=True,
    )


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", type=Path, required=True)
    parser.add_argument("--video", nargs="*", default=list(VIDEOS), choices=list(VIDEOS))
    parser.add_argument("--scale", type=float, default=0.5)
    parser.add_argument("--gap", type=int, default=64,
                        help="grey columns between a frame and its mirror image")  # fmt: skip
    parser.add_argument("--pasted", action="store_true",
                        help="the frames side by side as they are, not as the wider camera "
                             "turned would film them")  # fmt: skip
    parser.add_argument("--silhouette-term", type=float, default=0.0,
                        help="the command's --silhouette-term (each hand its share of the "
                             "skin; 0: off)")  # fmt: skip
    args = parser.parse_args()
    args.out.mkdir(parents=True, exist_ok=True)
    for name in args.video:
        study(name, args.out, args.scale, args.gap, args.pasted, args.silhouette_term)


if __name__ == "__main__":
    main()
