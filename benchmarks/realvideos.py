"""The three real videos tracked with their MediaPipe keypoints: lost frames, the keypoint
check, PCK against the detector on withheld frames, and the all-in time per frame.

Videos (``examples/data``): the example video (``dex-human-hand-video``, 1280×720), the
fingerspelling clip (``tfjs-asl-hand``, 620×1080) and the counting clip
(``boreep-counting``, 640×480, no hand in its first ~110 and last ~90 frames), each with
the MediaPipe keypoints of every frame.  Each is tracked online, frame by frame, as
`handvar track` does (frames resized so that the longer side is 640 px; monocular,
assumed camera; RVAR predictor, seed 0; the first pose fitted to the first keypoints):
skin silhouette, keypoints (with ``--every 5``: the detections of every 5th frame, carried
by optical flow between, `handvar.vision.carry.KeypointCarrier`), then
`handvar.tracking.recovery.Recovery.frame`.  Printed per video and K:

- frames, frames with a detection given, no-hand frames, lost, re-initialised;
- the keypoint check (`TrackQuality.check`: on every frame with keypoints the joints
  within 0.2 hand sizes of at least 98 % of the keypoints kept) and the keypoints
  rejected;
- PCK@0.2 against the detector's keypoints (its own hand size) over the frames whose
  detections were withheld (K > 1), and over all frames with a detection;
- ms per frame all-in (reading and resizing the frame, silhouette, carrying, fit,
  rules, quality): median, and the worst one-second window (mean over the frames of
  any window of fps consecutive frames).

Run: ``PYTHONPATH=src python benchmarks/realvideos.py [--every 1,5] [--videos NAME,...]``
"""

from __future__ import annotations

import argparse
import time
from pathlib import Path

import numpy as np

from handvar.hand import HandModel
from handvar.hand.anthropometry import HandShape
from handvar.predictors.catalogue import make_predictor
from handvar.tracking.costs import CostSettings
from handvar.tracking.recovery import Recovery, _assemble, pck
from handvar.tracking.tracker import Tracker, TrackerSettings
from handvar.vision.carry import KeypointCarrier
from handvar.vision.keypoints import read_keypoints
from handvar.vision.silhouette import EmptySilhouetteError, silhouettes_from_frames
from handvar.vision.skin import SkinModel
from handvar.vision.sources import open_source

DATA = Path(__file__).resolve().parents[1] / "examples" / "data"
VIDEOS = {
    "dex-human-hand-video": ("dex-human-hand-video.mp4", "dex-human-hand-video-keypoints.npy",
                             "right"),
    "tfjs-asl-hand": ("tfjs-asl-hand.mp4", "tfjs-asl-hand-keypoints.npy", "right"),
    "boreep-counting": ("boreep-counting.mp4", "boreep-counting-keypoints.npy", "right"),
}  # fmt: skip


def run(name: str, every: int, seed: int = 0) -> dict:
    """Track video `name` with the detections of every `every`-th frame; score it."""
    video, kp_file, side = VIDEOS[name]
    probe = open_source(DATA / video)
    w, h = probe.image_size
    scale = 640.0 / max(w, h)
    source = open_source(DATA / video, scale=scale)
    detected = read_keypoints(DATA / kp_file)
    truth = source.scaled_keypoints([detected])[0]
    given = source.scaled_keypoints([detected.every(every)])[0]
    hand = HandModel(HandShape.from_size(185.0, side=side))
    settings = TrackerSettings(cost=CostSettings(keypoint_tips="pad"))
    tracker = Tracker(source.rig, hand, make_predictor("rvar"), np.random.default_rng(seed),
                      settings)  # fmt: skip
    recovery = Recovery(tracker, cut_wrist=True)
    carrier = KeypointCarrier()
    frames, seconds = [], []
    model = SkinModel()
    it = source.frames()
    while True:
        t0 = time.perf_counter()
        item = next(it, None)
        if item is None:
            break
        i, images = item
        k = carrier.step(images[0], given.frame(i) if i < given.n_frames else None)
        kps = None if k is None else [k]

        def masks(images=images, i=i):  # the silhouette, only where it is used
            try:
                return np.stack(silhouettes_from_frames(images, model, wrist=False, frame=i))
            except EmptySilhouetteError:
                return np.zeros((1, *images[0].shape[:2]), dtype=bool)

        frames.append(recovery.frame(masks, kps, with_keypoints=True))
        seconds.append(time.perf_counter() - t0)
    seconds = np.asarray(seconds)
    hand = recovery.hand  # the shape adapted to the first frames
    result = _assemble(frames, hand, 1, settings.smd.max_iterations, recovery.init_seconds,
                       seconds)  # fmt: skip
    q, poses = result.quality, result.track.poses
    n = len(poses)
    scores = np.array(
        [pck(poses[t], hand, source.rig, [truth.frame(t)]) if truth.present[t].any()
         else np.nan for t in range(n)]
    )  # fmt: skip
    with_detection = given.present[:n].any(axis=1)
    seen = truth.present[:n].any(axis=1)
    window = max(1, round(source.fps))
    rolling = np.convolve(seconds, np.ones(window) / window, mode="valid")
    ok, worst, rejected = q.check()
    return {
        "frames": n, "given": int(with_detection.sum()), "no_hand": int(q.no_hand.sum()),
        "lost": int(q.lost.sum()), "reinit": int(q.reinit.sum()), "check": ok,
        "worst": worst, "rejected": rejected,
        "pck_withheld": float(np.nanmean(scores[seen & ~with_detection]))
        if (seen & ~with_detection).any() else float("nan"),
        "pck_all": float(np.nanmean(scores[seen])),
        "median_ms": 1e3 * float(np.median(seconds)), "worst_ms": 1e3 * float(rolling.max()),
        "size": source.image_size,
    }  # fmt: skip


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--every", default="1,5")
    ap.add_argument("--videos", default=",".join(VIDEOS))
    ap.add_argument("--seed", type=int, default=0)
    args = ap.parse_args()
    print(
        "video | K | frames (detections given) | no hand | lost | re-init | keypoint check "
        "(worst frame, rejected) | PCK withheld | PCK all | ms/frame median | worst 1 s"
    )
    for name in args.videos.split(","):
        for every in (int(v) for v in args.every.split(",")):
            r = run(name, every, args.seed)
            w, h = r["size"]
            print(f"{name} ({w}x{h}) | {every} | {r['frames']} ({r['given']}) | {r['no_hand']} | "
                  f"{r['lost']} | {r['reinit']} | {'holds' if r['check'] else 'fails'} "
                  f"({100 * r['worst']:.1f} %, {r['rejected']}) | {r['pck_withheld']:.3f} | "
                  f"{r['pck_all']:.3f} | {r['median_ms']:.1f} | {r['worst_ms']:.1f}",
                  flush=True)  # fmt: skip


if __name__ == "__main__":
    main()
