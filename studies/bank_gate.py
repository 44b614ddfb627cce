"""The bank of all experts on the league, with and without its autoregressions' gate.

Run:  .venv/bin/python studies/bank_gate.py

On the 35 rows of the league that ``handvar predict`` prints for the two htrack takes
(``--noise --smooth``: each take, slowed 4x, a random walk in velocity, and their noisy
copies) and for the dex keypoints (``--noise``), prints RMSE / the best simple
baseline's for the bank of all experts with ``ar_gate`` off and at 3, 4 and 5 (the
default is 4), one line per row, then the worst row of each.  The gate pulls an
isolated value whose innovation exceeds ``ar_gate`` times its RMS back to that bound
before the two autoregressive experts see it (design §16).
"""

from __future__ import annotations

from handvar.data import example_path
from handvar.evaluation.openloop import (
    Recording,
    layout_structure,
    league_table,
    noise_variants,
    read_pose_series,
    smooth_variants,
)
from handvar.predictors.catalogue import CATALOGUE
from handvar.synth.motion import htrack_to_handvar

GATES = {"off": None, "3": 3.0, "4": 4.0, "5": 5.0}


def recordings() -> list[Recording]:
    """The league's recordings, named and seeded as ``handvar predict`` names them."""
    H = htrack_to_handvar(read_pose_series(example_path("htrack")))
    D = 1000.0 * read_pose_series(example_path("video-landmarks"))
    out = []
    for rows in ((0, 4000), (4000, 6000)):
        name = f"htrack-fingerfist.txt:{rows[0]}:{rows[1]}"
        take = Recording(name, H[slice(*rows)], "handvar")
        for r in (take, *smooth_variants(take)):
            out += [r, *noise_variants(r)]
    dex = Recording("dex-human-hand-landmarks.npy", D, "keypoints")
    return [*out, dex, *noise_variants(dex)]


def bank(gate):
    """The catalogue's bank of all experts (as the league builds it) with `gate`."""
    spec = CATALOGUE["adaptive_open"].with_params(rate=30.0, ar_gate=gate)

    def make(rec: Recording):
        _groups, blocks = layout_structure(rec.layout, rec.X.shape[1])
        return spec.build(blocks)

    return make


def main() -> None:
    extra = {f"gate {k}": bank(g) for k, g in GATES.items()}
    rows = [r for r in league_table(recordings(), keys=(), extra=extra) if r.group == "all"]
    names = list(dict.fromkeys(r.recording for r in rows))
    ratio = {(r.recording, r.predictor): r.ratio for r in rows}
    print(f"{'row':48s}" + "".join(f"{'gate ' + k:>10s}" for k in GATES))
    for n in names:
        print(f"{n:48s}" + "".join(f"{ratio[n, 'gate ' + k]:10.3f}" for k in GATES))
    worst = {k: max(ratio[n, "gate " + k] for n in names) for k in GATES}
    label = f"worst of {len(names)} rows"
    print(f"{label:48s}" + "".join(f"{worst[k]:10.3f}" for k in GATES))


if __name__ == "__main__":
    main()
