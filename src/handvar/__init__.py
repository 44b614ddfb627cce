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

import importlib
from typing import TYPE_CHECKING

__version__ = "0.1.0"

#: public name -> the module that defines it
_LAZY = {
    "track": "handvar.pipeline",
    "Track": "handvar.pipeline",
    "HandsTrack": "handvar.pipeline",
    "HandsTracker": "handvar.tracking.hands",
    "HandsResult": "handvar.tracking.hands",
    "HandTracker": "handvar.tracking.hand_tracker",
    "FrameResult": "handvar.tracking.hand_tracker",
    "HandModel": "handvar.hand.kinematics",
    "HandShape": "handvar.hand.anthropometry",
    "HandLandmark": "handvar.hand.anthropometry",
    "make_predictor": "handvar.predictors.catalogue",
    "Predictor": "handvar.predictors",
    "NoMotion": "handvar.predictors",
    "Decelerating": "handvar.predictors",
    "VAR": "handvar.predictors",
    "RVAR": "handvar.predictors",
    "OfflineVAR": "handvar.predictors",
    "KalmanCV": "handvar.predictors",
    "OneEuro": "handvar.predictors",
    "AdaptiveBank": "handvar.predictors",
}

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


def __getattr__(name: str):
    """Import the module of a public name on first use (PEP 562)."""
    module = _LAZY.get(name)
    if module is None:
        raise AttributeError(f"module 'handvar' has no attribute {name!r}")
    value = getattr(importlib.import_module(module), name)
    globals()[name] = value  # later look-ups skip this function
    return value


def __dir__() -> list[str]:
    return sorted({*globals(), *__all__})
