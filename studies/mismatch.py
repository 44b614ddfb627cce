"""The paper's protocol under model mismatch (docs/results/mismatch.md): run, report, summarise.

Each variant is an experiment (the paper's five predictors) on a sequence the
tracker's model does not explain exactly: rendered with the skinned mesh, by a hand
10% larger or smaller, with corrupted silhouettes, replayed faster, or tracked with
the mesh. This script runs (or resumes) the variants' stores, writes a report per
variant into ``docs/results/mismatch/<variant>/`` (``report.md`` and the mean-error
figure) and prints the summary table of ``docs/results/mismatch/README.md``.

Every variant is also one command, printed in the table, e.g.::

    handvar experiment --out STORES/bench-mesh.zarr --workers 2 --set trials=6 \\
        --set sequence.model=mesh
    handvar report STORES/bench-mesh.zarr --out docs/results/mismatch/bench-mesh

Usage: ``python studies/mismatch.py [--stores DIR] [--no-run] [--only NAME ...]``
"""

from __future__ import annotations

import argparse
import os
from pathlib import Path

import numpy as np

from handvar.evaluation.claims import LOSS_MM, evaluate_claims
from handvar.evaluation.config import ExperimentConfig
from handvar.evaluation.results import fmt, load_results

# name: (what it is, --set assignments). Trials as the 2-core machine allowed.
VARIANTS: dict[str, tuple[str, tuple[str, ...]]] = {
    "flip-mesh": (
        "flip rendered with the mesh",
        ("sequence=flip", "frames=80", "trials=20", "sequence.model=mesh"),
    ),
    "flip-4x": (
        "flip replayed 4× faster",
        ("sequence=flip", "frames=20", "trials=20", "sequence.speed=4"),
    ),
    "flip-2x": (
        "flip replayed 2× faster",
        ("sequence=flip", "frames=40", "trials=20", "sequence.speed=2"),
    ),
    "flip": ("flip, no mismatch (reference)", ("sequence=flip", "frames=80", "trials=20")),
    "flip-mesh-4x": (
        "flip 4× faster, rendered with the mesh",
        ("sequence=flip", "frames=20", "trials=20", "sequence.model=mesh", "sequence.speed=4"),
    ),
    "bench-mesh": ("benchmark rendered with the mesh", ("trials=12", "sequence.model=mesh")),
    "bench-noise": (
        "benchmark, silhouettes corrupted at 3 px",
        ("trials=12", "sequence.noise=3"),
    ),
    "bench-large": (
        "benchmark, hand 10% longer and broader",
        ("trials=12", "sequence.length=1.1", "sequence.breadth=1.1"),
    ),
    "bench-small": (
        "benchmark, hand 10% shorter and narrower",
        ("trials=12", "sequence.length=0.9", "sequence.breadth=0.9"),
    ),
    "bench-trackmesh": (
        "benchmark tracked with the mesh (60 frames)",
        ("trials=2", "frames=60", "tracker.model=mesh"),
    ),
}

# short names of the paper §4–5 claims, in the order of evaluate_claims
_SHORT = ["dec>0", "fullVAR<0", "sVAR j1,18-21", "sVAR j13<0", "sVAR var", "RVAR≈0.5",
          "RVAR>dec", "RVAR var", "RVAR lowest"]  # fmt: skip
_KEYS = ("none", "decelerating", "full_var", "structured_var", "rvar")


def config_of(name: str) -> ExperimentConfig:
    """The experiment of a variant."""
    return ExperimentConfig().with_overrides(VARIANTS[name][1])


def command_of(name: str, stores: str = "STORES") -> str:
    """The command line that runs a variant."""
    sets = " ".join(f"--set {a}" for a in VARIANTS[name][1])
    return f"handvar experiment --out {stores}/{name}.zarr --workers 2 {sets}"


def summary_row(name: str, store: Path) -> list[str]:
    """One row of the summary table from a variant's store."""
    r = load_results(store)
    claims = evaluate_claims(r)
    paper = claims[: len(_SHORT)]
    held = [s for s, c in zip(_SHORT, paper, strict=True) if c.holds]
    failed = [s for s, c in zip(_SHORT, paper, strict=True) if c.holds is False]
    errors = " / ".join(fmt(r.overall_error(r.index(k))) for k in _KEYS)
    flips = [c for c in claims if c.section.startswith("paper §6")]
    if r.config.sequence == "flip":
        worst = [np.nanmax(r.mean_error_curve(r.index(k))) for k in ("rvar", "decelerating")]
        flip = (
            f"{flips[0].verdict} / {flips[1].verdict} (worst frame {fmt(worst[0])} vs "
            f"{fmt(worst[1])} mm)"
        )
    else:
        flip = "–"
    n = int(r.done.sum(axis=1).min())
    return [
        f"[{name}]({name}/report.md)",
        VARIANTS[name][0],
        f"{n} × {r.config.frames}",
        errors,
        f"{len(held)}/{len(held) + len(failed)}"
        + (f" (not: {', '.join(failed)})" if failed else ""),
        flip,
    ]


HEADER = [
    "variant",
    "what",
    "trials × frames",
    "overall mean error (mm): none / dec. / full VAR / str. VAR / RVAR",
    "paper §4–5 claims that hold",
    f"paper §6 flip: follows (RVAR < {LOSS_MM:g} mm ≤ dec.) / lower error",
]


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--stores", default="mismatch-stores", help="directory of the stores")
    ap.add_argument("--docs", default="docs/results/mismatch", help="reports go here")
    ap.add_argument("--only", nargs="*", default=None, help="variants (default: all)")
    ap.add_argument("--no-run", action="store_true", help="only report existing stores")
    ap.add_argument("--workers", type=int, default=os.cpu_count() or 1)
    args = ap.parse_args()

    from handvar.evaluation.experiment import run_experiment, summary_text
    from handvar.evaluation.report import write_report

    names = args.only or list(VARIANTS)
    rows = []
    for name in names:
        store = Path(args.stores) / f"{name}.zarr"
        if not args.no_run:
            summary = run_experiment(config_of(name), store, workers=args.workers, progress=False)
            print(summary_text(summary))
        if not store.exists():
            print(f"{name}: no store at {store}; skipped")
            continue
        write_report(store, Path(args.docs) / name, figures=("fig4_mean_error.png",))
        rows.append(summary_row(name, store))
    print("| " + " | ".join(HEADER) + " |")
    print("|" + "---|" * len(HEADER))
    for row in rows:
        print("| " + " | ".join(row) + " |")
    print()
    for name in names:
        print(f"{command_of(name, args.stores)}\nhandvar report {args.stores}/{name}.zarr")


if __name__ == "__main__":
    main()
