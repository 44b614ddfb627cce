"""Levenberg–Marquardt refinement of a stochastic least-squares cost (design §14.2).

SMD (`handvar.tracking.smd`) takes one diagonally preconditioned step per fresh sample
and stops at the first iteration that passes its test, so the pose it returns is the
optimum blurred by the sampling noise of its last gradients and by the directions its
diagonal scaling ignores. On frames with keypoints the tracker then takes a few damped
Gauss–Newton steps on the cost C = ½ rᵀr, r the stacked residuals of every term
(`handvar.tracking.costs.CostTerms.residuals`)::

    A = JᵀJ,  g = Jᵀr                    (samples drawn for the step, matches held fixed)
    (A + λ D) δ = −g,   D = diag(A) + ε · max diag(A)           (Marquardt's scaling)
    x' = clamp(project(x + δ))                                (joint limits, front)

A step is taken when it lowers the cost on the samples it was computed from (λ ← λ/3);
otherwise λ ← 4λ and the step is solved again, at most `RefineSettings.max_tries` times.
The full 26 × 26 matrix couples the parameters that SMD's diagonal treats apart (the
palm's depth and tilt, a finger's flexions); the floor ε bounds the step along a
direction that no residual constrains (a finger's flexion towards a single camera), so
that the refinement does not jump to the other branch of an ambiguity that SMD and the
motion prediction had settled.

The refinement's cost is the tracker's with three changes (`RefineSettings`): more
samples per step, and C_k with Tukey's redescending loss and a lower weight. SMD keeps
Huber's loss and w_k = 100: from a prediction that may be far off, a convex loss and a
strong pull bring a finger back into the basin; there, a detection more than c = 0.2
hand sizes off is a wrong one, and Tukey's loss drops it where Huber's still pulls with
force δ; w_k = 10 leaves the silhouettes, exact where they see a part, to place it, and
the keypoints to settle what they leave open. With the residuals of C_k in IRLS form
(r = a β(d) e, `handvar.tracking.keypoint_cost`) the steps are Gauss–Newton steps of the
robust cost.

The paper has no such step; the tracker runs it only on frames with keypoints, so
tracking without keypoints is the paper's.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
from numba import njit

from handvar.params import LOWER, UPPER
from handvar.tracking.keypoint_cost import LOSSES
from handvar.validate import as_float, as_instance, as_int, one_of

__all__ = ["RefineResult", "RefineSettings", "lm_step", "normal_equations", "refine"]


@dataclass(frozen=True)
class RefineSettings:
    """Settings of `refine` (design §14.2; not in the paper).

    Attributes
    ----------
    steps : int
        Gauss–Newton steps, 2; 0 turns the refinement off.
    damping : float
        λ of the first step, 0.1.
    max_tries : int
        Solves per step before it is given up (λ grows 4× per try), 4.
    floor : float
        ε of D = diag(A) + ε · max diag(A), 0.01: the damping of a parameter that no
        residual moves is at least λ ε times the curvature of the best constrained one.
    samples : int
        The tracker draws this many times the cost's surface and silhouette samples
        (`CostSettings.n_surface`, `n_pixels`) for each step, 2: fewer random residuals
        blur the optimum less.
    resample : bool
        Fresh samples for every step (True); False keeps the first step's samples, so
        that a taken step's evaluation serves as the next step's linearisation.
    keypoint_loss : {"huber", "tukey"}
        C_k's loss in the refinement's cost (`CostSettings.keypoint_loss`), "tukey".
    keypoint_scale : float
        Its scale (Tukey's c), hand sizes, 0.2.
    weight_keypoints : float
        w_k in the refinement's cost, 10.
    """

    steps: int = 2
    damping: float = 0.1
    max_tries: int = 4
    floor: float = 0.01
    samples: int = 2
    resample: bool = True
    keypoint_loss: str = "tukey"
    keypoint_scale: float = 0.2
    weight_keypoints: float = 10.0

    def __post_init__(self) -> None:
        as_int(self.steps, "steps", minimum=0)
        as_float(self.damping, "damping", minimum=0.0, exclusive_minimum=True)
        as_int(self.max_tries, "max_tries", minimum=1)
        as_float(self.floor, "floor", minimum=0.0, exclusive_minimum=True)
        as_int(self.samples, "samples", minimum=1)
        as_instance(self.resample, bool, "resample")
        one_of(self.keypoint_loss, LOSSES, "keypoint_loss")
        as_float(self.keypoint_scale, "keypoint_scale", minimum=0.0, exclusive_minimum=True)
        as_float(self.weight_keypoints, "weight_keypoints", minimum=0.0)


@dataclass(frozen=True, eq=False)
class RefineResult:
    """Outcome of `refine`.

    Attributes
    ----------
    x : (d,) ndarray
        Final parameters.
    costs : (k,) ndarray
        The cost at the start of every step, on that step's samples.
    evaluations : int
        Cost evaluations in all (with and without the Jacobian).
    accepted : int
        Steps taken.
    """

    x: np.ndarray
    costs: np.ndarray
    evaluations: int
    accepted: int


@njit(cache=True)
def normal_equations(r: np.ndarray, J: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """JᵀJ (d, d) and Jᵀr (d,), skipping the rows of J that are zero.

    Compiled rather than ``J.T @ J``: for these small products a multi-threaded BLAS
    spends more time synchronising its threads than computing, and most rows of the
    silhouette terms are zero (samples that fit).
    """
    d = J.shape[1]
    A = np.zeros((d, d))
    g = np.zeros(d)
    for i in range(J.shape[0]):
        row = J[i]
        nonzero = False
        for a in range(d):
            if row[a] != 0.0:
                nonzero = True
                break
        if not nonzero:
            continue
        for a in range(d):
            ja = row[a]
            if ja == 0.0:
                continue
            g[a] += ja * r[i]
            for b in range(a, d):
                A[a, b] += ja * row[b]
    for a in range(d):
        for b in range(a):
            A[a, b] = A[b, a]
    return A, g


def lm_step(r: np.ndarray, J: np.ndarray, lam: float, floor: float = 1e-6) -> np.ndarray:
    """The damped Gauss–Newton step δ of ½|r|², ``(JᵀJ + λ D) δ = −Jᵀr`` (module docstring).

    Parameters
    ----------
    r : (R,) ndarray
        Residuals.
    J : (R, d) ndarray
        Their Jacobian.
    lam : float
        λ.
    floor : float
        ε of D = diag(JᵀJ) + ε · max diag(JᵀJ).

    Returns
    -------
    (d,) ndarray

    Examples
    --------
    >>> J = np.array([[2.0, 0.0], [0.0, 1.0]]); r = np.array([4.0, -1.0])
    >>> lm_step(r, J, 1e-12)
    array([-2.,  1.])
    """
    A, g = normal_equations(np.ascontiguousarray(r, dtype=float),
                            np.ascontiguousarray(J, dtype=float))  # fmt: skip
    return _damped_solve(A, g, lam, floor)


def _damped_solve(A: np.ndarray, g: np.ndarray, lam: float, floor: float) -> np.ndarray:
    """δ of ``(A + λ D) δ = −g``, D = diag(A) + ε · max diag(A) (ε = `floor`)."""
    h = np.diag(A).copy()
    top = float(h.max()) if h.size else 0.0
    D = h + floor * (top if top > 0.0 else 1.0)
    return np.linalg.solve(A + lam * np.diag(D), -g)


def refine(
    draw: Callable[[], Callable[[np.ndarray, bool], tuple]],
    x0,
    settings: RefineSettings | None = None,
    *,
    lower: np.ndarray | None = LOWER,
    upper: np.ndarray | None = UPPER,
    project: Callable[[np.ndarray], np.ndarray] | None = None,
) -> RefineResult:
    """Refine `x0` by damped Gauss–Newton steps on a stochastic cost (module docstring).

    Parameters
    ----------
    draw : callable
        ``draw() -> f`` with fresh samples; ``f(x, jacobian) -> (cost, r, J)`` evaluates
        the cost on those samples at x, with the residuals r (R,) and their Jacobian
        (R, d) when `jacobian` is true (None otherwise), ``cost = ½ rᵀr``.
    x0 : (d,) array_like
        Start.
    settings : RefineSettings, optional
    lower, upper : (d,) ndarray or None, keyword-only
        Box the steps are clamped to (the joint limits by default).
    project : callable, keyword-only, optional
        ``project(x) -> x`` applied to every candidate before the box (the tracker's
        front projection).

    Returns
    -------
    RefineResult

    Examples
    --------
    >>> A = np.array([[3.0, 1.0], [1.0, 2.0]]); b = np.array([1.0, 4.0])
    >>> def draw():
    ...     return lambda x, jac: (0.5 * np.sum((A @ x - b) ** 2), A @ x - b, A)
    >>> res = refine(draw, np.zeros(2), RefineSettings(steps=10), lower=None, upper=None)
    >>> np.allclose(res.x, np.linalg.solve(A, b), atol=1e-6)
    True
    """
    s = RefineSettings() if settings is None else as_instance(settings, RefineSettings, "settings")
    x = np.array(x0, dtype=float)
    if x.ndim != 1 or not np.all(np.isfinite(x)):
        raise ValueError(f"x0: expected a finite (d,) vector; got shape {x.shape}")

    def admissible(z):
        if project is not None:
            z = np.asarray(project(z), dtype=float)
        if lower is not None or upper is not None:
            z = np.clip(z, lower, upper)
        return z

    lam = s.damping
    costs = np.empty(s.steps)
    f = draw()
    cost, r, J = f(x, True)
    evaluations, accepted = 1, 0
    for k in range(s.steps):
        costs[k] = cost
        # JᵀJ and Jᵀr once per step: a rejected try changes only λ
        A, g = normal_equations(np.ascontiguousarray(r, dtype=float),
                                np.ascontiguousarray(J, dtype=float))  # fmt: skip
        for _ in range(s.max_tries):
            candidate = admissible(x + _damped_solve(A, g, lam, s.floor))
            c_new, r_new, J_new = f(candidate, not s.resample)
            evaluations += 1
            if c_new < cost:
                x, cost, r, J = candidate, c_new, r_new, J_new
                accepted += 1
                lam = max(lam / 3.0, 1e-12)
                break
            lam *= 4.0
        if s.resample and k + 1 < s.steps:
            f = draw()
            cost, r, J = f(x, True)
            evaluations += 1
    return RefineResult(x, costs, evaluations, accepted)
