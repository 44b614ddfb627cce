"""Keypoints carried between detector frames by optical flow (design §14.5).

A keypoint detector slower than the tracker (`Keypoints2D.every`: at 6 fps beside a
30 fps tracker) leaves the frames between its detections without keypoints; there the
fit rests on the silhouette and the motion prediction alone, and a finger can settle in
the wrong gap of the silhouette.  The image still shows where the detected points went:
each point is followed from frame to frame by pyramidal Lucas–Kanade optical flow
(Bouguet's implementation, `cv2.calcOpticalFlowPyrLK`), starting at the last detection.

For a point p in the grey frame I_{t-1} the flow finds p' in I_t minimising the windowed
brightness difference Σ_w (I_t(q + p' − p) − I_{t-1}(q))², coarse to fine over an image
pyramid.  A point is kept only if the flow found it both ways: tracked back from p' to
I_{t-1} it must land within `CarrySettings.max_error` pixels of p (the forward–backward
check of Kalal, Mikolajczyk and Matas, 2010).  A point that fails it, or that OpenCV
reports as not found, is no longer followed until the next detection: it is *held*,
with its confidence times `CarrySettings.hold` (0 drops it), and moved with the hand:
each frame by the median displacement of the points followed there (while two or more
are).  A point the flow loses is mostly a fast one (a fingertip flicking); where it
was last seen, moved as the rest of the hand moved, is a better guess of it than the
motion prediction's, but a weaker one than a point followed.  Left where it was last
followed instead, it drags the fit back to where the hand was: on the two-hand
benchmark with the detector on every 5th frame a hand moving off the other was pulled
onto it (docs/keypoint-fit.md, "rules").  The carried points keep the detector's
confidence times `CarrySettings.confidence`.  Nothing is carried more than
`CarrySettings.max_frames` frames past a detection.

Carried forward it is causal (frame t uses frames t−1 and t and the detections up to
t), so it runs online beside the tracker (`KeypointCarrier`).  Carried both ways, each
detection is also followed backwards over the frames since the previous one and the two
are blended (`TwoWayCarrier`): a frame's keypoints wait for the next detection, at most
`CarrySettings.max_frames` frames.  `carry_keypoints` carries a whole recording's
keypoints at once.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Iterable
from dataclasses import dataclass

import cv2
import numpy as np

from handvar.validate import as_array, as_float, as_instance, as_int
from handvar.vision.keypoints import N_KEYPOINTS, Keypoints2D, as_frame_keypoints

__all__ = [
    "CARRY_SETTINGS",
    "CarrySettings",
    "KeypointCarrier",
    "TwoWayCarrier",
    "carry_keypoints",
    "until_next_detection",
]


@dataclass(frozen=True)
class CarrySettings:
    """Named settings of the optical-flow carrying (module notes; design §14.5).

    Attributes
    ----------
    window : int
        Side of the Lucas–Kanade window, pixels of the tracked frames; 15 (OpenCV's
        example value; at half resolution a fingertip is about 10 px wide).
    levels : int
        Pyramid levels above the frame; 3 (motions up to about 2³ windows a frame).
    max_error : float
        Forward–backward error above which a point is dropped, pixels; 1.
    confidence : float
        Factor on the detector's confidence of a carried point; 1 (on the example video
        the carried points lie as close to the detector's own as its neighbouring
        detections do, design §14.5).
    max_frames : int
        Frames after a detection beyond which nothing is carried; 30 (one second of
        video at 30 fps).
    hold : float
        Factor on the detector's confidence of a point the flow lost, held and moved
        with the points still followed (module notes); 0 drops it.  0.5, chosen among
        0, 0.5 and 1 on the realistic benchmark and the three real videos with
        keypoints every 5th frame (docs/keypoint-fit.md, "rules").
    hold_frames : int or None
        Frames after a detection for which a lost point is held; after that it is
        dropped.  None (the default): for as long as the others are carried.
    lead_points : int or None
        Carried both ways (`TwoWayCarrier`), the first detection of a run is carried
        back to the frames before it (at most `max_frames`) while the flow still follows
        this many of its points; None carries it back only to the frames the detector
        skipped.  6, chosen among 0, 2, 6 and 11 on the realistic benchmark with
        MediaPipe inside and on the two-hand benchmark's MediaPipe runs (each hand's
        detections alone): 0 put points on 51 frames without the hand, 2 misplaced a
        stereo hand's shape (docs/keypoint-fit.md, "rules").
    """

    window: int = 15
    levels: int = 3
    max_error: float = 1.0
    confidence: float = 1.0
    max_frames: int = 30
    hold: float = 0.5
    hold_frames: int | None = None
    lead_points: int | None = 6

    def __post_init__(self) -> None:
        as_int(self.window, "window", minimum=3)
        as_int(self.levels, "levels", minimum=0)
        as_float(self.max_error, "max_error", minimum=0.0, exclusive_minimum=True)
        as_float(self.confidence, "confidence", minimum=0.0, maximum=1.0,
                 exclusive_minimum=True)  # fmt: skip
        as_int(self.max_frames, "max_frames", minimum=1)
        as_float(self.hold, "hold", minimum=0.0, maximum=1.0)
        if self.hold_frames is not None:
            as_int(self.hold_frames, "hold_frames", minimum=0)
        if self.lead_points is not None:
            as_int(self.lead_points, "lead_points", minimum=0, maximum=N_KEYPOINTS)


CARRY_SETTINGS = CarrySettings()


def until_next_detection(every: int, settings: CarrySettings = CARRY_SETTINGS) -> CarrySettings:
    """`settings` for carrying forward online beside a detector run on every `every`-th
    frame: no farther than its next frame (``every − 1`` frames, at most
    ``settings.max_frames``), where a detection that finds nothing means no hand."""
    every = as_int(every, "every", minimum=2)
    return dataclasses.replace(settings, max_frames=min(every - 1, settings.max_frames))


def _grey(image, name: str) -> np.ndarray:
    if isinstance(image, np.ndarray) and image.dtype == np.uint8:
        a = image  # a frame as read: nothing to convert before the shape check
    else:
        a = as_array(image, name, what="an (H, W) grey or (H, W, 3) BGR image")
    if a.ndim == 3 and a.shape[2] == 3:
        return cv2.cvtColor(np.ascontiguousarray(a, dtype=np.uint8), cv2.COLOR_BGR2GRAY)
    if a.ndim == 2:
        return np.ascontiguousarray(a, dtype=np.uint8)
    raise ValueError(f"{name}: expected an (H, W) grey or (H, W, 3) BGR image; got shape {a.shape}")


class KeypointCarrier:
    """Keypoints of one camera, carried by optical flow between detections, online.

    Give it every frame in order with that frame's detected keypoints (or None);
    `step` returns the frame's keypoints: the detection where there is one, else the
    last detection's points followed to this frame (module notes).

    Parameters
    ----------
    settings : CarrySettings, optional

    Examples
    --------
    A bright square moving 2 px to the right per frame carries its corner along:

    >>> frames = np.zeros((3, 64, 64), np.uint8)
    >>> for t in range(3):
    ...     frames[t, 20:40, 20 + 2 * t:40 + 2 * t] = 255
    >>> detected = np.full((21, 3), np.nan)
    >>> detected[0] = (20.0, 20.0, 1.0)  # the top-left corner
    >>> carrier = KeypointCarrier()
    >>> _ = carrier.step(frames[0], detected)
    >>> _ = carrier.step(frames[1])
    >>> np.round(carrier.step(frames[2])[0], 1).tolist()
    [24.0, 20.0, 1.0]
    """

    def __init__(self, settings: CarrySettings = CARRY_SETTINGS) -> None:
        self.settings = as_instance(settings, CarrySettings, "settings")
        s = settings
        self._flow = {
            "winSize": (s.window, s.window),
            "maxLevel": s.levels,
            "criteria": (cv2.TERM_CRITERIA_EPS | cv2.TERM_CRITERIA_COUNT, 30, 0.01),
        }
        self._grey: np.ndarray | None = None  # the previous frame
        self._points: np.ndarray | None = None  # (21, 1, 2) float32, being carried
        self._confidence = np.zeros(N_KEYPOINTS)  # 0: not carried
        self._followed = np.zeros(N_KEYPOINTS, dtype=bool)  # else held
        self._age = 0  # frames since the last detection

    @property
    def age(self) -> int:
        """Frames since its last detection (0 on a detected frame)."""
        return self._age

    @property
    def followed(self) -> int:
        """Points of the last detection the flow still follows (not held)."""
        return int(np.count_nonzero(self._followed))

    @property
    def following(self) -> np.ndarray:
        """(21,) bool: the points of the last detection the flow still follows (a copy)."""
        return self._followed.copy()

    def step(self, image, keypoints=None) -> np.ndarray | None:
        """This frame's keypoints: detected, else carried from the previous frame.

        Parameters
        ----------
        image : (H, W, 3) BGR or (H, W) grey uint8 array_like
            The frame, in the pixels the keypoints are in.
        keypoints : (21, 2) or (21, 3) array_like, optional
            The frame's detection (x, y[, confidence]; NaN or confidence 0 missing);
            None, or no point present, for a frame without one.

        Returns
        -------
        (21, 3) ndarray or None
            x, y, confidence (NaN, NaN, 0 where missing); None when no point is there.
        """
        grey = _grey(image, "image")
        if self._grey is not None and grey.shape != self._grey.shape:
            raise ValueError(
                f"image: expected the size of the previous frame {self._grey.shape[::-1]}; "
                f"got {grey.shape[::-1]}"
            )
        detected = None if keypoints is None else as_frame_keypoints(keypoints, "keypoints")
        previous, self._grey = self._grey, grey
        if detected is not None and np.any(detected[:, 2] > 0):
            self._points = np.nan_to_num(detected[:, :2]).astype(np.float32)[:, None, :]
            self._confidence = detected[:, 2].copy()
            self._followed = self._confidence > 0
            self._age = 0
            return detected
        self._age += 1
        if self._points is None or previous is None or self._age > self.settings.max_frames:
            return None
        self._carry(previous, grey)
        s = self.settings
        hold = s.hold if s.hold_frames is None or self._age <= s.hold_frames else 0.0
        factor = np.where(self._followed, s.confidence, hold)
        confidence = self._confidence * factor
        ok = confidence > 0
        if not ok.any():
            return None
        out = np.full((N_KEYPOINTS, 3), np.nan)
        out[:, 2] = 0.0
        out[ok, :2] = self._points[ok, 0]
        out[ok, 2] = confidence[ok]
        return out

    def _carry(self, previous: np.ndarray, grey: np.ndarray) -> None:
        """Move the followed points from `previous` to `grey`; hold those that fail, and
        move the held ones by the median displacement of those followed (two or more)."""
        ok = self._followed
        if not ok.any():
            return
        p0 = np.ascontiguousarray(self._points[ok])
        p1, found, _ = cv2.calcOpticalFlowPyrLK(previous, grey, p0, None, **self._flow)
        back, found_back, _ = cv2.calcOpticalFlowPyrLK(grey, previous, p1, None, **self._flow)
        error = np.linalg.norm((back - p0)[:, 0], axis=1)
        kept = (found[:, 0] == 1) & (found_back[:, 0] == 1) & (error <= self.settings.max_error)
        kept &= np.isfinite(p1[:, 0]).all(axis=1)
        index = np.flatnonzero(ok)
        self._followed[index[~kept]] = False
        if np.count_nonzero(kept) >= 2:  # the held points move with the hand
            self._points[~self._followed] += np.median((p1 - p0)[kept, 0], axis=0)
        self._points[index[kept]] = p1[kept]


class TwoWayCarrier:
    """Keypoints of one camera carried both ways between detections, with a delay.

    Give it every frame in order with that frame's detection (or None), as to
    `KeypointCarrier`; `step` returns the frames whose keypoints are now final, in order,
    as ``(t, keypoints)`` pairs (t counting the frames given from 0, keypoints as
    `KeypointCarrier.step` returns them).  A detection frame is final at once, and so
    are the frames before it: their points carried forward from the previous detection
    and backwards from this one are blended (`_blend`).  Keypoints are carried across
    a gap between two detections of at most `CarrySettings.max_frames` frames, not
    across a longer one.  Before a run of detections (the first, or the first after a
    longer gap) the run's first detection is carried backwards as far as the flow
    follows at least `CarrySettings.lead_points` of its points (a hand the detector
    found late: the flow still follows it; a hand that came into view or a cut: the
    flow loses it), at most `CarrySettings.max_frames` frames.  After a run's last
    detection there is no hand as far as the detector knows, except on the frames it
    did not look at: with a detector on every (`reach` + 1)-th frame, the `reach`
    frames after its last detection keep the points carried forward (and the `reach`
    frames before its first get them carried backwards whatever the flow follows).
    A frame is held back until the next detection, or until
    `CarrySettings.max_frames` frames have passed: the delay is at most that many
    frames, and as many frames are kept.  `flush` gives out the frames still held
    after the last detection.

    Examples
    --------
    >>> frames = np.zeros((3, 64, 64), np.uint8)
    >>> for t in range(3):
    ...     frames[t, 20:40, 20 + 2 * t:40 + 2 * t] = 255
    >>> first, last = np.full((21, 3), np.nan), np.full((21, 3), np.nan)
    >>> first[0], last[0] = (20.0, 20.0, 1.0), (24.0, 20.0, 1.0)
    >>> carrier = TwoWayCarrier()
    >>> [t for t, _ in carrier.step(frames[0], first)], carrier.step(frames[1])
    ([0], [])
    >>> [(t, np.round(k[0], 1).tolist()) for t, k in carrier.step(frames[2], last)][0]
    (1, [22.0, 20.0, 1.0])
    """

    def __init__(self, settings: CarrySettings = CARRY_SETTINGS, *, reach: int = 0) -> None:
        self.settings = as_instance(settings, CarrySettings, "settings")
        self.reach = as_int(reach, "reach", minimum=0)
        self._forward = KeypointCarrier(settings)
        self._t = -1  # the frame given last
        self._last: int | None = None  # the frame of the last detection
        self._across = False  # the gap since it is short enough to carry across
        # t, grey, the points carried forward and which of them the flow follows
        self._gap: list[tuple[int, np.ndarray, np.ndarray | None, np.ndarray]] = []

    def step(self, image, keypoints=None) -> list[tuple[int, np.ndarray | None]]:
        """Give frame t (the next) and its detection; the frames now final, in order."""
        self._t += 1
        grey = _grey(image, "image")
        forward = self._forward.step(grey, keypoints)
        detection = None if keypoints is None else as_frame_keypoints(keypoints, "keypoints")
        if detection is not None and np.any(detection[:, 2] > 0):
            out = self._blend(grey, detection)
            self._last, self._across, self._gap = self._t, True, []
            return [*out, (self._t, forward)]
        self._gap.append((self._t, grey, forward, self._forward.following))
        if len(self._gap) > self.settings.max_frames:  # a gap too long to carry across
            self._across = False  # the next detection starts a run
            t, _, forward, _ = self._gap.pop(0)
            return [self._after_run(t, forward)]
        return []

    def flush(self) -> list[tuple[int, np.ndarray | None]]:
        """The frames still held at the end, after the last detection: none carried
        there, except to the `reach` frames right after it, which keep the points
        carried forward (the detector did not look at them:
        `until_next_detection`'s online rule)."""
        out, self._gap = [self._after_run(t, forward) for t, _, forward, _ in self._gap], []
        return out

    def _after_run(self, t, forward) -> tuple[int, np.ndarray | None]:
        """A frame given out after the last detection of a run: its points carried
        forward within `reach` frames of that detection, none beyond."""
        near = self._last is not None and t - self._last <= self.reach
        return t, forward if near else None

    def _blend(self, grey, detection) -> list[tuple[int, np.ndarray | None]]:
        """Carry `detection` back over the held frames and blend (module notes).

        A point the flow follows both ways is the mean of the two weighted by the
        nearness of each detection, w_f = k_b / (k_f + k_b) on the forward point, which
        is k_f frames after its detection, and 1 − w_f on the backward one, k_b frames
        before this detection; so is a point the flow lost both ways (held both ways).
        A point followed one way and held the other is the followed one: a held point
        only moves with the hand (`KeypointCarrier`), and the flow loses mostly the fast
        points, which have moved on.  A point carried one way only is that one.
        """
        back = KeypointCarrier(self.settings)
        back.step(grey, detection)
        out = []
        going = True  # the backward carry still has points
        lead = self.settings.lead_points
        for t, g, f, f_follows in reversed(self._gap):
            skipped = self._t - t <= self.reach  # a frame the detector did not look at
            if not self._across:  # before a run: carried back while the flow follows
                going = going and (skipped or lead is not None)
                f = None
            b = back.step(g) if going else None
            if b is not None and not (self._across or skipped) and back.followed < lead:
                b = None
            going = b is not None
            if b is None:
                out.append((t, f))
                continue
            if f is None:
                out.append((t, b))
                continue
            fwd, bwd = f[:, 2] > 0, b[:, 2] > 0
            k_b = self._t - t
            w = np.full(N_KEYPOINTS, k_b / ((t - self._last) + k_b))
            b_follows = back.following
            w[f_follows & ~b_follows] = 1.0
            w[b_follows & ~f_follows] = 0.0
            w = w[:, None]
            mixed = w * np.nan_to_num(f) + (1.0 - w) * np.nan_to_num(b)
            k = np.where((fwd & bwd)[:, None], mixed, np.where(bwd[:, None], b, f))
            out.append((t, k))
        return out[::-1]


def carry_keypoints(
    images: Iterable,
    keypoints: Keypoints2D,
    settings: CarrySettings = CARRY_SETTINGS,
    *,
    both: bool = False,
    every: int = 1,
) -> Keypoints2D:
    """One camera's keypoints carried by optical flow over the frames without a detection.

    Parameters
    ----------
    images : iterable of (H, W, 3) BGR or (H, W) grey uint8 arrays
        The camera's frames from frame 0, in the pixels of `keypoints`; frames past the
        last image keep `keypoints` as they are.
    keypoints : Keypoints2D
        The detections (`Keypoints2D.every` for a detector at a lower rate).
    settings : CarrySettings, optional
    both : bool, keyword-only
        Also carry the next detection backwards, and blend (`TwoWayCarrier`): not
        causal, a frame's keypoints wait for the next detection.
    every : int, keyword-only
        The detector ran on every `every`-th frame: carried both ways, the frames after
        the last detection that it skipped (``every − 1`` at most) keep the points
        carried forward (`TwoWayCarrier.flush`).

    Returns
    -------
    Keypoints2D
        The detections where there are any, the carried points elsewhere (module notes).
    """
    as_instance(keypoints, Keypoints2D, "keypoints")
    as_instance(both, bool, "both")
    # stops at the shorter: the keypoints' last frame or the last image
    frames = zip(range(keypoints.n_frames), images, strict=False)
    if both:
        two_way = TwoWayCarrier(settings, reach=as_int(every, "every", minimum=1) - 1)
        done = [d for t, image in frames
                for d in two_way.step(_grey(image, "images"), keypoints.frame(t))]  # fmt: skip
        done += two_way.flush()
    else:
        forward = KeypointCarrier(settings)
        done = [(t, forward.step(_grey(image, "images"), keypoints.frame(t)))
                for t, image in frames]  # fmt: skip
    out = keypoints.to_array()
    for t, k in done:
        if k is not None:
            out[t] = k
    return Keypoints2D.from_array(out, name=keypoints.name)
