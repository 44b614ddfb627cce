"""Bad inputs to every command: one clean line, exit 2, and nothing that existed is lost.

Each case of :data:`CASES` runs one command with one wrong input and asserts (design
design §13.1, §13.4): exit status 2, exactly one line of output starting ``handvar: error:``,
naming the argument or the user's path (never a temporary), no traceback, no
temporary left behind, and every file that existed before byte-identical afterwards.
`studies/bad_inputs.py` runs the same table and prints the count of outcomes.

Cases that need FFmpeg's own stderr (a damaged video) run in a subprocess, where a C
library's output on file descriptor 2 is seen.
"""

from __future__ import annotations

import dataclasses
import os
import shlex
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from click.testing import CliRunner

from handvar.cli import main

KNOWN = b"known bytes that must survive\n"


# --- the inputs ---------------------------------------------------------------------------


def make_inputs(root: Path) -> Path:
    """Write every input the cases use into `root` (tiny files; one 2-frame sequence)."""
    from handvar.camera import Rig
    from handvar.evaluation.config import ExperimentConfig
    from handvar.evaluation.store import create_store, write_scores, write_trial
    from handvar.evaluation.trials import TrialRunner
    from handvar.hand.kinematics import named_pose
    from handvar.io import Sequence, write_sequence
    from handvar.synth.sequences import make_sequence

    root.mkdir(parents=True, exist_ok=True)
    (root / "existing.txt").write_bytes(KNOWN)
    (root / "existing.png").write_bytes(KNOWN)
    (root / "existing.csv").write_bytes(KNOWN)
    (root / "adir").mkdir()
    (root / "adir" / "keep.txt").write_bytes(KNOWN)
    (root / "empty.txt").write_text("")
    (root / "abc.txt").write_text("abc " * 26)
    (root / "short.txt").write_text("1 2 3")
    pose = named_pose("open")
    (root / "good_pose.txt").write_text(" ".join(map(str, pose)))
    front = pose.copy()
    front[:3] = (0.0, 0.0, 400.0)  # in front of a recording's assumed camera
    (root / "front_pose.txt").write_text(" ".join(map(str, front)))
    (root / "nan_pose.txt").write_text(" ".join(["nan", *map(str, pose[1:])]))
    far = pose.copy()
    far[2] = 1e12
    (root / "far_pose.txt").write_text(" ".join(map(str, far)))
    spin = pose.copy()
    spin[3] = 1e6
    (root / "spin_pose.txt").write_text(" ".join(map(str, spin)))
    behind = pose.copy()
    behind[2] = -600.0
    (root / "behind_pose.txt").write_text(" ".join(map(str, behind)))
    rng = np.random.default_rng(0)
    np.savetxt(root / "series.txt", rng.normal(size=(30, 26)))
    np.savetxt(root / "series_huge.txt", 1e200 * rng.normal(size=(30, 26)))
    np.savetxt(root / "series_cols.txt", rng.normal(size=(30, 5)))
    np.savetxt(root / "series_25.txt", rng.normal(size=(30, 25)))
    series_nan = rng.normal(size=(30, 26))
    series_nan[4, 4] = np.nan
    np.savetxt(root / "series_nan.txt", series_nan)
    (root / "random.mp4").write_bytes(rng.integers(0, 256, 4000, dtype=np.uint8).tobytes())
    (root / "noise.npy").write_bytes(b"not an npy file")
    # an MP4 header and nothing else: FFmpeg itself logs "moov atom not found"
    (root / "header.mp4").write_bytes(
        b"\x00\x00\x00\x18ftypmp42\x00\x00\x00\x00mp42isom" + bytes(3000)
    )
    # a 12-frame MJPG video cut in half: the container still claims 12 frames, 5 decode
    import cv2

    writer = cv2.VideoWriter(str(root / "short.avi"), cv2.VideoWriter_fourcc(*"MJPG"), 25, (64, 48))
    for _ in range(12):
        writer.write(rng.integers(0, 256, (48, 64, 3), dtype=np.uint8))
    writer.release()
    whole = (root / "short.avi").read_bytes()
    (root / "short.avi").write_bytes(whole[: len(whole) // 2])
    # 4 frames of skin colour wall to wall: no hand in view
    writer = cv2.VideoWriter(str(root / "skin.avi"), cv2.VideoWriter_fourcc(*"MJPG"), 25, (64, 48))
    for _ in range(4):
        skin = np.array([120.0, 150.0, 210.0]) + rng.normal(0.0, 4.0, (48, 64, 3))
        writer.write(np.clip(skin, 0, 255).astype(np.uint8))
    writer.release()
    # calibrations of that video the pinhole model cannot hold: K[2][2] = 0, a skew
    for name, (i, j, value) in {"k22.yml": (2, 2, 0.0), "skew.yml": (0, 1, 500.0)}.items():
        K = np.array([[60.0, 0, 31.5], [0, 60.0, 23.5], [0, 0, 1]])
        K[i, j] = value
        fs = cv2.FileStorage(str(root / name), cv2.FILE_STORAGE_WRITE)
        fs.write("camera_matrix", K)
        fs.write("image_width", 64)
        fs.write("image_height", 48)
        fs.release()
    (root / "fisheye.toml").write_text(  # an anipose camera group of a fisheye camera
        '[cam_0]\nname = "A"\nsize = [ 64, 48,]\nmatrix = [ [ 60.0, 0.0, 31.5,], '
        "[ 0.0, 60.0, 23.5,], [ 0.0, 0.0, 1.0,],]\ndistortions = [ 0.1, 0.0, 0.0, 0.0,]\n"
        "rotation = [ 0.0, 0.0, 0.0,]\ntranslation = [ 0.0, 0.0, 0.0,]\nfisheye = true\n"
    )
    # a sequence of 2 frames, and damaged copies of it
    seq = make_sequence("benchmark", n_frames=2)
    write_sequence(seq, root / "seq")
    write_sequence(seq, root / "seq_trunc")
    png = root / "seq_trunc" / "cam0" / "mask_00001.png"
    png.write_bytes(png.read_bytes()[:50])
    write_sequence(seq, root / "seq_far")  # ground truth 1e12 mm away
    truth = dict(np.load(root / "seq_far" / "truth.npz"))
    truth["poses"][1, 2] = 1e12
    np.savez_compressed(root / "seq_far" / "truth.npz", **truth)
    write_sequence(seq, root / "seq_json")
    (root / "seq_json" / "sequence.json").write_text("{not json")
    # a 3x3 blob in both cameras: nothing the hand model can fit
    rig = Rig.default()
    w, h = rig.cameras[0].size
    blob = np.zeros((1, len(rig), h, w), bool)
    blob[:, :, h // 2 : h // 2 + 3, w // 2 : w // 2 + 3] = True
    write_sequence(Sequence("blob", 25.0, rig, blob), root / "blob")
    # an experiment store of one open-loop trial per predictor, and damaged copies
    config = ExperimentConfig(trials=1, frames=6, trial_kind="openloop")
    six = make_sequence("benchmark", n_frames=6)
    store = create_store(root / "store.zarr", config, six)
    runner = TrialRunner(six)
    for p, spec in enumerate(config.predictors):
        write_trial(store, p, 0, runner.run(config, spec.key, 0), six.truth.joints, 1)
    write_scores(store, config, 0)
    import shutil

    shutil.copytree(store, root / "corrupt.zarr")
    (root / "corrupt.zarr" / "error" / "2.0.0").write_bytes(b"garbage")
    shutil.copytree(store, root / "deleted.zarr")
    (root / "deleted.zarr" / "poses" / "1.0.0.0").unlink()
    for name, chunks in {  # chunks whose fill value would be read as data
        "no_r2.zarr": ["r2_joints/1.0.0"],
        "no_timings.zarr": ["timings/2.0.0.0"],
        "no_masks.zarr": ["masks/3.0.0.0", "poses/1.0.0.0"],
    }.items():
        shutil.copytree(store, root / name)
        for chunk in chunks:
            (root / name / chunk).unlink()
    shutil.copytree(store, root / "nanned.zarr")
    # NaN where a finished trial must have numbers: rewrite one trial's errors
    from handvar.evaluation.store import _write_region

    nan_err = {"error": (("predictor", "trial", "frame"), np.full((1, 1, 6), np.nan))}
    _write_region(root / "nanned.zarr", nan_err, 3, 0)
    _keypoint_inputs(root, seq)
    _track_inputs(root, seq)
    _hands_inputs(root)
    (root / "report_out").mkdir()
    (root / "report_out" / "report.md").write_bytes(KNOWN)
    (root / "track_out").mkdir()
    (root / "track_out" / "poses.csv").write_bytes(KNOWN)
    return root


def _keypoint_inputs(root: Path, seq) -> None:
    """Keypoint files of the 2-frame sequence `seq` and of skin.avi, and damaged ones."""
    from handvar.synth.keypoints import synthetic_keypoints

    kp = synthetic_keypoints(seq, noise_px=0.0, outliers=0.0)[:, 0]  # (2, 21, 3), camera 0
    np.savez_compressed(root / "kp_half.npz", keypoints=kp)
    whole = (root / "kp_half.npz").read_bytes()
    (root / "kp_half.npz").write_bytes(whole[: len(whole) // 2])
    with open(root / "kp_npy.npz", "wb") as fh:  # a .npy under the .npz's name
        np.save(fh, kp)
    # world points 1000 times too large (mm taken as µm): a hand of ~80 m
    np.savez_compressed(root / "kp_huge_world.npz", keypoints=kp,
                        world=1000.0 * seq.truth.joints)  # fmt: skip
    np.save(root / "kp_3frames.npy", np.concatenate([kp, kp[:1]]))
    # skin.avi (4 frames of 64x48): keypoints of its 4 frames and of 3
    rng = np.random.default_rng(1)
    skin = np.concatenate([rng.uniform(10, 40, (4, 21, 2)), np.ones((4, 21, 1))], axis=2)
    np.save(root / "kp_skin4.npy", skin)
    np.save(root / "kp_skin3.npy", skin[:3])


def _track_inputs(root: Path, seq) -> None:
    """A track directory of the 2-frame sequence `seq` (its true poses, as `handvar track
    --out` writes one), a copy with a pose 1e9 mm away and one with its meta garbled."""
    import shutil

    from handvar.hand.kinematics import HandModel
    from handvar.pipeline import Track
    from handvar.tracking.tracker import TrackResult

    poses, joints = seq.truth.poses, seq.truth.joints
    n, n_cams = len(poses), len(seq.rig)
    result = TrackResult(
        poses=poses, joints=joints, starts=poses, costs=np.zeros((n, 1)),
        iterations=np.ones(n, dtype=int), seconds=np.zeros((n, 3)),
        iou=np.full((n, n_cams), 0.9), cost=np.zeros(n), keypoint_error=np.full(n, np.nan),
        lost=np.zeros(n, dtype=bool), empty=np.zeros((n, n_cams), dtype=bool),
    )  # fmt: skip
    Track(
        poses=poses, joints=joints, projected=np.zeros((0, n, 21, 2)), quality=None, rig=None,
        shape=HandModel().shape, name="seq", predictor="rvar", seed=0, fps=seq.fps,
        result=result,
    ).save(root / "track_good", video=False, overlays=False)  # fmt: skip
    for name in ("track_far", "track_meta"):
        shutil.copytree(root / "track_good", root / name)
        stored = dict(np.load(root / name / "track.npz"))
        if name == "track_far":
            stored["poses"][1, 2] = 1e9
        else:
            stored["meta"] = np.array("{not json")
        np.savez_compressed(root / name / "track.npz", **stored)


def _hands_inputs(root: Path) -> None:
    """Detections files of skin.avi's 4 frames (`handvar keypoints --hands 2`'s layout)
    with one wrong value each, and a directory of both hands (the track of
    `_track_inputs` as the right hand) and damaged copies of it."""
    import copy
    import json
    import shutil

    rng = np.random.default_rng(2)
    hand = {"points": [[*xy, 1.0] for xy in rng.uniform(10, 40, (21, 2)).tolist()],
            "side": "right", "score": 0.9}  # fmt: skip
    for name, change in {
        "hands_conf": lambda h: h["points"][3].__setitem__(2, 5.0),
        "hands_negconf": lambda h: h["points"][3].__setitem__(2, -0.5),
        "hands_inf": lambda h: h["points"][3].__setitem__(0, float("inf")),
        "hands_text": lambda h: h["points"][3].__setitem__(0, "12"),
        "hands_world0": lambda h: h.__setitem__("world", [[0.0, 0.0, 0.0]] * 21),
    }.items():
        bad = copy.deepcopy(hand)
        change(bad)
        (root / f"{name}.json").write_text(json.dumps([[hand], [hand], [bad], []]))
    norm = {**hand, "points": [[x / 64, y / 48, c] for x, y, c in hand["points"]]}
    (root / "hands_norm.json").write_text(json.dumps([[norm]] * 3 + [[]]))  # not pixels
    index = {"name": "seq", "fps": 25.0,
             "hands": [{"id": 0, "side": "right", "directory": "right"}]}  # fmt: skip
    shutil.copytree(root / "track_good", root / "hands_good" / "right")
    (root / "hands_good" / "hands.json").write_text(json.dumps(index))
    shutil.copytree(root / "hands_good", root / "hands_noindex")
    (root / "hands_noindex" / "hands.json").unlink()


# --- the cases ----------------------------------------------------------------------------


@dataclasses.dataclass(frozen=True)
class Case:
    """One bad input: the command's arguments (``{r}`` = the inputs' folder) and what
    the one line must name."""

    id: str
    args: tuple[str, ...]
    names: str
    subprocess: bool = False
    slow: bool = False


def _c(id, args, names, **kw) -> Case:
    return Case(id, tuple(shlex.split(args)), names, **kw)


# fmt: off
CASES = [
    # synth
    _c("synth-unknown-name", "synth nonesuch {r}/s1", "nonesuch"),
    _c("synth-out-empty", "synth flip --frames 1 ''", "OUT"),
    _c("synth-out-is-file", "synth flip {r}/existing.txt", "existing.txt"),
    _c("synth-out-under-file", "synth flip {r}/existing.txt/sub", "existing.txt"),
    _c("synth-out-other-dir", "synth flip {r}/adir", "adir"),
    _c("synth-frames-zero", "synth flip {r}/s1 --frames 0", "--frames"),
    _c("synth-frames-negative", "synth flip {r}/s1 --frames -3", "--frames"),
    _c("synth-seed-negative", "synth flip {r}/s1 --seed -1", "--seed"),
    _c("synth-seed-text", "synth flip {r}/s1 --seed abc", "--seed"),
    _c("synth-model-unknown", "synth flip {r}/s1 --model cubes", "--model"),
    _c("synth-size-zero", "synth flip {r}/s1 --size 0 0", "--size"),
    _c("synth-size-negative", "synth flip {r}/s1 --size -1 1", "--size"),
    _c("synth-size-nan", "synth flip {r}/s1 --size nan 1", "--size"),
    _c("synth-size-huge", "synth flip {r}/s1 --size 1e9 1e9", "--size"),
    _c("synth-noise-nan", "synth flip {r}/s1 --noise nan", "--noise"),
    # show
    _c("show-unknown-pose", "show nonesuch --out {r}/existing.png", "POSE"),
    _c("show-short-file", "show {r}/short.txt --out {r}/existing.png", "short.txt"),
    _c("show-empty-file", "show {r}/empty.txt --out {r}/existing.png", "empty.txt"),
    _c("show-text-file", "show {r}/abc.txt --out {r}/existing.png", "abc.txt"),
    _c("show-nan-pose", "show {r}/nan_pose.txt --out {r}/existing.png", "nan_pose.txt"),
    _c("show-far-pose", "show {r}/far_pose.txt --out {r}/existing.png", "tz"),
    _c("show-spun-pose", "show {r}/spin_pose.txt --out {r}/existing.png", "rx"),
    _c("show-behind", "show {r}/behind_pose.txt --out {r}/existing.png", "in front"),
    _c("show-corrupt-npy", "show {r}/noise.npy --out {r}/existing.png", "noise.npy"),
    _c("show-hand-length-huge", "show open --hand-length 1e9 --out {r}/x.png", "--hand-length"),
    _c("show-hand-length-zero", "show open --hand-length 0 --out {r}/x.png", "--hand-length"),
    _c("show-hand-length-nan", "show open --hand-length nan --out {r}/x.png", "--hand-length"),
    _c("show-out-dir", "show open --out {r}/adir", "adir"),
    _c("show-out-suffix", "show open --out {r}/x.jpg", "--out"),
    _c("show-out-no-folder", "show open --out {r}/nodir/x.png", "--out"),
    _c("show-out-empty", "show open --out=", "--out"),
    _c("show-frame-too-big", "show {r}/seq --frame 9 --out {r}/existing.png", "--frame"),
    _c("show-frame-not-seq", "show {r}/adir --frame 0 --out {r}/existing.png", "adir"),
    _c("show-frame-negative", "show {r}/seq --frame -1 --out {r}/existing.png", "--frame"),
    # predict
    _c("predict-missing", "predict {r}/nofile.txt", "nofile.txt"),
    _c("predict-directory", "predict {r}/adir", "adir"),
    _c("predict-empty", "predict {r}/empty.txt", "empty.txt"),
    _c("predict-text", "predict {r}/abc.txt", "abc.txt"),
    _c("predict-nan", "predict {r}/series_nan.txt", "series_nan.txt"),
    _c("predict-columns", "predict {r}/series_cols.txt", "series_cols.txt"),
    _c("predict-huge", "predict {r}/series_huge.txt", "series_huge.txt"),
    _c("predict-stride-zero", "predict {r}/series.txt --stride 0", "--stride"),
    _c("predict-reset-beyond", "predict {r}/series.txt --reset-at 999", "--reset-at"),
    _c("predict-reset-negative", "predict {r}/series.txt --reset-at -1", "--reset-at"),
    _c("predict-layout", "predict {r}/series.txt --layout nonesuch", "--layout"),
    _c("predict-csv-dir", "predict {r}/series.txt --csv {r}/adir", "adir"),
    _c("predict-csv-no-folder", "predict {r}/series.txt --csv {r}/nodir/x.csv", "--csv"),
    _c("predict-csv-suffix", "predict {r}/series.txt --csv {r}/x.png", "--csv"),
    _c("predict-csv-empty", "predict {r}/series.txt --csv=", "--csv"),
    _c("predict-corrupt-npy", "predict {r}/noise.npy", "noise.npy"),
    _c("predict-fps-nan", "predict {r}/series.txt --fps nan", "--fps"),
    _c("predict-fps-inf", "predict {r}/series.txt --fps inf", "--fps"),
    _c("predict-train-columns", "predict {r}/series.txt --train {r}/series_25.txt",
       "--train: {r}/series_25.txt"),
    # track
    _c("track-unknown-seq", "track nonesuch --out {r}/t1", "SEQ"),
    _c("track-out-is-file", "track {r}/seq --out {r}/existing.txt", "existing.txt"),
    _c("track-out-under-file", "track {r}/seq --out {r}/existing.txt/t", "existing.txt"),
    _c("track-predictor", "track {r}/seq --predictor nonesuch --out {r}/t1", "--predictor"),
    _c("track-frames-zero", "track {r}/seq --frames 0 --out {r}/t1", "--frames"),
    _c("track-init-unknown", "track {r}/seq --init nonesuch --out {r}/t1", "POSE"),
    _c("track-init-far", "track {r}/seq --init {r}/far_pose.txt --out {r}/t1", "far_pose"),
    _c("track-init-nan", "track {r}/seq --init {r}/nan_pose.txt --out {r}/t1", "nan_pose"),
    _c("track-hand-length", "track {r}/seq --hand-length 10 --out {r}/t1", "--hand-length"),
    _c("track-calib-on-seq", "track {r}/seq --calib {r}/existing.txt --out {r}/t1", "--calib"),
    _c("track-shape-no-track", "track {r}/seq --shape {r}/adir --out {r}/t1", "--shape"),
    _c("track-shape-a-file", "track {r}/seq --shape {r}/existing.txt --out {r}/t1", "--shape"),
    _c("track-truncated-png", "track {r}/seq_trunc --out {r}/track_out", "mask_00001.png"),
    _c("track-far-truth", "track {r}/seq_far --out {r}/track_out",
       "truth.npz: poses: expected a pose within the parameter limits; tz = 1e+12 at frame 1"),
    _c("show-far-truth", "show {r}/seq_far --frame 1 --out {r}/existing.png", "truth.npz: poses"),
    _c("track-bad-json", "track {r}/seq_json --out {r}/track_out", "sequence.json"),
    _c("track-other-dir", "track {r}/adir --out {r}/track_out", "adir"),
    _c("track-scale-zero", "track {r}/seq --scale 0 --out {r}/t1", "--scale"),
    _c("track-no-out", "track {r}/seq", "--out"),
    _c("track-carry-on-seq", "track {r}/seq --carry forward --out {r}/t1", "--carry"),
    _c("track-carry-unknown", "track {r}/seq --carry sideways --out {r}/t1", "--carry"),
    _c("track-tips-unknown", "track {r}/seq --keypoint-tips nail --out {r}/t1",
       "--keypoint-tips"),
    _c("track-hand-unknown", "track {r}/seq --hand middle --out {r}/t1", "--hand"),
    _c("track-left-mesh", "track {r}/seq --hand left --model mesh --out {r}/t1", "--model"),
    # init
    _c("init-missing-source", "init {r}/nofile.mp4 --out {r}/existing.txt", "nofile.mp4"),
    _c("init-out-dir", "init {r}/seq --out {r}/adir", "adir"),
    _c("init-shape-no-track", "init {r}/seq --shape {r}/adir --out {r}/existing.txt", "--shape"),
    _c("init-overlay-no-folder",
       "init {r}/seq --out {r}/existing.txt --overlay {r}/nodir/o.png", "--overlay"),
    _c("init-overlay-suffix",
       "init {r}/seq --out {r}/existing.txt --overlay {r}/o.jpg", "--overlay"),
    _c("init-frame-beyond", "init {r}/seq --frame 7 --out {r}/existing.txt", "--frame"),
    _c("init-threshold-zero", "init {r}/seq --threshold 0 --out {r}/existing.txt", "--threshold"),
    _c("init-keypoints-count",
       "init {r}/seq --keypoints {r}/a.npy --keypoints {r}/b.npy --keypoints {r}/c.npy "
       "--out {r}/existing.txt", "--keypoints: expected one file per camera of the sequence"),
    _c("init-keypoints-corrupt",
       "init {r}/seq --keypoints {r}/noise.npy --keypoints {r}/noise.npy --out {r}/existing.txt",
       "noise.npy"),
    _c("init-blob", "init {r}/blob --out {r}/existing.txt", "IoU", slow=True),
    _c("init-calib-on-seq", "init {r}/seq --calib {r}/existing.txt --out {r}/x.txt", "--calib"),
    _c("init-random-video", "init {r}/random.mp4 --out {r}/existing.txt", "random.mp4",
       subprocess=True),
    _c("track-random-video", "track {r}/random.mp4 --init open --out {r}/track_out",
       "random.mp4", subprocess=True),
    _c("init-header-only-video", "init {r}/header.mp4 --out {r}/existing.txt", "header.mp4",
       subprocess=True),
    _c("track-header-only-video", "track {r}/header.mp4 --init open --out {r}/track_out",
       "header.mp4", subprocess=True),
    _c("track-short-video", "track {r}/short.avi --init {r}/front_pose.txt --out {r}/track_out",
       "short.avi: decoding stopped after 5 of the 12 frames", subprocess=True),
    _c("init-short-video", "init {r}/short.avi --frame 8 --out {r}/existing.txt",
       "short.avi: decoding stopped after 5 of the 12 frames", subprocess=True),
    _c("track-skin-video", "track {r}/skin.avi --out {r}/track_out",
       "skin.avi: expected a hand; the detector found none in its 4 frames", subprocess=True),
    _c("track-skin-video-silhouettes", "track {r}/skin.avi --detector none --out {r}/track_out",
       "skin.avi: expected a hand in some frame", subprocess=True),
    _c("init-skin-video", "init {r}/skin.avi --out {r}/existing.txt",
       "camera 'skin.avi', frame 0: not a hand", subprocess=True),
    _c("track-calib-k22", "track {r}/short.avi --calib {r}/k22.yml --init open --out {r}/t1",
       "k22.yml: key 'camera_matrix': expected a pinhole matrix (K[2][2] = 1", subprocess=True),
    _c("init-calib-skew", "init {r}/short.avi --calib {r}/skew.yml --out {r}/existing.txt",
       "skew.yml: key 'camera_matrix': expected no skew (K[0][1] = 0", subprocess=True),
    _c("track-calib-fisheye", "track {r}/skin.avi --calib {r}/fisheye.toml --out {r}/t1",
       "fisheye.toml: camera [cam_0] is a fisheye camera; expected a pinhole camera"),
    # both hands
    _c("track-hands-three", "track {r}/skin.avi --hands 3 --out {r}/t1", "--hands"),
    _c("track-hands-keypoints",
       "track {r}/skin.avi --hands 2 --keypoints {r}/kp_skin4.npy --out {r}/t1",
       "kp_skin4.npy: expected a .json detections file with every hand found"),
    _c("track-hands-carry", "track {r}/skin.avi --hands 2 --carry forward --out {r}/t1",
       "--carry: expected none with --hands 2"),
    _c("track-hands-detector-none", "track {r}/skin.avi --hands 2 --detector none --out {r}/t1",
       "--detector: expected auto or mediapipe with --hands 2"),
    _c("track-hands-skin-video", "track {r}/skin.avi --hands 2 --out {r}/track_out",
       "skin.avi: expected a hand; the detector found none in its 4 frames", subprocess=True),
    _c("track-hands-keypoint-tips",
       "track {r}/skin.avi --hands 2 --keypoint-tips end --out {r}/t1",
       "--keypoint-tips: expected none with --hands 2"),
    _c("track-hands-no-recover", "track {r}/skin.avi --hands 2 --no-recover --out {r}/t1",
       "--no-recover: expected none with --hands 2"),
    # detections files (.json) that are not what `handvar keypoints --hands 2` writes
    _c("track-hands-confidence",
       "track {r}/skin.avi --hands 2 --keypoints {r}/hands_conf.json --out {r}/track_out",
       "hands_conf.json: frame 2, hand 0: expected confidences in [0, 1] (each point's "
       "third number); got 5.0 at point 3"),
    _c("track-hands-negative-confidence",
       "track {r}/skin.avi --hands 2 --keypoints {r}/hands_negconf.json --out {r}/track_out",
       "hands_negconf.json: frame 2, hand 0: expected confidences in [0, 1]"),
    _c("track-hands-infinity",
       "track {r}/skin.avi --hands 2 --keypoints {r}/hands_inf.json --out {r}/track_out",
       "hands_inf.json: frame 2, hand 0: expected 'points' finite numbers or null; got "
       "infinity at point 3"),
    _c("track-hands-text-number",
       "track {r}/skin.avi --hands 2 --keypoints {r}/hands_text.json --out {r}/track_out",
       "hands_text.json: frame 2, hand 0: expected 'points' as 21 × [3 numbers or null]"),
    _c("track-hands-world-zero",
       "track {r}/skin.avi --hands 2 --keypoints {r}/hands_world0.json --out {r}/track_out",
       "hands_world0.json: expected world points in mm"),
    _c("track-hands-normalised",
       "track {r}/skin.avi --hands 2 --keypoints {r}/hands_norm.json --out {r}/track_out",
       "hands_norm.json: expected pixels of the 64x48 frames"),
    # keypoint files that are not what `handvar keypoints` writes
    _c("init-keypoints-truncated-npz",
       "init {r}/seq --keypoints {r}/kp_half.npz --keypoints {r}/kp_half.npz "
       "--out {r}/existing.txt",
       "kp_half.npz: expected a .npz archive (the file `handvar keypoints` writes); got a "
       "damaged or truncated archive"),
    _c("track-keypoints-truncated-npz",
       "track {r}/seq --keypoints {r}/kp_half.npz --out {r}/t1", "kp_half.npz: expected a .npz"),
    _c("init-keypoints-npy-as-npz",
       "init {r}/skin.avi --keypoints {r}/kp_npy.npz --out {r}/existing.txt",
       "kp_npy.npz: expected a .npz archive (the file `handvar keypoints` writes); got a "
       "single .npy array (not a .npz archive)"),
    _c("track-keypoints-world-x1000",
       "track {r}/seq --keypoints {r}/kp_huge_world.npz --out {r}/t1",
       "kp_huge_world.npz: expected world points in mm (a hand's wrist to middle MCP "
       "measures 20 to 200 mm); got 8.25e+04"),
    _c("init-keypoints-frames",
       "init {r}/skin.avi --keypoints {r}/kp_skin3.npy --out {r}/existing.txt",
       "kp_skin3.npy: expected keypoints of 4 frames (the recording's); got 3"),
    _c("init-keypoints-frames-sequence",
       "init {r}/seq --keypoints {r}/kp_3frames.npy --keypoints {r}/kp_3frames.npy "
       "--out {r}/existing.txt", "kp_3frames.npy: expected keypoints of 2 frames"),
    # messages that name the options, and only options that exist
    _c("track-realtime-carry-both",
       "track {r}/skin.avi --realtime --carry both --keypoints {r}/kp_skin4.npy --out {r}/t1",
       "--realtime: expected --recover on and --carry forward or none (one frame at a time); "
       "got --recover, --carry both"),
    _c("track-hand-auto-without-handedness",
       "track {r}/skin.avi --hand auto --keypoints {r}/kp_skin4.npy --out {r}/t1",
       "--hand: auto expected --keypoints with handedness (a .npz written by handvar "
       "keypoints) or two calibrated cameras' --keypoints; got neither"),
    _c("init-hand-auto-without-handedness",
       "init {r}/skin.avi --hand auto --keypoints {r}/kp_skin4.npy --out {r}/existing.txt",
       "--hand: auto expected --keypoints with handedness (a .npz written by handvar "
       "keypoints) or two calibrated cameras' --keypoints; got neither"),
    # export, view
    _c("export-far-pose-json", "export {r}/track_far --format json",
       "track.npz: poses: expected a pose within the parameter limits; tz = 1e+09 at frame 1"),
    _c("export-far-pose-openpose", "export {r}/track_far --format openpose",
       "track.npz: poses: expected a pose within the parameter limits; tz = 1e+09 at frame 1"),
    _c("export-far-pose-bvh", "export {r}/track_far --format bvh",
       "track.npz: poses: expected a pose within the parameter limits; tz = 1e+09 at frame 1"),
    _c("export-far-pose-gltf", "export {r}/track_far --format gltf",
       "track.npz: poses: expected a pose within the parameter limits; tz = 1e+09 at frame 1"),
    _c("view-far-pose", "view {r}/track_far",
       "track.npz: poses: expected a pose within the parameter limits; tz = 1e+09 at frame 1"),
    _c("export-garbled-meta", "export {r}/track_meta --format bvh",
       "track_meta/track.npz: not a readable track (meta: expected a JSON object"),
    _c("export-not-a-track", "export {r}/adir --format bvh", "adir"),
    _c("export-openpose-other-dir", "export {r}/track_good --format openpose --out {r}/adir",
       "--out: expected a new folder, an empty one or an earlier OpenPose export (only "
       "*_keypoints.json files); {r}/adir holds keep.txt"),
    _c("export-openpose-hand-folder",
       "export {r}/hands_good --format openpose --out {r}/hands_good/right",
       "{r}/hands_good/right holds"),
    _c("export-json-over-hands-index",
       "export {r}/hands_good --format json --out {r}/hands_good/hands.json",
       "--out: expected a file other than the track's own"),
    _c("export-hands-without-index", "export {r}/hands_noindex --format bvh",
       "TRACK_DIR: expected a directory of both hands with hands.json"),
    _c("view-hands-without-index", "view {r}/hands_noindex --no-frames",
       "TRACK_DIR: expected a directory of both hands with hands.json"),
    # experiment
    _c("experiment-set-unknown", "experiment --out {r}/e.zarr --set nothing=1", "--set"),
    _c("experiment-set-trials-zero", "experiment --out {r}/e.zarr --set trials=0", "trials"),
    _c("experiment-set-trials-text", "experiment --out {r}/e.zarr --set trials=abc", "trials"),
    _c("experiment-set-no-equals", "experiment --out {r}/e.zarr --set trials", "--set"),
    _c("experiment-set-predictors",
       "experiment --out {r}/e.zarr --set predictors=nonesuch", "predictors"),
    _c("experiment-set-gamma", "experiment --out {r}/e.zarr --set rvar.gamma=abc", "gamma"),
    _c("experiment-set-tracker",
       "experiment --out {r}/e.zarr --set tracker.nonesuch=1", "tracker"),
    _c("experiment-sweep-text", "experiment --out {r}/e.zarr --sweep rvar.gamma=abc", "--sweep"),
    _c("experiment-sweep-unknown",
       "experiment --out {r}/e.zarr --sweep nonesuch.x=1", "--sweep"),
    _c("experiment-sweep-no-arg", "experiment --out {r}/e.zarr --sweep rvar=1", "--sweep"),
    _c("experiment-sweep-empty", "experiment --out {r}/e.zarr --sweep rvar.gamma=", "--sweep"),
    _c("experiment-workers-zero", "experiment --out {r}/e.zarr --workers 0", "--workers"),
    _c("experiment-out-file", "experiment --out {r}/existing.txt", "existing.txt"),
    _c("experiment-out-other-dir", "experiment --out {r}/adir", "adir"),
    _c("experiment-other-config",
       "experiment --out {r}/store.zarr --set trials=2", "different experiment"),
    # report
    _c("report-missing-store", "report {r}/nostore.zarr --out {r}/report_out", "nostore.zarr"),
    _c("report-not-a-store", "report {r}/adir --out {r}/report_out", "adir"),
    _c("report-corrupt-chunk", "report {r}/corrupt.zarr --out {r}/report_out", "trial 0"),
    _c("report-deleted-chunk", "report {r}/deleted.zarr --out {r}/report_out", "trial 0"),
    _c("report-deleted-r2", "report {r}/no_r2.zarr --out {r}/report_out",
       "trial 0 of predictor 'decelerating' (r2_joints: chunk file 1.0.0 missing)"),
    _c("report-deleted-timings", "report {r}/no_timings.zarr --out {r}/report_out",
       "(timings: chunk file 2.0.0.0 missing)"),
    _c("experiment-deleted-masks",
       "experiment --out {r}/no_masks.zarr --set trials=1 --set frames=6 "
       "--set trial_kind=openloop", "masks: chunk file 3.0.0.0 missing"),
    _c("report-nan-trial", "report {r}/nanned.zarr --out {r}/report_out", "trial 0"),
    _c("report-out-is-file", "report {r}/store.zarr --out {r}/existing.txt", "existing.txt"),
    # keypoints
    _c("keypoints-suffix", "keypoints {r}/random.mp4 --out {r}/k.txt", "k.txt"),
    _c("keypoints-out-dir", "keypoints {r}/random.mp4 --out {r}/adir", "adir"),
    _c("keypoints-out-no-folder", "keypoints {r}/random.mp4 --out {r}/nodir/k.npy", "--out"),
    _c("keypoints-frames-zero", "keypoints {r}/random.mp4 --out {r}/k.npy --frames 0", "--frames"),
    _c("keypoints-hand", "keypoints {r}/random.mp4 --out {r}/k.npy --hand both", "--hand"),
]
# fmt: on


def snapshot(root: Path) -> dict[str, bytes | None]:
    """Every file under `root` (relative path -> bytes); directories as None."""
    out: dict[str, bytes | None] = {}
    for path in sorted(root.rglob("*")):
        rel = str(path.relative_to(root))
        out[rel] = None if path.is_dir() else path.read_bytes()
    return out


@dataclasses.dataclass
class Outcome:
    status: int
    lines: list[str]
    before: dict
    after: dict

    def problems(self, case: Case, root: Path) -> list[str]:
        """What is wrong with this outcome (empty: a clean error)."""
        found = []
        text = "\n".join(self.lines)
        if "Traceback" in text:
            found.append("traceback")
        if self.status != 2:
            found.append(f"exit status {self.status}")
        if len(self.lines) != 1:
            found.append(f"{len(self.lines)} lines")
        elif not self.lines[0].startswith("handvar: error: "):
            found.append("not an error line")
        if case.names.format(r=root) not in text:
            found.append(f"does not name {case.names!r}")
        if ".handvar-" in text:
            found.append("names a temporary")
        changed = [k for k, v in self.before.items() if self.after.get(k, "gone") != v]
        if changed:
            found.append(f"changed {changed[:3]}")
        left = [k for k in self.after if ".handvar-" in k]
        if left:
            found.append(f"left temporaries {left[:3]}")
        return found


def run_case(case: Case, root: Path) -> Outcome:
    """Run one case against the inputs in `root`."""
    args = [a.format(r=root) for a in case.args]
    before = snapshot(root)
    if case.subprocess:
        proc = subprocess.run(
            [sys.executable, "-c", "from handvar.cli import main; main()", *args],
            capture_output=True,  # bytes: text mode would turn "\r" into "\n"
            env={**os.environ, "PYTHONPATH": str(Path(__file__).parents[1] / "src")},
            timeout=300,
        )
        status, output = proc.returncode, (proc.stdout + proc.stderr).decode(errors="replace")
    else:
        result = CliRunner().invoke(main, args)
        status, output = result.exit_code, result.output
        if result.exception is not None and not isinstance(result.exception, SystemExit):
            import traceback

            output += "".join(traceback.format_exception(result.exception))
    return Outcome(status, _terminal_lines(output), before, snapshot(root))


def _terminal_lines(output: str) -> list[str]:
    """The lines a terminal shows of `output`: a progress bar erased with carriage
    returns is gone, blank lines are not counted."""
    lines = [line.rsplit("\r", 1)[-1] for line in output.split("\n")]
    return [line for line in lines if line.strip()]


# --- beyond the table: a warning, Ctrl-C, the option names -----------------------------------


def metres_outcome(root: Path) -> list[str]:
    """World points in metres (MediaPipe's own unit) in a keypoint .npz: `handvar init`
    reads them as mm and says so in one warning line. Returns the problems (none: as
    documented)."""
    import warnings

    from handvar.data import example_path
    from handvar.vision.keypoints import Keypoints2D, KeypointUnitWarning, write_keypoints

    z = np.load(example_path("video").parent / "tfjs-asl-hand-mediapipe.npz")  # mm
    xy = z["landmarks_px"]
    conf = np.where(np.isnan(xy).any(axis=2), 0.0, 1.0)
    path = root / "kp_metres.npz"
    write_keypoints(path, Keypoints2D(xy, conf, "m", world=z["world_mm"] / 1000.0))
    out = root / "metres_pose.txt"
    args = ["init", str(example_path("video").parent / "tfjs-asl-hand.mp4"), "--keypoints",
            str(path), "--scale", "0.5", "--out", str(out)]  # fmt: skip
    with warnings.catch_warnings():  # as outside pytest: a warning is shown, not raised
        warnings.simplefilter("default", KeypointUnitWarning)
        result = CliRunner().invoke(main, args)
    lines = _terminal_lines(result.output)
    said = [line for line in lines if line.startswith("handvar: warning: ")]
    expected = (
        f"handvar: warning: {path}: world points taken as metres and converted to mm "
        "(the hand's wrist to middle MCP measures 0.101; a hand's is 20 to 200 mm)"
    )
    found = []
    if result.exit_code != 0:
        found.append(f"exit status {result.exit_code}")
    if said != [expected]:
        found.append(f"warning lines {said}")
    if len(lines) != 2 or not out.is_file():
        found.append(f"{len(lines)} lines")
    return found


def interrupt_outcome(root: Path) -> list[str]:
    """Ctrl-C on `handvar track` of three recordings (a batch on the embedded Dask
    cluster): after it the terminal shows ``handvar: aborted`` alone, no worker's stack,
    and every recording folder in OUT is whole. Returns the problems (none: as
    documented)."""
    import signal
    import threading
    import time

    import cv2

    from handvar.data import example_path

    capture = cv2.VideoCapture(str(example_path("video")))
    frames = [cv2.resize(capture.read()[1], (320, 180), interpolation=cv2.INTER_AREA)
              for _ in range(80)]  # fmt: skip
    capture.release()
    recordings = []
    for name in ("clip_a", "clip_b", "clip_c"):
        folder = root / "interrupt" / name
        folder.mkdir(parents=True, exist_ok=True)
        for t, frame in enumerate(frames):
            cv2.imwrite(str(folder / f"{t:03d}.png"), frame)
        recordings.append(str(folder))
    out = root / "interrupt" / "out"
    # Ctrl-C as a terminal's foreground job gets it, even where this test runs as a
    # background job (which starts with SIGINT ignored, and so would the child)
    child = ("import signal; signal.signal(signal.SIGINT, signal.default_int_handler); "
             "from handvar.cli import main; main()")  # fmt: skip
    proc = subprocess.Popen(
        [sys.executable, "-c", child, "track", *recordings,
         "--no-video", "--workers", "1", "--out", str(out)],
        stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, start_new_session=True,
        env={**os.environ, "PYTHONPATH": str(Path(__file__).parents[1] / "src")},
    )  # fmt: skip
    received: list[bytes] = []
    reader = threading.Thread(target=lambda: received.extend(iter(
        lambda: os.read(proc.stderr.fileno(), 4096), b"")), daemon=True)  # fmt: skip
    reader.start()
    start = time.monotonic()
    while b"recordings:" not in b"".join(received) and time.monotonic() - start < 120:
        time.sleep(0.1)  # the cluster is up and the bar drawn: the recordings are tracked
    time.sleep(1.0)
    if proc.poll() is None:
        before = len(b"".join(received))
        os.killpg(proc.pid, signal.SIGINT)  # Ctrl-C: the terminal's whole process group
    proc.wait(timeout=120)
    reader.join(timeout=10)
    proc.stderr.close()
    everything = b"".join(received).decode(errors="replace")
    if "before" not in locals():
        return [f"ended before Ctrl-C (exit status {proc.returncode}): {everything[-300:]}"]
    after = _terminal_lines(b"".join(received)[before:].decode(errors="replace"))
    found = []
    if proc.returncode != 1:
        found.append(f"exit status {proc.returncode}")
    if after != ["handvar: aborted"]:
        found.append(f"after Ctrl-C: {after[:5]}")
    if "Traceback" in everything:
        found.append("traceback")
    folders = sorted(out.iterdir()) if out.exists() else []  # none finished: OUT not left
    broken = [p.name for p in folders
              if ".handvar-" not in p.name and not (p / "track.npz").is_file()]  # fmt: skip
    if broken:
        found.append(f"incomplete folders {broken}")
    return found


def cli_option_names() -> set[str]:
    """Every option name of every command of `handvar` (and the group's own)."""
    import click

    names = set()
    for command in [main, *main.commands.values()]:
        for param in command.params:
            if isinstance(param, click.Option):
                names.update(param.opts + param.secondary_opts)
    return names | {"--help"}  # the group's context_settings


def named_options_and_commands() -> dict[str, list[str]]:
    """What the library's text names (option -> where): every ``--option`` in a string
    of its sources, and every command of a message (``handvar NAME`` in what a raise, a
    warning or an echo says, or a `handvar NAME` anywhere)."""
    import ast
    import re

    option = re.compile(r"(?<![\w-])--[a-z](?:[a-z0-9-]*[a-z0-9])?(?![\w-])")
    command = re.compile(r"\bhandvar ([a-z][a-z-]*)")
    named: dict[str, list[str]] = {}
    src = Path(__file__).parents[1] / "src" / "handvar"
    for path in sorted(src.rglob("*.py")):
        tree = ast.parse(path.read_text(encoding="utf-8"))
        messages = []
        for node in ast.walk(tree):
            if isinstance(node, ast.Raise) and node.exc is not None:
                messages.append(node.exc)
            elif isinstance(node, ast.Call) and getattr(
                node.func, "attr", getattr(node.func, "id", None)
            ) in ("echo", "warn", "fail", "BadParameter", "UsageError"):
                messages.append(node)
        rel = path.relative_to(src)
        for node in ast.walk(tree):
            if isinstance(node, ast.Constant) and isinstance(node.value, str):
                for m in option.finditer(node.value):
                    named.setdefault(m.group(0), []).append(f"{rel}:{node.lineno}")
                for m in re.finditer(r"`handvar ([a-z][a-z-]*)", node.value):
                    named.setdefault(f"handvar {m.group(1)}", []).append(f"{rel}:{node.lineno}")
        for message in messages:
            for node in ast.walk(message):
                if isinstance(node, ast.Constant) and isinstance(node.value, str):
                    for m in command.finditer(node.value):
                        named.setdefault(f"handvar {m.group(1)}", []).append(f"{rel}:{node.lineno}")
    return named


# --- the tests ------------------------------------------------------------------------------


@pytest.fixture(scope="module")
def inputs(tmp_path_factory):
    return make_inputs(tmp_path_factory.mktemp("bad"))


@pytest.mark.parametrize(
    "case",
    [pytest.param(c, id=c.id, marks=[pytest.mark.slow] if c.slow else []) for c in CASES],
)
def test_bad_input_is_one_clean_line_and_loses_nothing(case, inputs):
    outcome = run_case(case, inputs)
    assert outcome.problems(case, inputs) == [], outcome.lines


def test_the_table_covers_every_command():
    commands = {c.args[0] for c in CASES}
    assert commands == set(main.commands)
    assert len(CASES) >= 110


def test_world_points_in_metres_are_read_as_mm_with_one_warning_line(tmp_path):
    from handvar.vision.keypoints import KeypointUnitWarning, read_keypoints

    assert metres_outcome(tmp_path) == []
    z = np.load(Path(__file__).parents[1] / "examples/data/tfjs-asl-hand-mediapipe.npz")
    with pytest.warns(KeypointUnitWarning, match=r"kp_metres\.npz: world points taken as metres"):
        back = read_keypoints(tmp_path / "kp_metres.npz")
    np.testing.assert_allclose(back.world, z["world_mm"], rtol=1e-12)  # / 1000, then * 1000
    # in mm they read as they are, without a warning (warnings are errors here)
    np.savez(tmp_path / "kp_mm.npz", keypoints=z["landmarks_px"], world=z["world_mm"])
    np.testing.assert_array_equal(read_keypoints(tmp_path / "kp_mm.npz").world, z["world_mm"])


def test_ctrl_c_on_a_batch_prints_aborted_alone_and_keeps_whole_folders(tmp_path):
    assert interrupt_outcome(tmp_path) == []


def test_the_embedded_clusters_workers_leave_ctrl_c_to_the_client():
    """The preload each worker of `local_client` runs: SIGINT ignored (run here in a
    child, as a worker runs it)."""
    from handvar.evaluation.experiment import WORKER_PRELOAD

    check = WORKER_PRELOAD + "print(signal.getsignal(signal.SIGINT) is signal.SIG_IGN)"
    run = subprocess.run([sys.executable, "-c", check], capture_output=True, text=True, timeout=60)
    assert run.stdout.strip() == "True", run.stderr


WORKER_LOGS = """
import logging
from handvar.evaluation.experiment import local_client

def logs():
    logging.getLogger("distributed.worker").error("an error the worker logs")
    return 1

if __name__ == "__main__":
    client, cluster = local_client(1)
    print(client.submit(logs).result())
    client.close()
    cluster.close()
"""


def test_the_embedded_clusters_workers_log_nothing_before_the_commands_line(tmp_path):
    """An error a worker of `local_client` logs (as when the cluster closes under it
    after a failure: a lost heartbeat) is not printed: a failing command prints its one
    line alone.  The task's result still comes back."""
    script = tmp_path / "worker_logs.py"
    script.write_text(WORKER_LOGS)
    run = subprocess.run([sys.executable, str(script)], capture_output=True, text=True,
                         timeout=120)  # fmt: skip
    assert run.returncode == 0, run.stderr
    assert run.stdout.strip() == "1"
    assert "an error the worker logs" not in run.stderr + run.stdout


def test_every_option_and_command_the_library_names_exists():
    options = cli_option_names()
    named = named_options_and_commands()
    commands = {f"handvar {name}" for name in main.commands}
    unknown = {k: v[:3] for k, v in named.items() if k not in options | commands}
    assert unknown == {}
    # the check sees what it should: options of several commands, and commands
    assert {"--keypoints", "--out", "--recover", "--format", "handvar keypoints"} <= set(named)


def test_handvar_tracks_keywords_become_its_options_and_only_there():
    """`handvar track` renames `handvar.track`'s keywords in its messages: where they name
    the argument at fault (before the colon), and after it only where they stand for an
    option, never a plain word ("hand") or the command ``handvar keypoints``."""
    from handvar.cli.track import OPTION_NAMES, TEXT_NAMES, _cli_message

    track_options = cli_option_names() | {"SEQ"}
    assert set(OPTION_NAMES.values()) | set(TEXT_NAMES.values()) <= track_options
    for message, seq, expected in [
        ("realtime: expected recovery on and carry forward or none (one frame at a time); "
         "got recover=True, carry=both", "v.mp4",
         "--realtime: expected --recover on and --carry forward or none (one frame at a "
         "time); got --recover, --carry both"),
        ("realtime: expected recovery on and carry forward or none (one frame at a time); "
         "got recover=False, carry=forward", "v.mp4",
         "--realtime: expected --recover on and --carry forward or none (one frame at a "
         "time); got --no-recover, --carry forward"),
        ("hand: auto expected keypoints with handedness (a .npz written by handvar "
         "keypoints); got none", "v.mp4",
         "--hand: auto expected --keypoints with handedness (a .npz written by handvar "
         "keypoints); got none"),
        ("skin.avi: expected a hand in some frame; none of the 4 frames read shows one",
         "skin.avi", "skin.avi: expected a hand in some frame; none of the 4 frames read "
         "shows one"),
        ("recovery, on_frame: expected only with recover (on by default for a recording or "
         "with keypoints); got it off", "v.mp4",
         "--silhouette-term, --show: expected only with --recover (on by default for a "
         "recording or with --keypoints); got it off"),
        ("keypoint_every: expected only with keypoints", "v.mp4",
         "--keypoint-every: expected only with --keypoints"),
        ("flip: the sequence has no ground truth; give the first pose with init", "flip",
         "flip: the sequence has no ground truth; give the first pose with --init"),
        ("model: expected spheres for a left hand (the skinned mesh is a right hand); got "
         "mesh", "v.mp4", "--model: expected spheres for a left hand (the skinned mesh is a "
         "right hand); got mesh"),
        ("k.npy: expected keypoints of 3 frames (the recording's); got 2", "v.mp4",
         "k.npy: expected keypoints of 3 frames (the recording's); got 2"),
    ]:  # fmt: skip
        assert _cli_message(message, seq) == expected


def test_track_load_names_directory_and_a_garbled_meta(inputs):
    from handvar.pipeline import Track

    with pytest.raises(TypeError, match=r"^directory: expected a path \(str or path-like\); got "):
        Track.load(42)
    with pytest.raises(ValueError, match=r"track_meta/track\.npz: not a readable track \(meta: "):
        Track.load(inputs / "track_meta")
    far = r"track\.npz: poses: expected a pose within the parameter limits; tz = 1e\+09 at frame 1 "
    with pytest.raises(ValueError, match=far):
        Track.load(inputs / "track_far")
    assert Track.load(inputs / "track_good").n_frames == 2


def test_allow_short_is_taken_with_two_hands(inputs):
    """--allow-short with --hands 2: the frames read are tracked, after its warning (not
    the refusal that asks for --allow-short)."""
    case = _c("", "track {r}/short.avi --hands 2 --allow-short --out {r}/track_out", "")
    outcome = run_case(dataclasses.replace(case, subprocess=True), inputs)
    assert outcome.status == 2 and len(outcome.lines) == 2, outcome.lines
    assert outcome.lines[0].endswith("(a truncated or damaged video); using the 5 read")
    assert outcome.lines[1] == ("handvar: error: short.avi: expected a hand; the detector "
                                "found none in its 5 frames")  # fmt: skip


def test_hands_track_load_names_directory(inputs):
    from handvar.pipeline import HandsTrack

    with pytest.raises(TypeError, match=r"^directory: expected a path \(str or path-like\)"):
        HandsTrack.load(42)
    for folder in (inputs / "hands_noindex", inputs / "hands_good" / "hands.json"):
        with pytest.raises(ValueError, match=r"^directory: expected a directory of both hands "
                           r"with hands\.json"):  # fmt: skip
            HandsTrack.load(folder)
    assert HandsTrack.load(inputs / "hands_good").n_frames == 2


def test_a_track_replaces_an_earlier_one_of_the_other_kind_in_its_folder(inputs, tmp_path):
    """One hand's track written where both hands' were loses their index (else `handvar
    export` and `handvar view` read the earlier hands), and both hands' written where one
    hand's was lose its files; the rest of the folder stays."""
    import shutil

    from handvar.pipeline import HandsTrack, Track

    folder = tmp_path / "out"
    shutil.copytree(inputs / "hands_good", folder)
    (folder / "mine.txt").write_bytes(KNOWN)
    Track.load(inputs / "track_good").save(folder, video=False, overlays=False)
    assert not (folder / "hands.json").exists() and (folder / "mine.txt").read_bytes() == KNOWN
    HandsTrack.load(inputs / "hands_good").save(folder, video=False)
    assert sorted(p.name for p in folder.iterdir()) == ["hands.json", "mine.txt", "right"]


def test_unwritable_folder_is_refused_before_rendering(tmp_path, monkeypatch):
    # root may write anywhere, so the folder's permission is simulated
    from handvar import atomic

    real = os.access
    monkeypatch.setattr(
        atomic.os, "access", lambda p, mode: False if Path(p) == tmp_path else real(p, mode)
    )
    for args, name in [
        (["synth", "flip", str(tmp_path / "s")], "OUT"),
        (["show", "open", "--out", str(tmp_path / "o.png")], "--out"),
        (["predict", "x.txt", "--csv", str(tmp_path / "o.csv")], "--csv"),
        (["track", "flip", "--out", str(tmp_path / "t")], "--out"),
        (["report", "x.zarr", "--out", str(tmp_path / "r")], "--out"),
    ]:
        res = CliRunner().invoke(main, args)
        assert res.exit_code == 2, res.output
        assert res.output == f"handvar: error: {name}: expected a writable folder; cannot " \
            f"write into {tmp_path}\n"  # fmt: skip
    assert list(tmp_path.iterdir()) == []
