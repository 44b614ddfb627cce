"""Online motion predictors (paper §3–5): one protocol, ``update`` / ``predict`` / ``reset``.

>>> import numpy as np
>>> from handvar.predictors import RVAR
>>> rvar = RVAR()                      # γ = 0.8, c = 8, structured VAR inside
>>> for x in np.zeros((5, 26)):
...     rvar.update(x)
>>> rvar.predict().shape
(26,)
"""

from handvar.params import hand_blocks
from handvar.predictors.adaptive import (
    EXPERTS,
    JOINING,
    STEERING_EXPERTS,
    AdaptiveBank,
    hand_groups,
)
from handvar.predictors.base import Predictor, one_step_chunks, one_step_predictions
from handvar.predictors.kalman import KalmanCV
from handvar.predictors.offline import OfflineVAR
from handvar.predictors.one_euro import OneEuro
from handvar.predictors.order import OrderSelection, select_order
from handvar.predictors.rvar import RVAR, fit_affine_weights, fit_trust_weights
from handvar.predictors.simple import Decelerating, NoMotion
from handvar.predictors.var import VAR, second_differences

__all__ = [
    "EXPERTS",
    "JOINING",
    "RVAR",
    "STEERING_EXPERTS",
    "VAR",
    "AdaptiveBank",
    "Decelerating",
    "KalmanCV",
    "NoMotion",
    "OfflineVAR",
    "OneEuro",
    "OrderSelection",
    "Predictor",
    "fit_affine_weights",
    "fit_trust_weights",
    "hand_blocks",
    "hand_groups",
    "one_step_chunks",
    "one_step_predictions",
    "second_differences",
    "select_order",
]
