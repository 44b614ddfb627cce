"""Pinhole cameras with OpenCV lens distortion, stereo rigs and calibration files.

Conventions (design §3), the same as OpenCV's:

- lengths in millimetres, image coordinates in pixels;
- ``x_cam = R @ x_world + t`` (``R``, ``t``: world → camera);
- camera frame: x to the right of the image, y down the image, z along the optical axis;
- pixel ``(u, v)``: column ``u``, row ``v``; integer coordinates are pixel centres, so
  pixel ``mask[i, j]`` is centred on ``(u, v) = (j, i)``;
- lens distortion: OpenCV's model with coefficients ``(k1, k2, p1, p2, k3)`` or the
  rational ``(k1, k2, p1, p2, k3, k4, k5, k6)`` (:mod:`handvar.geometry.distortion`).

Calibration files
-----------------
:meth:`Rig.save` writes, and :meth:`Rig.load` reads, ``cv2.FileStorage`` files (YAML
``.yml``/``.yaml``, XML ``.xml`` or JSON ``.json``, chosen by the extension) with this
layout::

    cameras:                        # a sequence, one map per camera
      - name: left
        image_width: 640            # pixels
        image_height: 480
        camera_matrix: 3x3          # K = [[fx, 0, cx], [0, fy, cy], [0, 0, 1]]
        dist_coeffs: 1x5            # k1 k2 p1 p2 k3 (or 1x8 with k4 k5 k6)
        R: 3x3                      # world -> camera rotation
        T: 3x1                      # world -> camera translation, mm

:meth:`Rig.load` also reads three layouts written by other OpenCV programs:

- the stereo layout of ``cv2.stereoCalibrate`` users: ``K1`` (or ``M1``), ``D1``,
  ``K2`` (or ``M2``), ``D2``, ``R``, ``T`` where ``R``, ``T`` map camera-1 coordinates to
  camera-2 coordinates; camera 1 is put at the world origin (``R = I``, ``T = 0``);
- the single-camera layout of OpenCV's calibration sample: ``camera_matrix`` (or ``K``),
  ``distortion_coefficients`` (or ``dist_coeffs``, ``D``), optional ``R``, ``T``;
- the rectified stereo layout ``cv2.stereoRectify`` writes: ``P1`` and ``P2``, the 3×4
  projection matrices of the rectified cameras, in a file without ``K1``/``M1`` (with
  both, the frames are taken as not rectified); the world is the rectified camera 1's
  frame and the cameras have no distortion.

In every layout the image size is ``image_width`` and ``image_height`` or a two-element
sequence ``image_size``/``imageSize`` (width, height); the stereo layouts have one size
for both cameras. When a file has no size, pass ``size=`` or ``default_size=`` to
:meth:`Rig.load` (the recordings' size, when they are opened with it). A
``camera_matrix`` may be spelled ``K`` and ``dist_coeffs`` ``D`` or
``distortion_coefficients`` everywhere; ``T`` may be ``t``.

A ``.toml`` file is read as the camera group anipose writes (``aniposelib``'s
``CameraGroup.dump``; FreeMoCap's calibrations are the same): one table per camera
(``cam_0``, ``cam_1``, … taken in the order ``aniposelib`` loads them, their names
sorted; ``metadata`` skipped) with ``name``, ``size`` (width, height), ``matrix`` (K),
``distortions``, ``rotation`` (a Rodrigues vector) and ``translation``, world → camera.
Its lengths are taken as millimetres (anipose and FreeMoCap measure the board in mm).
A fisheye camera (``fisheye = true``) is refused: the model holds OpenCV's pinhole
distortion only.

One concept in one module, the calibrated camera: its model, the rig of several and
their calibration files. The distortion's formula lives in `handvar.geometry.distortion`.
"""

from __future__ import annotations

import functools
import os
import tomllib
from collections.abc import Iterator, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import cv2
import numpy as np

from handvar.atomic import write_atomic
from handvar.geometry.distortion import (
    distort,
    distort_normalized,
    distortion_coefficients,
    padded,
)
from handvar.geometry.rotations import shortest_rotation
from handvar.validate import as_array, as_float, as_instance, readonly

__all__ = ["IN_FRONT_DEPTH", "Camera", "PackedRig", "Rig", "check_in_front"]


# --- Camera --------------------------------------------------------------------------


@dataclass(frozen=True, eq=False)
class Camera:
    """A calibrated pinhole camera with OpenCV lens distortion.

    Parameters
    ----------
    fx, fy : float
        Focal lengths, pixels.
    cx, cy : float
        Principal point, pixels (integer coordinates are pixel centres).
    dist : (5,) or (8,) array_like, optional
        OpenCV distortion ``k1 k2 p1 p2 k3 [k4 k5 k6]``; 4 values are padded with
        ``k3 = 0``. Zeros (no distortion) by default.
    R : (3, 3) array_like, optional
        World → camera rotation (orthonormal, det +1). Identity by default.
    t : (3,) array_like, optional
        World → camera translation, mm: ``x_cam = R x_world + t``.
    size : (int, int), optional
        Image ``(width, height)``, pixels. ``(640, 480)`` by default.

    Examples
    --------
    >>> cam = Camera(600.0, 600.0, 320.0, 240.0, t=[0.0, 0.0, 500.0])
    >>> cam.project([[0.0, 0.0, 0.0], [50.0, 0.0, 0.0]]).round(3)
    array([[320., 240.],
           [380., 240.]])
    """

    fx: float
    fy: float
    cx: float
    cy: float
    dist: np.ndarray = field(default_factory=lambda: np.zeros(5))
    R: np.ndarray = field(default_factory=lambda: np.eye(3))
    t: np.ndarray = field(default_factory=lambda: np.zeros(3))
    size: tuple[int, int] = (640, 480)

    def __post_init__(self) -> None:
        for name in ("fx", "fy", "cx", "cy"):
            object.__setattr__(self, name, as_float(getattr(self, name), name))
        if self.fx <= 0 or self.fy <= 0:
            raise ValueError(f"fx, fy: expected positive focal lengths; got {self.fx}, {self.fy}")
        R = as_array(self.R, "R", (3, 3))
        if not np.allclose(R @ R.T, np.eye(3), atol=1e-6) or np.linalg.det(R) < 0:
            raise ValueError("R: expected a rotation matrix (orthonormal, det +1); got " + repr(R))
        object.__setattr__(self, "R", readonly(R))
        object.__setattr__(self, "t", readonly(as_array(self.t, "t", (3,))))
        object.__setattr__(self, "dist", readonly(distortion_coefficients(self.dist)))
        try:
            w, h = (int(v) for v in self.size)
        except (TypeError, ValueError):
            raise TypeError(f"size: expected (width, height); got {self.size!r}") from None
        if w <= 0 or h <= 0 or (w, h) != tuple(self.size):
            raise ValueError(f"size: expected positive integers (width, height); got {self.size}")
        object.__setattr__(self, "size", (w, h))

    # -- equality (array fields) --
    def __eq__(self, other: object) -> bool:
        if not isinstance(other, Camera):
            return NotImplemented
        return (
            (self.fx, self.fy, self.cx, self.cy, self.size)
            == (other.fx, other.fy, other.cx, other.cy, other.size)
            and np.array_equal(self.dist, other.dist)
            and np.array_equal(self.R, other.R)
            and np.array_equal(self.t, other.t)
        )

    __hash__ = None  # type: ignore[assignment]

    def allclose(self, other: Camera, *, rtol: float = 1e-9, atol: float = 1e-9) -> bool:
        """True when every parameter of `other` equals this camera's within tolerance."""
        return (
            self.size == other.size
            and np.allclose(
                [self.fx, self.fy, self.cx, self.cy],
                [other.fx, other.fy, other.cx, other.cy],
                rtol=rtol,
                atol=atol,
            )
            and self.dist.shape == other.dist.shape
            and np.allclose(self.dist, other.dist, rtol=rtol, atol=atol)
            and np.allclose(self.R, other.R, rtol=rtol, atol=atol)
            and np.allclose(self.t, other.t, rtol=rtol, atol=atol)
        )

    # -- derived quantities --
    @property
    def K(self) -> np.ndarray:
        """(3, 3) intrinsic matrix ``[[fx, 0, cx], [0, fy, cy], [0, 0, 1]]``."""
        return np.array([[self.fx, 0.0, self.cx], [0.0, self.fy, self.cy], [0.0, 0.0, 1.0]])

    @property
    def width(self) -> int:
        """Image width, pixels."""
        return self.size[0]

    @property
    def height(self) -> int:
        """Image height, pixels."""
        return self.size[1]

    @property
    def center(self) -> np.ndarray:
        """(3,) world position of the optical centre, mm: ``-Rᵀ t``."""
        return -self.R.T @ self.t

    @property
    def axis(self) -> np.ndarray:
        """(3,) unit optical axis (camera +z) in world coordinates."""
        return self.R[2].copy()

    @functools.cached_property
    def has_distortion(self) -> bool:
        """True when any distortion coefficient is non-zero (`dist` is read-only)."""
        return bool(np.any(self.dist))

    # -- geometry --
    def camera_from_world(self, points) -> np.ndarray:
        """Map (N, 3) world points (mm) to (N, 3) camera coordinates (mm)."""
        points = as_array(points, "points", (None, 3))
        return points @ self.R.T + self.t

    def pixels_from_normalized(self, xy: np.ndarray) -> np.ndarray:
        """Distort (N, 2) normalised coordinates and apply K: (N, 2) pixels."""
        xy = as_array(xy, "xy", (None, 2))
        if self.has_distortion:
            xy = distort_normalized(xy, self.dist)
        return xy * (self.fx, self.fy) + (self.cx, self.cy)

    def project(self, points) -> np.ndarray:
        """Project world points to pixels, with lens distortion.

        Parameters
        ----------
        points : (N, 3) array_like
            World points, mm. Points must lie in front of the camera (z_cam > 0);
            others are projected by the same formula, as ``cv2.projectPoints`` does.

        Returns
        -------
        (N, 2) ndarray
            Pixel coordinates ``(u, v)``.
        """
        return self.project_jacobian(points, jacobian=False)[0]

    def project_jacobian(self, points, *, jacobian: bool = True):
        """Project world points and return the analytic Jacobian of the projection.

        Parameters
        ----------
        points : (N, 3) array_like
            World points, mm.
        jacobian : bool, optional
            Compute the Jacobian (default True).

        Returns
        -------
        pixels : (N, 2) ndarray
            Pixel coordinates.
        J : (N, 2, 3) ndarray or None
            ``d pixels / d points``, pixels per mm (world coordinates), including
            distortion.
        """
        Xc = self.camera_from_world(points)
        z = Xc[:, 2]
        with np.errstate(divide="ignore", invalid="ignore"):
            inv_z = 1.0 / z
        xy = Xc[:, :2] * inv_z[:, None]  # pinhole: (X/Z, Y/Z)
        f = np.array([self.fx, self.fy])
        if self.has_distortion:
            xyd, Jd = distort(xy, self.dist, jacobian=jacobian)
        else:
            xyd, Jd = xy, None
        pixels = xyd * f + (self.cx, self.cy)
        if not jacobian:
            return pixels, None
        # d(x, y)/d Xc = [[1/Z, 0, -X/Z²], [0, 1/Z, -Y/Z²]]
        Jp = np.zeros((Xc.shape[0], 2, 3))
        Jp[:, 0, 0] = inv_z
        Jp[:, 1, 1] = inv_z
        Jp[:, :, 2] = -xy * inv_z[:, None]
        if Jd is not None:
            Jp = Jd @ Jp
        # d pixels / d x_world = diag(fx, fy) · d(xd, yd)/d(x, y) · d(x, y)/d Xc · R
        J = (f[None, :, None] * Jp) @ self.R
        return pixels, J

    def rays(self, pixels) -> tuple[np.ndarray, np.ndarray]:
        """Back-project pixels to world rays.

        Parameters
        ----------
        pixels : (N, 2) array_like
            Pixel coordinates ``(u, v)``.

        Returns
        -------
        origins : (N, 3) ndarray
            The optical centre, repeated, mm (world).
        directions : (N, 3) ndarray
            Unit ray directions (world). With distortion, pixels are undistorted by
            ``cv2.undistortPoints`` (iterative; accurate to about 1e-6 in normalised
            coordinates for calibrations with moderate distortion).
        """
        pixels = as_array(pixels, "pixels", (None, 2))
        if self.has_distortion and pixels.shape[0]:
            criteria = (cv2.TERM_CRITERIA_COUNT | cv2.TERM_CRITERIA_EPS, 50, 1e-12)
            xy = cv2.undistortPoints(
                pixels.reshape(-1, 1, 2),
                self.K,
                self.dist,
                R=np.eye(3),
                P=np.eye(3),
                criteria=criteria,
            ).reshape(-1, 2)
        else:
            xy = (pixels - (self.cx, self.cy)) / (self.fx, self.fy)
        d = np.concatenate([xy, np.ones((xy.shape[0], 1))], axis=1)
        d /= np.linalg.norm(d, axis=1, keepdims=True)
        directions = d @ self.R  # Rᵀ d for each row
        origins = np.broadcast_to(self.center, directions.shape).copy()
        return origins, directions

    def ray_rotation(self, pixel) -> np.ndarray:
        """The rotation from a view along the ray through `pixel` to this camera's axes.

        A detector that works on a crop around the hand (MediaPipe) gives its 3D as a
        camera looking straight at the crop would see it: in axes whose z is the ray
        through the crop.  This is the shortest rotation taking the optical axis
        (0, 0, 1) onto that ray's direction, both in this camera's axes, so that
        ``points @ R.T`` turns such 3D into this camera's axes.  Near the image's centre
        it is nearly the identity; at the border of a wide image, tens of degrees.

        Parameters
        ----------
        pixel : (2,) array_like
            Pixel coordinates ``(u, v)``.

        Returns
        -------
        (3, 3) ndarray
        """
        _, d = self.rays(np.asarray(pixel, dtype=float).reshape(1, 2))
        return shortest_rotation((0.0, 0.0, 1.0), self.R @ d[0])

    def in_image(self, pixels) -> np.ndarray:
        """(N,) bool: pixel coordinates inside the image (pixel-centre convention)."""
        pixels = as_array(pixels, "pixels", (None, 2))
        w, h = self.size
        return (
            (pixels[:, 0] >= -0.5)
            & (pixels[:, 0] < w - 0.5)
            & (pixels[:, 1] >= -0.5)
            & (pixels[:, 1] < h - 0.5)
        )

    # -- constructors --
    @classmethod
    def look_at(
        cls,
        eye,
        target=(0.0, 0.0, 0.0),
        up=(0.0, -1.0, 0.0),
        *,
        fx: float = 650.0,
        fy: float | None = None,
        cx: float | None = None,
        cy: float | None = None,
        size: tuple[int, int] = (640, 480),
        dist=None,
    ) -> Camera:
        """A camera at `eye` looking at `target`, with world direction `up` up the image.

        Parameters
        ----------
        eye, target : (3,) array_like
            Optical centre and a point on the optical axis, mm (world).
        up : (3,) array_like, optional
            World direction that should point up in the image (camera −y); by default
            world −y, so the camera y axis is close to world +y.
        fx, fy : float, optional
            Focal lengths, pixels (``fy`` defaults to ``fx``).
        cx, cy : float, optional
            Principal point; the image centre ``((w-1)/2, (h-1)/2)`` by default.
        size : (int, int), optional
            Image (width, height).
        dist : array_like, optional
            Distortion coefficients.
        """
        eye = as_array(eye, "eye", (3,))
        target = as_array(target, "target", (3,))
        up = as_array(up, "up", (3,))
        z = target - eye
        if np.linalg.norm(z) == 0:
            raise ValueError("target: expected a point different from eye; got the same point")
        z /= np.linalg.norm(z)
        y = -(up - (up @ z) * z)  # camera y points down the image
        if np.linalg.norm(y) < 1e-9:
            raise ValueError("up: expected a direction not parallel to the optical axis")
        y /= np.linalg.norm(y)
        x = np.cross(y, z)
        R = np.stack([x, y, z])  # rows: camera axes in world coordinates
        w, h = size
        return cls(
            fx=fx,
            fy=fx if fy is None else fy,
            cx=(w - 1) / 2.0 if cx is None else cx,
            cy=(h - 1) / 2.0 if cy is None else cy,
            dist=np.zeros(5) if dist is None else dist,
            R=R,
            t=-R @ eye,
            size=size,
        )

    # -- serialisation --
    def to_dict(self) -> dict[str, Any]:
        """JSON-friendly description (lists of floats)."""
        return {
            "fx": self.fx,
            "fy": self.fy,
            "cx": self.cx,
            "cy": self.cy,
            "dist": self.dist.tolist(),
            "R": self.R.tolist(),
            "t": self.t.tolist(),
            "size": list(self.size),
        }

    @classmethod
    def from_dict(cls, data: dict[str, Any], *, where: str = "camera") -> Camera:
        """Inverse of :meth:`to_dict`; errors name the missing key and `where`."""
        as_instance(data, dict, where, what="a mapping")
        missing = [k for k in ("fx", "fy", "cx", "cy", "R", "t", "size") if k not in data]
        if missing:
            raise ValueError(f"{where}: missing key {missing[0]!r}")
        try:
            return cls(
                fx=data["fx"],
                fy=data["fy"],
                cx=data["cx"],
                cy=data["cy"],
                dist=data.get("dist", np.zeros(5)),
                R=data["R"],
                t=data["t"],
                size=tuple(data["size"]),
            )
        except (TypeError, ValueError) as exc:
            raise type(exc)(f"{where}: {exc}") from None

    def scaled(self, factor: float) -> Camera:
        """The same camera for images resized by `factor` (``cv2.resize``'s pixel grid).

        A pixel centre ``u`` of the original image maps to ``(u + ½)·s − ½`` in the resized
        one, with ``s`` the exact ratio of the integer sizes per axis (``round(W·factor) /
        W``), so ``fx' = s fx`` and ``cx' = (cx + ½) s − ½``.  Distortion acts on
        normalised coordinates and is unchanged, as are R and t.

        Parameters
        ----------
        factor : float
            Resize factor, > 0.

        Returns
        -------
        Camera
            With image size ``(round(W·factor), round(H·factor))``.

        Examples
        --------
        >>> Camera(500.0, 500.0, 319.5, 239.5, size=(640, 480)).scaled(0.5).cx
        159.5
        """
        from handvar.validate import as_float

        factor = as_float(factor, "factor", minimum=0.0, exclusive_minimum=True)
        w, h = self.size
        w2, h2 = max(1, round(w * factor)), max(1, round(h * factor))
        sx, sy = w2 / w, h2 / h
        return Camera(
            self.fx * sx,
            self.fy * sy,
            (self.cx + 0.5) * sx - 0.5,
            (self.cy + 0.5) * sy - 0.5,
            dist=self.dist,
            R=self.R,
            t=self.t,
            size=(w2, h2),
        )

    @classmethod
    def assumed(cls, size: tuple[int, int], *, fov: float) -> Camera:
        """A camera for uncalibrated monocular video, from an assumed field of view.

        The camera sits at the world origin looking along world +z (``R = I``, ``t = 0``),
        image x to the right and y down; square pixels, no distortion, principal point at
        the image centre, and the focal length that gives the horizontal field of view
        `fov`: ``fx = fy = (W / 2) / tan(fov / 2)``.

        Depth is only as good as this guess: the tracker places a hand of the model's size
        at the distance where its image has the observed size, so a focal length off by
        k % puts the hand k % too near or too far (its image position and shape are
        unaffected).

        Parameters
        ----------
        size : (int, int)
            Image (width, height), pixels.
        fov : float, keyword-only
            Horizontal field of view, degrees, in (0, 180).

        Returns
        -------
        Camera

        Examples
        --------
        >>> cam = Camera.assumed((1280, 720), fov=60.0)
        >>> round(cam.fx, 1), cam.cx, cam.cy
        (1108.5, 639.5, 359.5)
        """
        import math

        from handvar.validate import as_float, as_instance, as_int

        as_instance(size, (tuple, list, np.ndarray), "size", what="(width, height) in pixels")
        if len(size) != 2:
            raise ValueError(f"size: expected (width, height) in pixels; got {size!r}")
        w, h = (as_int(v, "size", minimum=1) for v in size)
        fov = as_float(fov, "fov", minimum=0.0, maximum=180.0)
        if fov in (0.0, 180.0):
            raise ValueError(f"fov: expected a field of view in (0, 180) degrees; got {fov}")
        f = 0.5 * w / math.tan(math.radians(0.5 * fov))
        return cls(f, f, (w - 1) / 2.0, (h - 1) / 2.0, size=(w, h))


# --- Rig -----------------------------------------------------------------------------


@dataclass(frozen=True)
class RigSettings:
    """The convergent stereo pair of paper §2 (figure 1).

    Two 640×480 cameras on the world −z side, ``distance`` from the world origin,
    ``baseline`` apart along world x, optical axes crossing at the origin (where the
    hand is), image up = world −y. ``focal`` makes a 185 mm hand about half the image
    height tall.
    """

    distance: float = 500.0  # mm, optical centre to the origin
    baseline: float = 220.0  # mm
    focal: float = 650.0  # pixels
    size: tuple[int, int] = (640, 480)
    names: tuple[str, str] = ("left", "right")


@dataclass(frozen=True, eq=False)
class PackedRig:
    """The parameters of a rig's n cameras in arrays (`Rig.packed`).

    Attributes
    ----------
    intrinsics : (n, 4) ndarray
        ``fx, fy, cx, cy`` per camera, pixels.
    dist : (n, 8) ndarray
        Distortion coefficients padded with zeros to ``k1 k2 p1 p2 k3 k4 k5 k6``.
    rational : (n,) bool ndarray
        The camera uses the rational model (``k4 k5 k6``).
    R : (n, 3, 3) ndarray
        World → camera rotations.
    t : (n, 3) ndarray
        World → camera translations, mm.
    size : (n, 2) int64 ndarray
        Image (width, height), pixels.
    """

    intrinsics: np.ndarray
    dist: np.ndarray
    rational: np.ndarray
    R: np.ndarray
    t: np.ndarray
    size: np.ndarray


@dataclass(frozen=True)
class Rig:
    """Several cameras observing the same scene, with names.

    Parameters
    ----------
    cameras : sequence of Camera
    names : sequence of str, optional
        One unique name per camera; ``cam0, cam1, ...`` by default.

    Examples
    --------
    >>> rig = Rig.default()
    >>> rig.names, len(rig), rig["left"].size
    (('left', 'right'), 2, (640, 480))
    """

    cameras: tuple[Camera, ...]
    names: tuple[str, ...] = ()

    def __post_init__(self) -> None:
        cams = tuple(self.cameras)
        if not cams:
            raise ValueError("cameras: expected at least one camera; got none")
        for i, cam in enumerate(cams):
            as_instance(cam, Camera, f"cameras[{i}]")
        names = tuple(str(n) for n in self.names) or tuple(f"cam{i}" for i in range(len(cams)))
        if len(names) != len(cams):
            raise ValueError(f"names: expected {len(cams)} names; got {len(names)}")
        if len(set(names)) != len(names):
            raise ValueError(f"names: expected unique names; got {names}")
        object.__setattr__(self, "cameras", cams)
        object.__setattr__(self, "names", names)

    def __len__(self) -> int:
        return len(self.cameras)

    def __iter__(self) -> Iterator[Camera]:
        return iter(self.cameras)

    def __getitem__(self, key: int | str) -> Camera:
        if isinstance(key, str):
            try:
                return self.cameras[self.names.index(key)]
            except ValueError:
                raise ValueError(
                    f"camera: expected one of {', '.join(self.names)}; got {key!r}"
                ) from None
        return self.cameras[key]

    def allclose(self, other: Rig, **tol: float) -> bool:
        """True when names match and every camera agrees within tolerance."""
        return (
            self.names == other.names
            and len(self) == len(other)
            and all(a.allclose(b, **tol) for a, b in zip(self, other, strict=True))
        )

    @classmethod
    def default(cls, defaults: RigSettings | None = None) -> Rig:
        """The paper's convergent stereo pair (see :class:`RigSettings`)."""
        d = RigSettings() if defaults is None else defaults
        half = d.baseline / 2.0
        z = -np.sqrt(d.distance**2 - half**2)
        cams = tuple(
            Camera.look_at((sx * half, 0.0, z), (0.0, 0.0, 0.0), fx=d.focal, size=d.size)
            for sx in (-1.0, 1.0)
        )
        return cls(cams, d.names)

    def packed(self) -> PackedRig:
        """The cameras' parameters stacked in arrays, for compiled loops (`PackedRig`)."""
        dist = np.zeros((len(self), 8))
        rational = np.zeros(len(self), dtype=np.bool_)
        for j, cam in enumerate(self.cameras):
            dist[j], rational[j] = padded(cam.dist)
        return PackedRig(
            intrinsics=np.array([[c.fx, c.fy, c.cx, c.cy] for c in self.cameras]),
            dist=dist,
            rational=rational,
            R=np.ascontiguousarray([c.R for c in self.cameras], dtype=float),
            t=np.ascontiguousarray([c.t for c in self.cameras], dtype=float),
            size=np.array([c.size for c in self.cameras], dtype=np.int64),
        )

    # -- dictionaries --
    def to_dict(self) -> dict[str, Any]:
        """JSON-friendly description: ``{"cameras": [{"name": ..., **Camera.to_dict()}]}``."""
        return {
            "cameras": [
                {"name": n, **c.to_dict()} for n, c in zip(self.names, self.cameras, strict=True)
            ]
        }

    @classmethod
    def from_dict(cls, data: dict[str, Any]) -> Rig:
        """Inverse of :meth:`to_dict`; errors name the missing key."""
        as_instance(data, dict, "rig", what="a mapping")
        if "cameras" not in data:
            raise ValueError("rig: missing key 'cameras'")
        entries = data["cameras"]
        if not isinstance(entries, Sequence) or isinstance(entries, str):
            raise TypeError(f"rig: expected 'cameras' to be a list; got {type(entries).__name__}")
        if not entries:
            raise ValueError("rig: expected 'cameras' to be a non-empty list; got none")
        cams, names = [], []
        for i, entry in enumerate(entries):
            cams.append(Camera.from_dict(entry, where=f"cameras[{i}]"))
            names.append(entry.get("name", f"cam{i}"))
        return cls(tuple(cams), tuple(names))

    # -- OpenCV files --
    def save(self, path: str | os.PathLike) -> None:
        """Write the rig as an OpenCV ``FileStorage`` file (layout in the module docs).

        The format follows the extension (``.yml``, ``.yaml``, ``.xml``, ``.json``). The
        file is written through `handvar.atomic.write_atomic`, so an existing file is
        never left half-written.
        """
        path = Path(path)
        ext = path.suffix.lower()
        if ext not in (".yml", ".yaml", ".xml", ".json"):
            raise ValueError(f"path: expected a .yml, .yaml, .xml or .json file; got {path}")

        def write(tmp: str) -> None:
            fs = cv2.FileStorage(tmp, cv2.FILE_STORAGE_WRITE)
            if not fs.isOpened():
                raise OSError(f"{path}: cannot open for writing")
            fs.startWriteStruct("cameras", cv2.FileNode_SEQ)
            for name, cam in zip(self.names, self.cameras, strict=True):
                fs.startWriteStruct("", cv2.FileNode_MAP)
                fs.write("name", name)
                fs.write("image_width", cam.width)
                fs.write("image_height", cam.height)
                fs.write("camera_matrix", cam.K)
                fs.write("dist_coeffs", cam.dist.reshape(1, -1))
                fs.write("R", cam.R)
                fs.write("T", cam.t.reshape(3, 1))
                fs.endWriteStruct()
            fs.endWriteStruct()
            fs.release()

        write_atomic(path, write)

    @classmethod
    def load(
        cls,
        path: str | os.PathLike,
        *,
        size: tuple[int, int] | None = None,
        default_size: tuple[int, int] | None = None,
    ) -> Rig:
        """Read a rig from a calibration file (any layout in the module docs).

        Parameters
        ----------
        path : path-like
            An OpenCV ``FileStorage`` file (YAML, XML or JSON), or an anipose camera
            group (``.toml``).
        size : (int, int), optional
            Image (width, height) of every camera; overrides the file.
        default_size : (int, int), optional
            Image (width, height) of a camera the file gives no size (e.g. the output of
            OpenCV's stereo calibration sample).

        Raises
        ------
        FileNotFoundError
            The file does not exist.
        ValueError
            The file cannot be parsed or a key is missing; the message names the file
            and the key.
        """
        path = Path(path)
        if not path.is_file():
            raise FileNotFoundError(f"{path}: calibration file not found")
        size = _size_or_none(size, "size")
        default_size = _size_or_none(default_size, "default_size")
        if path.suffix.lower() == ".toml":
            return _rig_from_anipose(path, size, default_size)
        try:
            fs = cv2.FileStorage(str(path), cv2.FILE_STORAGE_READ)
        except Exception as exc:  # cv2.error or SystemError from the parser
            msg = " ".join(str(exc).split())
            raise ValueError(f"{path}: not a readable OpenCV calibration file ({msg})") from None
        if not fs.isOpened():
            raise ValueError(f"{path}: not a readable OpenCV calibration file")
        try:
            reader = _NodeReader(fs.root(), path, default_size=default_size)
            if not fs.getNode("cameras").empty():
                return _rig_from_cameras(fs.getNode("cameras"), path, size, default_size)
            if reader.has("K1", "M1"):
                return _rig_from_stereo(reader, size)
            if reader.has("P1") and reader.has("P2"):
                return _rig_from_rectified(reader, size)
            if reader.has("camera_matrix", "K"):
                cam = _camera_from_node(reader, size, where=str(path))
                return cls((cam,), ("cam0",))
            raise ValueError(
                f"{path}: missing key 'cameras' (or stereo 'K1', rectified 'P1' and 'P2', "
                "or single 'camera_matrix')"
            )
        finally:
            fs.release()

    def scaled(self, factor: float) -> Rig:
        """Every camera through :meth:`Camera.scaled` (same names)."""
        return Rig(tuple(c.scaled(factor) for c in self), self.names)


#: Depth (mm) a joint must exceed in every camera to count as in front of it (design §13.5).
IN_FRONT_DEPTH = 1.0


def check_in_front(joints, rig: Rig, name: str) -> None:
    """Raise unless every joint lies in front of every camera of `rig` (design §13.5).

    Parameters
    ----------
    joints : (..., 21, 3) array_like
        Joints in the world frame, mm: one hand, or a track of them (frames first).
    rig : Rig
    name : str
        What the joints came from, named in the message.

    Raises
    ------
    ValueError
        Naming `name`, the camera, the nearest depth and, for a track, the frame.
    """
    joints = np.asarray(joints, dtype=float)
    for cam_name, cam in zip(rig.names, rig.cameras, strict=True):
        depth = np.asarray(cam.camera_from_world(joints.reshape(-1, 3)))[:, 2]
        depth = depth.reshape(joints.shape[:-1])
        if not np.all(depth > IN_FRONT_DEPTH):
            frame = ""
            if depth.ndim > 1:
                nearest = depth.reshape(len(depth), -1).min(axis=1)
                frame = f" at frame {int(np.argmax(~(nearest > IN_FRONT_DEPTH)))}"
            raise ValueError(
                f"{name}: expected the hand in front of every camera; it is behind or at "
                f"camera {cam_name!r}{frame} (nearest depth {np.nanmin(depth):.0f} mm)"
            )


class _NodeReader:
    """Typed access to a ``cv2.FileNode`` map with errors naming the file and the key."""

    def __init__(self, node, path: Path, prefix: str = "", default_size=None) -> None:
        self.node = node
        self.path = path
        self.prefix = prefix
        self.default_size = default_size  # where the file has none

    def _get(self, key: str):
        node = self.node.getNode(key)
        return None if node is None or node.empty() or node.isNone() else node

    def has(self, *keys: str) -> bool:
        return any(self._get(k) is not None for k in keys)

    def _first(self, keys: tuple[str, ...], required: bool):
        for k in keys:
            node = self._get(k)
            if node is not None:
                return k, node
        if required:
            raise ValueError(f"{self.path}: missing key {self.prefix}{keys[0]!r}")
        return None, None

    def matrix(self, *keys: str, required: bool = True) -> np.ndarray | None:
        key, node = self._first(keys, required)
        if node is None:
            return None
        if node.isMap():
            mat = node.mat()
        elif node.isSeq():
            mat = np.array([node.at(i).real() for i in range(node.size())])
        else:
            mat = np.array([node.real()])
        if mat is None:
            raise ValueError(f"{self.path}: key {self.prefix}{key!r} is not a matrix")
        return np.asarray(mat, dtype=float)

    def number(self, *keys: str, required: bool = True) -> float | None:
        key, node = self._first(keys, required)
        if node is None:
            return None
        if not node.isReal() and not node.isInt():
            raise ValueError(f"{self.path}: key {self.prefix}{key!r} is not a number")
        return node.real()

    def string(self, *keys: str) -> str | None:
        _, node = self._first(keys, False)
        return None if node is None else node.string()

    def image_size(self, size: tuple[int, int] | None) -> tuple[int, int]:
        if size is not None:
            return (int(size[0]), int(size[1]))
        if self.has("image_width") or self.has("image_height"):
            return (int(self.number("image_width")), int(self.number("image_height")))
        vec = self.matrix("image_size", "imageSize", required=False)
        if vec is None and self.default_size is not None:
            return self.default_size
        if vec is None:
            raise ValueError(
                f"{self.path}: missing key {self.prefix}'image_width' (or 'image_size'); "
                "pass size=(width, height)"
            )
        if vec.size != 2:
            raise ValueError(f"{self.path}: key 'image_size' expected 2 values; got {vec.size}")
        return (int(vec.ravel()[0]), int(vec.ravel()[1]))


def _camera_from_params(
    K: np.ndarray,
    dist,
    R,
    T,
    size: tuple[int, int],
    where: str,
    prefix: str = "",
    key: str = "camera_matrix",
) -> Camera:
    if K.shape != (3, 3):
        raise ValueError(f"{where}: key {prefix}{key!r} expected 3x3; got {K.shape}")
    _check_pinhole(K, f"{where}: key {prefix}{key!r}")
    try:
        return Camera(
            fx=K[0, 0],
            fy=K[1, 1],
            cx=K[0, 2],
            cy=K[1, 2],
            dist=np.zeros(5) if dist is None else np.ravel(dist),
            R=np.eye(3) if R is None else R,
            t=np.zeros(3) if T is None else np.ravel(T),
            size=size,
        )
    except (TypeError, ValueError) as exc:
        raise type(exc)(f"{where}: {prefix}{exc}") from None


def _check_pinhole(K: np.ndarray, where: str) -> None:
    """Raise unless the 3x3 `K` is a pinhole matrix [[fx, 0, cx], [0, fy, cy], [0, 0, 1]].

    The camera model holds fx, fy, cx and cy only: a skew K[0][1], a bottom row other
    than (0, 0, 1) or a nonzero K[1][0] cannot be represented, and reading just the
    four entries would silently project elsewhere than the file says.
    """
    expected = {(0, 1): 0.0, (1, 0): 0.0, (2, 0): 0.0, (2, 1): 0.0, (2, 2): 1.0}
    scale = max(abs(float(K[0, 0])), abs(float(K[1, 1])), 1.0)
    for (i, j), value in expected.items():
        tol = 1e-9 if i == 2 else 1e-9 * scale  # the bottom row is unitless
        if not abs(float(K[i, j]) - value) <= tol:  # also NaN
            what = "no skew" if (i, j) == (0, 1) else "a pinhole matrix"
            raise ValueError(
                f"{where}: expected {what} (K[{i}][{j}] = {value:g}, the camera model holds "
                f"fx, fy, cx, cy only); got K[{i}][{j}] = {float(K[i, j]):g}"
            )


def _camera_from_node(reader: _NodeReader, size, where: str) -> Camera:
    return _camera_from_params(
        reader.matrix("camera_matrix", "K"),
        reader.matrix("dist_coeffs", "distortion_coefficients", "D", required=False),
        reader.matrix("R", required=False),
        reader.matrix("T", "t", required=False),
        reader.image_size(size),
        where,
        reader.prefix,
    )


def _rig_from_cameras(seq, path: Path, size, default_size) -> Rig:
    if not seq.isSeq() or seq.size() == 0:
        raise ValueError(f"{path}: key 'cameras' expected a non-empty sequence")
    cams, names = [], []
    for i in range(seq.size()):
        reader = _NodeReader(seq.at(i), path, f"cameras[{i}].", default_size)
        cams.append(_camera_from_node(reader, size, str(path)))
        names.append(reader.string("name") or f"cam{i}")
    return Rig(tuple(cams), tuple(names))


def _rig_from_stereo(reader: _NodeReader, size) -> Rig:
    where = str(reader.path)
    wh = reader.image_size(size)
    K1 = reader.matrix("K1", "M1")
    K2 = reader.matrix("K2", "M2")
    D1 = reader.matrix("D1", required=False)
    D2 = reader.matrix("D2", required=False)
    R = reader.matrix("R")
    T = reader.matrix("T")
    cam1 = _camera_from_params(K1, D1, None, None, wh, where, key="K1")
    cam2 = _camera_from_params(K2, D2, R, T, wh, where, key="K2")
    return Rig((cam1, cam2), ("left", "right"))


def _rig_from_rectified(reader: _NodeReader, size) -> Rig:
    """Two rectified cameras from their projection matrices P = K [R | t] (module docs)."""
    where = str(reader.path)
    wh = reader.image_size(size)
    cams = []
    for key in ("P1", "P2"):
        P = reader.matrix(key)
        if P.shape != (3, 4) or not np.all(np.isfinite(P)):
            raise ValueError(f"{where}: key {key!r} expected a finite 3x4 matrix; got {P.shape}")
        K, R, centre = cv2.decomposeProjectionMatrix(P)[:3]
        if abs(centre[3, 0]) < 1e-12 * np.abs(centre).max():
            raise ValueError(f"{where}: key {key!r} is not a camera's projection matrix")
        K = K / K[2, 2]
        K[np.abs(K) < 1e-9 * np.abs(K).max()] = 0.0  # the decomposition's rounding
        t = -R @ (centre[:3, 0] / centre[3, 0])
        cams.append(_camera_from_params(K, None, R, t, wh, where, key=key))
    return Rig(tuple(cams), ("left", "right"))


def _rig_from_anipose(path: Path, size, default_size) -> Rig:
    """The cameras of an anipose camera group, a ``.toml`` file (module docs)."""
    try:
        with path.open("rb") as f:
            group = tomllib.load(f)
    except (tomllib.TOMLDecodeError, UnicodeDecodeError) as exc:
        raise ValueError(f"{path}: not a readable TOML calibration file ({exc})") from None
    keys = sorted(k for k, v in group.items() if k != "metadata" and isinstance(v, dict))
    if not keys:
        raise ValueError(f"{path}: expected one table per camera ([cam_0], …); got none")
    cams = []
    for key in keys:
        table = group[key]
        if table.get("fisheye", False):
            raise ValueError(
                f"{path}: camera [{key}] is a fisheye camera; expected a pinhole camera "
                "(OpenCV's standard distortion model)"
            )
        entry = functools.partial(_toml_numbers, table, path, key)
        if size is None and ("size" in table or default_size is None):
            wh = tuple(int(v) for v in entry("size", (2,)))
        else:
            wh = size or default_size
        K, dist = entry("matrix", (3, 3)), entry("distortions", None)
        R, t = cv2.Rodrigues(entry("rotation", (3,)))[0], entry("translation", (3,))
        cams.append(_camera_from_params(K, dist, R, t, wh, str(path), f"[{key}].", "matrix"))
    return Rig(tuple(cams), tuple(str(group[k].get("name", k)) for k in keys))


def _toml_numbers(table: dict, path: Path, key: str, name: str, shape) -> np.ndarray:
    """Entry `name` of camera table `key` as finite numbers of `shape` (None: any length)."""
    if name not in table:
        raise ValueError(f"{path}: missing key [{key}].{name}")
    try:
        a = np.array(table[name], dtype=float)
    except (TypeError, ValueError):
        a = np.array([np.nan])
    if (shape is not None and a.shape != shape) or not np.all(np.isfinite(a)):
        what = "a list of" if shape is None else "x".join(map(str, shape))
        raise ValueError(
            f"{path}: key [{key}].{name} expected {what} finite numbers; got {table[name]!r:.60}"
        )
    return a


def _size_or_none(size, name: str) -> tuple[int, int] | None:
    if size is None:
        return None
    wh = tuple(as_array(size, name, what="(width, height) in pixels").ravel())
    if len(wh) != 2 or min(wh) < 1 or any(v != int(v) for v in wh):
        raise ValueError(f"{name}: expected (width, height), two positive integers; got {size!r}")
    return (int(wh[0]), int(wh[1]))
