"""Forward kinematics G(x), bone frames and their Jacobians (handvar.hand.kinematics)."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from handvar.hand import (
    BONES,
    JOINTS,
    LOWER,
    NAMES,
    POSE_NAMES,
    UPPER,
    HandModel,
    HandShape,
    named_pose,
    within_limits,
)
from handvar.hand.anthropometry import bone_index
from handvar.hand.kinematics import euler_from_matrix, world_from_hand_rotation

MODEL = HandModel()
NUMPY = HandModel(compiled=False)


def random_pose(rng: np.random.Generator) -> np.ndarray:
    """A pose with articulation uniform within the limits and any palm pose."""
    x = rng.uniform(LOWER, UPPER)
    x[0:3] = rng.uniform(-300.0, 300.0, 3)
    x[3:6] = rng.uniform(-180.0, 180.0, 3)
    return x


def central_difference(f, x: np.ndarray, h: float = 1e-5) -> np.ndarray:
    """d f / d x by central differences; f returns an array, result has a last axis 26."""
    cols = []
    for i in range(x.size):
        e = np.zeros_like(x)
        e[i] = h
        cols.append((f(x + e) - f(x - e)) / (2.0 * h))
    return np.stack(cols, axis=-1)


def relative_error(J: np.ndarray, J_fd: np.ndarray) -> float:
    """Largest entry error relative to the largest entry of the reference."""
    return float(np.max(np.abs(J - J_fd)) / np.max(np.abs(J_fd)))


# --- Jacobians ---------------------------------------------------------------------


@pytest.mark.parametrize("seed", range(5))
def test_points_jacobian_matches_central_differences(seed):
    rng = np.random.default_rng(seed)
    x = random_pose(rng)
    bone = rng.integers(0, len(BONES), 60)
    local = rng.normal(0.0, 15.0, (60, 3))
    p, J = MODEL.points(x, bone, local, jacobian=True)
    assert J.shape == (60, 3, 26)
    np.testing.assert_allclose(p, MODEL.points(x, bone, local), rtol=0, atol=1e-12)
    J_fd = central_difference(lambda v: MODEL.points(v, bone, local), x)
    assert relative_error(J, J_fd) <= 1e-5
    # every column individually, against its own scale (catches a wrong small column)
    for i in range(26):
        scale = max(np.max(np.abs(J_fd[..., i])), 1e-3)
        assert np.max(np.abs(J[..., i] - J_fd[..., i])) <= 1e-5 * scale, NAMES[i]


@pytest.mark.parametrize("seed", range(3))
def test_surface_sample_jacobian_matches_central_differences(seed):
    rng = np.random.default_rng(100 + seed)
    x = random_pose(rng)
    s = MODEL.sample_surface(300, rng)
    _, J = MODEL.points(x, s.bone, s.local, jacobian=True)
    J_fd = central_difference(lambda v: MODEL.points(v, s.bone, s.local), x)
    assert relative_error(J, J_fd) <= 1e-5


@pytest.mark.parametrize("seed", range(3))
def test_joints_jacobian_matches_central_differences(seed):
    rng = np.random.default_rng(200 + seed)
    x = random_pose(rng)
    J = MODEL.joints_jacobian(x)
    assert J.shape == (21, 3, 26)
    J_fd = central_difference(MODEL.joints, x)
    assert relative_error(J, J_fd) <= 1e-5
    for i in range(26):
        scale = max(np.max(np.abs(J_fd[..., i])), 1e-3)
        assert np.max(np.abs(J[..., i] - J_fd[..., i])) <= 1e-5 * scale, NAMES[i]


def test_joint_jacobian_structure():
    """A finger's joints do not depend on another digit's angles; the wrist only on t."""
    J = MODEL.joints_jacobian(named_pose("fist"))
    np.testing.assert_array_equal(J[0], np.hstack([np.eye(3), np.zeros((3, 23))]))
    index_tip = JOINTS.index("index_tip")
    others = [i for i in range(6, 26) if i not in (7, 14, 15, 16)]
    assert np.all(J[index_tip][:, others] == 0.0)
    assert np.all(np.abs(J[index_tip][:, [7, 14, 15, 16]]).sum(axis=0) > 0.1)


# --- the open hand: anthropometric lengths ------------------------------------------


def test_open_hand_has_the_published_segment_lengths():
    x = np.zeros(26)
    x[0:3] = [12.0, -40.0, 300.0]  # translation only
    G = MODEL.joints(x)
    L = 185.0
    # Buchholz et al. (1992) ratios times hand length, mm (hand-computed)
    expected = {
        "thumb": [0.251 * L, 0.196 * L, 0.158 * L],
        "index": [0.245 * L, 0.143 * L, 0.097 * L],
        "middle": [0.266 * L, 0.170 * L, 0.108 * L],
        "ring": [0.244 * L, 0.165 * L, 0.107 * L],
        "little": [0.204 * L, 0.117 * L, 0.093 * L],
    }
    for k, digit in enumerate(expected):
        chain = G[1 + 4 * k : 5 + 4 * k]
        lengths = np.linalg.norm(np.diff(chain, axis=0), axis=1)
        np.testing.assert_allclose(lengths, expected[digit], rtol=1e-12)
        np.testing.assert_allclose(lengths, MODEL.shape.segments[k], rtol=1e-12)
    # the MCP joints sit where the published joint-centre ratios put them (HB = 0.46 HL)
    B = 0.46 * L
    mcp = G[[5, 9, 13, 17]] - x[0:3]
    np.testing.assert_allclose(mcp[:, 0], np.array([0.251, 0.0, -0.206, -0.402]) * B, atol=1e-9)
    np.testing.assert_allclose(mcp[:, 1], np.array([0.447, 0.446, 0.409, 0.368]) * L, atol=1e-9)
    # open hand: wrist to the tip of the middle finger is 0.99 hand lengths, straight up y
    np.testing.assert_allclose(G[12] - G[0], [0.0, 0.99 * L, 0.0], atol=1e-9)


def test_joints_are_the_bone_origins_and_bones_point_at_the_next_joint():
    rng = np.random.default_rng(7)
    x = random_pose(rng)
    R, o = MODEL.bone_frames(x)
    G = MODEL.joints(x)
    np.testing.assert_allclose(R @ R.transpose(0, 2, 1), np.broadcast_to(np.eye(3), R.shape),
                               atol=1e-12)  # fmt: skip
    np.testing.assert_allclose(np.linalg.det(R), 1.0, atol=1e-12)
    np.testing.assert_allclose(o[0], G[0], atol=1e-12)
    for k in range(5):
        for level in range(3):
            b = bone_index(k, level)
            start, end = G[1 + 4 * k + level], G[2 + 4 * k + level]
            np.testing.assert_allclose(o[b], start, atol=1e-9)
            direction = (end - start) / np.linalg.norm(end - start)
            np.testing.assert_allclose(R[b][:, 1], direction, atol=1e-12)


# --- global pose: rigid motion ---------------------------------------------------------


@pytest.mark.parametrize("seed", range(3))
def test_palm_pose_moves_G_rigidly(seed):
    rng = np.random.default_rng(300 + seed)
    x = random_pose(rng)
    local = x.copy()
    local[0:6] = 0.0
    G0 = MODEL.joints(local)
    G = MODEL.joints(x)
    # pairwise distances are preserved
    d0 = np.linalg.norm(G0[:, None] - G0[None], axis=-1)
    d = np.linalg.norm(G[:, None] - G[None], axis=-1)
    np.testing.assert_allclose(d, d0, atol=1e-9)
    # and the motion is R = Rx Ry Rz (intrinsic x-y-z, scipy's "XYZ") plus t
    R = Rotation.from_euler("XYZ", x[3:6], degrees=True).as_matrix()
    np.testing.assert_allclose(G, G0 @ R.T + x[0:3], atol=1e-9)


# --- signs of the articulation -----------------------------------------------------------


def _tip(x, digit):
    return MODEL.joints(x)[4 + 4 * digit]


def test_flexion_turns_digits_towards_the_palm_side():
    base = _tip(np.zeros(26), 1)
    x = np.zeros(26)
    x[NAMES.index("index_mcp")] = 30.0
    tip = _tip(x, 1)
    assert tip[2] > base[2] + 10.0  # towards +z (palmar)
    # the thumb, flexed, crosses the palm: towards −x (ulnar) and in front of it (+z)
    x = np.zeros(26)
    x[NAMES.index("thumb_cmc")] = 40.0
    x[NAMES.index("thumb_mcp")] = 40.0
    x[NAMES.index("thumb_ip")] = 20.0
    tip = _tip(x, 0)
    index_mcp, little_mcp = MODEL.joints(x)[[5, 17]]
    assert little_mcp[0] < tip[0] < index_mcp[0]
    assert tip[2] > MODEL.shape.palm_radii.max()  # in front of the palm's surface


@pytest.mark.parametrize(
    ("name", "digit", "direction"),
    [("abd_thumb", 0, 1), ("abd_index", 1, 1), ("abd_middle", 2, 1), ("abd_ring", 3, -1),
     ("abd_little", 4, -1)],
)  # fmt: skip
def test_abduction_moves_away_from_the_middle_finger(name, digit, direction):
    x = np.zeros(26)
    x[NAMES.index(name)] = 15.0
    moved = _tip(x, digit) - _tip(np.zeros(26), digit)
    assert direction * moved[0] > 5.0  # along ±x, in the palm plane
    assert abs(moved[2]) < 1e-9 or name == "abd_thumb"


# --- named poses -------------------------------------------------------------------------


def test_named_poses_face_the_default_cameras():
    from handvar.camera import Rig

    rig = Rig.default()
    for name in POSE_NAMES:
        x = named_pose(name)
        assert within_limits(x), name
        assert (x[3], x[1]) == (180.0, 90.0)
        G = MODEL.joints(x)
        assert np.linalg.norm(G.mean(axis=0)) < 45.0, name  # near the world origin
        R, _ = MODEL.bone_frames(x)
        palm_normal = R[0][:, 2]
        for cam in rig:
            # the palm faces the camera
            assert palm_normal @ (cam.center - G[9]) > 0.0
            uv = cam.project(G)
            assert np.all(cam.in_image(uv)), name
    # the open hand: fingers up in the image, thumb on the image's right
    uv = rig[0].project(MODEL.joints(named_pose("open")))
    assert uv[12, 1] < uv[9, 1] < uv[0, 1]
    assert uv[4, 0] > uv[8, 0] > uv[20, 0]


def test_named_pose_contents():
    G = {name: MODEL.joints(named_pose(name)) for name in POSE_NAMES}
    # pinch: thumb and index fingertips touch (tip spheres about one radius sum apart)
    c, _ = MODEL.world_spheres(named_pose("pinch"))
    names = MODEL.primitives.names
    thumb, index = c[names.index("thumb_distal"), 1], c[names.index("index_distal"), 1]
    r = MODEL.shape.radii[0, 3] + MODEL.shape.radii[1, 3]
    assert abs(np.linalg.norm(thumb - index) - r) < 2.0
    # fist: fingertips curled back close to the palm
    wrist_to_tips = np.linalg.norm(G["fist"][[8, 12, 16, 20]] - G["fist"][0], axis=1)
    assert np.all(wrist_to_tips < 0.6 * np.linalg.norm(G["open"][12] - G["open"][0]))
    # point: the index finger as in the open hand, the other fingers as in the fist
    np.testing.assert_allclose(G["point"][5:9], G["open"][5:9], atol=1e-9)
    np.testing.assert_allclose(G["point"][9:], G["fist"][9:], atol=1e-9)
    # spread: fingertips further apart than in the open hand
    spread = np.linalg.norm(G["spread"][8] - G["spread"][20])
    assert spread > np.linalg.norm(G["open"][8] - G["open"][20]) + 30.0


# --- shapes and caching ----------------------------------------------------------------


def test_a_longer_hand_scales_G():
    x = named_pose("fist")
    x[0:3] = 0.0
    big = HandModel(HandShape.from_size(200.0, 0.46 * 200.0))
    np.testing.assert_allclose(big.joints(x), MODEL.joints(x) * 200.0 / 185.0, atol=1e-9)


def test_cached_pose_is_not_stale():
    rng = np.random.default_rng(11)
    model = HandModel()
    x1, x2 = random_pose(rng), random_pose(rng)
    G1, J1 = model.joints(x1), model.joints_jacobian(x1)
    x = x1.copy()
    model.joints(x)
    x[:] = x2  # mutate the caller's array after the call
    np.testing.assert_allclose(model.joints(x), HandModel().joints(x2), atol=1e-12)
    np.testing.assert_allclose(model.joints_jacobian(x2), HandModel().joints_jacobian(x2),
                               atol=1e-12)  # fmt: skip
    np.testing.assert_array_equal(model.joints(x1), G1)
    np.testing.assert_array_equal(model.joints_jacobian(x1), J1)


# --- bad input ---------------------------------------------------------------------------


@pytest.mark.parametrize(
    "bad",
    [np.zeros(25), np.zeros((26, 1)), np.r_[np.zeros(25), np.nan], np.r_[np.inf, np.zeros(25)]],
)
def test_bad_pose_raises(bad):
    for call in (MODEL.joints, MODEL.joints_jacobian, MODEL.bone_frames, MODEL.world_spheres):
        with pytest.raises(ValueError, match="x"):
            call(bad)


@pytest.mark.parametrize("model", [MODEL, NUMPY], ids=["compiled", "numpy"])
@pytest.mark.parametrize("jacobian", [False, True])
def test_bad_points_raise(model, jacobian):
    x = np.zeros(26)
    bone, local = np.array([0, 3, 15, 7]), np.zeros((4, 3))
    for b in ([0, 3, 16, 7], [0, -1, 15, 7]):
        with pytest.raises(ValueError, match=r"bone: expected indices in 0\.\.15; got values"):
            model.points(x, b, local, jacobian=jacobian)
    with pytest.raises(TypeError, match="bone: expected integer bone indices"):
        model.points(x, bone + 0.5, local, jacobian=jacobian)
    with pytest.raises(ValueError, match=r"bone: expected a \(N,\) array"):
        model.points(x, bone[None], local, jacobian=jacobian)
    with pytest.raises(ValueError, match=r"local: expected shape \(4, 3\) to match bone"):
        model.points(x, bone, local[:3], jacobian=jacobian)
    for bad in (np.nan, np.inf):
        far = local.copy()
        far[3, 1] = bad
        with pytest.raises(ValueError, match="local: expected finite coordinates"):
            model.points(x, bone, far, jacobian=jacobian)
    # accepted: other integer dtypes, lists, and no points at all
    ref = model.points(x, bone, local)
    np.testing.assert_array_equal(model.points(x, bone.astype(np.uint8), local.tolist()), ref)
    assert model.points(x, [], np.zeros((0, 3))).shape == (0, 3)


def test_bad_model_input_raises():
    with pytest.raises(ValueError, match="name"):
        named_pose("wave")
    with pytest.raises(TypeError, match="shape"):
        HandModel(shape="large")


def test_compiled_and_numpy_routes_agree():
    rng = np.random.default_rng(400)
    compiled, reference = HandModel(), HandModel(compiled=False)
    for _ in range(5):
        x = random_pose(rng)
        bone = rng.integers(0, len(BONES), 200)
        local = rng.normal(0.0, 15.0, (200, 3))
        for a, b in [
            (compiled.joints(x), reference.joints(x)),
            (compiled.bone_frames(x)[0], reference.bone_frames(x)[0]),
            (compiled.bone_frames(x)[1], reference.bone_frames(x)[1]),
            (compiled.points(x, bone, local), reference.points(x, bone, local)),
            (compiled.points(x, bone, local, jacobian=True)[1],
             reference.points(x, bone, local, jacobian=True)[1]),
        ]:  # fmt: skip
            np.testing.assert_allclose(a, b, rtol=0, atol=1e-10)
    # no points: empty results of the right shapes
    p, J = compiled.points(x, np.zeros(0, dtype=int), np.zeros((0, 3)), jacobian=True)
    assert p.shape == (0, 3) and J.shape == (0, 3, 26)


def test_euler_from_matrix_inverts_the_kinematics_rotation():
    rng = np.random.default_rng(7)
    angles = rng.uniform([-179, -89, -179], [179, 89, 179], size=(50, 3))
    R = np.stack([world_from_hand_rotation(a)[0] for a in angles])
    np.testing.assert_allclose(euler_from_matrix(R), angles, atol=1e-9)


@pytest.mark.parametrize("b", [90.0, -90.0])
def test_euler_from_matrix_at_gimbal_lock_gives_the_same_rotation(b):
    R = world_from_hand_rotation([30.0, b, 40.0])[0]
    back = world_from_hand_rotation(euler_from_matrix(R))[0]
    np.testing.assert_allclose(back, R, atol=1e-9)


def test_euler_from_matrix_rejects_bad_shape():
    with pytest.raises(
        ValueError, match=r"R: expected rotation matrices of shape \(\.\.\., 3, 3\)"
    ):
        euler_from_matrix(np.eye(4))
