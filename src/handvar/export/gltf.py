"""The skinned mesh hand and the motion of a track as glTF 2.0 binary (.glb).

Layout (docs/outputs.md):

- **Axes and units**: glTF's, metres and y up. The camera (world) frame, x right, y
  down, z forward, is turned by 180° about x (`Y_UP`: x, −y, −z), a proper rotation;
  the camera then looks along −z, as a glTF camera does.
- **Nodes**: one per bone of `BONES` (node i is bone i, node 0 the palm at the wrist),
  one per fingertip, then, with ``corrective``, six helper joints per bone (below), and
  the mesh node. A node's local transform is its bone in its parent's frame as
  `handvar.hand.kinematics` composes them: the palm ``Y_UP T(t) Rx(rx) Ry(ry) Rz(rz)``,
  a digit's first bone ``T(b_k) Rz(s_k a_k) B_k Rx(f1)``, the next ones
  ``T(0, L, 0) Rx(f)``, the tip ``T(0, L3, 0)``.
- **Skin**: the bones, the tips and the helpers; inverse bind matrices are the inverses
  of their rest frames (all 26 parameters 0, the hand frame then the camera frame,
  turned by `Y_UP`). The mesh (`handvar.hand.mesh`) is stored in that rest pose with
  normals and a skin-coloured metallic-roughness material.
- **Animation**: a key per frame at ``i / fps`` seconds: the palm's translation and
  every bone's rotation (quaternions, signs chosen for the shortest path), LINEAR. The
  frame rate is also in the asset's and the scene's ``extras`` (``fps``).
- **Frames without a hand** (pose NaN as a whole): the palm's scale is 0 there (a STEP
  channel keyed where the hand comes and goes), which collapses the skinned mesh to a
  point, so the hand is hidden; its bones hold the last tracked pose (before the first
  tracked frame, the first one, `handvar.export.absent.held_poses`).

The model's mesh is not plain linear blend skinning: a vertex's coordinates in each of
its bones come from a per-bone registration (`SkinnedMesh`), ``v = Σ_b w_b (R_b l_b +
o_b)``, while glTF skins one rest position p: ``Σ_b w_b (R_b q_b + o_b)`` with ``q_b``
p in bone b's rest frame. The difference ``Σ_b w_b R_b d_b``, ``d_b = l_b − q_b``, is
rotated with the bones, so it is carried by joints that move with them: helper joint
(b, ±axis) is a child of bone b with no transform of its own and inverse bind matrix
``T(±s e_axis) · IBM_b``, so that it skins p to ``R_b (q_b ± s e_axis) + o_b``. Moving
weight ``u = w_b |d_b,axis| / s`` from bone b to the helper on the side of the sign of
``d_b,axis``, for each axis, adds exactly ``w_b R_b d_b``: the file's skinned vertices
are the model's at every pose, to float32 rounding, with a fixed skin whatever the
number of frames (the file grows linearly with them). ``s`` (`_helper_reach`) is at
least the largest ``|d_b|₁``, so no bone's weight goes negative. p is the model's rest
mesh (the blend of the ``l_b``). The first ``JOINTS_0`` / ``WEIGHTS_0`` set holds the
vertex's bones, the next three its helpers (a vertex has up to 16 influences): a
reader that takes the first set alone skins the rest mesh by its bones, off by up to
7 mm near the knuckles (as plain skinning, ``corrective=False``).

A left hand: the package's mesh is a right hand; its mirror image in the hand frame's
y–z plane (`HandShape.mirrored`) is exported, with the triangles' winding reversed so
their normals still face outwards. The skeleton is the left hand's own (proper
rotations), so a left track animates it with the same 26 parameters.

Several hands (`hands_glb_bytes`): each hand's nodes, skin and mesh as above, named by
side, in one file; one animation holds every hand's channels.
"""

from __future__ import annotations

import json
import os
import struct
from pathlib import Path

import numpy as np
from scipy.spatial.transform import Rotation

from handvar.atomic import write_atomic
from handvar.export.absent import hand_frames, held_poses
from handvar.export.hands import checked_hands
from handvar.geometry.normals import vertex_normals
from handvar.hand.anthropometry import BONES, HandShape, bone_index
from handvar.hand.kinematics import HandModel, world_from_hand_rotation
from handvar.params import DIGITS, N_PARAMS
from handvar.validate import as_array, as_instance

__all__ = [
    "SKIN_COLOUR",
    "Y_UP",
    "glb_bytes",
    "hands_glb_bytes",
    "mesh_vertices",
    "rest_mesh",
    "write_glb",
    "write_hands_glb",
]

_M = 1e-3  # metres per mm
_DEFAULT_FPS = 30.0
_FLOAT, _UINT, _USHORT = 5126, 5125, 5123
_MIRROR = np.array([-1.0, 1.0, 1.0])
#: glTF's axes (y up) from the camera frame (x right, y down, z forward): 180° about x.
Y_UP = np.diag([1.0, -1.0, -1.0])
#: Base colour of the hand's material, linear RGBA (sRGB about 230, 182, 155: skin).
SKIN_COLOUR = (0.79, 0.48, 0.34, 1.0)
#: The least helper reach s, mm: longer than any bone, so that Blender's importer,
#: which sizes a bone by its nearest child joint, still sizes it by the next bone.
_MIN_REACH = 100.0


def _mesh_model(shape: HandShape) -> HandModel:
    """The mesh model of the right hand of `shape` (itself, or its mirror image)."""
    right = shape if shape.side == "right" else shape.mirrored()
    return HandModel(right, surface="mesh")


def mesh_vertices(shape: HandShape, poses, *, model: HandModel | None = None) -> np.ndarray:
    """The skinned mesh's vertices at each pose, (T, V, 3) mm, world frame.

    For a right hand these are ``HandModel(shape, surface="mesh").mesh.vertices(x)``;
    for a left hand the right hand's, mirrored in the hand frame's y–z plane:
    ``R M Rᵀ (v − t) + t`` with M = diag(−1, 1, 1) and (R, t) the palm's pose.

    Parameters
    ----------
    shape : HandShape
    poses : (T, 26) array_like
    model : HandModel, keyword-only, optional
        The right-hand mesh model to use (built from `shape` when omitted).
    """
    as_instance(shape, HandShape, "shape")
    poses = as_array(poses, "poses", (None, N_PARAMS), what="poses")
    model = _mesh_model(shape) if model is None else model
    out = np.empty((poses.shape[0], model.mesh.skinned.n_vertices, 3))
    for i, x in enumerate(poses):
        v = model.mesh.vertices(x)
        if shape.side == "left":
            R, _ = world_from_hand_rotation(x[3:6])
            t = x[0:3]
            v = ((v - t) @ R * _MIRROR) @ R.T + t
        out[i] = v
    return out


def rest_mesh(shape: HandShape, *, model: HandModel | None = None):
    """The mesh at the rest pose (all 26 parameters 0): vertices (V, 3) mm in the hand
    frame, triangles (F, 3) (outward winding) and dense weights (V, 16) over `BONES`."""
    model = _mesh_model(shape) if model is None else model
    vertices = mesh_vertices(shape, np.zeros((1, N_PARAMS)), model=model)[0]
    triangles = model.mesh.triangles
    if shape.side == "left":
        triangles = triangles[:, ::-1]
    return vertices, np.ascontiguousarray(triangles), model.mesh.skinned._dense_weight


def _bone_points(shape: HandShape, model: HandModel) -> np.ndarray:
    """(V, 16, 3) each vertex in each bone's frame (the model's l_b), mm; a left hand's
    are the right hand's mirrored in x, since its bone frames are the mirror images."""
    local = model.mesh.skinned._dense_local  # the registration (`SkinnedMesh`)
    return local * _MIRROR if shape.side == "left" else local


def _rest_skin(shape: HandShape, model: HandModel, corrective: bool):
    """The rest mesh p (V, 3) mm, triangles, weights (V, 16), the corrections d (V, 16, 3)
    mm in bone frames (module docstring; 0 without `corrective`) and the bones' rest
    frames."""
    p, triangles, weights = rest_mesh(shape, model=model)
    R0, o0 = HandModel(shape).bone_frames(np.zeros(N_PARAMS))  # rest: hand = world
    d = np.zeros((*weights.shape, 3))
    if corrective:
        q = np.einsum("bji,vbj->vbi", R0, p[:, None] - o0)  # p in each bone's rest frame
        d = np.where(weights[..., None] > 0, _bone_points(shape, model) - q, 0.0)
    return p, triangles, weights, d, R0, o0


def _helper_reach(d: np.ndarray) -> float:
    """The helpers' offset s, mm: at least `_MIN_REACH` and the largest ``|d_b|₁``."""
    return float(max(_MIN_REACH, np.ceil(np.abs(d).sum(axis=-1).max())))


def _influences(weights: np.ndarray, d: np.ndarray, reach: float, first_helper: int):
    """Per vertex the joints and weights of the bones (first set) and of the helpers.

    Helper (b, axis, side) is skin joint ``first_helper + 6 b + 2 axis + side`` (side 0
    for +, 1 for −). Returns dense (V, n_joints) weights: bones with ``w_b − Σ u``,
    helpers with ``u = w_b |d_b,axis| / s``.
    """
    n_v, n_b = weights.shape
    u = weights[..., None] * np.abs(d) / reach  # (V, 16, 3)
    dense = np.zeros((n_v, first_helper + 6 * n_b))
    dense[:, :n_b] = weights - u.sum(axis=2)
    side = (d < 0).astype(int)
    cols = first_helper + 6 * np.arange(n_b)[:, None] + 2 * np.arange(3) + side  # (V, 16, 3)
    np.put_along_axis(dense, cols.reshape(n_v, -1), u.reshape(n_v, -1), axis=1)
    return dense


def _weight_sets(dense: np.ndarray, n_bones: int) -> list[tuple[np.ndarray, np.ndarray]]:
    """JOINTS_n / WEIGHTS_n pairs: the bones first (set 0), then the helpers, each set
    four influences by decreasing weight, unused slots joint 0 weight 0; the weights
    rounded to float32 so that each vertex's sum is 1 to float32 rounding."""
    groups = [dense[:, :n_bones], dense[:, n_bones:]]
    sets = []
    for g, offset in zip(groups, (0, n_bones), strict=True):
        if not (g > 0).any():
            continue
        order = np.argsort(-g, axis=1, kind="stable")
        n_sets = -(-int((g > 0).sum(axis=1).max()) // 4)
        for s in range(n_sets):
            idx = order[:, 4 * s : 4 * s + 4]
            w = np.take_along_axis(g, idx, axis=1)
            sets.append((np.where(w > 0, idx + offset, 0), w))
    weights = np.concatenate([w for _, w in sets], axis=1).astype(np.float32)
    # put the float32 rounding of the sum on the largest weight (set 0, slot 0)
    weights[:, 0] += np.float32(1.0) - weights.sum(axis=1, dtype=np.float64).astype(np.float32)
    return [(j.astype(np.uint16), weights[:, 4 * i : 4 * i + 4])
            for i, (j, _) in enumerate(sets)]  # fmt: skip


def _local_rotations(poses: np.ndarray, shape: HandShape) -> np.ndarray:
    """(T, 16, 3, 3) each bone's rotation in its parent's frame (module docstring); the
    palm's in the camera frame."""
    n = poses.shape[0]
    rot = np.empty((n, len(BONES), 3, 3))
    rot[:, 0] = Rotation.from_euler("XYZ", poses[:, 3:6], degrees=True).as_matrix()
    for k in range(5):
        abd = Rotation.from_euler(
            "z", shape.abduction_sign[k] * poses[:, 6 + k, None], degrees=True
        )
        for level in range(3):
            flex = Rotation.from_euler("x", poses[:, 11 + 3 * k + level, None], degrees=True)
            b = bone_index(k, level)
            if level == 0:
                rot[:, b] = (abd.as_matrix() @ shape.base_rotations[k]) @ flex.as_matrix()
            else:
                rot[:, b] = flex.as_matrix()
    return rot


def _local_translations(shape: HandShape) -> np.ndarray:
    """(16, 3) each bone's origin in its parent's frame, mm (the palm's: 0)."""
    out = np.zeros((len(BONES), 3))
    for k in range(5):
        out[bone_index(k, 0)] = shape.bases[k]
        for level in (1, 2):
            out[bone_index(k, level), 1] = shape.segments[k, level - 1]
    return out


def _parents() -> list[int]:
    parent = [-1] * len(BONES)
    for k in range(5):
        parent[bone_index(k, 0)] = 0
        parent[bone_index(k, 1)] = bone_index(k, 0)
        parent[bone_index(k, 2)] = bone_index(k, 1)
    return parent


def _quaternions(matrices: np.ndarray) -> np.ndarray:
    """(T, 4) x, y, z, w of (T, 3, 3), signs chosen for the shortest path between keys:
    key i is negated when the product of the signs of the dot products up to it is −1."""
    q = Rotation.from_matrix(matrices).as_quat()
    turn = np.where(np.einsum("ij,ij->i", q[1:], q[:-1]) < 0, -1.0, 1.0)
    q[1:] *= np.cumprod(turn)[:, None]
    return q


def _frame(R: np.ndarray, o: np.ndarray) -> np.ndarray:
    """(..., 4, 4) rigid transforms from rotations (..., 3, 3) and origins (..., 3)."""
    m = np.zeros((*R.shape[:-2], 4, 4))
    m[..., :3, :3] = R
    m[..., :3, 3] = o
    m[..., 3, 3] = 1.0
    return m


class _Buffer:
    """The binary chunk, its buffer views and accessors, built together."""

    def __init__(self) -> None:
        self.data = bytearray()
        self.views: list[dict] = []
        self.accessors: list[dict] = []

    def view(self, array: np.ndarray, target: int | None = None) -> int:
        while len(self.data) % 4:
            self.data.append(0)
        raw = np.ascontiguousarray(array).tobytes()
        view = {"buffer": 0, "byteOffset": len(self.data), "byteLength": len(raw)}
        if target is not None:
            view["target"] = target
        self.data += raw
        self.views.append(view)
        return len(self.views) - 1

    def accessor(self, array, kind: str, *, target=None, bounds=False) -> int:
        arr = np.asarray(array)
        ctype = {np.dtype(np.float32): _FLOAT, np.dtype(np.uint32): _UINT,
                 np.dtype(np.uint16): _USHORT}[arr.dtype]  # fmt: skip
        acc = {"bufferView": self.view(arr, target), "componentType": ctype,
               "count": int(arr.shape[0]), "type": kind}  # fmt: skip
        if bounds:
            flat = arr.reshape(arr.shape[0], -1)
            acc["min"] = flat.min(axis=0).tolist()
            acc["max"] = flat.max(axis=0).tolist()
        self.accessors.append(acc)
        return len(self.accessors) - 1


def glb_bytes(
    poses, shape: HandShape, *, fps: float | None = None, corrective: bool = True,
    model: HandModel | None = None,
) -> bytes:  # fmt: skip
    """The .glb file of a track: skinned mesh, skeleton and animation (module docstring).

    Parameters
    ----------
    poses : (T, 26) array_like
        mm and degrees, camera (world) frame; NaN as a whole on a frame without a
        hand, where the hand is hidden (its bones hold a tracked pose, `held_poses`).
    shape : HandShape
        The tracked hand (either side).
    fps : float, keyword-only, optional
        Frame rate of the recording (key times ``i / fps`` seconds); 30 when unknown.
    corrective : bool, keyword-only
        Add the helper joints that make the skinned vertices the model's at every pose
        (module docstring); without them plain skinning of the model's rest mesh is
        off by up to several mm near the knuckles.
    model : HandModel, keyword-only, optional
        The right-hand mesh model (`mesh_vertices`), built when omitted.

    Returns
    -------
    bytes

    Raises
    ------
    ValueError
        If no frame has a hand, or a pose is NaN in part.
    """
    present = hand_frames(poses, "poses", (None, N_PARAMS))[1]
    poses = held_poses(poses)
    as_instance(shape, HandShape, "shape")
    fps = _frame_rate(fps)
    n = poses.shape[0]
    model = _mesh_model(shape) if model is None else model
    buf = _Buffer()
    nodes: list[dict] = []
    hand = _skinned_hand(buf, nodes, poses, shape, model, corrective, prefix="", index=0)
    times = buf.accessor((np.arange(n) / fps).astype(np.float32), "SCALAR", bounds=True)
    samplers: list[dict] = []
    channels: list[dict] = []
    _channels(buf, samplers, channels, hand, present, times, fps)

    extras = {"fps": fps, "frames": n, "frames_without_hand": int(n - present.sum())}
    document = {
        "asset": {"version": "2.0", "generator": "handvar", "extras": extras},
        "scene": 0,
        "scenes": [
            {"name": "track", "nodes": [hand["root"], hand["mesh_node"]], "extras": {"fps": fps}}
        ],
        "nodes": nodes,
        "meshes": [hand["mesh"]],
        "materials": [_MATERIAL],
        "skins": [hand["skin"]],
        "animations": [{"name": "track", "samplers": samplers, "channels": channels}],
        "accessors": buf.accessors,
        "bufferViews": buf.views,
        "buffers": [{"byteLength": len(buf.data)}],
    }
    return _glb(document, bytes(buf.data))


def hands_glb_bytes(hands, *, fps: float | None = None, corrective: bool = True) -> bytes:
    """The .glb file of several hands: per hand a skinned mesh, its skin and its node
    hierarchy as `glb_bytes` writes them, named by side, and one animation holding the
    channels of every hand.

    A hand's nodes, mesh and skin are named as one hand's, prefixed with its side
    (``right_palm``, ``left_index_tip``, mesh and skin ``left_hand``, mesh node
    ``left_hand_mesh``); the hands share the material and the key times. A frame
    without a hand hides that hand (its palm scaled to 0), as `glb_bytes` does.

    Parameters
    ----------
    hands : sequence of TrackedHand
        At most one of each side, over the same frames (`checked_hands`); each with a
        hand on some frame.
    fps, corrective : keyword-only
        As `glb_bytes`.

    Returns
    -------
    bytes

    Raises
    ------
    ValueError
        If a hand has no frame with a hand, or a pose is NaN in part.
    """
    hands = checked_hands(hands)
    fps = _frame_rate(fps)
    buf = _Buffer()
    nodes: list[dict] = []
    parts = []
    for i, h in enumerate(hands):
        name = f"hands ({h.side}) poses"
        present = hand_frames(h.poses, name, (None, N_PARAMS))[1]
        poses = held_poses(h.poses, name=name)
        shape = h.hand.shape
        part = _skinned_hand(buf, nodes, poses, shape, _mesh_model(shape), corrective,
                             prefix=f"{h.side}_", index=i)  # fmt: skip
        parts.append((part, present))
    n = len(parts[0][1])
    times = buf.accessor((np.arange(n) / fps).astype(np.float32), "SCALAR", bounds=True)
    samplers: list[dict] = []
    channels: list[dict] = []
    for part, present in parts:
        _channels(buf, samplers, channels, part, present, times, fps)

    roots = [i for p, _ in parts for i in (p["root"], p["mesh_node"])]
    extras = {"fps": fps, "frames": n,
              "hands": [{"side": h.side, "id": int(h.id),
                         "frames_without_hand": int(n - present.sum())}
                        for h, (_, present) in zip(hands, parts, strict=True)]}  # fmt: skip
    document = {
        "asset": {"version": "2.0", "generator": "handvar", "extras": extras},
        "scene": 0,
        "scenes": [{"name": "track", "nodes": roots, "extras": {"fps": fps}}],
        "nodes": nodes,
        "meshes": [p["mesh"] for p, _ in parts],
        "materials": [_MATERIAL],
        "skins": [p["skin"] for p, _ in parts],
        "animations": [{"name": "track", "samplers": samplers, "channels": channels}],
        "accessors": buf.accessors,
        "bufferViews": buf.views,
        "buffers": [{"byteLength": len(buf.data)}],
    }
    return _glb(document, bytes(buf.data))


_MATERIAL = {
    "name": "skin",
    "pbrMetallicRoughness": {
        "baseColorFactor": list(SKIN_COLOUR),
        "metallicFactor": 0.0,
        "roughnessFactor": 0.6,
    },
}


def _frame_rate(fps) -> float:
    fps = _DEFAULT_FPS if fps is None else float(fps)
    if not (np.isfinite(fps) and fps > 0):
        raise ValueError(f"fps: expected a positive frame rate; got {fps}")
    return fps


def _skinned_hand(
    buf: _Buffer, nodes: list[dict], poses: np.ndarray, shape: HandShape, model: HandModel,
    corrective: bool, *, prefix: str, index: int,
) -> dict:  # fmt: skip
    """One hand's nodes (appended to `nodes`, named with `prefix`), its mesh (number
    `index`, material 0) and skin, their data in `buf`; returns them with the root's
    and the mesh node's indices and the animation's values (module docstring)."""
    at = len(nodes)  # this hand's first node
    rest, triangles, weights, d, R0, o0 = _rest_skin(shape, model, corrective)
    parents = _parents()
    trans = _local_translations(shape)
    rot = _local_rotations(poses, shape)
    rot[:, 0] = Y_UP @ rot[:, 0]  # the palm in glTF's axes
    quats = np.stack([_quaternions(rot[:, b]) for b in range(len(BONES))], axis=1)
    palm_t = poses[:, 0:3] @ Y_UP.T * _M

    # nodes: bones, tips, helpers, the mesh
    for b, name in enumerate(BONES):
        translation = palm_t[0] if b == 0 else trans[b] * _M
        node = {"name": prefix + name, "translation": translation.tolist(),
                "rotation": quats[0, b].tolist(), "children": []}  # fmt: skip
        nodes.append(node)
    for c, p in enumerate(parents):
        if p >= 0:
            nodes[at + p]["children"].append(at + c)
    tips = []
    for k in range(5):
        tips.append(len(nodes))
        nodes.append({"name": f"{prefix}{DIGITS[k]}_tip",
                      "translation": [0.0, float(shape.segments[k, 2] * _M), 0.0]})  # fmt: skip
        nodes[at + bone_index(k, 2)]["children"].append(tips[-1])
    bind = _frame(R0, o0 * _M)  # rest frames of the bones (metres), hand = camera frame
    tip_bind = np.stack([bind[bone_index(k, 2)] @ _frame(np.eye(3), nodes[t]["translation"])
                         for k, t in enumerate(tips)])  # fmt: skip
    joints = [at + b for b in range(len(BONES))] + tips
    ibm = [np.linalg.inv(_frame(Y_UP, np.zeros(3)) @ m) for m in (*bind, *tip_bind)]
    reach = _helper_reach(d)
    if corrective:
        for b, name in enumerate(BONES):
            for axis, sign in ((a, s) for a in range(3) for s in (1.0, -1.0)):
                joints.append(len(nodes))
                nodes[at + b]["children"].append(len(nodes))
                nodes.append({"name": f"{prefix}{name}_fix{'+' if sign > 0 else '-'}"
                                      f"{'xyz'[axis]}"})  # fmt: skip
                offset = np.zeros(3)
                offset[axis] = sign * reach * _M
                ibm.append(_frame(np.eye(3), offset) @ ibm[b])  # T(±s e_axis) IBM_b
    for node in nodes[at:]:
        if not node.get("children", True):
            del node["children"]
    mesh_node = len(nodes)
    nodes.append({"name": f"{prefix}hand_mesh", "mesh": index, "skin": index})

    # the mesh: rest positions, normals, weights in sets of four, triangles
    positions = rest @ Y_UP.T * _M
    attributes = {
        "POSITION": buf.accessor(positions.astype(np.float32), "VEC3", target=34962,
                                 bounds=True),
        "NORMAL": buf.accessor(vertex_normals(positions, triangles).astype(np.float32),
                               "VEC3", target=34962),
    }  # fmt: skip
    dense = _influences(weights, d, reach, len(BONES) + len(tips))
    for s, (j, w) in enumerate(_weight_sets(dense, len(BONES))):
        attributes[f"JOINTS_{s}"] = buf.accessor(j, "VEC4", target=34962)
        attributes[f"WEIGHTS_{s}"] = buf.accessor(w, "VEC4", target=34962)
    primitive = {"attributes": attributes, "mode": 4, "material": 0,
                 "indices": buf.accessor(triangles.reshape(-1).astype(np.uint32), "SCALAR",
                                         target=34963)}  # fmt: skip
    skin = {"name": f"{prefix}hand", "joints": joints, "skeleton": at,
            "inverseBindMatrices": buf.accessor(
                np.stack(ibm).transpose(0, 2, 1).reshape(-1, 16).astype(np.float32),
                "MAT4")}  # fmt: skip  # column-major
    return {
        "root": at,
        "mesh_node": mesh_node,
        "skin": skin,
        "palm_t": palm_t,
        "quats": quats,
        "mesh": {"name": f"{prefix}hand", "primitives": [primitive]},
    }


def _channels(
    buf: _Buffer,
    samplers: list[dict],
    channels: list[dict],
    hand: dict,
    present: np.ndarray,
    times: int,
    fps: float,
) -> None:
    """Append one hand's animation (`_skinned_hand`'s) to `samplers` and `channels`: a
    key per frame at `times` for the palm's translation and every bone's rotation, and
    the palm's scale, 0 on frames without the hand (module docstring)."""
    root = hand["root"]

    def channel(node: int, path: str, values, kind: str, *, at=times, how="LINEAR") -> None:
        out = buf.accessor(np.asarray(values, dtype=np.float32), kind)
        samplers.append({"input": at, "output": out, "interpolation": how})
        channels.append({"sampler": len(samplers) - 1, "target": {"node": node, "path": path}})

    channel(root, "translation", hand["palm_t"], "VEC3")
    for b in range(len(BONES)):
        channel(root + b, "rotation", hand["quats"][:, b], "VEC4")
    if not present.all():  # hide the hand: palm scale 0, keyed where it comes and goes
        keys = np.flatnonzero(np.r_[True, present[1:] != present[:-1]])
        at = buf.accessor((keys / fps).astype(np.float32), "SCALAR", bounds=True)
        scale = np.repeat(present[keys, None].astype(float), 3, axis=1)
        channel(root, "scale", scale, "VEC3", at=at, how="STEP")


def _glb(document: dict, binary: bytes) -> bytes:
    """The GLB container: 12-byte header, a JSON chunk and a BIN chunk, 4-byte aligned."""
    text = json.dumps(document, separators=(",", ":")).encode("utf-8")
    text += b" " * (-len(text) % 4)
    binary += b"\0" * (-len(binary) % 4)
    length = 12 + 8 + len(text) + 8 + len(binary)
    return b"".join([
        struct.pack("<4sII", b"glTF", 2, length),
        struct.pack("<I4s", len(text), b"JSON"), text,
        struct.pack("<I4s", len(binary), b"BIN\0"), binary,
    ])  # fmt: skip


def write_glb(path: str | os.PathLike, poses, shape: HandShape, **options) -> Path:
    """Write the .glb of a track (`glb_bytes`, same keyword options) to `path`, atomically."""
    data = glb_bytes(poses, shape, **options)
    write_atomic(path, lambda tmp: Path(tmp).write_bytes(data))
    return Path(path)


def write_hands_glb(path: str | os.PathLike, hands, **options) -> Path:
    """Write the .glb of several hands (`hands_glb_bytes`, same keyword options) to
    `path`, atomically."""
    data = hands_glb_bytes(hands, **options)
    write_atomic(path, lambda tmp: Path(tmp).write_bytes(data))
    return Path(path)
