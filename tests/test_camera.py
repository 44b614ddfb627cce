"""Cameras: projection against OpenCV, Jacobians, rays, the default rig, calibration files."""

from __future__ import annotations

import json

import cv2
import numpy as np
import pytest

from handvar.camera import Camera, Rig

DISTORTIONS = {
    "none": np.zeros(5),
    "k1k2p1p2k3": np.array([-0.28, 0.09, 0.0012, -0.0008, -0.012]),
    "rational": np.array([0.12, -0.05, 0.0007, 0.0011, 0.01, 0.3, -0.04, 0.02]),
}


def random_rotation(rng: np.random.Generator) -> np.ndarray:
    rvec = rng.normal(size=3) * 0.6
    return cv2.Rodrigues(rvec)[0]


def random_camera(rng: np.random.Generator, dist: np.ndarray) -> Camera:
    return Camera(
        fx=rng.uniform(500, 800),
        fy=rng.uniform(500, 800),
        cx=rng.uniform(300, 340),
        cy=rng.uniform(220, 260),
        dist=dist,
        R=random_rotation(rng),
        t=rng.normal(size=3) * 30 + [0, 0, 500],
        size=(640, 480),
    )


def points_in_view(cam: Camera, rng: np.random.Generator, n: int = 200) -> np.ndarray:
    """World points in front of the camera, within about ±25° of its axis."""
    xy = rng.uniform(-0.45, 0.45, size=(n, 2))
    z = rng.uniform(300, 800, size=n)
    pc = np.column_stack([xy * z[:, None], z])
    return (pc - cam.t) @ cam.R  # Rᵀ (pc − t)


@pytest.mark.parametrize("dist_name", sorted(DISTORTIONS))
def test_project_matches_opencv(dist_name):
    rng = np.random.default_rng(1)
    for _ in range(5):
        cam = random_camera(rng, DISTORTIONS[dist_name])
        X = points_in_view(cam, rng)
        rvec = cv2.Rodrigues(cam.R)[0]
        ref, _ = cv2.projectPoints(X, rvec, cam.t, cam.K, cam.dist)
        np.testing.assert_allclose(cam.project(X), ref.reshape(-1, 2), rtol=0, atol=1e-9)


@pytest.mark.parametrize("dist_name", sorted(DISTORTIONS))
def test_project_jacobian_matches_central_differences(dist_name):
    rng = np.random.default_rng(2)
    cam = random_camera(rng, DISTORTIONS[dist_name])
    X = points_in_view(cam, rng, 100)
    px, J = cam.project_jacobian(X)
    np.testing.assert_allclose(px, cam.project(X), rtol=0, atol=1e-12)
    h = 1e-3  # mm
    J_fd = np.stack(
        [(cam.project(X + h * e) - cam.project(X - h * e)) / (2 * h) for e in np.eye(3)], axis=-1
    )
    assert J.shape == (100, 2, 3)
    # central differences are accurate to O(h²) ≈ 1e-9 here
    np.testing.assert_allclose(J, J_fd, rtol=1e-6, atol=1e-8)


@pytest.mark.parametrize("dist_name", sorted(DISTORTIONS))
def test_rays_round_trip(dist_name):
    rng = np.random.default_rng(3)
    cam = random_camera(rng, DISTORTIONS[dist_name])
    X = points_in_view(cam, rng)
    origins, dirs = cam.rays(cam.project(X))
    np.testing.assert_allclose(np.linalg.norm(dirs, axis=1), 1.0, atol=1e-12)
    np.testing.assert_allclose(origins, np.broadcast_to(cam.center, X.shape), atol=1e-9)
    # each point lies on its ray: distance from the line below a micrometre
    v = X - origins
    off = v - np.einsum("ij,ij->i", v, dirs)[:, None] * dirs
    assert np.max(np.linalg.norm(off, axis=1)) < 1e-6
    assert np.all(np.einsum("ij,ij->i", v, dirs) > 0)


def test_center_and_camera_from_world():
    rng = np.random.default_rng(4)
    cam = random_camera(rng, np.zeros(5))
    np.testing.assert_allclose(cam.camera_from_world(cam.center[None]), 0.0, atol=1e-9)
    X = rng.normal(size=(10, 3)) * 100
    np.testing.assert_allclose(cam.camera_from_world(X), (cam.R @ X.T).T + cam.t, atol=1e-12)


def test_look_at_orientation():
    eye = np.array([100.0, -50.0, -400.0])
    target = np.array([10.0, 20.0, 30.0])
    cam = Camera.look_at(eye, target, fx=600.0)
    np.testing.assert_allclose(cam.center, eye, atol=1e-9)
    np.testing.assert_allclose(cam.R @ cam.R.T, np.eye(3), atol=1e-12)
    assert np.linalg.det(cam.R) == pytest.approx(1.0)
    # the target is imaged at the principal point, world −y (up) above it
    u, v = cam.project(target[None])[0]
    assert (u, v) == pytest.approx((cam.cx, cam.cy), abs=1e-9)
    above = cam.project(target[None] + [0.0, -20.0, 0.0])[0]
    assert above[1] < cam.cy - 5 and abs(above[0] - cam.cx) < abs(above[1] - cam.cy)


def test_default_rig_is_the_papers_convergent_pair():
    rig = Rig.default()
    assert len(rig) == 2 and rig.names == ("left", "right")
    left, right = rig["left"], rig["right"]
    for cam in rig:
        assert cam.size == (640, 480)
        assert np.linalg.norm(cam.center) == pytest.approx(500.0, rel=0.05)
        assert cam.center[2] < 0  # world −z side, looking towards +z
        assert cam.axis[2] > 0.9
        assert cam.R[1] @ [0.0, 1.0, 0.0] > 0.99  # camera y ≈ world +y (image up = −y)
        assert 600 <= cam.fx <= 700
        # optical axes cross at the origin
        np.testing.assert_allclose(cam.project(np.zeros((1, 3)))[0], (cam.cx, cam.cy))
    baseline = right.center - left.center
    assert 200 <= baseline[0] <= 250 and abs(baseline[1]) < 1e-9 and abs(baseline[2]) < 1e-9
    # a 185 mm hand, fingers up, centred near the origin fills a good part of the image
    hand = np.array([[0.0, 90.0, 0.0], [0.0, -95.0, 0.0]])
    for cam in rig:
        px = cam.project(hand)
        assert np.all(cam.in_image(px))
        assert 0.4 * 480 < px[0, 1] - px[1, 1] < 0.9 * 480


def test_rig_lookup_errors():
    rig = Rig.default()
    assert rig[1] is rig["right"]
    with pytest.raises(ValueError, match="camera: expected one of left, right; got 'middle'"):
        rig["middle"]
    with pytest.raises(ValueError, match="names"):
        Rig(rig.cameras, ("a", "a"))


def make_rig(rng: np.random.Generator) -> Rig:
    cams = tuple(random_camera(rng, d) for d in DISTORTIONS.values())
    return Rig(cams, ("a", "b", "c"))


@pytest.mark.parametrize("ext", [".yml", ".yaml", ".xml", ".json"])
def test_calibration_file_round_trip(tmp_path, ext):
    rig = make_rig(np.random.default_rng(5))
    path = tmp_path / f"rig{ext}"
    rig.save(path)
    back = Rig.load(path)
    assert back.names == rig.names
    assert back.allclose(rig, rtol=0, atol=1e-14)
    assert [p.name for p in tmp_path.iterdir()] == [path.name]  # no temporary left
    # the file is plain OpenCV: its matrices read back with cv2.FileStorage
    fs = cv2.FileStorage(str(path), cv2.FILE_STORAGE_READ)
    node = fs.getNode("cameras").at(1)
    np.testing.assert_array_equal(node.getNode("camera_matrix").mat(), rig[1].K)
    np.testing.assert_array_equal(node.getNode("T").mat().ravel(), rig[1].t)
    assert node.getNode("image_width").real() == 640
    fs.release()


def test_dict_round_trip_through_json():
    rig = make_rig(np.random.default_rng(6))
    back = Rig.from_dict(json.loads(json.dumps(rig.to_dict())))
    assert back == rig
    with pytest.raises(ValueError, match=r"cameras\[0\]: missing key 'fx'"):
        Rig.from_dict({"cameras": [{"fy": 1.0}]})


def test_reads_stereo_calibrate_output(tmp_path):
    """Calibrate a synthetic stereo pair with cv2.stereoCalibrate, save as users do, load."""
    rng = np.random.default_rng(7)
    truth = Rig.default()
    left, right = truth
    # a 9x6 chessboard of 25 mm squares, seen in 8 poses near the origin
    grid = np.zeros((54, 3), np.float32)
    grid[:, :2] = np.mgrid[0:9, 0:6].T.reshape(-1, 2) * 25.0 - [100.0, 62.5]
    obj, img1, img2 = [], [], []
    for _ in range(8):
        R = cv2.Rodrigues(rng.normal(size=3) * 0.25)[0]
        X = grid @ R.T + rng.normal(size=3) * 20
        obj.append(grid)
        img1.append(left.project(X).astype(np.float32))
        img2.append(right.project(X).astype(np.float32))
    rms, K1, D1, K2, D2, R, T, _, _ = cv2.stereoCalibrate(
        obj, img1, img2, left.K, left.dist.copy(), right.K, right.dist.copy(), left.size,
        flags=cv2.CALIB_FIX_INTRINSIC,
    )  # fmt: skip
    assert rms < 1e-2
    path = tmp_path / "stereo.yml"
    fs = cv2.FileStorage(str(path), cv2.FILE_STORAGE_WRITE)
    fs.startWriteStruct("imageSize", cv2.FileNode_SEQ | cv2.FileNode_FLOW)
    fs.write("", 640)
    fs.write("", 480)
    fs.endWriteStruct()
    for key, value in (("K1", K1), ("D1", D1), ("K2", K2), ("D2", D2), ("R", R), ("T", T)):
        fs.write(key, value)
    fs.release()
    rig = Rig.load(path)
    assert len(rig) == 2 and rig[0].size == (640, 480)
    np.testing.assert_allclose(rig[0].R, np.eye(3))
    np.testing.assert_allclose(rig[0].t, 0.0)
    # camera 2 relative to camera 1 equals the true relative pose
    R_rel = right.R @ left.R.T
    t_rel = right.t - R_rel @ left.t
    np.testing.assert_allclose(rig[1].R, R_rel, atol=1e-5)
    np.testing.assert_allclose(rig[1].t, t_rel, atol=1e-2)
    # and it projects points like the true rig (after moving them into camera-1 frame)
    X = rng.normal(size=(20, 3)) * 50
    np.testing.assert_allclose(
        rig[1].project(left.camera_from_world(X)), right.project(X), atol=0.02
    )


def test_reads_legacy_yaml_and_single_camera(tmp_path):
    text = (
        "%YAML:1.0\n---\n"
        "image_width: 800\nimage_height: 600\n"
        "camera_matrix: !!opencv-matrix\n   rows: 3\n   cols: 3\n   dt: d\n"
        "   data: [ 700., 0., 399.5, 0., 705., 299.5, 0., 0., 1. ]\n"
        "distortion_coefficients: !!opencv-matrix\n   rows: 5\n   cols: 1\n   dt: d\n"
        "   data: [ -0.1, 0.02, 0., 0., 0. ]\n"
    )
    path = tmp_path / "calib.yml"
    path.write_text(text)
    rig = Rig.load(path)
    cam = rig[0]
    assert cam.size == (800, 600)
    assert (cam.fx, cam.fy, cam.cx, cam.cy) == (700.0, 705.0, 399.5, 299.5)
    np.testing.assert_array_equal(cam.dist, [-0.1, 0.02, 0.0, 0.0, 0.0])


def anipose_toml(rig: Rig, rvecs) -> str:
    """`rig` as aniposelib's ``CameraGroup.dump`` writes it (the ``toml`` package's style:
    a table per camera, lists with a trailing comma, then the group's metadata)."""

    def row(values) -> str:
        return "[ " + " ".join(f"{float(v)!r}," for v in values) + "]"

    text = []
    for i, (cam, rvec) in enumerate(zip(rig.cameras, rvecs, strict=True)):
        matrix = "[ " + " ".join(row(r) + "," for r in cam.K) + "]"
        text += [
            f"[cam_{i}]", f'name = "{rig.names[i]}"',
            f"size = [ {cam.size[0]}, {cam.size[1]},]", f"matrix = {matrix}",
            f"distortions = {row(cam.dist)}", f"rotation = {row(rvec)}",
            f"translation = {row(cam.t)}", "",
        ]  # fmt: skip
    return "\n".join([*text, "[metadata]", "adjusted = false", "error = 0.31", ""])


def test_reads_an_anipose_camera_group(tmp_path):
    """A camera group as anipose writes it projects as aniposelib does: cv2.projectPoints
    with each camera's matrix, distortions, Rodrigues rotation and translation."""
    rng = np.random.default_rng(8)
    cams = [random_camera(rng, DISTORTIONS["k1k2p1p2k3"]) for _ in range(3)]
    rvecs = [cv2.Rodrigues(c.R)[0].ravel() for c in cams]
    path = tmp_path / "calibration.toml"
    path.write_text(anipose_toml(Rig(tuple(cams), ("A", "B", "C")), rvecs))
    rig = Rig.load(path)
    assert rig.names == ("A", "B", "C") and rig[2].size == (640, 480)
    X = points_in_view(cams[0], rng, 50)
    for cam, rvec, mine in zip(cams, rvecs, rig.cameras, strict=True):
        theirs, _ = cv2.projectPoints(X, rvec, cam.t, cam.K, cam.dist)
        np.testing.assert_allclose(mine.project(X), theirs[:, 0], atol=1e-6)

    fisheye = tmp_path / "fisheye.toml"
    fisheye.write_text(path.read_text().replace('name = "B"', 'name = "B"\nfisheye = true'))
    with pytest.raises(ValueError, match=r"fisheye\.toml: camera \[cam_1\] is a fisheye camera"):
        Rig.load(fisheye)
    broken = tmp_path / "broken.toml"
    broken.write_text(path.read_text().replace("rotation = [", "rotations = ["))
    with pytest.raises(ValueError, match=r"broken\.toml: missing key \[cam_0\]\.rotation"):
        Rig.load(broken)
    broken.write_text("[cam_0\nname = 1")
    with pytest.raises(ValueError, match=r"broken\.toml: not a readable TOML calibration file"):
        Rig.load(broken)


def test_reads_a_rectified_pair_from_its_projection_matrices(tmp_path):
    """``P1``, ``P2`` of cv2.stereoRectify (no image size in the file): the rectified
    cameras project a point as P @ [X; 1] does, and onto the same image row."""
    left, right = Rig.default()
    R_rel = right.R @ left.R.T
    t_rel = right.t - R_rel @ left.t
    R1, R2, P1, P2, Q, _, _ = cv2.stereoRectify(
        left.K, left.dist, right.K, right.dist, left.size, R_rel, t_rel.reshape(3, 1)
    )
    path = tmp_path / "extrinsics.yml"  # as OpenCV's stereo calibration sample writes it
    fs = cv2.FileStorage(str(path), cv2.FILE_STORAGE_WRITE)
    for key, value in (("R", R_rel), ("T", t_rel), ("R1", R1), ("R2", R2), ("P1", P1),
                       ("P2", P2), ("Q", Q)):  # fmt: skip
        fs.write(key, value)
    fs.release()
    with pytest.raises(ValueError, match=r"extrinsics\.yml: missing key 'image_width'"):
        Rig.load(path)
    rig = Rig.load(path, default_size=(640, 480))
    assert rig.names == ("left", "right") and rig[1].size == (640, 480)
    X = np.random.default_rng(9).normal(size=(30, 3)) * 60 + [0, 0, 600]
    for cam, P in zip(rig.cameras, (P1, P2), strict=True):
        h = np.column_stack([X, np.ones(len(X))]) @ P.T
        np.testing.assert_allclose(cam.project(X), h[:, :2] / h[:, 2:], atol=1e-6)
    np.testing.assert_allclose(rig[0].project(X)[:, 1], rig[1].project(X)[:, 1], atol=1e-6)
    assert Rig.load(path, size=(320, 240), default_size=(640, 480))[0].size == (320, 240)


def test_calibration_errors_name_file_and_key(tmp_path):
    missing = tmp_path / "none.yml"
    with pytest.raises(FileNotFoundError, match=r"none\.yml"):
        Rig.load(missing)
    path = tmp_path / "partial.yml"
    fs = cv2.FileStorage(str(path), cv2.FILE_STORAGE_WRITE)
    fs.write("K1", np.eye(3) * 600)
    fs.write("K2", np.eye(3) * 600)
    fs.write("image_width", 640)
    fs.write("image_height", 480)
    fs.write("T", np.zeros((3, 1)))
    fs.release()
    with pytest.raises(ValueError, match=r"partial\.yml: missing key 'R'"):
        Rig.load(path)
    garbage = tmp_path / "garbage.yml"
    garbage.write_text("cameras: [ [ \n")
    with pytest.raises(ValueError, match=r"garbage\.yml"):
        Rig.load(garbage)
    nosize = tmp_path / "nosize.yml"
    fs = cv2.FileStorage(str(nosize), cv2.FILE_STORAGE_WRITE)
    fs.write("camera_matrix", np.diag([600.0, 600.0, 1.0]))
    fs.release()
    with pytest.raises(ValueError, match=r"nosize\.yml: missing key 'image_width'"):
        Rig.load(nosize)
    assert Rig.load(nosize, size=(320, 240))[0].size == (320, 240)


def test_input_validation():
    cam = Rig.default()[0]
    with pytest.raises(ValueError, match=r"points: expected an array of shape \(N, 3\)"):
        cam.project(np.zeros((4, 2)))
    with pytest.raises(ValueError, match="points: expected finite"):
        cam.project([[0.0, np.nan, 0.0]])
    with pytest.raises(ValueError, match="pixels"):
        cam.rays(np.zeros(3))
    with pytest.raises(ValueError, match="R: expected a rotation"):
        Camera(600, 600, 320, 240, R=np.diag([1.0, 1.0, -1.0]))
    with pytest.raises(ValueError, match="dist: expected 4, 5 or 8"):
        Camera(600, 600, 320, 240, dist=np.zeros(6))
    with pytest.raises(ValueError, match="fx, fy"):
        Camera(-600, 600, 320, 240)
    with pytest.raises(ValueError, match="t: expected finite"):
        Camera(600, 600, 320, 240, t=[0, 0, np.inf])
    with pytest.raises(ValueError, match="size"):
        Camera(600, 600, 320, 240, size=(640.5, 480))


def test_ray_rotation_turns_the_optical_axis_onto_the_ray_without_a_twist():
    """Against the ray from the intrinsic matrix's inverse, by hand: the optical axis goes
    onto it, the rotation is proper, and its axis lies in the image plane (no twist about
    the optical axis), for a camera turned in the world too."""
    from scipy.spatial.transform import Rotation

    cam = Camera.assumed((1280, 720), fov=70.0)
    R = Rotation.from_euler("xyz", [10, -25, 5], degrees=True).as_matrix()
    turned = Camera(cam.fx, cam.fy, cam.cx, cam.cy, R=R, size=cam.size)
    for c in (cam, turned):
        for pixel in ((0.0, 0.0), (640.0, 360.0), (1279.0, 200.0)):
            Q = c.ray_rotation(pixel)
            ray = np.linalg.solve(c.K, [*pixel, 1.0])
            np.testing.assert_allclose(Q @ [0.0, 0.0, 1.0], ray / np.linalg.norm(ray), atol=1e-12)
            np.testing.assert_allclose(Q @ Q.T, np.eye(3), atol=1e-12)
            assert np.linalg.det(Q) > 0
            axis = Rotation.from_matrix(Q).as_rotvec()
            assert abs(axis[2]) < 1e-12
