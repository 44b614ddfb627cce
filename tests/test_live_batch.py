"""Live and real-time tracking (the online form of the pipeline) and many recordings on Dask."""

from __future__ import annotations

import itertools
import os
import re
import time
from pathlib import Path

import cv2
import numpy as np
import pytest
from click.testing import CliRunner

from handvar.cli import main
from handvar.data import example_path
from handvar.hand.anthropometry import HandShape
from handvar.hand.kinematics import HandModel

VIDEO = example_path("video")
KEYPOINTS = example_path("video-keypoints")


def _in_front() -> np.ndarray:
    """A first pose 40 cm in front of the camera: no pose search (the tests stay fast)."""
    from handvar.hand.kinematics import named_pose

    x = named_pose("open")
    x[2] += 400.0
    return x


class FakeClock:
    """Simulated seconds: `sleep` and the consumer's work advance it, nothing else."""

    def __init__(self) -> None:
        self.now = 0.0

    def __call__(self) -> float:
        return self.now

    def sleep(self, seconds: float) -> None:
        self.now += seconds


# --- real-time playback ----------------------------------------------------------------


def test_paced_frames_drops_what_a_slow_consumer_misses():
    """10 fps, 0.25 s per frame: the schedule worked out by hand in the comments."""
    from handvar.pipeline import paced_frames

    clock, dropped, got = FakeClock(), [], []
    frames = ((i, [f"image {i}"]) for i in range(10))
    for index, seconds, images in paced_frames(
        frames, 10.0, dropped, clock=clock, sleep=clock.sleep
    ):
        assert images == [f"image {index}"]
        got.append((index, seconds, clock.now + 0.25))  # finished 0.25 s later
        clock.now += 0.25
    # t=0 frame 0; t=.25 frames 1, 2 due: 2; t=.5: 5; t=.75: 7; t=1: 9 (the last)
    assert [g[0] for g in got] == [0, 2, 5, 7, 9]
    assert dropped == [1, 3, 4, 6, 8]
    latency = [finish - capture for _, capture, finish in got]
    np.testing.assert_allclose(latency, [0.25, 0.3, 0.25, 0.3, 0.35])


def test_paced_frames_waits_for_a_fast_consumer():
    from handvar.pipeline import paced_frames

    clock, dropped, played = FakeClock(), [], []
    for index, seconds, _ in paced_frames(
        ((i, []) for i in range(5)), 25.0, dropped, clock=clock, sleep=clock.sleep
    ):
        played.append((index, clock.now))
        assert seconds == pytest.approx(index / 25.0)
    assert dropped == []
    np.testing.assert_allclose([t for _, t in played], np.arange(5) / 25.0)


def test_realtime_on_the_example_video_reports_latency_and_drops(tmp_path):
    out = tmp_path / "rt"
    result = CliRunner().invoke(
        main,
        ["track", str(VIDEO), "--realtime", "--frames", "30", "--scale", "0.25",
         "--keypoints", str(KEYPOINTS), "--no-video", "--out", str(out)],
    )  # fmt: skip
    assert result.exit_code == 0, result.output
    line = result.output.strip().splitlines()[-1]
    m = re.fullmatch(
        r"realtime: 30 frames, (\d+) dropped, latency median (\d+) ms, 95 % (\d+) ms", line
    )
    assert m, line
    from handvar.pipeline import Track

    track = Track.load(out)
    assert track.n_frames == 30 and not track.dropped[0]
    assert int(track.dropped.sum()) == int(m.group(1))
    tracked = ~track.dropped
    assert np.isnan(track.latency[track.dropped]).all()
    assert (track.latency[tracked] > 0).all()
    # latency = finish - capture, and a frame finishes after the one before it
    finish = track.latency[tracked] + np.flatnonzero(tracked) / 30.0
    assert np.all(np.diff(finish) > 0)
    assert int(m.group(2)) == round(1000 * np.median(track.latency[tracked]))
    # a dropped frame holds the pose of the last frame tracked
    for t in np.flatnonzero(track.dropped):
        last = np.flatnonzero(tracked[:t])[-1]
        np.testing.assert_array_equal(track.poses[t], track.poses[last])
    table = track.to_dataframe()
    assert table["dropped"].sum() == track.dropped.sum()


@pytest.mark.parametrize("carry", ["forward", "both"])
def test_online_route_equals_the_whole_recording_route(carry):
    """track() frame by frame = silhouettes, carried keypoints and recovery run apart."""
    from handvar.hand.anthropometry import HandShape
    from handvar.hand.kinematics import HandModel
    from handvar.pipeline import track
    from handvar.predictors.catalogue import make_predictor
    from handvar.tracking import CostSettings, Tracker, TrackerSettings
    from handvar.tracking.recovery import track_with_recovery
    from handvar.vision.keypoints import read_keypoints
    from handvar.vision.sources import open_source

    # frames 0-3: two detections and the frames between them (none after the last)
    online = track(str(VIDEO), keypoints=str(KEYPOINTS), scale=0.25, frames=4,
                   keypoint_every=3, carry=carry)  # fmt: skip
    source = open_source([str(VIDEO)], scale=0.25)
    detected = [read_keypoints(KEYPOINTS).every(3)]
    sequence = source.to_sequence(stop=4, allow_empty=True, wrist=False)
    carried = source.carried_keypoints(detected, stop=4, both=carry == "both")
    np.testing.assert_array_equal(online.sequence.masks, sequence.masks)
    tracker = Tracker(
        source.rig, HandModel(HandShape.from_size(185.0)), make_predictor("rvar"),
        np.random.default_rng(0), TrackerSettings(cost=CostSettings(keypoint_tips="pad")),
    )  # fmt: skip
    whole = track_with_recovery(
        tracker, list(sequence.masks), None,
        keypoints=lambda i: [k.frame(i) for k in carried], cut_wrist=True,
    )  # fmt: skip
    np.testing.assert_array_equal(online.poses, whole.track.poses)
    np.testing.assert_array_equal(online.keypoints[0].to_array(), carried[0].to_array()[:4])
    assert online.dropped is None and online.latency is None


# --- a live camera -----------------------------------------------------------------------


def test_camera_source_hands_out_the_newest_frame():
    """A video read as a camera (the same VideoCapture calls): every frame read once."""
    from handvar.vision.sources import open_camera

    camera = open_camera(0, capture=cv2.VideoCapture(str(VIDEO)), scale=0.25)
    assert camera.image_size == (320, 180)
    got = []
    for index, seconds, images in camera.stream(stop=40):
        got.append((index, seconds))
        assert images[0].shape == (180, 320, 3)
        time.sleep(0.02)  # slower than the reader: frames are skipped
    camera.close()
    indices = [i for i, _ in got]
    assert indices == sorted(indices) and got[0] == (0, 0.0)
    assert sorted(indices + camera.dropped) == list(range(indices[-1] + 1))
    assert all(b[1] >= a[1] for a, b in itertools.pairwise(got))


def test_tracking_a_camera_gives_a_realtime_track():
    from handvar.pipeline import track
    from handvar.vision.sources import open_camera

    camera = open_camera(0, capture=cv2.VideoCapture(str(VIDEO)), scale=0.25)
    result = track(camera, frames=3, init=_in_front())
    assert result.n_frames >= 1 and result.dropped is not None
    assert result.n_frames == int((~result.dropped).sum() + result.dropped.sum())
    assert result.realtime_summary().startswith(f"realtime: {result.n_frames} frames")
    with pytest.raises(ValueError, match="calib, fov, scale, keypoints"):
        track(camera, scale=0.5)


# --- bad input -----------------------------------------------------------------------------


@pytest.mark.parametrize(
    ("args", "named"),
    [
        (["--camera", "7"], "--camera"),
        (["benchmark", "--realtime"], "--realtime"),
        ([str(VIDEO), "--camera", "0"], "--camera"),
        ([str(VIDEO), "--realtime", "--show"], "--show"),
        ([str(VIDEO), "--show"], "--show"),
        ([str(VIDEO), "--realtime", "--no-recover"], "--realtime"),
        ([str(VIDEO), "--no-recover", "--silhouette-term", "0.05"], "--silhouette-term"),
        (["benchmark", "--silhouette-term", "0.05", "--frames", "2"], "--silhouette-term"),
        ([str(VIDEO), "--realtime", "--carry", "both", "--keypoints", str(KEYPOINTS)],
         "--realtime"),
        ([], "SEQ"),
        ([str(VIDEO), str(VIDEO)], "SEQ"),
        ([str(VIDEO), "benchmark", "--realtime"], "--realtime"),
        ([str(VIDEO), "benchmark", "--keypoints", str(KEYPOINTS)], "--keypoints"),
        ([str(VIDEO), "--scheduler", "tcp://127.0.0.1:1"], "--scheduler"),
    ],
)  # fmt: skip
def test_bad_live_and_batch_input_is_one_line(tmp_path, args, named):
    out = tmp_path / "out"
    out.mkdir()
    (out / "kept.txt").write_text("mine")
    result = CliRunner().invoke(main, ["track", *args, "--out", str(out)])
    assert result.exit_code == 2, result.output
    lines = result.output.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("handvar: error: ") and named in lines[0]
    assert sorted(os.listdir(out)) == ["kept.txt"]
    assert (out / "kept.txt").read_text() == "mine"


def test_output_under_a_file_is_refused(tmp_path):
    (tmp_path / "file").write_text("x")
    for args in (["--camera", "7"], [str(VIDEO), "benchmark"]):
        result = CliRunner().invoke(main, ["track", *args, "--out", str(tmp_path / "file" / "o")])
        assert result.exit_code == 2 and "--out" in result.output
    assert (tmp_path / "file").read_text() == "x"


# --- many recordings ------------------------------------------------------------------------


@pytest.fixture(scope="module")
def recordings(tmp_path_factory) -> list[str]:
    """Two short recordings (image folders of the example video at 1/4 size) and a broken one."""
    root = tmp_path_factory.mktemp("recordings")
    capture = cv2.VideoCapture(str(VIDEO))
    frames = [cv2.resize(capture.read()[1], (320, 180), interpolation=cv2.INTER_AREA)]
    for _ in range(2):
        frames.append(cv2.resize(capture.read()[1], (320, 180), interpolation=cv2.INTER_AREA))
    capture.release()
    out = []
    for name, first in (("clip_a", 0), ("clip_c", 1)):
        folder = root / name
        folder.mkdir()
        for t in range(2):
            cv2.imwrite(str(folder / f"{t:03d}.png"), frames[first + t])
        out.append(str(folder))
    broken = root / "clip_b.mp4"
    broken.write_bytes(b"not a video" * 100)
    return [out[0], str(broken), out[1]]


def _threads_client():
    from distributed import Client, LocalCluster

    cluster = LocalCluster(
        n_workers=1, threads_per_worker=2, processes=False, dashboard_address=":0",
        silence_logs=40,
    )  # fmt: skip
    return Client(cluster), cluster


def test_a_broken_recording_fails_alone_and_a_rerun_does_only_the_missing(recordings, tmp_path):
    from handvar.batch import track_many
    from handvar.pipeline import Track

    client, cluster = _threads_client()
    try:
        seen = []
        summary = track_many(
            recordings, tmp_path, client=client, video=False, frames=2, init=_in_front(),
            on_done=lambda name, error, line: seen.append((name, error)),
        )  # fmt: skip
        assert set(summary.computed) == {"clip_a", "clip_c"}
        assert list(summary.failed) == ["clip_b"]
        error = summary.failed["clip_b"]
        assert "clip_b.mp4" in error and "\n" not in error
        assert sorted(n for n, _ in seen) == ["clip_a", "clip_b", "clip_c"]
        assert sorted(os.listdir(tmp_path)) == ["clip_a", "clip_c"]  # nothing else left
        for name in ("clip_a", "clip_c"):
            assert Track.load(tmp_path / name).n_frames == 2
        # an interrupted run: one folder missing, a temporary of the killed save left
        import shutil

        shutil.rmtree(tmp_path / "clip_c")
        (tmp_path / ".clip_c.handvar-x1y2.tmp").mkdir()
        before = (tmp_path / "clip_a" / "poses.csv").stat().st_mtime_ns
        again = track_many(
            [recordings[0], recordings[2]], tmp_path, client=client, video=False,
            frames=2, init=_in_front(),
        )  # fmt: skip
        assert again.already_done == ("clip_a",) and again.computed == ("clip_c",)
        assert (tmp_path / "clip_a" / "poses.csv").stat().st_mtime_ns == before
        assert sorted(os.listdir(tmp_path)) == ["clip_a", "clip_c"]
    finally:
        client.close()
        cluster.close()


def test_batch_on_the_command_line_exits_2_naming_the_failure(recordings, tmp_path):
    np.save(tmp_path / "init.npy", _in_front())
    result = CliRunner().invoke(
        main,
        ["track", *recordings, "--frames", "2", "--no-video", "--init", str(tmp_path / "init.npy"),
         "--workers", "1", "--out", str(tmp_path / "out")],
    )  # fmt: skip
    assert result.exit_code == 2, result.output
    errors = [line for line in result.output.splitlines() if line.startswith("handvar: error")]
    assert len(errors) == 2 and "clip_b.mp4" in errors[0]
    assert errors[1] == "handvar: error: 1 of 3 recordings failed"
    assert sorted(os.listdir(tmp_path / "out")) == ["clip_a", "clip_c"]


def dies_once(recording, directory, keypoints, options, video):
    """A task whose worker process dies on its first attempt at each recording."""
    from handvar.batch import track_one

    marker = Path(directory).with_name(f"{Path(directory).name}.attempted")
    if not marker.exists():
        marker.write_text("1")
        os._exit(1)  # the worker process dies: no exception, no clean-up
    return track_one(recording, directory, keypoints, options, video)


@pytest.mark.slow
def test_a_killed_worker_is_replaced_and_every_recording_finishes(recordings, tmp_path):
    from distributed import Client, LocalCluster

    from handvar.batch import track_many

    out = tmp_path / "out"
    cluster = LocalCluster(
        n_workers=2, threads_per_worker=1, processes=True, dashboard_address=":0",
        silence_logs=50,
    )  # fmt: skip
    client = Client(cluster)
    try:
        summary = track_many(
            [recordings[0], recordings[2]], out, client=client, video=False,
            frames=2, init=_in_front(), task=dies_once,
        )  # fmt: skip
    finally:
        client.close()
        cluster.close()
    assert set(summary.computed) == {"clip_a", "clip_c"} and not summary.failed
    assert (out / "clip_a.attempted").exists() and (out / "clip_c.attempted").exists()
    assert sorted(p.name for p in out.iterdir() if p.is_dir()) == ["clip_a", "clip_c"]


def test_the_preview_window_draws_the_points_the_track_reports(monkeypatch):
    """``--show`` draws each frame as the track's overlay does: the 21 points where the
    detector marks them (the fingertip pads), not the skeleton's finger ends, on the
    hand as its shape is fitted (after the first 12 frames with keypoints, the track's
    own points), not as given."""
    import handvar.render
    from handvar.cli.track import _track_one

    drawn = []
    monkeypatch.setattr(cv2, "imshow", lambda *args: None)
    monkeypatch.setattr(cv2, "waitKey", lambda *args: -1)
    monkeypatch.setattr(cv2, "destroyAllWindows", lambda: None)
    real = handvar.render.overlay_views

    def overlay_views(hand, rig, backgrounds, pose):
        drawn.append(hand.landmarks(pose) if np.isfinite(pose).all() else None)
        return real(hand, rig, backgrounds, pose)

    monkeypatch.setattr(handvar.render, "overlay_views", overlay_views)
    track = _track_one(str(VIDEO), show=True, keypoints=str(KEYPOINTS), hand="right",
                       hand_length=185.0, model="spheres", frames=14, scale=0.5)  # fmt: skip
    assert len(drawn) == 14 and drawn[-1] is not None
    np.testing.assert_allclose(drawn[-1], track.joints[-1], atol=1e-6)
    given = HandModel(HandShape.from_size(185.0, side="right"), tips="pad")
    moved = np.linalg.norm(given.landmarks(track.poses[-1]) - track.joints[-1], axis=1)
    assert moved.max() > 1.0  # mm: the fitted shape is not the given one
