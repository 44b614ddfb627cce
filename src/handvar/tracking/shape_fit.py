"""The hand's own proportions from the first frames with keypoints (docs/keypoint-fit.md).

A model hand made with the published average proportions (`HandShape.from_size`)
cannot reach every point a detector marks on a particular person's hand: its fingers
may be longer or shorter, its palm longer.  `fit_shape` adapts, from several frames'
keypoints at once, a few factors of the shape

    θ = (log s, log p, log f_thumb, log f_index, log f_middle, log f_ring, log f_little)

(`adapt_shape`): s scales the whole hand, p the palm along the hand (the distance of
the digits' base joints from the wrist), f_d the three bones of digit d.  With several
cameras the keypoints are triangulated, and the person's hand is fitted in detail: 25
factors more (`DETAIL_FACTORS`), each bone's length b_dl and each digit base's position
across (a_d) and along (p_d) the palm on top of the seven, with a prior of σ_detail
(`ShapeFitSettings.detail`), so that the model's joints can go where the detector marks
that person's joints.  The N frames' poses and θ minimise together

    Σ_frames E_frame(x_n; θ)  +  ½ |θ / σ_θ|²

with E_frame the keypoint-first fit's robust reprojection terms (and the detector's 3D
where given, `handvar.tracking.frame_fit`), each pose within the joint limits, and a
prior on θ of σ_θ (`ShapeFitSettings.spread`, the spread of the published proportions
between adults).  One camera cannot tell a large hand far away from a small one near:
there s is not fitted and the hand keeps its given length (wrist to middle fingertip);
a stereo rig fits it too.  The detector's 3D (MediaPipe's world landmarks, at the size
of its own average hand) shapes the proportions but does not set s.

It is solved by Levenberg–Marquardt on the stacked problem (the poses' blocks
eliminated by their Schur complement): the poses' Jacobians are exact
(`keypoint_points`), θ's by forward differences (seven shapes per step).  The
shape found is held fixed for the rest of the track.
"""

from __future__ import annotations

import copy
import dataclasses
from dataclasses import dataclass

import numpy as np

from handvar.hand.anthropometry import HandShape
from handvar.params import LOWER, N_PARAMS, UPPER
from handvar.tracking.frame_fit import (
    FRAME_FIT_DEFAULTS,
    FrameFitSettings,
    _clean,
    _Problem,
    fit_frame,
)
from handvar.validate import as_float, as_int

__all__ = [
    "DETAIL_FACTORS",
    "SHAPE_FIT_DEFAULTS",
    "ShapeFit",
    "ShapeFitSettings",
    "adapt_shape",
    "fit_shape",
]

#: Names of the factors θ, in order.
FACTORS = ("scale", "palm", "thumb", "index", "middle", "ring", "little")
_N = len(FACTORS)
_DIGITS = FACTORS[2:]
#: The detail factors fitted with several cameras, after `FACTORS`: each bone's length,
#: each digit base's position across (x, and the thumb's z) and along (y) the palm.
DETAIL_FACTORS = (
    *(f"{d}_{bone}" for d in _DIGITS for bone in ("proximal", "middle", "distal")),
    *(f"{d}_base_across" for d in _DIGITS),
    *(f"{d}_base_along" for d in _DIGITS),
)


@dataclass(frozen=True)
class ShapeFitSettings:
    """Settings of `fit_shape` (chosen on the realistic benchmark, docs/keypoint-fit.md).

    Attributes
    ----------
    frames : int
        How many frames with keypoints the shape is fitted to; 12 (under half a second
        of a recording: the first frames, where a track starts).
    stride : int
        Of the first frames with keypoints, every `stride`-th is one of them, the frames
        between fitted again with the shape found; 1 (consecutive frames).  From one
        camera a digit shorter than the model's looks like one turned towards it, and
        consecutive frames hardly tell them apart; a larger stride waits for poses
        further apart (docs/keypoint-fit.md, "the hand's own proportions": measured,
        not the default).
    spread : float
        σ_θ of the prior on the log factors; 0.08 (the spread of bone lengths between
        adults relative to hand length is about 5-8 %, Buchholz et al. 1992).
    bound : float
        |log factor| at most; 0.3 (a bone 35 % longer or 26 % shorter than the average
        proportions give).
    iterations : int
        Levenberg–Marquardt steps at most; 8.
    min_points : int
        A frame takes part when at least this many keypoints are present in one
        camera; 18.
    detail : float
        σ of the prior on the `DETAIL_FACTORS`' logs, fitted with several cameras;
        0.04 (half the spread: a person's knuckles keep their arch and a digit's bones
        their ratios more closely than hands differ in size).  0 leaves them out.
    """

    frames: int = 12
    stride: int = 1
    spread: float = 0.08
    bound: float = 0.3
    iterations: int = 8
    min_points: int = 18
    detail: float = 0.04

    def __post_init__(self) -> None:
        as_int(self.frames, "frames", minimum=1)
        as_int(self.stride, "stride", minimum=1)
        as_float(self.spread, "spread", minimum=0.0, exclusive_minimum=True)
        as_float(self.bound, "bound", minimum=0.0, exclusive_minimum=True)
        as_int(self.iterations, "iterations", minimum=1)
        as_int(self.min_points, "min_points", minimum=1)
        as_float(self.detail, "detail", minimum=0.0)


SHAPE_FIT_DEFAULTS = ShapeFitSettings()


@dataclass(frozen=True, eq=False)
class ShapeFit:
    """The result of `fit_shape`.

    Attributes
    ----------
    shape : HandShape
        The adapted shape.
    factors : (7,) or (32,) ndarray
        s, p and the five digits' f (`FACTORS`; not logarithms), then the
        `DETAIL_FACTORS` where they were fitted.
    poses : (N, 26) ndarray
        The frames' poses fitted with it.
    metric : bool
        Whether s was fitted (a stereo rig) or kept the given hand length.
    """

    shape: HandShape
    factors: np.ndarray
    poses: np.ndarray
    metric: bool


def _wrist_to_tip(shape: HandShape) -> float:
    return float(shape.bases[2, 1] + shape.segments[2].sum())


def adapt_shape(shape: HandShape, factors) -> HandShape:
    """`shape` with its digits' bones scaled by f_d, its palm along the hand by p and
    the whole by s (module notes); radii unchanged except by s.

    Parameters
    ----------
    shape : HandShape
    factors : (7,) or (32,) array_like
        s, p, f_thumb … f_little (`FACTORS`), positive; then optionally the
        `DETAIL_FACTORS` (each bone's length, each digit base across and along the
        palm).

    Examples
    --------
    >>> base = HandShape.from_size(185.0)
    >>> s = adapt_shape(base, [1.0, 1.0, 1.0, 1.1, 1.0, 1.0, 1.0])
    >>> round(float(s.segments[1].sum() / base.segments[1].sum()), 3)
    1.1
    """
    f = np.asarray(factors, dtype=float)
    n_all = _N + len(DETAIL_FACTORS)
    if f.shape not in ((_N,), (n_all,)) or not np.all(np.isfinite(f)) or np.any(f <= 0):
        raise ValueError(f"factors: expected {_N} or {n_all} positive numbers; got {f!r}")
    s, p, digits = f[0], f[1], f[2:_N]
    along = np.array([1.0, p, 1.0])
    segments = s * shape.segments * digits[:, None]
    bases = s * shape.bases * along
    if len(f) == n_all:
        segments = segments * f[_N : _N + 15].reshape(5, 3)
        across, lengthwise = f[_N + 15 : _N + 20], f[_N + 20 :]
        bases = bases * np.stack([across, lengthwise, across], axis=1)
    # the hand length follows the wrist → middle-fingertip distance
    tip = (bases[2, 1] + segments[2].sum()) / (shape.bases[2, 1] + shape.segments[2].sum())
    return dataclasses.replace(
        shape,
        segments=segments,
        bases=bases,
        radii=s * shape.radii,
        palm_centres=s * shape.palm_centres * along,
        palm_radii=s * shape.palm_radii,
        length=tip * shape.length,
        breadth=s * shape.breadth,
    )


def _shape_of(base: HandShape, theta: np.ndarray, metric: bool) -> HandShape:
    f = np.exp(theta)
    if not metric:  # keep the given wrist → middle-tip length: p B + f_middle S at s = 1
        palm, middle = base.bases[2, 1], base.segments[2].sum()
        f[0] = _wrist_to_tip(base) / (f[1] * palm + f[4] * middle)
    return adapt_shape(base, f)


def fit_shape(
    keypoints,
    rig,
    hand,
    poses,
    *,
    world=None,
    settings: ShapeFitSettings = SHAPE_FIT_DEFAULTS,
    frame_settings: FrameFitSettings = FRAME_FIT_DEFAULTS,
) -> ShapeFit:
    """Fit the hand's proportions and the frames' poses to several frames' keypoints.

    Parameters
    ----------
    keypoints : sequence of (sequence of (21, 3) array_like or None)
        Per frame, per camera: x, y (pixels), confidence.
    rig : Rig
    hand : HandModel
        The model whose shape is adapted (its surface kind is kept).
    poses : (N, 26) array_like
        Starting poses of the frames (e.g. the keypoint-first fit's).
    world : sequence of (21, 3) array_like or None, keyword-only, optional
        Per frame the detector's 3D joints (as `fit_frame`'s ``world``).
    settings : ShapeFitSettings, keyword-only
    frame_settings : FrameFitSettings, keyword-only
        The residuals' settings (noise, Huber scale, tips).

    Returns
    -------
    ShapeFit
    """
    from handvar.hand import HandModel

    poses = np.array(poses, dtype=float)
    n = len(poses)
    if poses.shape != (n, N_PARAMS) or n != len(keypoints) or n == 0:
        raise ValueError(
            f"poses: expected ({len(keypoints)}, {N_PARAMS}) poses, one per frame of "
            f"keypoints; got shape {poses.shape}"
        )
    worlds = [None] * n if world is None else list(world)
    # The detector's 3D shapes the proportions but does not set the scale: MediaPipe's
    # world landmarks come at the size of its own average hand (docs/keypoint-fit.md).
    metric = len(rig) > 1
    n_theta = _N + (len(DETAIL_FACTORS) if metric and settings.detail > 0 else 0)
    sigma = np.r_[np.full(_N, settings.spread), np.full(n_theta - _N, settings.detail)]
    base = hand.shape
    kps = [_clean(k, len(rig), frame_settings.min_confidence) for k in keypoints]
    s = dataclasses.replace(frame_settings, iterations=1, polish=0)

    def make(theta):
        return HandModel(_shape_of(base, theta, metric), surface=hand.surface)

    def problems(model, x):
        out = [_Problem(model, rig, k, None, None, w, s, xi) for k, w, xi in
               zip(kps, worlds, x, strict=True)]  # fmt: skip
        return out

    ref = problems(hand, poses)  # hand sizes held at the starting poses

    def residuals(theta, x, jacobian):
        model = make(theta)
        rs, js = [], []
        for P0, xi in zip(ref, x, strict=True):
            P = copy.copy(P0)  # the same keypoints and hand sizes, the new model
            P.hand = model
            r, J = P.rows(xi, jacobian=jacobian)
            rs.append(r)
            js.append(J)
        return rs, js

    def cost(theta, x):
        rs, _ = residuals(theta, x, False)
        fit = sum(float(r @ r) for r in rs)
        prior = (theta / sigma)[int(not metric) :]
        return 0.5 * fit + 0.5 * float(prior @ prior)

    theta = np.zeros(n_theta)
    x = poses.copy()
    lam, h = 1e-3, 1e-5
    current = cost(theta, x)
    for _ in range(settings.iterations):
        rs, js = residuals(theta, x, True)
        sizes = [len(r) for r in rs]
        # d r / d θ by forward differences, every frame at once
        Jt = np.zeros((sum(sizes), n_theta))
        r0 = np.concatenate(rs)
        for a in range(n_theta):
            if a == 0 and not metric:
                continue
            e = np.zeros(n_theta)
            e[a] = h
            plus, _ = residuals(theta + e, x, False)
            Jt[:, a] = (np.concatenate(plus) - r0) / h
        # the normal equations: a 26 x 26 block per frame, θ's block, their coupling
        B = np.zeros((n, N_PARAMS, N_PARAMS))
        C = np.zeros((n, N_PARAMS, n_theta))
        gx = np.zeros((n, N_PARAMS))
        D = np.diag(1.0 / sigma**2)
        gt = D @ theta
        row = 0
        for i, (r, J) in enumerate(zip(rs, js, strict=True)):
            Ji = Jt[row : row + len(r)]
            B[i], C[i], gx[i] = J.T @ J, J.T @ Ji, J.T @ r
            D = D + Ji.T @ Ji
            gt = gt + Ji.T @ r
            row += len(r)
        free = np.ones(n_theta, dtype=bool)
        free[0] = metric  # one camera without 3D: s is not a free factor
        improved = False
        for _ in range(6):
            dx, dt = _schur_step(B, C, D, gx, gt, lam, free)
            x2 = np.clip(x + dx, LOWER, UPPER)
            t2 = np.clip(theta + dt, -settings.bound, settings.bound)
            c2 = cost(t2, x2)
            if c2 < current:
                improved = True
                break
            lam *= 10.0
        if not improved:
            break
        rel = (current - c2) / max(current, 1e-12)
        theta, x, current = t2, x2, c2
        lam = max(lam / 10.0, 1e-7)
        if rel < 1e-4:
            break
    shape = _shape_of(base, theta, metric)
    factors = np.exp(theta)
    factors[0] = shape.breadth / base.breadth  # s
    model = HandModel(shape, surface=hand.surface)
    x = np.stack([fit_frame(k, rig, model, xi, world=w, settings=frame_settings).pose
                  for k, xi, w in zip(keypoints, x, worlds, strict=True)])  # fmt: skip
    return ShapeFit(shape, factors, x, metric)


def _schur_step(B, C, D, gx, gt, lam, free):
    """The damped Gauss–Newton step of the stacked problem by the Schur complement of
    the poses' blocks: (n, 26) pose steps and the (7,) θ step (0 where not free)."""
    n = len(B)
    Bd = B + lam * np.maximum(np.einsum("nii->ni", B), 1e-9)[:, :, None] * np.eye(N_PARAMS)
    Dd = D + lam * np.diag(np.maximum(np.diag(D), 1e-9))
    Binv_C = np.linalg.solve(Bd, C)
    Binv_g = np.linalg.solve(Bd, gx[:, :, None])[:, :, 0]
    S = Dd - np.einsum("nip,niq->pq", C, Binv_C)
    rhs = -gt + np.einsum("nip,ni->p", C, Binv_g)
    dt = np.zeros(len(D))
    dt[free] = np.linalg.solve(S[np.ix_(free, free)], rhs[free])
    dx = -Binv_g - np.einsum("nip,p->ni", Binv_C, dt)
    return dx.reshape(n, N_PARAMS), dt
