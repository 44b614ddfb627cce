"""Synthetic 2D keypoints of a sequence with ground truth: projected joints, noise, outliers.

A stand-in for a keypoint detector (design §14.2): the true joints G(x_t) projected
into every camera, each coordinate perturbed by Gaussian noise of `noise_px` pixels, and
a fraction `outliers` of the points displaced instead uniformly within ±1 hand size per
axis (the hand size of camera j being f_j · L / z_j, L the wrist → middle-MCP length of
the true joints and z_j the depth of the palm point ½(G_0 + G_9), as in the tracker's
keypoint term).

Examples
--------
>>> import numpy as np
>>> from handvar.synth.sequences import make_sequence
>>> seq = make_sequence("benchmark", n_frames=2)
>>> kp = synthetic_keypoints(seq, rng=np.random.default_rng(0))
>>> kp.shape, float(kp[..., 2].min())
((2, 2, 21, 3), 1.0)
"""

from __future__ import annotations

import numpy as np

from handvar.validate import as_float, as_instance

__all__ = ["hand_size_px", "synthetic_keypoints"]


def hand_size_px(camera, joints) -> np.ndarray:
    """Hand size of each frame in `camera`, pixels: ``f · L / z`` (module docstring).

    Parameters
    ----------
    camera : handvar.camera.Camera
    joints : (T, 21, 3) array_like
        The true points of every frame, world, mm (G(x); only the wrist and the middle
        MCP are used).

    Returns
    -------
    (T,) ndarray
    """
    G = np.asarray(joints, dtype=float)
    L = np.linalg.norm(G[:, 0] - G[:, 9], axis=1)  # (T,) mm
    z = camera.camera_from_world(0.5 * (G[:, 0] + G[:, 9]))[:, 2]
    return 0.5 * (camera.fx + camera.fy) * L / z


def synthetic_keypoints(
    sequence,
    noise_px: float = 3.0,
    outliers: float = 0.1,
    rng: np.random.Generator | None = None,
) -> np.ndarray:
    """Keypoints of every frame and camera of `sequence` from its true joints.

    Parameters
    ----------
    sequence : handvar.io.Sequence
        With ground truth (``sequence.truth.joints``, (T, 21, 3) mm).
    noise_px : float, optional
        Standard deviation of the Gaussian noise per coordinate, pixels (3).
    outliers : float, optional
        Fraction of the points, drawn independently per point, frame and camera, that are
        outliers: the true projection displaced uniformly within ±1 hand size per axis
        (0.1).
    rng : numpy.random.Generator, optional
        ``default_rng(0)`` by default.

    Returns
    -------
    (T, n_cams, 21, 3) ndarray
        x, y (pixels of the sequence's cameras) and confidence 1; ``kp[:, j]`` is camera
        j's (T, 21, 3) array, as `handvar.vision.keypoints.Keypoints2D.from_array` and
        `handvar.tracking.Tracker.track` take.
    """
    from handvar.io import Sequence

    as_instance(sequence, Sequence, "sequence", what="a handvar.io.Sequence")
    if sequence.truth is None:
        raise ValueError("sequence: expected a sequence with ground truth; got none")
    noise_px = as_float(noise_px, "noise_px", minimum=0.0)
    outliers = as_float(outliers, "outliers", minimum=0.0, maximum=1.0)
    rng = np.random.default_rng(0) if rng is None else rng
    as_instance(rng, np.random.Generator, "rng", what="a numpy.random.Generator")
    G = np.asarray(sequence.truth.joints, dtype=float)  # (T, 21, 3)
    T = G.shape[0]
    n_cams = len(sequence.rig)
    out = np.ones((T, n_cams, 21, 3))
    for j, cam in enumerate(sequence.rig):
        uv = cam.project(G.reshape(-1, 3)).reshape(T, 21, 2)
        size = hand_size_px(cam, G)  # (T,) pixels
        noise = rng.normal(0.0, noise_px, (T, 21, 2)) if noise_px > 0 else np.zeros((T, 21, 2))
        bad = rng.random((T, 21)) < outliers
        shift = rng.uniform(-1.0, 1.0, (T, 21, 2)) * size[:, None, None]
        out[:, j, :, :2] = uv + np.where(bad[..., None], shift, noise)
    return out
