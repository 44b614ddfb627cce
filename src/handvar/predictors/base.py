"""The predictor protocol shared by the tracker, the experiments and users' trackers.

Every motion predictor speaks two verbs, as filterpy's estimators do: ``update(x)``
hands it the tracker's estimate for the newest frame, ``predict()`` returns the
initial value for the next frame.  ``reset()`` forgets everything.
"""

from __future__ import annotations

from typing import Protocol, runtime_checkable

import numpy as np

from handvar.validate import as_array, as_int

__all__ = ["Predictor", "as_series", "as_vector", "one_step_chunks", "one_step_predictions"]


@runtime_checkable
class Predictor(Protocol):
    """A one-step-ahead motion predictor.

    ``predict()`` before the first ``update()`` raises ``RuntimeError``: there is
    nothing to extrapolate from.
    """

    def update(self, x: np.ndarray) -> None:
        """Take the estimate ``x`` (d,) of the newest frame."""

    def predict(self) -> np.ndarray:
        """Return the prediction (d,) for the next frame."""

    def reset(self) -> None:
        """Forget every frame seen so far."""


def as_vector(x, name: str = "x", size: int | None = None) -> np.ndarray:
    """Return `x` as a finite float64 vector, or raise naming `name`.

    TypeError if it is not numeric, ValueError if its shape differs from ``(size,)``
    (any length but 0 when `size` is None) or it holds NaN or infinity.
    """
    # The per-frame fast path; handvar.validate words the error when there is one.
    try:
        arr = None if isinstance(x, str | bytes) else np.asarray(x, dtype=float)
    except (TypeError, ValueError):
        arr = None
    if (
        arr is None
        or arr.ndim != 1
        or (size is not None and arr.shape[0] != size)
        or not np.isfinite(arr).all()
    ):
        return as_array(x, name, (size,), what="a vector")
    if arr.shape[0] == 0:
        raise ValueError(f"{name}: expected a vector of at least one value; got shape (0,)")
    return arr


def as_series(X, name: str = "X") -> np.ndarray:
    """Return `X` as a finite float64 (T, d) array, or raise naming `name`."""
    arr = as_array(X, name, (None, None), finite=False, what="a series")
    if arr.shape[0] < 1 or arr.shape[1] < 1:
        raise ValueError(f"{name}: expected a series of shape (T, d); got shape {arr.shape}")
    if not np.isfinite(arr).all():
        bad = np.argwhere(~np.isfinite(arr))[0]
        raise ValueError(
            f"{name}: expected finite values; got {arr[tuple(bad)]} at row {bad[0]}, "
            f"column {bad[1]}"
        )
    return arr


def one_step_predictions(predictor: Predictor, X, *, resets=()) -> np.ndarray:
    """Run `predictor` along a recorded series: open-loop one-step prediction.

    Parameters
    ----------
    predictor : Predictor
        Reset first, then fed the rows of `X` one at a time.
    X : (T, d) array_like
        The recorded series, one row a frame.
    resets : iterable of int, optional
        Rows at which the recording restarts (a cut between two takes): the
        predictor is reset before that row, whose prediction is then undefined.

    Returns
    -------
    (T, d) ndarray
        ``X_hat[t]`` is the prediction made from ``X[:t]`` (since the last reset);
        rows with no history (row 0 and every reset row) are NaN.

    Examples
    --------
    >>> from handvar.predictors import Decelerating
    >>> one_step_predictions(Decelerating(rho=1.0), [[0.0], [1.0], [2.0]])[1:, 0]
    array([0., 2.])
    """
    X = as_series(X)
    X_hat = np.full_like(X, np.nan)
    for start, chunk in one_step_chunks(predictor, X, resets=resets, chunk=len(X)):
        X_hat[start : start + len(chunk)] = chunk
    return X_hat


def one_step_chunks(predictor: Predictor, X, *, resets=(), chunk: int = 4096):
    """:func:`one_step_predictions`, `chunk` rows at a time: memory flat in T.

    Yields ``(start, X_hat[start : start + chunk])`` in order; the predictor keeps its
    state from one chunk to the next, so the chunks together are exactly
    :func:`one_step_predictions`' result.  Several predictors advanced in lockstep
    (one generator each) let a caller score a long series without holding every
    prediction of it.

    Examples
    --------
    >>> from handvar.predictors import NoMotion
    >>> [(s, c[:, 0].tolist()) for s, c in one_step_chunks(NoMotion(), [[1.0], [2.0], [3.0]],
    ...                                                     chunk=2)]
    [(0, [nan, 1.0]), (2, [2.0])]
    """
    X = as_series(X)
    chunk = as_int(chunk, "chunk", minimum=1)
    cuts = {as_int(r, "resets") for r in resets}
    if any(not 0 <= r < len(X) for r in cuts):
        raise ValueError(f"resets: expected row numbers in [0, {len(X)}); got {sorted(cuts)}")
    predictor.reset()
    fresh = True
    for start in range(0, len(X), chunk):
        rows = X[start : start + chunk]
        X_hat = np.full_like(rows, np.nan)
        for k, x in enumerate(rows):
            if start + k in cuts:
                predictor.reset()
                fresh = True
            if not fresh:
                X_hat[k] = predictor.predict()
            predictor.update(x)
            fresh = False
        yield start, X_hat
