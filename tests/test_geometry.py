"""The geometry leaf package: its imports, the packed rig, the distortion's two callers."""

from __future__ import annotations

import ast
from pathlib import Path

import cv2
import numpy as np

import handvar.geometry
from handvar.camera import Camera, Rig
from handvar.geometry.distortion import distort, distort_point, padded

RATIONAL = np.array([-0.2, 0.05, 0.001, -0.002, 0.01, 0.03, 0.01, 0.002])


def test_geometry_imports_nothing_from_handvar_but_validate():
    folder = Path(handvar.geometry.__file__).parent
    seen = set()
    for path in folder.glob("*.py"):
        for node in ast.walk(ast.parse(path.read_text())):
            if isinstance(node, ast.ImportFrom) and node.module:
                seen.add(node.module)
            elif isinstance(node, ast.Import):
                seen.update(alias.name for alias in node.names)
    inside = sorted(m for m in seen if m.split(".")[0] == "handvar")
    outside = [
        m for m in inside if m != "handvar.validate" and not m.startswith("handvar.geometry")
    ]
    assert inside and not outside


def test_packed_rig_holds_every_camera_parameter():
    plain = Rig.default()
    cams = (plain[0], Camera(600.0, 610.0, 300.0, 250.0, dist=RATIONAL, t=[0, 0, 400.0]))
    rig = Rig(cams, ("a", "b"))
    packed = rig.packed()
    for j, cam in enumerate(cams):
        np.testing.assert_array_equal(packed.intrinsics[j], [cam.fx, cam.fy, cam.cx, cam.cy])
        np.testing.assert_array_equal(packed.dist[j, : cam.dist.size], cam.dist)
        assert not packed.dist[j, cam.dist.size :].any()
        assert packed.rational[j] == (cam.dist.size == 8)
        np.testing.assert_array_equal(packed.R[j], cam.R)
        np.testing.assert_array_equal(packed.t[j], cam.t)
        np.testing.assert_array_equal(packed.size[j], cam.size)


def test_compiled_scalar_distortion_matches_opencv_and_its_array_route():
    rng = np.random.default_rng(11)
    xy = rng.uniform(-0.4, 0.4, (50, 2))
    for dist in (RATIONAL[:4], RATIONAL[:5], RATIONAL):
        full = np.concatenate([dist, np.zeros(5 - dist.size)]) if dist.size < 5 else dist
        # OpenCV projects the points (x, y, 1) with K = I: the distorted coordinates
        points = np.concatenate([xy, np.ones((50, 1))], axis=1)
        ref, _ = cv2.projectPoints(points, np.zeros(3), np.zeros(3), np.eye(3), full)
        d8, rational = padded(full)
        one = np.array([distort_point(x, y, d8, rational) for x, y in xy])
        np.testing.assert_allclose(one[:, :2], ref.reshape(-1, 2), rtol=1e-12, atol=1e-14)
        many, J = distort(xy, full, jacobian=True)
        np.testing.assert_array_equal(many, one[:, :2])
        np.testing.assert_array_equal(J[:, 0, 0], one[:, 2])
        np.testing.assert_array_equal(J[:, 0, 1], one[:, 3])
        np.testing.assert_array_equal(J[:, 1, 0], one[:, 3])
        np.testing.assert_array_equal(J[:, 1, 1], one[:, 4])
