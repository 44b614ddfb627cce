"""`handvar experiment` and `handvar report`: the paper's experiments and its figures."""

from __future__ import annotations

import sys

import click

from handvar.cli.common import _one_line_errors

# --- experiment: the paper's tracking experiments on Dask ------------------------------


@click.command("experiment")
@click.option(
    "--out",
    "store",
    type=click.Path(file_okay=False),
    default="experiment.zarr",
    show_default=True,
    help="Zarr store of the results; an existing one is resumed.",
)
@click.option("--scheduler", default=None, help="Address of an existing Dask scheduler.")
@click.option(
    "--workers",
    type=click.IntRange(min=1),
    default=None,
    help="Worker processes of the embedded cluster [default: the number of cores].",
)
@click.option(
    "--set", "assignments", multiple=True, metavar="KEY=VALUE",
    help="Change the protocol: trials=4, frames=40, seed=1, trial=openloop, "
    "rvar.gamma=0.7, tracker.FIELD=V, predictors=none,rvar, extras=true; repeatable.",
)  # fmt: skip
@click.option(
    "--sweep", "sweeps", multiple=True, metavar="PRED.ARG=V1,V2,...",
    help="Add variants of a predictor, e.g. rvar.gamma=0.5,0.6,0.7; repeatable.",
)  # fmt: skip
@click.option("--quick", is_flag=True, help="A reduced protocol: 3 trials of 40 frames.")
@click.option(
    "--extras",
    is_flag=True,
    help="Add ours: edge and relative RVAR, Kalman CV, One Euro and both adaptive banks.",
)
@click.option("--progress/--no-progress", default=True, show_default=True)
@_one_line_errors
def experiment_command(store, scheduler, workers, assignments, sweeps, quick, extras, progress):
    """Run the paper's experiment (5 predictors x 50 trials x 175 frames) into a store.

    Trials run as tasks on Dask: an embedded local cluster (one process per core)
    or --scheduler.  Each finished trial is written at once; running the same
    command again computes only the missing trials.  With an existing store and no
    protocol options, its own configuration is resumed.
    """
    import os

    from handvar.atomic import check_output_dir
    from handvar.evaluation.config import ExperimentConfig, tracker_settings
    from handvar.evaluation.experiment import run_experiment, summary_text
    from handvar.evaluation.store import read_config, store_sequence

    check_output_dir(store, "--out")
    resume = os.path.exists(store)
    if resume and not (assignments or sweeps or quick or extras):
        config = read_config(store)
    else:
        config = ExperimentConfig.quick() if quick else ExperimentConfig()
        if extras:
            config = config.with_extras()
        for text in assignments:
            config = _configure(config.with_overrides, [text], "--set", text)
        for text in sweeps:
            config = _configure(config.with_sweep, text, "--sweep", text)
    # every setting is checked before any work (rendering, a cluster)
    if config.trial_kind == "tracker":
        _configure(tracker_settings, config.tracker, "--set", "tracker")
    for spec in config.predictors:
        _configure(spec.build, None, "--set", spec.key)
    if resume and read_config(store) != config:
        raise ValueError(
            f"--out: {store} holds a different experiment; choose another --out or the "
            "same settings (or none, to resume it)"
        )
    if resume:  # a store that cannot be resumed is refused before the heading
        store_sequence(store)
    click.echo(
        f"{len(config.predictors)} predictors x {config.trials} trials x {config.frames} "
        f"frames of {config.sequence} ({config.trial_kind}) -> {store}"
    )
    summary = run_experiment(config, store, scheduler=scheduler, workers=workers, progress=progress)
    if summary.repaired:
        click.echo(
            f"{store}: {len(summary.repaired)} damaged trials recomputed: "
            + ", ".join(f"{label} trial {t}" for label, t in summary.repaired)
        )
    click.echo(summary_text(summary))
    if not summary.complete:
        sys.exit(1)


def _configure(apply, arg, option: str, text: str):
    """``apply(arg)`` (or ``apply()``), its ValueError / TypeError naming `option` and `text`."""
    try:
        return apply() if arg is None else apply(arg)
    except (ValueError, TypeError) as exc:
        msg = str(exc)
        if msg.startswith(option):
            raise ValueError(msg) from None
        raise ValueError(f"{option} {text}: {msg}") from None


# --- report: the paper's figures and claims from an experiment store --------------------


@click.command("report")
@click.argument("store", type=click.Path(file_okay=False))
@click.option(
    "--out",
    type=click.Path(file_okay=False),
    default=None,
    help="Output directory [default: STORE's name with -report].",
)
@_one_line_errors
def report_command(store, out):
    """Draw the paper's figures 2-6 and the table of its claims from STORE."""
    import os

    from handvar.atomic import check_output_dir
    from handvar.evaluation.report import write_report

    if out is None:
        base = os.path.splitext(os.path.normpath(store))[0]
        out = f"{base}-report"
    check_output_dir(out, "--out")
    path = write_report(store, out)
    click.echo(f"report -> {path} (and report.html, figures in {out})")
