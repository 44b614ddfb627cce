"""The per-frame tracker: ``result = tracker.process(frame)`` (design §1).

`HandTracker` is the whole per-frame step in one object, in MediaPipe's habit: give it
each colour frame (one per camera) in order and it returns one `FrameResult`: the
pose, the 21 joints in mm, their projections, the fit's quality, and whether there was
a hand.  Inside, a frame takes one of two lanes:

- **keypoints** (the detector found the hand, or the caller gave its points): the
  keypoint-first fit from the motion prediction, with the recovery's rules
  (`handvar.tracking.recovery.Recovery.keypoint_frame`);
- **silhouettes** (no detector): the paper's silhouette tracker from the prediction
  (`Recovery.silhouette_frame`), on the frame's skin-colour silhouettes (the skin
  component where the prediction puts the hand, not the largest).

A frame on which the detector ran and found no hand is a frame without a hand: NaN
pose and joints, ``no_hand`` true, the predictor left as it was.  The first pose comes
from the first frame with a hand.  With ``hand="auto"`` the side is that frame's
handedness.  `handvar.track` runs the same step (`fit`) over a whole recording, with
the detector in a worker thread ahead of the fit and the keypoints carried both ways.

Examples
--------
>>> import numpy as np
>>> tracker = HandTracker(detector=lambda image: None)  # a detector that finds nothing
>>> result = tracker.process(np.zeros((48, 64, 3), np.uint8))
>>> result.no_hand, bool(np.isnan(result.joints).all())
(True, True)
"""

from __future__ import annotations

import dataclasses
import functools
from dataclasses import dataclass

import numpy as np

from handvar.camera import Rig
from handvar.hand.anthropometry import SIDES, HandShape
from handvar.hand.kinematics import keypoint_points
from handvar.params import N_PARAMS
from handvar.tracking.recovery import _Frame, _frame_quality, _present
from handvar.validate import as_float, as_instance, as_int, one_of

__all__ = ["FrameResult", "HandTracker"]


@dataclass(frozen=True, eq=False)
class FrameResult:
    """What `HandTracker.process` gives for one frame.

    Attributes
    ----------
    index : int
        The frame's number, from 0.
    pose : (26,) ndarray
        The fitted pose (`handvar.params`, mm and degrees); NaN without a hand.
    joints : (21, 3) ndarray
        The hand's 21 points, mm, in the first camera's frame: G(x) with the fingertips
        and the thumb's base where a detector marks them (``keypoint_tips``, "pad" by
        default; design §14.6); NaN without a hand.
    projected : (n_cameras, 21, 2) ndarray
        The joints in every camera, pixels of the frames given; NaN without a hand.
    keypoints : list of (21, 3) ndarray or None
        Per camera the keypoints the fit used (x, y, confidence), None where none.
    quality : FrameQuality
        The fit's silhouette IoU, keypoint error, cost and lost flag.
    no_hand : bool
        No hand in the frame: nothing was fitted.
    lost : bool
        The fit failed the lost rule (design §14.3).
    seconds : float
        Wall time of the fit, seconds.
    side : str
        The side of the hand tracked ("right", "left"; "" before it is decided).
    id : int
        The hand's identity (`handvar.tracking.hands.HandsTracker`; 0 for one hand).
    hidden : bool
        The hand was hidden and its pose held where it was last (`carried`).
    """

    index: int
    pose: np.ndarray
    joints: np.ndarray
    projected: np.ndarray
    keypoints: list | None
    quality: object
    no_hand: bool
    lost: bool
    seconds: float
    side: str = ""
    id: int = 0
    hidden: bool = False


class HandTracker:
    """Track one hand frame by frame (module notes).

    Parameters
    ----------
    rig : Rig, path-like or None
        The cameras of the frames given (`handvar.camera.Rig.load` reads a path); None:
        one assumed camera (`handvar.vision.sources.assumed_camera`, field of view
        `fov`) of the first frame's size.
    hand : {"auto", "right", "left"}, keyword-only
        The side tracked; "auto": that of the frames with a hand so far, until
        `handvar.vision.detector.SIDE_FRAMES` of them: with two cameras the hand's 3D
        shape, else the handedness (a detector that says no side: right); where it
        turns, the model is built again on the other side.
    detector : {"auto", "mediapipe", "none"} or callable, keyword-only
        The keypoint detector (`handvar.vision.detector.make_detectors`): "auto" is
        MediaPipe Hands when installed, else none (silhouettes alone); a callable
        ``frame -> points`` is the user's own.
    predictor : str, keyword-only
        Motion predictor (`handvar.predictors.catalogue.make_predictor`).
    hand_length : float, keyword-only
        Hand length of the model before its shape is fitted, mm.
    shape : HandShape, keyword-only, optional
        The hand's proportions, held instead (no shape fit), as `handvar.track`'s
        ``shape`` (`handvar.pipeline.load_shape` reads a saved track's); its side is
        the hand tracked (`hand` "auto" or that side).
    model : {"spheres", "mesh"}, keyword-only
        The model's surface.
    keypoint_every : int, keyword-only
        Run the detector on every K-th frame only; the frames between carry the last
        detection forward by optical flow (`handvar.vision.carry.KeypointCarrier`), up
        to the next one.
    keypoint_tips : {"pad", "end"}, keyword-only
        Model point a detected fingertip is compared with (design §14.6).
    recovery : RecoverySettings, keyword-only, optional
    seed : int, keyword-only
        Seed of the optimiser's random samples.
    fov : float, keyword-only, optional
        With no `rig`: the assumed camera's horizontal field of view, degrees.
    mirrored : bool, keyword-only
        MediaPipe: the frames are mirrored (a selfie camera).
    """

    def __init__(
        self,
        rig=None,
        *,
        hand: str = "auto",
        detector="auto",
        predictor: str = "rvar",
        hand_length: float = 185.0,
        model: str = "spheres",
        keypoint_every: int = 1,
        keypoint_tips: str = "pad",
        recovery=None,
        seed: int = 0,
        fov: float | None = None,
        mirrored: bool = False,
        shape=None,
    ) -> None:
        from handvar.predictors.catalogue import catalogue_key
        from handvar.tracking.recovery import RECOVERY_DEFAULTS, RecoverySettings
        from handvar.vision.detector import make_detectors

        one_of(hand, (*SIDES, "auto"), "hand")
        if shape is not None:
            as_instance(shape, HandShape, "shape")
            if hand not in ("auto", shape.side):
                raise ValueError(f"hand: expected auto or {shape.side}, the side of the shape "
                                 f"given; got {hand}")  # fmt: skip
            hand = shape.side
        one_of(model, ("spheres", "mesh"), "model")
        one_of(keypoint_tips, ("end", "pad"), "keypoint_tips")
        self.rig = None if rig is None else (rig if isinstance(rig, Rig) else Rig.load(rig))
        n = 1 if self.rig is None else len(self.rig)
        self.detectors = make_detectors(detector, n, mirrored=mirrored)
        self.side = None if hand == "auto" else hand
        self._votes = [] if hand == "auto" else None  # the hands found, while voting
        self._shape = 0.0  # with two cameras, the sum of the hand's chirality (`_vote`)
        self.labelled = True  # whether the labels weigh which hand a detection is
        self.predictor = catalogue_key(as_instance(predictor, str, "predictor"), "predictor")
        self.hand_length = as_float(hand_length, "hand_length", minimum=0.0,
                                    exclusive_minimum=True)  # fmt: skip
        self.model = model
        self.every = as_int(keypoint_every, "keypoint_every", minimum=1)
        self.tips = keypoint_tips
        self.settings = as_instance(recovery if recovery is not None else RECOVERY_DEFAULTS,
                                    RecoverySettings, "recovery")  # fmt: skip
        self.shape = shape
        if shape is not None:  # held as given
            self.settings = dataclasses.replace(self.settings, shape=None)
        self.seed = as_int(seed, "seed", minimum=0)
        self.fov = fov
        self.recovery = None  # built at the first frame with a hand (its side known)
        self.frames: list = []  # what the recovery kept of every frame (`track`)
        self.seconds: list[float] = []
        self._carriers = None
        self._skin = None
        self.frame_count = 0

    @classmethod
    def following(cls, tracker, *, keyed: bool, settings=None) -> HandTracker:
        """A HandTracker driving an existing `handvar.tracking.Tracker` (`handvar.track`,
        whose keypoints come detected and carried); `keyed`: the frames come with
        keypoints (else silhouettes alone)."""
        self = cls.__new__(cls)
        from handvar.tracking.recovery import RECOVERY_DEFAULTS, Recovery

        self.settings = RECOVERY_DEFAULTS if settings is None else settings
        self.rig, self.detectors = tracker.rig, ([] if keyed else None)
        self.recovery = Recovery(tracker, settings=self.settings, cut_wrist=keyed)
        self.frames, self.seconds, self.frame_count = [], [], 0
        self._carriers, self._skin, self._votes = None, None, None  # the side is decided
        self.side = tracker.hand.shape.side
        self.tips = tracker.settings.cost.keypoint_tips
        return self

    # -- one frame ----------------------------------------------------------------------

    def process(self, frames, *, keypoints=None, world=None, silhouettes=None) -> FrameResult:
        """Track the next frame.

        Parameters
        ----------
        frames : (H, W, 3) uint8 ndarray or list of them
            The BGR colour frame of every camera (one array for one camera).
        keypoints : list of (21, 2|3) array_like or None, keyword-only, optional
            The frame's keypoints per camera from the caller's own detector, pixels of
            the frames given; instead of the tracker's detector.
        world : (21, 3) array_like, keyword-only, optional
            With `keypoints`: the detector's metric 3D points of the first camera's
            hand, mm (`handvar.vision.keypoints.Detection.world`).
        silhouettes : (n_cameras, H, W) array_like or callable, keyword-only, optional
            The hand's silhouette in every camera, instead of the skin the tracker
            finds in `frames` (a callable ``() -> masks`` is called only where the fit
            needs them); `HandsTracker` gives each hand its share of the skin.

        Returns
        -------
        FrameResult
        """
        images = _images(frames, 1 if self.rig is None else len(self.rig))
        if self.rig is None:
            from handvar.vision.sources import SOURCE_SETTINGS, assumed_camera

            h, w = images[0].shape[:2]
            fov = SOURCE_SETTINGS.fov if self.fov is None else self.fov
            self.rig = Rig([assumed_camera((w, h), fov=fov)])
        kps, found_world, ran = self._keypoints(images, keypoints)
        world = found_world if keypoints is None else world
        if self.recovery is None:
            if self.detectors is not None and not _present(kps):  # no hand seen yet
                return self._kept(_Frame.without_hand(), 0.0, None)
            self._start()
        return self.fit(self.masks(images, silhouettes), kps, world, absent=ran)

    def fit(self, masks, keypoints, world=None, *, absent: bool = False) -> FrameResult:
        """Fit the next frame from its silhouettes (or a callable ``near=None -> masks``
        giving them, `handvar.tracking.recovery.Recovery.frame`) and its keypoints per
        camera (None: none); `absent`: the detector looked and found no hand (a frame
        without keypoints is then one without a hand)."""
        keyed = self.detectors is not None
        kps = keypoints if _present(keypoints) else None
        f, s = self.recovery.step(masks, kps, world, with_keypoints=keyed, absent=absent)
        quality = _frame_quality(f.result, f.empty or f.no_hand)
        return self._kept(f, s, kps, quality)

    def carried(self) -> FrameResult:
        """The next frame with the hand hidden from every camera: its pose held where it
        was last, which the motion predictor learns (a frame ``empty`` and ``hidden``).

        Held, not carried on by the prediction: on the two-hand benchmark the
        prediction carried a hand that had stopped against the other one on, off it
        (`handvar.tracking.hands`, rule 6; docs/results/two-hands.md)."""
        if self.recovery is None or self.recovery.previous is None:
            raise ValueError("carried: expected a hand tracked before; got none yet")
        pose = self.recovery.previous.copy()
        self.recovery.tracker.accept(pose)
        f = _Frame(None, pose, empty=True)
        r = self._kept(f, 0.0, None, _frame_quality(None, True))
        return dataclasses.replace(r, hidden=True)

    def _kept(self, f, seconds: float, kps, quality=None) -> FrameResult:
        self.frames.append(f)
        self.seconds.append(seconds)
        index, self.frame_count = self.frame_count, self.frame_count + 1
        pose = f.pose if not f.no_hand else np.full(N_PARAMS, np.nan)
        n = len(self.rig)
        joints, projected = np.full((21, 3), np.nan), np.full((n, 21, 2), np.nan)
        if np.all(np.isfinite(pose)):
            joints = keypoint_points(self.recovery.hand, pose, self.tips)
            projected = np.stack([cam.project(joints) for cam in self.rig.cameras])
        if quality is None:
            quality = _frame_quality(None, True)
        return FrameResult(
            index=index, pose=pose, joints=joints, projected=projected, keypoints=kps,
            quality=quality, no_hand=bool(f.no_hand), lost=bool(quality.lost),
            seconds=seconds, side=self.side or "",
        )  # fmt: skip

    # -- a whole track ------------------------------------------------------------------

    def recovered(self, *, keypoints: bool):
        """The `RecoveredTrack` of every frame so far (`handvar.track`).  The poses of
        the first frames are those after the hand's shape was fitted to them, which may
        differ from what `process` returned then."""
        return self.recovery.result(self.frames, self.seconds, keypoints=keypoints)

    @property
    def hand(self):
        """The tracked `HandModel` (its shape fitted over the first frames); None before
        the first frame with a hand."""
        return None if self.recovery is None else self.recovery.hand

    def close(self) -> None:
        """Release the detectors (MediaPipe's graphs)."""
        for d in self.detectors or ():
            if hasattr(d, "close"):
                d.close()

    def __enter__(self) -> HandTracker:
        return self

    def __exit__(self, *exc) -> None:
        self.close()

    # -- inside -------------------------------------------------------------------------

    def _start(self) -> None:
        """Build the model, predictor and recovery once the side is known."""
        from handvar.hand.kinematics import HandModel

        side = self.side or "right"
        shape = self.shape or HandShape.from_size(self.hand_length, side=side)
        hand = HandModel(shape, surface=self.model)
        self.recovery = self.recovery_for(hand)

    def recovery_for(self, hand, settings=None):
        """A new `handvar.tracking.recovery.Recovery` of this tracker's kind (rig,
        predictor, seed, keypoint tips) for `hand`; `settings`: its `RecoverySettings`
        (default: this tracker's)."""
        from handvar.predictors.catalogue import make_predictor
        from handvar.tracking import CostSettings, Tracker, TrackerSettings
        from handvar.tracking.recovery import Recovery

        tracker = Tracker(self.rig, hand, make_predictor(self.predictor),
                          np.random.default_rng(self.seed),
                          TrackerSettings(cost=CostSettings(keypoint_tips=self.tips)))  # fmt: skip
        return Recovery(tracker, settings=self.settings if settings is None else settings,
                        cut_wrist=self.detectors is not None)  # fmt: skip

    def _keypoints(self, images, given):
        """Per camera the frame's keypoints, the detector's 3D, whether it looked."""
        from handvar.vision.detector import choose

        if given is not None:
            from handvar.vision.keypoints import as_frame_keypoints

            given = list(given) if isinstance(given, list | tuple) else [given]
            if len(given) != len(images):
                raise ValueError(
                    f"keypoints: expected one entry per camera ({len(images)}); got {len(given)}"
                )
            kps = [None if k is None else as_frame_keypoints(k, f"keypoints[{j}]")
                   for j, k in enumerate(given)]  # fmt: skip
            if self.detectors is None:
                self.detectors = []  # the caller's keypoints: a track with keypoints
            return kps, None, True
        if not self.detectors:
            return None, None, False
        ran = self.frame_count % self.every == 0
        found = ([d(image, frame=self.frame_count) for d, image in
                  zip(self.detectors, images, strict=True)] if ran else None)  # fmt: skip
        if found is not None and self._votes is not None and any(found):
            self._vote(found)
        side = self.side if self.labelled else None
        chosen = [choose(f, side or "auto") for f in found] if found else None
        kps = None if chosen is None else [p for p, _ in chosen]
        world = None if chosen is None or chosen[0][1] is None else chosen[0][1].world
        if self.every > 1:
            kps = self._carry(images, kps)
        return kps, world, ran

    def _vote(self, found) -> None:
        """With ``hand="auto"``: the side of the frames with a hand so far, `SIDE_FRAMES`
        of them at most, as `handvar.track` decides it before its first fit
        (`handvar.vision.keypoints.decide_side`: with two cameras by the hand's 3D
        shape, else by the handedness).  Where it turns, the model is built again on
        the other side and the predictor restarts at the next frame with a hand; the
        frames returned stay as they were."""
        from handvar.vision.detector import SIDE_FRAMES
        from handvar.vision.keypoints import decide_side, found_chirality

        self._votes.extend(found)
        if len(found) >= 2:  # the hand both cameras see, triangulated
            self._shape = np.nansum([self._shape, found_chirality(found, self.rig.cameras)])
        side, self.labelled = decide_side(self._votes, float(self._shape))
        if side != self.side:
            self.side = side
            self.recovery = None  # built again at this frame (`process`)
        if sum(1 for f in self._votes if f) >= SIDE_FRAMES * len(found):
            self._votes = None  # decided

    def _carry(self, images, kps):
        """Carried forward by optical flow up to the next detector frame."""
        from handvar.vision.carry import KeypointCarrier, until_next_detection

        if self._carriers is None:
            settings = until_next_detection(self.every)
            self._carriers = [KeypointCarrier(settings) for _ in images]
        kps = kps or [None] * len(images)
        return [c.step(im, k) for c, im, k in zip(self._carriers, images, kps, strict=True)]

    def masks(self, images, silhouettes=None):
        """The frame's silhouettes as `Recovery.step` takes them, a callable ``near=None
        -> masks``: `silhouettes` as given to `process` (checked against `images`), or
        those the skin model finds in `images`."""
        if silhouettes is None:
            return functools.partial(self._silhouettes, images)
        return functools.partial(_given_silhouettes, silhouettes, images)

    def _silhouettes(self, images, near=None):
        from handvar.vision.skin import SkinModel
        from handvar.vision.sources import frame_silhouettes

        if self._skin is None:
            self._skin = SkinModel()
        return frame_silhouettes(images, self._skin, index=self.frame_count,
                                 names=self.rig.names, wrist=self.detectors is None,
                                 allow_empty=True, near=near)  # fmt: skip


def _given_silhouettes(silhouettes, images, near=None) -> np.ndarray:
    """The silhouettes given to `HandTracker.process`, checked against its frames
    (`near`, where the hand is expected, is the skin's choice: not used)."""
    masks = np.asarray(silhouettes() if callable(silhouettes) else silhouettes)
    shape = (len(images), *images[0].shape[:2])
    if masks.shape != shape:
        raise ValueError(f"silhouettes: expected shape {shape}, one (H, W) mask per camera "
                         f"of the frames; got {masks.shape}")  # fmt: skip
    return masks.astype(bool, copy=False)


def _images(frames, n: int) -> list[np.ndarray]:
    """The frame of every camera, checked: (H, W, 3) uint8 BGR."""
    images = list(frames) if isinstance(frames, list | tuple) else [frames]
    if len(images) != n:
        raise ValueError(f"frames: expected one image per camera ({n}); got {len(images)}")
    out = []
    for j, image in enumerate(images):
        a = np.asarray(image)
        if a.ndim != 3 or a.shape[2] != 3 or a.dtype != np.uint8:
            raise ValueError(
                f"frames: expected (H, W, 3) uint8 BGR images; got {a.shape} {a.dtype} "
                f"for camera {j}"
            )
        out.append(a)
    return out
