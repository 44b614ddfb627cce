"""The hand model: 26 parameters, kinematics G(x) with Jacobians, sphere-mesh surface.

- :mod:`~handvar.params`: names, units, limits, optimiser groups and VAR blocks of
  the 26 parameters.
- :mod:`~handvar.hand.anthropometry`: bone lengths, joint positions and thickness from
  hand length and breadth (`HandShape`).
- :mod:`~handvar.hand.kinematics`: `HandModel` (forward kinematics, exact Jacobians,
  surface queries) and `named_pose`.
- :mod:`~handvar.hand.surface`: the sphere-mesh's primitives and the pool of surface
  samples (their geometry: :mod:`handvar.geometry`).
- :mod:`~handvar.hand.projection`: the model's image in a camera and its closest point
  to a pixel (eq. 1).
- :mod:`~handvar.hand.mesh`: the skinned mesh hand (``HandModel(surface="mesh")``),
  and :mod:`~handvar.hand.raster`, the scan conversion of its triangles.
"""

from typing import TYPE_CHECKING

from handvar.lazy import attach

# imported on first use: `handvar.hand.anthropometry` alone (a keypoint file's reader
# needs its names) loads neither numba nor the surface's geometry
__getattr__, __dir__ = attach(__name__, {
    "handvar.geometry.projected": ["ProjectedPrimitives"],
    "handvar.hand.anthropometry": ["BONES", "JOINTS", "MIDDLE_MCP", "WRIST",
                                   "HandProportions", "HandShape"],
    "handvar.hand.kinematics": ["POSE_NAMES", "HandModel", "named_pose"],
    "handvar.hand.surface": ["Primitives", "SurfaceSamples"],
    "handvar.params": ["DIGITS", "GROUPS", "LOWER", "N_PARAMS", "NAMES", "UNITS", "UPPER",
                       "check_pose", "clamp", "hand_blocks", "index", "within_limits"],
})  # fmt: skip

if TYPE_CHECKING:  # what static checkers and editors see
    from handvar.geometry.projected import ProjectedPrimitives
    from handvar.hand.anthropometry import (
        BONES,
        JOINTS,
        MIDDLE_MCP,
        WRIST,
        HandProportions,
        HandShape,
    )
    from handvar.hand.kinematics import POSE_NAMES, HandModel, named_pose
    from handvar.hand.surface import Primitives, SurfaceSamples
    from handvar.params import (
        DIGITS,
        GROUPS,
        LOWER,
        N_PARAMS,
        NAMES,
        UNITS,
        UPPER,
        check_pose,
        clamp,
        hand_blocks,
        index,
        within_limits,
    )

__all__ = [
    "BONES",
    "DIGITS",
    "GROUPS",
    "JOINTS",
    "LOWER",
    "MIDDLE_MCP",
    "NAMES",
    "N_PARAMS",
    "POSE_NAMES",
    "UNITS",
    "UPPER",
    "WRIST",
    "HandModel",
    "HandProportions",
    "HandShape",
    "Primitives",
    "ProjectedPrimitives",
    "SurfaceSamples",
    "check_pose",
    "clamp",
    "hand_blocks",
    "index",
    "named_pose",
    "within_limits",
]
