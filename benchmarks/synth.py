"""Speed of the synthetic sequences: motion, silhouette rendering, writing and reading.

Run: ``.venv/bin/python benchmarks/synth.py [--repeat N]``. Prints medians over the
repeats (the machine is shared, so single runs are noisy).
"""

from __future__ import annotations

import argparse
import shutil
import statistics
import tempfile
import time
from pathlib import Path

from handvar.io import read_sequence, write_sequence
from handvar.synth.sequences import SEQUENCE_NAMES, make_sequence, sequence_poses


def _median_time(func, repeat: int) -> tuple[float, object]:
    times, result = [], None
    for _ in range(repeat):
        start = time.perf_counter()
        result = func()
        times.append(time.perf_counter() - start)
    return statistics.median(times), result


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--repeat", type=int, default=3)
    args = parser.parse_args()
    print(f"median of {args.repeat} runs")
    for name in SEQUENCE_NAMES:
        t, poses = _median_time(lambda name=name: sequence_poses(name, 0), args.repeat)
        print(f"{name:9s} poses ({poses.shape[0]} frames): {t * 1e3:8.1f} ms")

    tmp = Path(tempfile.mkdtemp(prefix="handvar-bench-"))
    try:
        t, seq = _median_time(lambda: make_sequence("benchmark"), args.repeat)
        n = seq.n_frames * seq.n_cameras
        print(f"benchmark render {n} masks: {t:6.2f} s ({t / n * 1e3:.1f} ms per mask)")
        t, _ = _median_time(lambda: write_sequence(seq, tmp / "bench"), args.repeat)
        print(f"benchmark write {n} masks + truth: {t:6.2f} s ({t / n * 1e3:.1f} ms per mask)")
        t, _ = _median_time(lambda: read_sequence(tmp / "bench"), args.repeat)
        print(f"benchmark read (eager, checked): {t:6.2f} s ({t / n * 1e3:.1f} ms per mask)")
        t, _ = _median_time(lambda: read_sequence(tmp / "bench", lazy=True), args.repeat)
        print(f"benchmark read (lazy, checked):  {t:6.2f} s")
        t, _ = _median_time(lambda: make_sequence("flip", rgb=True, n_frames=10), 1)
        print(f"flip render 10 frames with colour: {t:6.2f} s ({t / 20 * 1e3:.0f} ms per image)")
        size = sum(p.stat().st_size for p in (tmp / "bench").rglob("*") if p.is_file())
        print(f"benchmark on disk: {size / 1e6:.1f} MB")
    finally:
        shutil.rmtree(tmp, ignore_errors=True)


if __name__ == "__main__":
    main()
