"""Exported formats read back by independent readers and compared with the model.

- keypoint JSON and OpenPose JSON: read with the standard `json` module, compared with
  G(x) (`HandModel.joints`) and the cameras' projections;
- BVH: read with bvhio, whose forward kinematics must give G(x), turned into the file's
  axes and units by hand, within a micron over the whole synthetic track (float32
  inside bvhio: about 1e-4 mm); its skeleton has no zero-length bone;
- glTF: read with pygltflib, skinned with the specification's linear blend formula in
  `tests/export_readers.py`, turned back from y-up metres by hand and compared with the
  model's mesh on every frame (exact to float32 rounding; 2 mm required); the Khronos
  validator (npm's gltf-validator, when installed) finds no error and no warning;
- the viewer page: its figure decoded with `json`: keypoints and surface on the frames
  with a hand and nothing on the others, the opening view computed from the layout as
  gl-plot3d draws it and compared with the camera's projection, axes that hold the
  hand, frames as small JPEGs, curves named by what they hold; rendered by headless
  Chromium: no console message, the surface, the skeleton and the frame drawn.

`benchmarks/export_files.py` prints the same round-trip errors.
"""

from __future__ import annotations

import json
import os
import re
import shutil
import subprocess
import warnings
from pathlib import Path

import numpy as np
import pytest

from handvar.camera import Camera, Rig
from handvar.export import (
    bvh_text,
    fit_confidence,
    glb_bytes,
    joint_visibility,
    keypoint_frames,
    keypoint_share,
    mesh_vertices,
    openpose_frames,
    viewer_html,
    write_openpose,
)
from handvar.export.bvh import bvh_joint_order
from handvar.export.keypoints import openpose_name, point_support
from handvar.hand.anthropometry import JOINTS, HandShape
from handvar.hand.kinematics import HandModel, named_pose
from handvar.synth.sequences import sequence_poses
from tests.export_readers import bvh_world_joints, gltf_skinned_vertices

SIDES = ("right", "left")


@pytest.fixture(scope="module")
def poses() -> np.ndarray:
    """The whole synthetic benchmark track (175 frames)."""
    return sequence_poses("benchmark")


@pytest.mark.parametrize("side", SIDES)
def test_keypoint_json_round_trip(poses, side):
    hand = HandModel(HandShape.from_size(185.0, side=side))
    rig = Rig.default()
    sub = poses[::25]
    conf = np.linspace(0.2, 0.9, len(sub))
    doc = json.loads(json.dumps(keypoint_frames(sub, hand, rig, confidence=conf)))
    assert doc["joints"] == list(JOINTS) and doc["hand"] == side
    assert len(doc["frames"]) == len(sub)
    for t, x in enumerate(sub):
        frame = doc["frames"][t]
        G = hand.joints(x)
        np.testing.assert_allclose(frame["world"], G, atol=1e-4)
        assert frame["confidence"] == pytest.approx(conf[t])
        for view, camera, cam in zip(frame["views"], rig.cameras, doc["cameras"], strict=True):
            np.testing.assert_allclose(view["keypoints_2d"], camera.project(G), atol=1e-3)
            # the camera-frame 3D, and back to the world with the written R, t
            p_cam = np.array(view["keypoints_3d"])
            np.testing.assert_allclose(p_cam, G @ camera.R.T + camera.t, atol=1e-4)
            back = (p_cam - np.array(cam["t"])) @ np.array(cam["R"])
            np.testing.assert_allclose(back, G, atol=1e-3)
            assert len(view["visible"]) == 21 and all(view["in_image"])


def _openpose_file(folder, names, camera: int, frame: int) -> dict:
    """One OpenPose frame file: in `folder` for one camera, in its subfolder for more."""
    sub = folder if len(names) == 1 else folder / names[camera]
    return json.loads((sub / openpose_name(names[camera], frame)).read_text())


@pytest.mark.parametrize("side", SIDES)
def test_openpose_round_trip(poses, side, tmp_path):
    """Every list OpenPose writes at its full length; the tracked hand in its side's,
    pixels and world points where found, zeros elsewhere; a point's score is the
    frame's confidence, halved where the hand hides it, 0 outside the image."""
    hand = HandModel(HandShape.from_size(185.0, side=side))
    rig = Rig.default()
    sub = poses[:3].copy()
    sub[1, 1] -= 150.0  # up out of the image: 10 points outside either camera's
    conf = np.array([0.9, 0.5, 0.0])  # frame 2 lost
    write_openpose(tmp_path / "op", openpose_frames(sub, hand, rig, confidence=conf), rig.names)
    lengths = {"pose_keypoints_2d": 75, "face_keypoints_2d": 210, "hand_left_keypoints_2d": 63,
               "hand_right_keypoints_2d": 63, "pose_keypoints_3d": 100,
               "face_keypoints_3d": 280, "hand_left_keypoints_3d": 84,
               "hand_right_keypoints_3d": 84}  # fmt: skip  # BODY_25, face, hands: x y (z) c
    for j, camera in enumerate(rig.cameras):
        for t, x in enumerate(sub):
            data = _openpose_file(tmp_path / "op", rig.names, j, t)
            assert data["version"] == 1.3 and len(data["people"]) == 1
            person = data["people"][0]
            assert person["person_id"] == [-1]
            assert {k: len(v) for k, v in person.items() if k != "person_id"} == lengths
            for name, values in person.items():
                if name != "person_id" and not name.startswith(f"hand_{side}_"):
                    assert not any(values), name  # nothing found there: zeros
            kp = np.array(person[f"hand_{side}_keypoints_2d"]).reshape(21, 3)
            G = hand.joints(x)
            uv = camera.project(G)
            inside = camera.in_image(uv)
            want = np.where(inside, np.where(joint_visibility(hand, x, camera), 1.0, 0.5), 0.0)
            np.testing.assert_allclose(kp[:, 2], conf[t] * want, atol=1e-4)
            found = kp[:, 2] > 0
            np.testing.assert_allclose(kp[found, :2], uv[found], atol=1e-3)
            assert not kp[~found].any()  # zeros where nothing was found
            assert found.sum() == {0: 21, 1: 11, 2: 0}[t]  # by the shift above
            kp3 = np.array(person[f"hand_{side}_keypoints_3d"]).reshape(21, 4)
            if conf[t] > 0:  # 3D: c 1 where reconstructed, as OpenPose's --3d output
                np.testing.assert_allclose(kp3, np.column_stack([G, np.ones(21)]), atol=1e-3)
            else:
                assert not kp3.any()


def test_point_confidence_follows_the_tracks_evidence(poses):
    """Per point: the frame's confidence times 1 (keypoint followed), 0.5 (far from
    the fit), 0.25 (rejected or missing), times 0.5 more on a frame whose keypoints were
    carried; 1 on a frame fitted without keypoints (by hand from docs/outputs.md)."""
    from types import SimpleNamespace

    d = np.full((3, 2, 21), np.nan)  # hand sizes; NaN: no keypoint or rejected
    d[0, 0, :3] = [0.05, 0.5, np.nan]
    d[0, 1, :3] = [np.nan, 0.3, np.nan]  # the nearest camera counts
    d[1, 0, :] = 0.1
    d[1, 0, 20] = np.nan
    quality = SimpleNamespace(keypoints=np.array([True, True, False]), distances=d)
    support = point_support(quality, detections=[True, False, False])
    want = np.ones((3, 21))
    want[0, 3:] = 0.25  # no keypoint kept on a frame with keypoints
    want[0, :3] = [1.0, 0.5, 0.25]
    want[1] = 0.5  # carried
    want[1, 20] = 0.5 * 0.25
    np.testing.assert_allclose(support, want)
    hand, rig = HandModel(HandShape.from_size(185.0)), Rig.default()
    conf = np.array([0.8, 0.6, 0.7])
    doc = keypoint_frames(poses[:3], hand, rig, confidence=conf, support=support)
    frames = openpose_frames(poses[:3], hand, rig, confidence=conf, support=support)
    for t in range(3):
        for j, camera in enumerate(rig.cameras):
            hidden = ~joint_visibility(hand, poses[t], camera)
            score = conf[t] * want[t] * np.where(hidden, 0.5, 1.0)
            kp = np.array(frames[j][t]["people"][0]["hand_right_keypoints_2d"]).reshape(21, 3)
            np.testing.assert_allclose(kp[:, 2], score, atol=1e-4)
            np.testing.assert_allclose(doc["frames"][t]["views"][j]["scores"], score, atol=1e-4)


@pytest.mark.parametrize("side", SIDES)
def test_openpose_folder_loads_in_pose_format(poses, gappy, side, tmp_path):
    """pose-format's OpenPose reader (PyPI pose-format) finds the 21 points in the
    hand's component, the points and scores written, nothing in the other components,
    and nothing on the frames without a hand."""
    why = "pose-format is not installed (pip install pose-format)"
    openpose = pytest.importorskip("pose_format.utils.openpose", reason=why)
    hand = HandModel(HandShape.from_size(185.0, side=side))
    camera = Rig.default().cameras[0]
    rig = Rig([camera], ("cam0",))
    conf = np.linspace(0.5, 0.9, len(gappy))
    write_openpose(tmp_path / "op", openpose_frames(gappy, hand, rig, confidence=conf), rig.names)
    width, height = camera.size
    pose = openpose.load_openpose_directory(str(tmp_path / "op"), fps=25.0, width=width,
                                            height=height)  # fmt: skip
    names = [c.name for c in pose.header.components]
    assert names == ["pose_keypoints_2d", "face_keypoints_2d", "hand_left_keypoints_2d",
                     "hand_right_keypoints_2d"]  # fmt: skip
    assert pose.body.data.shape == (len(gappy), 1, 25 + 70 + 21 + 21, 2)
    ours = pose.get_components([f"hand_{side}_keypoints_2d"])
    assert ours.body.data.shape == (len(gappy), 1, 21, 2)
    others = [n for n in names if n != f"hand_{side}_keypoints_2d"]
    assert not pose.get_components(others).body.confidence.any()
    for t, x in enumerate(gappy):
        data, score = ours.body.data[t, 0], np.asarray(ours.body.confidence[t, 0])
        if t in ABSENT:
            assert not score.any() and data.mask.all()  # people []: nothing there
            continue
        uv = camera.project(hand.joints(x))
        want = np.where(joint_visibility(hand, x, camera), 1.0, 0.5) * camera.in_image(uv)
        np.testing.assert_allclose(score, conf[t] * want, atol=1e-4)
        found = score > 0
        np.testing.assert_allclose(data[found], uv[found], atol=1e-3)
        assert data.mask[~found].all()


def test_visibility_of_open_hand_and_fist():
    """A flat open hand hides none of its keypoints from either side; a fist seen from
    the back of the hand hides the four fingertips curled under the knuckles."""
    hand = HandModel()
    front = Rig.default().cameras[0]  # the palm faces the default cameras
    back = Camera.look_at(front.center * np.array([1.0, 1.0, -1.0]), target=[0.0, 90.0, 0.0])
    open_, fist = named_pose("open"), named_pose("fist")
    assert joint_visibility(hand, open_, front).all()
    assert joint_visibility(hand, open_, back).all()
    tips = [JOINTS.index(f"{d}_tip") for d in ("index", "middle", "ring", "little")]
    assert not joint_visibility(hand, fist, back)[tips].any()
    assert joint_visibility(hand, fist, back)[JOINTS.index("wrist")]


def test_keypoint_share_is_the_checks_measure_with_the_rejected_counted_out():
    from handvar.tracking.frame_fit import honoured
    from handvar.tracking.recovery import TrackQuality

    d = np.array([[[0.1, 0.3, np.nan, 0.05]], [[np.nan] * 4], [[0.1, 0.1, 0.1, 0.1]]])
    n = len(d)
    quality = TrackQuality(
        iou=np.full((n, 1), np.nan), keypoint_error=np.zeros(n), cost=np.zeros(n),
        lost=np.zeros(n, bool), reinit=np.zeros(n, bool), empty=np.zeros((n, 1), bool),
        keypoints=np.ones(n, bool), rejected=np.array([1, 0, 0]), distances=d,
    )  # fmt: skip
    share = keypoint_share(quality)
    np.testing.assert_allclose(share, [2 / 4, np.nan, 1.0])
    # the keypoint check's worst frame over the kept points alone is the share without them
    assert honoured(d[[0]], np.zeros((1, 1, 4), bool))[1] == 2 / 3
    conf = fit_confidence(quality.iou, quality.lost, share)
    np.testing.assert_allclose(conf, [0.5, 0.0, 1.0])


def test_fit_confidence_is_iou_and_zero_when_lost():
    conf = fit_confidence([[0.8, 0.6], [np.nan, np.nan], [1.2, 1.0]], [False, False, True])
    np.testing.assert_allclose(conf, [0.7, 0.0, 0.0])


def in_file_axes(points, up: str = "y", units: str = "m") -> np.ndarray:
    """Camera-frame mm points (x right, y down, z forward) in a y-up or z-up file's
    axes and units, written out by hand: y up is (x, -y, -z), z up is (x, z, -y)."""
    p = np.asarray(points, dtype=float)
    turned = p * [1.0, -1.0, -1.0] if up == "y" else p[..., [0, 2, 1]] * [1.0, 1.0, -1.0]
    return turned / {"mm": 1.0, "cm": 10.0, "m": 1000.0}[units]


@pytest.mark.parametrize(("side", "units", "up", "every"),
                         [("right", "m", "y", 1), ("left", "m", "y", 1),
                          ("right", "mm", "z", 5), ("left", "cm", "z", 5)])  # fmt: skip
def test_bvh_forward_kinematics_is_g_of_x(poses, side, units, up, every, tmp_path):
    """bvhio's forward kinematics gives G(x) turned into the file's axes and units."""
    shape = HandShape.from_size(170.0, side=side)
    sub = poses[::every]
    path = tmp_path / "track.bvh"
    path.write_text(bvh_text(sub, shape, fps=25.0, units=units, up=up))
    got = bvh_world_joints(path, bvh_joint_order())
    hand = HandModel(shape)
    want = in_file_axes(np.stack([hand.joints(x) for x in sub]), up, units)
    assert got.shape == want.shape
    mm = {"mm": 1.0, "cm": 10.0, "m": 1000.0}[units]
    assert np.abs(got - want).max() * mm <= 1e-3  # float32 inside bvhio: ~1e-4 mm


def test_bvh_skeleton_reads_as_a_hand(poses, tmp_path):
    """Every bone has a length (a tool that draws a bone from a joint to its child
    draws no stub); a bone runs from the wrist to each digit's base joint, the joint's
    only child; the root's bone ends at the wrist; Frame Time is 1/fps."""
    with warnings.catch_warnings():  # its glm binding warns of a deprecation on import
        warnings.simplefilter("ignore", PendingDeprecationWarning)
        import bvhio

    shape = HandShape.from_size(185.0)
    path = tmp_path / "track.bvh"
    path.write_text(bvh_text(poses[:3], shape, fps=29.97))
    bvh = bvhio.readAsBvh(str(path))
    assert bvh.FrameTime == pytest.approx(1 / 29.97, rel=1e-6) and bvh.FrameCount == 3
    joints = {j.Name: (j, depth) for j, _, depth in bvh.Root.layout()}
    for name, (joint, depth) in joints.items():
        if depth > 0:
            assert np.linalg.norm(np.array(joint.Offset)) > 1e-3, name  # > 1 mm
        if joint.EndSite is not None:
            assert np.linalg.norm(np.array(joint.EndSite)) > 1e-3, name
    root = bvh.Root
    assert len(root.Children) == 5 and np.linalg.norm(np.array(root.Offset)) == 0.0
    # offsets are in the hand frame, which is the world frame at the rest pose (x = 0)
    rest = HandModel(shape).joints(np.zeros(26)) / 1000.0  # m
    stub = 0.3 * np.linalg.norm(rest[9] - rest[0])  # the forearm: 0.3 palm lengths
    for wrist_joint, base in zip(root.Children, [1, 5, 9, 13, 17], strict=True):
        np.testing.assert_allclose(wrist_joint.Offset, [0.0, stub, 0.0], atol=1e-7)
        (child,) = wrist_joint.Children  # one bone, from the wrist to the base joint
        np.testing.assert_allclose(child.Offset, rest[base] - rest[0], atol=1e-7)


def test_bvh_frame_time_follows_the_frame_rate(poses):
    for fps, line in [(25.0, "Frame Time: 0.04000000"), (None, "Frame Time: 0.03333333"),
                      (60.0, "Frame Time: 0.01666667")]:  # fmt: skip
        assert line in bvh_text(poses[:2], HandShape.from_size(), fps=fps).splitlines()


@pytest.mark.parametrize("side", SIDES)
def test_gltf_skinned_vertices_are_the_mesh_on_every_frame(poses, side, tmp_path):
    """The specification's skinning of the file, turned back from glTF's y-up metres by
    hand, is the model's mesh on every frame of the benchmark track (required: 2 mm)."""
    shape = HandShape.from_size(185.0, side=side)
    path = tmp_path / "track.glb"
    path.write_bytes(glb_bytes(poses, shape, fps=25.0))
    got = gltf_skinned_vertices(path, range(len(poses)))
    want = mesh_vertices(shape, poses)
    worst = max(np.linalg.norm(in_file_axes(want[f]) - got[f], axis=1).max()
                for f in range(len(poses)))  # fmt: skip
    assert worst * 1000.0 <= 1e-3  # mm: exact to float32 rounding (about 2e-5 mm)


def test_gltf_plain_skinning_is_what_the_helpers_correct(poses, tmp_path):
    """Without the helper joints the file is plain skinning of the rest mesh: off by
    millimetres (so the helpers are needed), and only 16 joints."""
    import pygltflib

    shape = HandShape.from_size(185.0)
    path = tmp_path / "plain.glb"
    path.write_bytes(glb_bytes(poses[::25], shape, corrective=False))
    gltf = pygltflib.GLTF2().load(str(path))
    assert len(gltf.skins[0].joints) == 16 + 5  # the bones and the fingertips
    got = gltf_skinned_vertices(path, range(len(poses[::25])))
    want = mesh_vertices(shape, poses[::25])
    worst = max(np.abs(in_file_axes(want[i]) - got[i]).max() for i in got) * 1000.0
    assert 1.0 < worst < 10.0  # mm


def test_gltf_size_grows_linearly_with_the_frames(poses):
    """Each frame adds the same bytes (its time, the palm's translation and 16
    quaternions: 4 + 12 + 16 · 16 = 272), whatever the number of frames."""
    shape = HandShape.from_size(185.0)
    loop = np.concatenate([poses, poses[::-1]])
    size = {n: len(glb_bytes(np.resize(loop, (n, 26)), shape)) for n in (100, 400, 1600)}
    per_frame = [(size[400] - size[100]) / 300, (size[1600] - size[400]) / 1200]
    assert per_frame == pytest.approx([272.0, 272.0], abs=0.5)  # JSON bounds vary a byte


def test_gltf_frame_rate_and_material(poses, tmp_path):
    """Key i at i/fps s, the frame rate in the asset's and the scene's extras, a
    metallic-roughness skin-coloured material and unit normals."""
    import pygltflib

    from tests.export_readers import accessor

    path = tmp_path / "track.glb"
    path.write_bytes(glb_bytes(poses[:30], HandShape.from_size(185.0), fps=29.97))
    gltf = pygltflib.GLTF2().load(str(path))
    blob = gltf.binary_blob()
    for sampler in gltf.animations[0].samplers:
        times = accessor(gltf, blob, sampler.input)[:, 0]
        np.testing.assert_allclose(times, np.arange(30) / 29.97, rtol=1e-6)
    assert gltf.asset.extras["fps"] == gltf.scenes[0].extras["fps"] == 29.97
    prim = gltf.meshes[0].primitives[0]
    pbr = gltf.materials[prim.material].pbrMetallicRoughness
    r, g, b, a = pbr.baseColorFactor
    assert r > g > b > 0.2 and a == 1.0 and pbr.metallicFactor == 0.0  # skin: warm, opaque
    normals = accessor(gltf, blob, prim.attributes.NORMAL)
    np.testing.assert_allclose(np.linalg.norm(normals, axis=1), 1.0, atol=1e-6)


def _gltf_validator() -> tuple[str, str] | None:
    """node and the folder holding the npm package gltf-validator, if installed."""
    node, npm = shutil.which("node"), shutil.which("npm")
    if node is None or npm is None:
        return None
    root = subprocess.run([npm, "root", "-g"], capture_output=True, text=True).stdout.strip()
    return (node, root) if (Path(root) / "gltf-validator").is_dir() else None


@pytest.mark.skipif(_gltf_validator() is None, reason="the Khronos glTF validator is not "
                    "installed (npm install -g gltf-validator)")  # fmt: skip
def test_gltf_passes_the_khronos_validator(poses, gappy, tmp_path):
    node, root = _gltf_validator()
    script = (
        "const v = require('gltf-validator'); const fs = require('fs');"
        "v.validateBytes(new Uint8Array(fs.readFileSync(process.argv[1])))"
        ".then(r => console.log(JSON.stringify(r.issues)))"
        ".catch(e => { console.error(String(e)); process.exit(1); });"
    )
    files = {"right": glb_bytes(poses[:20], HandShape.from_size(185.0)),
             "left": glb_bytes(poses[:20], HandShape.from_size(170.0, side="left")),
             "gaps": glb_bytes(gappy, HandShape.from_size(185.0)),
             "plain": glb_bytes(poses[:5], HandShape.from_size(), corrective=False)}  # fmt: skip
    for name, data in files.items():
        path = tmp_path / f"{name}.glb"
        path.write_bytes(data)
        run = subprocess.run([node, "-e", script, str(path)], capture_output=True, text=True,
                             env={**os.environ, "NODE_PATH": root}, timeout=120)  # fmt: skip
        assert run.returncode == 0, run.stderr[-2000:]
        issues = json.loads(run.stdout)
        assert (issues["numErrors"], issues["numWarnings"]) == (0, 0), (name, issues["messages"])


def test_left_mesh_fits_the_left_skeleton():
    """The exported left mesh is a mesh of the left hand: its distances to the left
    model's keypoints G(x) are the right mesh's distances to the right model's, and it
    is not the right mesh."""
    from scipy.spatial import cKDTree

    x = named_pose("pinch")
    dist = {}
    for side in SIDES:
        shape = HandShape.from_size(side=side)
        vertices = mesh_vertices(shape, x[None])[0]
        dist[side] = cKDTree(vertices).query(HandModel(shape).joints(x))[0]
    np.testing.assert_allclose(dist["left"], dist["right"], atol=1e-6)
    right = mesh_vertices(HandShape.from_size(), x[None])[0]
    left = mesh_vertices(HandShape.from_size(side="left"), x[None])[0]
    assert np.abs(left - right).max() > 50.0


def _chromium() -> str | None:
    return shutil.which("chromium") or shutil.which("chromium-browser")


@pytest.mark.slow
@pytest.mark.skipif(_chromium() is None, reason="headless Chromium is not installed "
                    "(apt-get install chromium)")  # fmt: skip
def test_viewer_renders_in_headless_chromium(poses, tmp_path):
    """No console message; the scene shows the hand's surface (skin tones) and the
    skeleton's digit colours on the left, the frame (a blue image here) on the right."""
    from handvar.export.viewer import hand_surface

    shape = HandShape.from_size()
    joints = np.stack([HandModel(shape).joints(x) for x in poses[:20]])
    blue = np.zeros((480, 640, 3), np.uint8)
    blue[..., 2] = 255
    page = tmp_path / "view.html"
    page.write_text(viewer_html(joints, surface=hand_surface(shape, poses[:20]),
                                images=[blue] * 20, rig=Rig.default(),
                                quality=np.linspace(0.7, 0.9, 20)))  # fmt: skip
    text = page.read_text()
    assert "Plotly.newPlot" in text and not re.search(r"<script[^>]*\bsrc=", text)  # embedded
    # a copy that records console errors and uncaught exceptions into the page's title
    capture = (
        "<script>window.__errors = [];"
        "window.addEventListener('error', function (e) { __errors.push(String(e.message)); });"
        "var __ce = console.error; console.error = function () {"
        " __errors.push(Array.prototype.join.call(arguments, ' '));"
        " __ce.apply(console, arguments); };"
        "window.addEventListener('load', function () { setTimeout(function () {"
        " document.title = 'errors:' + JSON.stringify(__errors)"
        " + ' canvases:' + document.querySelectorAll('canvas').length; }, 500); });</script>"
    )
    probe = tmp_path / "probe.html"
    probe.write_text(text.replace("<head>", "<head>" + capture, 1))
    common = [_chromium(), "--headless", "--no-sandbox", "--disable-gpu",
              "--disable-background-networking", "--window-size=1000,850",
              "--virtual-time-budget=5000"]  # fmt: skip
    dom = subprocess.run([*common, "--dump-dom", probe.as_uri()], capture_output=True,
                         text=True, timeout=120)  # fmt: skip
    assert dom.returncode == 0, dom.stderr[-2000:]
    title = re.search(r"<title>(.*?)</title>", dom.stdout)
    assert title is not None, "the page's scripts did not run"
    assert title.group(1).startswith("errors:[] canvases:"), title.group(1)
    assert int(title.group(1).rsplit(":", 1)[1]) > 0  # plotly made its canvases
    shot = tmp_path / "shot.png"
    run = subprocess.run([*common, f"--screenshot={shot}", page.as_uri()],
                         capture_output=True, text=True, timeout=120)  # fmt: skip
    assert run.returncode == 0, run.stderr[-2000:]
    import cv2

    image = cv2.imread(str(shot))
    assert image is not None and image.shape[0] > 100
    # drawn: not one flat colour; in the WebGL scene (left half) skin and the thumb's
    # red (230, 60, 60) and the index finger's orange (240, 170, 30); the frame's blue
    # on the right
    assert image.std() > 10.0
    half = image.shape[1] // 2
    b, g, r = (image[:, :half, i].astype(int) for i in range(3))
    assert np.sum((r > 180) & (r - b > 25) & (r > g) & (g > b) & (g > 120)) > 2000  # skin
    assert np.sum((r > 180) & (g < 110) & (b < 110)) > 50  # thumb
    assert np.sum((r > 200) & (g > 130) & (g < 200) & (b < 90)) > 50  # index
    b, g, r = (image[:, half:, i].astype(int) for i in range(3))
    assert np.sum((b > 200) & (r < 60) & (g < 60)) > 20000


# A track whose hand is absent on some frames: its pose there is NaN as a whole.
ABSENT = [0, 1, 4, 5]  # leading and inner frames without a hand, of 8
HELD_FROM = [2, 2, 2, 3, 3, 3, 6, 7]  # the tracked frame each one shows in BVH and glTF:
# the last one before it, or the first one for the leading frames (by hand)


@pytest.fixture(scope="module")
def gappy(poses) -> np.ndarray:
    """The first 8 frames of the benchmark track, without a hand on the frames ABSENT."""
    out = poses[:8].copy()
    out[ABSENT] = np.nan
    return out


def test_keypoint_json_has_no_points_on_frames_without_a_hand(poses, gappy):
    """world null, confidence 0 and no views there, whatever confidence was given; the
    other frames as if every frame had a hand."""
    hand, rig = HandModel(HandShape.from_size(185.0)), Rig.default()
    conf = np.where(np.isin(np.arange(8), ABSENT), 0.0, 0.9)
    given = np.full(8, 0.9)  # a confidence on the frames without a hand too: overruled
    doc = json.loads(json.dumps(keypoint_frames(gappy, hand, rig, confidence=given)))
    unknown = keypoint_frames(gappy, hand, rig)  # no confidence: null, but 0 without a hand
    assert [f["confidence"] for f in unknown["frames"]] == [
        0.0 if t in ABSENT else None for t in range(8)]  # fmt: skip
    full = json.loads(json.dumps(keypoint_frames(poses[:8], hand, rig, confidence=conf)))
    assert [f["frame"] for f in doc["frames"]] == list(range(8))
    for t, frame in enumerate(doc["frames"]):
        if t in ABSENT:
            assert frame == {"frame": t, "confidence": 0.0, "world": None, "views": []}
        else:
            assert frame == full["frames"][t]  # the same points as with every frame tracked
    assert {k: v for k, v in doc.items() if k != "frames"} == {
        k: v for k, v in full.items() if k != "frames"
    }


def test_openpose_has_no_people_on_frames_without_a_hand(poses, gappy, tmp_path):
    hand, rig = HandModel(HandShape.from_size(185.0, side="left")), Rig.default()
    write_openpose(tmp_path / "gaps", openpose_frames(gappy, hand, rig), rig.names)
    write_openpose(tmp_path / "full", openpose_frames(poses[:8], hand, rig), rig.names)
    for j, name in enumerate(rig.names):  # one folder per camera
        assert len(list((tmp_path / "gaps" / name).iterdir())) == 8
        for t in range(8):
            got = _openpose_file(tmp_path / "gaps", rig.names, j, t)
            if t in ABSENT:
                assert got == {"version": 1.3, "people": []}
            else:
                assert got == _openpose_file(tmp_path / "full", rig.names, j, t)


@pytest.mark.parametrize("side", SIDES)
def test_bvh_holds_the_last_tracked_pose_on_frames_without_a_hand(poses, gappy, side, tmp_path):
    shape = HandShape.from_size(170.0, side=side)
    path = tmp_path / "track.bvh"
    path.write_text(bvh_text(gappy, shape, fps=25.0))
    got = bvh_world_joints(path, bvh_joint_order())  # bvhio
    hand = HandModel(shape)
    want = in_file_axes(np.stack([hand.joints(poses[f]) for f in HELD_FROM]))
    assert got.shape == (8, 21, 3)
    assert np.abs(got - want).max() <= 1e-6  # m
    assert path.read_text() == bvh_text(poses[HELD_FROM], shape, fps=25.0)  # filled by hand


def test_gltf_hides_the_hand_on_frames_without_a_hand(poses, gappy, tmp_path):
    """The palm is scaled to 0 there (STEP keys where the hand comes and goes): every
    vertex at the held pose's wrist; the other frames are the model's mesh."""
    import pygltflib

    from tests.export_readers import accessor

    shape = HandShape.from_size(185.0)
    path = tmp_path / "track.glb"
    path.write_bytes(glb_bytes(gappy, shape, fps=25.0))
    gltf = pygltflib.GLTF2().load(str(path))
    blob = gltf.binary_blob()
    (scale,) = [c for c in gltf.animations[0].channels if c.target.path == "scale"]
    sampler = gltf.animations[0].samplers[scale.sampler]
    assert sampler.interpolation == "STEP" and scale.target.node == 0  # the palm
    np.testing.assert_allclose(accessor(gltf, blob, sampler.input)[:, 0],
                               np.array([0, 2, 4, 6]) / 25.0, rtol=1e-6)  # fmt: skip
    np.testing.assert_array_equal(accessor(gltf, blob, sampler.output)[:, 0], [0, 1, 0, 1])
    got = gltf_skinned_vertices(path, range(8))
    for f in range(8):
        held = poses[HELD_FROM[f]]
        if f in ABSENT:
            wrist = in_file_axes(held[:3])  # every vertex there
            assert np.abs(got[f] - wrist).max() <= 1e-7
        else:
            want = in_file_axes(mesh_vertices(shape, held[None])[0])
            assert np.abs(got[f] - want).max() <= 1e-6  # m
    assert gltf.asset.extras["frames_without_hand"] == len(ABSENT)


def _animated(data: list, frame: dict) -> dict[str, dict]:
    """A page frame's data by the name of the trace each one updates."""
    return {data[i]["name"]: d for i, d in zip(frame["traces"], frame["data"], strict=True)}


def test_viewer_shows_neither_skeleton_nor_surface_on_frames_without_a_hand(poses, gappy,
                                                                            tmp_path):  # fmt: skip
    """The frames with a hand show its keypoints (to 0.05 mm) and its surface (to half a
    mm: whole mm on the page); the others nothing, and keep their place."""
    from handvar.export import write_viewer
    from handvar.export.viewer import hand_surface
    from tests.export_readers import plotly_array, plotly_page

    shape = HandShape.from_size()
    hand = HandModel(shape)
    joints = np.full((8, 21, 3), np.nan)
    tracked = [t for t in range(8) if t not in ABSENT]
    joints[tracked] = [hand.joints(poses[t]) for t in tracked]
    vertices, triangles = hand_surface(shape, gappy)
    page = write_viewer(tmp_path / "view.html", joints, surface=(vertices, triangles),
                        rig=Rig.default(), quality=np.linspace(0.0, 0.9, 8))  # fmt: skip
    data, layout, frames = plotly_page(page.read_text())
    assert [f["name"] for f in frames] == [str(t) for t in range(8)]
    assert len(layout["sliders"][0]["steps"]) == 8
    (mesh,) = [d for d in data if d["type"] == "mesh3d"]
    np.testing.assert_array_equal(np.column_stack([plotly_array(mesh[k]) for k in "ijk"]),
                                  triangles)  # fmt: skip
    for t, frame in enumerate(frames):
        got = _animated(data, frame)
        bones, dots, surface = got["bones"], got["keypoints"], got["surface"]
        if t in ABSENT:
            assert all(v is None for trace in (bones, dots) for k in "xyz" for v in trace[k])
            assert surface["visible"] is False and surface["x"] == []
        else:
            xyz = np.column_stack([plotly_array(dots[k]) for k in "xyz"])
            np.testing.assert_allclose(xyz, joints[t], atol=0.05)
            assert sum(v is not None for v in bones["x"]) == 40  # 20 bones, 2 ends each
            assert surface["visible"] is True
            xyz = np.column_stack([plotly_array(surface[k]) for k in "xyz"])
            np.testing.assert_allclose(xyz, vertices[t], atol=0.5)
    assert all(v is None for v in data[1]["x"])  # the first frame, shown on opening
    assert data[0]["visible"] is False


def test_the_skeleton_has_the_overlays_colours():
    from handvar.export.viewer import DIGIT_RGB
    from handvar.render.overlay import _DIGIT_RGB

    assert DIGIT_RGB == _DIGIT_RGB


def _area(vertices: np.ndarray, triangles: np.ndarray) -> float:
    a, b, c = (vertices[triangles[:, i]] for i in range(3))
    return float(0.5 * np.linalg.norm(np.cross(b - a, c - a), axis=1).sum())


def test_hand_surface_is_the_models_mesh(poses, gappy):
    """Its vertices are vertices of the model's skinned mesh (`mesh_vertices`) on every
    frame with a hand, for either hand, and its triangles cover the same area within
    2 %; NaN on the frames without one."""
    from scipy.spatial import cKDTree

    from handvar.export.gltf import rest_mesh
    from handvar.export.viewer import SURFACE_VERTICES, hand_surface

    for side in SIDES:
        shape = HandShape.from_size(175.0, side=side)
        vertices, triangles = hand_surface(shape, gappy)
        assert vertices.shape == (8, SURFACE_VERTICES, 3) and triangles.shape[1] == 3
        assert np.isnan(vertices[ABSENT]).all()
        full = mesh_vertices(shape, poses[:8])
        _, full_triangles, _ = rest_mesh(shape)
        for t in sorted(set(range(8)) - set(ABSENT)):
            assert cKDTree(full[t]).query(vertices[t])[0].max() < 1e-9  # a subset
            want = _area(full[t], full_triangles)
            assert _area(vertices[t], triangles) == pytest.approx(want, rel=0.02)


def test_viewer_opens_through_the_camera_with_the_hand_large(poses, tmp_path):
    """The opening view, computed from the page's layout as gl-plot3d draws it
    (`plotly_view_pixels`), shows the hand as the first camera does: its keypoints are
    the camera's pixels up to a scale and a shift (no turn, no mirror: within 3 % of
    the hand's size in the image), inside the view and at least half its height; the
    free view looks from elsewhere, as far away."""
    from tests.export_readers import plotly_page, plotly_view_pixels

    rig = Rig.default()
    hand = HandModel()
    joints = np.stack([hand.joints(x) for x in poses[:30]])
    _, layout, frames = plotly_page(viewer_html(joints, rig=rig))
    scene = layout["scene"]
    size = (800, 700)
    got = plotly_view_pixels(scene, joints[0], size)
    want = rig.cameras[0].project(joints[0])
    # want ≈ s · got + shift, least squares
    A = np.zeros((42, 3))
    A[0::2, 0], A[1::2, 0] = got[:, 0], got[:, 1]
    A[0::2, 1], A[1::2, 2] = 1.0, 1.0
    (s, *_), *_ = np.linalg.lstsq(A, want.ravel(), rcond=None)
    fit = A @ np.linalg.lstsq(A, want.ravel(), rcond=None)[0]
    extent = np.ptp(want, axis=0).max()
    assert s > 0 and np.abs(fit - want.ravel()).max() < 0.03 * extent
    assert got.min() > 0 and (got < size).all()  # in the view
    assert np.ptp(got, axis=0).max() > 0.5 * size[1]  # large
    assert scene["aspectmode"] == "cube" and scene["dragmode"] == "orbit"
    # the frame's ranges are the opening layout's (frame 0)
    assert frames[0]["layout"]["scene"]["xaxis"]["range"] == scene["xaxis"]["range"]
    views = {b["label"]: b["args"][0]["scene.camera"] for b in layout["updatemenus"][1]["buttons"]}
    assert views["Camera view"] == scene["camera"]
    eye = [np.array([views[v]["eye"][k] for k in "xyz"]) for v in ("Camera view", "Free view")]
    assert np.linalg.norm(eye[0]) == pytest.approx(np.linalg.norm(eye[1]))
    assert np.degrees(np.arccos(eye[0] @ eye[1] / (eye[0] @ eye[0]))) > 30.0


def test_viewer_axes_follow_the_hand(poses):
    """Every frame's axes are a cube of one side that holds that frame's hand; the hand
    sweeping 400 mm sideways, the cube is smaller than the span and moves with it."""
    from tests.export_readers import plotly_page

    hand = HandModel()
    moved = poses.copy()
    moved[:, 0] += np.linspace(0.0, 400.0, len(poses))  # mm along x
    joints = np.stack([hand.joints(x) for x in moved])
    _, _, frames = plotly_page(viewer_html(joints, rig=Rig.default()))
    ranges = np.array([[f["layout"]["scene"][f"{k}axis"]["range"] for k in "xyz"]
                       for f in frames])  # fmt: skip  # (T, 3, 2)
    sides = ranges[:, :, 1] - ranges[:, :, 0]
    np.testing.assert_allclose(sides, sides[0, 0], atol=0.02)
    assert (joints >= ranges[:, None, :, 0]).all() and (joints <= ranges[:, None, :, 1]).all()
    assert sides[0, 0] < 0.7 * np.ptp(joints[..., 0])
    assert np.ptp(ranges[:, 0, 0]) > 350.0  # it moved along


def test_viewer_frames_are_embedded_as_small_jpegs(poses):
    """The frames beside the scene: JPEG at most 320 pixels wide, the given image (to a
    few grey levels), one per frame on the slider."""
    import base64

    import cv2

    from tests.export_readers import plotly_page

    hand = HandModel()
    joints = np.stack([hand.joints(x) for x in poses[:3]])
    ramp = np.linspace(0, 255, 640).astype(np.uint8)
    images = [np.dstack([np.tile(ramp, (480, 1)), np.full((480, 640), 40 * t, np.uint8),
                         np.tile(ramp[::-1], (480, 1))]) for t in range(3)]  # fmt: skip
    data, _, frames = plotly_page(viewer_html(joints, images=images))
    for t, frame in enumerate(frames):
        source = _animated(data, frame)["frame"]["source"]
        head, body = source.split(",", 1)
        assert head == "data:image/jpeg;base64"
        bgr = cv2.imdecode(np.frombuffer(base64.b64decode(body), np.uint8), cv2.IMREAD_COLOR)
        assert bgr.shape == (240, 320, 3)
        want = cv2.resize(images[t], (320, 240), interpolation=cv2.INTER_AREA)
        assert np.abs(bgr[:, :, ::-1].astype(int) - want).mean() < 3.0
    with pytest.raises(ValueError, match=r"^images: expected one frame per frame of the track"):
        viewer_html(joints, images=images[:2])


def test_viewer_page_keeps_any_title_as_text(poses):
    """The slashes of the figure's JSON are written plainly; a title with a closing
    script tag, a slash and an escape's text stays text."""
    from tests.export_readers import plotly_page

    joints = np.stack([HandModel().joints(x) for x in poses[:2]])
    title = "a/b </script><b>x</b> \\u002f \\\\u002f"
    text = viewer_html(joints, title=title)
    _, layout, _ = plotly_page(text)
    assert layout["title"]["text"] == title
    figure = text.split('<div id="', 1)[1]  # after plotly.js
    assert "\\u002f" not in figure.replace(r"\\u002f", "") and "</script><b>" not in text
    assert "<title>a/b &lt;/script&gt;&lt;b&gt;x&lt;/b&gt;" in text


def test_viewer_labels_its_curves(poses):
    """One curve per quality given, its axis titled by its label; a second on an axis of
    its own."""
    from tests.export_readers import plotly_page

    joints = np.stack([HandModel().joints(x) for x in poses[:4]])
    error = np.array([0.05, np.nan, 0.1, 0.07])
    one = {"keypoint error (hand sizes)": error}
    data, layout, _ = plotly_page(viewer_html(joints, quality=one))
    (curve,) = [d for d in data if d["name"] == "keypoint error (hand sizes)"]
    assert curve["y"] == [0.05, None, 0.1, 0.07]
    assert layout["yaxis"]["title"]["text"] == "keypoint error (hand sizes)"
    assert layout["yaxis"]["range"] == pytest.approx([0.0, 0.11])
    both = {"silhouette IoU": np.full(4, 0.8), "keypoint error (hand sizes)": error}
    _, layout, _ = plotly_page(viewer_html(joints, quality=both))
    assert layout["yaxis"]["title"]["text"] == "silhouette IoU"
    assert layout["yaxis"]["range"] == [0.0, 1.0]
    assert layout["yaxis3"]["title"]["text"] == "keypoint error (hand sizes)"


def test_a_pose_nan_in_part_or_infinite_is_refused(gappy):
    shape = HandShape.from_size(185.0)
    hand, rig = HandModel(shape), Rig.default()
    exporters = [
        lambda p: keypoint_frames(p, hand, rig),
        lambda p: openpose_frames(p, hand, rig),
        lambda p: bvh_text(p, shape),
        lambda p: glb_bytes(p, shape),
    ]
    part, inf = gappy.copy(), gappy.copy()
    part[3, 7] = np.nan
    inf[6, 0] = np.inf
    for export in exporters:
        with pytest.raises(ValueError, match=r"^poses: .*NaN in part of frame 3$"):
            export(part)
        with pytest.raises(ValueError, match=r"^poses: .*infinity in frame 6$"):
            export(inf)
    joints = np.stack([hand.joints(x) for x in gappy[[2, 3]]])
    joints[1, 4, 2] = np.nan
    with pytest.raises(ValueError, match=r"^joints: .*NaN in part of frame 1$"):
        viewer_html(joints)
    with pytest.raises(ValueError, match=r"^confidence: expected finite values"):
        keypoint_frames(gappy, hand, rig, confidence=np.full(8, np.nan))


def test_bvh_and_gltf_refuse_a_track_without_a_hand():
    shape = HandShape.from_size(185.0)
    nothing = np.full((3, 26), np.nan)
    for export in (bvh_text, glb_bytes):
        with pytest.raises(ValueError, match=r"^poses: expected a hand on at least one frame"):
            export(nothing, shape)
    doc = keypoint_frames(nothing, HandModel(shape), Rig.default())  # no points: fine
    assert [f["world"] for f in doc["frames"]] == [None] * 3
