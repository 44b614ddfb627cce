"""Stochastic meta-descent (SMD), the tracker's optimiser (paper §4, §5).

SMD (Schraudolph 1999; Bray et al. 2007 for articulated tracking) is gradient descent
with one gain per parameter, adapted online from the correlation of successive
stochastic gradients. With g the gradient of a fresh stochastic cost at x and Gv a
curvature-vector product (Gauss–Newton, ``Jᵀ(J v)``), one step is::

    p ← p ⊙ max(½, 1 − μ g ⊙ v)          (gain adaptation)
    x ← clamp_to_limits(x − p ⊙ g)        (descent, projected onto the joint limits)
    v ← λ v − p ⊙ (g + λ Gv)              (v ≈ dx/d log p, v = 0 at the start of a frame)

With the paper's horizon λ = 0 the last line is ``v = −p ⊙ g`` and no curvature product
is needed. The iteration stops when the cost falls below a threshold or after a
maximum number of iterations (paper §4: 0.006 and 50).

Gains and units (``SMDSettings.precondition``)
----------------------------------------------
A gain multiplies a gradient with respect to mm or degrees, so its meaning depends on
the parametrisation and on the cost's unit, both of which differ from the paper's
(unpublished) ones. Measured on our cost, the diagonal of the Gauss–Newton matrix
JᵀJ spans four orders of magnitude over the 26 parameters (palm rotation about the
view axis most sensitive, distal finger joints least): with any single choice of
units the paper's raw gains either diverge on the palm or leave the fingers where they
started (SMD's multiplicative adaptation would need a 10⁴-fold growth, which the
50 iterations cannot give). We therefore run SMD in coordinates normalised by the
damped diagonal curvature h supplied with every gradient (a diagonal preconditioner
refreshed at every iteration, the step ``x ← x − (p / h) ⊙ g``) and keep
the paper's gains as the normalised gains: a gain of 1 is one full diagonal
Gauss–Newton step. The SMD rule itself is unchanged, since ``g ⊙ v`` is the same in
both coordinates. ``precondition=False`` runs the raw update with the gains in mm² and
deg² per unit of cost.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from handvar.params import GROUPS, LOWER, N_PARAMS, UPPER
from handvar.validate import as_float, as_instance, as_int

__all__ = [
    "SMDResult",
    "SMDSettings",
    "damped",
    "initial_gains",
    "minimise",
    "smd_step",
]


@dataclass(frozen=True)
class SMDSettings:
    """Settings of stochastic meta-descent, the paper's values (paper §4).

    Attributes
    ----------
    meta_gain : float
        μ, 0.1.
    horizon : float
        λ, 0 (v then only remembers the last step).
    gain_translation, gain_rotation, gain_finger : float
        Initial gains p of the palm translation (2.5), the palm rotation (0.4) and the
        abduction and flexion angles (0.2).
    threshold : float
        Stop when the cost falls below it, 0.006 (in the cost's unit).
    max_iterations : int
        Stop after this many cost evaluations, 50.
    min_factor : float
        The ½ of ``max(½, 1 − μ g v)``: a gain shrinks at most by this factor per step.
    max_factor : float
        A gain grows at most by this factor per step, 2 (our addition: the paper's
        rule has no upper bound, and on a diverging fit — a lost track — successive
        gradients stay aligned and the gains overflow).
    precondition : bool
        Read the gains as fractions of a diagonal Gauss–Newton step (module docstring);
        True by default (our addition, not in the paper).
    damping : float
        Relative floor of the diagonal curvature, ``h_i + damping · max h``: parameters
        the silhouettes hardly constrain (a hidden fingertip) get at most
        1 / damping times the step of the best constrained one.
    keypoint_stop : float
        The tracker's stopping test on frames with keypoints (design §14.2): stop once
        the cost without the keypoint term is below `threshold` and the keypoint term
        fell by less than this fraction in the last iteration, 0.01. Detector noise and
        outliers leave the keypoint term a floor that the threshold alone would never
        pass. Not used by `minimise` itself (the tracker passes it as ``stop=``).
    """

    meta_gain: float = 0.1
    horizon: float = 0.0
    gain_translation: float = 2.5
    gain_rotation: float = 0.4
    gain_finger: float = 0.2
    threshold: float = 0.006
    max_iterations: int = 50
    min_factor: float = 0.5
    max_factor: float = 2.0
    precondition: bool = True
    damping: float = 0.01
    keypoint_stop: float = 0.01

    def __post_init__(self) -> None:
        # checked, not converted: the settings keep the values (and repr) they were given
        for name in ("meta_gain", "threshold"):
            as_float(getattr(self, name), name, minimum=0)
        as_float(self.horizon, "horizon", minimum=0, maximum=1)
        for name in ("gain_translation", "gain_rotation", "gain_finger", "damping"):
            as_float(getattr(self, name), name, minimum=0, exclusive_minimum=True)
        as_int(self.max_iterations, "max_iterations", minimum=1)
        as_float(self.min_factor, "min_factor", minimum=0, maximum=1, exclusive_minimum=True)
        as_float(self.max_factor, "max_factor", minimum=1)
        as_float(self.keypoint_stop, "keypoint_stop", minimum=0, maximum=1)


def initial_gains(settings: SMDSettings | None = None) -> np.ndarray:
    """The (26,) initial gains p, per parameter group (`handvar.params.GROUPS`)."""
    s = SMDSettings() if settings is None else settings
    by_group = {
        "translation": s.gain_translation,
        "rotation": s.gain_rotation,
        "finger": s.gain_finger,
    }
    return np.array([by_group[g] for g in GROUPS])


def smd_step(
    x: np.ndarray,
    p: np.ndarray,
    v: np.ndarray,
    g: np.ndarray,
    Gv: np.ndarray | None = None,
    *,
    meta_gain: float = 0.1,
    horizon: float = 0.0,
    min_factor: float = 0.5,
    max_factor: float = np.inf,
    lower: np.ndarray | None = LOWER,
    upper: np.ndarray | None = UPPER,
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """One SMD update (module docstring), as a pure function.

    Parameters
    ----------
    x, p, v, g : (d,) ndarray
        Parameters, gains, the v vector and the stochastic gradient at x.
    Gv : (d,) ndarray, optional
        Curvature-vector product G v at x (only used when ``horizon > 0``).
    meta_gain, horizon, min_factor, max_factor : float, keyword-only
        μ, λ and the bounds of the gain factor (no upper bound by default).
    lower, upper : (d,) ndarray or None, keyword-only
        Box onto which x is projected (the hand's joint limits by default; None for
        none).

    Returns
    -------
    x, p, v : (d,) ndarray
        New arrays.

    Examples
    --------
    >>> x, p, v = smd_step(np.array([1.0]), np.array([0.5]), np.zeros(1), np.array([2.0]),
    ...                    lower=None, upper=None)
    >>> x, p, v
    (array([0.]), array([0.5]), array([-1.]))
    """
    factor = np.clip(1.0 - meta_gain * g * v, min_factor, max_factor)
    p = p * factor  # p ← p ⊙ max(½, 1 − μ g ⊙ v), growth bounded by max_factor
    x = x - p * g  # x ← x − p ⊙ g
    if lower is not None or upper is not None:
        x = np.clip(x, lower, upper)  # clamp to the joint limits
    if horizon > 0.0:
        if Gv is None:
            raise ValueError("Gv: expected a curvature-vector product when horizon > 0; got None")
        v = horizon * v - p * (g + horizon * Gv)  # v ← λ v − p ⊙ (g + λ G v)
    else:
        v = -p * g  # λ = 0
    return x, p, v


def damped(h: np.ndarray, damping: float) -> np.ndarray:
    """A diagonal curvature with a relative floor, ``h + damping · max h``.

    Parameters
    ----------
    h : (d,) ndarray
        Non-negative diagonal curvature (e.g. of the Gauss–Newton matrix JᵀJ).
    damping : float
        Relative floor (Levenberg style), so that parameters the residuals hardly
        constrain still get a bounded step.

    Returns
    -------
    (d,) ndarray
        Positive (ones when h is all zero).
    """
    top = float(h.max()) if h.size else 0.0
    if not top > 0.0:
        return np.ones_like(h)
    return h + damping * top


@dataclass(frozen=True, eq=False)
class SMDResult:
    """Outcome of one `minimise` run.

    Attributes
    ----------
    x : (d,) ndarray
        Final parameters.
    costs : (k,) ndarray
        Cost at each of the k evaluations (the last one is below the threshold when
        the run stopped on it).
    iterations : int
        Number of cost evaluations k.
    converged : bool
        True when the cost fell below the threshold.
    gains : (d,) ndarray
        Final gains, in x's units (after preconditioning).
    """

    x: np.ndarray
    costs: np.ndarray
    iterations: int
    converged: bool
    gains: np.ndarray


def minimise(
    objective: Callable,
    x0,
    settings: SMDSettings | None = None,
    *,
    gains: np.ndarray | None = None,
    lower: np.ndarray | None = LOWER,
    upper: np.ndarray | None = UPPER,
    project: Callable[[np.ndarray], np.ndarray] | None = None,
    stop: Callable[[float], bool] | None = None,
) -> SMDResult:
    """Minimise a stochastic objective by SMD from `x0`, with v = 0 at the start.

    Parameters
    ----------
    objective : callable
        ``objective(x, need_jacobian) -> (cost, g, J, h)`` with a fresh stochastic
        sample at every call: the cost (float), its gradient (d,), the residual
        Jacobian (R, d) with ``g = Jᵀ r`` when `need_jacobian` is true (may be None
        otherwise) and a diagonal curvature h (d,) for the preconditioner (or None: then
        ``diag(JᵀJ)`` is used). The Jacobian is asked for at the first call when
        preconditioning without h and at every call when ``horizon > 0`` (for
        ``Gv = Jᵀ(J v)``).
    x0 : (d,) array_like
        Start.
    settings : SMDSettings, optional
        The paper's by default.
    gains : (d,) ndarray, keyword-only, optional
        Initial gains (before preconditioning); `initial_gains(settings)` by default
        (for d = 26).
    lower, upper : (d,) ndarray or None, keyword-only
        Box constraints (the hand's joint limits by default).
    project : callable, keyword-only, optional
        ``project(x) -> x``, applied to the start and after every step before the box
        (the tracker keeps the palm in front of the cameras, `front_projection`).
    stop : callable, keyword-only, optional
        ``stop(cost) -> bool`` called after every evaluation in place of the test
        ``cost < threshold`` (the tracker's test with keypoints, design §14.2).

    Returns
    -------
    SMDResult
    """
    s = SMDSettings() if settings is None else as_instance(settings, SMDSettings, "settings")
    x = np.array(x0, dtype=float)
    if x.ndim != 1 or not np.all(np.isfinite(x)):
        raise ValueError(f"x0: expected a finite (d,) vector; got shape {x.shape}")
    if gains is None:
        if x.shape != (N_PARAMS,):
            raise ValueError(f"gains: expected gains for a ({x.shape[0]},) x0; got None")
        p = initial_gains(s)
    else:
        p = np.array(gains, dtype=float)
        if p.shape != x.shape or not np.all(p > 0):
            raise ValueError(f"gains: expected {x.shape} positive gains; got shape {p.shape}")
    if project is not None:
        x = np.asarray(project(x), dtype=float)
    if lower is not None or upper is not None:
        x = np.clip(x, lower, upper)
    v = np.zeros_like(x)
    costs = np.empty(s.max_iterations)
    converged = False
    supplies_h = False
    k = 0
    while k < s.max_iterations:
        need_jacobian = s.horizon > 0.0 or (s.precondition and not supplies_h)
        cost, g, J, h = objective(x, need_jacobian)
        supplies_h = h is not None
        g = np.asarray(g, dtype=float)
        costs[k] = cost
        k += 1
        if (cost < s.threshold) if stop is None else stop(cost):
            converged = True
            break
        if s.precondition:
            if h is None:
                h = np.einsum("ri,ri->i", np.asarray(J), np.asarray(J))
            scale = 1.0 / damped(np.asarray(h, dtype=float), s.damping)
        else:
            scale = 1.0
        Gv = np.asarray(J).T @ (np.asarray(J) @ v) if s.horizon > 0.0 else None  # Gv = Jᵀ(J v)
        # SMD on coordinates z = x ⊙ √h: g_z ⊙ v_z = g ⊙ v, step p ⊙ g_z ↔ (p / h) ⊙ g in x
        x, pe, v = smd_step(
            x, p * scale, v, g, Gv,
            meta_gain=s.meta_gain, horizon=s.horizon,
            min_factor=s.min_factor, max_factor=s.max_factor, lower=lower, upper=upper,
        )  # fmt: skip
        if project is not None:
            x = np.asarray(project(x), dtype=float)
            if lower is not None or upper is not None:
                x = np.clip(x, lower, upper)
        p = pe / scale
    return SMDResult(x, costs[:k].copy(), k, converged, p)
