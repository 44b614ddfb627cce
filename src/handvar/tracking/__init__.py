"""Model-based tracking: the silhouette cost, stochastic meta-descent and the tracker.

- :mod:`~handvar.tracking.costs`: C_s, C_f (eq. 1) and their gradients (paper §2.1).
- :mod:`~handvar.tracking.keypoint_cost`: the keypoint term C_k and the front term C_z.
- :mod:`~handvar.tracking.smd`: stochastic meta-descent (paper §4).
- :mod:`~handvar.tracking.refine`: Levenberg–Marquardt steps after SMD on frames with
  keypoints (design §14.2).
- :mod:`~handvar.tracking.tracker`: `Tracker` (predict → optimise → update per frame).
- :mod:`~handvar.tracking.outputs`: the files of a track (poses, joints, overlays).
"""

from handvar.tracking.costs import (
    CostSettings,
    CostTerms,
    FrameData,
    Samples,
    SilhouetteCost,
    cost_reference,
    nearest_silhouette_field,
    prepare_frame,
)
from handvar.tracking.refine import RefineResult, RefineSettings, refine
from handvar.tracking.smd import SMDResult, SMDSettings, initial_gains, minimise, smd_step
from handvar.tracking.tracker import (
    FrameResult,
    QualitySettings,
    Tracker,
    TrackerSettings,
    TrackingWarning,
    TrackResult,
)

__all__ = [
    "CostSettings",
    "CostTerms",
    "FrameData",
    "FrameResult",
    "QualitySettings",
    "RefineResult",
    "RefineSettings",
    "SMDResult",
    "SMDSettings",
    "Samples",
    "SilhouetteCost",
    "TrackResult",
    "Tracker",
    "TrackerSettings",
    "TrackingWarning",
    "cost_reference",
    "initial_gains",
    "minimise",
    "nearest_silhouette_field",
    "prepare_frame",
    "refine",
    "smd_step",
]
