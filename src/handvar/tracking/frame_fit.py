"""The keypoint-first fit of one frame (design: docs/keypoint-fit.md).

On a frame with 2D keypoints (detected, or carried by optical flow), the keypoints are
the primary observation and the pose x (26 parameters, `handvar.params`) minimises

    E(x) = Σ_j Σ_i c_ij ρ(d_ij(x) / σ_k)  +  Σ_p ((x_p − x̂_p) / σ_p)²
           + Σ_i |(W(x)_i − W(x)_0) − (w_i − w_0)|² / σ_w²          (only with w given)
           + Σ_j Σ_a ρ_s(|π_j(A_a(x)) − q_ja| / s_j) / σ_s²           (only with σ_s > 0)

within the joint limits, where

- d_ij = |π_j(G_i(x)) − k_ij| / s_j is the distance of joint i's projection in camera j
  to its keypoint, in hand sizes (s_j: the model's wrist → middle-MCP length seen in
  camera j, `hand_size_px`), c_ij the keypoint's confidence, σ_k the detector's noise
  (`FrameFitSettings.noise`, hand sizes) and ρ Huber's loss of scale
  `FrameFitSettings.huber` (quadratic for small d, linear beyond: a gross error pulls
  with a bounded force);
- x̂ is the motion predictor's prediction and σ_p its recent accuracy per parameter
  group (`PriorScale`): the temporal prior (paper §3's predictor, here a residual
  rather than only the starting point); its weight follows how well the predictor
  predicted the last frames;
- W(x) are the joints and w the detector's own 3D joints (MediaPipe's world landmarks,
  metric), both relative to the wrist, σ_w their noise (`FrameFitSettings.world_noise`,
  three times larger where a second camera's keypoints give the depth):
  a weak cue, used only when the detector gives it.  The detector infers w from a crop
  around the hand, so w is the hand as a camera looking straight at the crop sees it:
  it is turned into the first camera's axes, from the ray through the palm's keypoints
  onto the optical axis (`handvar.vision.keypoints.world_in_camera`; on a hand at the
  border of a wide image the two differ by tens of degrees), and W(x) is taken in the
  first camera's axes;
- A_a(x) are points on the skeleton's 20 bones (a quarter, half and three quarters
  along each, `AXIS_POINTS`), q_ja the silhouette pixel of camera j nearest to A_a's
  projection (the labelled distance transform of `handvar.tracking.costs.prepare_frame`,
  held fixed within a step as in the paper's C_s), σ_s = `FrameFitSettings.silhouette`
  and ρ_s Tukey's biweight of scale c = `FrameFitSettings.silhouette_scale`: the
  silhouette as a secondary cue, off by default (docs/keypoint-fit.md, "the silhouette
  term").  A point inside the silhouette costs nothing, so skin where the model is not
  (a forearm, another hand, a face) never pulls; a bone point off the silhouette is
  pulled back, and one farther than c (a hole, a finger the segmentation missed) not
  at all.  A camera whose silhouette disagrees with its keypoints (fewer than 90 % of
  them within 0.1 hand sizes of it: the segmentation found something else) has no
  silhouette rows in that frame.

Where two or more cameras see joint i, their keypoints' errors are not independent:
a learned detector marks a joint at nearly the same place on the hand from both
sides.  The rows a_i = (√c_ij β(d_ij) e_ij / σ_k)_j of the joint's views are taken as
Gaussian with covariance Σ_i = (1 − ρ) I + σ_o² P_i P_iᵀ: a 3D offset of the joint
that all its views share (P_i: their projections' Jacobians with respect to the
joint, in the rows' units, at the starting pose; σ_o² such that the offset makes the
share ρ = `FrameFitSettings.view_correlation` of a view's variance on average) plus
a part each view has alone.  They enter E as ½ a_iᵀ Σ_i⁻¹ a_i (rows L_i⁻¹ a_i,
Σ_i = L_i L_iᵀ): the views' disagreement, the depth, weighs more than either view's
point.  Only where the views agree (the joint placed in 3D by one linear step from the
model's reprojects within σ_k of its keypoint in every view); a joint whose views
disagree (a gross error in one) keeps its independent rows, so that Huber's loss and
the rejection act view by view.

E is minimised by Levenberg–Marquardt on the exact Jacobians of G(x)
(`handvar.tracking.keypoint_cost.keypoint_points`) and of the projection
(`handvar.camera.Camera.project_jacobian`), Huber's loss by iteratively
reweighted least squares, each step projected onto the joint limits.  The keypoint rows
of a camera without lens distortion, the 3D joints' rows and the damped step are
compiled loops (numba): the same rows to rounding in one pass each, where the general
route costs a dozen small array operations per call (the tests check them against the
camera's own projection and finite differences).  A keypoint still
farther than `FrameFitSettings.reject` hand sizes from its joint at convergence is
*rejected*: it gets weight 0 and the fit takes a few more steps without it; the number
of rejected keypoints is reported per frame (`FrameFit.rejected`).

`reinitialise` starts the same fit from the perspective-n-point palm poses of the
frame's keypoints (`handvar.tracking.keypoint_fit.palm_candidates`), without a prior:
a direct re-initialisation with no grid search, and the first pose of `handvar init`
with keypoints.
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass

import numpy as np
from numba import njit

from handvar.hand.anthropometry import MIDDLE_MCP, WRIST
from handvar.params import LOWER, N_PARAMS, UPPER, clamp
from handvar.tracking.costs import FrameData
from handvar.tracking.keypoint_cost import TIPS, frame_keypoints, hand_length, keypoint_points
from handvar.validate import as_float, as_int, one_of
from handvar.vision.keypoints import world_in_camera

__all__ = [
    "AXIS_POINTS",
    "CHECK_THRESHOLD",
    "FRAME_FIT_DEFAULTS",
    "FrameFit",
    "FrameFitSettings",
    "PriorScale",
    "fit_frame",
    "hand_size_px",
    "honoured",
    "honoured_counts",
    "honoured_shares",
    "keypoint_distances",
    "reinitialise",
]

#: The keypoint check's distance, hand sizes (docs/keypoint-fit.md, "the check").
CHECK_THRESHOLD = 0.2


def _axis_points() -> np.ndarray:
    """(60, 21) weights of the silhouette term's points on the 21 joints (module notes)."""
    bones = [(0, 1 + 4 * d) for d in range(5)]
    bones += [(1 + 4 * d + k, 2 + 4 * d + k) for d in range(5) for k in range(3)]
    out = np.zeros((3 * len(bones), 21))
    for b, (i, j) in enumerate(bones):
        for a, t in enumerate((0.25, 0.5, 0.75)):
            out[3 * b + a, i], out[3 * b + a, j] = 1.0 - t, t
    out.flags.writeable = False
    return out


#: Points of the silhouette term: a quarter, half and three quarters along each of the
#: 20 bones between the 21 joints (wrist to each digit's base, then along the digit),
#: as (60, 21) weights on the joints.
AXIS_POINTS = _axis_points()

#: Parameter groups of the temporal prior: translation (mm), palm rotation, fingers (°).
_GROUPS = (slice(0, 3), slice(3, 6), slice(6, N_PARAMS))


@dataclass(frozen=True)
class FrameFitSettings:
    """Settings of the keypoint-first fit (module notes; chosen on the benchmarks with
    ground truth, docs/keypoint-fit.md).

    Attributes
    ----------
    noise : float
        σ_k, the detector's per-point noise, hand sizes; 0.05 (a detector's typical
        error on a hand of 100 px is about 5 px).
    huber : float
        Scale of the Huber loss on d, hand sizes; 0.1 (twice the noise: a point
        beyond pulls with a bounded force).
    reject : float
        A keypoint farther than this from its fitted joint, hand sizes, is rejected as
        an outlier; 0.25: five times the noise (a Gaussian error that far is one in
        10⁵), a quarter beyond the PCK@0.2 radius, so that the check of `honoured`
        (within 0.2 of the kept points) can still fail.
    world_noise : float
        σ_w, noise of the detector's 3D joints relative to the wrist, mm; 20.
    world_noise_seen_twice : float
        Factor on σ_w in a frame where two or more cameras have keypoints; 3.  The
        detector's 3D stands in for the depth one view cannot see; where a second view
        sees the hand its keypoints give the depth, and the learned 3D adds mostly its
        own bias.  Chosen among 1, 3 and ∞ (the 3D left out) on the realistic benchmark
        with the detector inside, its fast gestures and the still hands before a stereo
        pair; on the two-hand benchmark's stereo runs it costs 3D (docs/keypoint-fit.md,
        "the fit of one frame").
    view_correlation : float
        ρ, the share of the detector's error that a joint's views have alike (module
        notes); 0.9.  A learned detector looking at one hand from two cameras marks a
        joint at nearly the same place on the hand in both: MediaPipe's errors on the
        still hands before a stereo pair correlate at 0.85 across the rows and 0.96
        along them (`studies/stereo_shape.py`, its MediaPipe run), so the views'
        disagreement, the depth, is known better than either point.  Used by this fit
        and the shape fit.  Chosen among 0 (the views independent), 0.9, and 0.9 in
        this fit alone (0.7 tried on the fast gestures), on the still hands before a
        stereo pair, the realistic benchmark's stereo cases and fast gestures with the
        detector inside and the two-hand benchmark with two cameras
        (docs/keypoint-fit.md, "the fit of one frame"): the 3D error falls on all of
        them, the fast gestures' 2D to the detector's.  A detector whose views err
        independently (the benchmark's simulated one) would want 0.
    iterations : int
        Levenberg–Marquardt steps at most (before the outliers are dropped); 12.
    polish : int
        Steps after the outliers are dropped; 3.
    tolerance : float
        Stop when a step lowers E by less than this fraction; 1e-3.
    tips : {"end", "pad"}
        The model point a detected fingertip is compared with
        (`handvar.tracking.keypoint_cost.keypoint_attachment`).
    min_confidence : float
        Keypoints of lower confidence are left out; 0.05.
    silhouette : float
        σ_s of the silhouette term, hand sizes; 0 (the default): the silhouette is
        not a term of the fit (docs/keypoint-fit.md, "the silhouette term").
    silhouette_scale : float
        c of the silhouette term's Tukey loss, hand sizes; 0.15 (a bone point farther
        than this off the silhouette is not pulled at all).
    """

    noise: float = 0.05
    huber: float = 0.1
    reject: float = 0.25
    world_noise: float = 20.0
    world_noise_seen_twice: float = 3.0
    view_correlation: float = 0.9
    iterations: int = 12
    polish: int = 3
    tolerance: float = 1e-3
    tips: str = "end"
    min_confidence: float = 0.05
    silhouette: float = 0.0
    silhouette_scale: float = 0.15

    def __post_init__(self) -> None:
        as_float(self.noise, "noise", minimum=0.0, exclusive_minimum=True)
        as_float(self.reject, "reject", minimum=0.0, exclusive_minimum=True)
        as_float(self.world_noise, "world_noise", minimum=0.0, exclusive_minimum=True)
        as_float(self.world_noise_seen_twice, "world_noise_seen_twice", minimum=1.0)
        as_float(self.view_correlation, "view_correlation", minimum=0.0, maximum=0.99)
        as_int(self.iterations, "iterations", minimum=1)
        as_int(self.polish, "polish", minimum=0)
        one_of(self.tips, TIPS, "tips")
        as_float(self.min_confidence, "min_confidence", minimum=0.0, maximum=1.0)
        as_float(self.silhouette, "silhouette", minimum=0.0)
        as_float(self.silhouette_scale, "silhouette_scale", minimum=0.0, exclusive_minimum=True)


FRAME_FIT_DEFAULTS = FrameFitSettings()


@dataclass(frozen=True)
class PriorScale:
    """The temporal prior's σ per parameter group from the predictor's recent accuracy.

    σ_g² is an exponential moving average (rate `rate`) of the mean squared difference
    between the fitted pose and the prediction over group g (translation, palm
    rotation, finger angles), times `inflate`², floored at `floor` (mm, °, °).  Before
    any frame, σ is `initial`: a weak prior.  `update` returns the new scale.

    Attributes
    ----------
    sigma : (3,) tuple of float
        Current σ per group: mm, degrees, degrees.
    """

    sigma: tuple[float, float, float] = (50.0, 30.0, 30.0)
    rate: float = 0.2
    inflate: float = 2.0
    floor: tuple[float, float, float] = (3.0, 3.0, 5.0)

    def per_parameter(self) -> np.ndarray:
        """(26,) σ of every parameter."""
        out = np.empty(N_PARAMS)
        for g, s in zip(_GROUPS, self.sigma, strict=True):
            out[g] = s
        return out

    def update(self, fitted, predicted) -> PriorScale:
        """The scale after a frame fitted at `fitted` where `predicted` was predicted."""
        d = np.asarray(fitted, float) - np.asarray(predicted, float)
        if not np.all(np.isfinite(d)):
            return self
        new = []
        for g, s, lo in zip(_GROUPS, self.sigma, self.floor, strict=True):
            ms = float(np.mean(d[g] ** 2)) * self.inflate**2
            var = (1 - self.rate) * s * s + self.rate * ms
            new.append(max(lo, float(np.sqrt(var))))
        return PriorScale(tuple(new), self.rate, self.inflate, self.floor)


@dataclass(frozen=True, eq=False)
class FrameFit:
    """The result of `fit_frame`.

    Attributes
    ----------
    pose : (26,) ndarray
        mm and degrees.
    distances : (n_cams, 21) ndarray
        d_ij at the pose, hand sizes; NaN where no keypoint.
    rejected : (n_cams, 21) bool ndarray
        Keypoints rejected as outliers.
    cost : float
        E at the pose.
    iterations : int
        Levenberg–Marquardt steps taken.
    starts : int
        The fits started to find it: 1, or with `reinitialise` one per palm pose and
        finger posture.
    """

    pose: np.ndarray
    distances: np.ndarray
    rejected: np.ndarray
    cost: float
    iterations: int
    starts: int = 1

    @property
    def n_rejected(self) -> int:
        """Keypoints rejected in this frame."""
        return int(self.rejected.sum())

    @property
    def _kept(self) -> np.ndarray:
        """d_ij of the kept keypoints, flat."""
        return self.distances[~self.rejected & ~np.isnan(self.distances)]

    @property
    def error(self) -> float:
        """Mean d_ij over the kept keypoints, hand sizes (NaN if none)."""
        d = self._kept
        return float(d.mean()) if d.size else float("nan")

    @property
    def n_off(self) -> int:
        """Kept keypoints farther than the keypoint check's `CHECK_THRESHOLD` hand sizes."""
        return int(np.sum(self._kept > CHECK_THRESHOLD))

    @property
    def order(self) -> tuple[int, float]:
        """How two fits of one frame's keypoints compare, best lowest: fewer keypoints
        rejected or off (`n_off`), then closer (`error`).  Not by the cost: a fit that
        rejects a keypoint drops its row, so a fit that rejects more can cost less."""
        return (self.n_rejected + self.n_off, self.error)


def hand_size_px(hand, x, camera) -> float:
    """The model's wrist → middle-MCP length seen by `camera` at its palm depth, pixels."""
    G = hand.joints(x)
    z = camera.camera_from_world(0.5 * (G[WRIST] + G[MIDDLE_MCP])[None])[0, 2]
    return 0.5 * (camera.fx + camera.fy) * hand_length(hand) / max(float(z), 1.0)


def _clean(keypoints, n_cams: int, least: float) -> np.ndarray:
    """`frame_keypoints` (all zero when none), the points of confidence under `least`
    left out."""
    kp = frame_keypoints(keypoints, n_cams)
    if kp is None:
        return np.zeros((n_cams, 21, 3))
    kp[kp[:, :, 2] < least] = 0.0
    return kp


class _Problem:
    """Residual rows of E (module notes) and their Jacobian, for one frame.

    Each keypoint gives two rows r = √c β(d) e / σ_k, e the pixel error over the hand
    size s_j, with β(d)² = 2ρ(d)/d² of Huber's loss (scale `FrameFitSettings.huber`),
    so that ½|r|² = c ρ(d) / σ_k²; their Jacobian holds β at the current point (the
    iteratively reweighted Gauss–Newton step).  s_j is the model's hand size at the
    starting pose, held fixed in the frame: measured at the current pose it would
    reward moving the hand towards the camera (the errors shrink in hand sizes).
    Then the temporal prior's rows, the detector's 3D rows and the silhouette rows
    (two per bone point and camera whose silhouette agrees with its keypoints, Tukey's
    loss with its exact gradient).
    """

    def __init__(self, hand, rig, kp, prior, sigma, world, settings, start, silhouettes=None):
        self.hand, self.rig, self.kp, self.s = hand, rig, kp, settings
        self.prior, self.sigma = prior, sigma
        if prior is not None:
            self._prior_jacobian = np.diag(1.0 / sigma)
        self.world = None  # relative to its wrist, in the first camera's axes
        if world is not None:
            w = _world_in_first_camera(world, kp[0], rig.cameras[0])  # module notes
            ok = np.isfinite(w).all(axis=1)
            ok[WRIST] = False
            self.world = w - w[WRIST]
            self.world_points = np.flatnonzero(ok)  # the joints with a row
            seen = np.count_nonzero((kp[:, :, 2] > 0).any(axis=1))
            self.world_noise = settings.world_noise * (
                settings.world_noise_seen_twice if seen > 1 else 1.0
            )
        self.silhouettes = silhouettes if settings.silhouette > 0 else None
        self.sizes = np.array([hand_size_px(hand, start, cam) for cam in rig])
        self.present = [np.flatnonzero(k[:, 2] > 0) for k in kp]
        self.shared = self._shared_whitening(start) if settings.view_correlation > 0 else None
        if self.silhouettes is not None:
            self.agree = _agreeing_cameras(self.silhouettes, kp, self.sizes)
        self.R0 = rig.cameras[0].R

    def rows(self, x, jacobian: bool = True):
        """Residual rows r (½ rᵀr = E) and, with `jacobian`, their Jacobian J."""
        s = self.s
        if jacobian:
            G, JG = keypoint_points(self.hand, x, s.tips, jacobian=True)
        else:
            G, JG = keypoint_points(self.hand, x, s.tips), None
        rows, jac = [], []
        for j, cam in enumerate(self.rig):
            if self.present[j].size:
                self._keypoint_rows(j, cam, G, JG, rows, jac)
        if self.shared is not None:
            self._shared_rows(rows, jac)
        if self.silhouettes is not None:
            self._silhouette_rows(G, JG, rows, jac)
        if self.prior is not None:
            rows.append((x - self.prior) / self.sigma)
            if jacobian:
                jac.append(self._prior_jacobian)
        if self.world is not None:
            ok = self.world_points
            r = np.empty(3 * ok.size)
            J = np.empty((3 * ok.size, N_PARAMS)) if jacobian else _NO_ROWS
            _world_rows(G, _NO_JG if JG is None else JG, ok, self.R0, self.world,
                        self.world_noise, r, J, jacobian)  # fmt: skip
            rows.append(r)
            if jacobian:
                jac.append(J)
        r = np.concatenate(rows) if rows else np.zeros(0)
        if not jacobian:
            return r, None
        return r, (np.concatenate(jac) if jac else np.zeros((0, N_PARAMS)))

    def _keypoint_rows(self, j, cam, G, JG, rows, jac) -> None:
        """Append camera j's keypoint rows at joints G (Jacobian JG, or None)."""
        s, ok, jacobian = self.s, self.present[j], JG is not None
        if not cam.has_distortion:  # the same rows by compiled loops (module notes)
            r = np.empty(2 * ok.size)
            J = np.empty((2 * ok.size, N_PARAMS)) if jacobian else _NO_ROWS
            _keypoint_rows(G, JG if jacobian else _NO_JG, ok, cam.R, cam.t, cam.fx, cam.fy,
                           cam.cx, cam.cy, self.kp[j], self.sizes[j], s.huber, s.noise, r,
                           J, jacobian)  # fmt: skip
            rows.append(r)
            if jacobian:
                jac.append(J)
            return
        px, Jp = cam.project_jacobian(G[ok], jacobian=jacobian)
        e = (px - self.kp[j, ok, :2]) / self.sizes[j]
        d = np.sqrt((e**2).sum(axis=1))
        h = s.huber
        beta = np.where(d <= h, 1.0, np.sqrt(np.maximum(2.0 * h * (d - 0.5 * h), 0.0))
                        / np.maximum(d, 1e-12))  # fmt: skip
        w = (np.sqrt(self.kp[j, ok, 2]) * beta / s.noise)[:, None]
        rows.append((w * e).ravel())
        if jacobian:
            Je = np.einsum("nij,njp->nip", Jp, JG[ok]) / self.sizes[j]
            jac.append((w[:, :, None] * Je).reshape(-1, N_PARAMS))

    def _shared_whitening(self, start):
        """The (n', 21) mask of the points each camera with keypoints sees and the
        (21, 2n', 2n') whitening L⁻¹ of each point's rows over those n' cameras (module
        notes: errors alike in the views; the identity for a point seen once or whose
        views disagree); None where no point is seen twice.  P, the views' Jacobians
        with respect to the point, is taken at the starting pose and held in the frame,
        as the hand sizes are."""
        cams = [j for j, ok in enumerate(self.present) if ok.size]
        seen = np.zeros((len(cams), self.kp.shape[1]), dtype=bool)
        for c, j in enumerate(cams):
            seen[c, self.present[j]] = True
        multi = seen.sum(axis=0) > 1
        if not multi.any():
            return None
        G = keypoint_points(self.hand, start, self.s.tips)
        px, Jp = zip(*(self.rig.cameras[j].project_jacobian(G) for j in cams), strict=True)
        # P: a 3D offset of each point (mm) in row units (hand sizes over σ_k), per view
        scale = (self.sizes[cams] * self.s.noise)[:, None, None, None]
        P = np.stack(Jp) / scale
        b = (self.kp[cams, :, :2] - np.stack(px)) / scale[..., 0]  # (n, 21, 2)
        rho = self.s.view_correlation
        n = len(cams)
        W = np.tile(np.eye(2 * n), (G.shape[0], 1, 1))
        groups: dict[tuple, list[int]] = {}  # the points seen by the same cameras
        for i in np.flatnonzero(multi):
            groups.setdefault(tuple(np.flatnonzero(seen[:, i])), []).append(i)
        for views, points in groups.items():
            v, pts = np.array(views), np.array(points)
            Pi = P[v][:, pts].transpose(1, 0, 2, 3).reshape(len(pts), -1, 3)  # (k, 2m, 3)
            bi = b[v][:, pts].transpose(1, 0, 2).reshape(len(pts), -1)
            PT = Pi.transpose(0, 2, 1)
            # one linear step (damped a trifle: views from one centre do not place it)
            step = np.linalg.solve(PT @ Pi + 1e-9 * np.eye(3), PT @ bi[..., None])
            agree = np.abs(Pi @ step - bi[..., None]).max(axis=(1, 2)) <= 1.0
            if not agree.any():  # the views disagree: independent rows
                continue
            Pi, pts = Pi[agree], pts[agree]
            share = rho / np.mean(np.sum(Pi**2, axis=2), axis=1)
            cov = share[:, None, None] * Pi @ Pi.transpose(0, 2, 1) + (1.0 - rho) * np.eye(
                2 * v.size
            )
            idx = (2 * v[:, None] + np.arange(2)).ravel()
            W[np.ix_(pts, idx, idx)] = np.linalg.inv(np.linalg.cholesky(cov))
        return seen, W

    def _shared_rows(self, rows, jac) -> None:
        """The keypoint rows (one array per camera with keypoints, first in `rows` and
        `jac`) whitened for errors alike in the views: each point's rows over its
        cameras times L⁻¹ (module notes)."""
        seen, W = self.shared
        n, n_pts = seen.shape
        a = np.zeros((n_pts, n, 2))
        for c in range(n):
            a[seen[c], c] = rows[c].reshape(-1, 2)
        a = np.einsum("pij,pj->pi", W, a.reshape(n_pts, 2 * n)).reshape(n_pts, n, 2)
        for c in range(n):
            rows[c] = a[seen[c], c].ravel()
        if jac:
            Ja = np.zeros((n_pts, n, 2, N_PARAMS))
            for c in range(n):
                Ja[seen[c], c] = jac[c].reshape(-1, 2, N_PARAMS)
            Ja = np.einsum("pij,pjk->pik", W, Ja.reshape(n_pts, 2 * n, N_PARAMS))
            Ja = Ja.reshape(n_pts, n, 2, N_PARAMS)
            for c in range(n):
                jac[c] = Ja[seen[c], c].reshape(-1, N_PARAMS)

    def _silhouette_rows(self, G, JG, rows, jac) -> None:
        """Append the silhouette term's rows (module notes) at joints G (Jacobian JG)."""
        data, s = self.silhouettes, self.s
        A = AXIS_POINTS @ G
        JA = None if JG is None else np.einsum("ai,ipk->apk", AXIS_POINTS, JG)
        c = s.silhouette_scale
        for j, cam in enumerate(self.rig):
            if not self.agree[j]:
                continue
            px, Jp = cam.project_jacobian(A, jacobian=JG is not None)
            e = (px - _nearest_pixels(data, j, px)) / self.sizes[j]
            d = np.maximum(np.sqrt((e**2).sum(axis=1)), 1e-12)
            # Tukey's biweight ρ of scale c: r = α e with ½|r|² = ρ(d), and J = γ ∂e
            # with γ α = ρ'(d)/d, so that Jᵀr is ρ's gradient (0 beyond c)
            u = np.minimum((d / c) ** 2, 1.0)
            rho = c * c / 6.0 * (1.0 - (1.0 - u) ** 3)
            alpha = np.sqrt(2.0 * rho) / d
            rows.append(((alpha / s.silhouette)[:, None] * e).ravel())
            if JG is not None:
                # a point inside (e = 0) has no gradient and no curvature: a zero row
                gamma = np.where(d > 1e-12, (1.0 - u) ** 2 / np.maximum(alpha, 1e-12), 0.0)
                Je = np.einsum("nij,njp->nip", Jp, JA) / self.sizes[j]
                jac.append(((gamma / s.silhouette)[:, None, None] * Je).reshape(-1, N_PARAMS))

    def distances(self, x) -> np.ndarray:
        """d_ij at `x` (n_cams, 21) in hand sizes (the model's at `x`); NaN where none."""
        return _distances(self.hand, self.rig, self.kp, x, self.s.tips)


def _distances(hand, rig, kp, x, tips: str) -> np.ndarray:
    """d_ij at `x` (n_cams, 21) of keypoints `kp` (n_cams, 21, 3), in the model's hand
    sizes at `x`; NaN where there is no keypoint."""
    G = keypoint_points(hand, x, tips)
    d = np.full(kp.shape[:2], np.nan)
    for j, cam in enumerate(rig):
        ok = np.flatnonzero(kp[j, :, 2] > 0)
        if ok.size:
            px = cam.project(G[ok])
            d[j, ok] = np.linalg.norm(px - kp[j, ok, :2], axis=1) / hand_size_px(hand, x, cam)
    return d


def _world_in_first_camera(world, kp, camera) -> np.ndarray:
    """`world_in_camera` of the detector's 3D joints with `camera`'s keypoints `kp`
    (21, 3), kept for the next call with the same ones (a frame's fits share them)."""
    key = (world.tobytes(), kp.tobytes())
    cached = _WORLD_CACHE[0]
    if cached is not None and cached[0] is camera and cached[1] == key:
        return cached[2]
    w = world_in_camera(world, np.where(kp[:, 2:] > 0, kp[:, :2], np.nan), camera)
    w.flags.writeable = False
    _WORLD_CACHE[0] = (camera, key, w)
    return w


_WORLD_CACHE: list = [None]  # (camera, (world bytes, keypoint bytes), result)

_NO_ROWS, _NO_JG = np.empty((0, N_PARAMS)), np.empty((0, 3, N_PARAMS))


@njit(cache=True)
def _keypoint_rows(G, JG, ok, R, t, fx, fy, cx, cy, kp, size, huber, noise, r, J, jacobian):
    """The keypoint rows of one camera without lens distortion into `r` (2n,) and,
    with `jacobian`, their Jacobian into `J` (2n, 26): the rows of `_Problem.rows`'
    general route (`Camera.project_jacobian`) to rounding, in one pass over the n
    points `ok`."""
    for m in range(ok.shape[0]):
        n = ok[m]
        X = R[0, 0] * G[n, 0] + R[0, 1] * G[n, 1] + R[0, 2] * G[n, 2] + t[0]
        Y = R[1, 0] * G[n, 0] + R[1, 1] * G[n, 1] + R[1, 2] * G[n, 2] + t[1]
        Z = R[2, 0] * G[n, 0] + R[2, 1] * G[n, 1] + R[2, 2] * G[n, 2] + t[2]
        inv_z = 1.0 / Z
        x, y = X * inv_z, Y * inv_z
        ex = (x * fx + cx - kp[n, 0]) / size
        ey = (y * fy + cy - kp[n, 1]) / size
        d = np.sqrt(ex * ex + ey * ey)
        beta = 1.0
        if d > huber:
            beta = np.sqrt(max(2.0 * huber * (d - 0.5 * huber), 0.0)) / max(d, 1e-12)
        w = np.sqrt(kp[n, 2]) * beta / noise
        r[2 * m] = w * ex
        r[2 * m + 1] = w * ey
        if not jacobian:
            continue
        # d pixels / d G_n = diag(fx, fy) [[1/Z, 0, −x/Z], [0, 1/Z, −y/Z]] R
        zu, zv = fx * (-x * inv_z), fy * (-y * inv_z)
        pu0 = fx * inv_z * R[0, 0] + zu * R[2, 0]
        pu1 = fx * inv_z * R[0, 1] + zu * R[2, 1]
        pu2 = fx * inv_z * R[0, 2] + zu * R[2, 2]
        pv0 = fy * inv_z * R[1, 0] + zv * R[2, 0]
        pv1 = fy * inv_z * R[1, 1] + zv * R[2, 1]
        pv2 = fy * inv_z * R[1, 2] + zv * R[2, 2]
        for q in range(N_PARAMS):
            J[2 * m, q] = w * ((pu0 * JG[n, 0, q] + pu1 * JG[n, 1, q] + pu2 * JG[n, 2, q]) / size)
            J[2 * m + 1, q] = w * ((pv0 * JG[n, 0, q] + pv1 * JG[n, 1, q] + pv2 * JG[n, 2, q])
                                   / size)  # fmt: skip


@njit(cache=True)
def _world_rows(G, JG, ok, R0, world, noise, r, J, jacobian):
    """The rows of the detector's 3D joints into `r` (3n,) and, with `jacobian`, their
    Jacobian into `J` (3n, 26): ((G_n − G_wrist) R0ᵀ − w_n) / σ_w over the n points `ok`."""
    for m in range(ok.shape[0]):
        n = ok[m]
        for a in range(3):
            v = 0.0
            for b in range(3):
                v += R0[a, b] * (G[n, b] - G[WRIST, b])
            r[3 * m + a] = (v - world[n, a]) / noise
            if not jacobian:
                continue
            for q in range(N_PARAMS):
                v = 0.0
                for b in range(3):
                    v += R0[a, b] * (JG[n, b, q] - JG[WRIST, b, q])
                J[3 * m + a, q] = v / noise


def _agreeing_cameras(data: FrameData, kp: np.ndarray, sizes: np.ndarray) -> np.ndarray:
    """(n_cams,) bool: cameras whose silhouette agrees with their keypoints, i.e. at
    least `_AGREE_SHARE` of the keypoints lie within `_AGREE_DISTANCE` hand sizes of it."""
    out = np.zeros(len(sizes), dtype=bool)
    for j in range(len(sizes)):
        ok = kp[j, :, 2] > 0
        if data.counts[j] == 0 or not ok.any():
            continue
        px = kp[j, ok, :2]
        d = np.linalg.norm(px - _nearest_pixels(data, j, px), axis=1) / sizes[j]
        out[j] = np.mean(d <= _AGREE_DISTANCE) >= _AGREE_SHARE
    return out


#: A camera's silhouette agrees with its keypoints when at least this share of them lie
#: within this many hand sizes of it (twice the detector's noise).
_AGREE_SHARE, _AGREE_DISTANCE = 0.9, 0.1


def _nearest_pixels(data: FrameData, j: int, px: np.ndarray) -> np.ndarray:
    """(n, 2) the silhouette pixel of camera j nearest to each of the (n, 2) points `px`;
    a point on a silhouette pixel is its own (zero error), one outside the labelled
    region is looked up at the region's border."""
    u0, v0, w, h = data.roi[j]
    pixel = np.rint(px).astype(np.int64)
    iu = np.clip(pixel[:, 0] - u0, 0, w - 1)
    iv = np.clip(pixel[:, 1] - v0, 0, h - 1)
    q = data.pixels[j][data.labels[j, iv, iu] - 1]
    inside = (q == pixel).all(axis=1)  # a silhouette pixel's nearest is itself
    return np.where(inside[:, None], px, q)


def _solve(problem: _Problem, x, steps: int) -> tuple[np.ndarray, float, int]:
    """Levenberg–Marquardt on ½|r|², each step projected on the joint limits."""
    lam = 1e-3
    r, J = problem.rows(x)
    cost = 0.5 * float(r @ r)
    taken = 0
    for _ in range(steps):
        A = J.T @ J
        g = J.T @ r
        improved = False
        for _ in range(6):
            step = _damped_step(A, g, lam)
            x_new = np.clip(x + step, LOWER, UPPER)
            r2, _ = problem.rows(x_new, jacobian=False)
            c2 = 0.5 * float(r2 @ r2)
            if c2 < cost:
                improved = True
                break
            lam *= 10.0
        taken += 1
        if not improved:
            break
        rel = (cost - c2) / max(cost, 1e-12)
        x, cost = x_new, c2
        lam = max(lam / 10.0, 1e-7)
        if rel < problem.s.tolerance:
            break
        r, J = problem.rows(x)
    return x, cost, taken


@njit(cache=True)
def _damped_step(A, g, lam):
    """Levenberg–Marquardt's step: solve (A + λ diag(A)) δ = −g, the diagonal at least
    1e-9 (a parameter no row moves)."""
    M = A.copy()
    for i in range(A.shape[0]):
        M[i, i] += lam * max(A[i, i], 1e-9)
    return np.linalg.solve(M, -g)


def fit_frame(
    keypoints,
    rig,
    hand,
    start,
    *,
    prior=None,
    prior_scale: PriorScale | None = None,
    world=None,
    silhouettes: FrameData | None = None,
    settings: FrameFitSettings = FRAME_FIT_DEFAULTS,
) -> FrameFit:
    """Fit the pose to one frame's keypoints from `start` (module notes).

    Parameters
    ----------
    keypoints : sequence of (21, 3) array_like or None
        Per camera x, y (pixels of that camera's images) and confidence; None or NaN
        where missing.
    rig : Rig
    hand : HandModel
    start : (26,) array_like
        Starting pose.
    prior : (26,) array_like, keyword-only, optional
        The prediction x̂ of the temporal prior; None: no prior.
    prior_scale : PriorScale, keyword-only, optional
        Its σ (`PriorScale()` by default).
    world : (21, 3) array_like, keyword-only, optional
        The detector's 3D joints, mm, any origin, as the first camera would see them
        looking straight along the ray through the palm (module notes); NaN rows are
        left out.
    silhouettes : FrameData, keyword-only, optional
        The frame's silhouettes (`handvar.tracking.costs.prepare_frame`) for the
        silhouette term; used only when ``settings.silhouette`` > 0.
    settings : FrameFitSettings, keyword-only

    Returns
    -------
    FrameFit

    Examples
    --------
    >>> from handvar.camera import Rig
    >>> from handvar.hand import HandModel, named_pose
    >>> hand, rig, x = HandModel(), Rig.default(), named_pose("point")
    >>> kps = [np.column_stack([c.project(hand.joints(x)), np.ones(21)]) for c in rig]
    >>> fit = fit_frame(kps, rig, hand, x + 2.0)
    >>> bool(fit.error < 0.01), fit.n_rejected
    (True, 0)
    """
    n_cams = len(rig)
    kp = _clean(keypoints, n_cams, settings.min_confidence)
    x = np.clip(clamp(np.asarray(start, dtype=float)), LOWER, UPPER)
    sigma = None
    if prior is not None:
        prior = np.asarray(prior, dtype=float)
        sigma = (PriorScale() if prior_scale is None else prior_scale).per_parameter()
    if world is not None:
        world = np.asarray(world, dtype=float)
        if world.shape != (21, 3) or not np.isfinite(world[WRIST]).all():
            world = None
    problem = _Problem(hand, rig, kp, prior, sigma, world, settings, x, silhouettes)
    x, cost, n = _solve(problem, x, settings.iterations)
    d = problem.distances(x)
    present = kp[:, :, 2] > 0
    rejected = present & (d > settings.reject)
    if rejected.any() and settings.polish:
        kept = kp.copy()
        kept[rejected] = 0.0
        problem = _Problem(hand, rig, kept, prior, sigma, world, settings, x, silhouettes)
        x, cost, m = _solve(problem, x, settings.polish)
        n += m
        d = problem.distances(x)
        d[rejected] = _distances(hand, rig, kp, x, settings.tips)[rejected]
        rejected = present & (d > settings.reject)
    return FrameFit(x, d, rejected, cost, n)


def keypoint_distances(
    keypoints, rig, hand, x, *, settings: FrameFitSettings = FRAME_FIT_DEFAULTS
) -> np.ndarray:
    """d_ij of `fit_frame` at pose `x`: (n_cams, 21) distances of the projected joints to
    the keypoints, in the model's hand sizes at `x`; NaN where there is no keypoint."""
    kp = _clean(keypoints, len(rig), settings.min_confidence)
    x = np.asarray(x, dtype=float)
    return _distances(hand, rig, kp, x, settings.tips)


def reinitialise(
    keypoints,
    rig,
    hand,
    *,
    world=None,
    silhouettes: FrameData | None = None,
    settings: FrameFitSettings = FRAME_FIT_DEFAULTS,
    shapes: tuple[str, ...] = ("open",),
) -> FrameFit | None:
    """The pose of a frame from its keypoints alone: `fit_frame` from every palm pose.

    The perspective-n-point palm poses of each camera's keypoints
    (`handvar.tracking.keypoint_fit.palm_candidates`, four per camera), each with the
    fingers in every posture of `shapes` (`handvar.hand.kinematics.named_pose`), are
    fitted without a prior; of the fits in front of every camera with keypoints the one
    whose keypoints' loss is lowest is kept, each rejected keypoint charged the loss at
    the rejection distance (`_truncated_cost`).  None when no camera shows the wrist
    and the four MCPs, or every fit lies behind a camera.
    """
    from handvar.hand.kinematics import named_pose
    from handvar.tracking.keypoint_fit import _behind, palm_candidates

    kp = _clean(keypoints, len(rig), settings.min_confidence)
    seen = [k if (k[:, 2] > 0).any() else None for k in kp]
    best, starts = None, 0
    for cam, k in zip(rig, kp, strict=True):
        if not (k[:, 2] > 0).any():
            continue
        for p in palm_candidates(np.where(k[:, 2:] > 0, k, np.nan), cam, hand):
            for name in shapes:
                starts += 1
                x0 = named_pose(name)
                x0[:6] = p
                fit = fit_frame(kp, rig, hand, x0, world=world, silhouettes=silhouettes,
                                settings=settings)  # fmt: skip
                if _behind(fit.pose, hand, rig, seen):
                    continue  # a point reflection through a camera's centre projects alike
                score = _truncated_cost(fit, kp, settings)
                if best is None or score < best[0]:
                    best = (score, fit)
    return None if best is None else dataclasses.replace(best[1], starts=starts)


def _truncated_cost(fit: FrameFit, kp: np.ndarray, settings: FrameFitSettings) -> float:
    """Σ c_ij ρ(min(d_ij, `FrameFitSettings.reject`)) at the fit: its keypoints' Huber
    loss, each rejected one charged the loss at the rejection distance, d_ij in the
    model's hand sizes at the fit (`FrameFit.distances`), so that the fits of one frame
    from different starts compare on the same keypoints and the same scale.  (E itself
    does not: it leaves a fit's rejected keypoints out, so a fit far off, rejecting most
    of them, would cost least, and it measures d in the hand's size at the start.)"""
    h = settings.huber
    d = np.minimum(fit.distances, settings.reject)
    ok = ~np.isnan(d)
    rho = np.where(d <= h, 0.5 * d * d, h * (d - 0.5 * h))
    return float((kp[:, :, 2][ok] * rho[ok]).sum())


def honoured(
    distances, rejected, *, threshold: float = CHECK_THRESHOLD, share: float = 0.98
) -> tuple[bool, float, int]:
    """Whether a track honours its keypoints (docs/keypoint-fit.md, "the check").

    On every frame with keypoints, the fitted joints must project within `threshold`
    hand sizes of at least `share` of the keypoints the fit did not reject.

    Parameters
    ----------
    distances : (T, n_cams, 21) array_like
        Per frame the distance of every projected joint to its keypoint, hand sizes;
        NaN where there is no keypoint.
    rejected : (T, n_cams, 21) bool array_like
        The keypoints the fit rejected.
    threshold, share : float, keyword-only

    Returns
    -------
    ok : bool
        Every frame with kept keypoints passes.
    worst : float
        The lowest share of kept keypoints within `threshold` over the frames (NaN
        when no frame has keypoints).
    n_rejected : int
        Keypoints rejected over the whole track.

    Examples
    --------
    >>> d = np.array([[[0.1, 0.5, np.nan]]]); r = np.array([[[False, True, False]]])
    >>> honoured(d, r)
    (True, 1.0, 1)
    """
    rej = np.asarray(rejected, dtype=bool)
    shares = honoured_shares(distances, rej, threshold=threshold)
    frames = ~np.isnan(shares)
    if not frames.any():
        return True, float("nan"), int(rej.sum())
    shares = shares[frames]
    return bool(np.all(shares >= share)), float(shares.min()), int(rej.sum())


def honoured_counts(
    distances, rejected, *, threshold: float = CHECK_THRESHOLD
) -> tuple[np.ndarray, np.ndarray]:
    """(T,) per frame the kept keypoints within `threshold` hand sizes of the fitted
    joints, and (T,) the kept keypoints (`honoured`'s counts).

    Examples
    --------
    >>> d = np.array([[[0.1, 0.5, np.nan]]])
    >>> [c.tolist() for c in honoured_counts(d, np.zeros(d.shape, bool))]
    [[1], [2]]
    """
    d = np.asarray(distances, dtype=float)
    rej = np.asarray(rejected, dtype=bool)
    if d.shape != rej.shape or d.ndim != 3:
        raise ValueError(
            f"distances, rejected: expected two (T, n_cams, 21) arrays; got {d.shape}, {rej.shape}"
        )
    kept = ~np.isnan(d) & ~rej
    near = kept & (np.nan_to_num(d, nan=np.inf) <= threshold)
    return near.sum(axis=(1, 2)), kept.sum(axis=(1, 2))


def honoured_shares(distances, rejected, *, threshold: float = CHECK_THRESHOLD) -> np.ndarray:
    """(T,) per frame the share of the kept keypoints within `threshold` hand sizes of
    the fitted joints (`honoured`'s measure); NaN on a frame without kept keypoints.

    Examples
    --------
    >>> d = np.array([[[0.1, 0.5, np.nan]], [[np.nan] * 3]])
    >>> honoured_shares(d, np.zeros(d.shape, bool)).tolist()
    [0.5, nan]
    >>> honoured_shares(np.zeros((0, 1, 21)), np.zeros((0, 1, 21), bool)).shape
    (0,)
    """
    near, n_kept = honoured_counts(distances, rejected, threshold=threshold)
    with np.errstate(invalid="ignore", divide="ignore"):
        return np.where(n_kept > 0, near / np.maximum(n_kept, 1), np.nan)
