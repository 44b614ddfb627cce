"""Time the paper's protocol: one trial per predictor, and a reduced run on Dask.

Prints
- per predictor: seconds for one trial of the full benchmark sequence (175 frames) in
  this process, its ms per frame, and the median over `--repeat` trials;
- the projection for the paper's protocol (5 predictors × 50 trials) on N workers;
- a reduced experiment on an embedded LocalCluster (wall clock against the summed
  trial times: the overhead of Dask and of writing the store).

Usage: ``python benchmarks/experiment.py [--repeat 3] [--workers 2] [--frames 175]``
"""

from __future__ import annotations

import argparse
import os
import statistics
import tempfile
import time

import numpy as np

from handvar.evaluation.config import ExperimentConfig
from handvar.evaluation.experiment import run_experiment
from handvar.evaluation.store import open_store
from handvar.evaluation.trials import run_trial
from handvar.synth.sequences import make_sequence


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--repeat", type=int, default=3, help="trials per predictor timed")
    ap.add_argument("--workers", type=int, default=os.cpu_count() or 1)
    ap.add_argument("--frames", type=int, default=175)
    ap.add_argument("--dask-trials", type=int, default=4, help="trials of the Dask run")
    args = ap.parse_args()

    cfg = ExperimentConfig(frames=args.frames)
    seq = make_sequence(cfg.sequence, seed=cfg.sequence_seed, n_frames=cfg.frames)
    run_trial(cfg, "none", 0, seq)  # warm-up: JIT caches, surface pool
    print(f"one trial, {cfg.frames} frames, one process (median of {args.repeat}):")
    medians = {}
    for spec in cfg.predictors:
        times, iters = [], []
        for k in range(args.repeat):
            start = time.perf_counter()
            res = run_trial(cfg, spec.key, k, seq)
            times.append(time.perf_counter() - start)
            iters.append(float(np.mean(res.iterations)))
        medians[spec.key] = statistics.median(times)
        print(
            f"  {spec.label:<16}{medians[spec.key]:7.2f} s  "
            f"{1000 * medians[spec.key] / cfg.frames:6.1f} ms/frame  "
            f"{statistics.median(iters):5.1f} iterations/frame"
        )
    per_trial = statistics.mean(medians.values())
    full = ExperimentConfig()
    n_trials = len(full.predictors) * full.trials
    projected = n_trials * per_trial * full.frames / cfg.frames / args.workers
    print(
        f"projected protocol ({len(full.predictors)} x {full.trials} x {full.frames} frames) "
        f"on {args.workers} workers: {projected / 60:.1f} min (compute only)"
    )

    small = ExperimentConfig(trials=args.dask_trials, frames=args.frames)
    with tempfile.TemporaryDirectory() as tmp:
        path = os.path.join(tmp, "bench.zarr")
        start = time.perf_counter()
        summary = run_experiment(small, path, workers=args.workers, progress=False)
        wall = time.perf_counter() - start
        spent = float(np.nansum(open_store(path)["timings"].values))
    print(
        f"Dask run: {summary.computed} trials on {args.workers} workers in {wall:.1f} s "
        f"wall (cluster start, rendering, writing included); trial time summed "
        f"{spent:.1f} s = {spent / args.workers:.1f} s per worker"
    )


if __name__ == "__main__":
    main()
