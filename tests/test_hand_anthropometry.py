"""Hand proportions (handvar.hand.anthropometry)."""

from __future__ import annotations

import numpy as np
import pytest

from handvar.geometry.cone_spheres import cone_sphere_sdf
from handvar.hand import HandModel, HandShape
from handvar.hand.anthropometry import HandProportions


def test_default_hand_matches_the_published_ratios():
    shape = HandShape.from_size()
    assert shape.length == 185.0
    np.testing.assert_allclose(shape.breadth, 85.1)
    # Buchholz et al. (1992): index proximal 0.245 HL, little distal 0.093 HL, thumb
    # metacarpal 0.251 HL; thumb CMC 0.073 HL along, 0.196 HB across (hand-computed)
    np.testing.assert_allclose(shape.segments[1, 0], 45.325)
    np.testing.assert_allclose(shape.segments[4, 2], 17.205)
    np.testing.assert_allclose(shape.segments[0, 0], 46.435)
    np.testing.assert_allclose(shape.bases[0, :2], [0.196 * 85.1, 0.073 * 185.0])


def test_shape_scales_with_length_and_breadth():
    a = HandShape.from_size(185.0, 85.0)
    b = HandShape.from_size(2 * 185.0, 85.0)
    np.testing.assert_allclose(b.segments, 2 * a.segments)
    np.testing.assert_allclose(b.bases[:, 1], 2 * a.bases[:, 1])  # along: length
    np.testing.assert_allclose(b.bases[:, 0], a.bases[:, 0])  # across: breadth
    np.testing.assert_allclose(b.radii, a.radii)
    c = HandShape.from_size(185.0, 2 * 85.0)
    np.testing.assert_allclose(c.radii, 2 * a.radii)


def test_palm_is_as_wide_as_the_hand_breadth_and_fingers_are_finger_sized():
    shape = HandShape.from_size(190.0, 88.0)
    model = HandModel(shape)
    x = np.zeros(26)
    # probe the palm along lines across the hand between the MCP levels: its extent
    # across (radial side of the index to ulnar side of the little finger) is HB
    centres, radii = model.world_spheres(x)
    palm = model.primitives.bone == 0
    xs = np.linspace(-80, 80, 16001)
    lo, hi = np.inf, -np.inf
    for y in np.linspace(shape.bases[4, 1] - 5, shape.bases[1, 1] + 5, 41):
        probe = np.stack([xs, np.full_like(xs, y), np.zeros_like(xs)], axis=1)
        inside = cone_sphere_sdf(centres[palm], radii[palm], probe).min(axis=1) <= 0
        lo, hi = min(lo, xs[inside].min()), max(hi, xs[inside].max())
    np.testing.assert_allclose(hi - lo, 88.0, atol=0.05)
    # finger thickness: 14-22 mm across the proximal phalanges, 10-16 mm at the tips
    assert np.all((2 * shape.radii[1:, 0] > 14) & (2 * shape.radii[1:, 0] < 22))
    assert np.all((2 * shape.radii[1:, 3] > 10) & (2 * shape.radii[1:, 3] < 16))
    # the middle fingertip's surface reaches 0.99 HL from the wrist
    c, r = model.world_spheres(x)
    k = model.primitives.names.index("middle_distal")
    np.testing.assert_allclose(c[k, 1, 1] + r[k, 1], 0.99 * 190.0)


def test_custom_proportions():
    p = HandProportions(thumb_yaw=50.0)
    a, b = HandShape.from_size(proportions=p), HandShape.from_size()
    assert not np.allclose(a.base_rotations[0], b.base_rotations[0])
    np.testing.assert_allclose(a.base_rotations[1:], b.base_rotations[1:])


@pytest.mark.parametrize(
    ("kwargs", "name", "error"),
    [({"length": -1.0}, "length", ValueError), ({"length": np.nan}, "length", ValueError),
     ({"length": "big"}, "length", TypeError), ({"breadth": 0.0}, "breadth", ValueError),
     ({"breadth": np.inf}, "breadth", ValueError)],
)  # fmt: skip
def test_bad_size_raises(kwargs, name, error):
    with pytest.raises(error, match=f"{name}: expected a positive hand {name} in mm; got"):
        HandShape.from_size(**kwargs)


def test_bad_shape_arrays_raise():
    s = HandShape.from_size()
    fields = dict(
        segments=s.segments, bases=s.bases, base_rotations=s.base_rotations, radii=s.radii,
        palm_centres=s.palm_centres, palm_radii=s.palm_radii,
    )  # fmt: skip
    with pytest.raises(ValueError, match="segments"):
        HandShape(**{**fields, "segments": s.segments[:4]})
    with pytest.raises(ValueError, match="segments"):
        HandShape(**{**fields, "segments": -s.segments})
    with pytest.raises(ValueError, match="base_rotations"):
        HandShape(**{**fields, "base_rotations": 2 * s.base_rotations})
    with pytest.raises(ValueError, match="radii"):
        HandShape(**{**fields, "radii": np.full((5, 4), np.nan)})
    with pytest.raises(ValueError, match="palm_radii"):
        HandShape(**{**fields, "palm_radii": s.palm_radii[:2]})
    with pytest.raises(ValueError, match="radii"):  # tip spheres longer than the bones
        HandShape(**{**fields, "radii": s.radii * 4})
    with pytest.raises(TypeError, match="breadth: expected a positive hand breadth in mm"):
        HandShape(**{**fields, "breadth": None})


def test_joint_digit_names_each_joints_digit():
    from handvar.hand.anthropometry import JOINT_DIGIT, JOINTS
    from handvar.params import DIGITS

    for name, digit in zip(JOINTS, JOINT_DIGIT, strict=True):
        assert name.split("_")[0] == ("wrist" if digit == -1 else DIGITS[digit])
