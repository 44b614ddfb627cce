"""Where the detector marks a fingertip: how far the hand reaches beyond it (design §14.6).

On the example video (``examples/data/dex-human-hand-video.mp4``, scale 0.5) and its
MediaPipe keypoints (every frame), for every straight digit (the detected DIP → tip
direction within 25° of MCP → PIP) the ray from the detected tip along DIP → tip is
followed until it leaves

- the skin silhouette (`VideoSource.silhouettes`, forearm on): the *overshoot*, pixels
  and hand sizes (the detected wrist → middle-MCP distance in that frame);
- the image's fingertip edge: the strongest grey-level gradient along the same ray, up
  to 6 px beyond the silhouette's end (grey levels smoothed with σ = 0.7 px, every 3rd
  frame): whether the silhouette ends where the finger does (a halo or a bite would
  show as an offset).

Rays that leave the image or never leave the silhouette within 40 px (a finger in
front of the palm) are not counted.  For comparison the model's fingertip radius per
digit in its hand sizes (`HandShape.radii`, tip column, over |G_0 − G_9|): a
correspondence that puts the detected tip at the centre of the model's fingertip pad
expects an overshoot of one tip radius.

Run: ``PYTHONPATH=src .venv/bin/python studies/fingertips.py`` (``--at 555,565`` also
prints the overshoot of every digit in those frames, straight or not).
"""

from __future__ import annotations

import argparse

import cv2
import numpy as np

from handvar.data import example_path
from handvar.hand import HandModel
from handvar.tracking.keypoint_cost import hand_length
from handvar.vision.keypoints import read_keypoints
from handvar.vision.sources import open_source

VIDEO = example_path("video")
KEYPOINTS = example_path("video-keypoints")
TIP, DIP = [4, 8, 12, 16, 20], [3, 7, 11, 15, 19]
PIP, MCP = [2, 6, 10, 14, 18], [1, 5, 9, 13, 17]
DIGITS = ("thumb", "index", "middle", "ring", "little")
PHASES = ((0, 250, "open, 0-249"), (250, 300, "fist, 250-299"),
          (300, 459, "turning, 300-458"), (459, 621, "edge-on, 459-620"))  # fmt: skip


def overshoot(mask: np.ndarray, tip: np.ndarray, u: np.ndarray, reach: float = 40.0) -> float:
    """Distance along `u` from `tip` to the first pixel outside `mask`; NaN if none."""
    h, w = mask.shape
    for s in np.arange(0.0, reach, 0.25):
        x, y = np.round(tip + s * u).astype(int)
        if not (0 <= x < w and 0 <= y < h):
            return np.nan  # left the image first
        if not mask[y, x]:
            return float(s)
    return np.nan


def edge(gray: np.ndarray, tip: np.ndarray, u: np.ndarray, end: float) -> float:
    """Position along `u` of the strongest grey-level gradient in [0, end + 6] px."""
    s = np.arange(0.0, end + 6.0, 0.25)
    p = (tip + s[:, None] * u).astype(np.float32)
    values = cv2.remap(gray, p[None, :, 0], p[None, :, 1], cv2.INTER_LINEAR)[0]
    return float(s[np.argmax(np.abs(np.gradient(values, s)))])


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--at", default="", help="frames (comma-separated) to print per digit")
    at = {int(t) for t in parser.parse_args().at.split(",") if t}
    source = open_source(VIDEO, scale=0.5)
    truth = source.scaled_keypoints([read_keypoints(KEYPOINTS)])[0]
    rows, edges = [], []
    for t, frames, masks in source.silhouettes(wrist=False, allow_empty=True):
        m, k = np.asarray(masks[0]), truth.frame(t)
        if k is None or not m.any() or not np.all(k[:, 2] > 0):
            continue
        size = float(np.linalg.norm(k[9, :2] - k[0, :2]))
        if t in at:
            each = [
                overshoot(m, k[TIP[d], :2], (k[TIP[d], :2] - k[DIP[d], :2])
                          / np.linalg.norm(k[TIP[d], :2] - k[DIP[d], :2]))
                for d in range(5)
            ]  # fmt: skip
            print(f"  frame {t}: px beyond the detected tip, thumb to little {np.round(each, 1)}")
        gray = None
        for d in range(5):
            tip, dip = k[TIP[d], :2], k[DIP[d], :2]
            u = (tip - dip) / np.linalg.norm(tip - dip)
            v = k[PIP[d], :2] - k[MCP[d], :2]
            if u @ v < np.cos(np.radians(25.0)) * np.linalg.norm(v):
                continue  # a bent digit: its tip points elsewhere
            o = overshoot(m, tip, u)
            if np.isnan(o):
                continue
            rows.append((t, d, o, o / size))
            if t % 3 == 0:
                if gray is None:
                    g = cv2.cvtColor(np.asarray(frames[0]), cv2.COLOR_BGR2GRAY)
                    gray = cv2.GaussianBlur(g.astype(np.float32), (0, 0), 0.7)
                edges.append(o - edge(gray, tip, u, o))
    r = np.array(rows)
    hand = HandModel()
    model = hand.shape.radii[:, 3] / hand_length(hand)
    print(
        f"example video, scale 0.5: {len(r)} straight digits with a measured overshoot "
        f"in {len(np.unique(r[:, 0]))} frames"
    )
    q = np.percentile(r[:, 2], [25, 50, 75])
    print(
        f"  silhouette beyond the detected tip: median {q[1]:.1f} px (IQR {q[0]:.1f}-{q[2]:.1f}),"
        f" {np.median(r[:, 3]):.3f} hand sizes"
    )
    for lo, hi, name in PHASES:
        s = (r[:, 0] >= lo) & (r[:, 0] < hi)
        print(f"    {name}: n {s.sum()}, {np.median(r[s, 3]):.3f} hand sizes")
    for d, name in enumerate(DIGITS):
        s = r[:, 1] == d
        print(
            f"    {name}: n {s.sum()}, {np.median(r[s, 3]):.3f} hand sizes "
            f"(model tip radius {model[d]:.3f})"
        )
    e = np.percentile(edges, [25, 50, 75])
    print(
        f"  silhouette end minus image edge: median {e[1]:+.2f} px (IQR {e[0]:+.2f} to "
        f"{e[2]:+.2f}), {len(edges)} rays"
    )


if __name__ == "__main__":
    main()
