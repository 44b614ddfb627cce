"""Latency and dropped frames of real-time tracking on the example video.

Plays the example video at its own frame rate (30 fps) through `handvar.track(...,
realtime=True)`: the tracker takes the newest frame each time it is free and the
others are dropped (docs/live-and-batch.md). Prints the latency from a frame's capture
to its pose (median, 95th percentile, maximum, over the frames tracked), the share of
frames dropped, and the tracker's own time per tracked frame — with the shipped
keypoints (the default) or without (``--no-keypoints``: the first pose is then searched
in the silhouette, which takes seconds).

The figures depend on the machine and on its load; a shared machine gives longer
latencies and more drops.

    python benchmarks/realtime.py [--frames 150] [--scale 0.25] [--no-keypoints]
"""

from __future__ import annotations

import argparse
import os
import time

import numpy as np

from handvar import track
from handvar.data import example_path


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--frames", type=int, default=150, help="frames played")
    parser.add_argument("--scale", type=float, default=0.25, help="resize factor of the frames")
    parser.add_argument("--no-keypoints", action="store_true", help="silhouettes only")
    args = parser.parse_args()

    keypoints = None if args.no_keypoints else str(example_path("video-keypoints"))
    clock = time.perf_counter()
    result = track(
        str(example_path("video")), keypoints=keypoints, scale=args.scale, frames=args.frames,
        realtime=True,
    )  # fmt: skip
    wall = time.perf_counter() - clock
    tracked = ~result.dropped
    ms = 1000.0 * result.latency[tracked]
    fit = 1000.0 * result.fit_seconds[tracked]
    print(
        f"example video, {result.n_frames} frames at {result.fps:g} fps, scale {args.scale}, "
        f"{'with' if keypoints else 'without'} keypoints; {os.cpu_count()} cores, load "
        f"{os.getloadavg()[0]:.1f}; {wall:.1f} s wall"
    )
    print(result.realtime_summary())
    print(
        f"latency ms: median {np.median(ms):.0f}, 95 % {np.percentile(ms, 95):.0f}, "
        f"max {ms.max():.0f}; after the first frame: median {np.median(ms[1:]):.0f}"
        if ms.size > 1
        else f"latency ms: {ms[0]:.0f} (one frame tracked)"
    )
    print(
        f"dropped: {int(result.dropped.sum())} of {result.n_frames} "
        f"({100.0 * result.dropped.mean():.0f} %); tracker time per tracked frame: median "
        f"{np.median(fit):.0f} ms; pose searches {len(result.search_seconds)} in "
        f"{float(np.sum(result.search_seconds)):.1f} s"
    )


if __name__ == "__main__":
    main()
