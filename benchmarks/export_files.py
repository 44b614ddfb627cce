"""What the exported files hold, read back by independent readers (the tests' own,
`tests/export_readers.py`).

    python benchmarks/export_files.py

On the whole synthetic benchmark track (175 frames), both hands, it prints:

- BVH: the largest distance between bvhio's forward kinematics and G(x) turned into the
  file's axes and units (by hand: y up is x, -y, -z; z up is x, z, -y), mm, for every
  unit and up axis;
- glTF: the largest distance between the file's skinned vertices (the specification's
  linear blend skinning, turned back from y-up metres) and the model's mesh over every
  frame, mm, with the helper joints, as a reader that takes only the first four
  influences sees it, and without the helpers (plain skinning); the file's size;
- keypoint JSON (read with `json`): the largest difference of the world keypoints and
  the first camera's pixels from G(x) and its projection, and the share of keypoints
  visible in that camera.

Then it builds the .glb of a 10-minute 30 fps synthetic track (the benchmark track
played forwards and backwards to 18,000 frames) and prints its size and build time.
"""

from __future__ import annotations

import json
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent.parent))

from tests.export_readers import bvh_world_joints, gltf_skinned_vertices

from handvar.camera import Rig
from handvar.export import bvh_text, glb_bytes, keypoint_frames, mesh_vertices
from handvar.export.bvh import bvh_joint_order
from handvar.hand.anthropometry import HandShape
from handvar.hand.kinematics import HandModel
from handvar.synth.sequences import sequence_poses

MM = {"mm": 1.0, "cm": 10.0, "m": 1000.0}


def in_file_axes(points: np.ndarray, up: str) -> np.ndarray:
    """Camera-frame points (x right, y down, z forward) in a y-up or z-up file's axes."""
    return points * [1.0, -1.0, -1.0] if up == "y" else points[..., [0, 2, 1]] * [1.0, 1.0, -1.0]


def bvh_errors(poses: np.ndarray, folder: Path) -> None:
    for side in ("right", "left"):
        shape = HandShape.from_size(185.0, side=side)
        hand = HandModel(shape)
        truth = np.stack([hand.joints(x) for x in poses])
        worst = []
        for units in MM:
            for up in ("y", "z"):
                path = folder / f"{side}-{units}-{up}.bvh"
                path.write_text(bvh_text(poses, shape, units=units, up=up))
                got = bvh_world_joints(path, bvh_joint_order()) * MM[units]
                worst.append(np.abs(got - in_file_axes(truth, up)).max())
        print(f"{side:5s} BVH  max |bvhio FK - G(x)| over {len(poses)} frames, units m/cm/mm, "
              f"up y/z: {max(worst):.1e} mm")  # fmt: skip


def gltf_errors(poses: np.ndarray, folder: Path) -> None:
    for side in ("right", "left"):
        shape = HandShape.from_size(185.0, side=side)
        want = in_file_axes(mesh_vertices(shape, poses), "y") / 1000.0  # metres, y up
        for label, corrective, first_set in [("helper joints", True, False),
                                             ("first four influences", True, True),
                                             ("plain skinning", False, False)]:  # fmt: skip
            path = folder / f"{side}-{corrective}.glb"
            path.write_bytes(glb_bytes(poses, shape, corrective=corrective))
            got = gltf_skinned_vertices(path, range(len(poses)), first_set=first_set)
            err = max(np.linalg.norm(got[f] - want[f], axis=1).max() for f in got) * 1000.0
            size = path.stat().st_size / 1e6
            print(f"{side:5s} glTF {label:21s}: max |skinned - model mesh| over "
                  f"{len(poses)} frames {err:.1e} mm ({size:.2f} MB)")  # fmt: skip


def json_errors(poses: np.ndarray) -> None:
    rig = Rig.default()
    for side in ("right", "left"):
        hand = HandModel(HandShape.from_size(185.0, side=side))
        truth = np.stack([hand.joints(x) for x in poses])
        doc = json.loads(json.dumps(keypoint_frames(poses, hand, rig)))
        world = np.array([f["world"] for f in doc["frames"]])
        pixels = np.array([f["views"][0]["keypoints_2d"] for f in doc["frames"]])
        want = np.stack([rig.cameras[0].project(j) for j in truth])
        visible = np.mean([f["views"][0]["visible"] for f in doc["frames"]])
        print(f"{side:5s} JSON max world error {np.abs(world - truth).max():.1e} mm, pixel "
              f"error {np.abs(pixels - want).max():.1e} px; visible in camera 0: "
              f"{100 * visible:.1f}% of keypoints")  # fmt: skip


def long_track(poses: np.ndarray, folder: Path) -> None:
    fps, minutes = 30.0, 10
    n = int(minutes * 60 * fps)
    long = np.resize(np.concatenate([poses, poses[::-1]]), (n, poses.shape[1]))
    start = time.perf_counter()
    data = glb_bytes(long, HandShape.from_size(185.0), fps=fps)
    seconds = time.perf_counter() - start
    (folder / "long.glb").write_bytes(data)
    print(f"{minutes}-minute {fps:.0f} fps synthetic track ({n} frames): .glb "
          f"{len(data) / 1e6:.2f} MB, built in {seconds:.1f} s")  # fmt: skip


def main() -> None:
    poses = sequence_poses("benchmark")
    folder = Path(tempfile.mkdtemp())
    print(f"synthetic benchmark track: {len(poses)} frames")
    bvh_errors(poses, folder)
    gltf_errors(poses, folder)
    json_errors(poses)
    long_track(poses, folder)


if __name__ == "__main__":
    main()
