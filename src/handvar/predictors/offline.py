"""Offline-trained VAR on second differences (paper §7, future work; design §16).

The paper's VARs are refitted online on the last N frames.  Its conclusion suggests
training motion models offline instead; this is the simplest one: the VAR(p) of
eq. 2 on the second differences y_t = x_t − 2x_{t−1} + x_{t−2} (eq. 3), fitted once
by ridge-regularised least squares on a training recording,

    B̂ = Y Wᵀ (W Wᵀ + ε I)⁻¹,   ε = ridge · tr(W Wᵀ) / (d p)          (eq. 14 + ridge)

its order p chosen by an information criterion (:func:`select_order`), then run
online like the others: x̂_{T+1} = x_T + (x_T − x_{T−1}) + Σ_i A_i y_{T+1−i} (eq. 5).
With ``ridge = 0`` B̂ is the least-squares estimate statsmodels' ``VAR.fit(p,
trend="n")`` returns.
"""

from __future__ import annotations

import itertools
from collections.abc import Sequence

import numpy as np

from handvar.predictors.base import as_series, as_vector
from handvar.predictors.order import select_order
from handvar.predictors.var import second_differences
from handvar.validate import as_float, as_int, one_of

__all__ = ["OfflineVAR"]


class OfflineVAR:
    """A VAR(p) on second differences, trained offline by :meth:`fit`, then run online.

    Parameters
    ----------
    order : int or None, default None
        p; ``None`` chooses it on the training data with :func:`select_order`
        (orders 1..`max_order`, `criterion`).
    max_order : int, default 8
        The largest order tried when `order` is None (lowered if the training
        series is too short for it).
    criterion : {"bic", "aic", "hqic", "fpe"}, default "bic"
    ridge : float, default 1e-3
        ε / (tr(W Wᵀ) / (d p)): the ridge relative to the regressors' mean square.
    blocks : sequence of sequences of int, optional
        Independent VARs on a partition of the coordinates (eq. 25); ``None`` is one
        VAR of everything.
    max_step : float or None, default None
        Bound on |x̂ − x_T| per coordinate, in the series' units.

    Examples
    --------
    >>> import numpy as np
    >>> t = np.arange(400.0)
    >>> X = np.stack([np.sin(t / 9), np.cos(t / 13)], axis=1)
    >>> var = OfflineVAR(order=2, ridge=0.0).fit(X)
    >>> for x in X[:50]:
    ...     var.update(x)
    >>> bool(np.abs(var.predict() - X[50]).max() < 1e-4)
    True
    """

    def __init__(
        self,
        order: int | None = None,
        *,
        max_order: int = 8,
        criterion: str = "bic",
        ridge: float = 1e-3,
        blocks: Sequence[Sequence[int]] | None = None,
        max_step: float | None = None,
    ) -> None:
        self.order = None if order is None else as_int(order, "order", minimum=1)
        self.max_order = as_int(max_order, "max_order", minimum=1)
        self.criterion = one_of(criterion, ("bic", "aic", "hqic", "fpe"), "criterion")
        self.ridge = as_float(ridge, "ridge", minimum=0.0)
        self.max_step = (
            None if max_step is None
            else as_float(max_step, "max_step", minimum=0.0, exclusive_minimum=True)
        )  # fmt: skip
        self.blocks = None if blocks is None else [[int(i) for i in b] for b in blocks]
        self.coefs: np.ndarray | None = None  # (p, d, d), statsmodels' convention
        self.reset()

    def fit(self, X, *, resets=()) -> OfflineVAR:
        """Fit the VAR on the training series `X` (T, d); rows `resets` start new takes.

        Returns
        -------
        self
        """
        X = as_series(X, "X")
        T, d = X.shape
        cuts = sorted({0, *(int(r) for r in resets), T})
        Ys = [second_differences(X[a:b]) for a, b in itertools.pairwise(cuts)]
        Ys = [Y for Y in Ys if len(Y) > 0]
        blocks = [list(range(d))] if self.blocks is None else self.blocks
        if sorted(i for b in blocks for i in b) != list(range(d)):
            raise ValueError(f"blocks: expected a partition of 0..{d - 1}; got {self.blocks!r}")
        p = self.order
        if p is None:
            longest = max(Ys, key=len) if Ys else np.zeros((0, d))
            kmax = max(len(b) for b in blocks)
            top = self.max_order
            while top >= 1 and len(longest) - top <= top * kmax:
                top -= 1
            if top < 1:
                raise ValueError(
                    f"X: expected enough frames to fit a VAR(1) on {d} columns; got {T}"
                )
            if len(blocks) == 1:
                p = select_order(longest, top).selected[self.criterion]
            else:  # the order most blocks choose
                votes = [select_order(longest[:, b], top).selected[self.criterion]
                         for b in blocks]  # fmt: skip
                p = int(np.bincount(votes).argmax())
        A = np.zeros((p, d, d))
        for b in blocks:
            targets, regressors = [], []
            for Y in Ys:
                Yb = Y[:, b]
                if len(Yb) <= p:
                    continue
                targets.append(Yb[p:])
                regressors.append(
                    np.hstack([Yb[p - lag : len(Yb) - lag] for lag in range(1, p + 1)])
                )
            if not targets:
                raise ValueError(f"X: expected more than {p + 2} frames per take; got fewer")
            Yt, Wt = np.vstack(targets), np.vstack(regressors)  # rows are equations
            WW = Wt.T @ Wt  # W Wᵀ of eq. 14
            eps = self.ridge * np.trace(WW) / WW.shape[0]
            B = np.linalg.lstsq(WW + eps * np.eye(len(WW)), Wt.T @ Yt, rcond=None)[0].T
            k = len(b)
            for lag in range(p):
                A[lag][np.ix_(b, b)] = B[:, lag * k : (lag + 1) * k]
        self.coefs = A
        self.order_ = p
        self.reset()
        return self

    def reset(self) -> None:
        """Forget the frames seen online (the fitted coefficients stay)."""
        self._hist: list[np.ndarray] = []

    def update(self, x) -> None:
        """Take the estimate `x` (d,) of the newest frame."""
        if self.coefs is None:
            raise RuntimeError("update() needs fit() first")
        d = self.coefs.shape[1]
        self._hist.append(as_vector(x, "x", d).copy())
        del self._hist[: -(self.order_ + 2)]

    def predict(self) -> np.ndarray:
        """x̂_{T+1} = x_T + (x_T − x_{T−1}) + Σ_i A_i y_{T+1−i} (eq. 5)."""
        if not self._hist:
            raise RuntimeError("predict() needs at least one update()")
        h = self._hist
        x = h[-1]
        if len(h) == 1:
            return x.copy()
        step = x - h[-2]
        for i in range(1, min(self.order_, len(h) - 2) + 1):  # y_{T+1-i}
            y = h[-i] - 2.0 * h[-i - 1] + h[-i - 2]
            step = step + self.coefs[i - 1] @ y
        if self.max_step is not None:
            step = np.clip(step, -self.max_step, self.max_step)
        return x + step

    def __repr__(self) -> str:
        p = getattr(self, "order_", self.order)
        return f"OfflineVAR(order={p}, ridge={self.ridge}, criterion={self.criterion!r})"
