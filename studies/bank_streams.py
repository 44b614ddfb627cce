"""Both adaptive banks open loop on streams the league does not hold (design §16).

Run:  .venv/bin/python studies/bank_streams.py [--no-checks]

The league (``handvar predict ... --noise [--smooth]``) is where the banks' settings
were chosen.  This study runs them on series it does not hold, each with a copy plus
Gaussian noise of σ = 0.5 in its units, and prints the league's summary (RMSE over all
columns / the best simple baseline's, per recording):

- the htrack recording at 15 and 10 frames/s (every 2nd and 3rd frame: faster motion
  between frames; its two takes, frames 0-3999 and 4000 on, split by a reset as in
  the league), and the dex landmarks at 15 frames/s;
- a learned detector's output on two other real clips (MediaPipe Hands on the
  fingerspelling and the counting clip, shipped in ``examples/data``): its world
  landmarks (mm) and its image landmarks (px), each over its longest run of frames with
  a hand; and the keypoints of the dex video;

then, unless ``--no-checks``, three checks: the steering bank without the
join rule (``join=0``), as it is, and with the q/r = 1 Kalman filter always among its
experts, on the league's slow smooth rows (each htrack take slowed 4x, the random walk
in velocity), and on the test suite's synthetic families; and both banks on htrack at
the lower frame rates with and without the reset at the cut between its takes (a jump
in position that no predictor is told of without it); and both banks with the fast
blend's ``first_step`` at 0 and 0.4 beside the default (a step at the series' second
prediction: γ), on the rows it changes.
"""

from __future__ import annotations

import argparse
from dataclasses import replace
from functools import partial

import numpy as np

from handvar.data import example_path
from handvar.evaluation.openloop import (
    BASELINES,
    Recording,
    format_league,
    layout_structure,
    league_predictors,
    league_table,
    noise_variants,
    smooth_variants,
    synthetic_families,
)
from handvar.predictors import (
    EXPERTS,
    STEERING_EXPERTS,
    AdaptiveBank,
    hand_blocks,
    hand_groups,
)
from handvar.predictors.base import one_step_predictions
from handvar.predictors.catalogue import CATALOGUE
from handvar.synth.motion import htrack_to_handvar
from paper_real_video import longest_run

BANKS = ("adaptive", "adaptive_open")
TAKE = 4000  # the first frame of htrack's second take (the league's two ranges)


def recordings() -> list[Recording]:
    H = htrack_to_handvar(np.loadtxt(example_path("htrack")))
    D = 1000.0 * np.load(example_path("video-landmarks"))
    clean = [  # the row of H[::k] where the second take starts: ⌈TAKE / k⌉
        Recording("htrack, every 2nd frame", H[::2], "handvar", resets=(-(-TAKE // 2),)),
        Recording("htrack, every 3rd frame", H[::3], "handvar", resets=(-(-TAKE // 3),)),
        Recording("dex landmarks, every 2nd frame", D[::2].reshape(-1, 63), "keypoints"),
    ]
    for clip in ("fingerspelling", "counting"):
        z = np.load(example_path(f"{clip}-mediapipe"))
        for key, layout in (("world_mm", "keypoints"), ("landmarks_px", "columns")):
            found = np.isfinite(z[key].reshape(len(z[key]), -1)).all(axis=1)
            length, start = longest_run(found)  # the longest run of frames with a hand
            a = z[key][start : start + length]
            clean.append(Recording(f"{clip} MediaPipe {key} ({len(a)} frames)",
                                   a.reshape(len(a), -1), layout))  # fmt: skip
    K = np.load(example_path("video-keypoints"))
    clean.append(Recording("dex video keypoints", K.reshape(len(K), -1), "keypoints"))
    out = []
    for rec in clean:
        out += [rec, noise_variants(rec, sigmas=(0.5,), outlier_rate=0.0)[0]]
    return out


def _ratio(make, rec: Recording, blocks=None) -> float:
    """RMSE of a fresh predictor from `make` / the best baseline's, on `rec` (a noisy
    copy scored against its clean series, as in the league)."""
    truth = rec.X if rec.truth is None else rec.truth

    def rmse(p) -> float:
        P = one_step_predictions(p, rec.X, resets=rec.resets)
        ok = np.isfinite(P).all(1)
        return float(np.sqrt(np.mean((truth - P)[ok] ** 2)))

    preds = league_predictors(blocks, keys=())
    return rmse(make()) / min(rmse(preds[name]) for name in BASELINES)


def _checks() -> None:
    H = htrack_to_handvar(np.loadtxt(example_path("htrack")))
    added = tuple(e for e in EXPERTS if e in (*STEERING_EXPERTS, "Kalman CV"))
    print("steering bank without the join rule / as it is / with the q/r = 1 Kalman filter"
          " always, RMSE / best baseline:")  # fmt: skip
    variants = ({"experts": "steering", "join": 0.0}, {"experts": "steering"},
                {"experts": added, "join": 0.0})  # fmt: skip
    for name, X in (("0-3999", H[:TAKE]), ("4000-5999", H[TAKE:])):
        for rec in smooth_variants(Recording(f"htrack {name}", X, "handvar")):
            ratios = [
                _ratio(partial(AdaptiveBank, hand_groups(), var_blocks=hand_blocks(), **kw), rec)
                for kw in variants  # the catalogue's bank on hand parameters
            ]
            print(f"  {rec.name:<40}" + " / ".join(f"{r:.3f}" for r in ratios))
    for name, X in synthetic_families().items():  # every column alone
        ratios = [_ratio(partial(AdaptiveBank, **kw), Recording(name, X, "columns"))
                  for kw in variants]  # fmt: skip
        print(f"  {'synthetic ' + name:<40}" + " / ".join(f"{r:.3f}" for r in ratios))
    jump = np.abs(H[TAKE, :3] - H[TAKE - 1, :3]).max()
    print(f"at the cut between htrack's two takes (a jump of {jump:.0f} mm in position),"
          " with and without a reset there: the steering bank / the bank of all experts,"
          " RMSE / best baseline:")  # fmt: skip
    for rec in recordings()[:4]:
        ratios = []
        for resets in (rec.resets, ()):
            cut = replace(rec, resets=resets)
            for key in BANKS:
                ratios.append(_ratio(_bank(rec, key), cut))
        print(f"  {rec.name:<40}" + " / ".join(f"{r:.3f}" for r in ratios[:2])
              + "  without: " + " / ".join(f"{r:.3f}" for r in ratios[2:]))  # fmt: skip
    print("the fast blend's first step (its share of the step at the series' second"
          " prediction): first_step 0 (no motion there) / 0.4 / the default (γ = 0.8),"
          " rows where the first and the last differ by 0.001 or more; the steering bank"
          " | the bank of all experts, RMSE / best baseline:")  # fmt: skip
    for rec in recordings():
        cells = [[_ratio(_bank(rec, key, first_step=step), rec) for step in (0.0, 0.4)]
                 + [_ratio(_bank(rec, key), rec)] for key in BANKS]  # fmt: skip
        if max(abs(c[0] - c[-1]) for c in cells) >= 0.001:
            print(f"  {rec.name:<54}" + "   |   ".join(" / ".join(f"{r:.3f}" for r in c)
                                                      for c in cells))  # fmt: skip


def _bank(rec: Recording, key: str, **params):
    """A maker of the catalogue's bank `key` (with `params`) for `rec`'s layout, as the
    league builds it."""
    spec = CATALOGUE[key].with_params(**params) if params else CATALOGUE[key]
    return partial(spec.build, layout_structure(rec.layout, rec.X.shape[1])[1])


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--no-checks", action="store_true")
    args = ap.parse_args()
    rows = league_table(recordings(), keys=BANKS)
    text = format_league(rows)
    print(text[text.index("RMSE / best baseline (") :])  # the summary, not every ranking
    if not args.no_checks:
        _checks()


if __name__ == "__main__":
    main()
