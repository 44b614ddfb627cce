"""Tests of `handvar.track` and `handvar.Track`: the pipeline in one call."""

from __future__ import annotations

import numpy as np
import pandas as pd
import pytest

from handvar.hand import HandModel
from handvar.params import NAMES
from handvar.pipeline import Track, track


@pytest.fixture(scope="module")
def recovered():
    """Three frames of the synthetic benchmark, tracked with recovery (so with quality)."""
    return track("benchmark", frames=3, recover=True, seed=1)


def test_a_track_holds_the_model_joints_and_their_projections(recovered):
    t = recovered
    assert t.poses.shape == (3, 26) and t.joints.shape == (3, 21, 3)
    assert t.projected.shape == (len(t.rig), 3, 21, 2)
    # G(x) of the fitted poses, by the hand model directly
    np.testing.assert_allclose(t.joints[2], HandModel(t.shape).joints(t.poses[2]), atol=1e-9)
    for c, cam in enumerate(t.rig.cameras):
        np.testing.assert_allclose(t.projected[c, 1], cam.project(t.joints[1]), atol=1e-9)
    assert t.shape.side == "right" and t.predictor == "rvar" and t.seed == 1
    assert t.options["keypoint_tips"] == "end" and t.options["carry"] == "none"
    assert t.quality is not None and len(t.quality.iou) == 3
    assert t.fit_seconds.shape == (3,) and np.all(t.fit_seconds > 0)
    # the synthetic sequence's truth: the tracker starts at the true first pose
    np.testing.assert_allclose(t.result.starts[0], t.sequence.truth.poses[0])


def test_save_then_load_gives_the_track_back(recovered, tmp_path):
    written = recovered.save(tmp_path / "t", video=False)
    assert {"poses", "joints", "track", "overlay", "quality"} <= set(written)
    back = Track.load(tmp_path / "t")
    for name in ("poses", "joints", "projected", "search_seconds"):
        np.testing.assert_array_equal(getattr(back, name), getattr(recovered, name))
    for name in ("iou", "keypoint_error", "lost", "reinit", "empty", "keypoints"):
        np.testing.assert_array_equal(getattr(back.quality, name), getattr(recovered.quality, name))
    np.testing.assert_array_equal(back.shape.segments, recovered.shape.segments)
    assert back.shape.side == recovered.shape.side
    assert back.rig.allclose(recovered.rig)
    assert (back.name, back.predictor, back.seed) == ("benchmark", "rvar", 1)
    assert back.options == recovered.options
    # a loaded track has no frames: saved again without overlays, the same numbers
    with pytest.raises(ValueError, match="overlays"):
        back.save(tmp_path / "again")
    back.save(tmp_path / "again", video=False, overlays=False)
    for name in ("poses.csv", "joints.csv", "quality.csv"):
        assert (tmp_path / "again" / name).read_bytes() == (tmp_path / "t" / name).read_bytes()


def test_the_wide_table_matches_the_csv_files_read_by_pandas(recovered, tmp_path):
    recovered.save(tmp_path / "t", video=False)
    wide = recovered.to_dataframe()
    poses = pd.read_csv(tmp_path / "t" / "poses.csv")
    assert list(poses.columns) == list(NAMES)
    np.testing.assert_allclose(wide[list(NAMES)].to_numpy(), poses.to_numpy(), atol=1e-6)
    quality = pd.read_csv(tmp_path / "t" / "quality.csv")
    np.testing.assert_allclose(wide["iou"].to_numpy(), quality["iou"].to_numpy(), atol=1e-4)
    joints = pd.read_csv(tmp_path / "t" / "joints.csv").to_numpy()
    np.testing.assert_allclose(wide.filter(regex="_[xyz]$").to_numpy(), joints, atol=1e-4)


def test_the_long_table_has_a_row_per_frame_and_joint(recovered):
    long = recovered.to_dataframe("long")
    assert len(long) == 3 * 21
    row = long[(long.frame == 2) & (long.joint == long.joint.iloc[4])].iloc[0]
    np.testing.assert_allclose(row[["x", "y", "z"]].to_numpy(float), recovered.joints[2, 4])
    cam = recovered.rig.names[0]
    np.testing.assert_allclose(
        row[[f"u_{cam}", f"v_{cam}"]].to_numpy(float), recovered.projected[0, 2, 4]
    )


def test_without_recovery_a_sequence_has_no_quality():
    t = track("benchmark", frames=2, predictor="decel")
    assert t.quality is None and t.options["recover"] is False
    assert len(t.search_seconds) == 0 and t.detections is None


@pytest.mark.parametrize(
    ("kwargs", "message"),
    [
        ({"keypoint_every": 2}, "keypoint_every: expected only with keypoints"),
        ({"carry": "forward"}, "carry: expected a recording"),
        ({"hand": "left", "model": "mesh"}, "model: expected spheres for a left hand"),
        ({"calib": "rig.yml"}, "calib, fov: expected only with a video"),
        ({"init": "nonesuch"}, "init: expected a named pose"),
        ({"predictor": "nonesuch"}, "predictor: expected one of"),
        ({"keypoint_tips": "nail"}, "keypoint_tips: expected one of"),
        ({"frames": 0}, "frames: expected an integer"),
    ],
)
def test_errors_name_the_keyword(kwargs, message):
    with pytest.raises(ValueError, match=message):
        track("benchmark", **{"frames": 1, **kwargs})


def test_an_unknown_source_is_named():
    with pytest.raises(ValueError, match="source: expected a sequence directory"):
        track("nonesuch")
