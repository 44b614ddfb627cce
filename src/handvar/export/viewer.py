"""A self-contained HTML page to look at a track (plotly, its JavaScript embedded).

The page holds, on one time slider (play, pause, drag):

- a 3D scene: the hand model's surface (the skinned mesh, decimated: `hand_surface`),
  the skeleton (21 keypoints, 20 bones) over it, and the cameras as small frusta. It
  opens looking through the first camera at the hand (`camera_view`); two buttons go
  from that view to a free one and back (drag to turn, scroll to zoom). The axes
  follow the hand: on every frame a cube of one side around the hand's smoothed centre
  (`hand_boxes`), so the hand keeps its size on screen while it moves;
- beside it, the recording's frame with the fitted model drawn over it, when frames
  are given (JPEG at most `IMAGE_WIDTH` pixels wide, embedded as base64);
- under that, the per-frame quality curves with a cursor on the current frame; a
  click on a curve jumps to that frame.

A frame without a hand (its joints NaN as a whole) keeps its place on the slider and
shows neither skeleton nor surface. Nothing is fetched over the network to view it.

Plotly places a 3D scene's camera in the scene's own coordinates: with the three axis
ranges of one width ``s`` around ``c`` (aspect mode ``cube``), a point p is at
``(p − c) / s``, and the view's vertical field is gl-plot3d's fixed 45°.
"""

from __future__ import annotations

import base64
import math
import os
import re
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from handvar.atomic import write_atomic
from handvar.export.absent import hand_frames
from handvar.export.hands import checked_hands
from handvar.hand.anthropometry import JOINT_DIGIT, JOINTS, HandShape
from handvar.params import N_PARAMS
from handvar.validate import as_array, as_instance

__all__ = [
    "DIGIT_RGB",
    "IMAGE_WIDTH",
    "SURFACE_VERTICES",
    "bone_pairs",
    "camera_view",
    "hand_boxes",
    "hand_surface",
    "hands_viewer_html",
    "viewer_html",
    "write_hands_viewer",
    "write_viewer",
]

#: Vertices of the hand's surface on the page (the model's mesh has 1,656): edges of
#: about 10 mm, 2.7 KB a frame (whole millimetres, int16).
SURFACE_VERTICES = 450
#: Widest embedded frame, pixels.
IMAGE_WIDTH = 320
_JPEG_QUALITY = 60
_FRUSTUM_DEPTH = 80.0  # mm, length of the drawn camera frusta
_GRID = 50.0  # mm between the scene's grid lines
_DEFAULT_FPS = 30.0
_FOVY = math.radians(45.0)  # gl-plot3d's vertical field of view (module notes)
_FILL = 0.85  # the share of half the view's height the hand's radius fills on opening
_SMOOTH_SECONDS = 0.5  # window of the moving average of the box's centre
_SKIN = "rgb(230, 182, 155)"  # the glTF export's skin colour (sRGB)
#: The surface's opacity on opening, low enough to show the skeleton inside it and not
#: the speckle of plotly's unsorted transparent triangles (0.55 and above); a button
#: makes it solid.
_SEE_THROUGH = 0.4
#: Per digit (thumb, index, middle, ring, little) the colour of its bones and keypoints,
#: the overlays' (`handvar.render.overlay`, tested equal); the wrist white.
DIGIT_RGB = ((230, 60, 60), (240, 170, 30), (60, 200, 60), (40, 140, 240), (190, 80, 220))
_CURVE_COLOURS = ("#1a9641", "#7b3294")


def bone_pairs() -> list[tuple[int, int]]:
    """The 20 (parent, child) keypoint index pairs of the skeleton, in `JOINTS` order.

    Examples
    --------
    >>> bone_pairs()[:4]
    [(0, 1), (1, 2), (2, 3), (3, 4)]
    """
    pairs = []
    for k in range(5):
        base = 1 + 4 * k
        pairs += [(0, base), (base, base + 1), (base + 1, base + 2), (base + 2, base + 3)]
    return pairs


def _rgb(colour) -> str:
    return "rgb({}, {}, {})".format(*colour)


#: Colours of the bones' line points (`_segments`' order: two ends and a gap per bone)
#: and of the keypoints.
_BONE_COLOURS = [_rgb(DIGIT_RGB[JOINT_DIGIT[child]]) for _, child in bone_pairs()
                 for _ in range(3)]  # fmt: skip
_JOINT_COLOURS = ["white"] + [_rgb(DIGIT_RGB[JOINT_DIGIT[j]]) for j in range(1, len(JOINTS))]


def hand_surface(shape: HandShape, poses, *, n_vertices: int = SURFACE_VERTICES):
    """The hand's surface per frame: the model's skinned mesh, decimated.

    The mesh (`handvar.export.gltf.mesh_vertices`, a left hand's mirrored) is decimated
    once at rest (`handvar.geometry.decimate.decimate_mesh`, its vertices a subset of
    the mesh's), and every frame takes those vertices of its skinned mesh.

    Parameters
    ----------
    shape : HandShape
    poses : (T, 26) array_like
        mm and degrees; NaN as a whole on a frame without a hand.
    n_vertices : int, keyword-only
        Vertices to keep.

    Returns
    -------
    vertices : (T, K, 3) ndarray
        mm, world frame; NaN on frames without a hand.
    triangles : (F, 3) int ndarray
        Indices into the K vertices, wound outwards.
    """
    from handvar.export.gltf import mesh_vertices, rest_mesh
    from handvar.geometry.decimate import decimate_mesh

    as_instance(shape, HandShape, "shape")
    poses, present = hand_frames(poses, "poses", (None, N_PARAMS))
    rest, triangles, _ = rest_mesh(shape)
    kept, triangles = decimate_mesh(rest, triangles, n_vertices)
    vertices = np.full((poses.shape[0], len(kept), 3), np.nan)
    frames = np.flatnonzero(present)
    for chunk in np.array_split(frames, max(1, len(frames) // 500)):  # the whole mesh's
        vertices[chunk] = mesh_vertices(shape, poses[chunk])[:, kept]  # 40 KB a frame
    return vertices, triangles


def hand_boxes(points, *, fps: float | None = None, margin: float = 10.0):
    """Where the scene's axes sit on each frame: a cube of one side around the hand.

    The centre is the middle of the hand's bounding box, averaged over `_SMOOTH_SECONDS`
    (so that the axes glide rather than shake), on frames without a hand interpolated
    between the nearest frames with one (held before the first and after the last);
    the side is the least that holds every point of every frame with `margin` to spare.

    Parameters
    ----------
    points : (T, N, 3) array_like
        The hand's points per frame (keypoints, surface vertices), mm; NaN as a whole on
        frames without a hand.
    fps : float, keyword-only, optional
        Frame rate, for the averaging window; 30 when unknown.
    margin : float, keyword-only
        mm.

    Returns
    -------
    centres : (T, 3) ndarray
        mm.
    side : float
        mm; 300 when no frame has a hand (centres then at the origin).

    Examples
    --------
    Two frames at 2 frames a second (the average is over one frame: none):

    >>> box = np.array([[0.0, 0.0, 0.0], [40.0, 20.0, 10.0]])
    >>> centres, side = hand_boxes([box, box + 10.0], fps=2.0)
    >>> centres[1].tolist(), side  # 40 mm wide, 10 mm margin on either side
    ([30.0, 20.0, 15.0], 60.0)
    """
    from scipy.ndimage import uniform_filter1d

    points, present = hand_frames(points, "points", (None, None, 3), what="points")
    n = points.shape[0]
    if not present.any():
        return np.zeros((n, 3)), 300.0
    middle = (points[present].min(axis=1) + points[present].max(axis=1)) / 2.0
    frames = np.flatnonzero(present)
    centres = np.column_stack([np.interp(np.arange(n), frames, middle[:, i]) for i in range(3)])
    window = round(_SMOOTH_SECONDS * (_DEFAULT_FPS if fps is None else fps)) | 1
    centres = uniform_filter1d(centres, size=window, axis=0, mode="nearest")
    reach = np.abs(points[present] - centres[present, None, :]).max()
    return centres, float(2.0 * (reach + margin))


def camera_view(camera, target, side: float, *, radius: float) -> dict:
    """Plotly's scene camera looking from `camera` at `target`, the hand filling it.

    The eye sits on the line from `target` to the camera's optical centre, at the
    distance where a sphere of `radius` around the target fills `_FILL` of half the
    view's height; "up" is the camera's −y (its image's up). In the scene's coordinates
    (module notes) with the axes' cube of side `side` centred on `target`.

    Parameters
    ----------
    camera : Camera
    target : (3,) array_like
        World point looked at, mm: the centre of the scene's cube.
    side : float
        The cube's side, mm.
    radius : float, keyword-only
        mm.

    Returns
    -------
    dict
        ``{"eye": {...}, "center": {...}, "up": {...}}`` for ``layout.scene.camera``.
    """
    return _look(camera.center, target, -camera.R[1], side, radius, camera.axis)


def _look(centre, target, up, side: float, radius: float, axis) -> dict:
    """`camera_view` from an optical centre, its image's up and its optical axis (the
    way looked along when the target is at the centre), all in the world frame."""
    target = as_array(target, "target", (3,))
    towards = np.asarray(centre, dtype=float) - target
    norm = np.linalg.norm(towards)
    direction = -np.asarray(axis, dtype=float) if norm < 1e-9 else towards / norm
    distance = radius / (_FILL * math.tan(_FOVY / 2.0))
    eye = direction * distance / side
    return {"eye": _xyz(eye), "center": _xyz(np.zeros(3)), "up": _xyz(up)}


def _free_view(view: dict) -> dict:
    """`view` turned 50° about its up vector and raised 25° towards it: a view of the
    hand from aside, the same distance away."""
    eye = np.array([view["eye"][k] for k in "xyz"])
    up = np.array([view["up"][k] for k in "xyz"])
    up = up / np.linalg.norm(up)

    def turned(v, axis, degrees):  # Rodrigues' rotation of v about a unit axis
        a = math.radians(degrees)
        return v * math.cos(a) + np.cross(axis, v) * math.sin(a) + axis * (axis @ v) * (
            1.0 - math.cos(a))  # fmt: skip

    eye = turned(eye, up, 50.0)
    side = np.cross(eye, up)
    eye = turned(eye, side / np.linalg.norm(side), 25.0)
    return {**view, "eye": _xyz(eye)}


def _xyz(v) -> dict:
    return {"x": float(v[0]), "y": float(v[1]), "z": float(v[2])}


def _coordinates(values) -> list:
    """`values` as a list of floats rounded to 0.1 (mm), None for NaN (a gap, to plotly)."""
    return [round(float(v), 1) if np.isfinite(v) else None for v in values]


def _segments(points: np.ndarray) -> tuple[list, list, list]:
    """x, y, z lists of the bones as line pieces separated by None (all None for NaN
    points: nothing drawn)."""
    pairs = np.array(bone_pairs())
    pieces = np.full((len(pairs), 3, 3), np.nan)  # per bone: its two ends, then a gap
    pieces[:, 0], pieces[:, 1] = points[pairs[:, 0]], points[pairs[:, 1]]
    flat = pieces.reshape(-1, 3)
    return _coordinates(flat[:, 0]), _coordinates(flat[:, 1]), _coordinates(flat[:, 2])


def _frustum(camera, name: str, depth: float):
    """A Scatter3d of the camera's frustum (centre to the image's corners at `depth`)."""
    import plotly.graph_objects as go

    w, h = camera.size
    corners = np.array([[-0.5, -0.5], [w - 0.5, -0.5], [w - 0.5, h - 0.5], [-0.5, h - 0.5]])
    rays = np.column_stack([(corners[:, 0] - camera.cx) / camera.fx,
                            (corners[:, 1] - camera.cy) / camera.fy, np.ones(4)])  # fmt: skip
    world = (rays * depth - camera.t) @ camera.R  # Rᵀ (p_cam − t), row-wise
    c = camera.center
    path = [c, world[0], world[1], c, world[2], world[3], c, world[0], world[3], world[2],
            world[1]]  # fmt: skip
    path = np.array(path)
    return go.Scatter3d(x=path[:, 0], y=path[:, 1], z=path[:, 2], mode="lines",
                        line={"color": "grey", "width": 3}, name=f"camera {name}",
                        hoverinfo="name", showlegend=False)  # fmt: skip


def _jpeg_uri(image, width: int) -> str:
    """An RGB image as a JPEG data URI, resized to at most `width` pixels wide."""
    import cv2

    img = np.asarray(image)
    if img.ndim != 3 or img.shape[2] != 3 or img.dtype != np.uint8:
        raise ValueError(f"images: expected (H, W, 3) uint8 RGB frames; got {img.dtype} "
                         f"{img.shape}")  # fmt: skip
    if img.shape[1] > width:
        height = max(1, round(img.shape[0] * width / img.shape[1]))
        img = cv2.resize(img, (width, height), interpolation=cv2.INTER_AREA)
    ok, data = cv2.imencode(".jpg", np.ascontiguousarray(img[:, :, ::-1]),
                            [cv2.IMWRITE_JPEG_QUALITY, _JPEG_QUALITY])  # fmt: skip
    if not ok:  # pragma: no cover - OpenCV encodes any uint8 image
        raise ValueError("images: OpenCV could not encode a frame as JPEG")
    return "data:image/jpeg;base64," + base64.b64encode(data.tobytes()).decode("ascii")


def _curves(quality, quality_label: str, n: int) -> dict[str, np.ndarray]:
    """`quality` as {label: (T,) values}: one curve, or several by label."""
    if quality is None:
        return {}
    if not isinstance(quality, dict):
        quality = {quality_label: quality}
    curves = {str(label): as_array(values, f"quality[{label!r}]", (n,), finite=False,
                                   what="one value per frame")
              for label, values in quality.items()}  # fmt: skip
    if len(curves) > 2:
        raise ValueError(f"quality: expected at most two curves; got {len(curves)}")
    return curves


def _checked_surface(surface, n: int, present: np.ndarray):
    """`viewer_html`'s `surface` checked: (T, K, 3) vertices on the frames with a hand
    and (F, 3) triangles indexing them; (None, None) without one."""
    if surface is None:
        return None, None
    if not isinstance(surface, tuple | list) or len(surface) != 2:
        raise ValueError("surface: expected a pair (vertices, triangles) (`hand_surface`); "
                         f"got {type(surface).__name__}")  # fmt: skip
    vertices, on = hand_frames(surface[0], "surface", (n, None, 3), what="vertices")
    triangles = np.asarray(surface[1])
    k = vertices.shape[1]
    if (triangles.ndim != 2 or triangles.shape[1] != 3
            or not np.issubdtype(triangles.dtype, np.integer)
            or (triangles.size and (triangles.min() < 0 or triangles.max() >= k))):  # fmt: skip
        raise ValueError(f"surface: expected (F, 3) integer triangles indexing the {k} "
                         f"vertices; got {triangles.dtype} {triangles.shape}")  # fmt: skip
    if not np.array_equal(on, present):
        raise ValueError("surface: expected vertices on exactly the frames with keypoints; "
                         f"got them on {int(on.sum())} frames, keypoints on "
                         f"{int(present.sum())}")  # fmt: skip
    return vertices, triangles.astype(np.int32)


def _surface_frame(vertices: np.ndarray) -> dict:
    """The surface's coordinates on one frame: whole mm as int16 (half float32's bytes;
    the mesh's edges are about 10 mm), or hidden on a frame without a hand."""
    if np.isnan(vertices).all():
        return {"type": "mesh3d", "x": [], "y": [], "z": [], "visible": False}
    v = vertices.astype(np.float32)
    if np.abs(v).max() < 30000.0:
        v = np.rint(v).astype(np.int16)
    return {"type": "mesh3d", "x": v[:, 0], "y": v[:, 1], "z": v[:, 2], "visible": True}


def _no_type(data: dict) -> dict:
    return {k: v for k, v in data.items() if k != "type"}


def _curve_range(values: np.ndarray) -> list[float]:
    """A curve's axis range: from 0 (or its least value), up to 1 for a quality in
    [0.5, 1] (an IoU, a share), else 10 % above its largest value."""
    v = values[np.isfinite(values)]
    low, top = (min(0.0, float(v.min())), float(v.max())) if v.size else (0.0, 1.0)
    return [low, 1.0 if 0.5 <= top <= 1.0 else max(top, 1e-6) * 1.1]


def _layout(
    title, n, fps, curves, y_range, through, free, ranges, right, *, surface, cameras
) -> dict:
    """The page's layout: the scene (left, or on top without frames), the frame (right),
    the quality curves (under it), the buttons and the slider."""
    animate = {"frame": {"duration": max(1, round(1000.0 / fps)), "redraw": True},
               "fromcurrent": True, "transition": {"duration": 0}, "mode": "immediate"}  # fmt: skip
    still = {"frame": {"duration": 0, "redraw": True}, "transition": {"duration": 0},
             "mode": "immediate"}  # fmt: skip
    menus = [
        [{"label": "Play", "method": "animate", "args": [None, animate]},
         {"label": "Pause", "method": "animate", "args": [[None], still]}],
        [{"label": "Camera view" if cameras else "Front view", "method": "relayout",
          "args": [{"scene.camera": through}]},
         {"label": "Free view", "method": "relayout", "args": [{"scene.camera": free}]}],
    ]  # fmt: skip
    if surface:  # the surface traces' indices
        menus.append([
            {"label": "See-through", "method": "restyle",
             "args": [{"opacity": _SEE_THROUGH}, list(surface)]},
            {"label": "Solid", "method": "restyle", "args": [{"opacity": 1.0}, list(surface)]},
        ])  # fmt: skip
    colours = _CURVE_COLOURS
    scene_x, scene_y = ([0.0, 0.56], [0.08, 0.94]) if right else ([0.0, 1.0], [0.3, 0.94])
    curve_x, curve_y = ([0.63, 0.97], [0.1, 0.4]) if right else ([0.06, 0.94], [0.08, 0.22])
    # No tick labels nor titles: seen from close by they fall outside the scene's box;
    # the grid is every `_GRID` mm, and a keypoint's hover gives its coordinates.
    axis = {"showbackground": True, "backgroundcolor": "rgb(236, 238, 242)",
            "gridcolor": "white", "zeroline": False, "showticklabels": False,
            "title": {"text": ""}, "tick0": 0.0, "dtick": _GRID, "showspikes": False}  # fmt: skip
    layout = {
        "title": {"text": title, "x": 0.01, "y": 0.985},
        "margin": {"l": 20, "r": 20, "t": 40, "b": 0},
        "showlegend": False,
        "scene": {
            "domain": {"x": scene_x, "y": scene_y}, "aspectmode": "cube",
            "dragmode": "orbit", "camera": through,
            **{f"{k}axis": {**axis, **ranges[f"{k}axis"]} for k in "xyz"},
        },
        "xaxis": {"title": {"text": "frame"}, "range": [-0.5, n - 0.5], "domain": curve_x,
                  "anchor": "y"},
        "yaxis": {"title": {"text": next(iter(curves), "quality"),
                            "font": {"color": colours[0]}},
                  "anchor": "x", "domain": curve_y,
                  "range": y_range[0] if y_range else [0.0, 1.0]},
        "updatemenus": [{"type": "buttons", "direction": "left", "x": x, "y": 1.0,
                         "xanchor": "left", "yanchor": "top", "pad": {"t": 0, "l": 0},
                         "buttons": buttons}
                        for x, buttons in zip((0.0, 0.16, 0.36), menus, strict=False)],
        "sliders": [{"active": 0, "y": 0.0, "yanchor": "bottom", "len": 1.0,
                     "pad": {"t": 0, "b": 0},
                     "currentvalue": {"prefix": "frame ", "font": {"color": "black"},
                                      "offset": 6},
                     "ticklen": 0, "minorticklen": 0, "tickcolor": "rgba(0, 0, 0, 0)",
                     "font": {"color": "rgba(0, 0, 0, 0)"},  # a label per frame: too many
                     "steps": [{"label": f"{t} ({t / fps:.2f} s)", "method": "animate",
                                "args": [[str(t)], still]} for t in range(n)]}],
    }  # fmt: skip
    if len(curves) > 1:
        layout["yaxis3"] = {"title": {"text": list(curves)[1], "font": {"color": colours[1]}},
                            "overlaying": "y", "side": "right", "anchor": "x",
                            "range": y_range[1]}  # fmt: skip
    if right:
        layout["xaxis2"] = {"domain": [0.6, 1.0], "anchor": "y2", "visible": False}
        layout["yaxis2"] = {"domain": [0.48, 0.94], "anchor": "x2", "visible": False,
                            "scaleanchor": "x2", "autorange": "reversed",
                            "constraintoward": "top"}  # fmt: skip
    return layout


def viewer_html(
    joints, *, surface=None, images=None, rig=None, quality=None,
    quality_label: str = "quality", fps: float | None = None, title: str = "handvar track",
    image_width: int = IMAGE_WIDTH,
) -> str:  # fmt: skip
    """The viewer page of a track (module docstring) as one HTML string.

    Parameters
    ----------
    joints : (T, 21, 3) array_like
        The 21 points per frame (a track's joints), mm, world frame; NaN as a whole on a
        frame without a hand,
        which shows no skeleton.
    surface : tuple (vertices, triangles), keyword-only, optional
        The hand's surface: (T, K, 3) vertices per frame, mm, NaN as a whole on frames
        without a hand, and (F, 3) triangles indexing them (`hand_surface`).
    images : iterable of T (H, W, 3) uint8 RGB arrays, keyword-only, optional
        The frames to show beside the scene, the model drawn over them; resized to at
        most `image_width` pixels wide and embedded as JPEG, one at a time (a generator
        keeps a long recording's frames out of memory).
    rig : Rig, keyword-only, optional
        Cameras to draw; the page opens looking through the first at the hand.
        Without cameras, as a camera at the origin looking along +z would.
    quality : (T,) array_like, or dict of str to (T,) array_like, keyword-only, optional
        A per-frame quality to plot (NaN: no value), or several by label (two at most:
        the second on an axis of its own, on the right).
    quality_label : str, keyword-only
        The label of a single `quality` array.
    fps : float, keyword-only, optional
        Playback rate; 30 when unknown.
    title : str, keyword-only
    image_width : int, keyword-only
        Widest embedded frame, pixels.

    Returns
    -------
    str
        A complete HTML document with plotly.js embedded.
    """
    joints, present = hand_frames(joints, "joints", (None, len(JOINTS), 3), what="keypoints")
    if joints.shape[0] < 1:
        raise ValueError("joints: expected at least one frame; got 0")
    vertices, triangles = _checked_surface(surface, joints.shape[0], present)
    layer = _Layer(joints, present, vertices, triangles, _SKIN, _BONE_COLOURS, _JOINT_COLOURS,
                   "")  # fmt: skip
    return _viewer([layer], images=images, rig=rig, quality=quality,
                   quality_label=quality_label, fps=fps, title=title,
                   image_width=image_width)  # fmt: skip


def hands_viewer_html(
    hands, *, colours=None, images=None, rig=None, quality=None,
    quality_label: str = "quality", fps: float | None = None,
    title: str = "handvar track", image_width: int = IMAGE_WIDTH,
    n_vertices: int = SURFACE_VERTICES,
) -> str:  # fmt: skip
    """The viewer page of several hands: each hand's surface (`hand_surface`), bones and
    keypoints in the scene, as `viewer_html` draws one, in its side's colour.

    With `colours`, a hand's surface and bones are drawn in the colour of its side and
    its keypoints in the digits' colours (`DIGIT_RGB`), as the two-hand overlay draws
    them; the See-through and Solid buttons act on every surface. The axes and the
    opening view hold every hand; a hand's keypoints hover with its side's name.

    Parameters
    ----------
    hands : sequence of TrackedHand
        At most one of each side, over the same frames (`checked_hands`).
    colours : dict of str to (int, int, int), keyword-only, optional
        RGB per side (`handvar.pipeline.SIDE_RGB`); None: every hand as `viewer_html`
        draws one (skin, bones in the digits' colours).
    images, rig, quality, quality_label, fps, title, image_width : keyword-only
        As `viewer_html`; the frames should show every hand (the caller draws them).
    n_vertices : int, keyword-only
        Vertices of each hand's surface (`hand_surface`).

    Returns
    -------
    str
        A complete HTML document with plotly.js embedded.
    """
    layers = []
    for h in checked_hands(hands):
        poses, present = hand_frames(h.poses, f"hands ({h.side}) poses", (None, N_PARAMS))
        joints = np.full((len(poses), len(JOINTS), 3), np.nan)
        for t in np.flatnonzero(present):
            joints[t] = h.hand.landmarks(poses[t])
        vertices, triangles = hand_surface(h.hand.shape, poses, n_vertices=n_vertices)
        if colours is None:
            skin, bones = _SKIN, _BONE_COLOURS
        else:
            colour = colours.get(h.side)
            if colour is None:
                raise ValueError(f"colours: expected a colour for every hand's side; got none "
                                 f"for {h.side} in {sorted(colours)}")  # fmt: skip
            skin, bones = _rgb(colour), [_rgb(colour)] * len(_BONE_COLOURS)
        layers.append(_Layer(joints, present, vertices, triangles.astype(np.int32), skin, bones,
                             _JOINT_COLOURS, h.side))  # fmt: skip
    if len(layers[0].joints) < 1:
        raise ValueError("hands: expected at least one frame; got 0")
    return _viewer(layers, images=images, rig=rig, quality=quality, quality_label=quality_label,
                   fps=fps, title=title, image_width=image_width)  # fmt: skip


@dataclass(frozen=True, eq=False)
class _Layer:
    """One hand on the page: its keypoints (T, 21, 3) and frames with it, its surface
    (or None), the colours of its surface, bones (per line point) and keypoints, and its
    label (empty for one hand: the traces keep their plain names)."""

    joints: np.ndarray
    present: np.ndarray
    vertices: np.ndarray | None
    triangles: np.ndarray | None
    skin: str
    bones: list
    keypoints: list
    label: str

    def name(self, what: str) -> str:
        return f"{self.label} {what}" if self.label else what


def _together(layers) -> tuple[np.ndarray, np.ndarray]:
    """(T, N, 3) the points of every hand per frame (keypoints, surface) and which frames
    have a hand. On a frame where some hand is absent and another there, the absent
    hand's points are all the wrist of the first hand there, which leaves the hands'
    bounding box as it is; a frame without any hand is NaN as a whole (`hand_boxes`)."""
    parts = [ly.joints if ly.vertices is None else np.concatenate([ly.joints, ly.vertices], 1)
             for ly in layers]  # fmt: skip
    present = np.any([ly.present for ly in layers], axis=0)
    if len(parts) == 1:
        return parts[0], present
    wrist = np.full((len(present), 3), np.nan)
    for ly in reversed(layers):  # the first hand there wins
        wrist[ly.present] = ly.joints[ly.present, 0]
    filled = [np.where(ly.present[:, None, None], part, wrist[:, None, :])
              for part, ly in zip(parts, layers, strict=True)]  # fmt: skip
    return np.concatenate(filled, axis=1), present


def _viewer(layers, *, images, rig, quality, quality_label, fps, title, image_width) -> str:
    """The page of `layers` (`_Layer`, one per hand): `viewer_html`'s figure."""
    import plotly.graph_objects as go

    n = layers[0].joints.shape[0]
    sources = None if images is None else [_jpeg_uri(im, image_width) for im in images]
    if sources is not None and len(sources) != n:
        raise ValueError(f"images: expected one frame per frame of the track ({n}); "
                         f"got {len(sources)}")  # fmt: skip
    curves = _curves(quality, quality_label, n)
    fps = _DEFAULT_FPS if fps is None else float(fps)
    points, present = _together(layers)
    with_surface = any(ly.vertices is not None for ly in layers)
    margin = 10.0 if with_surface else 25.0  # the flesh around the keypoints
    centres, side = hand_boxes(points, fps=fps, margin=margin)
    if not present.any() and rig is not None:  # no hand at all: a cube ahead of the camera
        centres[:] = rig.cameras[0].center + 500.0 * rig.cameras[0].axis
    y_ranges = [_curve_range(v) for v in curves.values()]

    def ranges(t: int) -> dict:
        return {f"{k}axis": {"range": [round(float(centres[t, i] - side / 2.0), 2),
                                       round(float(centres[t, i] + side / 2.0), 2)]}
                for i, k in enumerate("xyz")}  # fmt: skip

    def frame(t: int) -> list[dict]:
        """What changes from frame to frame: the animated traces' coordinates."""
        data = []
        for ly in layers:
            if ly.vertices is not None:
                data.append(_surface_frame(ly.vertices[t]))
            xs, ys, zs = _segments(ly.joints[t])
            data.append({"type": "scatter3d", "x": xs, "y": ys, "z": zs})
            x, y, z = (_coordinates(ly.joints[t, :, i]) for i in range(3))
            data.append({"type": "scatter3d", "x": x, "y": y, "z": z})
        data.append({"type": "scatter", "x": [t, t]})
        if sources is not None:
            data.append({"type": "image", "source": sources[t]})
        return data

    fig = go.Figure()
    first = iter(frame(0))
    surfaces = []
    for ly in layers:
        if ly.vertices is not None:
            surfaces.append(len(fig.data))
            fig.add_trace(go.Mesh3d(
                **_no_type(next(first)), i=ly.triangles[:, 0], j=ly.triangles[:, 1],
                k=ly.triangles[:, 2], color=ly.skin, opacity=_SEE_THROUGH,
                name=ly.name("surface"), hoverinfo="skip",
                lighting={"ambient": 0.55, "diffuse": 0.7, "specular": 0.15, "roughness": 0.7,
                          "fresnel": 0.1},
            ))  # fmt: skip
        fig.add_trace(go.Scatter3d(**_no_type(next(first)), mode="lines", name=ly.name("bones"),
                                   line={"color": ly.bones, "width": 7},
                                   hoverinfo="skip"))  # fmt: skip
        text = [ly.name(j) for j in JOINTS]
        fig.add_trace(go.Scatter3d(
            **_no_type(next(first)), mode="markers", name=ly.name("keypoints"), text=text,
            marker={"size": 4, "color": ly.keypoints, "line": {"color": "black", "width": 1}},
            hovertemplate="%{text}: %{x:.0f}, %{y:.0f}, %{z:.0f} mm<extra></extra>",
        ))  # fmt: skip
    low, high = y_ranges[0] if y_ranges else (0.0, 1.0)
    fig.add_trace(go.Scatter(**_no_type(next(first)), y=[low, high], mode="lines",
                             name="frame", line={"color": "black", "width": 1},
                             hoverinfo="skip"))  # fmt: skip
    if sources is not None:
        fig.add_trace(go.Image(**_no_type(next(first)), xaxis="x2", yaxis="y2", name="frame",
                               hoverinfo="skip"))  # fmt: skip
    animated = list(range(len(fig.data)))
    for c, (label, v) in enumerate(curves.items()):
        hover = "frame %{x}: %{y:.3f}<extra>" + label + "</extra>"
        fig.add_trace(go.Scatter(x=np.arange(n), y=np.where(np.isfinite(v), v, None),
                                 mode="lines", name=label, line={"color": _CURVE_COLOURS[c]},
                                 yaxis="y" if c == 0 else "y3", hovertemplate=hover))  # fmt: skip
    if rig is not None:
        for name, cam in zip(rig.names, rig.cameras, strict=True):
            fig.add_trace(_frustum(cam, name, _FRUSTUM_DEPTH))
    fig.frames = [go.Frame(data=frame(t), traces=animated, name=str(t),
                           layout={"scene": ranges(t)}) for t in range(n)]  # fmt: skip

    # The views: through the first camera at the hand, and one from aside.
    opening = int(np.flatnonzero(present)[0]) if present.any() else 0
    radius = side / 4.0  # the opening frame's hand's radius around the box's centre
    if present.any():
        radius = float(np.linalg.norm(points[opening] - centres[opening], axis=1).max())
    if rig is not None:
        through = camera_view(rig.cameras[0], centres[opening], side, radius=radius)
    else:  # no camera: as one at the origin looking along +z, y down, would
        through = _look(np.zeros(3), centres[opening], [0.0, -1.0, 0.0], side, radius,
                        [0.0, 0.0, 1.0])  # fmt: skip
    fig.update_layout(_layout(
        title, n, fps, curves, y_ranges, through, _free_view(through), ranges(opening),
        sources is not None, surface=surfaces, cameras=rig is not None,
    ))  # fmt: skip
    jump = (
        "var gd = document.getElementById('{plot_id}');"
        "gd.on('plotly_click', function (e) {"
        " var p = e.points[0]; if (p.data.type !== 'scatter') { return; }"
        " Plotly.animate(gd, [String(Math.round(p.x))], {mode: 'immediate',"
        " frame: {duration: 0, redraw: true}, transition: {duration: 0}}); });"
    )
    body = fig.to_html(include_plotlyjs=False, full_html=False, post_script=jump,
                       auto_play=False, default_width="100%", default_height="96vh",
                       config={"responsive": True, "displaylogo": False})  # fmt: skip
    return _page(body, title)


def _page(body: str, title: str) -> str:
    """The HTML document: plotly.js inline, then the figure's `body` (plotly's
    ``to_html``), its JSON's escaped slashes written as slashes.

    Plotly writes "/" in its JSON as ``\\u002f`` (6 bytes), which makes the base64 of
    the frames and the surface a tenth longer; "<" stays escaped, so no ``</script>``
    can form. Only the figure's text is touched, not plotly.js (where ``\\u002f`` may
    sit in a regular expression)."""
    import html

    from plotly.offline import get_plotlyjs

    body = re.sub(r"(?<!\\)((?:\\\\)*)\\u002f", r"\1/", body)  # an even run of \ before
    return (
        '<!doctype html>\n<html>\n<head>\n<meta charset="utf-8" />\n'
        f"<title>{html.escape(title)}</title>\n</head>\n<body>\n"
        "<script type=\"text/javascript\">window.PlotlyConfig = {MathJaxConfig: 'local'};"
        f'</script>\n<script type="text/javascript">{get_plotlyjs()}</script>\n'
        f"{body}\n</body>\n</html>\n"
    )


def write_viewer(path: str | os.PathLike, joints, **options) -> Path:
    """Write the viewer page (`viewer_html`, same keyword options) to `path`, atomically."""
    html = viewer_html(joints, **options)
    write_atomic(path, lambda tmp: Path(tmp).write_text(html, encoding="utf-8"))
    return Path(path)


def write_hands_viewer(path: str | os.PathLike, hands, **options) -> Path:
    """Write the viewer page of several hands (`hands_viewer_html`, same keyword options)
    to `path`, atomically."""
    html = hands_viewer_html(hands, **options)
    write_atomic(path, lambda tmp: Path(tmp).write_text(html, encoding="utf-8"))
    return Path(path)
