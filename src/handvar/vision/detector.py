"""The keypoint detector as a stage of the pipeline (design §14.1).

A detector is anything that takes one colour frame and gives the hands it found:
``detector(image) -> list[Detection]`` (an empty list: no hand).  handvar ships one,
MediaPipe Hands (`handvar.vision.mediapipe.MediaPipeHands`, the optional extra); a
user's own (RTMPose, HaMeR, a lab's model) plugs in as a plain callable
``frame -> points`` that `user_detector` checks and wraps:

- ``None``: no hand in the frame;
- a (21, 2) or (21, 3) array: x, y in pixels of the frame given (centres at
  integers), and the confidence of each point in [0, 1] (1 when not given), NaN for
  a point not found;
- a dict with ``points`` as above and optionally ``confidence`` (21,), ``world``
  (21, 3) mm in the camera's axes (any origin) and ``side`` ("right" or "left");
- a `Detection`, or a list of them (several hands).

The 21 points are in the order of `handvar.vision.keypoints.HandLandmark`.

`choose` keeps the hand tracked among those found; `vote_side` reads the side of the
hand from the first detections; `detect_ahead` runs the detectors of every camera in
a worker thread ahead of the fit, so that detection and fitting overlap on two cores.
"""

from __future__ import annotations

import queue
import threading
from collections.abc import Callable, Iterable, Iterator

import numpy as np

from handvar.vision.keypoints import N_KEYPOINTS, Detection, choose, vote_side

__all__ = [
    "DETECTORS",
    "Detection",
    "choose",
    "detect_ahead",
    "make_detectors",
    "user_detector",
    "vote_side",
]

#: The detectors `handvar track --detector` names: "auto" is MediaPipe when it is
#: installed, else none (the silhouette tracker, with a notice).
DETECTORS: tuple[str, ...] = ("auto", "mediapipe", "none")


def user_detector(function: Callable, name: str = "detector") -> Callable:
    """Wrap a user's ``frame -> points`` callable (module notes) as a detector.

    Each call's result is checked; a wrong one raises a ValueError naming `name`,
    what was expected and what came, with the frame's count.

    Examples
    --------
    >>> detect = user_detector(lambda image: np.zeros((21, 2)))
    >>> found = detect(np.zeros((4, 4, 3), np.uint8))
    >>> len(found), found[0].points.shape, float(found[0].points[0, 2])
    (1, (21, 3), 1.0)
    """
    if not callable(function):
        raise TypeError(f"{name}: expected a callable frame -> points; got {function!r}")
    count = [0]

    def detect(image) -> list[Detection]:
        count[0] += 1
        try:
            return _as_detections(function(image))
        except (TypeError, ValueError) as exc:
            raise ValueError(f"{name}: at frame {count[0] - 1}, {exc}") from None

    return detect


def _as_detections(value) -> list[Detection]:
    """A user detector's result (module notes) as a list of `Detection`."""
    if value is None:
        return []
    if isinstance(value, Detection):
        return [value]
    if isinstance(value, list) and all(isinstance(v, Detection) for v in value):
        return list(value)
    if isinstance(value, dict):
        if "points" not in value:
            raise ValueError(f"expected a dict with 'points'; got keys {sorted(value)}")
        points = _points(value["points"])
        if value.get("confidence") is not None:
            c = np.asarray(value["confidence"], dtype=float)
            if c.shape != (N_KEYPOINTS,):
                raise ValueError(f"expected confidence of shape (21,); got {c.shape}")
            points[:, 2] = c
        world = value.get("world")
        if world is not None:
            world = np.asarray(world, dtype=float)
            if world.shape != (N_KEYPOINTS, 3):
                raise ValueError(f"expected world points of shape (21, 3) mm; got {world.shape}")
        return [Detection(points, world, side=str(value.get("side") or ""))]
    return [Detection(_points(value))]


def _points(value) -> np.ndarray:
    try:
        a = np.asarray(value, dtype=float)
    except (TypeError, ValueError):
        raise ValueError(
            f"expected (21, 2) or (21, 3) points (x, y [confidence]); got {type(value).__name__}"
        ) from None
    if a.shape not in ((N_KEYPOINTS, 2), (N_KEYPOINTS, 3)):
        raise ValueError(
            f"expected (21, 2) or (21, 3) points (x, y [confidence]); got shape {a.shape}"
        )
    if np.isinf(a).any():
        raise ValueError("expected finite points or NaN; got infinity")
    if a.shape[1] == 2:
        a = np.concatenate([a, np.ones((N_KEYPOINTS, 1))], axis=1)
    c = a[:, 2]
    if np.any((c < 0) | (c > 1)):
        raise ValueError(f"expected confidences in [0, 1]; got {float(c[(c < 0) | (c > 1)][0])!r}")
    return a.copy()


def mediapipe_available() -> bool:
    """Whether MediaPipe Hands (the optional extra) can be imported."""
    import importlib.util
    import sys

    if "mediapipe" in sys.modules:  # imported already, or masked (None) as not installed
        return sys.modules["mediapipe"] is not None
    return importlib.util.find_spec("mediapipe") is not None


def make_detectors(detector, n_cameras: int, *, mirrored: bool = False) -> list | None:
    """One detector per camera for `detector`, or None for no detector.

    Parameters
    ----------
    detector : {"auto", "mediapipe", "none"}, callable, or None
        "auto": MediaPipe when it is installed, else None; "mediapipe": MediaPipe (an
        error without the extra); a callable: the user's detector (`user_detector`),
        one shared by every camera; None or "none": no detector.
    n_cameras : int
    mirrored : bool, keyword-only
        MediaPipe: the frames are mirrored (a selfie camera), so its labels are literal.

    Raises
    ------
    ValueError
        An unknown name, or "mediapipe" without the extra (saying how to install it).
    """
    if detector is None or (isinstance(detector, str) and detector == "none"):
        return None
    if callable(detector):
        wrapped = user_detector(detector)
        return [wrapped] * n_cameras
    if not isinstance(detector, str) or detector not in DETECTORS:
        raise ValueError(
            f"detector: expected one of {', '.join(DETECTORS)} or a callable frame -> "
            f"points; got {detector!r}"
        )
    if detector == "auto" and not mediapipe_available():
        return None
    from handvar.vision.mediapipe import MediaPipeHands, MissingExtraError

    try:
        return [MediaPipeHands(mirrored=mirrored) for _ in range(n_cameras)]
    except MissingExtraError:
        raise ValueError(
            "detector: mediapipe expected MediaPipe Hands (the optional extra: pip install "
            "'handvar[mediapipe]'); got no mediapipe module"
        ) from None


_END = object()


def detect_ahead(feed: Iterable, detectors: list, *, depth: int = 4) -> Iterator:
    """Run `detectors` on the frames of `feed` in a worker thread, ahead of the consumer.

    Parameters
    ----------
    feed : iterable of (index, seconds, images, originals)
        The frames (`originals`: the full-resolution images the detectors see, one per
        camera).
    detectors : list of callable
        Per camera, ``image -> list[Detection]``.
    depth : int, keyword-only
        Frames detected ahead at most (the queue's size).

    Yields
    ------
    (index, seconds, images, found)
        `found`: per camera the list of hands found.  An error of the feed or of a
        detector is raised here, in the consumer's thread.
    """
    items: queue.Queue = queue.Queue(maxsize=depth)
    stop = threading.Event()

    def work() -> None:
        try:
            for index, seconds, images, originals in feed:
                found = [d(image) for d, image in zip(detectors, originals, strict=True)]
                while not stop.is_set():
                    try:
                        items.put((index, seconds, images, found), timeout=0.1)
                        break
                    except queue.Full:
                        continue
                if stop.is_set():
                    return
            items.put(_END)
        except BaseException as exc:  # handed to the consumer, raised there
            items.put(exc)

    worker = threading.Thread(target=work, name="handvar-detector", daemon=True)
    worker.start()
    try:
        while True:
            item = items.get()
            if item is _END:
                return
            if isinstance(item, BaseException):
                raise item
            yield item
    finally:
        stop.set()
        while worker.is_alive():  # let a worker blocked on a full queue finish
            try:
                items.get_nowait()
            except queue.Empty:
                worker.join(0.05)
