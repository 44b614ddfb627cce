"""A self-contained HTML page to look at a track in 3D (plotly, its JavaScript embedded).

The page shows the hand's skeleton (the 21 keypoints and the bones between them) over
time in a 3D scene that turns with the mouse, the cameras of the rig as small frusta
and, below, a per-frame quality curve. Play/pause buttons and a slider step through
the frames; the quality curve's marker follows the slider, and a click on the curve
jumps to that frame. Nothing is fetched over the network to view it. A frame without
a hand (its joints NaN as a whole) keeps its place on the slider and shows no skeleton.
"""

from __future__ import annotations

import os
from pathlib import Path

import numpy as np

from handvar.atomic import write_atomic
from handvar.export.absent import hand_frames
from handvar.hand.anthropometry import JOINTS
from handvar.validate import as_array

__all__ = ["bone_pairs", "viewer_html", "write_viewer"]

_FRUSTUM_DEPTH = 80.0  # mm, length of the drawn camera frusta
_DEFAULT_FPS = 30.0


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


def _coordinates(values) -> list:
    """`values` as a list of floats, None for NaN (a gap, to plotly)."""
    return [float(v) if np.isfinite(v) else None for v in values]


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
                        hoverinfo="name")  # fmt: skip


def viewer_html(
    joints, *, rig=None, quality=None, quality_label: str = "quality", fps: float | None = None,
    title: str = "handvar track",
) -> str:  # fmt: skip
    """The viewer page of a track (module docstring) as one HTML string.

    Parameters
    ----------
    joints : (T, 21, 3) array_like
        G(x) per frame, mm, world frame; NaN as a whole on a frame without a hand,
        which shows no skeleton.
    rig : Rig, keyword-only, optional
        Cameras to draw.
    quality : (T,) array_like, keyword-only, optional
        A per-frame quality to plot under the scene (NaN: no value).
    quality_label : str, keyword-only
        Its axis title.
    fps : float, keyword-only, optional
        Playback rate; 30 when unknown.
    title : str, keyword-only

    Returns
    -------
    str
        A complete HTML document with plotly.js embedded.
    """
    import plotly.graph_objects as go
    from plotly.subplots import make_subplots

    joints, present = hand_frames(joints, "joints", (None, len(JOINTS), 3), what="keypoints")
    n = joints.shape[0]
    if n < 1:
        raise ValueError("joints: expected at least one frame; got 0")
    if quality is not None:
        quality = as_array(quality, "quality", (n,), finite=False, what="one value per frame")
    fps = _DEFAULT_FPS if fps is None else float(fps)
    frame_ms = max(1, round(1000.0 / fps))

    fig = make_subplots(rows=2, cols=1, row_heights=[0.78, 0.22], vertical_spacing=0.04,
                        specs=[[{"type": "scene"}], [{"type": "xy"}]])  # fmt: skip

    def skeleton(t: int):
        xs, ys, zs = _segments(joints[t])
        bones = go.Scatter3d(x=xs, y=ys, z=zs, mode="lines", line={"color": "#d62728",
                             "width": 6}, name="bones", hoverinfo="skip")  # fmt: skip
        x, y, z = (_coordinates(joints[t, :, i]) for i in range(3))
        dots = go.Scatter3d(x=x, y=y, z=z, mode="markers",
                            marker={"size": 3, "color": "#1f77b4"},
                            text=list(JOINTS), name="keypoints")  # fmt: skip
        return bones, dots

    def marker(t: int):
        y = 0.0 if quality is None or not np.isfinite(quality[t]) else float(quality[t])
        return go.Scatter(x=[t], y=[y], mode="markers", marker={"size": 10, "color": "black"},
                          name="frame", showlegend=False)  # fmt: skip

    bones, dots = skeleton(0)
    fig.add_trace(bones, row=1, col=1)
    fig.add_trace(dots, row=1, col=1)
    fig.add_trace(marker(0), row=2, col=1)
    curve = np.full(n, np.nan) if quality is None else quality
    fig.add_trace(go.Scatter(x=np.arange(n), y=np.where(np.isfinite(curve), curve, None),
                             mode="lines", name=quality_label, line={"color": "#2ca02c"}),
                  row=2, col=1)  # fmt: skip
    if rig is not None:
        for name, camera in zip(rig.names, rig.cameras, strict=True):
            fig.add_trace(_frustum(camera, name, _FRUSTUM_DEPTH), row=1, col=1)

    fig.frames = [go.Frame(data=[*skeleton(t), marker(t)], traces=[0, 1, 2], name=str(t))
                  for t in range(n)]  # fmt: skip
    animate = {"frame": {"duration": frame_ms, "redraw": True}, "fromcurrent": True,
               "transition": {"duration": 0}, "mode": "immediate"}  # fmt: skip
    still = {"frame": {"duration": 0, "redraw": True}, "transition": {"duration": 0},
             "mode": "immediate"}  # fmt: skip
    # The scene's extent: every frame's keypoints (and the cameras), fixed while playing.
    pts = joints[present].reshape(-1, 3)
    if rig is not None:
        pts = np.vstack([pts, [c.center for c in rig.cameras]])
    if len(pts) == 0:  # no hand on any frame and no camera: an empty scene around 0
        pts = np.zeros((1, 3))
    lo, hi = pts.min(axis=0) - 20.0, pts.max(axis=0) + 20.0
    fig.update_layout(
        title=title,
        height=800,
        scene={"aspectmode": "data", "camera": {"up": {"x": 0, "y": -1, "z": 0}},
               "xaxis": {"range": [lo[0], hi[0]], "title": "x (mm)"},
               "yaxis": {"range": [lo[1], hi[1]], "title": "y (mm)"},
               "zaxis": {"range": [lo[2], hi[2]], "title": "z (mm)"}},
        xaxis={"title": "frame", "range": [-0.5, n - 0.5]},
        yaxis={"title": quality_label},
        updatemenus=[{"type": "buttons", "direction": "left", "x": 0.0, "y": 1.05,
                      "buttons": [{"label": "Play", "method": "animate", "args": [None, animate]},
                                  {"label": "Pause", "method": "animate",
                                   "args": [[None], still]}]}],
        sliders=[{"active": 0, "y": -0.02, "currentvalue": {"prefix": "frame "},
                  "steps": [{"label": str(t), "method": "animate", "args": [[str(t)], still]}
                            for t in range(n)]}],
    )  # fmt: skip
    jump = (
        "var gd = document.getElementById('{plot_id}');"
        "gd.on('plotly_click', function (e) {"
        " var p = e.points[0]; if (p.data.type !== 'scatter') { return; }"
        " Plotly.animate(gd, [String(Math.round(p.x))], {mode: 'immediate',"
        " frame: {duration: 0, redraw: true}, transition: {duration: 0}}); });"
    )
    return fig.to_html(include_plotlyjs=True, full_html=True, post_script=jump,
                       auto_play=False)  # fmt: skip


def write_viewer(path: str | os.PathLike, joints, **options) -> Path:
    """Write the viewer page (`viewer_html`, same keyword options) to `path`, atomically."""
    html = viewer_html(joints, **options)
    write_atomic(path, lambda tmp: Path(tmp).write_text(html, encoding="utf-8"))
    return Path(path)
