"""The adaptive bank steering the tracker: its weights, open loop vs closed loop (design §16).

Run:  .venv/bin/python studies/bank_closed_loop.py [--store STORE] [--trials N]

On the 175-frame benchmark sequence (taken from an experiment store, or rendered),
prints

1. the bank's weights (mean over its eight hand groups) at frames 30, 60, 100 and 174,
   fed the true poses (open loop) and steering the SMD tracker (closed loop, trial 0),
   for the bank of all twelve experts and for the steering bank;
2. each expert's one-step RMSE over the finger angles (frames 31 on, degrees) measured
   against the tracker's estimates, as the bank sees them, in that closed-loop trial;
3. the mean joint error (mm) of the tracker over trials 0..N−1 (on an embedded Dask
   cluster, one process per core) with banks of a few expert sets, the fast blend
   alone and without its parts (a diagonal VAR instead of eq. 25's blocks, no step
   bound), beside decelerating ρ = 0.4, 0.6, 1 and both RVARs; the same mean over
   frames 148–160 only, where the thumb crosses the palm (``--window``; the thumb's
   flexion steps there are printed first); its standard error over the trials and
   its worst trial;
4. with ``--join``, only the join rule's margins: for each expert of ``JOINING``, the
   ratio of its discounted squared error to the best steering expert's per hand group,
   frames 30 on (where the rule may act), as the steering bank without the rule sees it
   open loop on the league's slow smooth rows (median, least) and in closed loop over
   trials 0..N−1 (least, percentiles).

Trial k uses ``default_rng([0, k])`` as in ``handvar experiment``, so the figures are
the experiment's first trials.
"""

from __future__ import annotations

import argparse

import numpy as np

from handvar.evaluation.config import ExperimentConfig, tracker_settings
from handvar.evaluation.trials import _hand
from handvar.predictors import (
    EXPERTS,
    JOINING,
    STEERING_EXPERTS,
    AdaptiveBank,
    Decelerating,
    hand_blocks,
    hand_groups,
)
from handvar.predictors.catalogue import CATALOGUE
from handvar.tracking import Tracker

FRAMES = (30, 60, 100, 174)
DAMPED = ("no motion", "decelerating 0.2", "decelerating 0.4", "decelerating 0.6")


class _Recorder(AdaptiveBank):
    """A bank that keeps its weights and its experts' predictions of every frame."""

    def update(self, x) -> None:
        if self._d is not None:
            self.seen.append((self.expert_predictions, np.array(x, dtype=float)))
        super().update(x)
        self.history.append(self.weights.mean(0))


class _Ratios(AdaptiveBank):
    """A bank that keeps, every frame, each expert's discounted squared error over the
    best steering expert's, per group (n_groups, M)."""

    STEERING = tuple(EXPERTS.index(e) for e in STEERING_EXPERTS)

    def update(self, x) -> None:
        super().update(x)
        d = np.einsum("gaa->ga", self._G)
        with np.errstate(invalid="ignore", divide="ignore"):  # no errors yet: NaN
            self.ratios.append(d / d[:, list(self.STEERING)].min(1, keepdims=True))


def _ratio_bank() -> _Ratios:
    """The steering bank without the join rule, keeping its ratios."""
    bank = _Ratios(hand_groups(), experts="steering", join=0.0, var_blocks=hand_blocks())
    bank.ratios = []
    return bank


def _join_margins(sequence, trials: int) -> None:
    from handvar.data import example_path
    from handvar.evaluation.openloop import Recording, smooth_variants
    from handvar.synth.motion import htrack_to_handvar

    join = AdaptiveBank(experts="steering").join
    print(f"join rule (join = {join}): each joining expert's discounted squared error / "
          "the best steering expert's, frames 30 on, every group")  # fmt: skip
    H = htrack_to_handvar(np.loadtxt(example_path("htrack")))
    print("open loop, the league's slow smooth rows: median (least)")
    for name, X in (("0-3999", H[:4000]), ("4000-5999", H[4000:])):
        for rec in smooth_variants(Recording(f"htrack {name}", X, "handvar")):
            bank = _ratio_bank()
            for x in rec.X:
                bank.update(x)
            R = np.array(bank.ratios)[30:]
            cells = (R[..., EXPERTS.index(e)] for e in JOINING)
            print(f"  {rec.name:<40}"
                  + "  ".join(f"{np.median(r):.3f} ({r.min():.3f})" for r in cells))  # fmt: skip
    R = []
    for k in range(trials):
        bank = _ratio_bank()
        _track(sequence, bank, k)
        R.append(np.array(bank.ratios)[30:])
    R = np.array(R)  # (trials, frames, groups, M)
    print(f"closed loop on the benchmark, trials 0..{trials - 1}:")
    print(f"  {'expert':<20}{'least':>7}{'1 %':>7}{'10 %':>7}{'median':>8}  least per trial")
    for e in JOINING:
        r = R[..., EXPERTS.index(e)]
        q = np.quantile(r, [0.01, 0.1, 0.5])
        print(f"  {e:<20}{r.min():7.3f}" + "".join(f"{v:7.3f}" for v in q[:2]) + f"{q[2]:8.3f}  "
              + " ".join(f"{v:.2f}" for v in r.min(axis=(1, 2))))  # fmt: skip


def _recorder(experts):
    bank = _Recorder(hand_groups(), experts=experts, var_blocks=hand_blocks())
    bank.history, bank.seen = [], []
    return bank


def _track(sequence, predictor, trial: int):
    cfg = ExperimentConfig()
    rng = np.random.default_rng([cfg.seed, trial])
    tracker = Tracker(sequence.rig, _hand(), predictor, rng, tracker_settings(cfg.tracker))
    result = tracker.track(sequence, sequence.truth.poses[0])
    return np.linalg.norm(result.joints - sequence.truth.joints, axis=-1).mean(-1)


def _weights_table(sequence, experts) -> None:
    fingers = [j for g in hand_groups()[2:] for j in g]
    open_bank = _recorder(experts)
    for x in sequence.truth.poses:
        open_bank.update(x)
    closed = _recorder(experts)
    error = _track(sequence, closed, 0)
    print(f"\nexperts={experts!r}: closed-loop mean joint error (trial 0) {error.mean():.2f} mm")
    head = "  ".join(f"{f:>4}" for f in FRAMES)
    print(f"{'weight at frame':<22}{'open loop':>9} {head}   {'closed loop':>11} {head}")
    W_open, W_closed = np.array(open_bank.history), np.array(closed.history)
    for i, name in enumerate(EXPERTS):
        a = "  ".join(f"{W_open[f, i]:4.2f}" for f in FRAMES)
        b = "  ".join(f"{W_closed[f, i]:4.2f}" for f in FRAMES)
        print(f"{name:<22}{'':>9} {a}   {'':>11} {b}")
    P = np.array([p for p, _ in closed.seen])  # (T-1, M, d): predictions of frame t+1
    X = np.array([x for _, x in closed.seen])
    print("expert RMSE on the finger angles vs the estimates, closed loop (deg):")
    for i, name in enumerate(EXPERTS):
        e = X[30:, fingers] - P[30:, i][:, fingers]
        print(f"  {name:<22}{np.sqrt(np.mean(e**2)):6.2f}")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--store", help="experiment store holding the benchmark sequence")
    ap.add_argument("--trials", type=int, default=3)
    ap.add_argument("--window", type=int, nargs=2, default=(148, 160), metavar=("FIRST", "LAST"))
    ap.add_argument("--cases", help="semicolon-separated names of the cases to run (default all)")
    ap.add_argument("--no-weights", action="store_true", help="skip the weight tables")
    ap.add_argument("--join", action="store_true", help="print only the join rule's margins")
    args = ap.parse_args()
    if args.store:
        from handvar.evaluation.store import store_sequence

        sequence = store_sequence(args.store)
    else:
        from handvar.synth.sequences import make_sequence

        sequence = make_sequence("benchmark", seed=0, n_frames=175)
    if args.join:
        _join_margins(sequence, args.trials)
        return
    if not args.no_weights:
        _weights_table(sequence, "all")
        _weights_table(sequence, "steering")
    hb = hand_blocks()
    no_blend = tuple(e for e in STEERING_EXPERTS if e != "fast blend")
    with_kalman = tuple(e for e in EXPERTS if e in (*STEERING_EXPERTS, "Kalman CV"))

    def bank(experts, **kw):
        return lambda: AdaptiveBank(hand_groups(), experts=experts, **{"var_blocks": hb, **kw})

    cases = {
        "decelerating 0.4": lambda: Decelerating(0.4),
        "decelerating 0.6": lambda: Decelerating(0.6),
        "constant velocity": lambda: Decelerating(1.0),
        "RVAR": lambda: CATALOGUE["rvar"].build(),
        "RVAR relative": lambda: CATALOGUE["rvar_relative"].build(),
        "bank, all experts": bank("all"),
        "bank, steering": bank("steering"),
        "steering w/o fast blend": bank(no_blend),
        "steering + Kalman q/r=1": bank(with_kalman),
        "steering, pool 100": bank("steering", pool=100.0),
        "steering, pool 0": bank("steering", pool=0.0),
        "fast blend alone": bank(["fast blend"]),
        "fast blend, diagonal VAR": bank(["fast blend"], var_blocks=None),
        "fast blend, no bound": bank(["fast blend"], max_step=None),
        "bank, damped only": bank(DAMPED),
        "bank, damped + CV": bank((*DAMPED, "constant velocity")),
        "bank, damped + Kalman q/r=1": bank((*DAMPED, "Kalman CV")),
        "bank, damped + AR": bank((*DAMPED, "AR velocity", "AR acceleration")),
    }
    if args.cases:
        cases = {k: v for k, v in cases.items() if k in args.cases.split(";")}
    lo, hi = args.window
    steps = np.diff(sequence.truth.poses[lo - 1 : hi + 1, 11:14], axis=0)  # thumb flexions
    print(f"\nthumb flexion steps (deg/frame), frames {lo}-{hi}, the largest of the three: "
          + " ".join(f"{v:.1f}" for v in np.abs(steps).max(1)))  # fmt: skip
    print(f"\nmean joint error (mm) over trials 0..{args.trials - 1}, all frames and frames "
          f"{lo}-{hi}, the standard error of the first over the trials, and its worst "
          f"trial; steering set: {', '.join(STEERING_EXPERTS)}")  # fmt: skip
    print(f"{'predictor':<26}{'mean':>6}{f'{lo}-{hi}':>9}{'s.e.':>6}{'worst':>7}  per trial")
    for name, e in _errors(sequence, cases, args.trials):
        per = e.mean(1)
        listed = " ".join(f"{v:.2f}" for v in per) if len(per) <= 10 else ""
        se = per.std(ddof=1) / np.sqrt(len(per)) if len(per) > 1 else np.nan
        print(f"{name:<26}{e.mean():6.2f}{e[:, lo : hi + 1].mean():9.2f}{se:6.2f}"
              f"{per.max():7.2f}  {listed}", flush=True)  # fmt: skip


def _track_made(sequence, make, trial: int):
    return _track(sequence, make(), trial)


def _errors(sequence, cases: dict, trials: int):
    """Yield (name, per-frame error (trials, frames)) per case, in order: every (case,
    trial) a task on the experiment's embedded Dask cluster, one process per core (a
    trial is deterministic, so the figures do not depend on where it runs)."""
    from handvar.evaluation.experiment import cluster_client

    with cluster_client() as client:
        shared = client.scatter(sequence, broadcast=True)
        futures = {
            name: [client.submit(_track_made, shared, make, k, pure=False) for k in range(trials)]
            for name, make in cases.items()
        }
        for name, fs in futures.items():
            yield name, np.array(client.gather(fs))


if __name__ == "__main__":
    main()
