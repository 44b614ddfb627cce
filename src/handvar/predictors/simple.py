"""The two control predictors of the paper: no motion (eq. 16) and decelerating (eq. 22)."""

from __future__ import annotations

import numpy as np

from handvar.predictors.base import as_vector
from handvar.validate import as_float

__all__ = ["Decelerating", "NoMotion"]


class NoMotion:
    """The no-motion predictor, eq. 16: x̂_{T+1} = x_T."""

    def __init__(self) -> None:
        self.reset()

    def reset(self) -> None:
        self._x: np.ndarray | None = None

    def update(self, x) -> None:
        self._x = as_vector(x, "x", None if self._x is None else self._x.size).copy()

    def predict(self) -> np.ndarray:
        if self._x is None:
            raise RuntimeError("predict() needs at least one update()")
        return self._x.copy()

    def __repr__(self) -> str:
        return "NoMotion()"


class Decelerating:
    """The decelerating predictor, eq. 22: x̂_{T+1} = x_T + ρ (x_T − x_{T−1}).

    Parameters
    ----------
    rho : float, default 0.4
        The fraction of the last velocity carried forward; the paper's best value
        is 0.4 (paper §4), and ρ = 1 is the constant-velocity model.  With one frame
        seen, the prediction is that frame.
    """

    def __init__(self, rho: float = 0.4) -> None:
        self.rho = as_float(rho, "rho", minimum=0.0)
        self.reset()

    def reset(self) -> None:
        self._x: np.ndarray | None = None
        self._prev: np.ndarray | None = None

    def update(self, x) -> None:
        x = as_vector(x, "x", None if self._x is None else self._x.size)
        self._prev, self._x = self._x, x.copy()

    def predict(self) -> np.ndarray:
        if self._x is None:
            raise RuntimeError("predict() needs at least one update()")
        if self._prev is None:
            return self._x.copy()
        return self._x + self.rho * (self._x - self._prev)  # eq. 22

    def __repr__(self) -> str:
        return f"Decelerating(rho={self.rho})"
