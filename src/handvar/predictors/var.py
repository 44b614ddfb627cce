"""Online VAR(p) prediction on second differences with limited memory (paper §3, §4).

The paper refits eq. 14 on the last N samples after every frame.  Solving it from
scratch costs O(N d² p²) a frame; here the window is kept as its sufficient
statistics — the sums Σ W Wᵀ and Σ y Wᵀ of eq. 14 — updated in place: the newest
equation is added and the one that leaves the window is subtracted, so a frame costs
O(d² p²) whatever N is.  No library offers a sliding-window, block-constrained VAR
with this cost, which is why it is written here; the batch estimate is checked
against statsmodels in the tests.

Blocks (eq. 25) are independent VARs: the least-squares problem separates, so each
block's coefficients are the least-squares fit of that block alone.  The per-frame
loops over blocks are compiled (``_kernels``).
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from handvar.predictors import _kernels
from handvar.predictors.base import as_vector

__all__ = ["VAR", "second_differences"]


def second_differences(X) -> np.ndarray:
    """The 'accelerations' of eq. 3: y_t = x_t − 2 x_{t−1} + x_{t−2}, shape (T − 2, d)."""
    X = np.asarray(X, dtype=float)
    return X[2:] - 2.0 * X[1:-1] + X[:-2]


class VAR:
    """Online, limited-memory VAR(p) predictor on second differences (eq. 3–5, 14, 25).

    After every ``update`` the VAR(p) of eq. 2 on y_t = x_t − 2x_{t−1} + x_{t−2} is
    refitted by least squares (eq. 14) on the last `memory` equations; ``predict``
    returns x̂_{T+1} = ŷ_{T+1} + 2 x_T − x_{T−1} (eq. 5), each parameter's step
    |x̂ − x_T| bounded by `max_step` (the paper's 10° threshold, §4.2).

    Parameters
    ----------
    order : int, default 1
        The order p.  The paper uses p = 1 (§4.1).
    memory : int, default 150
        N, the number of equations (pairs of target y_t and regressors
        y_{t−1} … y_{t−p}) in the least-squares window; the paper's full VAR uses
        150, its structured VAR 30.
    blocks : sequence of sequences of int, optional
        A partition of the parameter indices into independent VARs; ``None`` is one
        block of everything (the full VAR), :func:`hand_blocks` is eq. 25.
    max_step : float or (d,) array_like or None, default 10.0
        Bound on |x̂ − x_T| per parameter, in the parameters' units (degrees for
        angles, millimetres for translations); ``None`` disables it.

    Notes
    -----
    The window is kept as sufficient statistics, so a frame costs the same whatever
    `memory` is; the sums are recomputed exactly from the stored window every
    `memory` frames so that rounding cannot accumulate.  Until a block has at least
    k·p equations (k its size) its ŷ is 0, i.e. the prediction is constant
    velocity; with one frame seen, the prediction is that frame.  A block whose
    regressors are linearly dependent gets the minimum-norm least-squares solution.

    Examples
    --------
    >>> import numpy as np
    >>> from handvar.predictors import VAR, hand_blocks
    >>> svar = VAR(order=1, memory=30, blocks=hand_blocks())  # the paper's structured VAR
    >>> for x in np.cumsum(np.ones((40, 26)), axis=0):
    ...     svar.update(x)
    >>> svar.predict()[:3]
    array([41., 41., 41.])
    """

    def __init__(
        self,
        order: int = 1,
        memory: int = 150,
        blocks: Sequence[Sequence[int]] | None = None,
        max_step: float | np.ndarray | None = 10.0,
    ) -> None:
        if isinstance(order, bool) or not isinstance(order, int | np.integer) or order < 1:
            raise ValueError(f"order: expected an integer >= 1; got {order!r}")
        if isinstance(memory, bool) or not isinstance(memory, int | np.integer) or memory < 1:
            raise ValueError(f"memory: expected an integer >= 1; got {memory!r}")
        if max_step is not None:
            step = np.asarray(max_step, dtype=float)
            if step.ndim > 1 or not np.all(np.isfinite(step)) or np.any(step <= 0):
                raise ValueError(
                    f"max_step: expected a positive number, a vector of them, or None; "
                    f"got {max_step!r}"
                )
            max_step = step
        self.order = int(order)
        self.memory = int(memory)
        self.blocks = None if blocks is None else [list(map(int, b)) for b in blocks]
        self.max_step = max_step
        self.reset()

    # -- state ------------------------------------------------------------------------
    def reset(self) -> None:
        """Forget every frame; the next update starts a new series."""
        self._d: int | None = None
        self._x: np.ndarray | None = None  # x_T
        self._x1: np.ndarray | None = None  # x_{T-1}
        self._x2: np.ndarray | None = None  # x_{T-2}
        self._n_x = 0  # frames seen since reset
        self._n_y = 0  # second differences seen since reset
        self._n_eq = 0  # equations in the least-squares window
        self._since_refresh = 0

    def _allocate(self, d: int) -> None:
        blocks = [list(range(d))] if self.blocks is None else self.blocks
        flat = sorted(i for b in blocks for i in b)
        if flat != list(range(d)) or any(len(b) == 0 for b in blocks):
            raise ValueError(
                f"blocks: expected a partition of the parameter indices 0..{d - 1} "
                f"(each exactly once); got {self.blocks!r}"
            )
        if self.max_step is not None and self.max_step.ndim == 1 and self.max_step.size != d:
            raise ValueError(
                f"max_step: expected a scalar or a vector of length {d}; "
                f"got length {self.max_step.size}"
            )
        nb, kmax = len(blocks), max(len(b) for b in blocks)
        m = kmax * self.order
        self._index = np.zeros((nb, kmax), dtype=np.intp)
        for i, b in enumerate(blocks):
            self._index[i, : len(b)] = b
        self._sizes = np.array([len(b) for b in blocks], dtype=np.intp)
        self._S_WW = np.zeros((nb, m, m))  # Σ W Wᵀ over the window (eq. 14's W W')
        self._S_YW = np.zeros((nb, kmax, m))  # Σ y Wᵀ over the window (eq. 14's Y W')
        self._B = np.zeros((nb, kmax, m))  # (A_1 ... A_p) per block, eq. 11
        self._ready = np.zeros(nb, dtype=np.bool_)
        self._d = d
        # y_n lives in row n % capacity; an equation spans p + 1 consecutive y's, and
        # the one leaving the window is `memory` equations behind the newest.
        self._capacity = self.memory + self.order + 1
        self._y = np.zeros((self._capacity, d))

    def _lags(self, n: int) -> np.ndarray:
        """(y_{n-1}, ..., y_{n-p}) as a (p, d) array."""
        if self.order == 1:
            return self._y[(n - 1) % self._capacity][None]
        return self._y[(n - 1 - np.arange(self.order)) % self._capacity]

    def _add(self, n: int, sign: float) -> None:
        """Add (sign = 1) or remove (sign = -1) the equation whose target is y_n."""
        _kernels.add_equation(
            self._S_WW,
            self._S_YW,
            self._index,
            self._sizes,
            self.order,
            self._y[n % self._capacity],
            self._lags(n),
            sign,
        )

    def update(self, x) -> None:
        """Take the estimate `x` (d,) of the newest frame and refit eq. 14."""
        x = as_vector(x, "x", self._d)
        if self._d is None:
            self._allocate(x.size)
        self._x2, self._x1, self._x = self._x1, self._x, x.copy()
        self._n_x += 1
        if self._n_x < 3:
            return
        n = self._n_y
        np.add(self._x - 2.0 * self._x1, self._x2, out=self._y[n % self._capacity])  # eq. 3
        self._n_y += 1
        if n < self.order:
            return
        self._add(n, 1.0)
        self._n_eq += 1
        if self._n_eq > self.memory:  # drop the oldest equation (limited memory, §3.2)
            self._add(n - self.memory, -1.0)
            self._n_eq -= 1
            self._since_refresh += 1
            if self._since_refresh >= self.memory:
                self._recompute()
        _kernels.fit_blocks(
            self._S_WW, self._S_YW, self._sizes, self.order, self._n_eq, self._B, self._ready
        )

    def _recompute(self) -> None:
        """Rebuild the window's sums exactly from the stored y's."""
        self._S_WW[:] = 0.0
        self._S_YW[:] = 0.0
        newest = self._n_y - 1
        for n in range(newest - self._n_eq + 1, newest + 1):
            self._add(n, 1.0)
        self._since_refresh = 0

    def predict(self) -> np.ndarray:
        """x̂_{T+1} = ŷ_{T+1} + 2 x_T - x_{T-1} (eq. 5), steps bounded by `max_step`."""
        if self._x is None:
            raise RuntimeError("predict() needs at least one update()")
        if self._x1 is None:
            return self._x.copy()
        step = self._x - self._x1  # x̂ - x_T with ŷ = 0 (constant velocity)
        if self._n_y >= self.order:
            y_hat = np.zeros(self._d)
            _kernels.predict_blocks(  # W_T of eq. 15 = (y_T, ..., y_{T-p+1})
                self._B, self._index, self._sizes, self.order, self._ready,
                self._lags(self._n_y), y_hat,
            )  # fmt: skip
            step += y_hat
        if self.max_step is not None:
            step = np.clip(step, -self.max_step, self.max_step)
        return self._x + step

    @property
    def coefs(self) -> np.ndarray:
        """The fitted A_1 ... A_p, shape (p, d, d), statsmodels' convention.

        ``coefs[i]`` is A_{i+1} of eq. 2; entries outside the blocks are exactly
        zero, and so are the rows of blocks that have too few equations yet.
        """
        if self._d is None:
            raise RuntimeError("coefs needs at least one update()")
        A = np.zeros((self.order, self._d, self._d))
        for b, k in enumerate(self._sizes):
            if not self._ready[b]:
                continue
            idx = self._index[b, :k]
            for lag in range(self.order):
                A[lag][np.ix_(idx, idx)] = self._B[b, :k, lag * k : (lag + 1) * k]
        return A

    @property
    def n_equations(self) -> int:
        """How many equations the least-squares window holds now (at most `memory`)."""
        return self._n_eq

    def __repr__(self) -> str:
        blocks = "None" if self.blocks is None else f"<{len(self.blocks)} blocks>"
        step = None if self.max_step is None else self.max_step.tolist()
        return f"VAR(order={self.order}, memory={self.memory}, blocks={blocks}, max_step={step})"
