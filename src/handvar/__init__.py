"""handvar: model-based 3D hand tracking with online, adaptive VAR motion prediction.

Implements Chik, Trumpf & Schraudolph, "Using an Adaptive VAR Model for Motion
Prediction in 3D Hand Tracking", and goes beyond it.

The public names load lazily, on first use (as scikit-image's do): ``import handvar``
itself imports none of numpy's heavy neighbours (numba, OpenCV, dask, SciPy's
optimisers)::

    import handvar
    track = handvar.track("video.mp4", keypoints="video-keypoints.npy")
    track.save("out")

- `track`, `Track`: the whole pipeline in one call (`handvar.pipeline`);
- `HandTracker`, `FrameResult`: the per-frame tracker, ``tracker.process(frame)``
  (`handvar.tracking.hand_tracker`); `HandsTracker`, `HandsResult`, `HandsTrack`: both
  hands at once, each under an identity kept by tracking (`handvar.tracking.hands`,
  ``handvar.track(..., hands=2)``);
- `HandModel`, `HandShape`: the hand model (`handvar.hand`);
- the motion predictors (`RVAR`, `VAR`, `AdaptiveBank`, ...; `handvar.predictors`) and
  `make_predictor` (by name, `handvar.predictors.catalogue`).
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from handvar.lazy import attach

__version__ = "0.1.0"

# imported on first use
__getattr__, __dir__ = attach(__name__, {
    "handvar.pipeline": ["track", "Track", "HandsTrack"],
    "handvar.tracking.hands": ["HandsTracker", "HandsResult"],
    "handvar.tracking.hand_tracker": ["HandTracker", "FrameResult"],
    "handvar.hand.kinematics": ["HandModel"],
    "handvar.hand.anthropometry": ["HandShape", "HandLandmark"],
    "handvar.predictors.catalogue": ["make_predictor"],
    "handvar.predictors": ["Predictor", "NoMotion", "Decelerating", "VAR", "RVAR",
                           "OfflineVAR", "KalmanCV", "OneEuro", "AdaptiveBank"],
})  # fmt: skip

__all__ = [
    "RVAR",
    "VAR",
    "AdaptiveBank",
    "Decelerating",
    "FrameResult",
    "HandLandmark",
    "HandModel",
    "HandShape",
    "HandTracker",
    "HandsResult",
    "HandsTrack",
    "HandsTracker",
    "KalmanCV",
    "NoMotion",
    "OfflineVAR",
    "OneEuro",
    "Predictor",
    "Track",
    "__version__",
    "make_predictor",
    "track",
]

if TYPE_CHECKING:  # what static checkers and editors see
    from handvar.hand.anthropometry import HandLandmark, HandShape
    from handvar.hand.kinematics import HandModel
    from handvar.pipeline import HandsTrack, Track, track
    from handvar.predictors import (
        RVAR,
        VAR,
        AdaptiveBank,
        Decelerating,
        KalmanCV,
        NoMotion,
        OfflineVAR,
        OneEuro,
        Predictor,
    )
    from handvar.predictors.catalogue import make_predictor
    from handvar.tracking.hand_tracker import FrameResult, HandTracker
    from handvar.tracking.hands import HandsResult, HandsTracker
