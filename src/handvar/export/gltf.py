"""The skinned mesh hand and the motion of a track as glTF 2.0 binary (.glb).

Layout (docs/outputs.md):

- one node per bone of `BONES` (node i is bone i, node 0 the palm at the wrist) and one
  per fingertip; a node's local transform is its bone in its parent's frame, exactly as
  `handvar.hand.kinematics` composes them: the palm ``T(t) Rx(rx) Ry(ry) Rz(rz)``, a
  digit's first bone ``T(b_k) Rz(s_k a_k) B_k Rx(f1)``, the next ones
  ``T(0, L, 0) Rx(f)``, the tip ``T(0, L3, 0)``;
- a skin over the 16 bone nodes whose inverse bind matrices are the bones' rest frames
  (all 26 parameters 0) inverted, and the mesh (`handvar.hand.mesh`) in that rest pose
  with its weights (``JOINTS_0/WEIGHTS_0``, more sets if a vertex has more than four);
- one animation with a key per frame: the palm's translation and every bone's rotation
  (quaternions), LINEAR interpolation.

Units are metres (glTF's), the frame is the world frame of the track's rig, unchanged.
A frame without a hand (its pose NaN as a whole) keeps its key, holding the last
tracked pose, or before the first tracked frame the first one
(`handvar.export.absent.held_poses`).

The model's mesh is not exactly linear blend skinning: a vertex's coordinates in each
of its bones come from a per-bone registration (`SkinnedMesh`), not from one rest
position. Standard skinning of the rest mesh is therefore off by up to several mm near
the knuckles (`benchmarks/export_roundtrip.py` prints it); with ``corrective=True``
(default) each frame carries a morph target, the rest-pose displacement that makes
standard skinning give the model's vertices at that frame, and the animation switches
it on at its key (weights one-hot per frame). The morph targets are sparse (only the
vertices that need one) but the weights grow as T².

A left hand: the package's mesh is a right hand; its mirror image in the hand frame's
y–z plane (`HandShape.mirrored`) is exported, with the triangles' winding reversed so
their normals still face outwards. The skeleton is the left hand's own (proper
rotations), so a left track animates it with the same 26 parameters.
"""

from __future__ import annotations

import json
import os
import struct
from pathlib import Path

import numpy as np
from scipy.spatial.transform import Rotation

from handvar.atomic import write_atomic
from handvar.export.absent import held_poses
from handvar.hand.anthropometry import BONES, HandShape, bone_index
from handvar.hand.kinematics import HandModel, world_from_hand_rotation
from handvar.params import DIGITS, N_PARAMS
from handvar.validate import as_array, as_instance

__all__ = ["glb_bytes", "mesh_vertices", "rest_mesh", "write_glb"]

_M = 1e-3  # metres per mm
_DEFAULT_FPS = 30.0
_FLOAT, _UINT, _USHORT = 5126, 5125, 5123
_MIRROR = np.array([-1.0, 1.0, 1.0])


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


def _local_rotations(poses: np.ndarray, shape: HandShape) -> np.ndarray:
    """(T, 16, 3, 3) each bone's rotation in its parent's frame (module docstring)."""
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
    """(T, 4) x, y, z, w of (T, 3, 3), signs chosen for the shortest path between keys."""
    q = Rotation.from_matrix(matrices).as_quat()
    for i in range(1, len(q)):
        if q[i] @ q[i - 1] < 0:
            q[i] = -q[i]
    return q


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

    def sparse(self, count: int, indices_view: int, values: np.ndarray, full_min, full_max):
        """A VEC3 float accessor of `count` zeros but `values` at the indices' rows."""
        acc = {"componentType": _FLOAT, "count": count, "type": "VEC3",
               "min": full_min, "max": full_max,
               "sparse": {"count": int(values.shape[0]),
                          "indices": {"bufferView": indices_view, "componentType": _UINT},
                          "values": {"bufferView": self.view(values.astype(np.float32))}},
               }  # fmt: skip
        self.accessors.append(acc)
        return len(self.accessors) - 1


def _skinning_setup(shape: HandShape, model: HandModel | None):
    model = _mesh_model(shape) if model is None else model
    vertices, triangles, weights = rest_mesh(shape, model=model)
    kin = HandModel(shape)
    R0, o0 = kin.bone_frames(np.zeros(N_PARAMS))  # rest: hand frame = world frame
    return model, kin, vertices, triangles, weights, R0, o0


def _corrections(poses, shape, model, kin, bind, weights, R0, o0) -> np.ndarray:
    """(T, V, 3) mm: the rest-pose displacement per frame after which standard skinning
    gives the model's vertices (module docstring)."""
    truth = mesh_vertices(shape, poses, model=model)
    out = np.empty_like(truth)
    for i, x in enumerate(poses):
        R, o = kin.bone_frames(x)
        rel = R @ R0.transpose(0, 2, 1)  # (16, 3, 3) world_from_bone · bone_from_rest
        A = np.einsum("vb,bij->vij", weights, rel)  # linear part per vertex
        lbs = np.einsum("vb,vbi->vi", weights,
                        np.einsum("bij,vbj->vbi", rel, bind[:, None] - o0) + o)  # fmt: skip
        out[i] = np.linalg.solve(A, (truth[i] - lbs)[..., None])[..., 0]
    return out


def glb_bytes(
    poses, shape: HandShape, *, fps: float | None = None, corrective: bool = True,
    model: HandModel | None = None,
) -> bytes:  # fmt: skip
    """The .glb file of a track: skinned mesh, skeleton and animation (module docstring).

    Parameters
    ----------
    poses : (T, 26) array_like
        mm and degrees; NaN as a whole on a frame without a hand, which then holds a
        tracked pose (`held_poses`).
    shape : HandShape
        The tracked hand (either side).
    fps : float, keyword-only, optional
        Frame rate (key times ``t / fps`` seconds); 30 when unknown.
    corrective : bool, keyword-only
        Add the per-frame morph targets that make the skinned vertices the model's.
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
    poses = held_poses(poses)
    as_instance(shape, HandShape, "shape")
    fps = _DEFAULT_FPS if fps is None else float(fps)
    if not (np.isfinite(fps) and fps > 0):
        raise ValueError(f"fps: expected a positive frame rate; got {fps}")
    n = poses.shape[0]
    model, kin, bind, triangles, weights, R0, o0 = _skinning_setup(shape, model)
    buf = _Buffer()
    parents = _parents()
    trans = _local_translations(shape)
    rot = _local_rotations(poses, shape)

    nodes: list[dict] = []
    for b, name in enumerate(BONES):
        node: dict = {"name": name, "translation": (trans[b] * _M).tolist(),
                      "rotation": _quaternions(rot[:1, b])[0].tolist()}  # fmt: skip
        if b == 0:
            node["translation"] = (poses[0, 0:3] * _M).tolist()
        kids = [c for c in range(len(BONES)) if parents[c] == b]
        if kids:
            node["children"] = kids
        nodes.append(node)
    for k in range(5):
        tip = len(nodes)
        nodes.append({"name": f"{DIGITS[k]}_tip",
                      "translation": [0.0, float(shape.segments[k, 2] * _M), 0.0]})  # fmt: skip
        nodes[bone_index(k, 2)]["children"] = [tip]
    mesh_node = len(nodes)
    nodes.append({"name": "hand_mesh", "mesh": 0, "skin": 0})

    # the mesh: rest positions, weights in sets of four, triangles
    attributes = {"POSITION": buf.accessor((bind * _M).astype(np.float32), "VEC3",
                                           target=34962, bounds=True)}  # fmt: skip
    order = np.argsort(-weights, axis=1, kind="stable")
    n_sets = -(-int((weights > 0).sum(axis=1).max()) // 4)
    for s in range(n_sets):
        idx = order[:, 4 * s : 4 * s + 4]
        w = np.take_along_axis(weights, idx, axis=1)
        joints = np.where(w > 0, idx, 0).astype(np.uint16)
        attributes[f"JOINTS_{s}"] = buf.accessor(joints, "VEC4", target=34962)
        attributes[f"WEIGHTS_{s}"] = buf.accessor(w.astype(np.float32), "VEC4", target=34962)
    primitive = {"attributes": attributes, "mode": 4,
                 "indices": buf.accessor(triangles.reshape(-1).astype(np.uint32), "SCALAR",
                                         target=34963)}  # fmt: skip
    mesh: dict = {"name": "hand", "primitives": [primitive]}

    # the skin: inverse of each bone's rest frame (metres)
    rest = np.zeros((len(BONES), 4, 4))
    rest[:, :3, :3] = R0
    rest[:, :3, 3] = o0 * _M
    rest[:, 3, 3] = 1.0
    ibm = np.linalg.inv(rest).transpose(0, 2, 1).reshape(len(BONES), 16)  # column-major
    skin = {"joints": list(range(len(BONES))), "skeleton": 0,
            "inverseBindMatrices": buf.accessor(ibm.astype(np.float32), "MAT4")}  # fmt: skip

    # the animation
    times = buf.accessor((np.arange(n) / fps).astype(np.float32), "SCALAR", bounds=True)
    samplers: list[dict] = []
    channels: list[dict] = []

    def channel(node: int, path: str, values: np.ndarray, kind: str) -> None:
        out = buf.accessor(values.astype(np.float32), kind)
        samplers.append({"input": times, "output": out, "interpolation": "LINEAR"})
        channels.append({"sampler": len(samplers) - 1, "target": {"node": node, "path": path}})

    channel(0, "translation", poses[:, 0:3] * _M, "VEC3")
    for b in range(len(BONES)):
        channel(b, "rotation", _quaternions(rot[:, b]), "VEC4")

    if corrective:
        delta = _corrections(poses, shape, model, kin, bind, weights, R0, o0) * _M
        need = np.flatnonzero(np.abs(delta).max(axis=(0, 2)) > 1e-9)
        if need.size:
            indices = buf.view(need.astype(np.uint32))
            targets = []
            for i in range(n):
                values = delta[i, need]
                lo = np.minimum(values.min(axis=0), 0.0).tolist()
                hi = np.maximum(values.max(axis=0), 0.0).tolist()
                targets.append({"POSITION": buf.sparse(len(bind), indices, values, lo, hi)})
            primitive["targets"] = targets
            mesh["weights"] = [0.0] * n
            channel(mesh_node, "weights", np.eye(n).reshape(-1, 1), "SCALAR")

    document = {
        "asset": {"version": "2.0", "generator": "handvar"},
        "scene": 0,
        "scenes": [{"nodes": [0, mesh_node]}],
        "nodes": nodes,
        "meshes": [mesh],
        "skins": [skin],
        "animations": [{"name": "track", "samplers": samplers, "channels": channels}],
        "accessors": buf.accessors,
        "bufferViews": buf.views,
        "buffers": [{"byteLength": len(buf.data)}],
    }
    return _glb(document, bytes(buf.data))


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
