"""Tests of `handvar.track` and `handvar.Track`: the pipeline in one call."""

from __future__ import annotations

import dataclasses
import json

import cv2
import numpy as np
import pandas as pd
import pytest

from handvar.camera import Rig
from handvar.hand import HandModel
from handvar.hand.anthropometry import HandShape
from handvar.params import NAMES
from handvar.pipeline import Track, load_shape, track
from handvar.tracking.tracker import TrackResult

#: What track.npz held before the track's shape and cameras were kept.
RECORD = {f.name for f in dataclasses.fields(TrackResult)} | {"predictor", "seed"}


@pytest.fixture(scope="module")
def recovered():
    """Three frames of the synthetic benchmark, tracked with recovery (so with quality)."""
    return track("benchmark", frames=3, recover=True, seed=1)


def test_a_track_holds_the_model_joints_and_their_projections(recovered):
    t = recovered
    assert t.poses.shape == (3, 26) and t.joints.shape == (3, 21, 3)
    assert t.projected.shape == (len(t.rig), 3, 21, 2)
    # G(x) of the fitted poses, by the hand model directly
    np.testing.assert_allclose(t.joints[2], HandModel(t.shape).joints(t.poses[2]), atol=1e-9)
    for c, cam in enumerate(t.rig.cameras):
        np.testing.assert_allclose(t.projected[c, 1], cam.project(t.joints[1]), atol=1e-9)
    assert t.shape.side == "right" and t.predictor == "rvar" and t.seed == 1
    assert t.options["keypoint_tips"] == "end" and t.options["carry"] == "none"
    assert t.quality is not None and len(t.quality.iou) == 3
    assert t.fit_seconds.shape == (3,) and np.all(t.fit_seconds > 0)
    # the synthetic sequence's truth: the tracker starts at the true first pose
    np.testing.assert_allclose(t.result.starts[0], t.sequence.truth.poses[0])


@pytest.fixture(scope="module")
def left_recording():
    """Three frames of the example video tracked as a left hand, at half size, with its
    keypoints: an assumed camera, the recording's frame rate and name."""
    from handvar.data import example_path

    return track(
        example_path("video"), keypoints=example_path("video-keypoints"), hand="left",
        hand_length=178.0, frames=3, scale=0.5,
    )  # fmt: skip


def _assert_same_track(back: Track, original: Track) -> None:
    """Everything a saved track keeps, equal to the last bit."""
    for name in ("poses", "joints", "projected", "search_seconds"):
        np.testing.assert_array_equal(getattr(back, name), getattr(original, name))
    for f in dataclasses.fields(HandShape):  # every array the shape is built from
        np.testing.assert_array_equal(getattr(back.shape, f.name), getattr(original.shape, f.name))
    assert back.shape.side == original.shape.side
    assert back.rig == original.rig  # names, K, distortion, R, t, image size
    for a, b in zip(back.rig.cameras, original.rig.cameras, strict=True):
        np.testing.assert_array_equal(a.K, b.K)
    assert back.fps == original.fps and back.name == original.name
    assert (back.predictor, back.seed) == (original.predictor, original.seed)
    assert back.options == original.options
    assert back.hand.surface == original.hand.surface  # the surface model


def test_save_then_load_gives_the_track_back(recovered, tmp_path):
    written = recovered.save(tmp_path / "t", video=False)
    assert {"poses", "joints", "track", "overlay", "quality", "cameras"} <= set(written)
    back = Track.load(tmp_path / "t")
    _assert_same_track(back, recovered)
    for name in ("iou", "keypoint_error", "lost", "reinit", "empty", "keypoints"):
        np.testing.assert_array_equal(getattr(back.quality, name), getattr(recovered.quality, name))
    assert (back.name, back.predictor, back.seed, back.fps) == ("benchmark", "rvar", 1, 25.0)
    # cameras.yml, read by OpenCV itself: the camera matrices of the rig
    fs = cv2.FileStorage(str(tmp_path / "t" / "cameras.yml"), cv2.FILE_STORAGE_READ)
    for c, cam in enumerate(recovered.rig.cameras):
        node = fs.getNode("cameras").at(c)
        assert node.getNode("name").string() == recovered.rig.names[c]
        np.testing.assert_array_equal(node.getNode("camera_matrix").mat(), cam.K)
    fs.release()
    # a loaded track has no frames: saved again without overlays, the same numbers
    with pytest.raises(ValueError, match="overlays"):
        back.save(tmp_path / "again")
    back.save(tmp_path / "again", video=False, overlays=False)
    for name in ("poses.csv", "joints.csv", "quality.csv", "cameras.yml"):
        assert (tmp_path / "again" / name).read_bytes() == (tmp_path / "t" / name).read_bytes()
    _assert_same_track(Track.load(tmp_path / "again"), recovered)


def test_a_left_hand_recording_saved_and_loaded_is_the_same(left_recording, tmp_path):
    left_recording.save(tmp_path / "t", video=False)
    back = Track.load(tmp_path / "t")
    _assert_same_track(back, left_recording)
    assert back.shape.side == "left" and back.shape.length == 178.0
    assert back.fps == 30.0 and back.name == "dex-human-hand-video"
    np.testing.assert_array_equal(back.detections, left_recording.detections)
    # the loaded hand gives the stored points (a recording's: the fingertips and the
    # thumb's base where a detector marks them): the shape, not only its size
    assert back.hand.tips == "pad"
    np.testing.assert_allclose(back.hand.landmarks(back.poses[2]), back.joints[2], atol=1e-9)


def test_the_surface_model_comes_back(recovered, tmp_path):
    meshed = dataclasses.replace(recovered, options={**recovered.options, "model": "mesh"})
    meshed.save(tmp_path / "t", video=False, overlays=False)
    assert Track.load(tmp_path / "t").hand.surface == "mesh"


def test_other_cameras_at_load_give_their_projections(recovered, tmp_path):
    recovered.save(tmp_path / "t", video=False, overlays=False)
    one = Rig(recovered.rig.cameras[1:], ("only",))
    back = Track.load(tmp_path / "t", rig=one)
    assert back.rig == one and back.projected.shape == (1, 3, 21, 2)
    np.testing.assert_array_equal(back.projected[0], recovered.projected[1])


def _strip_npz(path, drop) -> None:
    """Rewrite track.npz without the arrays for which ``drop(name)`` holds."""
    with np.load(path) as z:
        kept = {k: z[k] for k in z.files if not drop(k)}
    np.savez_compressed(path, **kept)


def test_older_track_directories_load_without_guessing(recovered, tmp_path):
    recovered.save(tmp_path / "t", video=False, overlays=False)
    # cameras kept in track.npz's meta, before cameras.yml
    with np.load(tmp_path / "t" / "track.npz") as z:
        meta = json.loads(str(z["meta"]))
    (tmp_path / "t" / "cameras.yml").unlink()
    _strip_npz(tmp_path / "t" / "track.npz", lambda k: k == "meta")
    with np.load(tmp_path / "t" / "track.npz") as z:
        arrays = dict(z)
    meta["rig"] = recovered.rig.to_dict()
    np.savez_compressed(tmp_path / "t" / "track.npz", **arrays, meta=np.array(json.dumps(meta)))
    _assert_same_track(Track.load(tmp_path / "t"), recovered)

    # only the tracker's record, the predictor and the seed: the default hand, checked
    _strip_npz(tmp_path / "t" / "track.npz", lambda k: k not in RECORD)
    back = Track.load(tmp_path / "t")
    np.testing.assert_array_equal(back.poses, recovered.poses)
    np.testing.assert_array_equal(back.shape.segments, HandShape.from_size().segments)
    assert back.shape.side == "right" and back.rig is None and back.fps is None
    assert back.quality is None and back.options == {} and back.name == "t"
    assert back.projected.shape == (0, 3, 21, 2)
    back.save(tmp_path / "again", video=False, overlays=False)  # and saved again
    assert not (tmp_path / "again" / "cameras.yml").exists()
    assert Track.load(tmp_path / "again").rig is None

    # joints that the default hand does not give: refused, nothing guessed
    with np.load(tmp_path / "t" / "track.npz") as z:
        arrays = dict(z)
    arrays["joints"] = arrays["joints"] * 1.01
    np.savez_compressed(tmp_path / "t" / "track.npz", **arrays)
    with pytest.raises(ValueError, match=r"no hand shape .* cannot be rebuilt"):
        Track.load(tmp_path / "t")


@pytest.mark.parametrize(
    ("content", "message"),
    [(None, "directory: expected a track directory"), (b"not a zip", "not a readable track")],
)
def test_load_refuses_what_is_not_a_track(tmp_path, content, message):
    if content is not None:
        (tmp_path / "track.npz").write_bytes(content)
    with pytest.raises(ValueError, match=message):
        Track.load(tmp_path)


def test_the_wide_table_matches_the_csv_files_read_by_pandas(recovered, tmp_path):
    recovered.save(tmp_path / "t", video=False)
    wide = recovered.to_dataframe()
    poses = pd.read_csv(tmp_path / "t" / "poses.csv")
    assert list(poses.columns) == list(NAMES)
    np.testing.assert_allclose(wide[list(NAMES)].to_numpy(), poses.to_numpy(), atol=1e-6)
    quality = pd.read_csv(tmp_path / "t" / "quality.csv")
    np.testing.assert_allclose(wide["iou"].to_numpy(), quality["iou"].to_numpy(), atol=1e-4)
    for name in ("lost", "keypoints", "no_hand", "rejected"):
        expected = np.asarray(getattr(recovered.quality, name), dtype=int)
        np.testing.assert_array_equal(quality[name].to_numpy(), expected)
    joints = pd.read_csv(tmp_path / "t" / "joints.csv").to_numpy()
    np.testing.assert_allclose(wide.filter(regex="_[xyz]$").to_numpy(), joints, atol=1e-4)


def test_the_long_table_has_a_row_per_frame_and_joint(recovered):
    long = recovered.to_dataframe("long")
    assert len(long) == 3 * 21
    row = long[(long.frame == 2) & (long.joint == long.joint.iloc[4])].iloc[0]
    np.testing.assert_allclose(row[["x", "y", "z"]].to_numpy(float), recovered.joints[2, 4])
    cam = recovered.rig.names[0]
    np.testing.assert_allclose(
        row[[f"u_{cam}", f"v_{cam}"]].to_numpy(float), recovered.projected[0, 2, 4]
    )


def test_a_saved_track_gives_its_hand_as_a_shape(recovered, tmp_path):
    recovered.save(tmp_path / "t")
    for source in (tmp_path / "t", tmp_path / "t" / "track.npz", str(tmp_path / "t")):
        shape = load_shape(source)
        for name in ("segments", "bases", "base_rotations", "radii", "palm_centres"):
            np.testing.assert_array_equal(getattr(shape, name), getattr(recovered.shape, name))
    with pytest.raises(ValueError, match="shape: expected a track saved by handvar"):
        load_shape(tmp_path)


def test_a_given_shape_is_the_hand_tracked_and_is_held():
    """With keypoints the track fits the hand's proportions to its first 12 frames; a
    shape given is tracked as it is (a left hand of 170 mm here, where the default is a
    right hand of 185 mm): the track's hand is that shape, its points that hand's."""
    from handvar.data import example_path

    given = HandShape.from_size(170.0, side="left")
    common = {"keypoints": example_path("video-keypoints"), "frames": 14, "scale": 0.5}
    fitted = track(example_path("video"), hand="left", hand_length=170.0, **common)
    held = track(example_path("video"), shape=given, **common)
    assert not np.allclose(fitted.shape.segments, given.segments)  # the shape fit ran
    assert held.shape.side == "left" and held.options["shape"] is True
    for name in ("segments", "bases", "radii"):
        np.testing.assert_array_equal(getattr(held.shape, name), getattr(given, name))
    np.testing.assert_allclose(held.joints[13],
                               HandModel(given, tips="pad").landmarks(held.poses[13]),
                               atol=1e-9)  # fmt: skip


def test_a_recordings_points_are_where_the_detector_marks_them():
    """On a recording the track reports the 21 points where a detector marks them (the
    fingertips at their pads, the thumb's base up its metacarpal; design §14.6), the
    points the fit compares with the keypoints: against MediaPipe's own points on the
    example video, those six lie nearer than the skeleton's joints G(x) do (which BVH
    and glTF carry), the other fifteen are G(x)'s."""
    from handvar.data import example_path
    from handvar.vision.keypoints import read_keypoints

    t = track(example_path("video"), keypoints=example_path("video-keypoints"), frames=14,
              scale=0.5)  # fmt: skip
    assert t.options["keypoint_tips"] == "pad" and t.hand.tips == "pad"
    detected = read_keypoints(example_path("video-keypoints"))
    cam = t.rig.cameras[0]
    skeleton = np.stack([cam.project(t.hand.joints(x)) for x in t.poses])
    moved = [1, 4, 8, 12, 16, 20]  # the thumb's base and the five tips
    same = [j for j in range(21) if j not in moved]
    np.testing.assert_allclose(t.projected[0][:, same], skeleton[:, same], atol=1e-9)
    size = np.linalg.norm(detected.xy[:14, 9] - detected.xy[:14, 0], axis=-1)[:, None]
    reported = np.linalg.norm(t.projected[0][:, moved] - detected.xy[:14, moved], axis=-1)
    joints = np.linalg.norm(skeleton[:, moved] - detected.xy[:14, moved], axis=-1)
    assert np.median(reported / size) < 0.8 * np.median(joints / size)


@pytest.mark.parametrize(
    ("kwargs", "message"),
    [
        ({"hand": "left"}, "hand: expected right, the side of the shape given"),
        ({"hand_length": 170.0}, "hand_length: expected none with a shape given"),
        ({"hands": 2}, "shape: expected none with hands=2"),
    ],
)
def test_a_shape_refuses_what_contradicts_it(kwargs, message):
    with pytest.raises(ValueError, match=message):
        track("benchmark", frames=1, shape=HandShape.from_size(), **kwargs)


def test_without_recovery_a_sequence_has_no_quality():
    t = track("benchmark", frames=2, predictor="decel")
    assert t.quality is None and t.options["recover"] is False
    assert len(t.search_seconds) == 0 and t.detections is None


@pytest.mark.parametrize(
    ("kwargs", "message"),
    [
        ({"keypoint_every": 2}, "keypoint_every: expected only with keypoints"),
        ({"carry": "forward"}, "carry: expected a recording"),
        ({"hand": "left", "model": "mesh"}, "model: expected spheres for a left hand"),
        ({"calib": "rig.yml"}, "calib, fov: expected only with a video"),
        ({"init": "nonesuch"}, "init: expected a named pose"),
        ({"predictor": "nonesuch"}, "predictor: expected one of"),
        ({"keypoint_tips": "nail"}, "keypoint_tips: expected one of"),
        ({"frames": 0}, "frames: expected an integer"),
    ],
)
def test_errors_name_the_keyword(kwargs, message):
    with pytest.raises(ValueError, match=message):
        track("benchmark", **{"frames": 1, **kwargs})


def test_an_unknown_source_is_named():
    with pytest.raises(ValueError, match="source: expected a sequence directory"):
        track("nonesuch")


def test_the_defaults_are_decided_without_a_video():
    """`decide_defaults` gives the defaults of the module notes from the kind of source,
    what came with it and the options alone."""
    from handvar.pipeline import TrackOptions, decide_defaults

    given = TrackOptions.checked()

    def decided(d):
        return d.hand, d.carry, d.keypoint_tips, d.recover, d.cut_wrist, d.first_pose

    # a recording with keypoints: carried both ways, pads, recovery, the wrist cut while
    # tracking, the first pose searched; keypoints without handedness: the right hand
    d = decide_defaults(given, "recording", keypoints=True)
    assert decided(d) == ("right", "both", "pad", True, True, "search")
    assert d.allow_empty
    # their handedness, or a detector's, decides the side
    assert decide_defaults(given, "recording", keypoints=True, handedness=True).hand == "auto"
    assert decide_defaults(given, "recording", detector=True).carry == "both"
    assert decide_defaults(given, "recording", detector=True).hand == "auto"
    # online (real time, a camera): carried forward only from a detector slower than the
    # frames, up to its next frame
    for kind, options in [("recording", {"realtime": True}), ("camera", {})]:
        for every, carry in [(1, "none"), (5, "forward")]:
            options_k = TrackOptions.checked(keypoint_every=every, **options)
            d = decide_defaults(options_k, kind, detector=True)
            assert (d.carry, d.recover, d.hand) == (carry, True, "auto"), (kind, every)
    # a recording without keypoints: the silhouette tracker with recovery, the
    # silhouettes cut at the wrist when computed
    assert decided(decide_defaults(given, "recording")) == (
        "right", "none", "pad", True, False, "search",
    )  # fmt: skip
    # a sequence: G(x) projected, its true first pose, recovery only with keypoints
    d = decide_defaults(given, "synthetic")
    assert decided(d) == ("right", "none", "end", False, False, "truth")
    assert not d.allow_empty
    assert decided(decide_defaults(given, "directory", keypoints=True)) == (
        "right", "none", "end", True, False, "truth",
    )  # fmt: skip
    # what is given stays
    chosen = TrackOptions.checked(hand="left", carry="forward", keypoint_tips="end",
                                  recover=False, init="open")  # fmt: skip
    assert decided(decide_defaults(chosen, "recording", keypoints=True)) == (
        "left", "forward", "end", False, False, "init",
    )  # fmt: skip


@pytest.mark.parametrize(
    ("options", "kind", "given", "message"),
    [
        ({"recover": False}, "recording", {}, r"^v\.mp4: the sequence has no ground truth"),
        ({"carry": "both"}, "recording", {}, r"^carry: expected a recording .* got no keypoints"),
        ({"carry": "both"}, "synthetic", {"keypoints": True},
         r"^carry: .* got the synthetic sequence 'v\.mp4'$"),
        ({"realtime": True, "carry": "both"}, "recording", {"keypoints": True},
         r"^realtime: expected recovery on .*; got recover=True, carry=both$"),
        ({"on_frame": print, "recover": False, "init": "open"}, "recording", {},
         r"^on_frame: expected only with recover"),
        ({"hand": "auto"}, "recording", {}, r"^hand: auto expected .*; got no keypoints$"),
    ],
)  # fmt: skip
def test_the_defaults_refuse_what_the_source_cannot_take(options, kind, given, message):
    from handvar.pipeline import TrackOptions, decide_defaults

    with pytest.raises(ValueError, match=message):
        decide_defaults(TrackOptions.checked(**options), kind, name="v.mp4", **given)


def test_the_options_are_checked_before_the_source_is_looked_at():
    from handvar.pipeline import TrackOptions

    options = TrackOptions.checked(keypoint_every=5, predictor="decel", init="fist", scale=1)
    assert options.keypoint_every == 5 and options.predictor_key == "decelerating"
    assert options.scale == 1.0 and options.init_pose.shape == (26,)
    with pytest.raises(ValueError, match=r"^init: expected a named pose"):
        track("nonesuch", init="nonesuch")  # the init is named, not the source


@pytest.mark.parametrize(("carry", "between"), [("both", "interpolated"), ("forward", "held")])
def test_the_detectors_3d_between_two_detections_is_interpolated_on_a_recording(
    monkeypatch, carry, between
):
    """The fingerspelling clip with its MediaPipe keypoints and world landmarks on every
    5th frame: carried both ways (a recording's default), a frame between two detections
    gives the fit the two detections' 3D interpolated linearly, as read from the file;
    carried forward (live), the last detection's."""
    from handvar.data import example_path
    from handvar.tracking.recovery import Recovery
    from handvar.vision.keypoints import Keypoints2D, read_keypoints

    kp = read_keypoints(example_path("fingerspelling-keypoints"))
    with np.load(example_path("fingerspelling-mediapipe")) as z:
        world = z["world_mm"]
    given = {}
    cue = Recovery._world_cue

    def recorded(self, world, kps):
        given[self._frame_no] = None if world is None else np.array(world)
        return cue(self, world, kps)

    monkeypatch.setattr(Recovery, "_world_cue", recorded)
    t0 = 20  # a detection with 3D on frames 20, 25 and 30
    assert np.isfinite(world[[t0, t0 + 5, t0 + 10]]).all()
    keypoints = Keypoints2D(kp.xy, kp.confidence, kp.name, world=world)
    track(example_path("fingerspelling"), keypoints=keypoints, keypoint_every=5, carry=carry,
          frames=t0 + 11, scale=0.5)  # fmt: skip
    for t in [t for t in range(t0, t0 + 10) if t % 5]:
        a, b = 5 * (t // 5), 5 * (t // 5) + 5
        want = world[a] + (t - a) / 5 * (world[b] - world[a]) if between == "interpolated" else None
        got = given[t]  # the fit's count of frames before this one
        if want is None:
            assert got is None, t  # no 3D of its own: the last detections' mean is used
        else:
            np.testing.assert_allclose(got, want, atol=1e-9, err_msg=str(t))
    for t in (t0, t0 + 5, t0 + 10):
        np.testing.assert_allclose(given[t], world[t])


def test_init_takes_the_shape_of_a_saved_track(recovered, tmp_path):
    """`handvar init SEQ --shape DIR` fits the saved track's hand (a right one): without
    --hand its side, with the other side refused in one line naming --hand."""
    from click.testing import CliRunner

    from handvar.cli import main
    from handvar.io import write_sequence
    from handvar.synth.sequences import make_sequence

    recovered.save(tmp_path / "t")
    write_sequence(make_sequence("benchmark", n_frames=1), tmp_path / "seq")
    args = ["init", str(tmp_path / "seq"), "--shape", str(tmp_path / "t")]
    done = CliRunner().invoke(main, [*args, "--out", str(tmp_path / "x0.txt")])
    assert done.exit_code == 0, done.output
    assert np.loadtxt(tmp_path / "x0.txt").shape == (26,)
    refused = CliRunner().invoke(main, [*args, "--hand", "left", "--out", str(tmp_path / "x1.txt")])
    assert refused.exit_code == 2 and refused.output.count("\n") == 1
    assert refused.output.startswith("handvar: error: --hand: expected right, the side of --shape")
    assert not (tmp_path / "x1.txt").exists()
