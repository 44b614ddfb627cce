"""The one command, all in: ``handvar track FRAMES --scale 0.5 --out DIR --no-video``.

Each of the three real videos (examples/data: the example video, 621 frames; the
fingerspelling clip, 325; the counting clip, 394) is tracked by the command a user
types first — the detector inside the pipeline (MediaPipe Hands), no keypoint file —
as a separate process, timed from its start to its exit: Python's start-up, the
imports, decoding, detection, the fit and the files written.  The frames are given as
the video file and as a folder of 1280×720 images (PNG, and JPEG with ``--jpeg``),
as a recording with no video container would be.  Printed per run: frames, wall
time, frames/s all-in, and the command's own summary line's rate.

``--cold`` runs each video file twice with numba's cache in a new, empty folder
(``NUMBA_CACHE_DIR``): the first run compiles the package's loops, as the first run
after ``pip install`` does (``make`` compiles them once when it installs), the second
finds them.

    python benchmarks/one_command.py [--videos example counting] [--jpeg] [--folders-only]
    python benchmarks/one_command.py --cold [--videos fingerspelling]
"""

from __future__ import annotations

import argparse
import re
import tempfile
from pathlib import Path

import cv2

from _command import timed_track
from handvar.data import example_path

VIDEOS = {"example": "video", "fingerspelling": "fingerspelling", "counting": "counting"}


def _folder(video: Path, folder: Path, suffix: str) -> int:
    folder.mkdir()
    cap = cv2.VideoCapture(str(video))
    n = 0
    while True:
        ok, image = cap.read()
        if not ok:
            break
        cv2.imwrite(str(folder / f"{n:05d}{suffix}"), image)
        n += 1
    cap.release()
    return n


def _run(source: Path, out: Path, env: dict | None = None) -> tuple[float, str]:
    return timed_track(source, "--scale", "0.5", "--out", out, env=env)


def _cold(names: list[str], tmp: Path) -> None:
    """Each video file with numba's cache empty, then again with it filled."""
    for name in names:
        video = example_path(VIDEOS[name])
        n = int(cv2.VideoCapture(str(video)).get(cv2.CAP_PROP_FRAME_COUNT))
        cache = {"NUMBA_CACHE_DIR": str(tmp / f"{name}-numba")}
        for kind in ("cold", "warm"):
            _print(name, kind, n, *_run(video, tmp / f"{name}-{kind}", cache))


def _print(name: str, kind: str, n: int, seconds: float, line: str) -> None:
    """One run's row: frames, wall time, frames/s all-in and the summary line's rate."""
    rate = re.search(r"([\d.]+) frames/s all-in", line).group(1)
    print(f"{name:<15} {kind:<8} {n:>6} {seconds:>7.1f} {n / seconds:>9.1f}  {rate}")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--videos", nargs="+", default=list(VIDEOS), choices=list(VIDEOS))
    parser.add_argument("--jpeg", action="store_true", help="JPEG frames instead of PNG")
    parser.add_argument("--folders-only", action="store_true")
    parser.add_argument("--cold", action="store_true",
                        help="each video file with numba's cache empty, then filled")  # fmt: skip
    args = parser.parse_args()
    suffix = ".jpg" if args.jpeg else ".png"
    print(f"{'video':<15} {'as':<8} {'frames':>6} {'wall s':>7} {'frames/s':>9}  "
          f"summary line's rate")  # fmt: skip
    with tempfile.TemporaryDirectory() as tmp:
        if args.cold:
            _cold(args.videos, Path(tmp))
            return
        for name in args.videos:
            video = example_path(VIDEOS[name])
            folder = Path(tmp) / f"{name}-frames"
            n = _folder(video, folder, suffix)
            sources = [(suffix[1:], folder)]
            if not args.folders_only:
                sources.insert(0, ("video", video))
            for kind, source in sources:
                _print(name, kind, n, *_run(source, Path(tmp) / f"{name}-{kind}"))


if __name__ == "__main__":
    main()
