"""`handvar predict`: the open-loop table on the real recording, and its errors."""

from __future__ import annotations

import numpy as np
import pytest
from click.testing import CliRunner

from handvar.cli import main, make_predictor
from handvar.data import example_path
from handvar.evaluation.openloop import (
    BASELINES,
    TABLE_ROWS,
    evaluate_open_loop,
    read_pose_series,
)
from handvar.predictors import NoMotion, one_step_predictions
from handvar.predictors.catalogue import CATALOGUE


@pytest.mark.slow  # 13 s, the whole recording; the tests below run on parts of real ones
def test_predict_table_on_the_real_recording(tmp_path):
    out = tmp_path / "table.csv"
    result = CliRunner().invoke(
        main,
        [
            "predict", str(example_path("htrack")), "--layout", "htrack",
            "--reset-at", "4000", "--csv", str(out),
        ],
    )  # fmt: skip
    assert result.exit_code == 0, result.output
    assert "little flexion (deg)" in result.output
    rows = np.genfromtxt(out, delimiter=",", names=True, dtype=None, encoding="utf-8")
    none = rows[rows["predictor"] == "no motion"]
    np.testing.assert_allclose(none["r2_tilde"], 0.0, atol=1e-12)
    # Two recordings: both first frames are unscored.
    assert set(rows["frames"]) == {6000 - 2}


def test_open_loop_scores_equal_a_direct_computation(fingerfist):
    from handvar.synth.motion import htrack_to_handvar

    X = htrack_to_handvar(fingerfist[:300])
    rows = evaluate_open_loop(X)
    none = one_step_predictions(NoMotion(), X)
    dec = one_step_predictions(make_predictor("decelerating"), X)
    idx = np.arange(14, 17)  # index finger flexion
    r2 = 1 - np.sum((X - dec)[1:, idx] ** 2) / np.sum((X - none)[1:, idx] ** 2)
    (row,) = [r for r in rows if r.group == "index flexion" and r.predictor == "decelerating"]
    assert abs(row.r2_tilde - r2) < 1e-12
    assert abs(row.rmse - np.sqrt(np.mean((X - dec)[1:, idx] ** 2))) < 1e-12


@pytest.mark.parametrize("chunk", [1, 7, 64])
def test_streamed_scores_equal_the_whole_series_at_once(fingerfist, chunk):
    """Streaming `chunk` frames at a time gives the scores of holding every prediction."""
    from handvar.synth.motion import htrack_to_handvar

    X = htrack_to_handvar(fingerfist[:150])
    truth = X + 0.0
    noisy = X + np.random.default_rng(3).normal(scale=0.5, size=X.shape)
    names = ("decelerating", "rvar", "adaptive", "kalman")
    resets = (60,)

    def fresh():  # by label, as the rows name them
        return {CATALOGUE[n].label: make_predictor(n) for n in ("none", *names)}

    streamed = evaluate_open_loop(noisy, fresh(), resets=resets, truth=truth, chunk=chunk)
    # The whole series at once: every prediction held, then scored with numpy.
    preds = {n: one_step_predictions(p, noisy, resets=resets) for n, p in fresh().items()}
    ok = np.isfinite(preds["no motion"]).all(1)
    assert ok.sum() == len(X) - 2
    assert {r.predictor for r in streamed} == set(preds)
    for row in streamed:
        if row.predictor == "no motion":
            continue
        (_, _, idx), *_ = [g for g in TABLE_ROWS if g[0] == row.group]
        err = (truth - preds[row.predictor])[ok][:, idx]
        ref = (truth - preds["no motion"])[ok][:, idx]
        np.testing.assert_allclose(row.rmse, np.sqrt(np.mean(err**2)), rtol=1e-12)
        np.testing.assert_allclose(row.mae, np.mean(np.abs(err)), rtol=1e-12)
        np.testing.assert_allclose(row.r2_tilde, 1 - np.sum(err**2) / np.sum(ref**2), rtol=1e-12,
                                   atol=1e-12)  # fmt: skip
        assert row.frames == ok.sum()


def test_pose_files_in_three_formats_read_the_same(tmp_path):
    X = np.random.default_rng(0).normal(size=(7, 26))
    np.save(tmp_path / "p.npy", X)
    np.savetxt(tmp_path / "p.txt", X)
    np.savetxt(tmp_path / "p.csv", X, delimiter=",", header=",".join(f"c{i}" for i in range(26)))
    for name in ("p.npy", "p.txt", "p.csv"):
        np.testing.assert_allclose(read_pose_series(tmp_path / name), X, rtol=1e-15)


def test_rows_without_values_split_the_series_as_resets_do(tmp_path):
    # A detector's output has frames without a hand: rows of NaN.  They are left out
    # and each run of rows with values is its own recording, exactly as the same rows
    # without the gaps, reset where each gap ended.
    rng = np.random.default_rng(3)
    X = np.cumsum(rng.normal(size=(90, 6)), axis=0)
    gappy = X.copy()
    gappy[[0, 30, 31, 32, 60]] = np.nan
    kept = np.delete(X, [0, 30, 31, 32, 60], axis=0)
    np.save(tmp_path / "gappy.npy", gappy)
    np.save(tmp_path / "kept.npy", kept)
    runner = CliRunner()
    a = runner.invoke(main, ["predict", str(tmp_path / "gappy.npy"), "--layout", "columns",
                             "--csv", str(tmp_path / "a.csv")])  # fmt: skip
    b = runner.invoke(main, ["predict", str(tmp_path / "kept.npy"), "--layout", "columns",
                             "--reset-at", "29", "--reset-at", "56",
                             "--csv", str(tmp_path / "b.csv")])  # fmt: skip
    assert a.exit_code == b.exit_code == 0, a.output + b.output
    assert "5 rows without values (NaN) left out; 3 runs" in a.output
    assert (tmp_path / "a.csv").read_text() == (tmp_path / "b.csv").read_text()
    partial = gappy.copy()
    partial[10, 2] = np.nan  # a frame with some values missing is malformed, not a gap
    np.save(tmp_path / "partial.npy", partial)
    c = runner.invoke(main, ["predict", str(tmp_path / "partial.npy"), "--layout", "columns"])
    assert c.exit_code == 2 and "row 10" in c.output, c.output


def test_predict_errors_are_one_line(tmp_path):
    bad = tmp_path / "bad.txt"
    bad.write_text("1 2 3\n4 5 nan\n")
    runner = CliRunner()
    for args in (
        ["predict", str(tmp_path / "missing.txt")],
        ["predict", str(bad)],
    ):
        result = runner.invoke(main, args)
        assert result.exit_code == 2
        assert len(result.output.strip().splitlines()) == 1
        assert result.output.startswith("handvar: error:")


def test_predict_on_real_keypoints(tmp_path):
    # The second real recording: 621 frames of 21 keypoints (metres), wrist-centred.
    out = tmp_path / "kp.csv"
    path = example_path("video-landmarks")
    result = CliRunner().invoke(
        main, ["predict", str(path), "--layout", "keypoints", "--csv", str(out)]
    )
    assert result.exit_code == 0, result.output
    rows = np.genfromtxt(out, delimiter=",", names=True, dtype=None, encoding="utf-8")
    assert {"wrist", "thumb", "little", "all digits"} <= set(rows["group"])
    # Direct check of one number: the decelerating predictor on the index finger (mm).
    X = 1000.0 * np.load(path).reshape(621, 63)
    dec = one_step_predictions(make_predictor("decel"), X)
    idx = np.arange(15, 27)
    rmse = np.sqrt(np.mean((X - dec)[1:, idx] ** 2))
    (row,) = rows[(rows["group"] == "index") & (rows["predictor"] == "decelerating")]
    assert abs(row["rmse"] - rmse) < 1e-4 * rmse


def test_keypoints_need_63_columns(tmp_path):
    bad = tmp_path / "x.npy"
    np.save(bad, np.zeros((10, 26)))
    result = CliRunner().invoke(main, ["predict", str(bad), "--layout", "keypoints"])
    assert result.exit_code == 2
    assert "63 columns" in result.output


# --- the league table -------------------------------------------------------------
@pytest.mark.slow
def test_predict_league_on_several_recordings_writes_csv_and_figure(tmp_path):
    csv, png = tmp_path / "league.csv", tmp_path / "league.png"
    result = CliRunner().invoke(
        main,
        [
            "predict", str(example_path("video-landmarks")) + ":0:300",
            str(example_path("video-landmarks")) + ":300:621",
            "--layout", "keypoints", "--predictor", "bank", "--noise",
            "--train", str(example_path("video-landmarks")) + ":0:300",
            "--csv", str(csv), "--figure", str(png),
        ],
    )  # fmt: skip
    assert result.exit_code == 0, result.output
    assert "RMSE / best baseline" in result.output
    rows = np.genfromtxt(csv, delimiter=",", names=True, dtype=None, encoding="utf-8")
    assert len(set(rows["recording"])) == 2 * 5  # each recording and 4 noisy variants
    allrows = rows[rows["group"] == "all"]
    # The best baseline's ratio is exactly 1 on every recording.
    base = allrows[np.isin(allrows["predictor"], list(BASELINES))]
    for rec in set(allrows["recording"]):
        assert base["ratio_to_best_baseline"][base["recording"] == rec].min() == 1.0
    assert {"adaptive bank", "offline VAR", "One Euro"} <= set(allrows["predictor"])
    assert png.read_bytes()[:4] == b"\x89PNG"


def test_predict_points_and_columns_layouts(tmp_path):
    D = np.load(example_path("video-landmarks"))[:200]
    f = tmp_path / "fourteen.npy"
    np.save(f, D[:, :14])
    result = CliRunner().invoke(main, ["predict", str(f), "--layout", "points"])
    assert result.exit_code == 0, result.output
    assert "point 13" in result.output and "all points" in result.output
    g = tmp_path / "cols.csv"
    np.savetxt(g, D[:, 0, :], delimiter=",")
    result = CliRunner().invoke(main, ["predict", str(g), "--layout", "columns"])
    assert result.exit_code == 0, result.output
    assert "column 2" in result.output


def test_predict_bad_paths_fail_before_computing(tmp_path):
    rec = str(example_path("video-landmarks"))
    for option, name in (("--csv", "x.csv"), ("--figure", "x.png")):
        result = CliRunner().invoke(
            main, ["predict", rec, "--layout", "keypoints", option, str(tmp_path / "no" / name)]
        )
        assert result.exit_code == 2
        assert f"{option}: expected a path in an existing folder" in result.output
    result = CliRunner().invoke(main, ["predict", rec + ":5:2", "--layout", "keypoints"])
    assert result.exit_code == 2 and "FILE: expected rows" in result.output
    result = CliRunner().invoke(main, ["predict", rec, "--predictor", "nope"])
    assert result.exit_code == 2 and "--predictor: expected one of" in result.output
    result = CliRunner().invoke(main, ["predict", rec, "--layout", "points", "--train", "x:a:b"])
    assert result.exit_code == 2 and "--train: expected FILE" in result.output


def test_python_m_handvar_is_the_same_command():
    """``python -m handvar`` runs `handvar.cli.main` (src/handvar/__main__.py)."""
    import os
    import subprocess
    import sys
    from pathlib import Path

    env = {**os.environ, "PYTHONPATH": str(Path(__file__).parents[1] / "src")}
    got = subprocess.run(
        [sys.executable, "-m", "handvar", "--version"], capture_output=True, text=True, env=env
    )
    assert got.returncode == 0, got.stderr
    import handvar

    assert got.stdout == f"handvar, version {handvar.__version__}\n"
    assert CliRunner().invoke(main, ["--version"]).output.endswith(got.stdout[len("handvar") :])
