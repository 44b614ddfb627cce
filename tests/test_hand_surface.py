"""Sphere-mesh surface: areas, samples, ray intersection, projected outlines."""

from __future__ import annotations

import numpy as np
import pytest
from scipy import stats

from handvar.camera import Camera, Rig
from handvar.geometry import (
    closest_point_cone_spheres_2d,
    cone_sphere_areas,
    cone_sphere_normals,
    cone_sphere_sdf,
    intersect_cone_spheres,
    sample_cone_spheres,
)
from handvar.hand import LOWER, UPPER, HandModel, named_pose

MODEL = HandModel()
TAU = np.linspace(0.0, 1.0, 4001)


def random_pose(rng: np.random.Generator) -> np.ndarray:
    """Random articulation within the limits, the hand near the default cameras' focus."""
    x = rng.uniform(LOWER, UPPER)
    x[0:3] = named_pose("open")[0:3] + rng.uniform(-20.0, 20.0, 3)
    x[3:6] = named_pose("open")[3:6] + rng.uniform(-40.0, 40.0, 3)
    return x


def ball_sweep(centres: np.ndarray, radii: np.ndarray, points: np.ndarray) -> np.ndarray:
    """Reference (N, P) distance: the hull of two balls is the union of the balls
    interpolated linearly between them, so outside it the distance is
    min over τ of |p − c(τ)| − r(τ) (brute force over a dense τ grid)."""
    out = np.empty((points.shape[0], centres.shape[0]))
    for i, (c, r) in enumerate(zip(centres, radii, strict=True)):
        ct = c[0] + TAU[:, None] * (c[1] - c[0])  # (T, D)
        rt = r[0] + TAU * (r[1] - r[0])
        dist = np.linalg.norm(points[:, None, :] - ct[None], axis=-1) - rt
        out[:, i] = dist.min(axis=1)
    return out


def random_cone_spheres(rng, p, dim=3):
    c1 = rng.normal(0.0, 30.0, (p, dim))
    c2 = c1 + rng.normal(0.0, 25.0, (p, dim))
    d = np.linalg.norm(c2 - c1, axis=1)
    r1 = rng.uniform(2.0, 15.0, p)
    r2 = np.clip(r1 + rng.uniform(-0.8, 0.8, p) * d, 1.0, None)
    return np.stack([c1, c2], axis=1), np.stack([r1, r2], axis=1)


# --- areas --------------------------------------------------------------------------


def _volume_of_revolution(c, r, eps):
    """Volume of the cone-sphere grown by eps, by integrating π ρ(a)² along the axis,
    with ρ(a) the largest cross-section radius over the swept balls."""
    d = np.linalg.norm(c[1] - c[0])
    a = np.linspace(-r[0] - eps, d + r[1] + eps, 8001)
    tau = np.linspace(0.0, 1.0, 2001)
    centre = tau * d
    radius = r[0] + eps + tau * (r[1] - r[0])
    rho2 = np.max(radius[None] ** 2 - (a[:, None] - centre[None]) ** 2, axis=1)
    return np.trapezoid(np.pi * np.clip(rho2, 0.0, None), a)


def test_areas_match_the_derivative_of_the_volume():
    """Steiner: growing a convex body by ε adds area·ε to its volume."""
    rng = np.random.default_rng(0)
    centres, radii = random_cone_spheres(rng, 4)
    areas = cone_sphere_areas(centres, radii).sum(axis=1)
    for c, r, area in zip(centres, radii, areas, strict=True):
        eps = 0.01
        dV = (_volume_of_revolution(c, r, eps) - _volume_of_revolution(c, r, -eps)) / (2 * eps)
        np.testing.assert_allclose(area, dV, rtol=2e-3)
    # and the sphere limit: equal centres are excluded, a tiny cone is almost a sphere
    a = cone_sphere_areas([[[0, 0, 0], [0, 0, 1e-6]]], [[2.0, 2.0]]).sum()
    np.testing.assert_allclose(a, 4 * np.pi * 4.0, rtol=1e-6)


# --- samples ------------------------------------------------------------------------


def test_sample_counts_are_proportional_to_the_exact_areas():
    rng = np.random.default_rng(1)
    prim = MODEL.primitives
    n = 200_000
    which, _, _ = sample_cone_spheres(prim.centres, prim.radii, n, rng)
    areas = cone_sphere_areas(prim.centres, prim.radii).sum(axis=1)
    counts = np.bincount(which, minlength=len(prim))
    chi2 = stats.chisquare(counts, areas / areas.sum() * n)
    assert chi2.pvalue > 1e-3
    # the pooled draws (no rejection): the pool's own multinomial noise adds to the draw's
    s = MODEL.sample_surface(20_000, rng, exposed=False)
    counts = np.bincount(s.primitive, minlength=len(prim))
    expected = areas / areas.sum() * 20_000
    statistic = np.sum((counts - expected) ** 2 / expected) / (1 + 20_000 / MODEL.pool_size)
    assert stats.chi2.sf(statistic, len(prim) - 1) > 1e-3


def test_samples_are_area_uniform_along_and_around_the_axis():
    """Axial coordinate: its CDF from the surface of revolution, computed independently
    (dA/da = 2π ρ(a) sqrt(1 + ρ'(a)²) with ρ from the swept balls); azimuth: uniform."""
    rng = np.random.default_rng(2)
    c = np.array([[[0.0, 0.0, 0.0], [0.0, 0.0, 30.0]]])
    r = np.array([[9.0, 4.0]])
    _, pts, normals = sample_cone_spheres(c, r, 40_000, rng)
    a_grid = np.linspace(-9.0, 34.0, 8001)
    tau = np.linspace(0.0, 1.0, 2001)
    centre = tau * 30.0
    radius = 9.0 + tau * (4.0 - 9.0)
    rho = np.sqrt(np.clip(np.max(radius**2 - (a_grid[:, None] - centre) ** 2, axis=1), 0, None))
    slope = np.gradient(rho, a_grid)
    density = 2 * np.pi * rho * np.sqrt(1 + np.clip(slope, -1e3, 1e3) ** 2)
    cdf = np.concatenate([[0.0], np.cumsum((density[1:] + density[:-1]) / 2 * np.diff(a_grid))])
    cdf /= cdf[-1]
    ks = stats.kstest(pts[:, 2], lambda v: np.interp(v, a_grid, cdf))
    assert ks.pvalue > 1e-3
    phi = np.arctan2(pts[:, 1], pts[:, 0])
    counts = np.histogram(phi, bins=12, range=(-np.pi, np.pi))[0]
    assert stats.chisquare(counts).pvalue > 1e-3
    # normals are unit and point away from the nearest swept ball's centre
    np.testing.assert_allclose(np.linalg.norm(normals, axis=1), 1.0, atol=1e-12)


@pytest.mark.parametrize("exposed", [True, False])
def test_samples_lie_on_the_surface_of_their_primitive(exposed):
    rng = np.random.default_rng(3)
    x = random_pose(rng)
    s = MODEL.sample_surface(400, rng, exposed=exposed)
    centres, radii = MODEL.world_spheres(x)
    p = MODEL.points(x, s.bone, s.local)
    ref = ball_sweep(centres, radii, p)[np.arange(len(s)), s.primitive]
    assert np.max(np.abs(ref)) < 1e-3  # mm; the τ grid limits the reference
    # the normal is the direction from the nearest swept ball's centre
    R, _ = MODEL.bone_frames(x)
    n_world = np.einsum("nij,nj->ni", R[s.bone], s.normal)
    c = centres[s.primitive]
    ct = c[:, None, 0] + TAU[None, :, None] * (c[:, None, 1] - c[:, None, 0])
    rt = radii[s.primitive][:, None, 0] + TAU * (radii[s.primitive][:, None, 1]
                                                 - radii[s.primitive][:, None, 0])  # fmt: skip
    k = np.argmin(np.linalg.norm(p[:, None] - ct, axis=-1) - rt, axis=1)
    towards = p - ct[np.arange(len(s)), k]
    towards /= np.linalg.norm(towards, axis=1, keepdims=True)
    assert np.min(np.einsum("ij,ij->i", towards, n_world)) > 0.999


def test_exposed_samples_are_not_buried_in_neighbouring_primitives():
    rng = np.random.default_rng(4)
    x = np.zeros(26)  # the rest pose the pool is checked in
    centres, radii = MODEL.world_spheres(x)
    s = MODEL.sample_surface(3000, rng)
    p = MODEL.points(x, s.bone, s.local)
    ref = cone_sphere_sdf(centres, radii, p)  # checked against the swept balls above
    ref[np.arange(len(s)), s.primitive] = np.inf
    prim_bone = MODEL.primitives.bone
    from handvar.hand.kinematics import _parents

    parents = _parents()
    b = s.bone[:, None]
    neighbour = (
        (prim_bone[None] == b) | (prim_bone[None] == parents[b]) | (parents[prim_bone][None] == b)
    )
    assert np.all(ref[neighbour] > -1e-6)
    # while the raw samples do include buried ones (the palm's cone-spheres overlap)
    s_all = MODEL.sample_surface(3000, rng, exposed=False)
    p_all = MODEL.points(x, s_all.bone, s_all.local)
    ref_all = cone_sphere_sdf(centres, radii, p_all)
    ref_all[np.arange(len(s_all)), s_all.primitive] = np.inf
    assert np.mean(ref_all.min(axis=1) < -1.0) > 0.1


def test_sampling_is_reproducible_and_varies():
    a = MODEL.sample_surface(50, np.random.default_rng(5))
    b = MODEL.sample_surface(50, np.random.default_rng(5))
    c = MODEL.sample_surface(50, np.random.default_rng(6))
    np.testing.assert_array_equal(a.local, b.local)
    assert not np.array_equal(a.local, c.local)
    assert np.array_equal(HandModel().sample_surface(50, np.random.default_rng(5)).local, a.local)


# --- signed distance and rays -----------------------------------------------------------


@pytest.mark.parametrize("dim", [2, 3])
def test_sdf_matches_the_swept_balls(dim):
    rng = np.random.default_rng(7 + dim)
    centres, radii = random_cone_spheres(rng, 6, dim)
    pts = rng.normal(0.0, 50.0, (500, dim))
    sdf = cone_sphere_sdf(centres, radii, pts)
    ref = ball_sweep(centres, radii, pts)
    outside = ref > 0
    np.testing.assert_allclose(sdf[outside], ref[outside], atol=1e-3)
    assert np.all(sdf[~outside] <= 1e-9)


@pytest.mark.parametrize("dim", [2, 3])
def test_normals_are_the_gradient_of_the_sdf(dim):
    """Analytic normals against central differences of `cone_sphere_sdf`, in all three
    regions of each primitive, and on the surface against the sampler's normals."""
    rng = np.random.default_rng(20 + dim)
    centres, radii = random_cone_spheres(rng, 6, dim)
    pts = rng.normal(0.0, 50.0, (600, dim))
    prim = rng.integers(0, 6, 600)
    sdf = cone_sphere_sdf(centres, radii, pts)[np.arange(600), prim]
    pts, prim = pts[sdf > 0.5], prim[sdf > 0.5]  # off the surface, outside: smooth there
    rows = np.arange(prim.size)

    def own_sdf(p):
        return cone_sphere_sdf(centres, radii, p)[rows, prim]

    eps = 1e-6
    fd = np.stack([(own_sdf(pts + eps * e) - own_sdf(pts - eps * e)) / (2 * eps)
                   for e in np.eye(dim)], axis=1)  # fmt: skip
    normals = cone_sphere_normals(centres, radii, pts, prim)
    np.testing.assert_allclose(normals, fd, atol=1e-6)
    np.testing.assert_allclose(np.linalg.norm(normals, axis=1), 1.0, rtol=1e-12)
    # all three regions were visited: nearest ball of the sweep at τ = 0, inside, τ = 1
    c, r = centres[prim], radii[prim]
    ct = c[:, None, 0] + TAU[None, :, None] * (c[:, None, 1] - c[:, None, 0])
    rt = r[:, None, 0] + TAU * (r[:, None, 1] - r[:, None, 0])
    k = np.argmin(np.linalg.norm(pts[:, None] - ct, axis=-1) - rt, axis=1)
    assert (k == 0).sum() > 20 and (k == TAU.size - 1).sum() > 20
    assert ((k > 0) & (k < TAU.size - 1)).sum() > 20
    if dim == 3:
        which, on_surface, ref = sample_cone_spheres(centres, radii, 2000, rng)
        got = cone_sphere_normals(centres, radii, on_surface, which)
        np.testing.assert_allclose(got, ref, atol=1e-9)
        # a miss (primitive −1) has no normal
        assert not cone_sphere_normals(centres, radii, on_surface[:3], [-1, -1, -1]).any()


def _march(centres, radii, o, v, far=2000.0):
    """Reference depth by sphere tracing the signed distance function."""
    v = v / np.linalg.norm(v, axis=1, keepdims=True)
    t = np.zeros(o.shape[0])
    done = np.zeros(o.shape[0], dtype=bool)
    closest = np.full(o.shape[0], np.inf)
    for _ in range(400):
        dist = cone_sphere_sdf(centres, radii, o + t[:, None] * v).min(axis=1)
        closest = np.minimum(closest, dist)
        done |= dist < 1e-9
        t = np.where(done, t, t + dist)
    t[~done] = np.inf
    return t, closest


def test_ray_intersection_agrees_with_ray_marching():
    rng = np.random.default_rng(11)
    x = random_pose(rng)
    centres, radii = MODEL.world_spheres(x)
    G = MODEL.joints(x)
    n = 600
    origins = rng.normal(0.0, 1.0, (n, 3))
    origins = 400.0 * origins / np.linalg.norm(origins, axis=1, keepdims=True)
    targets = G[rng.integers(0, 21, n)] + rng.normal(0.0, 15.0, (n, 3))
    directions = (targets - origins) * rng.uniform(0.5, 2.0, (n, 1))  # not unit
    depth, prim = MODEL.intersect_rays(x, origins, directions, return_primitive=True)
    ref, closest = _march(centres, radii, origins, directions)
    length = np.linalg.norm(directions, axis=1)
    clear = (closest > 1e-3) | np.isfinite(ref)  # leave out grazing misses
    hit = np.isfinite(ref)
    assert hit.sum() > 200 and (~hit).sum() > 50
    np.testing.assert_array_equal(np.isfinite(depth[clear]), hit[clear])
    np.testing.assert_allclose(depth[hit] * length[hit], ref[hit], atol=1e-5)
    assert np.all(prim[~np.isfinite(depth)] == -1)
    # the reported primitive is the one whose surface the hit point lies on
    pts = origins[hit] + depth[hit, None] * directions[hit]
    sdf = cone_sphere_sdf(centres, radii, pts)
    np.testing.assert_allclose(sdf[np.arange(hit.sum()), prim[hit]], 0.0, atol=1e-6)


def test_ray_hits_a_capsule_where_expected():
    c = np.array([[[-20.0, 0.0, 0.0], [20.0, 0.0, 0.0]]])
    r = np.array([[5.0, 5.0]])
    o = np.array([[0.0, 3.0, -100.0], [25.0, 0.0, -100.0], [0.0, 6.0, -100.0]])
    v = np.array([[0.0, 0.0, 2.0], [0.0, 0.0, 1.0], [0.0, 0.0, 1.0]])
    depth = intersect_cone_spheres(c, r, o, v)
    np.testing.assert_allclose(depth[:2], [(100.0 - 4.0) / 2.0, 100.0], atol=1e-12)
    assert depth[2] == np.inf


# --- projection and the closest projected point --------------------------------------


def _brute_closest_2d(centres, radii, pixels):
    """Closest point of the union of 2D hulls: the hull of two discs is the union of the
    interpolated discs; search τ on a grid, then on a fine grid around the best."""
    m = pixels.shape[0]
    rows = np.arange(m)
    best = np.full(m, np.inf)
    h = pixels.copy()
    coarse = np.linspace(0.0, 1.0, 1001)
    offsets = np.linspace(-1e-3, 1e-3, 2001)
    for c, r in zip(centres, radii, strict=True):
        dist = (np.linalg.norm(pixels[:, None] - (c[0] + coarse[:, None] * (c[1] - c[0])), axis=-1)
                - (r[0] + coarse * (r[1] - r[0])))  # fmt: skip
        tau = np.clip(coarse[np.argmin(dist, axis=1)][:, None] + offsets, 0.0, 1.0)  # (M, F)
        ct = c[0] + tau[..., None] * (c[1] - c[0])
        rt = r[0] + tau * (r[1] - r[0])
        diff = pixels[:, None, :] - ct
        dist = np.linalg.norm(diff, axis=-1) - rt
        k = np.argmin(dist, axis=1)
        dk = dist[rows, k]
        better = dk < best
        e = diff[rows, k] / np.linalg.norm(diff[rows, k], axis=1, keepdims=True)
        h[better] = (ct[rows, k] + rt[rows, k, None] * e)[better]
        best = np.minimum(best, dk)
    h[best <= 0] = pixels[best <= 0]
    return h, best


def test_projected_primitives_are_the_projected_spheres():
    rng = np.random.default_rng(12)
    x = random_pose(rng)
    cam = Rig.default()[0]
    proj = MODEL.project_primitives(x, cam)
    centres, radii = MODEL.world_spheres(x)
    np.testing.assert_allclose(proj.centres, cam.project(centres.reshape(-1, 3)).reshape(-1, 2, 2))
    # a sphere on the optical axis: its outline is a circle of radius f tan(asin(r/z))
    z = cam.camera_from_world(centres.reshape(-1, 3))[:, 2].reshape(-1, 2)
    f = (cam.fx + cam.fy) / 2
    np.testing.assert_allclose(proj.radii, f * np.tan(np.arcsin(radii / z)), rtol=1e-12)
    assert proj.visible.all()


def _pixels_around_the_hand(seed: int, n: int):
    """A random pose, a camera of the default rig and `n` pixels around the hand's image."""
    rng = np.random.default_rng(seed)
    x = random_pose(rng)
    cam = Rig.default()[seed % 2]
    proj = MODEL.project_primitives(x, cam)
    lo, hi = proj.centres.reshape(-1, 2).min(0) - 40, proj.centres.reshape(-1, 2).max(0) + 40
    return x, cam, proj, rng.uniform(lo, hi, (n, 2))


@pytest.mark.parametrize("seed", range(3))
def test_closest_projected_point_matches_brute_force(seed):
    x, cam, proj, pixels = _pixels_around_the_hand(20 + seed, 400)
    h, dh = MODEL.closest_projected_point(x, cam, pixels)
    ref, dist = _brute_closest_2d(proj.centres, proj.radii, pixels)
    assert (dist > 0).sum() > 100 and (dist <= 0).sum() > 30
    sure = np.abs(dist) > 1e-3
    np.testing.assert_allclose(h[sure], ref[sure], atol=2e-3)
    covered = dist < -1e-3
    np.testing.assert_array_equal(h[covered], pixels[covered])
    assert np.all(dh[covered] == 0.0)


@pytest.mark.parametrize("seed", range(3))
def test_closest_projected_point_jacobian_matches_central_differences(seed):
    x, cam, _, pixels = _pixels_around_the_hand(30 + seed, 300)
    h, dh = MODEL.closest_projected_point(x, cam, pixels)
    step = 1e-5
    fd = np.empty_like(dh)
    for i in range(26):
        e = np.zeros(26)
        e[i] = step
        fd[:, :, i] = (
            MODEL.closest_projected_point(x + e, cam, pixels)[0]
            - MODEL.closest_projected_point(x - e, cam, pixels)[0]
        ) / (2 * step)
    outside = np.any(h != pixels, axis=1)
    assert outside.sum() > 100
    err = np.abs(dh - fd).max(axis=(1, 2)) / np.maximum(np.abs(fd).max(axis=(1, 2)), 1e-6)
    assert np.median(err[outside]) < 1e-6
    assert np.max(err[outside]) <= 1e-5


def test_closest_point_2d_derivatives_in_every_region():
    """d h / d (c1, c2, ρ1, ρ2) by central differences, pixels near caps and flanks."""
    rng = np.random.default_rng(40)
    centres = np.array([[[100.0, 100.0], [160.0, 130.0]]])
    radii = np.array([[20.0, 9.0]])
    pixels = rng.uniform(40.0, 220.0, (400, 2))
    _, dh, _, dist = closest_point_cone_spheres_2d(centres, radii, pixels)
    out = dist > 0.5
    theta = np.concatenate([centres.ravel(), radii.ravel()])

    def f(th):
        return closest_point_cone_spheres_2d(th[:4].reshape(1, 2, 2), th[4:].reshape(1, 2),
                                             pixels)[0]  # fmt: skip

    fd = np.empty((400, 2, 6))
    for i in range(6):
        e = np.zeros(6)
        e[i] = 1e-6
        fd[:, :, i] = (f(theta + e) - f(theta - e)) / 2e-6
    np.testing.assert_allclose(dh[out], fd[out], atol=1e-6)
    # all three parts of the outline were exercised
    u = (centres[0, 1] - centres[0, 0]) / np.linalg.norm(centres[0, 1] - centres[0, 0])
    a = (pixels[out] - centres[0, 0]) @ u
    assert (a < -5).sum() > 10 and (a > 75).sum() > 10 and ((a > 10) & (a < 50)).sum() > 10


def test_closest_point_2d_of_a_segment_seen_end_on():
    """One circle inside the other: the outline is the larger circle."""
    centres = np.array([[[50.0, 50.0], [51.0, 50.0]]])
    radii = np.array([[10.0, 5.0]])
    h, _, _, dist = closest_point_cone_spheres_2d(centres, radii, np.array([[80.0, 50.0]]))
    np.testing.assert_allclose(h, [[60.0, 50.0]])
    np.testing.assert_allclose(dist, [20.0])


# --- bad input --------------------------------------------------------------------------


def test_bad_surface_input_raises():
    x = named_pose("open")
    rng = np.random.default_rng(0)
    with pytest.raises(ValueError, match="origins"):
        MODEL.intersect_rays(x, np.zeros((3, 2)), np.ones((3, 2)))
    with pytest.raises(ValueError, match="directions"):
        MODEL.intersect_rays(x, np.zeros((3, 3)), np.ones((2, 3)))
    with pytest.raises(ValueError, match="origins, directions"):
        MODEL.intersect_rays(x, np.full((1, 3), np.nan), np.ones((1, 3)))
    with pytest.raises(ValueError, match="directions"):
        MODEL.intersect_rays(x, np.zeros((1, 3)), np.zeros((1, 3)))
    with pytest.raises(ValueError, match="x"):
        MODEL.intersect_rays(np.zeros(3), np.zeros((1, 3)), np.ones((1, 3)))
    cam = Camera(600.0, 600.0, 320.0, 240.0, t=[0.0, 0.0, 500.0])
    with pytest.raises(ValueError, match="pixels"):
        MODEL.closest_projected_point(x, cam, np.zeros((4, 3)))
    with pytest.raises(ValueError, match="pixels"):
        MODEL.closest_projected_point(x, cam, [[np.nan, 1.0]])
    with pytest.raises(TypeError, match="camera"):
        MODEL.closest_projected_point(x, "left", np.zeros((4, 2)))
    with pytest.raises(TypeError, match="camera"):
        MODEL.project_primitives(x, None)
    with pytest.raises(ValueError, match="n"):
        MODEL.sample_surface(-1, rng)
    with pytest.raises(TypeError, match="rng"):
        MODEL.sample_surface(10, 42)
    centres, radii = MODEL.world_spheres(x)
    with pytest.raises(ValueError, match=r"points: expected shape \(N, 3\)"):
        cone_sphere_normals(centres, radii, np.zeros((2, 2)), [0, 0])
    with pytest.raises(ValueError, match="primitive: expected shape"):
        cone_sphere_normals(centres, radii, np.zeros((2, 3)), [0])
    with pytest.raises(TypeError, match="primitive: expected integer"):
        cone_sphere_normals(centres, radii, np.zeros((2, 3)), [0.0, 1.0])
    with pytest.raises(ValueError, match=r"primitive: expected indices in -1\.\.19"):
        cone_sphere_normals(centres, radii, np.zeros((2, 3)), [0, 20])


# --- the compiled routes agree with the numpy references ----------------------------------


def test_compiled_and_numpy_routes_agree():
    rng = np.random.default_rng(50)
    x = random_pose(rng)
    centres, radii = MODEL.world_spheres(x)
    G = MODEL.joints(x)
    origins = rng.normal(0.0, 1.0, (2000, 3))
    origins = 400.0 * origins / np.linalg.norm(origins, axis=1, keepdims=True)
    directions = G[rng.integers(0, 21, 2000)] + rng.normal(0.0, 20.0, (2000, 3)) - origins
    d_nb, p_nb = intersect_cone_spheres(centres, radii, origins, directions,
                                        return_primitive=True)  # fmt: skip
    d_np, p_np = intersect_cone_spheres(centres, radii, origins, directions,
                                        return_primitive=True, compiled=False)  # fmt: skip
    np.testing.assert_array_equal(np.isfinite(d_nb), np.isfinite(d_np))
    hit = np.isfinite(d_np)
    np.testing.assert_allclose(d_nb[hit], d_np[hit], rtol=1e-12)
    # the primitive may differ only where two share the hit point (a joint's sphere)
    differ = p_nb != p_np
    assert differ.sum() < 10
    pts = origins[differ] + d_np[differ, None] * directions[differ]
    sdf = cone_sphere_sdf(centres, radii, pts)
    rows = np.arange(differ.sum())
    np.testing.assert_allclose(sdf[rows, p_nb[differ]], 0.0, atol=1e-9)
    np.testing.assert_allclose(sdf[rows, p_np[differ]], 0.0, atol=1e-9)
    # 2D closest point, including segments seen end-on (one circle inside the other)
    c2 = rng.uniform(0.0, 200.0, (12, 2, 2))
    r2 = rng.uniform(3.0, 20.0, (12, 2))
    c2[:3, 1] = c2[:3, 0] + rng.normal(0.0, 1.0, (3, 2))
    r2[:3, 1] = r2[:3, 0] + 5.0
    valid = np.ones(12, dtype=bool)
    valid[5] = False
    pixels = rng.uniform(-20.0, 220.0, (1000, 2))
    out_nb = closest_point_cone_spheres_2d(c2, r2, pixels, valid=valid)
    out_np = closest_point_cone_spheres_2d(c2, r2, pixels, valid=valid, compiled=False)
    for a, b in zip(out_nb, out_np, strict=True):
        np.testing.assert_allclose(a, b, rtol=1e-10, atol=1e-10)
    assert np.all(out_nb[2] != 5)
