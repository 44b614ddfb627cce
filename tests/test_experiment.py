"""The experiment machinery: configuration, one trial, the store, resuming, Dask."""

from __future__ import annotations

import dataclasses
import json
import os
import signal

import numpy as np
import pytest

from handvar import params
from handvar.evaluation.config import (
    EXTRA_PREDICTORS,
    PAPER_PREDICTORS,
    ExperimentConfig,
    PredictorSpec,
    tracker_settings,
)
from handvar.evaluation.experiment import run_experiment
from handvar.evaluation.metrics import mean_joint_error, r2_tilde_acceleration, r2_tilde_joints
from handvar.evaluation.store import open_store, read_config, store_sequence
from handvar.evaluation.trials import FrameCache, TrialRunner, run_trial
from handvar.predictors import RVAR, VAR, Decelerating, one_step_predictions

# The paper's five predictors with the tracker, reduced: 2 trials of 40 frames.
SMALL = ExperimentConfig(trials=2, frames=40)
# Shorter still, for interrupting runs: 3 trials of 10 frames.
SHORT = ExperimentConfig(trials=3, frames=10)
# No tracker: the predictors one step ahead on noisy truth.
OPENLOOP = ExperimentConfig(trials=2, frames=40, trial_kind="openloop")


@pytest.fixture(scope="module")
def client():
    from distributed import Client, LocalCluster

    cluster = LocalCluster(
        n_workers=2, threads_per_worker=1, processes=True, dashboard_address=":0", silence_logs=40
    )
    c = Client(cluster)
    yield c
    c.close()
    cluster.close()


@pytest.fixture(scope="module")
def small_store(client, tmp_path_factory):
    path = tmp_path_factory.mktemp("exp") / "small.zarr"
    summary = run_experiment(SMALL, path, client=client, progress=False)
    return path, summary


# --- configuration -----------------------------------------------------------------


def test_default_config_is_the_papers_protocol():
    cfg = ExperimentConfig()
    assert (cfg.trials, cfg.frames, cfg.sequence, cfg.trial_kind) == (
        50,
        175,
        "benchmark",
        "tracker",
    )
    assert cfg.labels == ["no motion", "decelerating", "full VAR", "structured VAR", "RVAR"]
    built = [s.build() for s in cfg.predictors]
    assert built[1].rho == 0.4
    assert built[2].memory == 150 and built[2].blocks is None
    assert built[3].memory == 30 and built[3].blocks == params.hand_blocks()
    assert (built[4].gamma, built[4].cutoff, built[4].mode) == (0.8, 8, "paper")


def test_overrides_and_sweep():
    cfg = ExperimentConfig().with_overrides(
        ["trials=4", "frames=40", "rvar.γ=0.7", "decelerating.rho=0.5", "trial=openloop"]
    )
    assert (cfg.trials, cfg.frames, cfg.trial_kind) == (4, 40, "openloop")
    assert cfg.spec("rvar").build().gamma == 0.7
    assert cfg.spec("decelerating").build().rho == 0.5
    swept = cfg.with_sweep("rvar.gamma=0.5,0.7,0.9").with_sweep("structured_var.N=20")
    assert swept.labels[5:] == [
        "RVAR (gamma=0.5)",
        "RVAR (gamma=0.9)",
        "structured VAR (memory=20)",
    ]  # 0.7 is the entry's own value
    assert swept.spec("RVAR (gamma=0.9)").build().gamma == 0.9
    assert swept.spec("structured VAR (memory=20)").build().memory == 20
    assert swept.spec("RVAR (gamma=0.5)").build().cutoff == 8
    sub = ExperimentConfig().with_overrides(["predictors=none,rvar,kalman"])
    assert sub.labels == ["no motion", "RVAR", "Kalman CV"]
    assert ExperimentConfig().with_overrides(["extras=true"]).labels[-len(EXTRA_PREDICTORS) :] == [
        s.label for s in EXTRA_PREDICTORS
    ]


def test_config_json_round_trip():
    cfg = ExperimentConfig().with_extras().with_sweep("rvar.cutoff=4,12")
    again = ExperimentConfig.from_json(cfg.to_json())
    assert again == cfg
    assert json.loads(cfg.to_json())["predictors"][0] == PAPER_PREDICTORS[0].to_dict()


@pytest.mark.parametrize(
    ("assignment", "words"),
    [
        ("trials=0", "trials"),
        ("frames=two", "frames"),
        ("sequence=nope", "sequence"),
        ("trial=fast", "trial_kind"),
        ("rvar.gamma=1.5", "gamma"),
        ("rvar.bogus=1", "params"),
        ("nothing=1", "--set"),
        ("trials", "KEY=VALUE"),
        ("predictors=none,foo", "predictors"),
    ],
)
def test_bad_overrides_raise_value_error_naming_the_key(assignment, words):
    with pytest.raises(ValueError, match=words):
        ExperimentConfig().with_overrides([assignment])


def test_bad_config_values():
    with pytest.raises(ValueError, match="predictors"):
        ExperimentConfig(predictors=(PAPER_PREDICTORS[0], PAPER_PREDICTORS[0]))
    with pytest.raises(ValueError, match="kind"):
        PredictorSpec("x", "x", "magic")
    with pytest.raises(ValueError, match="--sweep"):
        ExperimentConfig().with_sweep("gamma=0.5")


# --- one trial ----------------------------------------------------------------------


def test_openloop_trial_matches_one_step_predictions():
    from handvar.synth.sequences import make_sequence

    seq = make_sequence("benchmark", n_frames=40)
    res = run_trial(OPENLOOP, "structured_var", 1, seq)
    # The same noise, drawn independently from the trial's seed.
    rng = np.random.default_rng([OPENLOOP.seed, 1])
    truth = seq.truth.poses
    observed = params.clamp(truth + rng.normal(0.0, OPENLOOP.noise, truth.shape))
    observed[0] = truth[0]
    expected = params.clamp(
        one_step_predictions(VAR(order=1, memory=30, blocks=params.hand_blocks()), observed)
    )
    np.testing.assert_allclose(res.poses[1:], expected[1:], rtol=0, atol=1e-12)
    np.testing.assert_array_equal(res.poses[0], truth[0])
    np.testing.assert_allclose(res.joints[5], _joints(res.poses[5]), rtol=0, atol=1e-12)
    with pytest.raises(ValueError, match="frames"):
        run_trial(dataclasses.replace(OPENLOOP, frames=30), "rvar", 0, seq)


def test_tracker_trial_is_the_tracker_with_the_trials_seed():
    from handvar.hand.kinematics import HandModel
    from handvar.synth.sequences import make_sequence
    from handvar.tracking import Tracker

    cfg = dataclasses.replace(SHORT, frames=6).with_overrides(["tracker.max_iterations=8"])
    assert cfg.tracker == (("smd.max_iterations", 8),)
    seq = make_sequence("benchmark", n_frames=6)
    res = run_trial(cfg, "rvar", 2, seq)
    settings = tracker_settings([("smd.max_iterations", 8)])
    direct = Tracker(seq.rig, HandModel(), RVAR(), np.random.default_rng([0, 2]), settings)
    expected = direct.track(seq, seq.truth.poses[0])
    np.testing.assert_array_equal(res.poses, expected.poses)
    np.testing.assert_array_equal(res.iterations, expected.iterations)
    assert res.iterations.max() <= 8 and res.timings.shape == (6, 3)
    np.testing.assert_array_equal(res.cost, expected.final_costs)
    with pytest.raises(ValueError, match="tracker setting"):
        SHORT.with_overrides(["tracker.speed=3"])
    with pytest.raises(ValueError, match="max_iterations"):
        SHORT.with_overrides(["tracker.max_iterations=0"])


def test_frame_cache_prepares_once_per_sequence_and_gives_the_same_trial():
    import pickle

    from handvar.synth.sequences import make_sequence

    cfg = dataclasses.replace(SHORT, frames=6).with_overrides(["tracker.max_iterations=8"])
    seq = make_sequence("benchmark", n_frames=6)
    runner = TrialRunner(seq)
    first = runner.run(cfg, "rvar", 1)
    held = runner.cache._held[2]
    assert len(runner.cache) == 6
    again = runner.run(cfg, "none", 0)
    assert runner.cache._held[2] is held  # the same prepared frames, not prepared again
    # a trial with shared frames is the trial without them, bit for bit
    np.testing.assert_array_equal(first.poses, run_trial(cfg, "rvar", 1, seq).poses)
    np.testing.assert_array_equal(again.poses, run_trial(cfg, "none", 0, seq).poses)
    # another sequence object replaces the held one; a pickled cache travels empty
    runner.cache.frames(_tracker(seq), make_sequence("benchmark", n_frames=6), "k")
    assert runner.cache._held[2] is not held
    assert len(pickle.loads(pickle.dumps(runner.cache))) == 0
    assert isinstance(pickle.loads(pickle.dumps(runner)).cache, FrameCache)


def _tracker(seq):
    from handvar.tracking import Tracker

    return Tracker(seq.rig)


def _joints(x):
    from handvar.hand.kinematics import HandModel

    return HandModel().joints(x)


# --- the store, on a Dask cluster ------------------------------------------------------


def test_store_holds_every_trial_and_consistent_scores(small_store):
    path, summary = small_store
    assert summary.complete and summary.computed == 10 and summary.already_done == 0
    ds = open_store(path)
    assert read_config(path) == SMALL
    assert ds["done"].values.all()
    np.testing.assert_array_equal(ds["writes"].values, 1)
    truth_z = ds["truth_joints"].values
    truth_x = ds["truth_poses"].values
    joints = ds["joints"].values
    poses = ds["poses"].values
    # every stored value agrees with the metrics recomputed from the stored poses
    for p in range(5):
        for t in range(2):
            np.testing.assert_allclose(joints[p, t, 7], _joints(poses[p, t, 7]), rtol=0, atol=1e-9)
            np.testing.assert_allclose(
                ds["error"].values[p, t], mean_joint_error(truth_z, joints[p, t]), atol=1e-12
            )
            np.testing.assert_allclose(
                ds["r2_joints"].values[p, t],
                r2_tilde_joints(truth_z, joints[p, t], joints[0, t]),
                atol=1e-12,
            )
            np.testing.assert_allclose(
                ds["r2_params"].values[p, t],
                r2_tilde_acceleration(truth_x, poses[p, t], poses[0, t]),
                atol=1e-12,
            )
    np.testing.assert_array_equal(ds["r2_joints"].values[0], 0.0)  # none against itself
    # the sequence kept in the store is the rendered one
    seq = store_sequence(path)
    from handvar.synth.sequences import make_sequence

    again = make_sequence("benchmark", n_frames=40)
    np.testing.assert_array_equal(np.asarray(seq.masks), again.masks)
    np.testing.assert_array_equal(seq.truth.poses, again.truth.poses)
    assert seq.rig.allclose(again.rig)


def test_small_store_makes_a_report_with_every_figure(small_store, tmp_path):
    from handvar.evaluation.report import write_report

    path, _ = small_store
    md = write_report(path, tmp_path / "report")
    names = {p.name for p in (tmp_path / "report").iterdir()}
    for fig in ("fig2_r2_decelerating", "fig3_r2_structured_var", "fig4_mean_error",
                "fig5_r2_rvar", "fig6_overlays", "r2_full_var"):  # fmt: skip
        assert f"{fig}.png" in names
    assert "report.html" in names and "10/10 trials finished" in md.read_text()


def test_rerun_computes_nothing_and_other_config_is_refused(small_store, client):
    path, _ = small_store
    summary = run_experiment(SMALL, path, client=client, progress=False)
    assert (summary.computed, summary.already_done, summary.complete) == (0, 10, True)
    with pytest.raises(ValueError, match="different experiment"):
        run_experiment(dataclasses.replace(SMALL, seed=1), path, client=client, progress=False)


@pytest.mark.slow
def test_same_seed_same_store(small_store, client, tmp_path):
    path, _ = small_store
    other = tmp_path / "again.zarr"
    run_experiment(SMALL, other, client=client, progress=False)
    a, b = open_store(path), open_store(other)
    for name in a.data_vars:
        if name != "timings":  # wall-clock times differ from run to run
            np.testing.assert_array_equal(a[name].values, b[name].values, err_msg=name)
    assert a.attrs == b.attrs


def test_restart_loses_no_finished_trial_and_rerun_completes(client, tmp_path):
    path = tmp_path / "restart.zarr"
    cfg = SHORT
    written = []

    def restart_once(label, trial):
        written.append((label, trial))
        if len(written) == 1:
            client.restart()  # every worker killed mid-run

    first = run_experiment(
        cfg, path, client=client, progress=False, rounds=1, on_written=restart_once
    )
    ds = open_store(path)
    done = ds["done"].values
    assert 1 <= done.sum() == first.computed < 15
    assert len(first.missing) == 15 - first.computed
    finished = ds["poses"].values[done]
    second = run_experiment(cfg, path, client=client, progress=False)
    assert second.already_done == first.computed
    assert second.computed == 15 - first.computed
    ds = open_store(path)
    np.testing.assert_array_equal(ds["writes"].values, 1)  # no trial written twice
    np.testing.assert_array_equal(ds["poses"].values[done], finished)
    assert np.isfinite(ds["r2_joints"].values).all()


@pytest.mark.slow
def test_killed_worker_process_loses_nothing(client, tmp_path):
    path = tmp_path / "kill.zarr"
    cfg = SHORT
    killed = []

    def kill_one_worker(label, trial):
        if not killed:
            pid = next(iter(client.run(os.getpid).values()))
            os.kill(pid, signal.SIGKILL)
            killed.append(pid)

    summary = run_experiment(cfg, path, client=client, progress=False, on_written=kill_one_worker)
    assert killed
    ds = open_store(path)
    missing = int((~ds["done"].values).sum())
    assert missing == len(summary.missing)
    rerun = run_experiment(cfg, path, client=client, progress=False)
    assert rerun.computed == missing and summary.computed + rerun.computed == 15
    np.testing.assert_array_equal(open_store(path)["writes"].values, 1)


@pytest.mark.slow
def test_interrupted_run_leaves_a_readable_store(client, tmp_path):
    path = tmp_path / "stop.zarr"

    class Stop(Exception):
        pass

    def stop(label, trial):
        raise Stop

    with pytest.raises(Stop):
        run_experiment(SHORT, path, client=client, progress=False, on_written=stop)
    ds = open_store(path)
    assert int(ds["done"].values.sum()) == 1
    assert np.isnan(ds["poses"].values[~ds["done"].values]).all()
    summary = run_experiment(SHORT, path, client=client, progress=False)
    assert (summary.already_done, summary.computed) == (1, 14)


def test_open_store_rejects_other_directories(tmp_path):
    with pytest.raises(ValueError, match="store"):
        open_store(tmp_path / "missing.zarr")
    (tmp_path / "plain").mkdir()
    with pytest.raises(ValueError, match="store"):
        open_store(tmp_path / "plain")


def test_predictor_specs_build_the_papers_predictors():
    cfg = ExperimentConfig().with_extras()
    rel = cfg.spec("rvar_relative").build()
    assert isinstance(rel, RVAR) and rel.mode == "relative"
    assert isinstance(cfg.spec("decelerating").build(), Decelerating)
    rvar_n = cfg.spec("rvar").with_params(N=20).build()
    assert rvar_n.structured.memory == 20


def test_cli_experiment_and_report(tmp_path):
    from click.testing import CliRunner

    from handvar.cli import main

    store = tmp_path / "cli.zarr"
    runner = CliRunner()
    args = ["experiment", "--out", str(store), "--workers", "1", "--no-progress"]
    setting = ["--set", "trial=openloop", "--set", "trials=1", "--set", "frames=6"]
    res = runner.invoke(main, [*args, *setting, "--sweep", "rvar.c=4"])
    assert res.exit_code == 0, res.output
    assert "6 predictors x 1 trials x 6 frames" in res.output
    assert read_config(store).labels[-1] == "RVAR (cutoff=4)"
    again = runner.invoke(main, args)  # an existing store resumes its own configuration
    assert again.exit_code == 0 and "6 already done, 0 computed" in again.output
    rep = runner.invoke(main, ["report", str(store), "--out", str(tmp_path / "rep")])
    assert rep.exit_code == 0 and (tmp_path / "rep" / "report.html").is_file()
    bad = runner.invoke(
        main, ["experiment", "--out", str(tmp_path / "x.zarr"), "--set", "trials=-1"]
    )
    assert bad.exit_code == 2 and bad.output.count("\n") == 1 and "trials" in bad.output
