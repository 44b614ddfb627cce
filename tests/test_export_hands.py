"""Both hands in one file: `handvar export` and `handvar view` on a two-hand directory.

The directory is written by `HandsTrack.save` (as ``handvar track --hands 2 --out``
does) from two synthetic tracks: a right hand and a left hand of the benchmark's poses,
120 mm right and left of it, the left one away on some frames and neither on one. The
files are read back by independent readers: `json`; pose-format's OpenPose reader; bvhio
(which takes one ROOT: the file is cut into one text per root by `bvh_roots`); pygltflib
with the specification's skinning (`tests/export_readers.py`); the Khronos validator;
Blender's own importers; headless Chromium. Each hand is compared with its own track:
its G(x), its mesh, its one-hand export.
"""

from __future__ import annotations

import json
import re
import subprocess
from pathlib import Path

import numpy as np
import pytest
from click.testing import CliRunner

from handvar.camera import Rig
from handvar.cli import main
from handvar.export.bvh import bvh_joint_order
from handvar.export.gltf import mesh_vertices
from handvar.export.keypoints import openpose_name
from handvar.hand.anthropometry import HandShape
from handvar.hand.kinematics import HandModel
from handvar.synth.sequences import sequence_poses
from tests.export_readers import (
    bvh_roots,
    bvh_world_joints,
    gltf_skinned_vertices,
    plotly_array,
    plotly_page,
)
from tests.test_export import _chromium, _gltf_validator

T = 6
#: Frames without each hand: the left hand away on 1, 4 and 5, neither there on 4.
ABSENT = {"right": [4], "left": [1, 4, 5]}
#: The frame each one shows in BVH and glTF (the last tracked one; the first before it).
HELD = {"right": [0, 1, 2, 3, 3, 5], "left": [0, 0, 2, 3, 3, 3]}
SHIFT = {"right": 120.0, "left": -120.0}  # mm along x
LENGTH = {"right": 185.0, "left": 170.0}
#: Colours of the sides (`handvar.pipeline.SIDE_RGB`), written out to check the page by.
ORANGE, LIGHT_BLUE = (255, 150, 40), (60, 200, 255)


def _track(side: str, rig: Rig):
    """A `Track` of `side` over the first T benchmark poses, moved along x, away on the
    frames `ABSENT[side]` (poses and joints NaN, as the tracker writes them)."""
    from handvar.pipeline import Track
    from handvar.tracking.tracker import TrackResult

    shape = HandShape.from_size(LENGTH[side], side=side)
    hand = HandModel(shape)
    poses = sequence_poses("benchmark")[:T].copy()
    poses[:, 0] += SHIFT[side]
    joints = np.stack([hand.joints(x) for x in poses])
    projected = np.stack([c.project(joints.reshape(-1, 3)).reshape(T, 21, 2) for c in rig])
    poses[ABSENT[side]], joints[ABSENT[side]] = np.nan, np.nan
    projected[:, ABSENT[side]] = np.nan
    result = TrackResult(
        poses=poses, joints=joints, starts=poses, costs=np.zeros((T, 1)),
        iterations=np.ones(T, dtype=int), seconds=np.zeros((T, 3)),
        iou=np.full((T, len(rig)), 0.9), cost=np.zeros(T), keypoint_error=np.full(T, np.nan),
        lost=np.zeros(T, dtype=bool), empty=np.zeros((T, len(rig)), dtype=bool),
    )  # fmt: skip
    return Track(poses=poses, joints=joints, projected=projected, quality=None, rig=rig,
                 shape=shape, name="two-hands", predictor="rvar", seed=0, fps=25.0,
                 result=result, options={})  # fmt: skip


@pytest.fixture(scope="module")
def hands_dir(tmp_path_factory) -> Path:
    """The two-hand directory (hands.json, right/, left/), no overlay video."""
    from handvar.pipeline import HandsTrack

    rig = Rig.default()
    root = tmp_path_factory.mktemp("hands") / "two"
    tracks = {0: _track("right", rig), 1: _track("left", rig)}
    HandsTrack(tracks=tracks, name="two-hands", fps=25.0, seconds=np.zeros(T)).save(
        root, video=False
    )
    return root


def _run(*args: str):
    return CliRunner().invoke(main, [str(a) for a in args], catch_exceptions=False)


def _poses(hands_dir: Path, side: str) -> np.ndarray:
    return np.load(hands_dir / side / "track.npz")["poses"]


def _joints(side: str, poses: np.ndarray) -> np.ndarray:
    """G(x) of each frame (NaN where the pose is), mm."""
    hand = HandModel(HandShape.from_size(LENGTH[side], side=side))
    return np.stack([hand.joints(x) if np.isfinite(x).all() else np.full((21, 3), np.nan)
                     for x in poses])  # fmt: skip


def test_json_lists_each_hand_as_its_one_hand_document(hands_dir, tmp_path):
    """The shared joints, units and cameras at the top; under "hands" each hand's id,
    side and frames, the frames exactly those of the hand's own one-hand export."""
    res = _run("export", hands_dir, "--format", "json", "--out", tmp_path / "k.json")
    assert res.exit_code == 0, res.output
    assert (
        "6 frames, right hand (1 frames without it), left hand (3 frames without it)" in res.output
    )
    doc = json.loads((tmp_path / "k.json").read_text())
    assert doc["format"] == "handvar-keypoints-hands" and doc["version"] == 1
    assert [(h["id"], h["side"]) for h in doc["hands"]] == [(0, "right"), (1, "left")]
    for h in doc["hands"]:
        side = h["side"]
        res = _run("export", hands_dir / side, "--format", "json", "--out", tmp_path / "one.json")
        assert res.exit_code == 0, res.output
        one = json.loads((tmp_path / "one.json").read_text())
        assert one["hand"] == side
        assert {k: one[k] for k in ("joints", "units", "cameras")} == {
            k: doc[k] for k in ("joints", "units", "cameras")}  # fmt: skip
        assert h["frames"] == one["frames"]
        want = _joints(side, _poses(hands_dir, side))
        for t, frame in enumerate(h["frames"]):
            if t in ABSENT[side]:
                assert frame["world"] is None and frame["views"] == []
            else:
                np.testing.assert_allclose(frame["world"], want[t], atol=1e-3)


def test_openpose_holds_both_hands_in_one_person(hands_dir, tmp_path):
    """One person per frame, each hand in its side's lists (pixels of that camera, world
    mm in 3D), zeros for the hand away, ``"people": []`` on the frame without either."""
    res = _run("export", hands_dir, "--format", "openpose", "--out", tmp_path / "op")
    assert res.exit_code == 0, res.output
    rig = Rig.default()
    want = {side: _joints(side, _poses(hands_dir, side)) for side in ABSENT}
    for j, camera in enumerate(rig.cameras):
        for t in range(T):
            name = openpose_name(rig.names[j], t)
            data = json.loads((tmp_path / "op" / rig.names[j] / name).read_text())
            if t == 4:
                assert data == {"version": 1.3, "people": []}
                continue
            (person,) = data["people"]
            assert not any(person["pose_keypoints_2d"]) and not any(person["face_keypoints_2d"])
            for side in ABSENT:
                kp2 = np.array(person[f"hand_{side}_keypoints_2d"]).reshape(21, 3)
                kp3 = np.array(person[f"hand_{side}_keypoints_3d"]).reshape(21, 4)
                if t in ABSENT[side]:
                    assert not kp2.any() and not kp3.any()
                    continue
                uv = camera.project(want[side][t])
                found = kp2[:, 2] > 0
                assert found.sum() >= 15
                np.testing.assert_allclose(kp2[found, :2], uv[found], atol=1e-3)
                np.testing.assert_allclose(kp3[:, :3], want[side][t], atol=1e-3)
                assert (kp3[:, 3] == 1.0).all()


def test_openpose_folder_of_both_hands_loads_in_pose_format(hands_dir, tmp_path):
    """pose-format's OpenPose reader finds each hand in its own component, on the frames
    it is there, and nothing on the others."""
    why = "pose-format is not installed (pip install pose-format)"
    openpose = pytest.importorskip("pose_format.utils.openpose", reason=why)
    rig = Rig.default()
    camera = rig.cameras[0]
    one = Rig([camera], (rig.names[0],))
    one.save(tmp_path / "cam0.yml")
    res = _run("export", hands_dir, "--format", "openpose", "--out", tmp_path / "op",
               "--calib", tmp_path / "cam0.yml")  # fmt: skip
    assert res.exit_code == 0, res.output
    width, height = camera.size
    pose = openpose.load_openpose_directory(str(tmp_path / "op"), fps=25.0, width=width,
                                            height=height)  # fmt: skip
    assert pose.body.data.shape == (T, 1, 25 + 70 + 21 + 21, 2)
    for side in ABSENT:
        got = pose.get_components([f"hand_{side}_keypoints_2d"]).body
        joints = _joints(side, _poses(hands_dir, side))
        for t in range(T):
            score = np.asarray(got.confidence[t, 0])
            if t in ABSENT[side]:
                assert not score.any() and got.data[t, 0].mask.all()
                continue
            found = score > 0
            assert found.sum() >= 15
            uv = camera.project(joints[t])
            np.testing.assert_allclose(got.data[t, 0][found], uv[found], atol=1e-3)


def test_bvh_has_one_root_per_hand_read_back_by_bvhio(hands_dir, tmp_path):
    """Two ROOTs, every joint name prefixed by its side and unique; each root's part,
    read by bvhio, is that hand's G(x) in the file's axes (y up, metres), holding the
    last tracked pose on the frames the hand is away."""
    res = _run("export", hands_dir, "--format", "bvh", "--out", tmp_path / "t.bvh")
    assert res.exit_code == 0, res.output
    text = (tmp_path / "t.bvh").read_text()
    assert re.findall(r"^ROOT (\S+)$", text, re.M) == ["right_forearm", "left_forearm"]
    names = re.findall(r"^\s*(?:ROOT|JOINT) (\S+)$", text, re.M)
    assert len(names) == len(set(names)) == 2 * 21
    assert "Frame Time: 0.04000000" in text and f"Frames: {T}" in text
    for side, part in zip(("right", "left"), bvh_roots(text), strict=True):
        (tmp_path / f"{side}.bvh").write_text(part)
        got = bvh_world_joints(tmp_path / f"{side}.bvh", bvh_joint_order(f"{side}_"))
        held = _joints(side, _poses(hands_dir, side)[HELD[side]])
        assert np.abs(got - held * [1.0, -1.0, -1.0] / 1000.0).max() <= 1e-6


def test_gltf_has_two_skinned_hands_in_one_animation(hands_dir, tmp_path):
    """Two meshes, two skins, two node hierarchies named by side, one animation with the
    channels of both; each mesh skinned by the specification's formula is its hand's
    mesh where the hand is, collapsed to its held wrist where it is away."""
    import pygltflib

    res = _run("export", hands_dir, "--format", "gltf", "--out", tmp_path / "t.glb")
    assert res.exit_code == 0, res.output
    gltf = pygltflib.GLTF2().load(str(tmp_path / "t.glb"))
    assert [m.name for m in gltf.meshes] == ["right_hand", "left_hand"]
    assert [s.name for s in gltf.skins] == ["right_hand", "left_hand"]
    assert len(gltf.animations) == 1
    roots = gltf.scenes[0].nodes
    assert [gltf.nodes[i].name for i in roots] == ["right_palm", "right_hand_mesh",
                                                   "left_palm", "left_hand_mesh"]  # fmt: skip
    for skin, side in zip(gltf.skins, ("right", "left"), strict=True):
        assert all(gltf.nodes[j].name.startswith(f"{side}_") for j in skin.joints)
    targets = {gltf.nodes[c.target.node].name.split("_")[0]
               for c in gltf.animations[0].channels}  # fmt: skip
    assert targets == {"right", "left"}
    for k, side in enumerate(("right", "left")):
        poses = _poses(hands_dir, side)
        shape = HandShape.from_size(LENGTH[side], side=side)
        got = gltf_skinned_vertices(tmp_path / "t.glb", range(T), mesh=k)
        held = poses[HELD[side]]
        want = mesh_vertices(shape, held) * [1.0, -1.0, -1.0] / 1000.0
        for t in range(T):
            if t in ABSENT[side]:  # hidden: every vertex at the held pose's wrist
                wrist = held[t, :3] * [1.0, -1.0, -1.0] / 1000.0
                assert np.abs(got[t] - wrist).max() <= 1e-7
            else:
                assert np.abs(got[t] - want[t]).max() <= 1e-6


@pytest.mark.skipif(_gltf_validator() is None, reason="the Khronos glTF validator is not "
                    "installed (npm install -g gltf-validator)")  # fmt: skip
def test_two_hand_gltf_passes_the_khronos_validator(hands_dir, tmp_path):
    import os

    node, root = _gltf_validator()
    res = _run("export", hands_dir, "--format", "gltf", "--out", tmp_path / "t.glb")
    assert res.exit_code == 0, res.output
    script = (
        "const v = require('gltf-validator'); const fs = require('fs');"
        "v.validateBytes(new Uint8Array(fs.readFileSync(process.argv[1])))"
        ".then(r => console.log(JSON.stringify(r.issues)))"
        ".catch(e => { console.error(String(e)); process.exit(1); });"
    )
    run = subprocess.run([node, "-e", script, str(tmp_path / "t.glb")], capture_output=True,
                         text=True, env={**os.environ, "NODE_PATH": root}, timeout=120)  # fmt: skip
    assert run.returncode == 0, run.stderr[-2000:]
    issues = json.loads(run.stdout)
    assert (issues["numErrors"], issues["numWarnings"]) == (0, 0), issues["messages"]


def test_one_hand_of_the_hands_layout_is_the_one_hand_openpose():
    """OpenPose's layout is the same for one hand: `hands_openpose_frames` of one hand
    is `openpose_frames` of it."""
    from handvar.export import TrackedHand, hands_openpose_frames, openpose_frames

    hand = HandModel(HandShape.from_size(170.0, side="left"))
    poses = sequence_poses("benchmark")[:4].copy()
    poses[1] = np.nan
    conf = np.array([0.9, 0.0, 0.5, 0.7])
    rig = Rig.default()
    one = openpose_frames(poses, hand, rig, confidence=conf)
    assert hands_openpose_frames([TrackedHand(poses, hand, confidence=conf)], rig) == one


def test_viewer_draws_each_hand_in_its_sides_colour(hands_dir, tmp_path):
    """A surface, bones and keypoints per hand, named by side, the surface and bones in
    the side's colour (the overlay's); nothing of a hand on the frames it is away."""
    res = _run("view", hands_dir, "--out", tmp_path / "v.html")
    assert res.exit_code == 0, res.output
    data, layout, frames = plotly_page((tmp_path / "v.html").read_text())
    by_name = {d.get("name"): i for i, d in enumerate(data)}
    rgb = {"right": "rgb({}, {}, {})".format(*ORANGE),
           "left": "rgb({}, {}, {})".format(*LIGHT_BLUE)}  # fmt: skip
    for side in ABSENT:
        surface, bones = data[by_name[f"{side} surface"]], data[by_name[f"{side} bones"]]
        assert surface["color"] == rgb[side]
        assert set(bones["line"]["color"]) == {rgb[side]}
        assert f"{side} keypoints" in by_name
    see_through = layout["updatemenus"][2]["buttons"][0]["args"][1]
    assert see_through == [by_name["right surface"], by_name["left surface"]]
    assert len(frames) == T
    for t, frame in enumerate(frames):
        for side in ABSENT:
            keypoints = plotly_array(frame["data"][by_name[f"{side} keypoints"]]["x"])
            assert np.isnan(keypoints).all() == (t in ABSENT[side])
            surface = frame["data"][by_name[f"{side} surface"]]
            assert surface["visible"] == (t not in ABSENT[side])


def _broken(hands_dir: Path, root: Path, what: str) -> Path:
    """A copy of the two-hand directory whose hands.json is `what` is wrong with."""
    import shutil

    bad = root / what
    shutil.copytree(hands_dir, bad)
    index = json.loads((bad / "hands.json").read_text())
    if what == "not_json":
        (bad / "hands.json").write_text("{not json")
        return bad
    if what == "missing_folder":
        index["hands"][1]["directory"] = "elsewhere"
    elif what == "no_list":
        index["hands"] = {"right": "right"}
    elif what == "wrong_side":
        index["hands"][1]["side"] = "right"
        index["hands"][1]["directory"] = "left"
    (bad / "hands.json").write_text(json.dumps(index))
    return bad


@pytest.mark.parametrize("what", ["not_json", "missing_folder", "no_list", "wrong_side"])
def test_a_broken_index_is_one_line_naming_it(hands_dir, tmp_path, what):
    bad = _broken(hands_dir, tmp_path, what)
    for args in (["export", bad, "--format", "json"], ["view", bad, "--no-frames"]):
        res = CliRunner().invoke(main, [str(a) for a in args])
        lines = res.output.strip().splitlines()
        assert res.exit_code == 2 and len(lines) == 1, res.output
        assert lines[0].startswith("handvar: error: ") and str(bad / "hands.json") in lines[0]
        assert "Traceback" not in res.output
    assert not (bad / "keypoints.json").exists() and not (bad / "view.html").exists()


@pytest.mark.slow
@pytest.mark.skipif(_chromium() is None, reason="headless Chromium is not installed "
                    "(apt-get install chromium)")  # fmt: skip
def test_two_hand_viewer_renders_in_headless_chromium(hands_dir, tmp_path):
    """The page shows both hands, the right one's orange and the left one's light blue,
    right of each other as the camera sees them; no console error."""
    import cv2

    res = _run("view", hands_dir, "--out", tmp_path / "v.html", "--no-frames")
    assert res.exit_code == 0, res.output
    common = [_chromium(), "--headless", "--no-sandbox", "--disable-gpu",
              "--disable-background-networking", "--window-size=1000,850",
              "--virtual-time-budget=5000"]  # fmt: skip
    shot = tmp_path / "shot.png"
    run = subprocess.run([*common, f"--screenshot={shot}", (tmp_path / "v.html").as_uri()],
                         capture_output=True, text=True, timeout=120)  # fmt: skip
    assert run.returncode == 0, run.stderr[-2000:]
    image = cv2.imread(str(shot))
    assert image is not None and image.std() > 10.0
    b, g, r = (image[:, :, i].astype(int) for i in range(3))
    orange = (r > 200) & (g > 110) & (g < 190) & (b < 110)
    blue = (b > 200) & (g > 150) & (r < 140)
    assert orange.sum() > 500 and blue.sum() > 500, (orange.sum(), blue.sum())
    # the right hand (x + 120 mm) is drawn right of the left hand (x − 120 mm)
    assert np.flatnonzero(orange.any(axis=0)).mean() > np.flatnonzero(blue.any(axis=0)).mean()


BLENDER_SCRIPT = r"""
import builtins, importlib.util, json, sys

import bpy

cfg = json.load(open(sys.argv[sys.argv.index("--") + 1]))
if importlib.util.find_spec("numpy") is None:  # the glTF importer imports numpy
    json.dump({"skip": "Blender's Python has no numpy, which its glTF importer needs"},
              open(cfg["out"], "w"))
    sys.exit(0)
# Debian's Blender 3.4 on Python 3.11 and NumPy 1.24: the two lines tests/test_blender.py
# mends (mode "rU", np.bool), mended the same way.
import numpy
import io_anim_bvh.import_bvh

if not hasattr(numpy, "bool"):
    numpy.bool = bool
io_anim_bvh.import_bvh.open = (
    lambda path, mode="r", *a, **k: builtins.open(path, mode.replace("U", ""), *a, **k))


def report(frame):
    scene = bpy.context.scene
    scene.frame_set(frame)
    out = []
    for arm in (o for o in scene.objects if o.type == "ARMATURE"):
        out.append({"name": arm.name,
                    "roots": sorted(b.name for b in arm.data.bones if b.parent is None),
                    "head": {b.name: list(arm.matrix_world @ b.head) for b in arm.pose.bones},
                    "tail": {b.name: list(arm.matrix_world @ b.tail) for b in arm.pose.bones},
                    "meshes": sorted(o.name for o in scene.objects
                                     if o.type == "MESH" and o.find_armature() is arm)})
    return out


result = {}
bpy.ops.wm.read_homefile(use_factory_startup=True)
bpy.ops.import_anim.bvh(filepath=cfg["bvh"])
result["bvh"] = report(1)  # BVH frame 0 on Blender frame 1
bpy.ops.wm.read_homefile(use_factory_startup=True)
bpy.ops.import_scene.gltf(filepath=cfg["glb"])
result["gltf"] = report(0)  # key 0 at 0 s
json.dump(result, open(cfg["out"], "w"))
"""


def _blender_points(pose: dict, side: str, *, bvh: bool) -> np.ndarray:
    """The 21 points of `JOINTS` of one hand read off Blender's bones (as
    tests/test_blender.py reads them): BVH: the forearm's tail, the digits' bones' heads
    and the distal bones' tails; glTF: the palm's head, the heads, the tips' heads."""
    from handvar.hand import BONES, DIGITS

    p = f"{side}_"
    points = [pose["tail"][p + "forearm"] if bvh else pose["head"][p + BONES[0]]]
    for k, digit in enumerate(DIGITS):
        bones = [p + b for b in BONES[1 + 3 * k : 4 + 3 * k]]
        points += [pose["head"][b] for b in bones]
        points.append(pose["tail"][bones[-1]] if bvh else pose["head"][f"{p}{digit}_tip"])
    return np.array(points)


@pytest.mark.skipif(
    __import__("shutil").which("blender") is None,
    reason="Blender is not installed (apt-get install blender python3-numpy)",
)
def test_blender_imports_both_hands(hands_dir, tmp_path):
    """Blender's BVH importer reads both ROOTs into one armature (two root bones, one
    per hand); its glTF importer too puts both skins' joints in one armature, and skins
    each hand's mesh by it. Every
    hand's joints are where the track has them (metres, Blender's z up) on the first
    frame, and each is a hand's size."""
    import shutil

    for fmt, name in (("bvh", "t.bvh"), ("gltf", "t.glb")):
        res = _run("export", hands_dir, "--format", fmt, "--out", tmp_path / name)
        assert res.exit_code == 0, res.output
    cfg = {"bvh": str(tmp_path / "t.bvh"), "glb": str(tmp_path / "t.glb"),
           "out": str(tmp_path / "blender.json")}  # fmt: skip
    (tmp_path / "cfg.json").write_text(json.dumps(cfg))
    (tmp_path / "script.py").write_text(BLENDER_SCRIPT)
    proc = subprocess.run(
        [shutil.which("blender"), "--background", "--factory-startup", "--python-exit-code",
         "1", "--python", str(tmp_path / "script.py"), "--", str(tmp_path / "cfg.json")],
        capture_output=True, text=True, timeout=120,
    )  # fmt: skip
    assert proc.returncode == 0, proc.stdout[-3000:] + proc.stderr[-3000:]
    report = json.loads((tmp_path / "blender.json").read_text())
    if "skip" in report:
        pytest.skip(report["skip"])
    (bvh,) = report["bvh"]
    assert bvh["roots"] == ["left_forearm", "right_forearm"]
    (gltf,) = report["gltf"]  # Blender puts both skins' joints in one armature too
    assert gltf["roots"] == ["left_palm", "right_palm"]
    assert [m.split(".")[0] for m in gltf["meshes"]] == ["left_hand_mesh", "right_hand_mesh"]
    for side in ABSENT:
        want = _joints(side, _poses(hands_dir, side))[0]
        want = np.column_stack([want[:, 0], want[:, 2], -want[:, 1]]) / 1000.0  # z up
        for seen, is_bvh in ((bvh, True), (gltf, False)):
            got = _blender_points(seen, side, bvh=is_bvh)
            assert np.abs(got - want).max() < 1e-3, (side, is_bvh)
            assert 0.12 < np.linalg.norm(got[12] - got[0]) < 0.25  # wrist to middle tip
