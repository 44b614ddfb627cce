"""What the exported files hold, read back by independent readers (the tests' own,
`tests/export_readers.py`).

    python benchmarks/export_files.py

On the whole synthetic benchmark track (175 frames), both hands, it prints:

- BVH: the largest distance between bvhio's forward kinematics and G(x) turned into the
  file's axes and units (by hand: y up is x, -y, -z; z up is x, z, -y), mm, for every
  unit and up axis.
"""

from __future__ import annotations

import sys
import tempfile
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent.parent))

from tests.export_readers import bvh_world_joints

from handvar.export import bvh_text
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


def main() -> None:
    poses = sequence_poses("benchmark")
    folder = Path(tempfile.mkdtemp())
    print(f"synthetic benchmark track: {len(poses)} frames")
    bvh_errors(poses, folder)


if __name__ == "__main__":
    main()
