"""The One Euro filter (Casiez, Roussel, Vogel, CHI 2012) as a one-step predictor.

Keypoint pipelines smooth their detections with it and show the filtered value, so
as a motion predictor its prediction of the next frame is the current filtered
value.  Per coordinate, with T_e = 1 / rate the sampling period and, for a cutoff
frequency f_c (Hz), τ = 1 / (2π f_c) and α(f_c) = 1 / (1 + τ / T_e):

    ẋ_i  = (x_i − x̂_{i−1}) / T_e                      (derivative of the signal)
    dx̂_i = α(f_d) ẋ_i + (1 − α(f_d)) dx̂_{i−1}          (its low-pass, cutoff f_d)
    f_c  = f_cmin + β |dx̂_i|                           (the speed-based cutoff)
    x̂_i  = α(f_c) x_i + (1 − α(f_c)) x̂_{i−1}           (the filtered value)

and x̂_1 = x_1, dx̂_1 = 0.  Not in the paper; a baseline of the league table (design §16).

Tuning (the CHI paper's two-step procedure): set β = 0 and f_cmin to a middle value
such as 1 Hz; with the hand still or moving slowly, lower f_cmin until the jitter is
gone while the lag stays acceptable; then move it fast and raise β (its scale depends
on the units: start at 0.001 or 0.0001 per unit/s and change it by factors of 10)
until the lag at high speed is acceptable.  The defaults here are the reference
implementation's: f_cmin = 1 Hz, β = 0, f_d = 1 Hz.
"""

from __future__ import annotations

import math

import numpy as np

from handvar.predictors.base import as_vector
from handvar.validate import as_float

__all__ = ["OneEuro", "one_euro_alpha"]


def one_euro_alpha(cutoff, rate: float):
    """α = 1 / (1 + τ / T_e) with τ = 1 / (2π f_c) and T_e = 1 / rate.

    Parameters
    ----------
    cutoff : float or ndarray
        Cutoff frequency f_c, Hz (> 0).
    rate : float
        Sampling rate, frames per second.
    """
    tau = 1.0 / (2.0 * math.pi * cutoff)
    return 1.0 / (1.0 + tau * rate)


class OneEuro:
    """One Euro filter on every coordinate; predicts the next frame as the filtered value.

    Parameters
    ----------
    min_cutoff : float, default 1.0
        f_cmin, the cutoff at zero speed, Hz.
    beta : float, default 0.0
        β, the cutoff's increase per unit of speed, Hz per (unit / s).
    d_cutoff : float, default 1.0
        f_d, the cutoff of the derivative's low-pass, Hz.
    rate : float, default 30.0
        Frames per second of the series.

    Examples
    --------
    >>> f = OneEuro(rate=30.0)
    >>> f.update([0.0]); f.update([1.0])
    >>> round(float(f.predict()[0]), 4)     # α(1 Hz) at 30 fps
    0.1732
    """

    def __init__(
        self,
        min_cutoff: float = 1.0,
        beta: float = 0.0,
        d_cutoff: float = 1.0,
        rate: float = 30.0,
    ) -> None:
        self.min_cutoff = as_float(min_cutoff, "min_cutoff", minimum=0.0, exclusive_minimum=True)
        self.beta = as_float(beta, "beta", minimum=0.0)
        self.d_cutoff = as_float(d_cutoff, "d_cutoff", minimum=0.0, exclusive_minimum=True)
        self.rate = as_float(rate, "rate", minimum=0.0, exclusive_minimum=True)
        self.reset()

    def reset(self) -> None:
        self._x: np.ndarray | None = None  # x̂_{i-1}
        self._dx: np.ndarray | None = None  # dx̂_{i-1}

    def update(self, x) -> None:
        x = as_vector(x, "x", None if self._x is None else self._x.size)
        if self._x is None:
            self._x, self._dx = x.copy(), np.zeros_like(x)
            return
        dx = (x - self._x) * self.rate
        self._dx += one_euro_alpha(self.d_cutoff, self.rate) * (dx - self._dx)
        a = one_euro_alpha(self.min_cutoff + self.beta * np.abs(self._dx), self.rate)
        self._x += a * (x - self._x)

    def predict(self) -> np.ndarray:
        if self._x is None:
            raise RuntimeError("predict() needs at least one update()")
        return self._x.copy()

    def __repr__(self) -> str:
        return (
            f"OneEuro(min_cutoff={self.min_cutoff}, beta={self.beta}, "
            f"d_cutoff={self.d_cutoff}, rate={self.rate})"
        )
