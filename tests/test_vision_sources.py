"""Tests of handvar.vision.sources: cameras, frame readers, checks, overlays."""

from __future__ import annotations

import math
from pathlib import Path

import cv2
import numpy as np
import pytest

from handvar.camera import Camera, Rig
from handvar.hand import HandModel, named_pose
from handvar.render import render_rgb, silhouette_of_spheres
from handvar.render.overlay import OverlayWriter, overlay_frame
from handvar.vision import EmptySilhouetteError
from handvar.vision.sources import assumed_camera, open_frames, open_source


def random_frames(n: int, size=(96, 64), seed: int = 0) -> list[np.ndarray]:
    w, h = size
    rng = np.random.default_rng(seed)
    # smooth images survive video compression well enough to compare
    small = rng.integers(0, 256, (n, h // 8, w // 8, 3), dtype=np.uint8)
    return [cv2.resize(s, (w, h), interpolation=cv2.INTER_CUBIC) for s in small]


def write_folder(folder: Path, frames, names=None) -> Path:
    folder.mkdir(parents=True, exist_ok=True)
    for k, f in enumerate(frames):
        name = names[k] if names else f"frame_{k}.png"
        assert cv2.imwrite(str(folder / name), f)
    return folder


def write_video(path: Path, frames, fps: float = 25.0) -> Path:
    h, w = frames[0].shape[:2]
    writer = cv2.VideoWriter(str(path), cv2.VideoWriter_fourcc(*"MJPG"), fps, (w, h))
    assert writer.isOpened()
    for f in frames:
        writer.write(f)
    writer.release()
    return path


# --- cameras ---------------------------------------------------------------------------


def test_assumed_camera_field_of_view_reaches_the_image_edges():
    cam = assumed_camera((1280, 720), fov=60.0)
    z = 800.0
    edge = np.array([[z * math.tan(math.radians(30.0)), 0.0, z]])
    # the left edge of pixel 0 is u = -0.5, the right edge of the last pixel W - 0.5
    np.testing.assert_allclose(cam.project(edge), [[1279.5, 359.5]], atol=1e-9)
    np.testing.assert_allclose(cam.project(edge * [-1, 1, 1]), [[-0.5, 359.5]], atol=1e-9)
    assert cam.center.tolist() == [0.0, 0.0, 0.0]
    with pytest.raises(ValueError, match=r"fov: expected a field of view in \(0, 180\)"):
        assumed_camera((640, 480), fov=180.0)


def test_scale_camera_matches_cv2_resize_of_a_rendered_silhouette():
    hand = HandModel()
    cam = Camera(700.0, 690.0, 330.0, 250.0, dist=[-0.1, 0.02, 0.001, -0.001, 0.0],
                 t=[0.0, -90.0, 500.0], size=(640, 480))  # fmt: skip
    centres, radii = hand.world_spheres(named_pose("spread"))
    full = silhouette_of_spheres(centres, radii, cam, coverage="centre").astype(np.float32)
    small_cam = cam.scaled(0.5)
    assert small_cam.size == (320, 240)
    resized = cv2.resize(full, small_cam.size, interpolation=cv2.INTER_AREA) > 0.5
    direct = silhouette_of_spheres(centres, radii, small_cam, coverage="centre")
    iou = (resized & direct).sum() / (resized | direct).sum()
    assert iou > 0.97
    # and the analytic pixel map u' = (u + 1/2) s - 1/2 for a 3D point
    p = np.array([[20.0, 40.0, 30.0]])
    np.testing.assert_allclose(small_cam.project(p), (cam.project(p) + 0.5) * 0.5 - 0.5)


# --- frame readers ---------------------------------------------------------------------


def test_image_folder_round_trip_in_natural_order(tmp_path):
    frames = random_frames(11)
    names = [f"img{k}.png" for k in range(11)]  # img10 must come after img9
    reader = open_frames(write_folder(tmp_path / "cam", frames, names))
    assert (reader.kind, reader.size, reader.n_frames) == ("folder", (96, 64), 11)
    got = list(reader.frames(start=2))
    assert [t for t, _ in got] == list(range(2, 11))
    for t, image in got:
        np.testing.assert_array_equal(image, frames[t])


def test_video_round_trip(tmp_path):
    frames = random_frames(8)
    reader = open_frames(write_video(tmp_path / "clip.avi", frames, fps=25.0))
    assert (reader.kind, reader.size, reader.n_frames, reader.fps) == ("video", (96, 64), 8, 25.0)
    got = list(reader.frames(start=3, stop=6))
    assert [t for t, _ in got] == [3, 4, 5]
    for t, image in got:  # MJPEG is lossy: the decoded frame is nearest to its original
        diffs = [np.abs(image.astype(int) - f).mean() for f in frames]
        assert int(np.argmin(diffs)) == t and diffs[t] < 10.0


def test_source_frames_step_and_scale(tmp_path):
    frames = random_frames(7)
    source = open_source(write_folder(tmp_path / "cam", frames), scale=0.5)
    assert source.image_size == (48, 32) and source.rig[0].size == (48, 32)
    assert not source.calibrated and source.fps == 30.0
    got = list(source.frames(start=1, step=3))
    assert [t for t, _ in got] == [1, 4]
    expected = cv2.resize(frames[4], (48, 32), interpolation=cv2.INTER_AREA)
    np.testing.assert_array_equal(got[1][1][0], expected)


@pytest.mark.parametrize("kind", ["folder", "video"])
def test_frames_read_ahead_in_order_and_stopping_early_leaves_no_reader(tmp_path, kind):
    import threading

    frames = random_frames(9, seed=5)
    path = (write_folder(tmp_path / "cam", frames) if kind == "folder"
            else write_video(tmp_path / "clip.avi", frames))  # fmt: skip
    cap = cv2.VideoCapture(str(path / "frame_%d.png" if kind == "folder" else path))
    direct = [cap.read()[1] for _ in range(9)]  # OpenCV alone, one frame at a time
    cap.release()
    # Readers of other tests in this process may wait for the collector: count ours only.
    before = set(threading.enumerate())
    reader = open_frames(path)
    for t, image in reader.frames():
        np.testing.assert_array_equal(image, direct[t])
    frames_iter = reader.frames(start=1)
    assert next(frames_iter)[0] == 1 and next(frames_iter)[0] == 2
    assert [t for t in set(threading.enumerate()) - before if t.name.startswith("handvar-read")]
    frames_iter.close()  # the reads queued ahead are cancelled, the one running waited for
    assert not [t for t in set(threading.enumerate()) - before if t.name.startswith("handvar-read")]


# --- checks ----------------------------------------------------------------------------


def test_unreadable_inputs_name_the_file(tmp_path):
    with pytest.raises(ValueError, match=r"nothing\.mp4: no such video file or image folder"):
        open_frames(tmp_path / "nothing.mp4")
    fake = tmp_path / "fake.mp4"
    fake.write_text("not a video\n")
    with pytest.raises(ValueError, match=r"fake\.mp4: not a readable video"):
        open_frames(fake)
    (tmp_path / "empty").mkdir()
    with pytest.raises(ValueError, match="empty: expected a folder of images"):
        open_frames(tmp_path / "empty")
    folder = write_folder(tmp_path / "mixed", random_frames(2))
    assert cv2.imwrite(str(folder / "frame_2.png"), np.zeros((10, 10, 3), np.uint8))
    with pytest.raises(ValueError, match=r"frame_2.png: frame 2 is 10x10 pixels; expected 96x64"):
        list(open_frames(folder).frames())


def test_a_truncated_video_is_refused_or_read_to_where_it_stops(tmp_path):
    from handvar.vision.frames import ShortVideoWarning

    video = write_video(tmp_path / "cut.avi", random_frames(12, seed=3))
    whole = video.read_bytes()
    video.write_bytes(whole[: len(whole) // 2])
    cap = cv2.VideoCapture(str(video))  # what OpenCV itself claims and decodes
    claimed, decoded = int(cap.get(cv2.CAP_PROP_FRAME_COUNT)), 0
    while cap.read()[0]:
        decoded += 1
    cap.release()
    assert 1 <= decoded < claimed == 12
    expected = rf"cut\.avi: decoding stopped after {decoded} of the 12 frames the container"
    with pytest.raises(ValueError, match=expected):
        list(open_source(video).frames())
    with pytest.raises(ValueError, match=expected):  # skipping to a frame beyond the end
        list(open_frames(video).frames(decoded + 1, decoded + 2))
    assert len(list(open_frames(video).frames(0, decoded))) == decoded  # all there: silent
    with pytest.warns(ShortVideoWarning, match=expected):
        frames = list(open_source(video, allow_short=True).frames())
    assert [i for i, _ in frames] == list(range(decoded))


def test_a_camera_matrix_the_model_cannot_hold_is_refused(tmp_path):
    import re

    good = tmp_path / "good.yml"
    Rig.default().save(good)
    assert Rig.load(good).allclose(Rig.default())
    text = good.read_text()
    for entry, value in [((2, 2), 0.0), ((0, 1), 500.0), ((2, 0), 0.1)]:
        # K of the first camera, as the file lays it out (row-major "data: [...]")
        data = re.search(r"camera_matrix: !!opencv-matrix.*?data: \[(.*?)\]", text, re.S)
        numbers = data.group(1).split(",")
        numbers[3 * entry[0] + entry[1]] = f" {value}"
        bad = tmp_path / f"k{entry[0]}{entry[1]}.yml"
        bad.write_text(text[: data.start(1)] + ",".join(numbers) + text[data.end(1) :])
        i, j = entry
        with pytest.raises(ValueError, match=rf"k{i}{j}\.yml: key cameras\[0\]\.'camera_matrix'"
                           rf": expected .*; got K\[{i}\]\[{j}\] = {value:g}"):  # fmt: skip
            Rig.load(bad)


def test_calibration_that_does_not_fit(tmp_path):
    folder = write_folder(tmp_path / "cam", random_frames(2, size=(640, 480)))
    calib = tmp_path / "stereo.yml"
    Rig.default().save(calib)
    with pytest.raises(ValueError, match=r"stereo.yml: calibrates 2 camera\(s\) \(left, right\)"):
        open_source([folder], calib)
    small = write_folder(tmp_path / "small", random_frames(2, size=(320, 240)))
    with pytest.raises(
        ValueError, match=r"small: frames are 320x240 pixels; camera 'right' of .*stereo\.yml is "
        "calibrated for 640x480",
    ):  # fmt: skip
        open_source([folder, small], calib)
    with pytest.raises(ValueError, match="calibration: expected a calibration file for 2 cameras"):
        open_source([folder, small])
    with pytest.raises(ValueError, match="fov: expected no field of view with a calibration"):
        open_source([folder, folder], calib, fov=50.0)
    source = open_source([folder, folder], calib, scale=0.5)
    assert source.calibrated and source.rig.names == ("left", "right")
    assert source.rig["left"].allclose(Rig.default()["left"].scaled(0.5))


def test_a_calibration_without_an_image_size_is_taken_for_the_frames(tmp_path):
    folder = write_folder(tmp_path / "cam", random_frames(2, size=(320, 240)))
    calib = tmp_path / "camera.yml"  # no image_width, image_height
    fs = cv2.FileStorage(str(calib), cv2.FILE_STORAGE_WRITE)
    fs.write("camera_matrix", np.array([[300.0, 0, 160], [0, 300, 120], [0, 0, 1]]))
    fs.release()
    source = open_source([folder], calib, scale=0.5)
    assert source.full_rig[0].size == (320, 240) and source.rig[0].size == (160, 120)


def test_empty_silhouette_names_the_file_and_frame(tmp_path):
    grey = np.full((64, 96, 3), 120, np.uint8)  # no skin colour anywhere
    source = open_source(write_folder(tmp_path / "cam", [grey, grey]))
    with pytest.raises(EmptySilhouetteError, match=r"camera 'cam', frame 1: empty silhouette"):
        list(source.silhouettes(start=1))


def test_to_sequence_keeps_masks_and_colour_in_rgb_order(tmp_path):
    rig = Rig((assumed_camera((320, 240)),))
    pose = named_pose("spread")
    pose[:3] = [0.0, 70.0, 450.0]
    rgb = render_rgb(HandModel(), pose, rig, background="clutter")[0]
    source = open_source(write_folder(tmp_path / "cam", [rgb[:, :, ::-1]] * 3))
    seq = source.to_sequence(stop=2, rgb=True, wrist=False)
    assert seq.n_frames == 2 and seq.rig.allclose(source.rig)
    np.testing.assert_array_equal(seq.rgb[1][0], rgb)
    _, _, masks = next(source.silhouettes(wrist=False))
    np.testing.assert_array_equal(seq.masks[0], masks)
    truth = silhouette_of_spheres(*HandModel().world_spheres(pose), rig[0])
    assert (masks[0] & truth).sum() / (masks[0] | truth).sum() > 0.85
    with pytest.raises(ValueError, match="start: expected a frame range inside the recording"):
        source.to_sequence(start=5)


# --- overlays --------------------------------------------------------------------------


def test_overlay_writer_writes_a_readable_video(tmp_path):
    frames = random_frames(5, size=(64, 48))
    with OverlayWriter(tmp_path / "out.mp4", 10.0) as out:
        for f in frames:
            out.write(f)
    assert out.path_written == tmp_path / "out.mp4"
    cap = cv2.VideoCapture(str(out.path_written))
    n = 0
    while cap.read()[0]:
        n += 1
    cap.release()
    assert n == 5
    assert [p.name for p in tmp_path.iterdir()] == ["out.mp4"]  # no temporary left


def test_overlay_writer_falls_back_to_png_frames(tmp_path):
    frames = random_frames(3, size=(64, 48))
    with OverlayWriter(tmp_path / "out.mp4", 10.0, codec="XXXX") as out:
        for f in frames:
            out.write(f)
    assert out.path_written == tmp_path / "out_frames"
    files = sorted(out.path_written.iterdir())
    assert [f.name for f in files] == ["frame_00000.png", "frame_00001.png", "frame_00002.png"]
    np.testing.assert_array_equal(cv2.imread(str(files[2])), frames[2])  # lossless


def test_overlay_writer_abort_keeps_the_previous_file(tmp_path):
    target = tmp_path / "out.mp4"
    target.write_bytes(b"previous")
    with pytest.raises(RuntimeError), OverlayWriter(target, 10.0) as out:
        out.write(random_frames(1, size=(64, 48))[0])
        raise RuntimeError("interrupted")
    assert target.read_bytes() == b"previous"
    assert [p.name for p in tmp_path.iterdir()] == ["out.mp4"]


def test_overlay_frame_draws_the_model_outline_where_the_model_is():
    hand = HandModel()
    rig = Rig((assumed_camera((320, 240)),))
    pose = named_pose("open")
    pose[:3] = [0.0, 70.0, 500.0]
    black = np.zeros((240, 320, 3), np.uint8)
    picture = overlay_frame(black, rig, hand, pose, thickness=2)
    drawn = picture.any(axis=2)
    centres, radii = hand.world_spheres(pose)
    model = silhouette_of_spheres(centres, radii, rig[0])
    # every drawn pixel lies within a joint marker's radius (thickness + 2 px, plus
    # anti-aliasing) of the model's silhouette, and the outline surrounds it
    distance = cv2.distanceTransform((~model).astype(np.uint8), cv2.DIST_L2, 5)
    assert drawn.sum() > 0.1 * model.sum()
    assert distance[drawn].max() <= 6.0
    with pytest.raises(ValueError, match=r"images: expected 1 frames \(one per camera\); got 2"):
        overlay_frame([black, black], rig, hand, pose)
