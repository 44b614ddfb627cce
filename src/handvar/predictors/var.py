"""Online VAR(p) prediction on second differences with limited memory (paper §3, §4).

The paper refits eq. 14 on the last N samples after every frame.  Solving it from
scratch costs O(N d² p²) a frame; here the window is kept as R factors of its QR
decomposition and slides in amortised O(d² p²) a frame whatever N is, without ever
removing a row from a factor: the window is split, as a queue built from two stacks,
into an older part held as its suffixes' R factors (R of rows i … f for every i) and
a newer part held as one R that rows are rotated into.  The window's R is the oldest
suffix's R with the newer part's rotated in; when the older part runs out, the
newer part's suffixes are built afresh from the stored second differences.  Every
factor is an orthogonal reduction of rows that are all still in the window, so the
fit is the least-squares fit of the window as numpy.linalg.lstsq computes it —
through rank-deficient windows (a parameter held still), scale changes of many
orders of magnitude and large offsets — where sums of outer products updated by
adding and subtracting would lose it to cancellation.  No library offers a
sliding-window, block-constrained VAR with this cost, which is why it is written
here; the batch estimate is checked against statsmodels and lstsq in the tests.

Blocks (eq. 25) are independent VARs: the least-squares problem separates, so each
block's coefficients are the least-squares fit of that block alone.  The per-frame
loops over blocks are compiled (``_kernels``).
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from handvar.predictors import _kernels
from handvar.predictors.base import as_vector
from handvar.validate import as_array, as_float, as_instance, as_int

__all__ = ["VAR", "second_differences"]


def second_differences(X) -> np.ndarray:
    """The 'accelerations' of eq. 3: y_t = x_t − 2 x_{t−1} + x_{t−2}, shape (T − 2, d)."""
    X = np.asarray(X, dtype=float)
    return X[2:] - 2.0 * X[1:-1] + X[:-2]


def check_blocks(blocks) -> list[list[int]] | None:
    """Return `blocks` as lists of ints if they are disjoint, non-empty and >= 0.

    Whether they cover 0 … d − 1 exactly is checked once d is known (the first
    update).  Raises TypeError for a non-integer index, ValueError otherwise.
    """
    if blocks is None:
        return None
    as_instance(blocks, Sequence | np.ndarray, "blocks", what="a sequence of sequences of int")
    out, seen = [], set()
    for block in blocks:
        as_instance(block, Sequence | np.ndarray, "blocks", what="a sequence of sequences of int")
        idx = [as_int(i, "blocks", minimum=0) for i in block]
        if not idx:
            raise ValueError(f"blocks: expected non-empty blocks; got {blocks!r}")
        twice = sorted(seen.intersection(idx)) or sorted({i for i in idx if idx.count(i) > 1})
        if twice:
            raise ValueError(
                f"blocks: expected disjoint blocks (each index once); got {twice[0]} twice"
            )
        seen.update(idx)
        out.append(idx)
    if not out:
        raise ValueError(f"blocks: expected at least one block; got {blocks!r}")
    return out


def _smallest_memory(order: int, k: int) -> int:
    """The fewest equations a window must be able to hold: k·p + 1."""
    return k * order + 1


class VAR:
    """Online, limited-memory VAR(p) predictor on second differences (eq. 3–5, 14, 25).

    After every ``update`` the VAR(p) of eq. 2 on y_t = x_t − 2x_{t−1} + x_{t−2} is
    refitted by least squares (eq. 14) on the last `memory` equations; ``predict``
    returns x̂_{T+1} = ŷ_{T+1} + 2 x_T − x_{T−1} (eq. 5), each parameter's step
    |x̂ − x_T| bounded by `max_step` (the paper's 10° threshold, paper §4.2).

    Parameters
    ----------
    order : int, default 1
        The order p.  The paper uses p = 1 (paper §4.1).
    memory : int, default 150
        N, the number of equations (pairs of target y_t and regressors
        y_{t−1} … y_{t−p}) in the least-squares window; the paper's full VAR uses
        150, its structured VAR 30.  At least k·p + 1 for the largest block's size
        k, so that every block can be fitted; for ``blocks=None`` k is the
        dimension, checked at the first update.
    blocks : sequence of sequences of int, optional
        A partition of the parameter indices into independent VARs; ``None`` is one
        block of everything (the full VAR), :func:`hand_blocks` is eq. 25.  Checked
        here (integers >= 0, disjoint, non-empty) and at the first update (they
        cover 0 … d − 1).
    max_step : float or (d,) array_like or None, default 10.0
        Bound on |x̂ − x_T| per parameter, in the parameters' units (degrees for
        angles, millimetres for translations); ``None`` disables it.

    Notes
    -----
    The coefficients after every update are the minimum-norm least-squares
    solution of the window, as numpy.linalg.lstsq gives it (same relative rank
    cut-off), whatever the history: a frame costs the same whatever `memory` is,
    amortised — every `memory` frames or so one frame rebuilds the older half of
    the window, O(`memory`·(kp)²·(kp + k)) — and the state holds `memory` + 1 R
    factors of (kp) × (kp + k) per block.  Until a block has at least k·p
    equations its ŷ is 0, i.e. the prediction is constant velocity; with one
    frame seen, the prediction is that frame.  The prediction moves with a constant
    offset of the input (x + c ↦ x̂ + c): the fit sees only second differences.

    Examples
    --------
    >>> import numpy as np
    >>> from handvar.predictors import VAR, hand_blocks
    >>> svar = VAR(order=1, memory=30, blocks=hand_blocks())  # the paper's structured VAR
    >>> for x in np.cumsum(np.ones((40, 26)), axis=0):
    ...     svar.update(x)
    >>> svar.predict()[:3]
    array([41., 41., 41.])
    >>> VAR(memory=10, blocks=[range(26)])
    Traceback (most recent call last):
    ...
    ValueError: memory: expected an integer >= 27 for order 1 with a block of 26 parameters; got 10
    """

    def __init__(
        self,
        order: int = 1,
        memory: int = 150,
        blocks: Sequence[Sequence[int]] | None = None,
        max_step: float | np.ndarray | None = 10.0,
    ) -> None:
        self.order = as_int(order, "order", minimum=1)
        self.memory = as_int(memory, "memory", minimum=1)
        self.blocks = check_blocks(blocks)
        if self.blocks is not None:
            self._check_memory(max(len(b) for b in self.blocks))
        if max_step is not None:
            if np.ndim(max_step) == 0:
                step = np.asarray(
                    as_float(max_step, "max_step", minimum=0.0, exclusive_minimum=True)
                )
            else:
                step = as_array(max_step, "max_step", (None,), what="a vector")
                if np.any(step <= 0):
                    raise ValueError(f"max_step: expected positive values; got {float(step.min())}")
            max_step = step
        self.max_step = max_step
        self.reset()

    def _check_memory(self, k: int) -> None:
        low = _smallest_memory(self.order, k)
        if self.memory < low:
            raise ValueError(
                f"memory: expected an integer >= {low} for order {self.order} with a block "
                f"of {k} parameters; got {self.memory}"
            )

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
        self._lo = 0  # target index of the oldest equation in the window
        self._f = 0  # target index of the oldest equation of the newer part
        self._n_back = 0  # equations in the newer part

    def _allocate(self, d: int) -> None:
        blocks = [list(range(d))] if self.blocks is None else self.blocks
        if self.blocks is None:
            self._check_memory(d)
        if sorted(i for b in blocks for i in b) != list(range(d)):
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
        # R factors (top kp rows of the QR of [W | Y]) per block: the newer part of
        # the window, the older part's suffixes (one slot per equation), the window.
        self._slots = self.memory + 1
        self._R_back = np.zeros((nb, m, m + kmax))
        self._R_front = np.zeros((nb, self._slots, m, m + kmax))
        self._R = np.zeros((nb, m, m + kmax))
        self._B = np.zeros((nb, kmax, m))  # (A_1 ... A_p) per block, eq. 11
        self._ready = np.zeros(nb, dtype=np.bool_)
        self._d = d
        # y_n lives in row n % capacity; an equation spans p + 1 consecutive y's.
        self._capacity = self.memory + self.order + 2
        self._y = np.zeros((self._capacity, d))

    def _lags(self, n: int) -> np.ndarray:
        """(y_{n-1}, ..., y_{n-p}) as a (p, d) array."""
        if self.order == 1:
            return self._y[(n - 1) % self._capacity][None]
        return self._y[(n - 1 - np.arange(self.order)) % self._capacity]

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
        if self._n_eq == 0:
            self._lo = self._f = n
        _kernels.push_equation(
            self._R_back, self._y, self._capacity, n, self._index, self._sizes, self.order
        )
        self._n_back += 1
        self._n_eq += 1
        if self._n_eq > self.memory:  # drop the oldest equation (limited memory, paper §3.2)
            if self._lo == self._f:  # the older part is used up: the newer becomes it
                _kernels.build_suffixes(
                    self._R_front, self._slots, self._y, self._capacity, self._f, n,
                    self._index, self._sizes, self.order,
                )  # fmt: skip
                self._f = n + 1
                self._R_back[:] = 0.0
                self._n_back = 0
            self._lo += 1
            self._n_eq -= 1
        front = self._lo % self._slots if self._lo < self._f else -1
        _kernels.fit_blocks(
            self._R_front, front, self._R_back, self._n_back, self._sizes, self.order,
            self._n_eq, self._R, self._B, self._ready,
        )  # fmt: skip

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
