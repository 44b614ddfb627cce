"""Independent readers of the exported files, for round-trip checks.

The glTF reader takes the structure from pygltflib and does standard linear blend
skinning itself (the glTF 2.0 specification's formula); the BVH reader takes bvhio's
forward kinematics; the viewer page's figure is decoded from its script with `json`.
None uses handvar's writers or kinematics.
"""

from __future__ import annotations

import warnings

import numpy as np

_DTYPES = {5126: np.float32, 5125: np.uint32, 5123: np.uint16, 5121: np.uint8}
_WIDTH = {"SCALAR": 1, "VEC2": 2, "VEC3": 3, "VEC4": 4, "MAT4": 16}


def _view(gltf, blob: bytes, index: int, dtype, count: int, width: int) -> np.ndarray:
    view = gltf.bufferViews[index]
    start = view.byteOffset or 0
    arr = np.frombuffer(blob, dtype=dtype, count=count * width, offset=start)
    return arr.reshape(count, width).astype(float)


def accessor(gltf, blob: bytes, index: int) -> np.ndarray:
    """The data of accessor `index` as (count, width) floats, sparse entries applied."""
    acc = gltf.accessors[index]
    width = _WIDTH[acc.type]
    dtype = _DTYPES[acc.componentType]
    if acc.bufferView is None:
        out = np.zeros((acc.count, width))
    else:
        out = _view(gltf, blob, acc.bufferView, dtype, acc.count, width).copy()
    if acc.sparse is not None:
        s = acc.sparse
        idx = _view(gltf, blob, s.indices.bufferView, _DTYPES[s.indices.componentType],
                    s.count, 1)[:, 0].astype(int)  # fmt: skip
        out[idx] = _view(gltf, blob, s.values.bufferView, dtype, s.count, width)
    return out


def _quat_matrix(q) -> np.ndarray:
    x, y, z, w = np.asarray(q, float) / np.linalg.norm(q)
    return np.array([
        [1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)],
        [2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)],
        [2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)],
    ])  # fmt: skip


def _world_matrices(local_t: dict, local_r: dict, parent: dict) -> dict:
    """Each node's global matrix: its parent's times its own T · R."""
    world: dict = {}

    def global_(i):
        if i not in world:
            m = np.eye(4)
            m[:3, :3] = _quat_matrix(local_r[i])
            m[:3, 3] = local_t[i]
            world[i] = m if i not in parent else global_(parent[i]) @ m
        return world[i]

    for i in local_t:
        global_(i)
    return world


def gltf_skinned_vertices(path, frames) -> dict[int, np.ndarray]:
    """Skinned vertex positions (V, 3), in the file's units, at the animation's keys
    `frames`: node transforms from the animation, then v = Σ w_j (N_j · IBM_j) (p + Σ
    μ_i Δ_i) over the JOINTS_n/WEIGHTS_n sets."""
    import pygltflib

    gltf = pygltflib.GLTF2().load(str(path))
    blob = gltf.binary_blob()
    prim = gltf.meshes[0].primitives[0]
    attrs = prim.attributes
    position = accessor(gltf, blob, attrs.POSITION)
    sets = []
    for s in range(4):
        j, w = getattr(attrs, f"JOINTS_{s}", None), getattr(attrs, f"WEIGHTS_{s}", None)
        if j is None:
            break
        sets.append((accessor(gltf, blob, j).astype(int), accessor(gltf, blob, w)))
    targets = [accessor(gltf, blob, t["POSITION"]) for t in (prim.targets or [])]
    skin = gltf.skins[0]
    ibm = accessor(gltf, blob, skin.inverseBindMatrices).reshape(-1, 4, 4).transpose(0, 2, 1)
    anim = gltf.animations[0]
    mesh_node = next(i for i, n in enumerate(gltf.nodes) if n.mesh is not None)
    parent = {c: i for i, n in enumerate(gltf.nodes) for c in (n.children or [])}
    out = {}
    for f in frames:
        local_t = {i: np.array(n.translation or [0, 0, 0], float) for i, n in enumerate(gltf.nodes)}
        local_r = {i: np.array(n.rotation or [0, 0, 0, 1], float) for i, n in enumerate(gltf.nodes)}
        morph = np.zeros(len(targets))
        for ch in anim.channels:
            values = accessor(gltf, blob, anim.samplers[ch.sampler].output)
            node, path_ = ch.target.node, ch.target.path
            if path_ == "translation":
                local_t[node] = values[f]
            elif path_ == "rotation":
                local_r[node] = values[f]
            elif path_ == "weights" and node == mesh_node:
                morph = values.reshape(-1, len(targets))[f]
        world = _world_matrices(local_t, local_r, parent)
        skinning = np.stack([world[j] @ ibm[k] for k, j in enumerate(skin.joints)])
        p = position + sum((m * d for m, d in zip(morph, targets, strict=True)),
                           np.zeros_like(position))  # fmt: skip
        ph = np.column_stack([p, np.ones(len(p))])
        v = np.zeros((len(p), 4))
        for joints, weights in sets:
            for c in range(4):
                v += weights[:, c, None] * np.einsum("vij,vj->vi", skinning[joints[:, c]], ph)
        out[f] = v[:, :3]
    return out


def bvh_world_joints(path, names) -> np.ndarray:
    """World positions (T, len(names), 3) of BVH joints by bvhio's forward kinematics;
    a name ``<joint>_end`` is the end site below ``<joint>``."""
    with warnings.catch_warnings():  # its glm binding warns of a deprecation on import
        warnings.simplefilter("ignore", PendingDeprecationWarning)
        import bvhio

    ends = {j.Name: j.EndSite for j, *_ in bvhio.readAsBvh(str(path)).Root.layout()
            if j.EndSite is not None}  # fmt: skip
    root = bvhio.readAsHierarchy(str(path))
    joints = {j.Name: j for j, *_ in root.layout()}
    n_frames = len(root.Keyframes)
    out = np.empty((n_frames, len(names), 3))
    for t in range(n_frames):
        root.loadPose(t)
        for i, name in enumerate(names):
            if name.endswith("_end"):
                j = joints[name[:-4]]
                out[t, i] = np.array(j.pointToWorld(ends[name[:-4]]))
            else:
                out[t, i] = np.array(joints[name].PositionWorld)
    return out


def plotly_page(html: str) -> tuple[list, dict, list]:
    """The data, layout and animation frames of a page written by plotly's ``to_html``,
    decoded from the arguments of its ``Plotly.newPlot`` and ``Plotly.addFrames`` calls
    with the standard `json` module."""
    import json
    import re

    decoder = json.JSONDecoder()
    start = re.search(r"Plotly\.newPlot\(\s*\"[^\"]+\",\s*", html).end()
    data, end = decoder.raw_decode(html, start)
    layout, _ = decoder.raw_decode(html, re.compile(r",\s*").match(html, end).end())
    start = re.search(r"Plotly\.addFrames\('[^']+',\s*", html).end()
    frames, _ = decoder.raw_decode(html, start)
    return data, layout, frames
