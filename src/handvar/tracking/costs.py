"""The tracker's cost: silhouette term C_s and filling term C_f (paper §2.1, §4).

Per frame and camera j, :func:`prepare_frame` builds once, from the observed silhouette
S_j, a field giving for every pixel its nearest silhouette pixel (OpenCV's labelled
distance transform) and the list of silhouette pixels. Every optimiser iteration then
draws fresh random samples (:meth:`SilhouetteCost.draw`): N points on the model surface,
projected into every camera, and M pixels inside every silhouette. The paper uses
"about 600 sample points" (paper §4); our default split is N = 150 surface points (300
projections in a stereo rig) and M = 150 silhouette pixels per camera (300 in all), so
that both terms are estimated from the same number of residuals.

Terms, for a rig of n_c cameras (residuals in pixels, see *Unit* below):

- C_s, the model inside the silhouette: the mean over surface samples i and cameras j of
  ½‖p_ij(x) − s*(p_ij)‖², p_ij the projection of sample i into camera j and s* the
  silhouette pixel nearest to the pixel p_ij falls on (zero when that pixel is in S_j).
- C_f, the silhouette filled by the model (eq. 1): the mean over silhouette samples ŝ_ij
  of ½‖ŝ_ij − h_ij(x)‖², h_ij the closest point of the model's image (zero where the
  model covers the pixel). Eq. 1 sums over the cameras and averages over the samples;
  we average over both, i.e. eq. 1 divided by n_c, so that one threshold serves a
  monocular and a stereo rig alike.
- C = 1.7 C_s + 0.4 C_f (paper §4), plus w_k C_k on frames with keypoints and w_z C_z, which
  keeps the hand in front of every camera (`handvar.tracking.keypoint_cost`).

Gradients follow the chain rule residual × projection Jacobian × kinematic Jacobian with
the matched targets s* and ŝ held fixed, as in ICP. The same quantities are returned as a
stacked residual vector r and its Jacobian J with ``C = ½ rᵀr`` and ``∇C = Jᵀr``, so
that a Gauss–Newton curvature-vector product is ``Jᵀ(J v)``.

Unit
----
The cost is dimensionless: residuals are measured in units of ``pixel_scale`` pixels
(`CostSettings`), i.e. C is in (pixel_scale px)². With the default pixel_scale of 3 px
the paper's stopping threshold 0.006 (paper §4) is a weighted mean squared misfit of
0.006 · 9 = 0.054 px². How it was chosen (benchmark sequence, stereo rig): at the true
pose C ≈ 1–2·10⁻⁴ (circle approximation of the model's outline, pixel rounding); with
every parameter 1 mm or 1° off C ≈ 0.05 (about 3 mm of mean joint error), and it stays
above 0.006 down to about 0.3 mm / 0.3°. The threshold therefore stops the optimiser
only once the silhouettes match to a fraction of a pixel, not while millimetres of
error remain; on the benchmark about half to three quarters of the frames stop on it.
The optimiser's steps do not depend on this unit (`handvar.tracking.smd`).

Speed
-----
All per-iteration work after the forward kinematics runs in one compiled kernel
(numba). The kinematics are queried once per iteration for four reference points per
bone: a bone moves rigidly, so the position and the Jacobian of any point attached to
it are affine in the point's bone coordinates and follow from those four exactly.
:func:`cost_reference` computes the same cost with the public numpy routines of
:mod:`handvar.hand` and :mod:`handvar.camera`; the tests check that both agree.

One concept in one module (the cost, its per-frame data and its compiled kernel), hence
its length. The kernel's geometry is not written here: it calls the one compiled form of
the projection with lens distortion (`handvar.geometry.distortion.project_point`) and of
the closest point of the model's image (`handvar.geometry.projected.closest_point_on_union`),
and reads the cameras only through `handvar.camera.Rig.packed`. The terms on the 21
points G(x) — the keypoint term C_k and the front term C_z — are computed by
`handvar.tracking.keypoint_cost` from the same kinematics, inside `SilhouetteCost.evaluate`.
"""

from __future__ import annotations

from dataclasses import dataclass

import cv2
import numpy as np
from numba import njit

from handvar.camera import Rig
from handvar.geometry.distortion import project_point as _project
from handvar.geometry.projected import closest_point_on_union, union_axes
from handvar.params import N_PARAMS, check_pose
from handvar.tracking.keypoint_cost import (
    LOSSES,
    TIPS,
    hand_length,
    joint_terms,
    keypoint_attachment,
)
from handvar.validate import as_float, as_instance, as_int, one_of

__all__ = [
    "CostSettings",
    "CostTerms",
    "FrameData",
    "Samples",
    "SilhouetteCost",
    "cost_reference",
    "nearest_silhouette_field",
    "prepare_frame",
]


@dataclass(frozen=True)
class CostSettings:
    """Weights and sample sizes of the tracking cost (paper §2.1 and §4).

    Attributes
    ----------
    weight_silhouette : float
        Weight of C_s, 1.7 (paper §4).
    weight_filling : float
        Weight of C_f, 0.4 (paper §4).
    n_surface : int
        Surface samples N per iteration, each projected into every camera.
    n_pixels : int
        Silhouette pixel samples M per camera and iteration. With the defaults a stereo
        rig has 300 + 300 residuals, the paper's "about 600 sample points" (paper §4).
    pixel_scale : float
        Pixels per unit of residual, so that the cost is in (pixel_scale px)². 3 px puts
        the paper's stopping threshold 0.006 (`SMDSettings.threshold`) at a weighted
        mean squared misfit of 0.054 px², reached on synthetic frames within about
        0.3 mm and 0.3° of the true pose (module docstring, *Unit*).
    weight_keypoints : float
        Weight w_k of the keypoint term C_k (hand sizes², `handvar.tracking.keypoint_cost`);
        only frames with keypoints have it. Chosen by measurement (design §14.2).
    keypoint_huber : float
        The scale of C_k's loss, hand sizes: Huber's δ (0.1), or Tukey's c.
    keypoint_loss : {"huber", "tukey"}
        C_k's loss ρ: Huber's (convex; a wrong detection pulls with bounded force) or
        Tukey's biweight (redescending; a point farther than c pulls not at all). The
        tracker's refinement after SMD uses its own (`RefineSettings`, design §14.2).
    keypoint_tips : {"end", "pad"}
        Which model point a detected fingertip is compared with: G(x)'s tip, the end
        of the finger's surface ("end"), or the centre of the fingertip's pad, one tip
        radius short of it ("pad", where MediaPipe marks it; design §14.6).  The tracker's
        keypoint error and the pose search from keypoints use the same points.
    near : float
        Depth (mm) in front of every camera below which a joint is penalised by C_z
        (design §13); also the floor of the depth in C_k's hand size.
    weight_front : float
        Weight w_z of the front term C_z.
    front_scale : float
        Unit of C_z's hinge, mm: a joint ``front_scale`` mm too close costs ½ w_z/(21 n_c).
    curvature_floor : float
        Fraction of the sensitivity added to the Gauss–Newton diagonal in
        `CostTerms.curvature`, the optimiser's preconditioner.
    roi_margin : int
        Pixels around a silhouette's bounding box in which the nearest-pixel field is
        computed; model points projecting farther out are matched through the nearest
        point of that region (a gross misfit either way, pulled back all the same).
    """

    weight_silhouette: float = 1.7
    weight_filling: float = 0.4
    n_surface: int = 150
    n_pixels: int = 150
    pixel_scale: float = 3.0
    roi_margin: int = 64
    curvature_floor: float = 0.1
    weight_keypoints: float = 100.0
    keypoint_huber: float = 0.1
    keypoint_loss: str = "huber"
    keypoint_tips: str = "end"
    near: float = 100.0
    weight_front: float = 1.0
    front_scale: float = 10.0

    def __post_init__(self) -> None:
        for name in ("weight_silhouette", "weight_filling", "weight_keypoints", "weight_front"):
            as_float(getattr(self, name), name, minimum=0.0)
        for name in ("keypoint_huber", "near", "front_scale"):
            as_float(getattr(self, name), name, minimum=0.0, exclusive_minimum=True)
        for name in ("n_surface", "n_pixels"):
            as_int(getattr(self, name), name, minimum=1)
        as_float(self.pixel_scale, "pixel_scale", minimum=0.0, exclusive_minimum=True)
        as_int(self.roi_margin, "roi_margin", minimum=0)
        one_of(self.keypoint_loss, LOSSES, "keypoint_loss")
        one_of(self.keypoint_tips, TIPS, "keypoint_tips")

    def total(self, c_s: float, c_f: float, c_k: float, c_z: float) -> float:
        """C = w_s C_s + w_f C_f + w_k C_k + w_z C_z of the unweighted terms."""
        return (
            self.weight_silhouette * c_s + self.weight_filling * c_f
            + self.weight_keypoints * c_k + self.weight_front * c_z
        )  # fmt: skip

    def joint_terms(self, P, JP, cams, keypoints, *, length: float, residuals: bool = False):
        """C_k and C_z of G(x) with these settings (`keypoint_cost.joint_terms`)."""
        return joint_terms(
            P, JP, cams, keypoints, length=length, huber=self.keypoint_huber, near=self.near,
            weight_keypoints=self.weight_keypoints, weight_front=self.weight_front,
            front_scale=self.front_scale, residuals=residuals, loss=self.keypoint_loss,
        )  # fmt: skip


# --- per-frame preprocessing --------------------------------------------------------------


def nearest_silhouette_field(mask: np.ndarray, *, margin: int = 64):
    """Nearest silhouette pixel of every pixel of a region around the silhouette.

    OpenCV's labelled distance transform (``cv2.distanceTransformWithLabels``, L2 with
    the 5×5 mask, ``DIST_LABEL_PIXEL``) of the inverted mask gives every pixel the
    label of its nearest silhouette pixel; labels number the silhouette pixels in
    raster order, which maps them back to coordinates. The 5×5 mask makes the match
    approximate: the distance to it exceeds the exact Euclidean one by a fraction of
    a pixel.

    Parameters
    ----------
    mask : (H, W) bool ndarray
        Silhouette (True inside); not empty.
    margin : int, keyword-only
        Pixels added around the silhouette's bounding box (clipped to the image).

    Returns
    -------
    nearest : (h, w, 2) float64 ndarray
        Image coordinates (u, v) of the nearest silhouette pixel for every pixel of the
        region; a silhouette pixel is its own nearest pixel.
    roi : (4,) int64 ndarray
        ``(u0, v0, w, h)``: the region's top-left pixel and size.
    pixels : (K, 2) float64 ndarray
        Coordinates (u, v) of the K silhouette pixels, raster order.
    """
    labels, roi, coords = _silhouette_labels(mask, margin)
    nearest = coords[labels - 1]
    return nearest, roi, coords


def _silhouette_labels(mask: np.ndarray, margin: int):
    """`nearest_silhouette_field` without the field: labels (h, w) int32, roi, coords.

    ``labels[y, x] - 1`` is the row of ``coords`` nearest to the region's pixel
    (x, y); keeping labels instead of the (h, w, 2) field of coordinates spares
    writing 16 bytes a pixel every frame.
    """
    m = np.asarray(mask)
    if m.ndim != 2:
        raise ValueError(f"mask: expected an (H, W) array; got shape {m.shape}")
    m = m.astype(bool, copy=False)
    rows = np.flatnonzero(m.any(axis=1))
    cols = np.flatnonzero(m.any(axis=0))
    if rows.size == 0:
        raise ValueError("mask: expected a non-empty silhouette; got an empty mask")
    H, W = m.shape
    v0 = max(int(rows[0]) - margin, 0)
    v1 = min(int(rows[-1]) + margin + 1, H)
    u0 = max(int(cols[0]) - margin, 0)
    u1 = min(int(cols[-1]) + margin + 1, W)
    sub = m[v0:v1, u0:u1]
    inverted = np.logical_not(sub).view(np.uint8)
    _, labels = cv2.distanceTransformWithLabels(
        inverted, cv2.DIST_L2, 5, labelType=cv2.DIST_LABEL_PIXEL
    )
    ys, xs = np.nonzero(sub)  # raster order, as the labels
    coords = np.empty((ys.size, 2))
    coords[:, 0] = xs + u0
    coords[:, 1] = ys + v0
    roi = np.array([u0, v0, u1 - u0, v1 - v0], dtype=np.int64)
    return labels, roi, coords


@dataclass(frozen=True, eq=False)
class FrameData:
    """Everything the cost needs from one frame's silhouettes, computed once per frame.

    Attributes
    ----------
    labels : (n_cams, h, w) int32 ndarray
        Per camera and pixel of its region (padded to the largest region), one plus
        the row in `pixels` of the nearest silhouette pixel.
    roi : (n_cams, 4) int64 ndarray
        ``(u0, v0, w, h)`` of each camera's region; w = h = 0 for an empty silhouette.
    pixels : (n_cams, K, 2) float64 ndarray
        Silhouette pixel coordinates per camera (padded to the largest count K).
    counts : (n_cams,) int64 ndarray
        Number of silhouette pixels per camera; a camera with none contributes no terms.
    """

    labels: np.ndarray
    roi: np.ndarray
    pixels: np.ndarray
    counts: np.ndarray

    @property
    def n_cameras(self) -> int:
        return self.roi.shape[0]

    @property
    def nearest(self) -> np.ndarray:
        """(n_cams, h, w, 2): the nearest silhouette pixel (u, v) of every region pixel."""
        rows = np.maximum(self.labels - 1, 0)
        return np.stack([self.pixels[j][rows[j]] for j in range(self.n_cameras)])


def prepare_frame(masks, rig: Rig, *, margin: int = 64) -> FrameData:
    """Per-frame preprocessing of the silhouettes of all cameras (see `FrameData`).

    Parameters
    ----------
    masks : (n_cams, H, W) bool array_like
        One silhouette per camera of `rig`, True inside.
    rig : Rig
        The cameras; camera j saw ``masks[j]``.
    margin : int, keyword-only
        See `nearest_silhouette_field`.

    Returns
    -------
    FrameData

    Raises
    ------
    ValueError
        When the shape does not match the rig, or every silhouette is empty. A camera
        whose silhouette alone is empty (the hand out of its view) is skipped.
    """
    as_instance(rig, Rig, "rig", what="a handvar.camera.Rig")
    m = np.asarray(masks)
    n = len(rig)
    if m.ndim != 3 or m.shape[0] != n:
        raise ValueError(
            f"masks: expected shape ({n}, H, W), one silhouette per camera; got shape {m.shape}"
        )
    for name, cam in zip(rig.names, rig.cameras, strict=True):
        if (m.shape[2], m.shape[1]) != tuple(cam.size):
            raise ValueError(
                f"masks: expected images of {cam.size[0]}x{cam.size[1]} for camera {name!r}; "
                f"got {m.shape[2]}x{m.shape[1]}"
            )
    fields = []
    for j in range(n):
        if m[j].any():
            fields.append(_silhouette_labels(m[j], margin))
        else:
            fields.append(None)
    if all(f is None for f in fields):
        raise ValueError("masks: expected a non-empty silhouette in at least one camera; all empty")
    h = max(f[1][3] for f in fields if f is not None)
    w = max(f[1][2] for f in fields if f is not None)
    k = max(f[2].shape[0] for f in fields if f is not None)
    labels = np.zeros((n, h, w), dtype=np.int32)
    roi = np.zeros((n, 4), dtype=np.int64)
    pixels = np.zeros((n, k, 2))
    counts = np.zeros(n, dtype=np.int64)
    for j, f in enumerate(fields):
        if f is None:
            continue
        lab, r, px = f
        labels[j, : r[3], : r[2]] = lab
        roi[j] = r
        pixels[j, : px.shape[0]] = px
        counts[j] = px.shape[0]
    return FrameData(labels, roi, pixels, counts)


# --- samples and results ------------------------------------------------------------------


@dataclass(frozen=True, eq=False)
class Samples:
    """The random samples of one optimiser iteration.

    Attributes
    ----------
    bone : (N,) int ndarray
        Bone of each surface sample.
    local : (N, 3) ndarray
        Surface samples in their bone's frame, mm.
    pixels : (n_cams, M, 2) ndarray
        Silhouette pixel samples ŝ per camera (meaningless for cameras without
        silhouette pixels).
    """

    bone: np.ndarray
    local: np.ndarray
    pixels: np.ndarray


@dataclass(frozen=True, eq=False)
class CostTerms:
    """The cost at one pose for one set of samples.

    Attributes
    ----------
    cost : float
        C = w_s C_s + w_f C_f + w_k C_k + w_z C_z, in (pixel_scale px)².
    silhouette, filling : float
        C_s and C_f (unweighted), same unit.
    gradient : (26,) ndarray
        dC/dx, per mm (translation) and per degree (angles).
    sensitivity : (26,) ndarray or None
        ``w_s · mean ‖∂p_ij/∂x_k‖² / scale²`` over all projected surface samples: the
        diagonal of JᵀJ that the silhouette rows would have if every sample were
        outside the silhouette. It measures how fast the model's image moves with each
        parameter, whatever the current misfit.
    gauss_newton_diagonal : (26,) ndarray or None
        ``diag(JᵀJ)`` of the stacked residuals (rows with zero residual do not count).
    residuals : (R,) ndarray or None
        Stacked weighted residuals r with ``C = ½ rᵀr``: for every camera the 2N
        silhouette rows (u, v per surface sample) then the 2M filling rows; then the
        rows of C_k and C_z (`handvar.tracking.keypoint_cost.joint_terms`).
    jacobian : (R, 26) ndarray or None
        dr/dx, so that ``gradient = Jᵀ r`` and ``Jᵀ(J v)`` is the Gauss–Newton product.
    keypoints, front : float
        C_k (hand sizes², 0 without keypoints) and C_z (unweighted).
    """

    cost: float
    silhouette: float
    filling: float
    gradient: np.ndarray
    sensitivity: np.ndarray | None = None
    gauss_newton_diagonal: np.ndarray | None = None
    residuals: np.ndarray | None = None
    jacobian: np.ndarray | None = None
    keypoints: float = 0.0
    front: float = 0.0

    def curvature(self, floor: float) -> np.ndarray:
        """Diagonal curvature for the optimiser: ``diag(JᵀJ) + floor · sensitivity``, (26,).

        The Gauss–Newton diagonal shrinks with the misfit (only residuals outside the
        silhouette or the model count); the floor keeps a fraction of the sensitivity
        so that a parameter whose samples all fit is not given an unbounded gain.
        """
        if self.gauss_newton_diagonal is None or self.sensitivity is None:
            raise ValueError("floor: the curvature needs the compiled route's diagonals")
        return self.gauss_newton_diagonal + floor * self.sensitivity

    def gauss_newton(self, v) -> np.ndarray:
        """Gauss–Newton curvature-vector product ``Jᵀ(J v)``, (26,)."""
        if self.jacobian is None:
            raise ValueError("v: a Gauss–Newton product needs the residual Jacobian")
        v = np.asarray(v, dtype=float)
        if v.shape != (N_PARAMS,):
            raise ValueError(f"v: expected shape (26,); got shape {v.shape}")
        return self.jacobian.T @ (self.jacobian @ v)


# --- the cost ------------------------------------------------------------------------------

# Local coordinates of the four reference points of every bone: its origin and the ends of
# its three unit axes.
_REFERENCE = np.array([[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]])


class SilhouetteCost:
    """The cost C = w_s C_s + w_f C_f of a hand model seen by a rig (module docstring).

    Holds what does not change between frames (the model's primitives, the camera
    parameters in arrays for the compiled kernel).

    Parameters
    ----------
    hand : HandModel
        The hand (its surface pool is built on first use).
    rig : Rig
        The cameras.
    settings : CostSettings, optional

    Examples
    --------
    >>> import numpy as np
    >>> from handvar.camera import Rig
    >>> from handvar.hand import HandModel, named_pose
    >>> from handvar.render import silhouettes
    >>> hand, rig, x = HandModel(), Rig.default(), named_pose("open")
    >>> cost = SilhouetteCost(hand, rig)
    >>> frame = cost.prepare(silhouettes(hand, x, rig))
    >>> terms = cost.evaluate(x, frame, cost.draw(frame, np.random.default_rng(0)))
    >>> terms.gradient.shape, bool(terms.cost < 0.006)
    ((26,), True)
    """

    def __init__(self, hand, rig: Rig, settings: CostSettings | None = None) -> None:
        as_instance(rig, Rig, "rig", what="a handvar.camera.Rig")
        settings = CostSettings() if settings is None else settings
        as_instance(settings, CostSettings, "settings")
        self.hand = hand
        self.rig = rig
        self.settings = settings
        prim = hand.primitives
        self._prim_bone = np.ascontiguousarray(prim.bone, dtype=np.int64)
        self._prim_local = np.ascontiguousarray(prim.centres, dtype=float)
        self._prim_radii = np.ascontiguousarray(prim.radii, dtype=float)
        n_bones = len(hand.bone_frames(np.zeros(N_PARAMS))[1])
        self._ref_bone = np.repeat(np.arange(n_bones), 4)
        self._ref_local = np.tile(_REFERENCE, (n_bones, 1))
        self._cams = rig.packed()
        bone, local = keypoint_attachment(hand, settings.keypoint_tips)  # G(x) by default
        self._joint_bone = np.ascontiguousarray(bone, dtype=np.int64)
        self._joint_local = np.ascontiguousarray(local, dtype=float)
        self.length = hand_length(hand)  # L of C_k, mm

    # -- per frame --
    def prepare(self, masks) -> FrameData:
        """`prepare_frame` for this rig, with the settings' margin."""
        return prepare_frame(masks, self.rig, margin=self.settings.roi_margin)

    # -- per iteration --
    def draw(self, frame: FrameData, rng: np.random.Generator) -> Samples:
        """Fresh random samples: N surface points and M silhouette pixels per camera.

        Surface points are drawn uniformly from the model's pool of area-uniform samples
        on the union's outer surface (`HandModel.surface_pool`); silhouette pixels
        uniformly, with replacement, from each camera's silhouette.
        """
        as_instance(rng, np.random.Generator, "rng", what="a numpy.random.Generator")
        pool = self.hand.surface_pool.exposed
        s = self.settings
        idx = rng.integers(0, pool.bone.shape[0], s.n_surface)
        n = frame.n_cameras
        pixels = np.zeros((n, s.n_pixels, 2))
        for j in range(n):
            if frame.counts[j] > 0:
                pixels[j] = frame.pixels[j, rng.integers(0, frame.counts[j], s.n_pixels)]
        return Samples(pool.bone[idx], pool.local[idx], pixels)

    def _reference_points(self, x: np.ndarray):
        """Positions (B, 4, 3) and Jacobians (B, 4, 3, 26) of every bone's reference points."""
        p, J = self.hand.points(x, self._ref_bone, self._ref_local, jacobian=True)
        return p.reshape(-1, 4, 3), J.reshape(-1, 4, 3, N_PARAMS)

    def evaluate(
        self, x, frame: FrameData, samples: Samples, *, residuals: bool = False, keypoints=None
    ) -> CostTerms:
        """Cost, its parts and gradient at pose `x` for the given frame and samples.

        Parameters
        ----------
        x : (26,) array_like
            Pose, mm and degrees.
        frame : FrameData
            From `prepare`.
        samples : Samples
            From `draw`.
        residuals : bool, keyword-only
            Also return the stacked residuals and their Jacobian (for Gauss–Newton
            products).
        keypoints : (n_cams, 21, 3) ndarray or None, keyword-only
            This frame's keypoints, x, y, confidence (missing: confidence 0), as
            `handvar.tracking.keypoint_cost.frame_keypoints` returns; None: no C_k.

        Returns
        -------
        CostTerms
        """
        x = check_pose(x, "x")
        if frame.n_cameras != len(self.rig):
            raise ValueError(
                f"frame: expected data of {len(self.rig)} cameras; got {frame.n_cameras}"
            )
        Q, JQ = self._reference_points(x)
        s = self.settings
        n_cams = frame.n_cameras
        active = frame.counts > 0
        n_active = int(active.sum())
        N, M = samples.bone.shape[0], samples.pixels.shape[1]
        scale2 = s.pixel_scale * s.pixel_scale
        # r = a (pixel residual) with ½ Σ r² = w · mean ½‖pixel residual‖² / scale²
        a_s = np.sqrt(s.weight_silhouette / (N * n_active * scale2))
        a_f = np.sqrt(s.weight_filling / (M * n_active * scale2))
        rows = 2 * (N + M) * n_cams
        r = np.zeros(rows)
        J = np.zeros((rows, N_PARAMS)) if residuals else np.zeros((0, N_PARAMS))
        g = np.zeros(N_PARAMS)
        parts = np.zeros(2)
        sens = np.zeros(N_PARAMS)
        gn = np.zeros(N_PARAMS)
        _cost_kernel(
            Q,
            JQ,
            np.ascontiguousarray(samples.bone, dtype=np.int64),
            np.ascontiguousarray(samples.local, dtype=float),
            self._prim_bone,
            self._prim_local,
            self._prim_radii,
            self._cams.intrinsics,
            self._cams.dist,
            self._cams.rational,
            self._cams.R,
            self._cams.t,
            frame.labels,
            frame.pixels,
            frame.roi,
            np.ascontiguousarray(samples.pixels, dtype=float),
            active,
            a_s,
            a_f,
            residuals,
            r,
            J,
            g,
            parts,
            sens,
            gn,
        )
        c_s = 0.5 * parts[0] / (N * n_active * scale2)
        c_f = 0.5 * parts[1] / (M * n_active * scale2)
        P = np.empty((self._joint_bone.shape[0], 3))
        JP = np.empty((P.shape[0], 3, N_PARAMS))
        _attached_all(Q, JQ, self._joint_bone, self._joint_local, P, JP)  # G(x), dG/dx
        c_k, c_z, g_j, gn_j, r_j, J_j = s.joint_terms(
            P, JP, self._cams, keypoints, length=self.length, residuals=residuals
        )
        g += g_j
        gn += gn_j
        cost = s.total(c_s, c_f, c_k, c_z)
        if residuals:
            r = np.concatenate([r, r_j])
            J = np.concatenate([J, J_j])
        return CostTerms(
            float(cost), float(c_s), float(c_f), g, sens, gn, r if residuals else None,
            J if residuals else None, c_k, c_z,
        )  # fmt: skip


# --- compiled kernel ---------------------------------------------------------------------


@njit(cache=True)
def _attached(Q, JQ, b, loc, p, J3):  # pragma: no cover - compiled
    """World point and Jacobian of local point `loc` on bone `b` (affine in `loc`)."""
    for i in range(3):
        v = Q[b, 0, i]
        for k in range(3):
            v += loc[k] * (Q[b, k + 1, i] - Q[b, 0, i])
        p[i] = v
        for col in range(JQ.shape[3]):
            w = JQ[b, 0, i, col]
            for k in range(3):
                w += loc[k] * (JQ[b, k + 1, i, col] - JQ[b, 0, i, col])
            J3[i, col] = w


@njit(cache=True)
def _attached_all(Q, JQ, bone, local, P, JP):  # pragma: no cover - compiled
    """`_attached` for every row of (bone, local): P (n, 3) and JP (n, 3, d), in place."""
    p = np.empty(3)
    J3 = np.empty((3, JQ.shape[3]))
    for n in range(bone.shape[0]):
        _attached(Q, JQ, bone[n], local[n], p, J3)
        P[n] = p
        JP[n] = J3


@njit(cache=True)
def _cost_kernel(
    Q, JQ, s_bone, s_local, prim_bone, prim_local, prim_radii,
    cam_k, cam_dist, cam_rational, cam_R, cam_t,
    labels, silhouette, roi, pixels, active, a_s, a_f, want_jacobian, r, J, g, parts, sens,
    gn,
):  # fmt: skip  # pragma: no cover - compiled
    """Residuals, gradient and the two sums of squares of the cost, in place.

    Row layout per camera j (offset 2 (N + M) j): 2N silhouette rows, then 2M filling
    rows. ``parts`` receives the sums of squared pixel residuals ‖p − s*‖² and ‖h − ŝ‖²
    (unweighted, unscaled); ``sens`` the diagonal of JᵀJ over all silhouette rows,
    whether their residual is zero or not; ``gn`` the diagonal of JᵀJ (Gauss–Newton).
    """
    n_par = JQ.shape[3]
    N = s_bone.shape[0]
    M = pixels.shape[1]
    P = prim_bone.shape[0]
    uv = np.empty(2)
    J2 = np.empty((2, n_par))
    # world sphere centres and surface points, and their Jacobians (camera independent)
    cw = np.empty((P, 2, 3))
    cJ = np.empty((P, 2, 3, n_par))
    for e in range(2):
        _attached_all(Q, JQ, prim_bone, prim_local[:, e], cw[:, e], cJ[:, e])
    sw = np.empty((N, 3))
    sJ = np.empty((N, 3, n_par))
    _attached_all(Q, JQ, s_bone, s_local, sw, sJ)
    pc = np.empty((P, 2, 2))
    prho = np.empty((P, 2))
    visible = np.empty(P, dtype=np.bool_)
    axes = np.zeros((P, 6))
    dth = np.empty((P, 6, n_par))
    for j in range(cam_k.shape[0]):
        if not active[j]:
            continue
        base = 2 * (N + M) * j
        camera = (cam_k[j], cam_dist[j], cam_rational[j], cam_R[j], cam_t[j])
        _silhouette_rows(camera, roi[j], labels[j], silhouette[j], sw, sJ, a_s, base,
                         want_jacobian, r, J, g, parts, sens, gn, uv, J2)  # fmt: skip
        _model_image(camera, cw, cJ, prim_radii, pc, prho, visible, dth, uv, J2)
        union_axes(pc, prho, visible, axes)
        _filling_rows(pixels[j], pc, prho, axes, visible, dth, a_f, base + 2 * N,
                      want_jacobian, r, J, g, parts, gn)  # fmt: skip


@njit(cache=True)
def _silhouette_rows(camera, roi, labels, silhouette, sw, sJ, a_s, base, want_jacobian, r,
                     J, g, parts, sens, gn, uv, J2):  # fmt: skip  # pragma: no cover
    """C_s of one camera: each surface sample against the nearest silhouette pixel s*(p),
    rows from `base`, accumulated into ``g``, ``parts[0]``, ``sens`` and ``gn``."""
    k, dist, rational, R, t = camera
    n_par = sJ.shape[2]
    u0, v0, w, hgt = roi[0], roi[1], roi[2], roi[3]
    for i in range(sw.shape[0]):
        z = _project(k, dist, rational, R, t, sw[i], sJ[i], uv, J2)
        row = base + 2 * i
        if not (z > 0.0 and np.isfinite(uv[0]) and np.isfinite(uv[1])):
            continue  # behind the camera: no match (rows stay zero)
        for col in range(n_par):
            sens[col] += a_s * a_s * (J2[0, col] * J2[0, col] + J2[1, col] * J2[1, col])
        iu = np.floor(uv[0] + 0.5)
        iv = np.floor(uv[1] + 0.5)
        cu = int(min(max(iu - u0, 0.0), w - 1.0))
        cv = int(min(max(iv - v0, 0.0), hgt - 1.0))
        nearest = labels[cv, cu] - 1  # the silhouette pixel s*(p)
        tu = silhouette[nearest, 0]
        tv = silhouette[nearest, 1]
        if tu == iu and tv == iv:
            continue  # inside the silhouette
        d0 = uv[0] - tu
        d1 = uv[1] - tv
        parts[0] += d0 * d0 + d1 * d1
        e0 = a_s * d0
        e1 = a_s * d1
        r[row] = e0
        r[row + 1] = e1
        for col in range(n_par):
            j0 = a_s * J2[0, col]
            j1 = a_s * J2[1, col]
            g[col] += e0 * j0 + e1 * j1
            gn[col] += j0 * j0 + j1 * j1
            if want_jacobian:
                J[row, col] = j0
                J[row + 1, col] = j1


@njit(cache=True)
def _model_image(camera, cw, cJ, prim_radii, pc, prho, visible, dth, uv,
                 J2):  # fmt: skip  # pragma: no cover - compiled
    """The model's image in one camera, cone-spheres as hulls of circles: each sphere's
    projected centre ``pc`` and radius ``prho`` (0 and not ``visible`` where the camera
    is inside or behind it), and their derivatives ``dth`` (q, (u0, v0, u1, v1, ρ0, ρ1),
    parameter)."""
    k, dist, rational, R, t = camera
    n_par = cJ.shape[3]
    f = 0.5 * (k[0] + k[1])
    for q in range(cw.shape[0]):
        vis = True
        for e in range(2):
            z = _project(k, dist, rational, R, t, cw[q, e], cJ[q, e], uv, J2)
            pc[q, e, 0] = uv[0]
            pc[q, e, 1] = uv[1]
            rad = prim_radii[q, e]
            zz = z * z - rad * rad
            if z > rad:
                rho = f * rad / np.sqrt(zz)
            else:
                rho = 0.0
                vis = False
            prho[q, e] = rho
            for col in range(n_par):
                dth[q, 2 * e, col] = J2[0, col]
                dth[q, 2 * e + 1, col] = J2[1, col]
                # ρ = f r (z² − r²)^(−1/2): dρ = −ρ z/(z² − r²) dz, dz = R[2] · dc
                dz = R[2, 0] * cJ[q, e, 0, col] + R[2, 1] * cJ[q, e, 1, col]
                dz += R[2, 2] * cJ[q, e, 2, col]
                dth[q, 4 + e, col] = -rho * z / zz * dz if vis else 0.0
        visible[q] = vis


@njit(cache=True)
def _filling_rows(pixels, pc, prho, axes, visible, dth, a_f, base, want_jacobian, r, J, g,
                  parts, gn):  # fmt: skip  # pragma: no cover - compiled
    """C_f of one camera: each silhouette pixel sample against the nearest point h of the
    model's image, rows from `base`, accumulated into ``g``, ``parts[1]`` and ``gn``."""
    n_par = dth.shape[2]
    h = np.empty(2)
    dh6 = np.empty((2, 6))
    for i in range(pixels.shape[0]):
        row = base + 2 * i
        s0 = pixels[i, 0]
        s1 = pixels[i, 1]
        q, d = closest_point_on_union(s0, s1, pc, prho, axes, visible, h, dh6)
        if q < 0 or d <= 0.0:
            continue  # covered by the model
        d0 = h[0] - s0
        d1 = h[1] - s1
        parts[1] += d0 * d0 + d1 * d1
        e0 = a_f * d0
        e1 = a_f * d1
        r[row] = e0
        r[row + 1] = e1
        for col in range(n_par):
            j0 = 0.0
            j1 = 0.0
            for c in range(6):
                j0 += dh6[0, c] * dth[q, c, col]
                j1 += dh6[1, c] * dth[q, c, col]
            j0 *= a_f
            j1 *= a_f
            g[col] += e0 * j0 + e1 * j1
            gn[col] += j0 * j0 + j1 * j1
            if want_jacobian:
                J[row, col] = j0
                J[row + 1, col] = j1


# --- the numpy route -----------------------------------------------------------------------


def cost_reference(
    hand, rig: Rig, frame: FrameData, samples: Samples, x, settings: CostSettings | None = None
) -> CostTerms:
    """The cost and gradient computed with the public numpy routines (slow, for checks).

    Same definition as `SilhouetteCost.evaluate` (without the residual Jacobian), through
    ``HandModel.points``, ``Camera.project_jacobian`` and
    ``HandModel.closest_projected_point``.
    """
    settings = CostSettings() if settings is None else settings
    x = check_pose(x, "x")
    active = frame.counts > 0
    n_active = int(active.sum())
    N, M = samples.bone.shape[0], samples.pixels.shape[1]
    scale2 = settings.pixel_scale**2
    p, Jp = hand.points(x, samples.bone, samples.local, jacobian=True)
    sum_s = sum_f = 0.0
    g_s = np.zeros(N_PARAMS)
    g_f = np.zeros(N_PARAMS)
    for j, cam in enumerate(rig):
        if not active[j]:
            continue
        uv, Jc = cam.project_jacobian(p)
        J2 = Jc @ Jp  # (N, 2, 26)
        u0, v0, w, h = frame.roi[j]
        iuv = np.floor(uv + 0.5)
        cu = np.clip(iuv[:, 0] - u0, 0, w - 1).astype(int)
        cv = np.clip(iuv[:, 1] - v0, 0, h - 1).astype(int)
        target = frame.nearest[j, cv, cu]
        inside = np.all(target == iuv, axis=1)
        res = np.where(inside[:, None], 0.0, uv - target)  # p − s*(p)
        sum_s += 0.5 * np.sum(res * res)
        g_s += np.einsum("nk,nkp->p", res, J2)
        s_hat = samples.pixels[j]
        hh, dh = hand.closest_projected_point(x, cam, s_hat)
        res_f = hh - s_hat
        sum_f += 0.5 * np.sum(res_f * res_f)
        g_f += np.einsum("nk,nkp->p", res_f, dh)
    c_s = sum_s / (N * n_active * scale2)
    c_f = sum_f / (M * n_active * scale2)
    g = (
        settings.weight_silhouette * g_s / (N * n_active)
        + settings.weight_filling * g_f / (M * n_active)
    ) / scale2
    cost = settings.weight_silhouette * c_s + settings.weight_filling * c_f
    return CostTerms(float(cost), float(c_s), float(c_f), g)
