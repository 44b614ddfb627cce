"""The person's hand from two cameras, then one camera: what it does to the mono depth.

One camera cannot tell a large hand far away from a small one near: the one command
tracks a single video with the default 185 mm hand, and its absolute 3D error is mostly
that (docs/results/realistic-benchmark.md, "the size").  Two calibrated cameras fit the
hand's size too.  Here, on the realistic benchmark's 8 stereo cases (hands of 172–196
mm), each case is first tracked by the one command with both cameras (``handvar track
cam0,cam1 --calib calib.yml --out STEREO``, the detector inside), then its camera 0 alone
as a single video (a calibration of that camera only), by the one command as it is and
with the stereo track's hand (``handvar track cam0 --calib cam0.yml --shape STEREO``):
a person's hand measured once before two cameras, then tracked with one.

Printed per case and over the 8, against the truth (the scored points are the
detector's, as `studies/realistic.py` scores them): the absolute 3D error (mm, the
camera's frame), the wrist-relative one, 2D PCK@0.2, and beside them what the
detector alone gives with one camera: its points' PCK and its world landmarks'
wrist-relative error (it has no absolute 3D); the true hand length and the stereo
track's.

Run: ``PYTHONPATH=src .venv/bin/python studies/stereo_hand_mono.py --out DIR`` (DIR as
``studies/realistic.py --out DIR`` makes it; the cases are generated if missing; about 5
minutes on two cores).
"""

from __future__ import annotations

import argparse
import os
import subprocess
from pathlib import Path

import numpy as np

from handvar.camera import Rig
from handvar.evaluation.metrics import joint_errors, pck_2d
from handvar.evaluation.realistic import read_case
from handvar.pipeline import Track
from handvar.tracking.shape_fit import _wrist_to_tip
from handvar.vision.keypoints import read_keypoints
from realistic import HANDVAR, ROOT, generate, project, run_inside, scored_points, specs


def mono(case_dir: Path, out: Path, extra: tuple[str, ...] = ()) -> Track:
    """Camera 0 of the case as one video, by the one command (`extra`: more options)."""
    rig = Rig.load(case_dir / "calib.yml")
    out.mkdir(parents=True, exist_ok=True)
    Rig([rig.cameras[0]], ["cam0"]).save(out / "cam0.yml")
    run(["track", str(case_dir / "cam0"), "--calib", str(out / "cam0.yml"),
         "--out", str(out / "track"), "--no-video", *extra])  # fmt: skip
    return Track.load(out / "track")


def run(args: list[str]) -> None:
    """``handvar ARGS``, its error raised."""
    env = dict(os.environ, PYTHONPATH=str(ROOT / "src"))
    done = subprocess.run([*HANDVAR, *args], capture_output=True, text=True, env=env)
    if done.returncode != 0:
        raise RuntimeError(f"handvar {' '.join(args)}\n{done.stderr.strip()}")


def figures(case, track: Track) -> dict[str, float]:
    """Absolute and wrist-relative 3D error (mm) and 2D PCK@0.2 of `track` against the
    case's truth, camera 0."""
    points = scored_points(track.hand, track.poses)
    seen = np.isfinite(points).all(axis=(1, 2))
    truth = case.joints[seen]
    return {
        "abs": float(joint_errors(truth, points[seen], alignment="none").mean()),
        "rel": float(joint_errors(truth, points[seen], alignment="wrist").mean()),
        "pck": pck_2d(case.truth_2d[0], project(track.rig, points)[0]),
    }


def detector_alone(case, track_dir: Path) -> tuple[float, float]:
    """The detector the one command ran (its keypoints.npz): its points' 2D PCK@0.2 (a
    frame it missed counts as wrong) and its world landmarks' wrist-relative error (mm,
    in camera 0's axes, over the frames it found the hand)."""
    kp = read_keypoints(track_dir / "keypoints.npz")
    found = kp.present.all(axis=1)
    truth = case.joints[found] @ case.rig.cameras[0].R.T  # in camera 0's axes
    rel = float(joint_errors(truth, kp.world[found], alignment="wrist").mean())
    return pck_2d(case.truth_2d[0], kp.xy), rel


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", type=Path, required=True, help="the cases' folder")
    args = parser.parse_args()
    rows = []
    print(f"{'case':28s} {'abs default':>11s} {'abs person':>10s} {'rel default':>11s} "
          f"{'rel person':>10s} {'MP rel':>6s} {'PCK default':>11s} {'PCK person':>10s} "
          f"{'MP PCK':>6s} {'length true / stereo':>20s}")  # fmt: skip
    for spec in (s for s in specs(False) if s.cameras == 2):
        case_dir = args.out / spec.name
        if not (case_dir / "truth.npz").exists():
            generate(spec, case_dir)
        case = read_case(case_dir)
        work = args.out / "stereo-hand" / spec.name
        stereo = work / "stereo"
        run_inside(case_dir, spec, 1, stereo)  # the one command with both cameras
        default = mono(case_dir, work / "default")
        person = mono(case_dir, work / "person", ("--shape", str(stereo)))
        d, p = figures(case, default), figures(case, person)
        mp_pck, mp = detector_alone(case, work / "default" / "track")
        length = _wrist_to_tip(Track.load(stereo).shape)
        rows.append((d["abs"], p["abs"], d["rel"], p["rel"], mp, d["pck"], p["pck"], mp_pck))
        print(f"{spec.name:28s} {d['abs']:11.1f} {p['abs']:10.1f} {d['rel']:11.1f} "
              f"{p['rel']:10.1f} {mp:6.1f} {d['pck']:11.3f} {p['pck']:10.3f} {mp_pck:6.3f} "
              f"{case.hand_length:9.1f} / {length:.1f}", flush=True)  # fmt: skip
    m = np.mean(rows, axis=0)
    better = sum(r[1] < r[0] for r in rows)
    print(f"{'mean':28s} {m[0]:11.1f} {m[1]:10.1f} {m[2]:11.1f} {m[3]:10.1f} {m[4]:6.1f} "
          f"{m[5]:11.3f} {m[6]:10.3f} {m[7]:6.3f}")  # fmt: skip
    print(f"the person's hand lowers the absolute error on {better} of {len(rows)} cases")


if __name__ == "__main__":
    main()
