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
  (21, 3) mm (any origin, as a view along the ray through the palm sees the hand, as
  MediaPipe's world landmarks are) and ``side`` ("right" or "left");
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

from handvar.vision.keypoints import N_KEYPOINTS, SIDE_FRAMES, Detection, choose, vote_side

__all__ = [
    "DETECTORS",
    "SIDE_FRAMES",
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
    what was expected and what came, with the frame's count.  The detector takes the
    frame's index as the pipeline gives it (``frame=``) and does not pass it on.

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

    def detect(image, frame: int | None = None) -> list[Detection]:
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
    """Run `detectors` on the frames of `feed` ahead of the consumer.

    MediaPipe holds Python's global lock while it infers, so beside the fit it runs in
    a process of its own (`_detect_in_process`: the frames pass through shared memory,
    the hands found come back), which lets detection and fitting overlap on two cores.
    Any other detector (a user's callable, which may not be picklable), and MediaPipe in
    a daemonic process (a Dask worker, which may start none), runs in a worker thread
    (`_detect_in_thread`).

    Parameters
    ----------
    feed : iterable of (index, seconds, images, originals)
        The frames (`originals`: the full-resolution images the detectors see, one per
        camera; None on a frame the detectors skip).
    detectors : list of callable
        Per camera, ``(image, frame=index) -> list[Detection]`` (the frame's index in
        the feed: MediaPipe looks twice at a frame far from the last it saw).
    depth : int, keyword-only
        Frames detected ahead at most.

    Yields
    ------
    (index, seconds, images, found)
        `found`: per camera the list of hands found; None where the detectors skipped.
        An error of the feed or of a detector is raised here, in the consumer's thread.
    """
    import multiprocessing

    from handvar.vision.mediapipe import MediaPipeHands

    # a daemonic process (a Dask worker of a batch) may not start one of its own
    alone = not multiprocessing.current_process().daemon
    if alone and all(isinstance(d, MediaPipeHands) for d in detectors):
        return _detect_in_process(feed, [d.options for d in detectors], depth)
    return _detect_in_thread(feed, detectors, depth)


def _detect_in_thread(feed: Iterable, detectors: list, depth: int) -> Iterator:
    items: queue.Queue = queue.Queue(maxsize=depth)
    stop = threading.Event()

    def work() -> None:
        try:
            for index, seconds, images, originals in feed:
                found = None
                if originals is not None:
                    found = [d(image, frame=index)
                             for d, image in zip(detectors, originals, strict=True)]  # fmt: skip
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


class _Slots:
    """Shared-memory buffers for the frames in flight, `depth` slots of one image per
    camera, each made (again) as large as the frame put in it."""

    def __init__(self, depth: int) -> None:
        self.free = list(range(depth))
        self._memory: dict[tuple[int, int], object] = {}

    def put(self, originals) -> tuple[int, list]:
        """A free slot holding `originals`: the slot and, per camera, (name, shape)."""
        from multiprocessing import shared_memory

        slot = self.free.pop()
        spec = []
        for j, image in enumerate(originals):
            image = np.ascontiguousarray(image, dtype=np.uint8)
            shm = self._memory.get((slot, j))
            if shm is None or shm.size < image.nbytes:
                if shm is not None:
                    shm.close()
                    shm.unlink()
                shm = shared_memory.SharedMemory(create=True, size=max(image.nbytes, 1))
                self._memory[(slot, j)] = shm
            np.ndarray(image.shape, np.uint8, shm.buf)[...] = image
            spec.append((shm.name, image.shape))
        return slot, spec

    def close(self) -> None:
        for shm in self._memory.values():
            shm.close()
            shm.unlink()
        self._memory.clear()


#: MediaPipe processes detecting in turn (frame k to process k mod 2): one MediaPipe
#: keeps up with about 45 frames/s of 1280×720 here, and beside the fit on the other
#: core with about 35; two, each tracking its hand over every other frame, leave the
#: two cores to share out detection, decoding and fitting (docs/detector.md).
DETECTOR_PROCESSES = 2


def _detect_in_process(
    feed: Iterable, options: list[dict], depth: int, processes: int = DETECTOR_PROCESSES
) -> Iterator:
    import collections

    workers = [_Worker(options) for _ in range(processes)]
    slots = _Slots(depth * processes)
    pending: collections.deque = collections.deque()  # (index, seconds, images, slot, k)
    frames = iter(feed)
    more, sent = True, 0
    try:
        for worker in workers:  # MediaPipe loaded and warmed up before the first frame is read
            worker.received()
        while True:
            while more and slots.free:  # keep the detectors `depth` frames ahead each
                item = next(frames, None)
                if item is None:
                    more = False
                    break
                index, seconds, images, originals = item
                slot = k = None
                if originals is not None:
                    slot, spec = slots.put(originals)
                    k, sent = sent % processes, sent + 1
                    workers[k].send((index, spec))
                pending.append((index, seconds, images, slot, k))
            if not pending:
                return
            index, seconds, images, slot, k = pending.popleft()
            found = None
            if slot is not None:
                found = workers[k].received()
                slots.free.append(slot)
            yield index, seconds, images, found
    finally:
        for worker in workers:  # all told to end, then each waited for
            worker.stop()
        for worker in workers:
            worker.close()
        slots.close()


class _Worker:
    """A detector's process: ``python -m handvar.vision.detector``, frames' shared-memory
    names sent on its standard input, the hands found read from a pipe of its own.

    Started as a plain subprocess, not by `multiprocessing`, which would import the
    caller's main script again in it (a script calling `handvar.track` at its top
    level, without ``if __name__ == "__main__"``, would then start it again there).
    """

    def __init__(self, options: list[dict]) -> None:
        import json
        import os
        import subprocess
        import sys

        read, write = os.pipe()
        self.process = subprocess.Popen(
            [sys.executable, "-m", "handvar.vision.detector", str(write), json.dumps(options)],
            stdin=subprocess.PIPE, stdout=subprocess.DEVNULL, pass_fds=(write,),
        )  # fmt: skip
        os.close(write)
        self.replies = os.fdopen(read, "rb")

    def send(self, message) -> None:
        import pickle

        pickle.dump(message, self.process.stdin, protocol=pickle.HIGHEST_PROTOCOL)
        self.process.stdin.flush()

    def received(self) -> list:
        """The hands found in the next frame sent, as `Detection` per camera."""
        import pickle

        try:
            message = pickle.load(self.replies)
        except EOFError:
            raise RuntimeError(
                f"detector: the detector's process ended (exit code {self.process.poll()})"
            ) from None
        if isinstance(message, str):  # an error in the detector's process
            raise ValueError(message)
        return [[Detection(p, w, side=s, score=c) for p, w, s, c in hands] for hands in message]

    def stop(self) -> None:
        """Tell the process to end (it ends at the frame it is on); once is enough."""
        if self.process.stdin.closed:
            return
        try:
            self.send(None)
            self.process.stdin.close()
        except (OSError, ValueError):
            pass

    def close(self) -> None:
        """End the process (`stop`, if not told already) and wait for it."""
        self.stop()
        import subprocess

        try:
            self.process.wait(5.0)
        except subprocess.TimeoutExpired:  # a process that will not end is killed
            self.process.kill()
            self.process.wait()
        self.replies.close()


def _serve(requests, replies, options: list[dict]) -> None:
    """The detector's process: MediaPipe Hands on each frame sent, the hands found sent
    back, until None comes."""
    import os
    import pickle
    import sys
    from multiprocessing import resource_tracker, shared_memory

    from handvar.vision.mediapipe import MediaPipeHands, hands_module_alone

    # MediaPipe's C++ logging writes to file descriptor 2 at any frame (a warning at
    # the first hand found): that goes to the null device, Python's errors still show
    sys.stderr.flush()
    sys.stderr = os.fdopen(os.dup(2), "w", buffering=1)
    null = os.open(os.devnull, os.O_WRONLY)
    os.dup2(null, 2)
    os.close(null)
    hands = hands_module_alone()  # this process runs the detector only
    detectors = [MediaPipeHands(**o) for o in options]
    for d in detectors:
        d._module = hands
        d(np.zeros((64, 64, 3), np.uint8))  # the graph built and its models loaded now
    pickle.dump([], replies)  # ready
    replies.flush()
    attached: dict[str, object] = {}
    while True:
        try:
            spec = pickle.load(requests)
        except EOFError:
            break
        if spec is None:
            break
        index, spec = spec
        try:
            found = []
            for detect, (name, shape) in zip(detectors, spec, strict=True):
                shm = attached.get(name)
                if shm is None:  # made and unlinked by the parent: not this one's to track
                    shm = attached[name] = shared_memory.SharedMemory(name=name)
                    resource_tracker.unregister(shm._name, "shared_memory")
                image = np.ndarray(shape, np.uint8, shm.buf)
                found.append([(d.points, d.world, d.side, d.score)
                              for d in detect(image, frame=index)])  # fmt: skip
        except (ValueError, ImportError) as exc:
            pickle.dump(str(exc), replies)
            replies.flush()
            break
        pickle.dump(found, replies, protocol=pickle.HIGHEST_PROTOCOL)
        replies.flush()
    for shm in attached.values():
        shm.close()
    for d in detectors:
        d.close()


if __name__ == "__main__":  # the detector's process (`_Worker`)
    import json
    import os
    import sys

    _serve(sys.stdin.buffer, os.fdopen(int(sys.argv[1]), "wb"), json.loads(sys.argv[2]))
