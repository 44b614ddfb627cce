"""Damaged experiment stores: found, recomputed on resume, refused by the report (design §13.3)."""

from __future__ import annotations

import shutil

import numpy as np
import pytest
from click.testing import CliRunner

from handvar.cli import main
from handvar.evaluation.config import ExperimentConfig
from handvar.evaluation.experiment import run_experiment
from handvar.evaluation.store import _write_region, damaged_trials, open_store

pytestmark = pytest.mark.slow  # a Dask client and 13 trials: about a minute

CONFIG = ExperimentConfig(trials=2, frames=6, trial_kind="openloop")


@pytest.fixture(scope="module")
def client():
    from distributed import Client

    c = Client(processes=False, n_workers=1, threads_per_worker=1, dashboard_address=":0")
    yield c
    c.close()


@pytest.fixture(scope="module")
def sound(client, tmp_path_factory):
    path = tmp_path_factory.mktemp("verify") / "sound.zarr"
    run_experiment(CONFIG, path, client=client, progress=False)
    return path


def _damage(sound, tmp_path):
    """A copy of the store with three trials damaged three ways."""
    path = tmp_path / "damaged.zarr"
    shutil.copytree(sound, path)
    (path / "error" / "1.0.0").write_bytes(b"not blosc")  # unreadable chunk
    (path / "poses" / "2.1.0.0").unlink()  # a chunk file missing
    nan = {
        "joints": (
            ("predictor", "trial", "frame", "joint", "xyz"),
            np.full((1, 1, 6, 21, 3), np.nan),
        )
    }
    _write_region(path, nan, 3, 0)  # NaN where a finished trial has numbers
    return path


def test_a_sound_store_has_no_damage(sound):
    assert damaged_trials(sound) == []


def test_damage_is_named_and_the_report_refuses_before_any_figure(sound, tmp_path):
    path = _damage(sound, tmp_path)
    labels = [str(v) for v in open_store(path)["predictor"].values]
    found = {(d.label, d.trial): d.reason for d in damaged_trials(path)}
    assert set(found) == {(labels[1], 0), (labels[2], 1), (labels[3], 0)}
    assert found[(labels[1], 0)].startswith("error: unreadable chunk 1.0.0")
    assert found[(labels[2], 1)] == "poses: chunk file 2.1.0.0 missing"
    # an all-NaN chunk equals the fill value, so zarr leaves no file: either reason
    assert found[(labels[3], 0)] in (
        "joints: NaN or infinity in a finished trial",
        "joints: chunk file 3.0.0.0.0 missing",
    )
    out = tmp_path / "report"
    res = CliRunner().invoke(main, ["report", str(path), "--out", str(out)])
    assert res.exit_code == 2
    lines = res.output.strip().splitlines()
    assert len(lines) == 1
    assert f"damaged trial 0 of predictor {labels[1]!r}" in lines[0]
    assert not out.exists()  # no figure written


def test_resume_recomputes_damaged_trials_bit_identically(sound, tmp_path, client):
    path = _damage(sound, tmp_path)
    summary = run_experiment(CONFIG, path, client=client, progress=False)
    labels = CONFIG.labels
    assert sorted(summary.repaired) == sorted([(labels[1], 0), (labels[2], 1), (labels[3], 0)])
    assert summary.computed == 3 and summary.already_done == 7 and summary.complete
    assert damaged_trials(path) == []
    a, b = open_store(sound), open_store(path)
    for name in ("poses", "joints", "error", "r2_joints", "r2_params", "done"):
        np.testing.assert_array_equal(a[name].values, b[name].values, err_msg=name)
    again = run_experiment(CONFIG, path, client=client, progress=False)
    assert again.repaired == () and again.computed == 0
    res = CliRunner().invoke(main, ["report", str(path), "--out", str(tmp_path / "r")])
    assert res.exit_code == 0, res.output
