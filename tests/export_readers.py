"""Independent readers of the exported files, for round-trip checks.

The glTF reader takes the structure from pygltflib and does standard linear blend
skinning itself (the glTF 2.0 specification's formula, every JOINTS_n/WEIGHTS_n set,
node scale included); the BVH reader takes bvhio's
forward kinematics; the viewer page's figure is decoded from its script with `json`
(plotly's typed arrays with `base64` and numpy), and its 3D view is computed from the
layout by the OpenGL camera that plotly's gl-plot3d builds (`plotly_view_pixels`).
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


def _quat_matrices(q) -> np.ndarray:
    """(..., 3, 3) rotation matrices of (..., 4) quaternions x, y, z, w."""
    q = np.asarray(q, float)
    x, y, z, w = np.moveaxis(q / np.linalg.norm(q, axis=-1, keepdims=True), -1, 0)
    return np.stack([
        np.stack([1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)], -1),
        np.stack([2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)], -1),
        np.stack([2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)], -1),
    ], -2)  # fmt: skip


def _sample(times: np.ndarray, values: np.ndarray, t: np.ndarray, how: str) -> np.ndarray:
    """A sampler's output at times `t`: STEP holds the last key at or before t; LINEAR
    is exact at the keys (where these readers look) and blends linearly between."""
    if how == "STEP":
        return values[np.clip(np.searchsorted(times, t, side="right") - 1, 0, None)]
    return np.stack([np.interp(t, times, values[:, c]) for c in range(values.shape[1])], -1)


def gltf_skinned_vertices(path, frames, *, first_set: bool = False,
                          mesh: int = 0) -> dict[int, np.ndarray]:  # fmt: skip
    """Skinned vertex positions (V, 3), in the file's units and axes, at the animation's
    keys `frames` (indices into its longest sampler input): node transforms T · R · S
    from the animation, then v = Σ w_j (N_j · IBM_j) (p + Σ μ_i Δ_i) over every
    JOINTS_n/WEIGHTS_n set (the glTF 2.0 specification's skinning). With `first_set`,
    as a reader that takes four influences only: JOINTS_0/WEIGHTS_0, renormalised."""
    import pygltflib

    gltf = pygltflib.GLTF2().load(str(path))
    blob = gltf.binary_blob()
    mesh_node = [i for i, n in enumerate(gltf.nodes) if n.mesh is not None][mesh]
    prim = gltf.meshes[gltf.nodes[mesh_node].mesh].primitives[0]
    attrs = prim.attributes
    position = accessor(gltf, blob, attrs.POSITION)
    sets = []
    while getattr(attrs, f"JOINTS_{len(sets)}", None) is not None:
        s = len(sets)
        sets.append((accessor(gltf, blob, getattr(attrs, f"JOINTS_{s}")).astype(int),
                     accessor(gltf, blob, getattr(attrs, f"WEIGHTS_{s}"))))  # fmt: skip
    if first_set:
        sets = [(sets[0][0], sets[0][1] / sets[0][1].sum(axis=1, keepdims=True))]
    targets = [accessor(gltf, blob, t["POSITION"]) for t in (prim.targets or [])]
    skin = gltf.skins[gltf.nodes[mesh_node].skin]
    ibm = accessor(gltf, blob, skin.inverseBindMatrices).reshape(-1, 4, 4).transpose(0, 2, 1)
    anim = gltf.animations[0]
    inputs = [accessor(gltf, blob, s.input)[:, 0] for s in anim.samplers]
    t = max(inputs, key=len)[list(frames)]
    parent = {c: i for i, n in enumerate(gltf.nodes) for c in (n.children or [])}
    n_f = len(t)
    trs = {i: {"translation": np.tile(n.translation or [0.0, 0.0, 0.0], (n_f, 1)),
               "rotation": np.tile(n.rotation or [0.0, 0.0, 0.0, 1.0], (n_f, 1)),
               "scale": np.tile(n.scale or [1.0, 1.0, 1.0], (n_f, 1))}
           for i, n in enumerate(gltf.nodes)}  # fmt: skip
    morph = np.zeros((n_f, len(targets)))
    for ch in anim.channels:
        sampler = anim.samplers[ch.sampler]
        values = accessor(gltf, blob, sampler.output)
        if ch.target.path == "weights":
            values = values.reshape(len(inputs[ch.sampler]), -1)
        got = _sample(inputs[ch.sampler], values, t, sampler.interpolation)
        if ch.target.path == "weights" and ch.target.node == mesh_node:
            morph = got
        elif ch.target.path != "weights":
            trs[ch.target.node][ch.target.path] = got
    world: dict = {}

    def global_(i):  # (F, 4, 4) node matrices: the parent's times this node's T R S
        if i not in world:
            m = np.zeros((n_f, 4, 4))
            m[:, :3, :3] = _quat_matrices(trs[i]["rotation"]) * trs[i]["scale"][:, None, :]
            m[:, :3, 3] = trs[i]["translation"]
            m[:, 3, 3] = 1.0
            world[i] = m if i not in parent else global_(parent[i]) @ m
        return world[i]

    skinning = np.stack([global_(j) @ ibm[k] for k, j in enumerate(skin.joints)], axis=1)
    out = {}
    for i, f in enumerate(frames):
        p = position + sum((m * d for m, d in zip(morph[i], targets, strict=True)),
                           np.zeros_like(position))  # fmt: skip
        blended = np.zeros((len(p), 4, 4))
        for joints, weights in sets:
            for c in range(4):
                blended += weights[:, c, None, None] * skinning[i, joints[:, c]]
        out[f] = np.einsum("vij,vj->vi", blended, np.column_stack([p, np.ones(len(p))]))[:, :3]
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


def bvh_roots(text: str) -> list[str]:
    """A BVH file of several ROOT hierarchies as one single-root BVH text per root (for
    readers that take one root, as bvhio does): each root's block of the HIERARCHY, and
    of every MOTION line the values of its channels (counted from its ``CHANNELS``
    lines, the roots' channels following each other in the file's order)."""
    lines = text.splitlines()
    motion = lines.index("MOTION")
    blocks: list[list[str]] = []
    depth = 0
    for line in lines[1:motion]:
        word = line.split()[0] if line.split() else ""
        if depth == 0 and word == "ROOT":
            blocks.append([])
        blocks[-1].append(line)
        depth += line.count("{") - line.count("}")
    counts = [sum(int(ln.split()[1]) for ln in b if ln.split()[0] == "CHANNELS") for b in blocks]
    header, rows = lines[motion : motion + 3], [ln.split() for ln in lines[motion + 3 :] if ln]
    out, start = [], 0
    for block, count in zip(blocks, counts, strict=True):
        values = [" ".join(r[start : start + count]) for r in rows]
        out.append("\n".join(["HIERARCHY", *block, *header, *values]) + "\n")
        start += count
    assert all(len(r) == start for r in rows), "MOTION lines do not hold the roots' channels"
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


def plotly_array(value) -> np.ndarray:
    """A data array of a plotly figure as floats: a JSON list (None: NaN) or plotly's
    typed array ``{"dtype": "i2", "bdata": base64}`` (little-endian)."""
    import base64

    if isinstance(value, dict):
        raw = base64.b64decode(value["bdata"])
        return np.frombuffer(raw, dtype=np.dtype(value["dtype"]).newbyteorder("<")).astype(float)
    return np.array([np.nan if v is None else v for v in value], dtype=float)


def plotly_view_pixels(scene: dict, points, size: tuple[int, int]) -> np.ndarray:
    """Where a plotly 3D scene shows world points, (N, 2) pixels of its viewport of
    `size` (width, height), from its layout alone, as gl-plot3d draws it:

    - model: each axis range [lo, hi] scaled to the aspect ratio a and centred,
      ``m = a (p − (lo + hi)/2) / (hi − lo)`` (aspect mode ``cube``: a = 1);
    - view: ``lookAt(eye, center, up)`` of the layout's ``camera`` (gl-matrix's: z from
      the centre to the eye, x = up × z, y = z × x);
    - projection: perspective, vertical field of view π/4, the viewport's aspect.
    """
    points = np.asarray(points, dtype=float)
    ranges = np.array([scene[f"{k}axis"]["range"] for k in "xyz"], dtype=float)
    aspect = np.ones(3) if scene.get("aspectmode") == "cube" else np.array(
        [scene["aspectratio"][k] for k in "xyz"])  # fmt: skip
    m = aspect * (points - ranges.mean(axis=1)) / (ranges[:, 1] - ranges[:, 0])
    cam = scene["camera"]
    eye, center, up = (np.array([cam[v][k] for k in "xyz"], dtype=float)
                       for v in ("eye", "center", "up"))  # fmt: skip
    z = (eye - center) / np.linalg.norm(eye - center)
    x = np.cross(up, z)
    x /= np.linalg.norm(x)
    y = np.cross(z, x)
    view = (m - eye) @ np.column_stack([x, y, z])  # camera coordinates, looking along −z
    f = 1.0 / np.tan(np.pi / 8.0)
    w, h = size
    ndc = np.column_stack([f * (h / w) * view[:, 0], f * view[:, 1]]) / -view[:, 2:3]
    return np.column_stack([(ndc[:, 0] + 1.0) * w / 2.0, (1.0 - ndc[:, 1]) * h / 2.0])
