"""Both hands, all in: ``handvar track VIDEO --hands 2 --out DIR --no-video`` at 640×360.

Renders the two-hand benchmark's scenarios (`handvar.evaluation.two_hands`, seed 0,
640×360, 125 frames each) into MP4 files, then tracks each by the command a user types
— MediaPipe inside the pipeline, asked for two hands — as a separate process, timed
from its start to its exit (Python's start-up, the imports, decoding, detection, both
fits and the files written).  Prints per scenario the frames, the wall time, the
frames/s all-in and the command's own summary line; first, the same command on the
first 5 frames of the first scenario, three times: what a run costs besides its frames
(start-up, the detector's processes, the first fits, exit).

    python benchmarks/two_hands.py [--scenario cross clap ...]
"""

from __future__ import annotations

import argparse
import tempfile
from pathlib import Path

import cv2

from _command import timed_track


def _video(case, path: Path, frames: int | None = None) -> None:
    h, w = case.frames.shape[2:4]
    writer = cv2.VideoWriter(str(path), cv2.VideoWriter_fourcc(*"mp4v"), case.fps, (w, h))
    for rgb in case.frames[0, :frames]:
        writer.write(cv2.cvtColor(rgb, cv2.COLOR_RGB2BGR))
    writer.release()


def main() -> None:
    from handvar.evaluation.two_hands import SCENARIOS, two_hand_case

    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--scenario", nargs="*", default=list(SCENARIOS))
    args = parser.parse_args()
    total_frames, total_seconds = 0, 0.0
    with tempfile.TemporaryDirectory() as tmp:
        short = Path(tmp) / "short.mp4"
        _video(two_hand_case(args.scenario[0], seed=0), short, frames=5)
        fixed = [
            timed_track(short, "--hands", "2", "--out", Path(tmp) / "short")[0] for _ in range(3)
        ]
        print(f"the command on 5 frames ({args.scenario[0]}): "
              f"{', '.join(f'{s:.2f}' for s in fixed)} s", flush=True)  # fmt: skip
        for scenario in args.scenario:
            case = two_hand_case(scenario, seed=0)
            video = Path(tmp) / f"{scenario}.mp4"
            _video(case, video)
            seconds, line = timed_track(video, "--hands", "2", "--out", Path(tmp) / scenario)
            n = case.n_frames
            total_frames, total_seconds = total_frames + n, total_seconds + seconds
            print(f"{scenario:<8} {n} frames 640x360: {seconds:5.1f} s, {n / seconds:5.1f} "
                  f"frames/s all-in  [{line}]", flush=True)  # fmt: skip
    print(
        f"all: {total_frames} frames in {total_seconds:.1f} s, "
        f"{total_frames / total_seconds:.1f} frames/s all-in (process start to exit)"
    )


if __name__ == "__main__":
    main()
