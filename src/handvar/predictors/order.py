"""VAR order selection by information criteria (paper §4.1; Lütkepohl 2006, section 4.3)."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from handvar.predictors.base import as_series
from handvar.validate import as_int

__all__ = ["OrderSelection", "select_order"]


@dataclass(frozen=True)
class OrderSelection:
    """Information criteria for VAR orders 1..max_order on one common sample.

    Attributes
    ----------
    orders : (K,) ndarray
        The orders compared, 1..max_order.
    aic, bic, hqic, fpe : (K,) ndarray
        Akaike, Schwarz (Bayesian), Hannan–Quinn and final prediction error.
    """

    orders: np.ndarray
    aic: np.ndarray
    bic: np.ndarray
    hqic: np.ndarray
    fpe: np.ndarray

    @property
    def selected(self) -> dict[str, int]:
        """The order each criterion picks (its minimum)."""
        return {
            name: int(self.orders[np.argmin(getattr(self, name))])
            for name in ("aic", "bic", "hqic", "fpe")
        }


def select_order(Y, max_order: int) -> OrderSelection:
    """AIC, BIC, HQ and FPE of VAR(p) without trend for p = 1..max_order.

    Every order is fitted by least squares on the same sample (the last
    T − max_order observations), as statsmodels' ``VAR.select_order(trend="n")``
    does, so the criteria are comparable.

    Parameters
    ----------
    Y : (T, d) array_like
        The (weakly stationary) series the VAR models; for poses, their second
        differences (:func:`handvar.predictors.second_differences`).
    max_order : int
        The largest order to try.

    Returns
    -------
    OrderSelection
    """
    Y = as_series(Y, "Y")
    T, d = Y.shape
    max_order = as_int(max_order, "max_order", minimum=1)
    if T - max_order <= max_order * d:
        raise ValueError(
            f"max_order: expected 1 <= max_order with more observations than "
            f"regressors (T - max_order > max_order * d = {max_order * d}); got "
            f"max_order={max_order} for T={T}"
        )
    nobs = T - max_order
    target = Y[max_order:]
    lagged = np.hstack([Y[max_order - lag : T - lag] for lag in range(1, max_order + 1)])
    out = {k: [] for k in ("aic", "bic", "hqic", "fpe")}
    for p in range(1, max_order + 1):
        Z = lagged[:, : p * d]
        coef, *_ = np.linalg.lstsq(Z, target, rcond=None)
        resid = target - Z @ coef
        sigma = resid.T @ resid / nobs  # maximum-likelihood residual covariance
        sign, logdet = np.linalg.slogdet(sigma)
        logdet = logdet if sign > 0 else -np.inf
        free = p * d * d
        out["aic"].append(logdet + 2.0 * free / nobs)
        out["bic"].append(logdet + np.log(nobs) * free / nobs)
        out["hqic"].append(logdet + 2.0 * np.log(np.log(nobs)) * free / nobs)
        df_model = p * d
        out["fpe"].append(((nobs + df_model) / (nobs - df_model)) ** d * np.exp(logdet))
    return OrderSelection(np.arange(1, max_order + 1), **{k: np.array(v) for k, v in out.items()})
