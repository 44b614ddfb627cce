"""Can MediaPipe's world landmarks give the hand's size from one camera?

The depth of a hand seen by one camera follows the size the fit assumes.  MediaPipe
gives metric 3D points (its world landmarks); if their scale followed the person's
hand, they could set the model's size.  On the realistic benchmark's renders (hands of
172–196 mm, `studies/realistic.py --out DIR --detector inside` writes the cases and the
one command's tracks with MediaPipe's points in ``keypoints.npz``), this prints per case
the true wrist → middle-MCP length and MediaPipe's (median over the frames), their
ratio, and the correlation of the two over the cases.

    PYTHONPATH=src python studies/world_size.py --cases DIR
"""

from __future__ import annotations

import argparse
from pathlib import Path

import numpy as np

from handvar.hand.anthropometry import MIDDLE_MCP, WRIST
from handvar.vision.keypoints import read_keypoints


def palm_length(points: np.ndarray) -> float:
    """Median over frames of the wrist → middle-MCP distance of (T, 21, 3) points."""
    return float(np.nanmedian(np.linalg.norm(points[:, MIDDLE_MCP] - points[:, WRIST], axis=1)))


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--cases", required=True, type=Path)
    args = parser.parse_args()
    true, seen = [], []
    print(f"{'case':<28} {'hand mm':>7} {'true W-MMCP':>11} {'MediaPipe':>9} {'ratio':>6}")
    for truth in sorted(args.cases.glob("*/truth.npz")):
        name = truth.parent.name
        fits = args.cases / "fits" / f"{name}-inside-every1"
        files = sorted(fits.glob("keypoints*.npz"))
        if not files:
            continue
        with np.load(truth) as z:
            t, length = palm_length(z["joints"]), float(z["hand_length"])
        m = palm_length(read_keypoints(files[0]).world)
        true.append(t)
        seen.append(m)
        print(f"{name:<28} {length:>7.0f} {t:>11.1f} {m:>9.1f} {m / t:>6.3f}")
    true, seen = np.array(true), np.array(seen)
    ratio = seen / true
    print(f"ratio MediaPipe / true: median {np.median(ratio):.3f}, range "
          f"{ratio.min():.3f}-{ratio.max():.3f}; correlation over the cases "
          f"{np.corrcoef(true, seen)[0, 1]:.2f}")  # fmt: skip


if __name__ == "__main__":
    main()
