"""Where the joint limits bind: recorded real motion, and the real videos' fits.

Run:  PYTHONPATH=src .venv/bin/python studies/joint_limits.py [--pip DEG]
          [--video NAME ...] [--hands DIR ...]

The 26 parameters are clamped to `handvar.params.LOWER` / `UPPER` after every step of
every fit.  This prints:

- the recorded hand pose sequence (``htrack-fingerfist.txt``, 6000 frames, mapped onto
  our parameters by `handvar.synth.motion.htrack_to_handvar`, not clamped): per
  parameter the share of frames below and above its limits and its range, and the
  share of frames with any parameter outside;
- each real video of ``examples/data`` tracked the one command's way
  (``handvar.track(VIDEO, scale=0.5)``, MediaPipe inside): the frames failing the
  keypoint check (`handvar.tracking.recovery.TrackQuality.check`), how many of them
  have a finger flexion (the four fingers' MCP, PIP, DIP) within 1° of its upper limit,
  and the same share over all frames with keypoints;
- with ``--hands DIR``: the same for each hand of a two-hand track directory
  (``handvar track ... --hands 2 --out DIR``, e.g. the composites of
  ``studies/two_hands_mirrored.py``);
- with ``--pip DEG``: the videos again with the fingers' PIP upper limit raised to DEG
  in this process (the limits every fit clamps with), to see whether the limit is what
  holds the fit off the keypoints.  No benchmark with ground truth can choose a limit
  here: the rendered benchmarks' motions are clamped to these limits themselves.
"""

from __future__ import annotations

import argparse
from contextlib import contextmanager
from pathlib import Path

import numpy as np

import handvar
from handvar import params
from handvar.data import example_path
from handvar.params import LOWER, NAMES, UPPER
from handvar.pipeline import HandsTrack
from handvar.synth.motion import htrack_to_handvar

VIDEOS = ("video", "fingerspelling", "counting")
FINGER_FLEXIONS = np.array([NAMES.index(f"{d}_{j}") for d in ("index", "middle", "ring", "little")
                            for j in ("mcp", "pip", "dip")])  # fmt: skip
AT_LIMIT = 1.0  # degrees


def recorded_motion() -> None:
    x = htrack_to_handvar(np.loadtxt(example_path("htrack")))
    below, above = x < LOWER - 1e-9, x > UPPER + 1e-9
    print(f"recorded motion (htrack fingerfist, {len(x)} frames): "
          f"{np.mean((below | above).any(axis=1)):.1%} of the frames have a parameter "
          f"outside its limits")  # fmt: skip
    for i in np.flatnonzero((below | above).any(axis=0)):
        print(f"  {NAMES[i]:12s} limits [{LOWER[i]:g}, {UPPER[i]:g}]: below on "
              f"{below[:, i].mean():.1%}, above on {above[:, i].mean():.1%}, "
              f"range {x[:, i].min():.1f} to {x[:, i].max():.1f}")  # fmt: skip


def at_limits(name: str, track) -> None:
    """Print `track`'s failing frames and the finger flexions at their upper limits."""
    q = track.quality
    frames = q.keypoints
    failing = q.failing_frames(frames=frames)
    poses = track.poses[:, FINGER_FLEXIONS]
    limited = (poses >= UPPER[FINGER_FLEXIONS] - AT_LIMIT).any(axis=1)
    n_fail = int(failing.sum())
    print(f"  {name}: fails the check on {n_fail} of {int(frames.sum())} frames with "
          f"keypoints (under 98 % of its kept keypoints within 0.2 hand sizes: "
          f"{np.flatnonzero(failing).tolist()}); a finger flexion at its upper limit on "
          f"{int((failing & limited).sum())} of them, on "
          f"{np.mean(limited[frames]):.1%} of all frames with keypoints")  # fmt: skip


@contextmanager
def pip_limit(degrees: float):
    """The fingers' PIP upper limit raised to `degrees` in this process."""
    keys = [NAMES.index(f"{d}_pip") for d in ("index", "middle", "ring", "little")]
    saved = params.UPPER[keys].copy()
    params.UPPER.flags.writeable = True
    params.UPPER[keys] = degrees
    try:
        yield
    finally:
        params.UPPER[keys] = saved
        params.UPPER.flags.writeable = False


def videos(names, label: str) -> None:
    print(label)
    for name in names:
        track = handvar.track(example_path(name), scale=0.5)
        at_limits(name, track)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--video", nargs="*", default=list(VIDEOS), choices=list(VIDEOS))
    parser.add_argument("--hands", nargs="*", type=Path, default=[], metavar="DIR")
    parser.add_argument("--pip", type=float, default=None, metavar="DEG")
    args = parser.parse_args()
    recorded_motion()
    for directory in args.hands:
        print(f"two-hand track {directory}")
        hands = HandsTrack.load(directory)
        for track in sorted(hands.tracks.values(), key=lambda t: t.shape.side):
            at_limits(track.shape.side, track)
    videos(args.video, "the real videos, the one command's way (scale 0.5, MediaPipe inside)")
    if args.pip is not None:
        with pip_limit(args.pip):
            videos(args.video, f"the same with the fingers' PIP limit at {args.pip:g}°")


if __name__ == "__main__":
    main()
