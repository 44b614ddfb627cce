"""The BVH and .glb exports opened in Blender by its own importers, at their defaults.

A 30-frame track of the example video (its MediaPipe keypoints given) is saved and
exported with `handvar export` at its defaults (BVH: metres, y up). Blender, started
from its factory settings in the background, imports each file as File › Import does
with nothing changed, and reports what a user sees: the armature's bones in world space
at some frames, the scene's frame range and rate, the animation's keys. The checks are
against the track itself: its skeleton's joints G(x) (mm, camera frame: x right, y
down, z forward; the track's reported points put the fingertips and the thumb's base
where a detector marks them, the skeleton at the bones' ends) turned into Blender's
metres and axes (z up, the camera looking along +y, as Blender's front view does) are
where the bones are.

Blender's importers at their defaults (Blender 3.4, io_anim_bvh and io_scene_gltf2):

- BVH: BVH frame i is keyed on Blender frame 1 + i ("Start Frame" 1, "Scale FPS" off);
  "Update Scene FPS" and "Update Scene Duration" are off, so the scene keeps its 24 fps
  and its frames 1-250: a 30 fps recording plays at 0.8 times its speed. With "Update
  Scene FPS" ticked the scene takes the file's rate; "Update Scene Duration" only ever
  lengthens the scene, so a short track leaves 1-250 as it is.
- glTF: key times in seconds become frames at the scene's rate (``fps``, not
  ``fps / fps_base``) from frame 0, and the scene's frame range is left alone: at the
  factory 24 fps key i of a 30 fps track is on frame 0.8 i (the motion at its real
  speed); with the scene set to 30 fps first, as docs/outputs.md says, on frame i.
"""

from __future__ import annotations

import json
import shutil
import subprocess

import numpy as np
import pytest
from click.testing import CliRunner

import handvar
from handvar.cli import main
from handvar.data import example_path
from handvar.hand import BONES, DIGITS, JOINTS, WRIST
from handvar.hand.anthropometry import HandLandmark

BLENDER = shutil.which("blender")
pytestmark = pytest.mark.skipif(
    BLENDER is None, reason="Blender is not installed (apt-get install blender python3-numpy)"
)
N_FRAMES = 30
#: Track frames whose bones are compared: the first, one in the middle, the last.
SAMPLED = (0, 15, N_FRAMES - 1)
#: Blender's factory scene (startup.blend): its frame rate and frame range.
FACTORY_FPS, FACTORY_RANGE = 24, (1, 250)
#: Bone positions against the track's joints, metres (float32 inside Blender).
TOL = 1e-3
#: The BVH's root joint (a forearm stub ending at the wrist; docs/outputs.md).
ROOT = "forearm"

# Runs inside Blender. Argument after "--": a JSON file {"bvh", "glb", "fps", "frames",
# "out"}; "frames" maps each case to the Blender frames to sample.
SCRIPT = r"""
import builtins, importlib.util, json, math, sys

import bpy

cfg = json.load(open(sys.argv[sys.argv.index("--") + 1]))
if importlib.util.find_spec("numpy") is None:  # the glTF importer imports numpy
    json.dump({"skip": "Blender's Python has no numpy, which its glTF importer needs "
               "(apt-get install python3-numpy)"}, open(cfg["out"], "w"))
    sys.exit(0)

# Debian 12's blender 3.4.1 runs on the system's Python 3.11 and numpy 1.24, not on the
# Python 3.10 and numpy 1.23 that Blender 3.4 is built with, and one line of each
# importer predates them: io_anim_bvh opens the file with mode "rU" (removed in Python
# 3.11) and io_scene_gltf2 asks for np.bool (removed in numpy 1.24). Both are restored
# to what they meant, so that the importers run as in Blender's own build; where they
# are not needed this changes nothing.
import numpy
import io_anim_bvh.import_bvh

if not hasattr(numpy, "bool"):
    numpy.bool = bool
io_anim_bvh.import_bvh.open = (
    lambda path, mode="r", *a, **k: builtins.open(path, mode.replace("U", ""), *a, **k))


def report(frames):
    scene = bpy.context.scene
    arms = [o for o in scene.objects if o.type == "ARMATURE"]
    out = {"frame_start": scene.frame_start, "frame_end": scene.frame_end,
           "fps": scene.render.fps, "fps_base": scene.render.fps_base,
           "armatures": len(arms), "objects": sorted(o.type for o in scene.objects)}
    arm = arms[0]
    out["bones"] = [b.name for b in arm.data.bones]
    fcurves = arm.animation_data.action.fcurves
    out["keys"] = sorted({round(k.co[0], 4) for c in fcurves for k in c.keyframe_points})
    out["keys_per_curve"] = sorted({len(c.keyframe_points) for c in fcurves})
    meshes = [o for o in scene.objects if o.type == "MESH" and o.find_armature() is arm]
    out["poses"] = []
    for f in frames:
        scene.frame_set(math.floor(f), subframe=f - math.floor(f))
        pose = {"frame": f,
                "head": {b.name: list(arm.matrix_world @ b.head) for b in arm.pose.bones},
                "tail": {b.name: list(arm.matrix_world @ b.tail) for b in arm.pose.bones}}
        for ob in meshes:  # the skinned mesh as drawn: its evaluated vertices' extent
            ev = ob.evaluated_get(bpy.context.evaluated_depsgraph_get())
            mesh = ev.to_mesh()
            v = [ev.matrix_world @ p.co for p in mesh.vertices]
            pose["mesh_min"] = [min(p[i] for p in v) for i in range(3)]
            pose["mesh_max"] = [max(p[i] for p in v) for i in range(3)]
            ev.to_mesh_clear()
        out["poses"].append(pose)
    return out


def fresh(fps=None):
    bpy.ops.wm.read_homefile(use_factory_startup=True)  # File > New, factory settings
    if fps is not None:  # Output Properties > Format > Frame Rate
        bpy.context.scene.render.fps, bpy.context.scene.render.fps_base = fps, 1.0


frames, result = cfg["frames"], {}
fresh()
bpy.ops.import_anim.bvh(filepath=cfg["bvh"])
result["bvh"] = report(frames["bvh"])
fresh()
bpy.ops.import_anim.bvh(filepath=cfg["bvh"], update_scene_fps=True,
                        update_scene_duration=True)
result["bvh_update_scene"] = report(frames["bvh"])
fresh()
bpy.ops.import_scene.gltf(filepath=cfg["glb"])
result["gltf"] = report(frames["gltf"])
result["gltf"]["scene_extras"] = {k: bpy.context.scene[k] for k in bpy.context.scene.keys()
                                  if isinstance(bpy.context.scene[k], (int, float, str))}
fresh(round(cfg["fps"]))
bpy.ops.import_scene.gltf(filepath=cfg["glb"])
result["gltf_at_fps"] = report(frames["gltf_at_fps"])
json.dump(result, open(cfg["out"], "w"))
"""


def blender_from_camera(points: np.ndarray) -> np.ndarray:
    """Camera-frame millimetres (x right, y down, z forward) in Blender's world metres.

    The y-up file holds ``(x, -y, -z)`` (docs/outputs.md: a turn of 180° about x; glTF's
    axes too) and Blender's importers take y up and -z forward to its z up and -y forward,
    ``(x, y, z) -> (x, -z, y)``: together ``(x, z, -y)``.
    """
    x, y, z = np.moveaxis(np.asarray(points, dtype=float) / 1000.0, -1, 0)
    return np.stack([x, z, -y], axis=-1)


def joints_from_bones(pose: dict, *, wrist: str, tip: str) -> np.ndarray:
    """The 21 points of `JOINTS` read off Blender's bones: `wrist` names the bone end at
    the wrist ("forearm.tail", "palm.head"); a digit's joints are the heads of its three
    bones (named as `BONES`), then its tip: the tail of the distal bone (``tip="tail"``)
    or the head of the bone ``<digit>_tip`` (``tip="node"``)."""
    name, end = wrist.split(".")
    points = [pose[end][name]]
    for k, digit in enumerate(DIGITS):
        bones = BONES[1 + 3 * k : 4 + 3 * k]
        points += [pose["head"][b] for b in bones]
        points.append(pose["tail"][bones[-1]] if tip == "tail" else pose["head"][f"{digit}_tip"])
    return np.array(points)


def palm_bones(pose: dict, joints: np.ndarray, tol: float = 2e-3) -> list[str]:
    """The digits whose base joint (CMC or MCP) is joined to the wrist by a bone: one with
    its head at the wrist and its tail at that joint, within `tol` metres."""
    heads, tails = pose["head"], pose["tail"]
    wrist = joints[WRIST]
    bases = [JOINTS.index(f"{d}_{'cmc' if d == 'thumb' else 'mcp'}") for d in DIGITS]
    return [digit for digit, base in zip(DIGITS, bases, strict=True)
            if any(np.linalg.norm(np.subtract(heads[b], wrist)) < tol
                   and np.linalg.norm(np.subtract(tails[b], joints[base])) < tol
                   for b in heads)]  # fmt: skip


def _glb_skin_joints(path) -> list[str]:
    """The names of the skin's joints in a .glb, from its JSON chunk (the glTF 2.0
    specification, section 4.4)."""
    data = path.read_bytes()
    length = int.from_bytes(data[12:16], "little")
    doc = json.loads(data[20 : 20 + length])
    return [doc["nodes"][j]["name"] for j in doc["skins"][0]["joints"]]


@pytest.fixture(scope="module")
def opened(tmp_path_factory):
    """The track, its exports, and what Blender made of them (the script's report)."""
    root = tmp_path_factory.mktemp("blender")
    track = handvar.track(example_path("video"), keypoints=example_path("video-keypoints"),
                          scale=0.5, frames=N_FRAMES)  # fmt: skip
    track.save(root / "track", video=False)
    for fmt in ("bvh", "gltf"):
        run = CliRunner().invoke(main, ["export", str(root / "track"), "--format", fmt])
        assert run.exit_code == 0, run.output
    fps = float(track.fps)
    frames = {"bvh": [1 + t for t in SAMPLED],  # BVH frame i on Blender frame 1 + i
              "gltf": [t / fps * FACTORY_FPS for t in SAMPLED],  # key i at i / fps s
              "gltf_at_fps": [float(t) for t in SAMPLED]}  # fmt: skip
    cfg = {"bvh": str(root / "track" / "track.bvh"), "glb": str(root / "track" / "track.glb"),
           "fps": fps, "frames": frames, "out": str(root / "blender.json")}  # fmt: skip
    (root / "cfg.json").write_text(json.dumps(cfg))
    (root / "script.py").write_text(SCRIPT)
    proc = subprocess.run(
        [BLENDER, "--background", "--factory-startup", "--python-exit-code", "1",
         "--python", str(root / "script.py"), "--", str(root / "cfg.json")],
        capture_output=True, text=True, timeout=120,
    )  # fmt: skip
    assert proc.returncode == 0, proc.stdout[-3000:] + proc.stderr[-3000:]
    report = json.loads((root / "blender.json").read_text())
    if "skip" in report:
        pytest.skip(report["skip"])
    return track, report, root / "track"


READERS = {  # case: how the 21 joints are read off its bones
    "bvh": {"wrist": f"{ROOT}.tail", "tip": "tail"},
    "bvh_update_scene": {"wrist": f"{ROOT}.tail", "tip": "tail"},
    "gltf": {"wrist": f"{BONES[0]}.head", "tip": "node"},
    "gltf_at_fps": {"wrist": f"{BONES[0]}.head", "tip": "node"},
}


@pytest.mark.parametrize("case", READERS)
def test_bones_are_the_tracks_joints(opened, case):
    """At the sampled frames every joint is where the track's skeleton has it, in metres,
    z up."""
    track, report, _ = opened
    seen = report[case]
    assert seen["armatures"] == 1
    for t, pose in zip(SAMPLED, seen["poses"], strict=True):
        got = joints_from_bones(pose, **READERS[case])
        want = blender_from_camera(track.hand.joints(track.poses[t]))
        err = np.linalg.norm(got - want, axis=1)
        assert err.max() < TOL, (case, t, JOINTS[int(err.argmax())], err.max())


@pytest.mark.parametrize("case", ["bvh", "gltf"])
def test_the_hand_stands_upright_at_its_size(opened, case):
    """On the first frame (the example's hand points up in the video) the middle
    fingertip is above the wrist in Blender's z, and the wrist-to-tip distance is a
    hand's, 0.15-0.25 m; the track's own joints, turned into Blender's axes, agree."""
    track, report, _ = opened
    pose = report[case]["poses"][0]
    got = joints_from_bones(pose, **READERS[case])
    want = blender_from_camera(track.hand.joints(track.poses[SAMPLED[0]]))
    tip, wrist = HandLandmark.MIDDLE_FINGER_TIP, WRIST
    for joints in (got, want):
        reach = joints[tip] - joints[wrist]
        assert 0.15 < np.linalg.norm(reach) < 0.25, np.linalg.norm(reach)
        # upright: within 45° of Blender's +z (the track's first frame: 39°)
        assert reach[2] > np.cos(np.radians(45)) * np.linalg.norm(reach), reach
    if "mesh_min" in pose:  # glTF: the skinned mesh is around the joints, a hand's size
        lo, hi = np.array(pose["mesh_min"]), np.array(pose["mesh_max"])
        assert np.all(got > lo - 1e-3) and np.all(got < hi + 1e-3)
        assert 0.15 < np.linalg.norm(hi - lo) < 0.35, hi - lo
        assert hi[2] > got[tip][2] and lo[2] < got[wrist][2]


def test_bvh_skeleton_has_a_palm(opened):
    """The BVH's joints (docs/outputs.md) are Blender's bones, one from the wrist to each
    digit's base joint among them, so that Blender draws a palm; no bone is a stub."""
    track, report, _ = opened
    seen = report["bvh"]
    wrist_joints = ["thumb_carpal"] + [f"{d}_metacarpal" for d in DIGITS[1:]]
    assert sorted(seen["bones"]) == sorted([ROOT, *wrist_joints, *BONES[1:]])
    for t, pose in zip(SAMPLED, seen["poses"], strict=True):
        joints = blender_from_camera(track.hand.joints(track.poses[t]))
        assert palm_bones(pose, joints) == list(DIGITS)
        lengths = [np.linalg.norm(np.subtract(pose["tail"][b], pose["head"][b]))
                   for b in seen["bones"]]  # fmt: skip
        assert min(lengths) > 5e-3, dict(zip(seen["bones"], lengths, strict=True))


def test_gltf_bones_are_the_skins_joints(opened):
    """Blender makes a bone of every joint of the .glb's skin (bones, tips, helpers) and
    skins the mesh by them."""
    _, report, track_dir = opened
    seen = report["gltf"]
    assert sorted(seen["bones"]) == sorted(_glb_skin_joints(track_dir / "track.glb"))
    assert seen["objects"].count("MESH") == 2  # the hand and the factory scene's cube
    assert "mesh_min" in seen["poses"][0]


def test_bvh_frames_at_defaults(opened):
    """BVH frame i on Blender frame 1 + i, every frame of the track; the scene keeps the
    factory 24 fps and 1-250 unless "Update Scene FPS" is ticked, which sets the
    recording's rate ("Update Scene Duration" never shortens the scene)."""
    track, report, _ = opened
    n = len(track.poses)
    for case in ("bvh", "bvh_update_scene"):
        seen = report[case]
        assert seen["keys"] == [float(1 + i) for i in range(n)]
        assert seen["keys_per_curve"] == [n]
        assert (seen["frame_start"], seen["frame_end"]) == FACTORY_RANGE
    assert report["bvh"]["fps"] == FACTORY_FPS
    rate = report["bvh_update_scene"]["fps"] / report["bvh_update_scene"]["fps_base"]
    assert rate == pytest.approx(track.fps, rel=1e-6)


def test_gltf_frames_at_the_scene_rate(opened):
    """A key per track frame, at i / fps seconds: on frame 0.8 i in the factory 24 fps
    scene, on frame i once the scene's rate is the recording's; the importer leaves the
    scene's range at 1-250 and keeps the file's fps as the scene's custom property."""
    track, report, _ = opened
    n, fps = len(track.poses), float(track.fps)
    default, matched = report["gltf"], report["gltf_at_fps"]
    assert default["keys_per_curve"] == matched["keys_per_curve"] == [n]
    np.testing.assert_allclose(default["keys"], np.arange(n) * FACTORY_FPS / fps, atol=1e-3)
    np.testing.assert_allclose(matched["keys"], np.arange(n), atol=1e-3)
    assert default["fps"] == FACTORY_FPS and matched["fps"] == round(fps)
    for seen in (default, matched):
        assert (seen["frame_start"], seen["frame_end"]) == FACTORY_RANGE
    assert default["scene_extras"]["fps"] == pytest.approx(fps)
