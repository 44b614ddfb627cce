"""Round-trip errors of the exported formats, read back by independent readers.

Run ``python benchmarks/export_roundtrip.py`` (from the repository root; the readers
are those of the tests, `tests/export_readers.py`: bvhio for BVH, pygltflib plus the
glTF specification's linear blend skinning for glTF). On the whole synthetic benchmark
track (175 frames), both hands, it prints:

- BVH: the largest distance between bvhio's forward kinematics and G(x), mm;
- glTF: the largest distance between the file's skinned vertices and the model's mesh
  at 5 frames, mm, with the per-frame corrective morph targets and without them (plain
  skinning of the rest mesh), and the file's size;
- keypoint JSON: the largest difference of the read-back world keypoints and pixels,
  and the share of keypoints visible in the first camera.
"""

from __future__ import annotations

import json
import sys
import tempfile
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


def main() -> None:
    poses = sequence_poses("benchmark")
    rig = Rig.default()
    folder = Path(tempfile.mkdtemp())
    print(f"synthetic benchmark track: {len(poses)} frames")
    for side in ("right", "left"):
        shape = HandShape.from_size(185.0, side=side)
        hand = HandModel(shape)
        truth = np.stack([hand.joints(x) for x in poses])

        path = folder / f"{side}.bvh"
        path.write_text(bvh_text(poses, shape))
        err = np.abs(bvh_world_joints(path, bvh_joint_order()) - truth).max()
        print(f"{side:5s} BVH  max |bvhio FK - G(x)| over all frames: {err:.2e} mm")

        frames = np.linspace(0, len(poses) - 1, 5).round().astype(int).tolist()
        want = mesh_vertices(shape, poses[frames])
        for corrective in (True, False):
            path = folder / f"{side}-{corrective}.glb"
            path.write_bytes(glb_bytes(poses, shape, corrective=corrective))
            got = gltf_skinned_vertices(path, frames)
            err = max(np.abs(got[f] * 1000.0 - want[i]).max() for i, f in enumerate(frames))
            label = "with corrective morphs" if corrective else "plain skinning       "
            size = path.stat().st_size / 1e6
            print(f"{side:5s} glTF {label} max vertex error at {len(frames)} frames: "
                  f"{err:.2e} mm  ({size:.1f} MB)")  # fmt: skip

        doc = json.loads(json.dumps(keypoint_frames(poses, hand, rig)))
        world = np.array([f["world"] for f in doc["frames"]])
        pix = np.array([f["views"][0]["keypoints_2d"] for f in doc["frames"]])
        want_pix = np.stack([rig.cameras[0].project(j) for j in truth])
        visible = np.mean([f["views"][0]["visible"] for f in doc["frames"]])
        print(f"{side:5s} JSON max world error {np.abs(world - truth).max():.1e} mm, pixel "
              f"error {np.abs(pix - want_pix).max():.1e} px; visible in camera 0: "
              f"{100 * visible:.1f}% of keypoints")  # fmt: skip


if __name__ == "__main__":
    main()
