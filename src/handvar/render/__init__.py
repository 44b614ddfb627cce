"""Rendering of the sphere-mesh hand model (design §2, §3).

- :mod:`~handvar.render.silhouettes`: exact silhouettes, one camera
  (`silhouette_of_spheres`) or a whole rig (`silhouettes`);
- :mod:`~handvar.render.shading`: Lambert-shaded colour images over synthetic
  backgrounds (`render_rgb`);
- :mod:`~handvar.render.mesh`: both for the skinned mesh hand;
- :mod:`~handvar.render.common`: what both surfaces' renderers share (the rig's image
  size, the backgrounds, the shading: `Shading`, `background_image`);
- :mod:`~handvar.render.overlay`: the model drawn over frames, and overlay videos.
"""

from handvar.render.common import Shading, background_image
from handvar.render.overlay import (
    SKELETON,
    VIDEO_CODEC,
    OverlayWriter,
    draw_overlay,
    overlay_frame,
    overlay_views,
    side_by_side,
    write_overlay_video,
)
from handvar.render.shading import render_rgb
from handvar.render.silhouettes import (
    SphereMeshModel,
    outlines,
    silhouette_of_spheres,
    silhouettes,
    sphere_ellipses,
)

__all__ = [
    "SKELETON",
    "VIDEO_CODEC",
    "OverlayWriter",
    "Shading",
    "SphereMeshModel",
    "background_image",
    "draw_overlay",
    "outlines",
    "overlay_frame",
    "overlay_views",
    "render_rgb",
    "side_by_side",
    "silhouette_of_spheres",
    "silhouettes",
    "sphere_ellipses",
    "write_overlay_video",
]
