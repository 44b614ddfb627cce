"""Wrong keypoints given with a recording: a one-line error naming them, or a flagged
frame, never a silent wrong track (`handvar.vision.keypoints.check_keypoints`)."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest
from click.testing import CliRunner

from handvar.cli import main
from handvar.data import example_path
from handvar.pipeline import track
from handvar.vision.keypoints import Keypoints2D, read_keypoints, write_keypoints

VIDEO = example_path("video")


@pytest.fixture(scope="module")
def detected():
    return read_keypoints(example_path("video-keypoints"))


def with_side(kp, side):
    return Keypoints2D(kp.xy, kp.confidence, "k.npz",
                       handedness=np.where(kp.present.any(axis=1), side, ""))  # fmt: skip


def test_keypoints_of_another_length_than_the_video(detected, tmp_path):
    short = Keypoints2D(detected.xy[:-1], detected.confidence[:-1], "short.npy")
    with pytest.raises(ValueError, match=r"short\.npy: expected keypoints of 621 frames "
                                         r"\(the recording's\); got 620"):  # fmt: skip
        track(VIDEO, keypoints=short, frames=2)
    write_keypoints(tmp_path / "short.npy", short)
    res = CliRunner().invoke(main, ["track", str(VIDEO), "--keypoints", str(tmp_path / "short.npy"),
                                    "--out", str(tmp_path / "t")])  # fmt: skip
    assert res.exit_code == 2 and len(res.output.strip().splitlines()) == 1, res.output
    assert "expected keypoints of 621 frames" in res.output
    assert not (tmp_path / "t").exists()


def test_keypoints_without_any_point_or_in_normalised_coordinates(detected):
    empty = Keypoints2D(np.full_like(detected.xy, np.nan), np.zeros_like(detected.confidence),
                        "empty.npy")  # fmt: skip
    with pytest.raises(ValueError, match=r"empty\.npy: expected at least one frame with a "):
        track(VIDEO, keypoints=empty, frames=2)
    unit = Keypoints2D(detected.xy / np.array([1280.0, 720.0]), detected.confidence, "unit.npy")
    with pytest.raises(ValueError, match=r"unit\.npy: expected pixels of the 1280x720 frames"):
        track(VIDEO, keypoints=unit, frames=2)


def test_all_nan_frames_are_frames_without_a_hand_and_points_far_outside_are_dropped(
    detected,
):
    xy, c = detected.xy.copy(), detected.confidence.copy()
    xy[2:4], c[2:4] = np.nan, 0.0  # two frames where the detector found no hand
    xy[1, 8] = (5000.0, 300.0)  # the index tip three frames to the right
    tr = track(VIDEO, keypoints=Keypoints2D(xy, c, "k.npy"), scale=0.5, frames=6,
               keypoint_every=1, carry="none")  # fmt: skip
    q = tr.quality
    assert q.keypoints.tolist() == [True, True, False, False, True, True]
    assert q.no_hand.tolist() == [False, False, True, True, False, False]
    assert tr.options["outside_keypoints"] == 1
    assert not q.lost.any()
    assert np.isnan(tr.poses[2:4]).all() and np.isfinite(tr.poses[[0, 1, 4, 5]]).all()


def test_a_left_hand_tracked_as_right_is_an_error_and_auto_takes_the_handedness(detected, tmp_path):
    left = with_side(detected, "left")
    with pytest.raises(ValueError, match=r"hand: expected the side the keypoints' handedness "
                                         r"gives \(left\); got right"):  # fmt: skip
        track(VIDEO, keypoints=left, frames=2, hand="right")
    assert track(VIDEO, keypoints=left, frames=2, scale=0.5).shape.side == "left"  # auto
    write_keypoints(tmp_path / "k.npz", with_side(detected, "right"))
    res = CliRunner().invoke(main, ["track", str(VIDEO), "--keypoints", str(tmp_path / "k.npz"),
                                    "--hand", "auto", "--scale", "0.5", "--frames", "3",
                                    "--out", str(tmp_path / "t"), "--no-video"])  # fmt: skip
    assert res.exit_code == 0, res.output
    with pytest.raises(ValueError, match="hand: auto expected a recording with a detector or "):
        track(VIDEO, hand="auto", detector="none", frames=2)


def test_cameras_whose_handedness_disagree_give_the_side_of_most_frames_or_take_the_given():
    from handvar.vision.keypoints import hand_side

    xy = np.zeros((10, 21, 2))
    xy[:, 9, 1] = 50.0

    def camera(rights: int) -> Keypoints2D:
        sides = np.array(["right"] * rights + ["left"] * (10 - rights))
        return Keypoints2D(xy, np.ones((10, 21)), handedness=sides)

    # one view labels the hand right on 8 of 10 frames, the other left on 7: 11 right
    assert hand_side([camera(8), camera(3)], "auto") == "right"
    assert hand_side([camera(2), None, camera(7)], "auto") == "left"  # 9 right, 11 left
    for given in ("right", "left"):  # labels at odds with each other overrule nothing
        assert hand_side([camera(8), camera(3)], given) == given
    with pytest.raises(ValueError, match="split evenly between right and left"):
        hand_side([camera(7), camera(3)], "auto")
    # agreeing cameras still check a given side against their word
    with pytest.raises(ValueError, match=r"handedness gives \(right\); got left"):
        hand_side([camera(8), camera(9)], "left")


def test_init_checks_the_side_against_the_handedness_and_auto_takes_it(detected, tmp_path):
    write_keypoints(tmp_path / "k.npz", with_side(detected, "left"))
    write_keypoints(tmp_path / "k.npy", detected)

    def init(keypoints, hand, out):
        return CliRunner().invoke(main, ["init", str(VIDEO), "--keypoints", str(keypoints),
                                         "--scale", "0.5", "--hand", hand,
                                         "--out", str(tmp_path / out)])  # fmt: skip

    res = init(tmp_path / "k.npz", "right", "right.txt")
    assert res.exit_code == 2 and len(res.output.strip().splitlines()) == 1, res.output
    assert "--hand: expected the side the --keypoints' handedness gives (left); got right" in (
        res.output
    )
    assert not (tmp_path / "right.txt").exists()
    res = init(tmp_path / "k.npy", "auto", "none.txt")
    assert res.exit_code == 2 and "--hand: auto expected --keypoints with handedness" in res.output
    for hand in ("auto", "left"):
        res = init(tmp_path / "k.npz", hand, f"{hand}.txt")
        assert res.exit_code == 0, res.output
    np.testing.assert_array_equal(np.loadtxt(tmp_path / "auto.txt"),
                                  np.loadtxt(tmp_path / "left.txt"))  # fmt: skip
    res = init(tmp_path / "k.npy", "right", "right.txt")  # the same points, the other hand
    assert res.exit_code == 0, res.output
    assert not np.allclose(np.loadtxt(tmp_path / "auto.txt"), np.loadtxt(tmp_path / "right.txt"))


@pytest.fixture(scope="module")
def stereo_cases(tmp_path_factory):
    """A right and a left hand making counting gestures before a calibrated stereo pair
    (`realistic_case`, written as a user has them), and per camera their true points'
    projections labelled the other side on every frame: a detector run on each view can
    call the hand of both views the other side."""
    from handvar.evaluation.realistic import realistic_case

    out = {}
    for side, label in (("right", "left"), ("left", "right")):
        case = realistic_case("counting", cameras=2, side=side, seed=1, frames=(0, 6),
                              size=(320, 180), distractor="none", skin="medium",
                              background=np.full((90, 160, 3), 110, np.uint8))  # fmt: skip
        paths = case.write(tmp_path_factory.mktemp(side))
        labelled = [Keypoints2D(xy, np.ones(xy.shape[:2]), handedness=np.full(len(xy), label))
                    for xy in case.truth_2d]  # fmt: skip
        out[side] = case, paths, labelled
    return out


def test_two_cameras_keypoint_files_take_the_side_from_the_hands_shape(stereo_cases):
    from handvar.vision.keypoints import hand_side

    case, _, right = stereo_cases["right"]
    cameras = case.rig.cameras
    assert hand_side(right, "auto") == "left"  # the labels alone
    assert hand_side(right, "auto", cameras) == "right"
    assert hand_side(stereo_cases["left"][2], "auto", cameras) == "left"
    assert hand_side(right, "right", cameras) == "right"  # the labels it overrules say nothing
    assert hand_side(right, "left", cameras) == "left"  # a side the labels give is taken
    unlabelled = [Keypoints2D(k.xy, k.confidence) for k in right]
    assert hand_side(unlabelled, "auto", cameras) == "right"
    with pytest.raises(ValueError, match="or two calibrated cameras' keypoints; got neither"):
        hand_side(unlabelled[:1], "auto", cameras[:1])
    # with the labels' scores the confidences are weighed for the side, as the detector
    # inside weighs its detections: by the score alone where the shape overrules them
    from handvar.vision.keypoints import check_keypoints

    scored = [dataclasses.replace(k, handedness_score=np.full(k.n_frames, 0.9)) for k in right]
    sizes = [c.size for c in cameras]
    out, side, _ = check_keypoints(scored, case.n_frames, sizes, "auto", cameras=cameras)
    assert side == "right" and np.allclose(out[0].confidence, 0.9)
    mixed = dataclasses.replace(scored[0], handedness=np.array(["left"] * 4 + ["right"] * 2))
    out, side, _ = check_keypoints([mixed], case.n_frames, sizes[:1], "auto")  # labels count
    assert side == "left" and np.allclose(out[0].confidence, [[0.9]] * 4 + [[0.1]] * 2)
    out, side, _ = check_keypoints(scored, case.n_frames, sizes, "left")  # given, no cameras
    assert np.allclose(out[1].confidence, 0.9)
    right_given = check_keypoints(scored, case.n_frames, sizes, "right", cameras=cameras)[0]
    assert np.allclose(right_given[1].confidence, 0.9)  # the shape confirms; labels overruled


@pytest.mark.parametrize("side", ["right", "left"])
def test_init_and_track_with_two_cameras_keypoint_files_take_the_side_of_the_hands_shape(
    stereo_cases, side, tmp_path
):
    from handvar.pipeline import Track

    _, paths, labelled = stereo_cases[side]
    cams = [str(p) for p in paths["frames"]]
    common = ["--calib", str(paths["calib"])]
    for j, k in enumerate(labelled):
        write_keypoints(tmp_path / f"k{j}.npz", k)
        common += ["--keypoints", str(tmp_path / f"k{j}.npz")]

    def run(*args: str):
        res = CliRunner().invoke(main, [*args, *common])
        assert res.exit_code == 0, res.output

    run("init", *cams, "--hand", "auto", "--out", str(tmp_path / "x0.txt"))
    run("init", *cams, "--hand", side, "--out", str(tmp_path / "given.txt"))
    np.testing.assert_array_equal(np.loadtxt(tmp_path / "x0.txt"),
                                  np.loadtxt(tmp_path / "given.txt"))  # fmt: skip
    run("track", ",".join(cams), "--hand", "auto", "--init", str(tmp_path / "x0.txt"),
        "--frames", "2", "--no-video", "--out", str(tmp_path / "t"))  # fmt: skip
    assert Track.load(tmp_path / "t").hand.shape.side == side
