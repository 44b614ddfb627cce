"""The report: figures and the claim table, generated from an experiment store."""

from __future__ import annotations

import dataclasses
import shutil
from html.parser import HTMLParser

import cv2
import numpy as np
import pytest
import zarr

from handvar.evaluation.claims import evaluate_claims
from handvar.evaluation.config import ExperimentConfig
from handvar.evaluation.experiment import run_experiment
from handvar.evaluation.figures import (
    mean_error_figure,
    overlay_figure,
    r2_boxplot,
    sweep_figure,
    sweeps,
)
from handvar.evaluation.report import write_report
from handvar.evaluation.results import error_peaks, load_results
from handvar.evaluation.store import open_store

# Open-loop trials: cheap and real (the predictors on noisy truth), with the extra predictors.
CONFIG = (
    ExperimentConfig(trials=6, frames=30, trial_kind="openloop", noise=0.5)
    .with_extras()
    .with_sweep("decelerating.rho=0.2,0.8")
)


@pytest.fixture(scope="module")
def store(tmp_path_factory):
    from distributed import Client, LocalCluster

    path = tmp_path_factory.mktemp("report") / "store.zarr"
    with (
        LocalCluster(
            processes=False, n_workers=1, threads_per_worker=2, dashboard_address=":0"
        ) as cluster,
        Client(cluster) as c,
    ):
        run_experiment(CONFIG, path, client=c, progress=False)
    return path


@pytest.fixture
def copy(store, tmp_path):
    path = tmp_path / "copy.zarr"
    shutil.copytree(store, path)
    return path


def _verdict(path, section, start):
    claims = evaluate_claims(load_results(path))
    hits = [c for c in claims if c.section == section and c.claim.startswith(start)]
    assert len(hits) == 1
    return hits[0]


def _set(path, name, predictor, value):
    """Overwrite one predictor's slice of a variable directly with zarr."""
    labels = list(open_store(path)["predictor"].values)
    group = zarr.open_group(str(path), mode="r+")
    arr = group[name]
    arr[labels.index(predictor)] = np.broadcast_to(value, arr.shape[1:])


# --- the claim table follows the store -------------------------------------------------


def test_claim_verdict_follows_the_store(copy):
    _set(copy, "r2_joints", "decelerating", 0.3)
    claim = _verdict(copy, "paper §4, fig. 2", "The decelerating")
    assert claim.holds is True and "= 0.30" in claim.measured
    _set(copy, "r2_joints", "decelerating", -0.3)
    claim = _verdict(copy, "paper §4, fig. 2", "The decelerating")
    assert claim.holds is False and "= -0.30" in claim.measured


def test_error_claim_follows_the_store(copy):
    _set(copy, "error", "RVAR", 0.01)
    assert _verdict(copy, "paper §5, fig. 4", "RVAR has the lowest").holds is True
    _set(copy, "error", "RVAR", 1000.0)
    assert _verdict(copy, "paper §5, fig. 4", "RVAR has the lowest").holds is False


def test_rvar_half_claim_counts_joints(copy):
    r2 = np.zeros((CONFIG.trials, 21))
    r2[:, :11] = 0.5  # 11 joints around 0.5: "most joints"
    _set(copy, "r2_joints", "RVAR", r2)
    claim = _verdict(copy, "paper §5, fig. 5", "RVAR (γ")
    assert claim.holds is True and claim.measured.startswith("11/21")
    r2[:, 10] = 0.9
    _set(copy, "r2_joints", "RVAR", r2)
    claim = _verdict(copy, "paper §5, fig. 5", "RVAR (γ")
    assert claim.holds is False and claim.measured.startswith("10/21")


def test_missing_predictor_gives_no_verdict(copy):
    _set(copy, "done", "Kalman CV", False)
    _set(copy, "r2_joints", "Kalman CV", np.nan)
    claim = _verdict(copy, "paper §4 (ρ = 1)", "Tracking with a constant-velocity")
    assert claim.holds is None and claim.verdict == "n/a"


def test_claim_statistics_match_numpy(store):
    results = load_results(store)
    ds = open_store(store)
    r2 = ds["r2_joints"].sel(predictor="full VAR").values
    expected = np.median(np.median(r2, axis=0))
    claim = _verdict(store, "paper §4.2", "The full VAR")
    assert f"= {expected:.2f}" in claim.measured
    assert claim.holds is bool(expected < 0)
    p = results.index("rvar")
    err = ds["error"].values[p][:, 1:].mean()
    assert results.overall_error(p) == pytest.approx(err, rel=1e-12)


# --- figures ---------------------------------------------------------------------------


def test_error_peaks():
    curve = np.zeros(60)
    curve[[0, 10, 12, 30, 45]] = [9.0, 5.0, 4.0, 3.0, 2.0]
    assert error_peaks(curve) == [10, 30, 45]  # frame 0 and 12 (too close) skipped
    assert error_peaks(curve, n=2, separation=1) == [10, 12]
    with pytest.raises(ValueError, match="curve"):
        error_peaks(np.zeros((3, 3)))


def test_boxplot_outliers_are_marked_as_in_the_paper(copy):
    values = np.zeros((CONFIG.trials, 21))
    values[:, :3] = [[0.0], [0.1], [0.2], [0.3], [0.4], [0.5]]
    # quartiles of 0, .1, ... .4 and one more value: 0.125 and 0.375, IQR 0.25
    values[-1, 1] = 1.0  # 0.625 above q3: between 1.5 and 3 IQR -> '+'
    values[-1, 2] = 10.0  # beyond 3 IQR -> 'o'
    _set(copy, "r2_joints", "RVAR", values)
    fig = r2_boxplot(load_results(copy), "rvar")
    ax = fig.axes[0]
    plus = [(x, y) for line in ax.lines if line.get_marker() == "+"
            for x, y in zip(line.get_xdata(), line.get_ydata(), strict=True)]  # fmt: skip
    rings = [(x, y) for line in ax.lines if line.get_marker() == "o"
             for x, y in zip(line.get_xdata(), line.get_ydata(), strict=True)]  # fmt: skip
    assert plus == [(2, 1.0)]
    assert rings == [(3, 10.0)]
    medians = [line.get_ydata()[0] for line in ax.lines if line.get_color() == "tab:red"
               and line.get_marker() in ("None", "")]  # fmt: skip
    np.testing.assert_allclose(medians[:3], np.median(values[:, :3], axis=0))


def test_mean_error_curves_are_the_trial_means(store):
    results = load_results(store)
    fig = mean_error_figure(results)
    lines = {line.get_label().split(" (")[0]: line for line in fig.axes[0].lines}
    ds = open_store(store)
    for label in ("no motion", "RVAR", "Kalman CV"):
        expected = ds["error"].sel(predictor=label).values.mean(axis=0)
        np.testing.assert_allclose(lines[label].get_ydata(), expected, rtol=1e-12)


def test_overlay_figure_rows_and_columns(store):
    results = load_results(store)
    fig = overlay_figure(store, results, frames=[5, 20])
    axes = fig.axes
    assert len(axes) == 6  # 3 predictors x 2 frames
    assert [ax.get_ylabel() for ax in axes[::2]] == ["no motion", "decelerating", "RVAR"]
    assert all(ax.get_title().startswith("frame 5") for ax in axes[::2])


def test_write_report_produces_every_file(store, tmp_path):
    out = tmp_path / "rep"
    md = write_report(store, out)
    names = {p.name for p in out.iterdir()}
    figures = {
        "fig2_r2_decelerating.png",
        "fig3_r2_structured_var.png",
        "fig4_mean_error.png",
        "fig5_r2_rvar.png",
        "fig6_overlays.png",
        "r2_full_var.png",
        "r2_rvar_relative.png",
        "r2_kalman.png",
        "r2_decelerating_rho_0_2.png",
        "sweep_decelerating_rho.png",
    }
    assert figures | {"report.md", "report.html"} <= names
    assert not [n for n in names if n.startswith(".")]  # no temporary file left
    for name in figures:
        image = cv2.imread(str(out / name))
        assert image is not None and image.shape[0] > 200 and image.shape[1] > 400
    text = md.read_text()
    claims = evaluate_claims(load_results(store))
    assert "| paper | claim of the paper | what we measured | holds? | test |" in text
    for c in claims:
        assert f"| {c.measured} | {c.verdict} |" in text.replace("\\|", "|")
    assert "OPEN-LOOP" in text

    class Rows(HTMLParser):
        rows = 0

        def handle_starttag(self, tag, attrs):
            self.rows += tag == "tr"

    parser = Rows()
    parser.feed((out / "report.html").read_text())
    # header + claims, header + one row per predictor
    assert parser.rows == 1 + len(claims) + 1 + len(CONFIG.predictors)


def test_report_of_an_unfinished_store(copy, tmp_path):
    group = zarr.open_group(str(copy), mode="r+")
    group["done"][:] = False
    group["done"][0, 0] = True
    group["r2_joints"][:] = np.nan
    md = write_report(copy, tmp_path / "rep")
    claims = evaluate_claims(load_results(copy))
    assert all(c.holds is None for c in claims)
    assert f"1/{len(CONFIG.predictors) * CONFIG.trials} trials finished" in md.read_text()


def test_bad_inputs(store, tmp_path):
    with pytest.raises(ValueError, match="predictor"):
        r2_boxplot(load_results(store), "nope")
    with pytest.raises(ValueError, match="store"):
        write_report(tmp_path / "nothing.zarr", tmp_path / "out")


def test_report_config_matches(store):
    assert dataclasses.asdict(load_results(store).config) == dataclasses.asdict(CONFIG)


def test_sweep_figure_plots_each_variant(store):
    results = load_results(store)
    points = sweeps(results)[("decelerating", "rho")]
    assert [v for v, _ in points] == [0.2, 0.4, 0.8]
    assert [results.labels[p] for _, p in points] == [
        "decelerating (rho=0.2)",
        "decelerating",
        "decelerating (rho=0.8)",
    ]
    fig = sweep_figure(results, "decelerating", "rho")
    line = fig.axes[0].lines[0]
    ds = open_store(store)
    expected = [
        ds["error"].sel(predictor=results.labels[p]).values[:, 1:].mean() for _, p in points
    ]
    np.testing.assert_allclose(line.get_xdata(), [0.2, 0.4, 0.8])
    np.testing.assert_allclose(line.get_ydata(), expected, rtol=1e-12)
    with pytest.raises(ValueError, match="swept"):
        sweep_figure(results, "rvar", "gamma")
