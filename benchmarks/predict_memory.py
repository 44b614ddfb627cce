"""Peak memory and time of `handvar predict` on a long series (10^6 frames × 26 columns).

Run:  .venv/bin/python benchmarks/predict_memory.py [--frames N] [--league]

Writes a series of N frames of the 26 hand parameters (the shipped htrack recording,
converted as ``--layout htrack`` does, mirrored back and forth to any length) as .npy
in a temporary directory, runs ``handvar predict FILE`` (every predictor of the
catalogue, the per-group table; with ``--league``: the league table of the one file
with its noisy copies, ``--noise``) in a child process, and prints its peak resident
memory (``resource.getrusage(RUSAGE_CHILDREN).ru_maxrss``, which includes the Python
interpreter, numpy, numba and the compiled kernels) and its wall-clock time.  The
series itself is N × 26 × 8 bytes (208 MB at 10^6 frames); the predictions are
streamed (``handvar.predictors.one_step_chunks``), so nothing else grows with N.
"""

from __future__ import annotations

import argparse
import resource
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

from handvar.synth.motion import htrack_to_handvar

DATA = Path(__file__).resolve().parent.parent / "examples" / "data" / "htrack-fingerfist.txt"


def motion(n: int) -> np.ndarray:
    X = htrack_to_handvar(np.loadtxt(DATA))
    reps = int(np.ceil(n / len(X)))
    # Mirrored back and forth, the series is continuous for any length.
    return np.concatenate([X if r % 2 == 0 else X[::-1] for r in range(reps)])[:n]


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--frames", type=int, default=1_000_000)
    ap.add_argument("--league", action="store_true", help="the league with --noise instead")
    args = ap.parse_args()
    with tempfile.TemporaryDirectory() as tmp:
        path = Path(tmp) / "series.npy"
        np.save(path, motion(args.frames))
        cmd = [sys.executable, "-m", "handvar", "predict", str(path)]
        if args.league:
            cmd.append("--noise")
        t0 = time.perf_counter()
        done = subprocess.run(cmd, capture_output=True, text=True)
        seconds = time.perf_counter() - t0
    if done.returncode:
        why = done.stderr or done.stdout
        raise SystemExit(f"handvar predict failed ({done.returncode}): {why}")
    peak_mb = resource.getrusage(resource.RUSAGE_CHILDREN).ru_maxrss / 1024  # KiB on Linux
    series_mb = args.frames * 26 * 8 / 1e6
    mode = "league with --noise" if args.league else "table"
    print(f"handvar predict ({mode}), {args.frames} frames x 26 columns")
    print(f"  the series alone: {series_mb:.0f} MB")
    print(f"  peak resident memory {peak_mb:.0f} MiB, wall clock {seconds:.1f} s")


if __name__ == "__main__":
    main()
