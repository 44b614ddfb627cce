"""A constant-velocity Kalman filter, one per parameter: a common baseline predictor.

Not in the paper; it is the textbook alternative to its decelerating model and is
reported beside it in the experiments.
"""

from __future__ import annotations

import numpy as np

from handvar.predictors.base import as_vector
from handvar.validate import as_float

__all__ = ["KalmanCV"]


class KalmanCV:
    """Independent constant-velocity Kalman filters on every parameter.

    State per parameter (position, velocity per frame); F = [[1, 1], [0, 1]],
    H = [1, 0], Q = q [[1/3, 1/2], [1/2, 1]] (white-noise acceleration over one
    frame), R = r.

    Parameters
    ----------
    q : float, default 1.0
        Process noise intensity, (units / frame)² per frame: how much the velocity
        may change between frames (degrees or millimetres).
    r : float, default 1.0
        Measurement noise variance of the tracker's estimates, units².

    Notes
    -----
    The filter is linear and starts at the first observation with zero velocity,
    so a constant offset of the input moves the prediction by the same constant.
    """

    def __init__(self, q: float = 1.0, r: float = 1.0) -> None:
        self.q = as_float(q, "q", minimum=0.0, exclusive_minimum=True)
        self.r = as_float(r, "r", minimum=0.0, exclusive_minimum=True)
        self.reset()

    def reset(self) -> None:
        self._m: np.ndarray | None = None  # (2, d) mean: position, velocity
        self._P: np.ndarray | None = None  # (3, d) covariance entries P00, P01, P11

    def update(self, x) -> None:
        z = as_vector(x, "x", None if self._m is None else self._m.shape[1])
        if self._m is None:
            self._m = np.stack([z, np.zeros_like(z)])
            self._P = np.stack([np.full_like(z, self.r), np.zeros_like(z), np.full_like(z, 1e4)])
            return
        m, (p00, p01, p11) = self._m, self._P
        q = self.q
        # Time update: m = F m; P = F P F' + Q.
        m = np.stack([m[0] + m[1], m[1]])
        p00, p01, p11 = (
            p00 + 2 * p01 + p11 + q / 3,
            p01 + p11 + q / 2,
            p11 + q,
        )
        # Measurement update: K = P H' / (H P H' + R); m += K (z - H m); P = (I - K H) P.
        s = p00 + self.r
        k0, k1 = p00 / s, p01 / s
        innovation = z - m[0]
        self._m = np.stack([m[0] + k0 * innovation, m[1] + k1 * innovation])
        self._P = np.stack([(1 - k0) * p00, (1 - k0) * p01, p11 - k1 * p01])

    def predict(self) -> np.ndarray:
        if self._m is None:
            raise RuntimeError("predict() needs at least one update()")
        return self._m[0] + self._m[1]  # H F m

    def __repr__(self) -> str:
        return f"KalmanCV(q={self.q}, r={self.r})"
