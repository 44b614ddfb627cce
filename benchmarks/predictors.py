"""Microseconds per frame (update + predict) of every predictor at d = 26.

Run:  .venv/bin/python benchmarks/predictors.py [--frames N] [--bank-only]

Each predictor is fed a real recorded hand motion (the shipped htrack recording,
converted to degrees and millimetres); the window is warmed up past `memory` first
so that every timed frame both adds and drops an equation.  For comparison, the
same structured / full VAR is refitted from scratch every frame with
numpy.linalg.lstsq (eq. 14 as written), and the ratio is printed.
"""

from __future__ import annotations

import argparse
import time

import numpy as np

from handvar.data import example_path
from handvar.predictors import RVAR, VAR, Decelerating, KalmanCV, NoMotion, hand_blocks

DATA = example_path("htrack")


def motion(n: int) -> np.ndarray:
    X = np.loadtxt(DATA)[:4000]
    X[:, 3:] = np.degrees(X[:, 3:])
    X[:, :3] *= 10.0
    reps = int(np.ceil(n / len(X)))
    # Mirror the recording back and forth so it is continuous for any length.
    return np.concatenate([X if r % 2 == 0 else X[::-1] for r in range(reps)])[:n]


def per_frame_us(predictor, X, warm: int) -> float:
    for x in X[:warm]:
        predictor.update(x)
        predictor.predict()
    times = []
    for x in X[warm:]:
        t0 = time.perf_counter()
        predictor.update(x)
        predictor.predict()
        times.append(time.perf_counter() - t0)
    return 1e6 * float(np.median(times))


class LstsqRefit:
    """Eq. 14 refitted from scratch with numpy.linalg.lstsq every frame (the baseline)."""

    def __init__(self, memory: int, blocks) -> None:
        self.memory, self.blocks = memory, [np.array(b) for b in blocks]
        self.X: list[np.ndarray] = []

    def update(self, x) -> None:
        self.X.append(np.asarray(x, dtype=float))
        self.X = self.X[-(self.memory + 3) :]

    def predict(self) -> np.ndarray:
        X = np.array(self.X)
        if len(X) < 4:
            return X[-1].copy()
        y = X[2:] - 2 * X[1:-1] + X[:-2]
        y_hat = np.zeros(X.shape[1])
        for b in self.blocks:
            coef, *_ = np.linalg.lstsq(y[:-1][:, b], y[1:][:, b], rcond=None)
            y_hat[b] = y[-1][b] @ coef
        return np.clip(y_hat + X[-1] - X[-2], -10, 10) + X[-1]


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--frames", type=int, default=2000, help="timed frames per case")
    args, _ = parser.parse_known_args()
    full = [list(range(26))]
    rows = []
    for memory in (30, 3000):
        X = motion(memory + 3 + args.frames)
        warm = memory + 3
        cases = [
            ("NoMotion", NoMotion()),
            ("Decelerating(0.4)", Decelerating(0.4)),
            ("KalmanCV", KalmanCV()),
            ("VAR full", VAR(memory=memory)),
            ("VAR structured", VAR(memory=memory, blocks=hand_blocks())),
            (
                "RVAR",
                RVAR(structured=VAR(memory=memory, blocks=hand_blocks())),
            ),
            ("lstsq refit, full", LstsqRefit(memory, full)),
            ("lstsq refit, structured", LstsqRefit(memory, hand_blocks())),
        ]
        for name, predictor in cases:
            rows.append((name, memory, per_frame_us(predictor, X, warm)))
    print(f"median µs per frame (update + predict), d = 26, {args.frames} timed frames")
    print(f"{'predictor':<26}{'N = 30':>10}{'N = 3000':>10}{'3000 / 30':>11}")
    names = list(dict.fromkeys(r[0] for r in rows))
    table = {(n, m): t for n, m, t in rows}
    for name in names:
        a, b = table[name, 30], table[name, 3000]
        print(f"{name:<26}{a:>10.1f}{b:>10.1f}{b / a:>10.2f}x")
    for kind, ours in (("full", "VAR full"), ("structured", "VAR structured")):
        for m in (30, 3000):
            ratio = table[f"lstsq refit, {kind}", m] / table[ours, m]
            print(f"online {kind} VAR is {ratio:.1f}x faster than lstsq refit at N = {m}")


def bank_speeds(frames: int) -> None:
    """The adaptive bank and One Euro (design §16): µs per frame at d = 26 and d = 63.

    The hand's banks use the catalogue's configuration (weight groups
    :func:`hand_groups`, the fast blend's VAR blocks :func:`hand_blocks`); the 63-column
    banks the keypoint digits as groups and VAR blocks (12 coordinates a block), as the
    open-loop league builds them, or 21 points with a diagonal VAR.
    """
    from handvar.evaluation.openloop import keypoint_blocks
    from handvar.predictors import AdaptiveBank, OneEuro, hand_groups

    X26 = motion(frames + 200)
    X63 = np.tile(X26[:, :21], 3)  # 63 columns of real motion
    points21 = [[3 * k, 3 * k + 1, 3 * k + 2] for k in range(21)]
    hb, kb = hand_blocks(), keypoint_blocks()
    cases = [
        ("adaptive bank, hand groups", 26, AdaptiveBank(hand_groups(), var_blocks=hb), X26),
        ("adaptive bank, every column", 26, AdaptiveBank(), X26),
        (
            "adaptive bank, steering",
            26,
            AdaptiveBank(hand_groups(), experts="steering", var_blocks=hb),
            X26,
        ),
        ("adaptive bank, 6 digit groups", 63, AdaptiveBank(kb, var_blocks=kb), X63),
        (
            "adaptive bank, steering, digits",
            63,
            AdaptiveBank(kb, experts="steering", var_blocks=kb),
            X63,
        ),
        ("adaptive bank, 21 points", 63, AdaptiveBank(points21), X63),
        ("One Euro", 26, OneEuro(), X26),
    ]
    print(f"\nmedian µs per frame (update + predict), {frames} timed frames")
    print(f"{'predictor':<32}{'d':>4}{'µs':>8}")
    for name, d, predictor, X in cases:
        print(f"{name:<32}{d:>4}{per_frame_us(predictor, X, 200):>8.1f}")


if __name__ == "__main__":
    extra = argparse.ArgumentParser(add_help=False)
    extra.add_argument("--frames", type=int, default=2000)
    extra.add_argument("--bank-only", action="store_true", help="only the last table")
    known = extra.parse_known_args()[0]
    if not known.bank_only:
        main()
    bank_speeds(known.frames)
