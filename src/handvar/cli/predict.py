"""`handvar predict`: the predictors scored one step ahead on recorded pose series."""

from __future__ import annotations

import click

from handvar.cli.common import _FiniteRange, _one_line_errors

#: Largest magnitude `predict` accepts in a pose series (mm, degrees): far beyond any
#: pose, far below where squares of the values overflow in the predictors' fits.
_MAX_SERIES_VALUE = 1e6


@click.command("predict")
@click.argument("files", nargs=-1, required=True, metavar="FILE[:START:STOP]...")
@click.option(
    "--layout",
    type=click.Choice(["handvar", "htrack", "keypoints", "points", "columns"]),
    default="handvar",
    show_default=True,
    help="Column layout: handvar's 26 parameters (mm, degrees), htrack's (radians), "
    "21 keypoints x, y, z in metres (63 columns, or a (T, 21, 3) .npy), any K points "
    "(K x 3 columns, or a (T, K, 3) .npy; one block per point), or plain columns.",
)
@click.option(
    "--stride", type=click.IntRange(min=1), default=1, show_default=True,
    help="Use every K-th frame (simulates a slower camera).",
)  # fmt: skip
@click.option(
    "--reset-at", "reset_at", type=click.IntRange(min=0), multiple=True,
    help="Row (of each file) where a new recording starts; repeatable.",
)  # fmt: skip
@click.option("--csv", "csv_out", type=click.Path(dir_okay=False), help="Also write a CSV.")
@click.option(
    "--figure", "figure_out", type=click.Path(dir_okay=False),
    help="Write the league figure (RMSE / best baseline) as a PNG.",
)  # fmt: skip
@click.option(
    "--noise", is_flag=True,
    help="Add noisy variants of every recording (Gaussian sigma 0.5, 1, 2 in the columns' "
    "units; 5% outlier frames), scored against the clean next frame.",
)  # fmt: skip
@click.option(
    "--smooth", is_flag=True,
    help="Add slow smooth motion: every recording played 4x slower after a Gaussian "
    "smoothing of 2 frames, and a random walk in velocity (at most 2000 frames, seeded); "
    "with --noise, their noisy copies too.",
)  # fmt: skip
@click.option(
    "--train", "train", metavar="FILE[:START:STOP]",
    help="Fit an offline VAR on this recording (same layout) and add it to the table.",
)  # fmt: skip
@click.option(
    "--predictor", "keys", multiple=True,
    help="Only these predictors besides the baselines (catalogue names); repeatable.",
)  # fmt: skip
@click.option(
    "--fps", type=_FiniteRange(min=0, min_open=True), default=30.0, show_default=True,
    help="Frame rate of the recordings (One Euro and the adaptive bank).",
)  # fmt: skip
@_one_line_errors
def predict_command(
    files, layout, stride, reset_at, csv_out, figure_out, noise, smooth, train, keys, fps
) -> None:
    """Score every predictor one step ahead on the recorded poses in FILE(s).

    FILE is whitespace text, CSV or .npy; rows are frames, 26 columns (or 63 for
    keypoints).  FILE:START:STOP takes rows START to STOP - 1.  A row of NaN is a frame
    without values (a detector that found no hand): it is left out, and each run of
    rows with values is scored as its own recording.  With one FILE and no
    league option, prints per parameter group RMSE and mean absolute error (mm or
    degrees) and R̃² against no motion (> 0: better than no motion).  With several
    FILEs, --noise, --smooth, --train, --predictor or --figure, prints the league table: per
    recording every predictor's RMSE, R̃², rank and RMSE / best simple baseline
    (no motion, decelerating 0.2 / 0.4 / 0.6, Kalman CV, One Euro).
    """
    import functools

    from handvar.atomic import OutputSet, check_output_file
    from handvar.evaluation.openloop import (
        format_league,
        league_table,
        write_league_csv,
        write_league_figure,
    )
    from handvar.predictors.catalogue import catalogue_key

    # The outputs are checked before any work and written together at the end.
    if csv_out is not None:
        check_output_file(csv_out, "--csv", suffixes=(".csv", ".txt"))
    if figure_out is not None:
        check_output_file(figure_out, "--figure", suffixes=(".png", ".pdf", ".svg"))
    keys = [catalogue_key(k, "--predictor") for k in keys] or None
    inner = {"htrack": "handvar"}.get(layout, layout)
    load = functools.partial(_load_series, layout=layout, reset_at=reset_at, stride=stride)

    league = len(files) > 1 or noise or smooth or train or keys or figure_out
    if not league:
        _print_table(files[0], load, layout, inner, csv_out)
        return
    recordings = _recordings(files, load, inner, noise=noise, smooth=smooth)
    extra = _offline_var(train, load, inner) if train else None
    rows = league_table(recordings, rate=fps, keys=keys, extra=extra)
    with OutputSet() as out:  # both files, or neither
        if csv_out:
            out.add(csv_out, lambda tmp: write_league_csv(rows, tmp))
        if figure_out:
            out.add(figure_out, lambda tmp: write_league_figure(rows, tmp))
    click.echo(format_league(rows))
    if csv_out:
        click.echo(f"wrote {csv_out}")
    if figure_out:
        click.echo(f"wrote {figure_out}")


def _load_series(spec: str, option: str, *, layout: str, reset_at, stride: int):
    """The series of FILE[:START:STOP] `spec` in `layout`'s units (every `stride`-th
    row), and its reset rows; errors name `option`."""
    import os

    import numpy as np

    from handvar.evaluation.openloop import read_pose_series

    path, rows = spec, None
    if not os.path.isfile(spec) and spec.count(":") >= 2:
        path, start, stop = spec.rsplit(":", 2)
        try:
            rows = (int(start) if start else 0, int(stop) if stop else None)
        except ValueError:
            raise ValueError(
                f"{option}: expected FILE or FILE:START:STOP with integer rows; got {spec!r}"
            ) from None
    X = read_pose_series(path, missing=True)
    if layout == "htrack":
        from handvar.synth.motion import htrack_to_handvar

        X = htrack_to_handvar(X)
    elif layout == "keypoints":
        X = 1000.0 * X  # metres -> millimetres
    start, stop = (0, len(X)) if rows is None else (rows[0], rows[1] or len(X))
    if not 0 <= start < stop <= len(X):
        raise ValueError(f"{option}: expected rows within 0..{len(X)}; got {spec!r}")
    if any(r >= len(X) for r in reset_at):
        raise ValueError(f"--reset-at: expected rows below {len(X)}; got {list(reset_at)}")
    biggest = float(max(np.nanmax(X), -np.nanmin(X))) if X.size else 0.0  # no |X| copy
    if biggest > _MAX_SERIES_VALUE:  # finite, but beyond any pose: the arithmetic overflows
        raise ValueError(
            f"{path}: expected poses in mm and degrees (|value| <= {_MAX_SERIES_VALUE:g}); "
            f"got {biggest:g}"
        )
    X = X[start:stop]
    local = [r - start for r in reset_at if start < r < stop]
    # Reset rows map onto the first kept frame at or after them.
    n = -(-len(X) // stride)
    resets = sorted({-(-r // stride) for r in local if -(-r // stride) < n})
    X = X[::stride]
    gone = np.isnan(X).all(axis=1)
    if gone.any():  # frames without values: each run of frames with them is a recording
        kept = np.flatnonzero(~gone)
        if len(kept) < 2:
            raise ValueError(f"{path}: expected at least 2 rows with values; got {len(kept)}")
        starts = kept[1:][np.diff(kept) > 1]  # the first row after each gap
        # Every reset moves to the first kept row at or after it (rows of the kept series).
        moved = {int(np.searchsorted(kept, r)) for r in (*resets, *starts)}
        resets = sorted(moved - {0, len(kept)})
        runs = (
            f"{len(starts) + 1} runs of rows with values, each scored as its own recording"
            if len(starts)
            else "the rows with values scored as one recording"
        )
        click.echo(
            f"{spec}: {int(gone.sum())} rows without values (NaN) left out; {runs}", err=True
        )
        X = X[kept]
    return X, tuple(resets)


def _print_table(file: str, load, layout: str, inner: str, csv_out) -> None:
    """One FILE without a league option: per parameter group RMSE, mean absolute error
    and R̃² against no motion (and the CSV)."""
    from handvar.evaluation.openloop import evaluate_open_loop, format_table, write_csv

    X, resets = load(file, "FILE")
    try:
        rows = evaluate_open_loop(X, resets=resets, layout=inner)
    except ValueError as exc:  # the series' shape or values: name the file
        msg = str(exc)
        raise ValueError(msg if msg.startswith(file) else f"{file}: {msg}") from None
    if csv_out:
        write_csv(rows, csv_out)  # first: a failure prints nothing but its one line
    click.echo(f"{file}: {len(X)} frames, {X.shape[1]} parameters, layout {layout}")
    click.echo(format_table(rows))
    if csv_out:
        click.echo(f"wrote {csv_out}")


def _recordings(files, load, inner: str, *, noise: bool, smooth: bool) -> list:
    """The league's recordings: every FILE, with its smooth and noisy variants."""
    import os

    from handvar.evaluation.openloop import Recording, noise_variants, smooth_variants

    recordings = []
    for file in files:
        X, resets = load(file, "FILE")
        rec = Recording(os.path.basename(file), X, inner, resets)
        for r in [rec, *(smooth_variants(rec) if smooth else [])]:
            recordings += [r, *(noise_variants(r) if noise else [])]
    return recordings


def _offline_var(train: str, load, inner: str) -> dict:
    """--train: an offline VAR fitted on that recording (its order printed), as the
    league's extra predictor (none for a recording of another width)."""
    from handvar.evaluation.openloop import layout_structure
    from handvar.predictors import OfflineVAR

    Xt, rt = load(train, "--train")
    try:
        _, blocks = layout_structure(inner, Xt.shape[1])
    except ValueError as exc:  # the series' shape: name the option and the file
        raise ValueError(f"--train: {train}: {str(exc).removeprefix('X: ')}") from None
    model = OfflineVAR(blocks=blocks).fit(Xt, resets=rt)
    click.echo(f"offline VAR: order {model.order_} (BIC), fitted on {train}, {len(Xt)} frames")

    def offline(rec):
        if rec.X.shape[1] != Xt.shape[1]:
            return None
        return OfflineVAR(blocks=blocks).fit(Xt, resets=rt)

    return {"offline VAR": offline}
