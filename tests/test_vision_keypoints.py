"""Keypoint files, their checks, scaling and subsampling; the MediaPipe adapter and CLI."""

from __future__ import annotations

import subprocess
import sys

import numpy as np
import pytest
from click.testing import CliRunner

from handvar.cli import main
from handvar.data import example_path
from handvar.vision.keypoints import (
    KEYPOINT_NAMES,
    PALM,
    Keypoints2D,
    as_frame_keypoints,
    read_keypoints,
    write_keypoints,
)

VIDEO = example_path("video")
SHIPPED = example_path("video-keypoints")
DATA = SHIPPED.parent


def random_keypoints(seed: int, T: int = 6, conf: bool = True) -> np.ndarray:
    rng = np.random.default_rng(seed)
    a = np.concatenate([rng.uniform(0, 1280, (T, 21, 1)), rng.uniform(0, 720, (T, 21, 1))], axis=2)
    if conf:
        a = np.concatenate([a, rng.uniform(0.1, 1.0, (T, 21, 1))], axis=2)
    a[2] = np.nan  # a whole frame missing
    a[4, 7, :2] = np.nan  # one point missing
    return a


def test_names_follow_the_model_joints():
    from handvar.hand.anthropometry import JOINTS

    assert len(KEYPOINT_NAMES) == 21 == len(JOINTS)
    assert KEYPOINT_NAMES[0] == "wrist"
    assert KEYPOINT_NAMES[1:5] == ("thumb_cmc", "thumb_mcp", "thumb_ip", "thumb_tip")
    assert KEYPOINT_NAMES[9] == "middle_mcp" and KEYPOINT_NAMES[20] == "little_tip"


@pytest.mark.parametrize("suffix", [".npy", ".csv"])
@pytest.mark.parametrize("conf", [True, False])
def test_round_trip(tmp_path, suffix, conf):
    a = random_keypoints(1, conf=conf)
    path = tmp_path / f"kp{suffix}"
    write_keypoints(path, a)
    back = read_keypoints(path)
    assert back.name == str(path)
    assert back.n_frames == 6
    np.testing.assert_array_equal(back.xy, Keypoints2D.from_array(a).xy)
    expected_conf = a[..., 2] if conf else np.ones((6, 21))
    present = ~np.isnan(a[..., 0])
    np.testing.assert_array_equal(back.confidence, np.where(present, expected_conf, 0.0))
    assert not back.present[2].any() and not back.present[4, 7] and back.present[4, 8]


def test_csv_42_columns_with_and_without_header(tmp_path):
    a = random_keypoints(2, conf=False)
    rows = a.reshape(6, 42)
    lines = [",".join("" if np.isnan(v) else repr(float(v)) for v in row) for row in rows]
    plain = tmp_path / "plain.csv"
    plain.write_text("\n".join(lines) + "\n")
    header = tmp_path / "header.csv"
    header.write_text(
        ",".join(f"{c}{k}" for k in range(21) for c in "xy") + "\n" + plain.read_text()
    )
    for path in (plain, header):
        kp = read_keypoints(path)
        np.testing.assert_array_equal(kp.xy, Keypoints2D.from_array(a).xy)
        assert kp.n_frames == 6


@pytest.mark.parametrize(
    ("array", "match"),
    [
        (np.zeros((5, 20, 2)), r"shape \(T, 21, 2\) or \(T, 21, 3\).*got shape \(5, 20, 2\)"),
        (np.zeros((5, 21, 4)), r"got shape \(5, 21, 4\)"),
        (np.zeros((21, 2)), r"got shape \(21, 2\)"),
        (np.zeros((0, 21, 3)), "at least one frame"),
    ],
)
def test_bad_shapes_name_the_file(tmp_path, array, match):
    path = tmp_path / "bad.npy"
    np.save(path, array)
    with pytest.raises(ValueError, match=match) as info:
        read_keypoints(path)
    assert str(path) in str(info.value)


def test_confidence_outside_unit_interval(tmp_path):
    a = random_keypoints(3)
    a[1, 3, 2] = 1.5
    path = tmp_path / "conf.npy"
    np.save(path, a)
    with pytest.raises(ValueError, match=r"conf\.npy: expected confidences in \[0, 1\]; got 1\.5"):
        read_keypoints(path)
    a[1, 3, 2] = -0.1
    with pytest.raises(ValueError, match="frame 1, point 3"):
        Keypoints2D.from_array(a)


def test_infinity_and_wrong_types(tmp_path):
    a = random_keypoints(4)
    a[0, 0, 0] = np.inf
    with pytest.raises(ValueError, match="infinity at frame 0, point 0"):
        Keypoints2D.from_array(a)
    with pytest.raises(TypeError, match="keypoints: expected"):
        Keypoints2D.from_array("not keypoints")


def test_csv_wrong_column_count_names_the_file(tmp_path):
    path = tmp_path / "cols.csv"
    path.write_text("\n".join([",".join(["1"] * 42), ",".join(["1"] * 41)]) + "\n")
    with pytest.raises(ValueError, match=r"cols\.csv: expected 42 columns.*got 41 in data row 1"):
        read_keypoints(path)
    path.write_text("\n".join([",".join(["1"] * 42), ",".join(["1"] * 63)]) + "\n")
    with pytest.raises(ValueError, match=r"expected 42 columns in every row.*got 63"):
        read_keypoints(path)
    path.write_text(",".join(["1"] * 41 + ["x"]) + "\n" + ",".join(["1"] * 41 + ["zz"]) + "\n")
    with pytest.raises(ValueError, match=r"cols\.csv: expected numbers; got 'zz' in data row 0"):
        read_keypoints(path)


def test_missing_file_and_wrong_suffix(tmp_path):
    with pytest.raises(ValueError, match=r"nothere\.npy: expected a keypoint file"):
        read_keypoints(tmp_path / "nothere.npy")
    (tmp_path / "kp.txt").write_text("1 2\n")
    with pytest.raises(ValueError, match=r"kp\.txt: expected a \.npy, \.csv or \.npz"):
        read_keypoints(tmp_path / "kp.txt")
    with pytest.raises(ValueError, match=r"out\.json: expected a file name ending"):
        write_keypoints(tmp_path / "out.json", random_keypoints(0))
    (tmp_path / "junk.npy").write_bytes(b"not an array")
    with pytest.raises(ValueError, match=r"junk\.npy: expected a NumPy \.npy array"):
        read_keypoints(tmp_path / "junk.npy")


def test_every_keeps_every_kth_frame():
    a = random_keypoints(5, T=12)
    kp = Keypoints2D.from_array(a)
    sub = kp.every(5)
    kept = np.arange(12) % 5 == 0
    assert np.array_equal(sub.present.any(axis=1), kept & kp.present.any(axis=1))
    np.testing.assert_array_equal(sub.xy[kept], kp.xy[kept])
    assert np.isnan(sub.xy[~kept]).all() and (sub.confidence[~kept] == 0).all()
    shifted = kp.every(4, offset=1)
    assert shifted.present.any(axis=1).nonzero()[0].tolist() == [1, 5, 9]
    assert np.array_equal(kp.every(1).to_array(), kp.to_array(), equal_nan=True)
    with pytest.raises(ValueError, match="k: expected an integer >= 1; got 0"):
        kp.every(0)


@pytest.mark.parametrize("factor", [0.5, 0.37, 1.0, 2.0])
def test_scaling_matches_the_scaled_camera(factor):
    """A point projected by a camera lands where the scaled camera projects it."""
    from handvar.vision.sources import assumed_camera

    cam = assumed_camera((1280, 720))
    rng = np.random.default_rng(6)
    world = np.column_stack([rng.uniform(-100, 100, (21, 2)), rng.uniform(400, 600, 21)])
    kp = Keypoints2D.from_array(cam.project(world)[None])
    small = cam.scaled(factor)
    np.testing.assert_allclose(kp.scaled(factor, cam.size).xy[0], small.project(world), atol=1e-9)


def test_frame_keypoints_check():
    a = as_frame_keypoints(np.zeros((21, 2)))
    assert a.shape == (21, 3) and (a[:, 2] == 1).all()
    with pytest.raises(ValueError, match=r"cam0: expected keypoints of shape \(21, 2\)"):
        as_frame_keypoints(np.zeros((20, 2)), "cam0")


@pytest.mark.parametrize(
    ("imported", "absent"),
    [
        # the package and its commands leave MediaPipe, an optional extra, unloaded
        ("handvar, handvar.vision, handvar.vision.keypoints, handvar.cli",
         ("mediapipe", "handvar.vision.mediapipe")),
        # a detector's process (`python -m handvar.vision.detector`) loads neither SciPy
        # nor numba before MediaPipe, so each of a run's two starts that much sooner
        ("handvar.vision.detector, handvar.vision.mediapipe",
         ("scipy", "numba", "handvar.vision.skin")),
    ],
)  # fmt: skip
def test_importing_leaves_the_heavy_modules_out(imported, absent):
    code = f"import sys, {imported}; print(sorted(m for m in {absent!r} if m in sys.modules))"
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert out.stdout.strip() == "[]"


def test_keypoints_command_without_the_extra(tmp_path, monkeypatch):
    monkeypatch.setitem(sys.modules, "mediapipe", None)  # as if not installed
    res = CliRunner().invoke(main, ["keypoints", str(VIDEO), "--out", str(tmp_path / "k.npy")])
    assert res.exit_code == 2
    lines = res.output.strip().splitlines()
    assert len(lines) == 1 and "pip install 'handvar[mediapipe]'" in lines[0], res.output
    assert not (tmp_path / "k.npy").exists()


def test_shipped_keypoints():
    """The shipped detections: the right hand found in every frame of the video."""
    kp = read_keypoints(SHIPPED)
    assert kp.n_frames == 621
    assert kp.present.all()
    # every point inside the 1280×720 frame
    assert (kp.xy[..., 0] > -1).all() and (kp.xy[..., 0] < 1280).all()
    assert (kp.xy[..., 1] > -1).all() and (kp.xy[..., 1] < 720).all()


def test_mediapipe_on_the_video_matches_the_shipped_keypoints(tmp_path):
    out = tmp_path / "k.csv"
    res = CliRunner().invoke(
        main, ["keypoints", str(VIDEO), "--out", str(out), "--frames", "30", "--hand", "right"]
    )
    assert res.exit_code == 0, res.output
    assert "right hand in 30 of 30 frames" in res.output
    got = read_keypoints(out)
    shipped = read_keypoints(SHIPPED)
    # the shipped points came from another build of MediaPipe 0.10.21 and of OpenCV's
    # decoder: 97 % of the coordinates agree within 0.5 px, none differs by 2.5 px
    diff = np.abs(got.xy - shipped.xy[:30])
    assert np.mean(diff <= 0.5) > 0.95 and diff.max() < 2.5, diff.max()
    # the left hand is not in the video: the same points, at the complementary confidence
    left = CliRunner().invoke(
        main, ["keypoints", str(VIDEO), "--out", str(out), "--frames", "3", "--hand", "left"]
    )
    assert left.exit_code == 0, left.output
    np.testing.assert_allclose(
        read_keypoints(out).confidence, 1.0 - shipped.confidence[:3], atol=0.01
    )
    # the .npz keeps each point's own confidence and the handedness score beside it:
    # weighed for the left hand (as the tracker does once it knows the side) they are
    # the confidences of the left hand's .csv
    npz = tmp_path / "k.npz"
    res = CliRunner().invoke(
        main, ["keypoints", str(VIDEO), "--out", str(npz), "--frames", "3", "--hand", "auto"]
    )
    assert res.exit_code == 0, res.output
    kept = read_keypoints(npz)
    assert (kept.confidence == 1.0).all() and (kept.handedness_score >= 0.5).all()
    np.testing.assert_allclose(kept.for_side("left").confidence, read_keypoints(out).confidence,
                               atol=0.01)  # fmt: skip


# --- what the detector knows besides the points (.npz) ---------------------------------------


def _example_details(name):
    """A shipped clip's MediaPipe output (examples/data/*-mediapipe.npz) as `Keypoints2D`."""
    from handvar.vision.mediapipe import handedness_side

    z = np.load(DATA / f"{name}-mediapipe.npz")
    xy = z["landmarks_px"]
    labels = [handedness_side(str(v)) if v else "" for v in z["handedness"]]
    return Keypoints2D(xy, np.where(np.isnan(xy).any(axis=2), 0.0, 1.0), name,
                       world=z["world_mm"], handedness=np.array(labels))  # fmt: skip


def test_npz_keypoints_round_trip_with_their_extras_and_old_files_still_read(tmp_path):
    kp = _example_details("tfjs-asl-hand")
    path = tmp_path / "k.npz"
    write_keypoints(path, kp)
    back = read_keypoints(path)
    np.testing.assert_array_equal(back.to_array(), kp.to_array())
    np.testing.assert_array_equal(back.world, kp.world)
    with np.load(path) as z:  # read by NumPy alone: the documented keys
        assert sorted(z.files) == ["handedness", "keypoints", "world"]
        np.testing.assert_array_equal(z["world"], kp.world)
    assert back.depth is None and back.presence is None
    # .npy keeps the points only, and reads as before
    write_keypoints(tmp_path / "k.npy", kp)
    old = read_keypoints(tmp_path / "k.npy")
    assert old.world is None and old.handedness is None
    np.testing.assert_array_equal(old.xy, kp.xy)
    # thinning and scaling carry the extras; a thinned frame loses them
    thin = kp.every(5).scaled(0.5)
    assert np.isnan(thin.world[1]).all() and thin.handedness[1] == ""
    np.testing.assert_array_equal(thin.world[5], kp.world[5])


def test_a_bad_npz_names_the_file_and_the_array(tmp_path):
    path = tmp_path / "k.npz"
    np.savez(path, points=np.zeros((2, 21, 2)))
    with pytest.raises(ValueError, match=r"k\.npz: expected a \.npz with a 'keypoints' array"):
        read_keypoints(path)
    np.savez(path, keypoints=np.zeros((2, 21, 2)), world=np.zeros((3, 21, 3)))
    with pytest.raises(ValueError, match=r"expected world of shape \(2, 21, 3\); got \(3, 21, 3\)"):
        read_keypoints(path)
    np.savez(path, keypoints=np.zeros((2, 21, 2)), handedness=np.array(["Left", ""]))
    with pytest.raises(ValueError, match="expected handedness right, left or empty; got 'Left'"):
        read_keypoints(path)


@pytest.mark.parametrize("name", ["tfjs-asl-hand", "boreep-counting"])
def test_the_side_from_mediapipes_handedness_of_the_shipped_clips(name):
    # MediaPipe labels as if the image were mirrored: its "Left" on these ordinary
    # recordings is the right hand each shows (examples/data/README.md)
    z = np.load(DATA / f"{name}-mediapipe.npz")
    labels = {str(v) for v in z["handedness"] if v}
    assert labels == {"Left"}
    assert _example_details(name).side() == "right"
    # the same labels of a selfie (mirrored) recording are literal
    from handvar.vision.mediapipe import handedness_side

    assert handedness_side("Left", mirrored=True) == "left"


@pytest.mark.parametrize("video", ["dex-human-hand-video.mp4", "tfjs-asl-hand.mp4"])
def test_mediapipe_on_the_mirrored_video_sees_a_left_hand(tmp_path, video):
    import cv2

    folder = tmp_path / "mirrored"
    folder.mkdir()
    cap = cv2.VideoCapture(str(DATA / video))
    for i in range(20):
        ok, frame = cap.read()
        assert ok
        cv2.imwrite(str(folder / f"{i:03d}.png"), frame[:, ::-1])
    out = tmp_path / "k.npz"
    for source, side in ((DATA / video, "right"), (folder, "left")):
        res = CliRunner().invoke(
            main, ["keypoints", str(source), "--out", str(out), "--frames", "20", "--hand", "auto"]
        )
        assert res.exit_code == 0, res.output
        assert read_keypoints(out).side() == side


def test_auto_keeps_one_hand_where_two_are_in_view(tmp_path):
    import cv2

    # the fingerspelling clip beside its mirror image: a right hand on the left half, a
    # left one on the right; taking each frame's most confident hand jumped between them
    # (frames 2 and 10-13); the side of the first frames with a hand keeps one
    folder = tmp_path / "both"
    folder.mkdir()
    cap = cv2.VideoCapture(str(example_path("fingerspelling")))
    for i in range(16):
        ok, frame = cap.read()
        assert ok
        gap = np.full((frame.shape[0], 64, 3), 128, np.uint8)
        cv2.imwrite(str(folder / f"{i:03d}.png"), np.hstack([frame, gap, frame[:, ::-1]]))
    out = tmp_path / "k.npz"
    res = CliRunner().invoke(main, ["keypoints", str(folder), "--out", str(out), "--hand", "auto"])
    assert res.exit_code == 0, res.output
    kept = read_keypoints(out)
    x = np.nanmean(kept.xy[..., 0], axis=1)
    assert kept.present.any(axis=1).all() and (x < frame.shape[1]).all(), x.round()
    assert kept.side() == "right"


def test_mediapipes_world_landmarks_are_seen_along_the_ray_not_in_the_cameras_axes():
    """The same hand at the centre and at the border of a wide image: MediaPipe gives
    (nearly) the same world landmarks, though in the camera's axes the two hands are
    turned by the angle between their rays, so they are the hand as a view along the ray
    through it sees it (what the keypoint fit turns them by, `Camera.ray_rotation`)."""
    import cv2

    from handvar.camera import Camera
    from handvar.evaluation.metrics import rotation_about_wrist, rotation_angle
    from handvar.vision.mediapipe import MediaPipeHands

    cap = cv2.VideoCapture(str(DATA / "tfjs-asl-hand.mp4"))
    frames = [cap.read()[1] for _ in range(12)]
    cap.release()
    h, w = frames[0].shape[:2]
    width = 4 * w
    camera = Camera.assumed((width, h), fov=90.0)
    world, centres = {}, {}
    for place, x0 in (("centre", (width - w) // 2), ("border", 0)):
        detector, found = MediaPipeHands(), []
        for frame in frames:
            canvas = np.full((h, width, 3), 128, np.uint8)
            canvas[:, x0 : x0 + w] = frame
            found.append(detector(canvas)[0])
        detector.close()
        world[place] = [d.world for d in found[2:]]  # its tracking settled
        centres[place] = np.mean([d.points[list(PALM), :2].mean(0) for d in found[2:]], axis=0)
    apart = [rotation_angle(rotation_about_wrist(a, b))
             for a, b in zip(world["centre"], world["border"], strict=True)]  # fmt: skip
    turn = camera.ray_rotation(centres["border"]).T @ camera.ray_rotation(centres["centre"])
    between_rays = rotation_angle(turn)
    assert between_rays > 30.0, between_rays
    # measured 0.9° apart against 37° between the rays
    assert np.median(apart) < between_rays / 4, (np.median(apart), between_rays)


# --- every hand found (.json, two hands) ------------------------------------------------------


def test_detections_file_round_trip_with_world_and_missing_points(tmp_path):
    from handvar.vision.keypoints import Detection, read_detections, write_detections

    rng = np.random.default_rng(3)
    a = np.c_[rng.uniform(0, 640, (21, 2)), rng.uniform(0.1, 1.0, 21)]
    a[5] = (np.nan, np.nan, 0.0)
    world = rng.normal(0, 40, (21, 3))
    frames = [[Detection(a, world=world, side="left", score=0.7),
               Detection(a + np.r_[10.0, 0.0, 0.0], side="", score=1.0)], [], [
               Detection(a, side="right", score=0.55)]]  # fmt: skip
    write_detections(tmp_path / "hands.json", frames)
    back = read_detections(tmp_path / "hands.json")
    assert [len(f) for f in back] == [2, 0, 1]
    for got, want in zip([d for f in back for d in f], [d for f in frames for d in f], strict=True):
        np.testing.assert_array_equal(got.points, want.points)  # NaN where missing
        assert (got.world is None) == (want.world is None)
        if want.world is not None:
            np.testing.assert_array_equal(got.world, want.world)
        assert (got.side, got.score) == (want.side, want.score)


@pytest.mark.parametrize(
    ("text", "match"),
    [("{}", "a list with one entry per frame; got dict"),
     ("[[1]]", "frame 0, hand 0: expected an object with 'points'"),
     ('[[], [{"points": [[1, 2]]}]]', r"frame 1, hand 0: expected 'points' as 21"),
     ('[[{"points": ' + str([[1, 2, 1]] * 21) + ', "side": "both"}]]', "'side' right, left"),
     ('[[{"points": ' + str([[1, 2, 1]] * 21) + ', "score": 2}]]', r"'score' a number in \[0, 1\]"),
     ("[[", "expected JSON; got an error at line 1")],
)  # fmt: skip
def test_a_bad_detections_file_names_the_file_the_frame_and_the_hand(tmp_path, text, match):
    from handvar.vision.keypoints import read_detections

    path = tmp_path / "hands.json"
    path.write_text(text, encoding="utf-8")
    with pytest.raises(ValueError, match=match) as info:
        read_detections(path)
    assert str(info.value).startswith(str(path))


def test_keypoints_command_keeps_every_hand_for_two_hands(tmp_path):
    """``handvar keypoints --hands 2``: the detections of MediaPipe asked for two hands,
    one list per frame, the example video's one right hand in each."""
    from handvar.vision.detector import mediapipe_available
    from handvar.vision.keypoints import read_detections

    if not mediapipe_available():
        pytest.skip("MediaPipe (the optional extra) is not installed")
    out = tmp_path / "hands.json"
    res = CliRunner().invoke(main, ["keypoints", str(VIDEO), "--hands", "2", "--frames", "8",
                                    "--out", str(out)])  # fmt: skip
    assert res.exit_code == 0, res.output
    found = read_detections(out)
    assert len(found) == 8 and all(len(f) >= 1 for f in found)
    shipped = read_keypoints(SHIPPED)
    for t, f in enumerate(found):  # the right hand, where the one-hand file has it
        right = [d for d in f if d.side == "right"]
        assert right and np.abs(right[0].points[:, :2] - shipped.xy[t]).max() < 2.5
        assert right[0].world is not None
    wrong = CliRunner().invoke(main, ["keypoints", str(VIDEO), "--hands", "2", "--out",
                                      str(tmp_path / "k.npz")])  # fmt: skip
    assert wrong.exit_code == 2 and "--out: expected a .json file with --hands 2" in wrong.output


def _short_video(tmp_path, frames: int = 12):
    """The first `frames` frames of the example video at a quarter of its size, as an MJPG
    .avi cut to half its bytes (its container still states all of them)."""
    import cv2

    cap = cv2.VideoCapture(str(VIDEO))
    path = tmp_path / "short.avi"
    writer = None
    for _ in range(frames):
        ok, image = cap.read()
        assert ok
        image = cv2.resize(image, (image.shape[1] // 4, image.shape[0] // 4))
        if writer is None:
            size = (image.shape[1], image.shape[0])
            writer = cv2.VideoWriter(str(path), cv2.VideoWriter_fourcc(*"MJPG"), 30, size)
        writer.write(image)
    writer.release()
    cap.release()
    whole = path.read_bytes()
    path.write_bytes(whole[: len(whole) // 2])
    return path


@pytest.mark.filterwarnings("default")  # the CLI prints its warnings
def test_a_truncated_video_gives_keypoints_that_track_takes_with_allow_short(tmp_path):
    """`handvar keypoints` reads a video as tracking reads it: a truncated one is refused
    naming --allow-short, and with it the frames decoded are detected; `handvar track
    --allow-short` then takes that file (fewer frames than the container states)."""
    pytest.importorskip("mediapipe")
    video, out = _short_video(tmp_path), tmp_path / "k.npz"
    refused = CliRunner().invoke(main, ["keypoints", str(video), "--out", str(out)])
    assert refused.exit_code == 2 and "--allow-short" in refused.output, refused.output
    assert not out.exists()
    res = CliRunner().invoke(main, ["keypoints", str(video), "--out", str(out), "--allow-short"])
    assert res.exit_code == 0, res.output
    read = read_keypoints(out).n_frames
    assert 0 < read < 12
    res = CliRunner().invoke(main, ["track", str(video), "--keypoints", str(out), "--allow-short",
                                    "--out", str(tmp_path / "t"), "--no-video"])  # fmt: skip
    assert res.exit_code == 0, res.output
    assert f"keypoints of {read} frames, the video's container states 12" in res.output
    from handvar.pipeline import HandsTrack, Track

    assert Track.load(tmp_path / "t").n_frames == read
    # both hands: the .json of every hand found, the same way
    found = tmp_path / "k.json"
    res = CliRunner().invoke(main, ["keypoints", str(video), "--hands", "2", "--out", str(found),
                                    "--allow-short"])  # fmt: skip
    assert res.exit_code == 0, res.output
    res = CliRunner().invoke(main, ["track", str(video), "--hands", "2", "--keypoints", str(found),
                                    "--allow-short", "--out", str(tmp_path / "h"),
                                    "--no-video"])  # fmt: skip
    assert res.exit_code == 0, res.output
    assert f"the hands found in {read} frames, the video's container states 12" in res.output
    assert HandsTrack.load(tmp_path / "h").n_frames == read


def test_keypoints_of_an_image_folder_follow_the_frames_in_tracking_order(tmp_path):
    """Images named 1, 2, 10 are frames 0, 1, 2 (natural order, as tracking reads them),
    not 1, 10, 2: the keypoints of the folder are those of the video's frames."""
    import cv2

    pytest.importorskip("mediapipe")
    from handvar.vision.mediapipe import detect_video

    cap = cv2.VideoCapture(str(VIDEO))
    folder = tmp_path / "frames"
    folder.mkdir()
    for name in ("1", "2", "10"):
        ok, image = cap.read()
        assert ok
        cv2.imwrite(str(folder / f"{name}.png"), image)
    cap.release()
    from_folder = detect_video(folder, hand="right")
    from_video = detect_video(VIDEO, hand="right", frames=3)
    np.testing.assert_allclose(from_folder, from_video, atol=1e-6)
