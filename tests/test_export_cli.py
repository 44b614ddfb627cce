"""`handvar export` and `handvar view` on a saved track, and their bad inputs.

A track directory is written by `Track.save` (as `handvar track --out` does) from a
short synthetic sequence and its true poses, without its cameras (they are given by
``--calib``), or with them; the exports are read back with the standard `json` module,
bvhio and pygltflib. Every bad input gives one line on standard error, exit status 2,
and leaves what existed byte-identical.
"""

from __future__ import annotations

import json
import os
from pathlib import Path

import numpy as np
import pytest
from click.testing import CliRunner

from handvar.camera import Rig
from handvar.cli import main
from handvar.export.bvh import bvh_joint_order
from handvar.hand.anthropometry import HandShape
from handvar.hand.kinematics import HandModel
from tests.export_readers import bvh_world_joints, gltf_skinned_vertices

KNOWN = b"known bytes that must survive\n"


def _saved_track(root: Path, side: str, length: float = 175.0, *, cameras=False, absent=(),
                 quality=None, detections=None, options=None) -> Path:  # fmt: skip
    """A 4-frame synthetic track saved in `root`; no hand (poses and joints NaN) on the
    frames `absent`, as the tracker writes a frame where it found none; `quality`,
    `detections` and `options` as `handvar.Track` holds them."""
    from handvar.pipeline import Track
    from handvar.synth.sequences import make_sequence
    from handvar.tracking.tracker import TrackResult

    hand = HandModel(HandShape.from_size(length, side=side))
    seq = make_sequence("benchmark", n_frames=4, hand=hand)
    poses, joints = seq.truth.poses.copy(), seq.truth.joints.copy()
    n, n_cams = len(poses), len(seq.rig)
    projected = np.stack([c.project(joints.reshape(-1, 3)).reshape(n, 21, 2) for c in seq.rig])
    poses[list(absent)], joints[list(absent)], projected[:, list(absent)] = np.nan, np.nan, np.nan
    result = TrackResult(
        poses=poses, joints=joints, starts=poses, costs=np.zeros((n, 1)),
        iterations=np.ones(n, dtype=int), seconds=np.zeros((n, 3)),
        iou=np.full((n, n_cams), 0.9), cost=np.zeros(n), keypoint_error=np.full(n, np.nan),
        lost=np.array([False, False, True, False]), empty=np.zeros((n, n_cams), dtype=bool),
    )  # fmt: skip
    rig = seq.rig if cameras else None
    track = Track(
        poses=poses, joints=joints, projected=projected if cameras else projected[:0],
        quality=quality, rig=rig, shape=hand.shape, name=f"benchmark-{side}", predictor="rvar",
        seed=0, fps=seq.fps, result=result, detections=detections, options=options or {},
    )  # fmt: skip
    out = root / (f"track_{side}" + ("_cameras" if cameras else "") + "_absent" * bool(absent)
                  + "_quality" * (quality is not None))  # fmt: skip
    track.save(out, video=False, overlays=False)
    seq.rig.save(root / "rig.yml")
    return out


@pytest.fixture(scope="module")
def tracks(tmp_path_factory) -> dict[str, Path]:
    root = tmp_path_factory.mktemp("tracks")
    return {side: _saved_track(root, side) for side in ("right", "left")}


def _run(*args: str):
    return CliRunner().invoke(main, list(args), catch_exceptions=False)


@pytest.mark.parametrize("side", ["right", "left"])
def test_export_every_format_reads_back(tracks, side, tmp_path):
    track = tracks[side]
    rig = str(track.parent / "rig.yml")
    poses = np.load(track / "track.npz")["poses"]
    shape = HandShape.from_size(175.0, side=side)
    hand = HandModel(shape)

    res = _run("export", str(track), "--format", "json", "--out", str(tmp_path / "k.json"),
               "--calib", rig)  # fmt: skip
    assert res.exit_code == 0, res.output
    doc = json.loads((tmp_path / "k.json").read_text())
    assert doc["hand"] == side and len(doc["frames"]) == len(poses)
    for t, frame in enumerate(doc["frames"]):
        np.testing.assert_allclose(frame["world"], hand.joints(poses[t]), atol=1e-3)
        assert frame["confidence"] == pytest.approx(0.0 if t == 2 else 0.9)
        assert len(frame["views"]) == 2

    res = _run("export", str(track), "--format", "openpose", "--out", str(tmp_path / "op"),
               "--calib", rig)  # fmt: skip
    assert res.exit_code == 0, res.output
    folders = sorted(os.listdir(tmp_path / "op"))  # one per camera
    assert folders == sorted(Rig.load(rig).names)
    files = sorted((tmp_path / "op" / folders[0]).iterdir())
    assert len(files) == len(poses)
    person = json.loads(files[0].read_text())["people"][0]
    assert len(person[f"hand_{side}_keypoints_2d"]) == 63

    res = _run("export", str(track), "--format", "bvh", "--out", str(tmp_path / "t.bvh"))
    assert res.exit_code == 0, res.output
    got = bvh_world_joints(tmp_path / "t.bvh", bvh_joint_order())  # metres, y up
    want = np.stack([hand.joints(x) for x in poses]) * [1.0, -1.0, -1.0] / 1000.0
    assert np.abs(got - want).max() <= 1e-6
    assert "Frame Time: 0.04000000" in (tmp_path / "t.bvh").read_text()  # 25 fps
    res = _run("export", str(track), "--format", "bvh", "--out", str(tmp_path / "z.bvh"),
               "--units", "mm", "--up", "z")  # fmt: skip
    assert res.exit_code == 0, res.output
    got = bvh_world_joints(tmp_path / "z.bvh", bvh_joint_order())  # mm, z up: x, z, -y
    want = np.stack([hand.joints(x) for x in poses])[..., [0, 2, 1]] * [1.0, 1.0, -1.0]
    assert np.abs(got - want).max() <= 1e-3

    res = _run("export", str(track), "--format", "gltf")  # default: into the track
    assert res.exit_code == 0, res.output
    from handvar.export.gltf import mesh_vertices

    got = gltf_skinned_vertices(track / "track.glb", [0, 3])  # metres, y up
    want = mesh_vertices(shape, poses[[0, 3]]) * [1.0, -1.0, -1.0] / 1000.0
    assert max(np.abs(got[f] - want[i]).max() for i, f in enumerate([0, 3])) <= 1e-6
    import pygltflib

    assert pygltflib.GLTF2().load(str(track / "track.glb")).asset.extras["fps"] == 25.0

    res = _run("view", str(track), "--out", str(tmp_path / "v.html"), "--calib", rig)
    assert res.exit_code == 0, res.output
    assert (tmp_path / "v.html").read_text().count("Plotly.newPlot") == 1


def test_point_confidences_come_from_the_tracks_quality(tmp_path):
    """The per-point scores of both keypoint files: the frame's IoU (0 when lost) times 1
    for a kept keypoint near the fit, 0.25 for a rejected one, 0.5 more on a frame whose
    keypoints were carried, 1 without keypoints; halved where the hand hides the point
    (docs/outputs.md; by hand here)."""
    from handvar.export import joint_visibility
    from handvar.tracking.recovery import TrackQuality

    n = 4
    d = np.full((n, 2, 21), 0.05)  # hand sizes: every keypoint near the fit
    d[0, :, 5] = np.nan  # frame 0: the index MCP rejected in both cameras
    d[3] = np.nan  # frame 3: no keypoints
    quality = TrackQuality(
        iou=np.full(n, 0.9), keypoint_error=np.zeros(n), cost=np.zeros(n),
        lost=np.array([False, False, True, False]), reinit=np.zeros(n, bool),
        empty=np.zeros(n, bool), keypoints=np.array([True, True, True, False]),
        rejected=np.array([2, 0, 0, 0]), distances=d,
    )  # fmt: skip
    detections = np.array([True, False, True, False])  # frame 1 carried
    track = _saved_track(tmp_path, "right", cameras=True, quality=quality,
                         detections=detections)  # fmt: skip
    res = _run("export", str(track), "--format", "openpose", "--out", str(tmp_path / "op"))
    assert res.exit_code == 0, res.output
    res = _run("export", str(track), "--format", "json", "--out", str(tmp_path / "k.json"))
    assert res.exit_code == 0, res.output
    doc = json.loads((tmp_path / "k.json").read_text())
    rig = Rig.load(track / "cameras.yml")
    poses = np.load(track / "track.npz")["poses"]
    hand = HandModel(HandShape.from_size(175.0))
    support = np.ones((n, 21))
    support[0, 5] = 0.25
    support[1] = 0.5
    frame_conf = [0.9, 0.9, 0.0, 0.9]  # the tracker's IoU, 0 on the lost frame
    for c, (name, camera) in enumerate(zip(rig.names, rig.cameras, strict=True)):
        for t in range(n):
            hidden = ~joint_visibility(hand, poses[t], camera)
            want = frame_conf[t] * support[t] * np.where(hidden, 0.5, 1.0)
            data = json.loads((tmp_path / "op" / name / f"{name}_{t:012d}_keypoints.json")
                              .read_text())  # fmt: skip
            kp = np.array(data["people"][0]["hand_right_keypoints_2d"]).reshape(21, 3)
            np.testing.assert_allclose(kp[:, 2], want, atol=1e-4)
            np.testing.assert_allclose(doc["frames"][t]["views"][c]["scores"], want, atol=1e-4)


def test_the_stored_cameras_are_used_and_calib_overrides_them(tmp_path):
    track = _saved_track(tmp_path, "left", cameras=True)
    stored = Rig.load(track / "cameras.yml")
    hand = HandModel(HandShape.from_size(175.0, side="left"))
    poses = np.load(track / "track.npz")["poses"]
    res = _run("export", str(track), "--format", "json", "--out", str(tmp_path / "k.json"))
    assert res.exit_code == 0, res.output
    doc = json.loads((tmp_path / "k.json").read_text())
    for c, cam in enumerate(stored.cameras):  # pixels by the stored cameras
        np.testing.assert_allclose(
            doc["frames"][1]["views"][c]["keypoints_2d"],
            cam.project(hand.joints(poses[1])),
            atol=5e-4,  # the file's pixels have three decimals
        )
    other = Rig(stored.cameras[:1], ("only",))  # --calib: other cameras instead
    other.save(tmp_path / "one.yml")
    res = _run("export", str(track), "--format", "openpose", "--out", str(tmp_path / "op"),
               "--calib", str(tmp_path / "one.yml"))  # fmt: skip
    assert res.exit_code == 0, res.output
    assert len(os.listdir(tmp_path / "op")) == len(poses)  # one camera, not the stored two
    res = _run("view", str(track))
    assert res.exit_code == 0 and (track / "view.html").is_file(), res.output


def test_a_track_saved_without_its_shape_is_refused_unless_the_default_hand(tmp_path):
    """Before the shape was kept, track.npz held only the tracker's record: the default
    185 mm right hand is taken when it gives the stored joints, a left hand is refused."""
    for side in ("right", "left"):
        track = _saved_track(tmp_path, side, 185.0)
        npz = track / "track.npz"
        with np.load(npz) as z:  # what write_track_outputs alone used to write
            kept = {k: z[k] for k in z.files if k != "meta" and not k.startswith("shape_")}
        np.savez_compressed(npz, **kept)
        res = _run("export", str(track), "--format", "bvh", "--out", str(tmp_path / "t.bvh"))
        if side == "right":
            assert res.exit_code == 0 and "right hand" in res.output, res.output
        else:
            lines = res.output.strip().splitlines()
            assert res.exit_code == 2 and len(lines) == 1, res.output
            assert "TRACK_DIR" in lines[0] and "no hand shape" in lines[0], lines


def _snapshot(root: Path) -> dict[str, bytes]:
    return {str(p): p.read_bytes() for p in sorted(root.rglob("*")) if p.is_file()}


def _bad_cases(track: Path, root: Path) -> list[tuple[list[str], str]]:
    missing = str(root / "no_such_track")
    return [
        (["export", missing, "--format", "bvh"], "TRACK_DIR"),
        (["export", str(root / "existing.txt"), "--format", "bvh"], "TRACK_DIR"),
        (["export", str(root / "not_a_track"), "--format", "json"], "TRACK_DIR"),
        (["export", str(track), "--format", "fbx"], "fbx"),
        (["export", str(track), "--format", "bvh", "--out", str(root / "nowhere" / "t.bvh")],
         "--out"),
        (["export", str(track), "--format", "bvh", "--out", str(root / "locked" / "t.bvh")],
         "--out"),
        (["export", str(track), "--format", "gltf", "--out", str(root / "existing.txt")],
         "--out"),
        (["export", str(track), "--format", "openpose", "--out", str(root / "existing.txt")],
         "--out"),
        (["export", str(track), "--format", "openpose"], "--calib"),
        (["export", str(track), "--format", "json", "--calib", str(root / "existing.txt")],
         "existing.txt"),
        (["view", missing], "TRACK_DIR"),
        (["view", str(track), "--out", str(root / "nowhere" / "v.html")], "--out"),
        (["view", str(track), "--out", str(root / "locked" / "v.html")], "--out"),
        (["view", str(track), "--out", str(root / "adir")], "--out"),
    ]  # fmt: skip


@pytest.mark.skipif(os.geteuid() == 0, reason="root writes into read-only folders")
def test_unwritable_folder_is_refused_for_non_root(tracks, tmp_path):
    locked = tmp_path / "locked"
    locked.mkdir(mode=0o500)
    res = CliRunner().invoke(main, ["view", str(tracks["right"]), "--out", str(locked / "v.html")])
    assert res.exit_code == 2 and "--out" in res.output


def test_bad_inputs_one_line_exit_2_nothing_damaged(tracks, tmp_path):
    track = tracks["right"]
    root = tmp_path
    (root / "existing.txt").write_bytes(KNOWN)
    (root / "adir").mkdir()
    (root / "adir" / "keep.txt").write_bytes(KNOWN)
    (root / "not_a_track").mkdir()
    (root / "not_a_track" / "track.npz").write_bytes(KNOWN)
    (root / "locked").mkdir()
    (root / "locked").chmod(0o500)
    before_root, before_track = _snapshot(root), _snapshot(track)
    try:
        for args, named in _bad_cases(track, root):
            if "locked" in " ".join(args) and os.geteuid() == 0:
                continue  # root may write anywhere; covered by the test above otherwise
            res = CliRunner().invoke(main, args)
            lines = res.output.strip().splitlines()
            assert res.exit_code == 2, (args, res.output)
            assert len(lines) == 1 and lines[0].startswith("handvar: error:"), (args, lines)
            assert named in lines[0], (args, lines)
            assert "Traceback" not in res.output and ".handvar-" not in res.output
    finally:
        (root / "locked").chmod(0o700)
    assert _snapshot(root) == before_root
    assert _snapshot(track) == before_track


def test_export_and_view_a_track_with_frames_without_a_hand(tmp_path):
    """No hand on frames 0 and 2 of 4: the keypoint files have no points there, BVH
    holds the tracked pose (frame 1 for both), glTF hides the hand, the viewer keeps
    every frame."""
    track = _saved_track(tmp_path, "right", absent=(0, 2))
    rig = str(tmp_path / "rig.yml")
    truth = np.load(track / "track.npz")["poses"]
    assert np.isnan(truth[[0, 2]]).all() and np.isfinite(truth[[1, 3]]).all()
    shape = HandShape.from_size(175.0)
    held = truth[[1, 1, 1, 3]]  # frame 0 before the first tracked one: the next one
    for fmt, out in [("json", "k.json"), ("openpose", "op"), ("bvh", "t.bvh"), ("gltf", "t.glb")]:
        res = _run("export", str(track), "--format", fmt, "--out", str(tmp_path / out),
                   "--calib", rig)  # fmt: skip
        assert res.exit_code == 0, res.output
        assert "4 frames (2 without a hand)" in res.output
    doc = json.loads((tmp_path / "k.json").read_text())
    assert [f["world"] is None and f["views"] == [] and f["confidence"] == 0.0
            for f in doc["frames"]] == [True, False, True, False]  # fmt: skip
    np.testing.assert_allclose(doc["frames"][3]["world"], HandModel(shape).joints(truth[3]),
                               atol=1e-3)  # fmt: skip
    people = [json.loads(f.read_text())["people"]
              for f in sorted((tmp_path / "op").rglob("*.json"))]  # fmt: skip
    assert len(people) == 8 and [p == [] for p in people] == [True, False, True, False] * 2
    got = bvh_world_joints(tmp_path / "t.bvh", bvh_joint_order())  # metres, y up
    want = np.stack([HandModel(shape).joints(x) for x in held]) * [1.0, -1.0, -1.0] / 1000.0
    assert got.shape == (4, 21, 3) and np.abs(got - want).max() <= 1e-6
    from handvar.export.gltf import mesh_vertices

    got = gltf_skinned_vertices(tmp_path / "t.glb", range(4))  # metres, y up
    want = mesh_vertices(shape, held) * [1.0, -1.0, -1.0] / 1000.0
    for f in (1, 3):  # tracked: the model's mesh
        assert np.abs(got[f] - want[f]).max() <= 1e-6
    for f in (0, 2):  # no hand: hidden, every vertex at the held pose's wrist
        assert np.abs(got[f] - held[f, :3] * [1.0, -1.0, -1.0] / 1000.0).max() <= 1e-7

    res = _run("view", str(track), "--out", str(tmp_path / "v.html"), "--calib", rig)
    assert res.exit_code == 0 and "4 frames (2 without a hand)" in res.output, res.output
    from tests.export_readers import plotly_page

    _, layout, frames = plotly_page((tmp_path / "v.html").read_text())
    assert len(frames) == len(layout["sliders"][0]["steps"]) == 4


def test_a_track_without_a_hand_is_refused_by_bvh_and_gltf(tmp_path):
    track = _saved_track(tmp_path, "left", absent=range(4))
    before = _snapshot(tmp_path)
    for fmt in ("bvh", "gltf"):
        res = CliRunner().invoke(main, ["export", str(track), "--format", fmt])
        lines = res.output.strip().splitlines()
        assert res.exit_code == 2 and len(lines) == 1, res.output
        assert lines[0].startswith("handvar: error: TRACK_DIR: ") and "benchmark-left" in lines[0]
    assert _snapshot(tmp_path) == before
    res = _run("export", str(track), "--format", "json")  # no points on any frame: fine
    assert res.exit_code == 0, res.output
    frames = json.loads((track / "keypoints.json").read_text())["frames"]
    assert [f["world"] for f in frames] == [None] * 4


def _quality(iou, keypoint_error):
    """A `TrackQuality` of 4 frames with these IoU and keypoint errors."""
    from handvar.tracking.recovery import TrackQuality

    n = 4
    return TrackQuality(
        iou=np.asarray(iou, float), keypoint_error=np.asarray(keypoint_error, float),
        cost=np.zeros(n), lost=np.zeros(n, bool), reinit=np.zeros(n, bool),
        empty=np.zeros(n, bool), keypoints=np.isfinite(keypoint_error),
    )  # fmt: skip


def test_view_labels_the_quality_by_what_it_holds(tmp_path):
    """Keypoints fitted without a silhouette: the keypoint error in hand sizes; the IoU
    where it was measured (both when both were); the tracker's IoU without recovery."""
    from tests.export_readers import plotly_page

    nan = np.nan
    cases = [
        (_quality([nan] * 4, [0.05, 0.04, nan, 0.06]), {"keypoint error (hand sizes)"}),
        (_quality([0.9, 0.8, 0.7, 0.9], [nan] * 4), {"silhouette IoU"}),
        (_quality([0.9, 0.8, 0.7, 0.9], [0.05, 0.04, nan, 0.06]),
         {"silhouette IoU", "keypoint error (hand sizes)"}),
        (None, {"silhouette IoU"}),  # the tracker's record: 0.9 on every frame and camera
    ]  # fmt: skip
    for i, (quality, labels) in enumerate(cases):
        track = _saved_track(tmp_path / str(i), "right", quality=quality)
        res = _run("view", str(track), "--out", str(tmp_path / f"v{i}.html"), "--no-frames")
        assert res.exit_code == 0, res.output
        data, layout, _ = plotly_page((tmp_path / f"v{i}.html").read_text())
        curves = {d["name"]: d["y"] for d in data
                  if d["type"] == "scatter" and d["name"] != "frame"}  # fmt: skip
        assert set(curves) == labels
        assert "fit confidence" not in (tmp_path / f"v{i}.html").read_text()
        assert layout["yaxis"]["title"]["text"] in labels
        if quality is None:
            assert curves["silhouette IoU"] == [0.9] * 4
        elif "keypoint error (hand sizes)" in labels:
            assert curves["keypoint error (hand sizes)"] == [0.05, 0.04, None, 0.06]


def _recording(folder: Path, camera, n: int, grey: int = 100) -> Path:
    """A recording of `n` plain grey frames of `camera`'s size, as an image folder."""
    import cv2

    folder.mkdir(parents=True)
    w, h = camera.size
    for t in range(n):
        cv2.imwrite(str(folder / f"{t:04d}.png"), np.full((h, w, 3), grey, np.uint8))
    return folder


def test_view_shows_the_recording_with_the_model_drawn_over_it(tmp_path):
    """--video: one JPEG per frame, at most 320 px wide, the model drawn in colour over
    the grey frames where there is a hand and nothing where there is none (frame 2);
    without a recording one line says the frames are left out; --no-frames says nothing."""
    import base64

    import cv2

    from tests.export_readers import plotly_page

    track = _saved_track(tmp_path, "right", cameras=True, absent=(2,))
    camera = Rig.load(track / "cameras.yml").cameras[0]
    video = _recording(tmp_path / "rec", camera, 5)
    res = _run("view", str(track), "--out", str(tmp_path / "v.html"), "--video", str(video))
    assert res.exit_code == 0 and "left out" not in res.output, res.output
    data, _, frames = plotly_page((tmp_path / "v.html").read_text())
    (index,) = [i for i, d in enumerate(data) if d["type"] == "image"]
    for t, frame in enumerate(frames):
        source = frame["data"][frame["traces"].index(index)]["source"]
        jpeg = base64.b64decode(source.split(",", 1)[1])
        image = cv2.imdecode(np.frombuffer(jpeg, np.uint8), cv2.IMREAD_COLOR).astype(int)
        assert image.shape[1] <= 320 and image.shape[1] == min(320, camera.size[0])
        coloured = np.sum(image.max(axis=2) - image.min(axis=2) > 60)  # the drawn model
        assert (coloured == 0) if t == 2 else (coloured > 100), (t, coloured)

    res = _run("view", str(track), "--out", str(tmp_path / "w.html"))
    assert res.exit_code == 0, res.output
    assert res.stderr.strip().splitlines() == [
        "handvar: note: frames left out: the track names no recording; give one with "
        "--video, or --no-frames"]  # fmt: skip
    data, _, _ = plotly_page((tmp_path / "w.html").read_text())
    assert not [d for d in data if d["type"] == "image"]
    res = _run("view", str(track), "--out", str(tmp_path / "x.html"), "--no-frames")
    assert res.exit_code == 0 and res.stderr == "", res.output


def test_view_takes_the_frames_of_the_recording_the_track_names(tmp_path):
    """Without --video, the recording the track was made from (its options' source),
    where it still is; one line when it is not."""
    from tests.export_readers import plotly_page

    camera = Rig.default().cameras[0]
    video = _recording(tmp_path / "rec", camera, 4)
    options = {"kind": "recording", "source": [str(video)]}
    track = _saved_track(tmp_path, "right", cameras=True, options=options)
    res = _run("view", str(track), "--out", str(tmp_path / "v.html"))
    assert res.exit_code == 0 and res.stderr == "", res.output
    data, _, _ = plotly_page((tmp_path / "v.html").read_text())
    assert [d["type"] for d in data].count("image") == 1
    video.rename(tmp_path / "moved")
    res = _run("view", str(track), "--out", str(tmp_path / "w.html"))
    assert res.exit_code == 0, res.output
    assert res.stderr.strip().splitlines() == [
        f"handvar: note: frames left out: the recording {video} is not there; give it with "
        "--video, or --no-frames"]  # fmt: skip


def test_view_refuses_a_recording_that_does_not_fit(tmp_path):
    track = _saved_track(tmp_path, "right", cameras=True)
    bare = _saved_track(tmp_path / "bare", "left")  # no cameras to draw with
    camera = Rig.load(track / "cameras.yml").cameras[0]
    short = _recording(tmp_path / "short", camera, 3)
    cases = [
        ([str(track), "--video", str(tmp_path / "nothing.mp4")], "--video"),
        ([str(track), "--video", str(short)], "--video: expected a recording of at least"),
        ([str(track), "--video", str(short), "--no-frames"], "--video: expected without"),
        ([str(bare), "--video", str(short)], "--video: expected the track's cameras"),
    ]
    for args, named in cases:
        res = CliRunner().invoke(main, ["view", *args, "--out", str(tmp_path / "v.html")])
        lines = res.output.strip().splitlines()
        assert res.exit_code == 2 and len(lines) == 1, (args, res.output)
        assert named in lines[0], (args, lines)
        assert not (tmp_path / "v.html").exists()
