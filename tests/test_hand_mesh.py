"""The skinned mesh hand: data, registration, skinning Jacobians, silhouettes, rendering."""

from __future__ import annotations

import cv2
import numpy as np
import pytest

from handvar.camera import Rig
from handvar.hand import HandModel, named_pose
from handvar.hand.mesh import MeshSamples, load_mesh_data
from handvar.hand.raster import rasterize_triangles
from handvar.params import LOWER, N_PARAMS, UPPER
from handvar.render import render_rgb, silhouettes


@pytest.fixture(scope="module")
def hand() -> HandModel:
    return HandModel(surface="mesh")


def _random_poses(rng: np.random.Generator, n: int) -> list[np.ndarray]:
    """Poses drawn inside the joint limits, in front of the default cameras."""
    poses = []
    for _ in range(n):
        x = rng.uniform(LOWER, UPPER)
        x[:3] = named_pose("open")[:3] + rng.normal(0, 10, 3)
        x[3:6] = named_pose("open")[3:6] + rng.normal(0, 20, 3)
        poses.append(x)
    return poses


def test_data_weights_sum_to_one_and_triangles_are_valid():
    data = load_mesh_data()
    np.testing.assert_allclose(data.weights.sum(axis=1), 1.0, atol=1e-12)
    assert np.all(data.weights >= 0)
    assert data.triangles.min() == 0 and data.triangles.max() == data.vertices.shape[0] - 1
    # every edge is shared by at most two triangles (a manifold surface)
    t = data.triangles
    edges = np.sort(np.concatenate([t[:, [0, 1]], t[:, [1, 2]], t[:, [2, 0]]]), axis=1)
    _, counts = np.unique(edges, axis=0, return_counts=True)
    assert counts.max() == 2


def test_blended_samples_keep_weights_summing_to_one(hand):
    s = hand.mesh.sample_surface(500, np.random.default_rng(1))
    np.testing.assert_allclose(s.weight.sum(axis=1), 1.0, atol=1e-12)
    np.testing.assert_allclose(hand.mesh.skinned.vertices.weight.sum(axis=1), 1.0, atol=1e-12)


def test_sample_equals_blend_of_skinned_corners(hand):
    """A sample is the barycentric blend of its triangle's skinned corners (linearity)."""
    x = named_pose("pinch")
    s = hand.mesh.sample_surface(200, np.random.default_rng(2))
    v = hand.mesh.vertices(x)
    expect = np.einsum("ni,nic->nc", s.barycentric, v[hand.mesh.triangles[s.triangle]])
    np.testing.assert_allclose(hand.mesh.points(x, s), expect, atol=1e-9)


def test_joints_are_those_of_the_sphere_mesh(hand):
    """Same bone frames, same G(x): the two models agree to rounding (1e-9 mm)."""
    spheres = HandModel()
    for x in _random_poses(np.random.default_rng(3), 5):
        np.testing.assert_allclose(hand.joints(x), spheres.joints(x), atol=1e-9)


def test_mesh_joints_sit_inside_the_mesh_at_rest(hand):
    """The registration puts the skeleton inside the surface: every joint but the
    fingertips lies closer to the mesh's vertices than 12 mm (half a finger's width
    plus the vertex spacing), and each fingertip within 5 mm of the surface."""
    x = named_pose("open")
    v = hand.mesh.vertices(x)
    d = np.array([np.linalg.norm(v - j, axis=1).min() for j in hand.joints(x)])
    tips = np.array([4, 8, 12, 16, 20])
    assert d[tips].max() < 5.0
    assert np.delete(d, tips).max() < 12.0


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_sample_jacobian_matches_central_differences(hand, seed):
    rng = np.random.default_rng(seed)
    x = _random_poses(rng, 1)[0]
    s = hand.mesh.sample_surface(300, rng)
    _, J = hand.mesh.points(x, s, jacobian=True)
    eps = 1e-5
    Jn = np.empty_like(J)
    for i in range(N_PARAMS):
        xp, xm = x.copy(), x.copy()
        xp[i] += eps
        xm[i] -= eps
        Jn[:, :, i] = (hand.mesh.points(xp, s) - hand.mesh.points(xm, s)) / (2 * eps)
    scale = np.abs(Jn).max(axis=(0, 1))  # per parameter
    rel = np.abs(J - Jn).max(axis=(0, 1)) / scale
    assert rel.max() <= 1e-5, rel


def test_joint_jacobian_matches_central_differences(hand):
    x = _random_poses(np.random.default_rng(4), 1)[0]
    J = hand.joints_jacobian(x)
    eps = 1e-5
    for i in range(N_PARAMS):
        xp, xm = x.copy(), x.copy()
        xp[i] += eps
        xm[i] -= eps
        Jn = (hand.joints(xp) - hand.joints(xm)) / (2 * eps)
        assert np.abs(J[:, :, i] - Jn).max() <= 1e-5 * np.abs(Jn).max()


def _splat_reference(hand, x, cam) -> np.ndarray:
    """Dense point splat: ~50 points per pixel of every triangle, rounded to the nearest
    pixel, closed morphologically (3×3) to fill the gaps between splats."""
    mesh = hand.mesh
    v = mesh.vertices(x)
    uv = cam.project(v)
    tri = mesh.triangles
    a, b, c = (uv[tri[:, i]] for i in range(3))
    e, f = b - a, c - a
    area = 0.5 * np.abs(e[:, 0] * f[:, 1] - e[:, 1] * f[:, 0])
    n_per = np.maximum(np.ceil(area * 50), 10).astype(int)
    t = np.repeat(np.arange(len(tri)), n_per)
    rng = np.random.default_rng(0)
    r1, r2 = rng.random(len(t)), rng.random(len(t))
    s = np.sqrt(r1)
    beta = np.column_stack([1 - s, s * (1 - r2), s * r2])
    corners = v[tri[t]]  # sample in 3D, then project (the exact image of the surface)
    p = cam.project(np.einsum("ni,nic->nc", beta, corners))
    ij = np.floor(p + 0.5).astype(int)
    w, h = cam.size
    ok = (ij[:, 0] >= 0) & (ij[:, 0] < w) & (ij[:, 1] >= 0) & (ij[:, 1] < h)
    mask = np.zeros((h, w), np.uint8)
    mask[ij[ok, 1], ij[ok, 0]] = 1
    return cv2.morphologyEx(mask, cv2.MORPH_CLOSE, np.ones((3, 3), np.uint8)).astype(bool)


@pytest.mark.parametrize("name", ["open", "fist", "pinch"])
def test_silhouette_matches_dense_splat(hand, name):
    x = named_pose(name)
    rig = Rig.default()
    masks = silhouettes(hand, x, rig)
    for k, cam in enumerate(rig):
        ref = _splat_reference(hand, x, cam)
        iou = (masks[k] & ref).sum() / (masks[k] | ref).sum()
        assert iou >= 0.99, iou


def test_rasteriser_centre_rule_against_point_in_triangle():
    """Pixel-centre coverage equals a plain point-in-triangle test on random triangles."""
    rng = np.random.default_rng(5)
    uv = rng.uniform(-5, 45, (30, 2))
    tri = rng.integers(0, 30, (10, 3))
    tri = tri[(tri[:, 0] != tri[:, 1]) & (tri[:, 1] != tri[:, 2]) & (tri[:, 0] != tri[:, 2])]
    mask = rasterize_triangles(uv, tri, (40, 30), coverage="centre")
    jj, ii = np.meshgrid(np.arange(40), np.arange(30))
    ref = np.zeros((30, 40), bool)
    for a, b, c in uv[tri]:
        d = lambda p, q: (q[0] - p[0]) * (ii - p[1]) - (q[1] - p[1]) * (jj - p[0])  # noqa: E731
        e = np.stack([d(a, b), d(b, c), d(c, a)])
        ref |= np.all(e >= 0, axis=0) | np.all(e <= 0, axis=0)
    assert np.array_equal(mask, ref)


def test_rasteriser_touch_rule_covers_every_point():
    """'touch' sets every pixel that a point of a triangle rounds to, and no pixel
    whose square lies farther than a pixel from the triangle (dense sampling check)."""
    rng = np.random.default_rng(6)
    uv = rng.uniform(0, 30, (3, 2))
    mask = rasterize_triangles(uv, [[0, 1, 2]], (32, 32), coverage="touch")
    beta = rng.dirichlet(np.ones(3), 200_000)
    ij = np.floor(beta @ uv + 0.5).astype(int)
    ref = np.zeros_like(mask)
    ref[ij[:, 1], ij[:, 0]] = True
    assert np.all(mask[ref])
    assert (mask & ~ref).sum() <= 0.02 * ref.sum()


def test_visibility_front_and_back(hand):
    """Seen from the palm side, palm-facing samples are visible and the back hidden."""
    x = named_pose("open")
    cam = Rig.default()[0]
    mesh = hand.mesh
    s = mesh.skinned.vertices
    vis = mesh.visible(x, cam, s)
    local_z = mesh.skinned.rest_vertices()[:, 2]  # hand frame: +z palmar
    palm = (mesh.skinned.vertices.bone[:, 0] == 0) & (s.weight[:, 0] > 0.99)
    assert vis[palm & (local_z > np.percentile(local_z[palm], 90))].mean() > 0.9
    assert vis[palm & (local_z < np.percentile(local_z[palm], 10))].mean() < 0.1


def test_closest_projected_point_jacobian(hand):
    """h of an uncovered pixel is a projected vertex; its Jacobian matches central
    differences of that vertex's projection (the vertex held fixed)."""
    x = named_pose("spread")
    cam = Rig.default()[0]
    pixels = np.array([[100.0, 100.0], [600.0, 400.0], [320.0, 60.0]])
    h, dh = hand.mesh.closest_projected_point(x, cam, pixels)
    uv = cam.project(hand.mesh.vertices(x))
    k = [int(np.argmin(np.linalg.norm(uv - p, axis=1))) for p in pixels]
    np.testing.assert_allclose(h, uv[k], atol=1e-9)
    eps = 1e-5
    for i in range(N_PARAMS):
        xp, xm = x.copy(), x.copy()
        xp[i] += eps
        xm[i] -= eps
        num = cam.project(hand.mesh.vertices(xp))[k] - cam.project(hand.mesh.vertices(xm))[k]
        num /= 2 * eps
        np.testing.assert_allclose(dh[:, :, i], num, atol=1e-5 * max(np.abs(num).max(), 1.0))
    covered = np.argwhere(silhouettes(hand, x, Rig([cam]))[0])[:1, ::-1].astype(float)
    h2, dh2 = hand.mesh.closest_projected_point(x, cam, covered)
    np.testing.assert_array_equal(h2, covered)
    assert not np.any(dh2)


def test_render_rgb_shades_the_silhouette(hand):
    x = named_pose("open")
    rig = Rig.default()
    img = render_rgb(hand, x, rig, background="plain", rng=np.random.default_rng(0))
    masks = silhouettes(hand, x, rig, coverage="centre")
    assert img.shape == (2, 480, 640, 3)
    skin = np.array([222, 170, 140])
    for k in range(2):
        inside = img[k][masks[k]].astype(float)
        # shaded skin: the hue of the skin colour, brightness within ambient..full
        ratio = inside / skin
        assert np.all(np.abs(ratio[:, 0] - ratio[:, 2]) < 0.15)
        assert 0.4 < np.median(ratio) < 1.1


def test_bad_arguments(hand):
    with pytest.raises(ValueError, match="surface: expected one of"):
        HandModel(surface="cubes")
    with pytest.raises(TypeError, match="samples: expected MeshSamples"):
        hand.mesh.points(named_pose("open"), np.zeros((3, 3)))
    with pytest.raises(ValueError, match="coverage: expected one of"):
        rasterize_triangles(np.zeros((3, 2)), [[0, 1, 2]], (4, 4), coverage="edge")
    assert isinstance(hand.mesh.skinned.vertices, MeshSamples)


def test_cli_synth_and_show_with_the_mesh(tmp_path):
    """`synth --model mesh` writes masks equal to the mesh's silhouettes of the true
    poses; `show --model mesh` writes a PNG."""
    from click.testing import CliRunner

    from handvar.cli import main
    from handvar.io import read_sequence

    runner = CliRunner()
    out = tmp_path / "seq"
    res = runner.invoke(main, ["synth", "benchmark", str(out), "--model", "mesh",
                               "--frames", "2"])  # fmt: skip
    assert res.exit_code == 0, res.output
    seq = read_sequence(out)
    assert seq.provenance["model"] == "mesh"
    hand = HandModel(surface="mesh")
    expect = silhouettes(hand, seq.truth.poses[1], seq.rig)
    assert np.array_equal(np.asarray(seq.masks[1]), expect)
    assert not np.array_equal(expect, silhouettes(HandModel(), seq.truth.poses[1], seq.rig))
    png = tmp_path / "fist.png"
    res = runner.invoke(main, ["show", "fist", "--model", "mesh", "--out", str(png)])
    assert res.exit_code == 0, res.output
    assert cv2.imread(str(png)).shape[0] > 400
