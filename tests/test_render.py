"""Rendering: exact silhouettes, ray casting, colour images, overlays and `handvar show`."""

from __future__ import annotations

import cv2
import numpy as np
import pytest
from click.testing import CliRunner

from handvar import render
from handvar.camera import Camera, Rig
from handvar.cli import main
from handvar.geometry import (
    cone_sphere_normals,
    cone_sphere_sdf,
    intersect_cone_spheres,
    sample_cone_spheres,
)
from handvar.hand.kinematics import HandModel, named_pose
from handvar.params import LOWER, UPPER
from handvar.render.overlay import _DIGIT_RGB

BARREL = np.array([-0.25, 0.08, 0.001, -0.001, -0.01])


@pytest.fixture(scope="module")
def hand() -> HandModel:
    return HandModel()


def random_pose(rng: np.random.Generator, hand: HandModel) -> np.ndarray:
    """A pose within the joint limits: any orientation, joints centred near the origin."""
    x = rng.uniform(LOWER, UPPER)
    x[3:6] = rng.uniform(-180, 180, 3)
    x[0:3] = 0.0
    x[0:3] = rng.uniform(-20, 20, 3) - hand.joints(x).mean(axis=0)
    return x


def random_conespheres(rng: np.random.Generator, n: int = 12):
    a = rng.normal(size=(n, 3)) * 40
    b = a + rng.normal(size=(n, 3)) * 25
    radii = rng.uniform(3, 14, (n, 2))
    return np.stack([a, b], axis=1), radii


def pixel_rays(cam: Camera, box=None):
    """Rays through the pixel centres of a box (rows, cols slices) of the image."""
    w, h = cam.size
    rows, cols = box or (slice(0, h), slice(0, w))
    ii, jj = np.mgrid[rows, cols]
    origins, dirs = cam.rays(np.column_stack([jj.ravel(), ii.ravel()]).astype(float))
    return origins, dirs, ii.shape


def bounding_box(mask: np.ndarray, margin: int = 3):
    rows = np.flatnonzero(mask.any(axis=1))
    cols = np.flatnonzero(mask.any(axis=0))
    h, w = mask.shape
    return (
        slice(max(rows[0] - margin, 0), min(rows[-1] + margin + 1, h)),
        slice(max(cols[0] - margin, 0), min(cols[-1] + margin + 1, w)),
    )


# --- geometry of the sphere images --------------------------------------------------


def test_sphere_ellipse_passes_through_projected_rim():
    """The rim where view rays graze a sphere projects onto the computed ellipse."""
    rng = np.random.default_rng(10)
    centres = rng.normal(size=(30, 3)) * [150, 150, 50] + [0, 0, 500]
    radii = rng.uniform(1, 60, 30)
    x0, S = render.sphere_ellipses(centres, radii)
    for c, r, x0_i, S_i in zip(centres, radii, x0, S, strict=True):
        # rim circle: centre c (1 − r²/|c|²), radius r sqrt(1 − r²/|c|²), normal to c
        dist = np.linalg.norm(c)
        axis = c / dist
        e1 = np.cross(axis, [1.0, 0.0, 0.0])
        e1 /= np.linalg.norm(e1)
        e2 = np.cross(axis, e1)
        phi = rng.uniform(0, 2 * np.pi, 50)
        rim_c = c * (1 - r**2 / dist**2)
        rim_r = r * np.sqrt(1 - r**2 / dist**2)
        rim = rim_c + rim_r * (np.cos(phi)[:, None] * e1 + np.sin(phi)[:, None] * e2)
        xy = rim[:, :2] / rim[:, 2:]
        d = xy - x0_i
        np.testing.assert_allclose(np.einsum("ni,ij,nj->n", d, np.linalg.inv(S_i), d), 1.0)


@pytest.mark.parametrize("dist", [None, BARREL], ids=["pinhole", "barrel"])
def test_centre_mask_equals_ray_casting(dist):
    """A pixel is set exactly when the ray through its centre hits a cone-sphere."""
    rng = np.random.default_rng(11)
    cam = Camera.look_at((-110.0, 0.0, -488.0), fx=650.0, dist=dist)
    centres, radii = random_conespheres(rng)
    mask = render.silhouette_of_spheres(
        centres, radii, cam, coverage="centre", tol=1e-3, tol_distortion=0.2
    )
    box = bounding_box(mask)
    origins, dirs, shape = pixel_rays(cam, box)
    hit = np.isfinite(intersect_cone_spheres(centres, radii, origins, dirs)).reshape(shape)
    assert mask[box].sum() == mask.sum() > 1000
    # outlines within 0.001 px: at most a handful of pixel centres that close
    assert np.sum(hit != mask[box]) <= 3


def test_hand_mask_equals_hand_ray_casting(hand):
    """The same against the hand model's own ray casting, at a random pose."""
    rng = np.random.default_rng(12)
    x = random_pose(rng, hand)
    cam = Rig.default()[1]
    mask = render.silhouettes(hand, x, Rig((cam,)), coverage="centre", tol=1e-3)[0]
    box = bounding_box(mask)
    origins, dirs, shape = pixel_rays(cam, box)
    hit = np.isfinite(hand.intersect_rays(x, origins, dirs)).reshape(shape)
    assert mask.sum() > 1000
    assert np.sum(hit != mask[box]) <= 3


@pytest.mark.parametrize("dist", [None, BARREL], ids=["pinhole", "barrel"])
def test_touch_mask_equals_supersampled_coverage(dist):
    """``touch``: pixels whose square meets the image, from an 8x finer centre mask."""
    rng = np.random.default_rng(13)
    s = 8
    cam = Camera.look_at((60.0, -40.0, -480.0), fx=640.0, dist=dist)
    # the same camera at s times the resolution: pixel j spans fine pixels s j .. s j + s − 1
    fine = Camera(
        cam.fx * s, cam.fy * s, cam.cx * s + (s - 1) / 2, cam.cy * s + (s - 1) / 2,
        dist=cam.dist, R=cam.R, t=cam.t, size=(cam.size[0] * s, cam.size[1] * s),
    )  # fmt: skip
    centres, radii = random_conespheres(rng)
    touch = render.silhouette_of_spheres(
        centres, radii, cam, coverage="touch", tol=1e-3, tol_distortion=0.2
    )
    sub = render.silhouette_of_spheres(
        centres, radii, fine, coverage="centre", tol=1e-3, tol_distortion=0.2
    )
    h, w = cam.size[1], cam.size[0]
    coarse = sub.reshape(h, s, w, s).any(axis=(1, 3))
    assert touch.sum() > 1000
    assert np.all(touch[coarse])  # every pixel the image meets is set
    # pixels met only by less than 1/8 px of the image are the only extra ones
    assert np.sum(touch & ~coarse) < 0.01 * touch.sum()


def test_surface_samples_fall_inside_mask_and_dense_projection_agrees(hand):
    rng = np.random.default_rng(14)
    rig = Rig.default()
    for _ in range(3):
        x = random_pose(rng, hand)
        masks = render.silhouettes(hand, x, rig)
        samples = hand.sample_surface(20_000, rng)
        on_surface = hand.points(x, samples.bone, samples.local)
        centres, radii = hand.world_spheres(x)
        _, dense, _ = sample_cone_spheres(centres, radii, 250_000, rng)
        for mask, cam in zip(masks, rig, strict=True):
            px = np.rint(cam.project(on_surface)).astype(int)
            ok = cam.in_image(px)
            assert ok.mean() > 0.99
            inside = mask[px[ok, 1], px[ok, 0]]
            assert inside.mean() >= 0.999
            # independent mask: dense projection, closed morphologically
            q = np.rint(cam.project(dense)).astype(int)
            q = q[cam.in_image(q)]
            ref = np.zeros(mask.shape, np.uint8)
            ref[q[:, 1], q[:, 0]] = 1
            ref = cv2.morphologyEx(ref, cv2.MORPH_CLOSE, np.ones((3, 3), np.uint8)).astype(bool)
            iou = np.sum(ref & mask) / np.sum(ref | mask)
            assert iou >= 0.97, iou


def test_primitives_behind_the_camera_are_left_out():
    cam = Camera(600.0, 600.0, 319.5, 239.5)
    centres = np.array([[[0.0, 0.0, 300.0], [10.0, 0.0, 300.0]], [[0.0, 0.0, 5.0], [0, 0, 50]]])
    radii = np.array([[10.0, 10.0], [10.0, 10.0]])  # the second reaches z < 0
    both = render.silhouette_of_spheres(centres, radii, cam)
    first = render.silhouette_of_spheres(centres[:1], radii[:1], cam)
    np.testing.assert_array_equal(both, first)
    assert len(render.outlines(centres, radii, cam)) == 1


def test_outlines_enclose_the_mask():
    rng = np.random.default_rng(15)
    cam = Rig.default()[0]
    centres, radii = random_conespheres(rng, 4)
    mask = render.silhouette_of_spheres(centres, radii, cam, coverage="centre")
    polys = render.outlines(centres, radii, cam, coverage="centre")
    ref = np.zeros(mask.shape, np.uint8)
    for p in polys:  # OpenCV's filler includes boundary pixels: compare up to them
        cv2.fillPoly(ref, [np.rint(p * 16).astype(np.int32)], 1, cv2.LINE_8, 4)
    ref = ref.astype(bool)
    assert np.all(ref[mask])
    inner = cv2.erode(ref.astype(np.uint8), np.ones((3, 3), np.uint8)).astype(bool)
    assert np.all(mask[inner])


# --- ray casting --------------------------------------------------------------------


def test_intersections_lie_on_the_surface_with_its_normal():
    """Ray hits are on the zero set of the distance function; normals are its gradient."""
    rng = np.random.default_rng(16)
    centres, radii = random_conespheres(rng, 8)
    origins = np.tile([0.0, 0.0, -500.0], (4000, 1))
    targets = rng.normal(size=(4000, 3)) * 40
    dirs = targets - origins
    dirs /= np.linalg.norm(dirs, axis=1, keepdims=True)
    depth, prim = intersect_cone_spheres(centres, radii, origins, dirs, return_primitive=True)
    hit = np.isfinite(depth)
    assert 0.2 < hit.mean() < 0.95
    assert np.all(prim[hit] >= 0) and np.all(prim[~hit] == -1)
    p = origins[hit] + depth[hit, None] * dirs[hit]
    assert np.abs(union_sdf(centres, radii, p)).max() < 1e-8
    # the primitive hit is the one whose surface the point is on
    np.testing.assert_allclose(
        cone_sphere_sdf(centres, radii, p)[np.arange(p.shape[0]), prim[hit]], 0.0, atol=1e-8
    )
    # the normal is the gradient of the signed distance (central differences)
    normals = cone_sphere_normals(centres, radii, p, prim[hit])
    np.testing.assert_allclose(normals, sdf_gradient(centres, radii, p), atol=1e-5)
    # a ray enters the surface: against its normal
    assert np.all(np.einsum("ij,ij->i", normals, dirs[hit]) < 0)


def union_sdf(centres, radii, p):
    return cone_sphere_sdf(centres, radii, p).min(axis=1)


def sdf_gradient(centres, radii, p, eps=1e-5):
    return np.stack(
        [
            (union_sdf(centres, radii, p + eps * e) - union_sdf(centres, radii, p - eps * e))
            / (2 * eps)
            for e in np.eye(3)
        ],
        axis=1,
    )


# --- colour -------------------------------------------------------------------------


@pytest.mark.parametrize("background", ["clutter", "texture", "plain"])
def test_render_rgb_hand_is_skin_and_background_is_not(hand, background):
    from handvar.vision.skin import SkinModel

    rig = Rig.default()
    x = named_pose("point")
    images = render.render_rgb(hand, x, rig, background=background, rng=np.random.default_rng(3))
    assert images.shape == (2, 480, 640, 3) and images.dtype == np.uint8
    again = render.render_rgb(hand, x, rig, background=background, rng=np.random.default_rng(3))
    np.testing.assert_array_equal(images, again)
    masks = render.silhouettes(hand, x, rig, coverage="centre")
    skin = SkinModel()
    for img, mask in zip(images, masks, strict=True):
        detected = skin.mask(img, order="rgb")
        assert detected[mask].mean() > 0.95
        assert detected[~mask].mean() < 0.01


def test_render_rgb_shading_follows_lambert(hand):
    """Noise-free: hand pixels = skin · (ambient + diffuse · max(0, n·l))."""
    rig = Rig((Rig.default()[0],))
    shading = render.Shading(noise_sigma=0.0)
    x = named_pose("open")
    img = render.render_rgb(hand, x, rig, background="plain", shading=shading)[0]
    mask = render.silhouettes(hand, x, rig, coverage="centre")[0]
    rows, cols = np.nonzero(mask)
    origins, dirs = rig[0].rays(np.column_stack([cols, rows]).astype(float))
    centres, radii = hand.world_spheres(x)
    depth = hand.intersect_rays(x, origins, dirs)
    hit = np.isfinite(depth)
    p = origins[hit] + depth[hit, None] * dirs[hit]
    grad = sdf_gradient(centres, radii, p, eps=1e-4)
    n = grad / np.linalg.norm(grad, axis=1, keepdims=True)
    light = np.asarray(shading.light) / np.linalg.norm(shading.light)
    expect = (
        np.asarray(shading.skin_rgb)
        * (shading.ambient + shading.diffuse * np.maximum(n @ light, 0.0))[:, None]
    )
    got = img[rows[hit], cols[hit]].astype(float)
    # rounding to integers; the union's kinks (where primitives meet) have no gradient
    assert np.mean(np.all(np.abs(got - expect) <= 1.0, axis=1)) > 0.98


def test_backgrounds_have_no_skin_colours():
    from handvar.vision.skin import SkinModel

    skin = SkinModel()
    for kind in ("clutter", "texture", "plain"):
        for seed in range(3):
            img = render.background_image((320, 240), kind, np.random.default_rng(seed))
            assert img.shape == (240, 320, 3)
            assert skin.mask(img, order="rgb").mean() < 0.002


# --- overlays and errors -------------------------------------------------------------


def test_draw_overlay_marks_projected_joints(hand):
    cam = Rig.default()[0]
    x = named_pose("open")
    joints = hand.joints(x)
    base = np.zeros((480, 640, 3), np.uint8)
    out = render.draw_overlay(base, cam, joints)
    assert not base.any()  # the input is not modified
    px = np.rint(cam.project(joints)).astype(int)
    for k in (4, 8, 12, 16, 20):  # fingertips: the digit's colour, drawn on top
        colour = out[px[k, 1], px[k, 0]]
        assert np.abs(colour.astype(int) - _DIGIT_RGB[(k - 1) // 4]).max() <= 2
    mask = render.silhouettes(hand, x, Rig((cam,)))[0]
    with_outline = render.draw_overlay(mask, cam, joints, mask=mask)
    assert with_outline.shape == (480, 640, 3)
    with pytest.raises(ValueError, match="joints"):
        render.draw_overlay(base, cam, joints[:20])
    with pytest.raises(ValueError, match="image: expected size"):
        render.draw_overlay(base[:100], cam, joints)


def test_input_errors(hand):
    rig = Rig.default()
    x = named_pose("open")
    bad = x.copy()
    bad[4] = np.nan
    with pytest.raises(ValueError, match="x: expected finite"):
        render.silhouettes(hand, bad, rig)
    with pytest.raises(ValueError, match="coverage: expected one of touch, centre"):
        render.silhouettes(hand, x, rig, coverage="area")
    with pytest.raises(ValueError, match="background: expected one of"):
        render.render_rgb(hand, x, rig, background="beach")
    mixed = Rig((rig[0], Camera(600, 600, 160, 120, size=(320, 240))))
    with pytest.raises(ValueError, match="rig: expected cameras of one image size"):
        render.silhouettes(hand, x, mixed)
    with pytest.raises(ValueError, match=r"centres: expected an array of shape \(N, 2, 3\)"):
        render.silhouette_of_spheres(np.zeros((3, 3)), np.ones((3, 2)), rig[0])


# --- handvar show -------------------------------------------------------------------


def test_show_writes_png(tmp_path):
    out = tmp_path / "open.png"
    result = CliRunner().invoke(main, ["show", "open", "--out", str(out)])
    assert result.exit_code == 0, result.output
    image = cv2.imread(str(out))
    assert image is not None and image.shape[0] > 480 and image.shape[1] >= 1280
    assert [p.name for p in tmp_path.iterdir()] == ["open.png"]
    # the silhouette's grey is drawn in the left view where the model is
    rig = Rig.default()
    mask = render.silhouettes(HandModel(), named_pose("open"), rig)[0]
    bar = image.shape[0] - 480
    left = image[bar:, :640]
    assert np.mean(left[mask].max(axis=1) > 100) > 0.9
    assert np.mean(left[~mask].max(axis=1) < 30) > 0.97


def test_show_reads_pose_files(tmp_path):
    x = named_pose("fist")
    np.save(tmp_path / "fist.npy", x)
    (tmp_path / "fist.txt").write_text(" ".join(f"{v:.17g}" for v in x))
    runner = CliRunner()
    images = []
    for name in ("fist.npy", "fist.txt"):
        out = tmp_path / (name + ".png")
        result = runner.invoke(main, ["show", str(tmp_path / name), "--out", str(out)])
        assert result.exit_code == 0, result.output
        images.append(cv2.imread(str(out)))
    named = tmp_path / "named.png"
    assert runner.invoke(main, ["show", "fist", "--out", str(named)]).exit_code == 0
    ref = cv2.imread(str(named))
    bar = ref.shape[0] - 480
    for img in images:  # same views; only the titles differ
        np.testing.assert_array_equal(img[bar:], ref[bar:])


@pytest.mark.parametrize(
    "args, message",
    [
        (["show", "no-such-pose"], "POSE: expected a named pose"),
        (["show", "open", "--hand-length", "-5"], "length"),
    ],
)
def test_show_errors_are_one_line(tmp_path, args, message):
    result = CliRunner().invoke(main, [*args, "--out", str(tmp_path / "x.png")])
    assert result.exit_code != 0
    lines = result.output.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("handvar: error:") and message in lines[0]
    assert not (tmp_path / "x.png").exists()


def test_show_rejects_short_pose_file(tmp_path):
    path = tmp_path / "short.txt"
    path.write_text("1 2 3")
    result = CliRunner().invoke(main, ["show", str(path), "--out", str(tmp_path / "x.png")])
    assert result.exit_code != 0
    assert "expected a pose of shape (26,)" in result.output
