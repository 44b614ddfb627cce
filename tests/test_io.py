"""Sequence directories: round trips, atomic writes and every kind of damage."""

from __future__ import annotations

import json
import os
from pathlib import Path

import cv2
import numpy as np
import pytest

from handvar.camera import Camera, Rig
from handvar.io import FrameStack, Sequence, SequenceError, Truth, read_sequence, write_sequence

T = 4
W, H = 64, 48


def _rig(size=(W, H)) -> Rig:
    cams = tuple(
        Camera.look_at((sx * 110.0, 0.0, -480.0), fx=80.0, size=size, dist=[0.01, 0, 0, 0, 0])
        for sx in (-1.0, 1.0)
    )
    return Rig(cams, ("left", "right"))


def _sequence(rng, *, rgb=True, truth=True) -> Sequence:
    masks = rng.random((T, 2, H, W)) < 0.3
    return Sequence(
        name="unit",
        fps=25.0,
        rig=_rig(),
        masks=masks,
        rgb=rng.integers(0, 256, (T, 2, H, W, 3), dtype=np.uint8) if rgb else None,
        truth=Truth(rng.normal(size=(T, 26)), rng.normal(size=(T, 21, 3))) if truth else None,
        provenance={"generator": "test", "seed": 7},
    )


@pytest.fixture
def written(tmp_path):
    rng = np.random.default_rng(11)
    seq = _sequence(rng)
    out = write_sequence(seq, tmp_path / "seq")
    return seq, out


def test_round_trip_is_exact(written):
    seq, out = written
    back = read_sequence(out)
    assert back.name == seq.name and back.fps == seq.fps and back.provenance == seq.provenance
    assert back.rig.names == seq.rig.names
    assert all(a == b for a, b in zip(back.rig, seq.rig, strict=True))
    np.testing.assert_array_equal(back.masks, seq.masks)
    assert back.masks.dtype == bool
    np.testing.assert_array_equal(np.asarray(back.rgb), seq.rgb)
    np.testing.assert_array_equal(back.truth.poses, seq.truth.poses)
    np.testing.assert_array_equal(back.truth.joints, seq.truth.joints)
    assert back.n_frames == T and back.n_cameras == 2 and back.image_size == (W, H)


def test_files_follow_the_documented_layout_and_opencv_reads_them(written):
    seq, out = written
    meta = json.loads((out / "sequence.json").read_text())
    assert meta["n_frames"] == T and meta["fps"] == 25.0 and meta["image_size"] == [W, H]
    assert [c["name"] for c in meta["rig"]["cameras"]] == ["left", "right"]
    assert meta["rig"]["cameras"][0]["size"] == [W, H]
    # OpenCV, independently of our reader: white = hand; colour stored as BGR on disk
    mask = cv2.imread(str(out / "cam1" / "mask_00002.png"), cv2.IMREAD_UNCHANGED)
    np.testing.assert_array_equal(mask > 0, seq.masks[2, 1])
    bgr = cv2.imread(str(out / "cam0" / "rgb_00003.png"), cv2.IMREAD_COLOR)
    np.testing.assert_array_equal(bgr[:, :, ::-1], seq.rgb[3, 0])
    with np.load(out / "truth.npz") as data:
        assert data["poses"].shape == (T, 26) and data["joints"].shape == (T, 21, 3)


def test_lazy_reading_decodes_the_same_frames(written):
    seq, out = written
    back = read_sequence(out, lazy=True)
    assert isinstance(back.masks, FrameStack) and back.masks.shape == (T, 2, H, W)
    np.testing.assert_array_equal(back.masks[1], seq.masks[1])
    np.testing.assert_array_equal(back.masks[1:3], seq.masks[1:3])
    np.testing.assert_array_equal(back.masks[2, 0], seq.masks[2, 0])
    np.testing.assert_array_equal(np.asarray(back.masks), seq.masks)
    np.testing.assert_array_equal(back.rgb[-1], seq.rgb[-1])


def test_sequence_without_rgb_and_truth(tmp_path):
    seq = _sequence(np.random.default_rng(2), rgb=False, truth=False)
    back = read_sequence(write_sequence(seq, tmp_path / "plain"))
    assert back.rgb is None and back.truth is None
    assert not list((tmp_path / "plain" / "cam0").glob("rgb_*"))
    np.testing.assert_array_equal(back.masks, seq.masks)


# --- atomic writing ---------------------------------------------------------------------


def test_overwriting_replaces_a_sequence_and_leaves_no_temporary_files(written, tmp_path):
    _, out = written
    seq2 = _sequence(np.random.default_rng(99), rgb=False)
    write_sequence(seq2, out)
    back = read_sequence(out)
    np.testing.assert_array_equal(back.masks, seq2.masks)
    assert back.rgb is None
    assert sorted(p.name for p in tmp_path.iterdir()) == ["seq"]


def test_a_failed_write_keeps_the_previous_sequence(written, tmp_path):
    seq, out = written
    before = {p.relative_to(out): p.read_bytes() for p in out.rglob("*") if p.is_file()}

    def failing(frames):
        for t in frames:
            if t == 2:
                raise OSError("disk full")
            yield t

    with pytest.raises(OSError, match="disk full"):
        write_sequence(_sequence(np.random.default_rng(5)), out, progress=failing)
    after = {p.relative_to(out): p.read_bytes() for p in out.rglob("*") if p.is_file()}
    assert after == before
    assert sorted(p.name for p in tmp_path.iterdir()) == ["seq"]
    np.testing.assert_array_equal(read_sequence(out).masks, seq.masks)


def test_refuses_to_overwrite_something_that_is_not_a_sequence(tmp_path):
    other = tmp_path / "photos"
    other.mkdir()
    (other / "holiday.jpg").write_bytes(b"not ours")
    with pytest.raises(ValueError, match=r"path: expected a new directory.*photos"):
        write_sequence(_sequence(np.random.default_rng(0)), other)
    assert (other / "holiday.jpg").read_bytes() == b"not ours"
    empty = tmp_path / "empty"
    empty.mkdir()
    write_sequence(_sequence(np.random.default_rng(0)), empty)
    assert (empty / "sequence.json").is_file()


# --- damaged directories ---------------------------------------------------------------


def _edit_json(out: Path, edit) -> None:
    meta = json.loads((out / "sequence.json").read_text())
    edit(meta)
    (out / "sequence.json").write_text(json.dumps(meta))


def _truncate(path: Path) -> None:
    data = path.read_bytes()
    path.write_bytes(data[: len(data) // 2])


def _resize(path: Path) -> None:
    cv2.imwrite(str(path), np.zeros((H + 2, W), np.uint8))


def _set_camera_size(meta) -> None:
    meta["rig"]["cameras"][1]["size"] = [W * 2, H * 2]


def _bad_truth_shape(out: Path) -> None:
    np.savez(out / "truth.npz", poses=np.zeros((T, 25)), joints=np.zeros((T, 21, 3)))


DAMAGE = {
    "missing json": (lambda o: (o / "sequence.json").unlink(), r"sequence\.json: missing"),
    "bad json": (lambda o: (o / "sequence.json").write_text("{"), r"sequence\.json: expected JSON"),
    "missing key": (
        lambda o: _edit_json(o, lambda m: m.pop("fps")),
        r"sequence\.json: missing key 'fps'",
    ),
    "bad fps": (
        lambda o: _edit_json(o, lambda m: m.update(fps=-3)),
        r"sequence\.json: expected 'fps' to be a positive number",
    ),
    "bad camera": (
        lambda o: _edit_json(o, lambda m: m["rig"]["cameras"][0].pop("fx")),
        r"sequence\.json: cameras\[0\]: missing key 'fx'",
    ),
    "calibration size": (
        lambda o: _edit_json(o, _set_camera_size),
        r"sequence\.json: camera 1 \('right'\) is calibrated for 128x96 images",
    ),
    "camera count": (
        lambda o: _edit_json(o, lambda m: m.update(n_cameras=3)),
        r"sequence\.json: expected 3 cameras",
    ),
    "missing frame": (
        lambda o: (o / "cam1" / "mask_00002.png").unlink(),
        r"cam1/mask_00002\.png: missing frame",
    ),
    "missing rgb frame": (
        lambda o: (o / "cam0" / "rgb_00003.png").unlink(),
        r"cam0/rgb_00003\.png: missing frame",
    ),
    "missing camera": (
        lambda o: [p.unlink() for p in (o / "cam1").iterdir()] and (o / "cam1").rmdir(),
        r"cam1: missing folder of camera 1",
    ),
    "truncated frame": (
        lambda o: _truncate(o / "cam0" / "mask_00001.png"),
        r"cam0/mask_00001\.png: expected a complete PNG image",
    ),
    "not a png": (
        lambda o: (o / "cam0" / "mask_00000.png").write_bytes(b"GIF89a" + bytes(40)),
        r"cam0/mask_00000\.png: expected a PNG image",
    ),
    "wrong size frame": (
        lambda o: _resize(o / "cam1" / "mask_00003.png"),
        r"cam1/mask_00003\.png: expected 64x48 pixels .*got 64x50",
    ),
    "rgb as mask": (
        lambda o: os.replace(o / "cam0" / "rgb_00000.png", o / "cam0" / "mask_00000.png"),
        r"cam0/mask_00000\.png: expected a grey-level mask",
    ),
    "extra frame": (
        lambda o: cv2.imwrite(str(o / "cam0" / "mask_00004.png"), np.zeros((H, W), np.uint8)),
        r"cam0/mask_00004\.png: unexpected frame",
    ),
    "missing truth": (lambda o: (o / "truth.npz").unlink(), r"truth\.npz: missing"),
    "truth shape": (
        _bad_truth_shape,
        r"truth\.npz: expected 'poses' of shape \(4, 26\); got shape \(4, 25\)",
    ),
    "truth garbage": (
        lambda o: (o / "truth.npz").write_bytes(b"garbage"),
        r"truth\.npz: could not read the arrays",
    ),
}


@pytest.mark.parametrize("damage", list(DAMAGE))
def test_damaged_directories_fail_naming_the_file(written, damage):
    _, out = written
    corrupt, message = DAMAGE[damage]
    corrupt(out)
    with pytest.raises(SequenceError, match=message):
        read_sequence(out)


def test_reading_a_missing_directory_fails(tmp_path):
    with pytest.raises(SequenceError, match=r"nowhere: expected a sequence directory"):
        read_sequence(tmp_path / "nowhere")


def test_lazy_reading_reports_a_corrupt_frame_when_decoded(written):
    _, out = written
    frame = out / "cam1" / "rgb_00002.png"
    data = bytearray(frame.read_bytes())
    data[40:200] = bytes(160)  # damage the compressed data, keep header and end marker
    frame.write_bytes(bytes(data))
    back = read_sequence(out, lazy=True)
    with pytest.raises(SequenceError, match=r"cam1/rgb_00002\.png"):
        back.rgb[2]


# --- in-memory checks -------------------------------------------------------------------


def test_sequence_rejects_inconsistent_arrays():
    rng = np.random.default_rng(0)
    masks = rng.random((T, 2, H, W)) < 0.5
    with pytest.raises(ValueError, match="masks: expected a bool array"):
        Sequence("x", 25.0, _rig(), masks.astype(np.uint8))
    with pytest.raises(ValueError, match=r"masks: expected shape \(T, 2, H, W\)"):
        Sequence("x", 25.0, _rig(), masks[:, :1])
    with pytest.raises(ValueError, match="rig: expected every camera to have the image size"):
        Sequence("x", 25.0, _rig(size=(W + 1, H)), masks)
    with pytest.raises(ValueError, match="fps: expected a positive frame rate"):
        Sequence("x", 0.0, _rig(), masks)
    with pytest.raises(ValueError, match=r"rgb: expected shape \(4, 2, 48, 64, 3\)"):
        Sequence("x", 25.0, _rig(), masks, rgb=np.zeros((T, 2, H, W), np.uint8))
    with pytest.raises(ValueError, match="truth: expected 4 frames"):
        Sequence("x", 25.0, _rig(), masks, truth=Truth(np.zeros((3, 26)), np.zeros((3, 21, 3))))
    with pytest.raises(ValueError, match=r"joints: expected shape \(3, 21, 3\)"):
        Truth(np.zeros((3, 26)), np.zeros((3, 20, 3)))
    with pytest.raises(ValueError, match="provenance: expected JSON-friendly values"):
        Sequence("x", 25.0, _rig(), masks, provenance={"rng": rng})
    with pytest.raises(TypeError, match=r"seq: expected a handvar\.io\.Sequence"):
        write_sequence(masks, "/nonexistent")


def test_ground_truth_is_checked_like_a_pose(tmp_path):
    from handvar.synth.sequences import make_sequence

    seq = make_sequence("benchmark", n_frames=2)
    write_sequence(seq, tmp_path / "s")
    truth = dict(np.load(tmp_path / "s" / "truth.npz"))
    cases = [
        ("poses", (1, 2), 1e12, r"poses: expected a pose within the parameter limits; tz = "
         r"1e\+12 at frame 1 is outside \[-2000, 2000\]"),
        ("poses", (0, 5), 1e6, r"poses: .*rz = 1e\+06 at frame 0"),
        ("joints", (1, slice(None), 2), -1e4, r"joints: expected the hand in front of every "
         r"camera; it is behind or at camera 'left' at frame 1"),
    ]  # fmt: skip
    for key, entry, value, message in cases:
        bad = {k: v.copy() for k, v in truth.items()}
        bad[key][entry] = value
        np.savez(tmp_path / "s" / "truth.npz", **bad)
        with pytest.raises(SequenceError, match=r"truth\.npz: " + message):
            read_sequence(tmp_path / "s")
    np.savez(tmp_path / "s" / "truth.npz", **truth)
    np.testing.assert_array_equal(read_sequence(tmp_path / "s").truth.poses, seq.truth.poses)
