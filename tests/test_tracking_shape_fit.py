"""The hand's proportions fitted to several frames' keypoints (handvar.tracking.shape_fit),
against the shape the keypoints were made from."""

from __future__ import annotations

import numpy as np
import pytest

from handvar.camera import Rig
from handvar.hand import HandModel, named_pose
from handvar.hand.anthropometry import HandShape
from handvar.hand.kinematics import POSE_NAMES
from handvar.tracking.frame_fit import fit_frame
from handvar.tracking.shape_fit import DETAIL_FACTORS, ShapeFitSettings, adapt_shape, fit_shape

#: s, palm, thumb, index, middle, ring, little of the hand the keypoints come from
TRUE = np.array([1.05, 1.08, 0.93, 1.1, 1.05, 0.95, 0.9])


def frames(rig, truth, n=10, seed=0):
    rng = np.random.default_rng(seed)
    poses = []
    for i in range(n):
        x = named_pose(POSE_NAMES[i % len(POSE_NAMES)]).copy()
        x[3:6] += rng.normal(0.0, 15.0, 3)
        x[6:] += rng.normal(0.0, 5.0, 20)
        poses.append(x)
    kps = [[np.column_stack([c.project(truth.joints(x)), np.ones(21)]) for c in rig]
           for x in poses]  # fmt: skip
    return poses, kps


def wrist_to_tip(shape):
    return shape.bases[2, 1] + shape.segments[2].sum()


def test_adapt_shape_scales_the_bones_it_names():
    base = HandShape.from_size(185.0, side="left")
    s = adapt_shape(base, TRUE)
    np.testing.assert_allclose(s.segments, 1.05 * base.segments * TRUE[2:, None])
    np.testing.assert_allclose(s.bases[:, 1], 1.05 * 1.08 * base.bases[:, 1])
    np.testing.assert_allclose(s.bases[:, 0], 1.05 * base.bases[:, 0])
    assert s.side == "left"
    with pytest.raises(ValueError, match="factors"):
        adapt_shape(base, [1.0] * 6)


def test_a_stereo_rig_recovers_every_factor():
    base = HandShape.from_size(185.0)
    truth = HandModel(adapt_shape(base, TRUE))
    model, rig = HandModel(base), Rig.default()
    poses, kps = frames(rig, truth)
    starts = [fit_frame(k, rig, model, x).pose for k, x in zip(kps, poses, strict=True)]
    fit = fit_shape(kps, rig, model, starts, settings=ShapeFitSettings(detail=0.0))
    assert fit.metric
    np.testing.assert_allclose(fit.factors, TRUE, atol=0.02)  # the prior shrinks a little
    joints = np.array([truth.joints(x) for x in poses])
    fitted = np.array([HandModel(fit.shape).joints(x) for x in fit.poses])
    assert np.linalg.norm(fitted - joints, axis=2).mean() < 1.0  # mm


def test_a_stereo_rig_recovers_a_persons_bones_in_detail():
    """A hand whose every bone and knuckle is off the average proportions (not a shape
    the seven factors can make): the detail factors bring its joints within 1 mm."""
    base = HandShape.from_size(185.0)
    rng = np.random.default_rng(3)
    detail = np.exp(rng.normal(0.0, 0.04, len(DETAIL_FACTORS)))
    truth = HandModel(adapt_shape(base, np.r_[TRUE, detail]))
    model, rig = HandModel(base), Rig.default()
    poses, kps = frames(rig, truth)
    starts = [fit_frame(k, rig, model, x).pose for k, x in zip(kps, poses, strict=True)]
    joints = np.array([truth.joints(x) for x in poses])

    def error(settings):
        fit = fit_shape(kps, rig, model, starts, settings=settings)
        fitted = np.array([HandModel(fit.shape).joints(x) for x in fit.poses])
        return fit, np.linalg.norm(fitted - joints, axis=2).mean()

    fit, detailed = error(ShapeFitSettings())
    assert fit.factors.shape == (7 + len(DETAIL_FACTORS),)
    _, seven = error(ShapeFitSettings(detail=0.0))
    assert detailed < 1.0 < seven  # mm


def test_one_camera_keeps_the_given_length_and_moves_the_proportions_towards_the_truth():
    base = HandShape.from_size(185.0)
    truth = HandModel(adapt_shape(base, TRUE))
    model = HandModel(base)
    rig = Rig([Rig.default().cameras[0]], ["c0"])
    poses, kps = frames(rig, truth)
    starts = [fit_frame(k, rig, model, x).pose for k, x in zip(kps, poses, strict=True)]
    fit = fit_shape(kps, rig, model, starts)
    assert not fit.metric
    assert wrist_to_tip(fit.shape) == pytest.approx(wrist_to_tip(base), rel=1e-9)

    # the digits' lengths relative to the palm's: closer to the truth than the average
    def ratios(shape):
        return shape.segments.sum(axis=1) / shape.bases[2, 1]

    assert (
        np.abs(ratios(fit.shape) - ratios(truth.shape)).mean()
        < 0.5 * np.abs(ratios(base) - ratios(truth.shape)).mean()
    )
