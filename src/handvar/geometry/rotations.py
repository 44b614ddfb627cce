"""The shortest rotation between two directions."""

from __future__ import annotations

import numpy as np

__all__ = ["shortest_rotation"]


def shortest_rotation(u, v) -> np.ndarray:
    """The rotation Q with Q u = v for unit vectors u, v, about u × v (Rodrigues).

    Parameters
    ----------
    u, v : (3,) array_like
        Unit vectors less than 180° apart.

    Returns
    -------
    (3, 3) ndarray

    Examples
    --------
    >>> Q = shortest_rotation([1.0, 0.0, 0.0], [0.0, 1.0, 0.0])
    >>> (Q @ [1.0, 0.0, 0.0]).round(12) + 0.0, (Q @ [0.0, 0.0, 1.0]).round(12) + 0.0
    (array([0., 1., 0.]), array([0., 0., 1.]))
    """
    u, v = np.asarray(u, dtype=float), np.asarray(v, dtype=float)
    w = np.cross(u, v)
    c = float(u @ v)
    if c < -1.0 + 1e-12:
        raise ValueError("u, v: expected directions less than 180° apart; got opposite ones")
    K = np.array([[0.0, -w[2], w[1]], [w[2], 0.0, -w[0]], [-w[1], w[0], 0.0]])
    return np.eye(3) + K + K @ K / (1.0 + c)
