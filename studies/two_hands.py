"""Both hands on the two-hand benchmark: identities, accuracy and lost frames, fit against detector.

Usage: PYTHONPATH=src python studies/two_hands.py [--seeds N] [--cameras 1|2]
       [--detector simulated|mediapipe] [--every K] [--scenario NAME ...] [--size W H]
       [--missed-carry N] [--hidden-frames N] [--missed-frames N] [--side-run N]
       [--same-hand X] [--held-view C] [--alone-palm MM] [--hidden-weight W]
       [--cache DIR]
       [--landmarks full|lite] [--confidence C] [--forward-only] [--no-look] [--mirror]
       [--lost-frames]

For every scenario of `handvar.evaluation.two_hands.SCENARIOS` and seed, renders the
case (640×360 by default) and tracks it with `handvar.tracking.hands.HandsTracker`, the
detector's hands given to it frame by frame: the simulated detector's (labels that
flip, one detection where the hands overlap, hidden points displaced) or MediaPipe
Hands run on the rendered frames.  Prints per true hand (left, right), for the raw
detections taken as a user of the labels would (the label is the identity) and for
the fit:

- identity switches (a track changing hands plus a hand changing tracks, CLEAR MOT's
  count, `score_two_hands`);
- 2D PCK@0.2 over the frames the hand is in view (a frame without a track on it counts
  as wrong);
- lost: frames in view without a track within 0.5 hand sizes (and, in the last line,
  those where at least 11 of the hand's 21 points are visible: inside the image and
  not hidden by the other hand; of the fit's, those where a detection lay within 0.5
  hand sizes of it, camera 0 (perhaps the other hand's), and those where none had for
  up to 10 frames in a row or longer: `lost_causes`; ``--lost-frames`` prints each);
- in the last line, the frames a hand is drawn on no true hand (`drawn_off`: a
  detection's or a track's frames matched to neither hand; of the fit's, those it
  was carried hidden behind the other hand; of both, those farther than a hand size
  from both hands, `drawn_away`: where there is none), and those a hand is
  drawn on a true hand of the other side than it says (the detector's label, the
  track's side);
- the fit's wrist-relative and absolute 3D error (mm), and with MediaPipe its world
  landmarks' wrist-relative error and the fit's on the same frames (those where it
  found the hand and a track is on it); with two cameras, the absolute error of
  each hand's detections triangulated point by point (given to it by the truth: the
  baseline at its best) and the fit's on the same frames;
- in the last line, how closely the fit holds the detector's points (`honoured`: per
  true hand, camera 0, the frames with a detection on it and a track on it: every
  point within 0.2 of the detection's hand size, as the keypoint check asks, and their
  mean within it), and on those frames the detection's PCK@0.2 against the truth;
- the tracker's rate (fits and assignment, frames/s);

and last a Markdown table per scenario (its seeds and both hands) with the overall row.

``--palms`` prints only, with two cameras, the palm lengths (wrist → middle MCP) the
detections' rays make for one hand's two views and for the two hands' views whose rays
meet by chance (`palm_pairs`): whether `handvar.vision.keypoints.PALM_MM` tells them
apart.

``--mirror`` prints only MediaPipe's PCK@0.2 against the truth per true hand on the
frames as rendered and flipped left to right (camera 0): whether a hand's side or
its poses and place make it harder for the detector.

``--side-run N`` sets the run of sure labels for the other side that turns a hand's
side (`handvar.tracking.hands.SIDE_RUN`); the last line gives the runs seen, on tracks
whose side is right and on those whose side is wrong.  ``--missed-carry N`` sets the
frames a hand the detector misses is followed by optical flow
(`handvar.tracking.hands.MISSED_CARRY`, to compare values); ``--hidden-frames N`` the
frames a hand behind or against the other is carried, held (at most `GONE_FRAMES` + 1,
after which it is no longer expected; `handvar.tracking.hands.HIDDEN_FRAMES`);
``--missed-frames N`` the frames a hand missed in the open is carried, held, once the
flow follows none of its points (`handvar.tracking.hands.MISSED_FRAMES`);
``--same-hand X`` the
palm lengths within which one hand's views given to two hands are merged
(`handvar.tracking.hands.SAME_HAND`; ``inf``: wherever their rays meet); ``--held-view
C`` the confidence of the points a missed hand followed in one camera only is held at
in the others (`handvar.tracking.hands.HELD_VIEW`); ``--alone-palm MM`` the shortest
palm a hand's views in two cameras may make where no other hand's view is left over
(`handvar.tracking.hands.ALONE_PALM`; 50, `PALM_MM`'s, bounds them as any two views);
``--hidden-weight W`` the confidence factor of a keypoint inside the outline of the
hand in front (`handvar.tracking.hands.HIDDEN_WEIGHT`).
With ``--every K`` the detector runs on every K-th frame only (MediaPipe as the
command runs it: two MediaPipes taking those frames in turn, each given the frame's
index); the fit carries
each hand's detection by optical flow over the frames between, and the detections'
baseline is interpolated linearly between the detector's frames.  ``--landmarks lite``
runs MediaPipe with its lite landmark model (faster; `benchmarks/detector_options.py`),
``--confidence C`` with detection and tracking thresholds C (the pipeline's: 0.5).
The tracker fits a hand found late back on the frames before (`HandsTracker.back_fill`),
as ``handvar track --hands 2`` does on a recording; ``--forward-only`` leaves it frame
by frame, as from a live camera.  With MediaPipe the tracker looks again, as the command
does, where a hand it expects was missed (a second MediaPipe on a box of the frame,
`handvar.tracking.hands.LOOK_PAD`, rule 6); ``--no-look`` leaves it to the detections
(this second look is not cached: each run runs it).
``--cache DIR`` keeps MediaPipe's detections per case in DIR and reads them back on the
next run (the renders are the same for the same scenario, seed and size).
"""

from __future__ import annotations

import argparse
import dataclasses
import itertools
import time

import cv2
import numpy as np


def fitted_tracks(case, detections, every: int = 1, back: bool = True, look=None,
                  recovery=None, split: bool = True):  # fmt: skip
    """Track `case` with the given detections per frame; the tracks as `score_two_hands`
    takes them (camera 0), and the frames/s of the tracker.  `back`: as on a recording,
    a hand found late is carried back (`HandsTracker.back_fill`); `look`: the tracker's
    second look where a hand expected was missed (`HandsTracker`'s); `recovery`: every
    hand's settings; `split`: with the silhouette term, the skin shared between the
    hands (False: each hand given the skin as one hand would be)."""
    from handvar.tracking.hands import HandsTracker
    from handvar.tracking.keypoint_cost import keypoint_points

    tracker = HandsTracker(case.rig, detector=None, keypoint_every=every, back=back, look=look,
                           recovery=recovery)  # fmt: skip
    tracker._split = tracker._split and split
    T = case.n_frames
    n = len(case.rig)
    results = []
    camera = case.rig.cameras[0]
    points = np.full((len(tracker.hands), T, 21, 2), np.nan)
    joints = np.full((len(tracker.hands), T, 21, 3), np.nan)
    seconds = 0.0
    for t in range(T):
        images = [cv2.cvtColor(case.frames[j, t], cv2.COLOR_RGB2BGR) for j in range(n)]
        t0 = time.perf_counter()
        found = [detections[j][t] for j in range(n)] if t % every == 0 else None
        r = tracker.process(images, detections=found)
        seconds += time.perf_counter() - t0
        results.append(r)
        for h in tracker.hands:  # the points detectors mark, on the hand's model of now
            x = r.hands[h.id].pose
            if np.isfinite(x).all():
                joints[h.id, t] = keypoint_points(h.tracker.hand, x, "pad")
                points[h.id, t] = camera.project(joints[h.id, t])
    if back:
        t0 = time.perf_counter()
        for t, poses in tracker.back_fill().items():
            for i, x in poses.items():  # NaN: a track taken off
                joints[i, t] = points[i, t] = np.nan
                if np.isfinite(x).all():
                    joints[i, t] = keypoint_points(tracker.hands[i].tracker.hand, x, "pad")
                    points[i, t] = camera.project(joints[i, t])
        seconds += time.perf_counter() - t0
    tracks = {h.id: {"points_2d": points[h.id], "joints": joints[h.id]}
              for h in tracker.hands if h.tracker.hand is not None}  # fmt: skip
    tracker.close()  # the second look's MediaPipe graphs
    return tracks, T / seconds, results


def wrong_sides(case, score, sides: dict) -> int:
    """Frames a track is on a true hand of the other side than it says (`sides`: track
    id → (T,) its side per frame, or one side)."""
    wrong = 0
    for k, true_side in enumerate(case.sides):
        for t in np.flatnonzero(score.match[k] >= 0):
            side = sides[score.ids[score.match[k, t]]]
            wrong += (side if isinstance(side, str) else side[t]) != true_side
    return int(wrong)


def label_runs(case, score, tracks: dict, results) -> dict:
    """The runs of labels sure of the other side (`handvar.tracking.hands.SIDE_SURE`)
    on a track, split by whether the track's side is its true hand's: ``{True: [...],
    False: [...]}`` run lengths.  A track's label each frame: that of the detection of
    camera 0 nearest its points (mean distance under 0.3 of its wrist → middle-MCP
    length); frames without one leave the run as it is."""
    from handvar.tracking.hands import SIDE_SURE

    runs = {True: [], False: []}
    for key, track in tracks.items():
        run, right = 0, True
        for t, r in enumerate(results):
            p = track["points_2d"][t]
            true = np.flatnonzero(score.match[:, t] == score.ids.index(key))
            if not np.isfinite(p).all() or not len(true):
                continue
            dist = [np.mean(np.linalg.norm(d.points[:, :2] - p, axis=1))
                    for d in case.detections[0][t]]  # fmt: skip
            if not dist or min(dist) > 0.3 * np.linalg.norm(p[9] - p[0]):
                continue
            d = case.detections[0][t][int(np.argmin(dist))]
            if not d.side:
                continue
            side = r.hands[key].side
            if d.side != side and d.score >= SIDE_SURE:
                run, right = run + 1, side == case.sides[true[0]]
            elif run:
                runs[right].append(run)
                run = 0
        if run:
            runs[right].append(run)
    return runs


def drawn_off_hidden(score, results) -> int:
    """Of the frames a track is drawn on no true hand (`score.drawn_off`), those where
    it was carried hidden behind the other hand (its `FrameResult.hidden`)."""
    count = 0
    for t, r in enumerate(results):
        for key in score.ids:
            matched = (score.match[:, t] == score.ids.index(key)).any()
            count += bool(r.hands[key].hidden and not r.hands[key].no_hand and not matched)
    return count


def interpolated(tracks: dict, every: int) -> dict:
    """The detector's labelled hands on every `every`-th frame only, each point linearly
    interpolated between two such frames where both have it (which needs the next
    detection: what a user with the detections and no tracker can do at best)."""
    out = {}
    for key, track in tracks.items():
        p = np.asarray(track["points_2d"], dtype=float)
        q = np.full_like(p, np.nan)
        kept = np.arange(0, len(p), every)
        q[kept] = p[kept]
        for a, b in itertools.pairwise(kept):
            for t in range(a + 1, b):
                w = (t - a) / (b - a)
                q[t] = (1 - w) * p[a] + w * p[b]  # NaN where either end has no point
        out[key] = {"points_2d": q, "joints": None}
    return out


def mediapipe_detections(case, cache=None, model: int = 1, every: int = 1,
                         confidence: float = 0.5):  # fmt: skip
    """MediaPipe Hands on the rendered frames, per camera (read from, or written to,
    ``cache/<case>-<size>-cam<j>[-lite][-everyK][-confC].json`` when a cache folder is
    given); `model` its landmark model (1 full, 0 lite), `confidence` its detection and
    tracking thresholds (the pipeline's: 0.5).  With `every` > 1 on every `every`-th
    frame only, as the command runs it: `DETECTOR_PROCESSES` MediaPipes taking those
    frames in turn, each given the frame's index (it looks twice at a frame far from
    the last it saw); no hand on the other frames."""
    from pathlib import Path

    from handvar.vision.detector import DETECTOR_PROCESSES
    from handvar.vision.keypoints import read_detections, write_detections
    from handvar.vision.mediapipe import MediaPipeHands

    out = []
    height, width = case.frames.shape[2:4]
    for j in range(len(case.rig)):
        name = (f"{case.name}-{width}x{height}-cam{j}{'' if model else '-lite'}"
                f"{'' if every == 1 else f'-every{every}'}"
                f"{'' if confidence == 0.5 else f'-conf{confidence:g}'}.json")  # fmt: skip
        options = {"model_complexity": model, "min_detection_confidence": confidence,
                   "min_tracking_confidence": confidence}  # fmt: skip
        path = None if cache is None else Path(cache) / name
        if path is not None and path.exists():
            out.append(read_detections(path))
            continue
        if every == 1:
            detect = MediaPipeHands(**options)
            out.append([detect(cv2.cvtColor(case.frames[j, t], cv2.COLOR_RGB2BGR))
                        for t in range(case.n_frames)])  # fmt: skip
            detect.close()
        else:
            detectors = [MediaPipeHands(**options) for _ in range(DETECTOR_PROCESSES)]
            found = []
            for t in range(case.n_frames):
                k = t // every
                image = cv2.cvtColor(case.frames[j, t], cv2.COLOR_RGB2BGR)
                found.append(detectors[k % len(detectors)](image, frame=t)
                             if t % every == 0 else [])  # fmt: skip
            for d in detectors:
                d.close()
            out.append(found)
        if path is not None:
            path.parent.mkdir(parents=True, exist_ok=True)
            write_detections(path, out[-1])
    return out


def mean_off(points: np.ndarray, truth: np.ndarray) -> float:
    """Mean distance (pixels) of `points`' (x, y) to `truth`, (21, 2), NaN points left
    out."""
    with np.errstate(invalid="ignore"):
        return float(np.nanmean(np.linalg.norm(points[:, :2] - truth, axis=1)))


def nearest(case, detections, j: int, k: int) -> list:
    """Per frame, the detection of camera j nearest true hand k (mean distance under
    0.5 of its size), or None: each hand's detection given it by the truth, whatever
    its label."""
    from handvar.synth.keypoints import hand_size_px

    size = hand_size_px(case.rig.cameras[j], case.joints[k])
    out = []
    for t, found in enumerate(detections[j]):
        dist = [mean_off(d.points, case.truth_2d[j, k, t]) for d in found]
        near = bool(dist) and min(dist) < 0.5 * size[t]
        out.append(found[int(np.argmin(dist))] if near else None)
    return out


def world_error(case, detections, tracks: dict, score) -> list[tuple[float, float]]:
    """Per true hand, the wrist-relative error (mm) of the detector's world landmarks and
    of the fit on the same frames: those where a detection lies within 0.5 hand sizes
    of it (camera 0, `nearest`) and a track is on it."""
    from handvar.evaluation.metrics import joint_errors

    out = []
    for k in range(2):
        errs = []
        for t, d in enumerate(nearest(case, detections, 0, k)):
            m = score.match[k, t]
            if d is None or d.world is None or not case.in_view[0, k, t] or m < 0:
                continue
            truth = case.joints[k, t][None]
            fit = tracks[score.ids[m]]["joints"][t][None]
            errs.append((joint_errors(truth, d.world[None]).mean(),
                         joint_errors(truth, fit).mean()))  # fmt: skip
        out.append(tuple(np.mean(errs, axis=0)) if errs else (np.nan, np.nan))
    return out


#: Frames in a row without a detection near a hand up to which `lost_causes` counts a
#: miss as brief.
BRIEF_MISS = 10


def lost_causes(case, detections, score, tracks: dict, run: int = BRIEF_MISS,
                show: bool = False) -> np.ndarray:  # fmt: skip
    """Of each true hand's frames lost while visible (`TwoHandScore.lost_visible`, camera
    0), those where a detection lay within 0.5 hand sizes of it (`nearest`: perhaps the
    other hand's, where they overlap), where none had for up to `run` frames in a row
    (the frames a detector on every K-th frame skips count), and for longer: (near,
    missed briefly, missed long), summed over both hands.  `show`: print each such
    frame with camera 0's detections there and the nearest one's mean distance (hand
    sizes), for how many frames none had lain near, and the nearest track's distance."""
    from handvar.evaluation.two_hands import VISIBLE_POINTS
    from handvar.synth.keypoints import hand_size_px

    out = np.zeros(3, np.int64)
    for k in range(2):
        near = nearest(case, detections, 0, k)
        seen = case.visible[0, k].sum(axis=1) >= VISIBLE_POINTS
        size = hand_size_px(case.rig.cameras[0], case.joints[k])
        missed = 0  # frames since a detection last lay near the hand (0: at t)
        for t in range(case.n_frames):
            missed = 0 if near[t] is not None else missed + 1
            if not (case.in_view[0, k, t] and seen[t] and score.match[k, t] < 0):
                continue
            out[0 if not missed else 1 if missed <= run else 2] += 1
            if show:  # distances in hand sizes
                truth = case.truth_2d[0, k, t]
                found = [mean_off(d.points, truth) / size[t] for d in detections[0][t]]
                tracked = [mean_off(tr["points_2d"][t], truth) / size[t] for tr in tracks.values()]
                near_text = f"none near for {missed} frame(s)" if missed else "one near"
                print(
                    f"  lost {case.name} {case.sides[k]} frame {t}: {len(found)} "
                    f"detection(s), the nearest {min(found, default=np.nan):.2f} hand sizes "
                    f"off ({near_text}), the nearest track {np.nanmin([*tracked, np.inf]):.2f}"
                )
    return out


def truth_hits(case, k: int, t: int, d, size: np.ndarray) -> int:
    """How many of detection d's points lie within 0.2 of true hand k's size (`size`,
    per frame, pixels) of its true points in camera 0 at frame t."""
    return int(np.sum(np.linalg.norm(d.points[:, :2] - case.truth_2d[0, k, t], axis=1)
                      <= 0.2 * size[t]))  # fmt: skip


def honoured(case, detections, tracks: dict, score) -> np.ndarray:
    """Per true hand, (frames, frames held, frames near, points right): the frames of
    camera 0 where a detection lies within 0.5 hand sizes of it (`nearest`) and a track
    is on it; of them, those where the track's points lie within 0.2 of the detection's
    hand size (its wrist → middle MCP) of every point it found (the keypoint check), and
    those where their mean distance does; and the detection's points within 0.2 of the
    true hand size of the truth, summed over those frames (out of 21 a frame)."""
    from handvar.synth.keypoints import hand_size_px

    out = np.zeros((2, 4))
    for k in range(2):
        true_size = hand_size_px(case.rig.cameras[0], case.joints[k])
        for t, d in enumerate(nearest(case, detections, 0, k)):
            m = score.match[k, t]
            if d is None or m < 0:
                continue
            found = d.points[:, 2] > 0
            size = np.linalg.norm(d.points[9, :2] - d.points[0, :2])
            dist = np.linalg.norm(tracks[score.ids[m]]["points_2d"][t] - d.points[:, :2], axis=1)
            dist = dist[found] / size
            out[k] += (1, np.all(dist <= 0.2), np.mean(dist) <= 0.2,
                       truth_hits(case, k, t, d, true_size))  # fmt: skip
    return out


def mirrored_pck(args) -> None:
    """``--mirror``: MediaPipe on every case's frames (camera 0) and on the same frames
    flipped left to right (its points flipped back), each true hand's nearest detection
    (`nearest`) scored against the truth: PCK@0.2 per true hand, original / mirrored."""
    from handvar.evaluation.two_hands import two_hand_case
    from handvar.synth.keypoints import hand_size_px
    from handvar.vision.mediapipe import MediaPipeHands

    right = np.zeros((2, 2, 2))  # hand, original / mirrored, (points right, points)
    for scenario in args.scenario:
        for seed in range(args.seeds):
            case = two_hand_case(scenario, cameras=1, seed=seed, size=tuple(args.size))
            width = case.frames.shape[3]
            found = mediapipe_detections(case, args.cache)[0]
            detect = MediaPipeHands()
            flipped = []
            for t in range(case.n_frames):
                image = cv2.flip(cv2.cvtColor(case.frames[0, t], cv2.COLOR_RGB2BGR), 1)
                flipped.append(detect(image))
                for d in flipped[-1]:
                    d.points[:, 0] = (width - 1) - d.points[:, 0]
            detect.close()
            for m, detections in enumerate((found, flipped)):
                for k in range(2):
                    size = hand_size_px(case.rig.cameras[0], case.joints[k])
                    for t, d in enumerate(nearest(case, [detections], 0, k)):
                        if d is not None and case.in_view[0, k, t]:
                            right[k, m] += (truth_hits(case, k, t, d, size), 21)
    pck = right[..., 0] / np.maximum(right[..., 1], 1)
    print(f"MediaPipe's PCK@0.2 against the truth, the frames as rendered / mirrored: left "
          f"hand {pck[0, 0]:.3f} / {pck[0, 1]:.3f}, right hand {pck[1, 0]:.3f} / "
          f"{pck[1, 1]:.3f}")  # fmt: skip


def palm_lengths(case, detections, every: int = 1):
    """`palm_pairs` on one case: the palm lengths (mm) of its true hands' pairs of views
    and of its two hands' pairs whose rays meet within `RAY_GAP`, and per true pair
    (hand, frame, palm)."""
    from handvar.vision.keypoints import RAY_GAP, ray_points

    near = [[nearest(case, detections, j, k) for k in range(2)] for j in range(2)]
    a, b = case.rig.cameras[:2]
    one, two, frames = [], [], []
    for t, k in itertools.product(range(0, case.n_frames, every), range(2)):
        for other, found in ((k, one), (1 - k, two)):
            d0, d1 = near[0][k][t], near[1][other][t]
            if d0 is None or d1 is None or (other != k and (
                    d0 is near[0][other][t] or d1 is near[1][k][t])):  # fmt: skip
                continue  # a view missing, or one detection for both hands
            mid, gap = ray_points(a, d0.points, b, d1.points, palm=(0.0, np.inf))
            if gap <= RAY_GAP:
                found.append(float(np.linalg.norm(mid[9] - mid[0])))  # wrist → middle MCP
                if other == k:
                    frames.append((k, t, found[-1]))
    return one, two, frames


def palm_pairs(args) -> None:
    """``--palms``: with two cameras, the wrist → middle-MCP length the detections'
    rays make (`handvar.vision.keypoints.ray_points` without its `PALM_MM` test) for
    each true hand's pair of views (`nearest` in both cameras) and for each pair of
    the two hands' views (one hand's in camera 0, the other's in camera 1) whose rays
    meet within `RAY_GAP` all the same: whether the palm test can tell one hand seen
    twice from two hands meeting by chance.  Prints the true pairs under the test's
    lower bound (case, hand, frame, palm)."""
    from handvar.evaluation.two_hands import two_hand_case
    from handvar.vision.keypoints import PALM_MM, RAY_GAP

    one, two, short = [], [], []
    for scenario in args.scenario:
        for seed in range(args.seeds):
            case = two_hand_case(scenario, cameras=2, seed=seed, size=tuple(args.size))
            detections = case.detections
            if args.detector == "mediapipe":
                detections = mediapipe_detections(case, args.cache, every=args.every)
            ones, twos, frames = palm_lengths(case, detections, args.every)
            one += ones
            two += twos
            short += [f"{case.name} {case.sides[k]} frame {t}: {palm:.0f} mm"
                      for k, t, palm in frames if palm < PALM_MM[0]]  # fmt: skip
    for name, palms in (("one hand's views", one), ("two hands' views", two)):
        palms = np.asarray(palms)
        low, high = (np.count_nonzero(palms < PALM_MM[0]), np.count_nonzero(palms > PALM_MM[1]))
        print(f"{name}: {len(palms)} pairs whose rays meet within {RAY_GAP:g} mm; "
              f"palm {np.min(palms, initial=np.inf):.0f}–{np.max(palms, initial=0):.0f} mm, "
              f"median {np.median(palms) if len(palms) else np.nan:.0f}; under "
              f"{PALM_MM[0]:g} mm {low}, over {PALM_MM[1]:g} mm {high}")  # fmt: skip
    for line in short:
        print(f"  one hand's views under {PALM_MM[0]:g} mm: {line}")


def nearest_points(case, k: int) -> np.ndarray:
    """(2, T, 21, 2): the points of `nearest` in the first two cameras, NaN where there
    is none (and where a point is not found)."""
    out = np.full((2, case.n_frames, 21, 2), np.nan)
    for j in range(2):
        for t, d in enumerate(nearest(case, case.detections, j, k)):
            if d is not None:
                out[j, t] = np.where(d.points[:, 2:] > 0, d.points[:, :2], np.nan)
    return out


def triangulation_error(case, k: int, tracks: dict, score) -> tuple[float, float]:
    """True hand k's detections in the first two cameras (`nearest_points`: the
    baseline at its best) triangulated point by point (`studies/realistic.py`'s
    `triangulated`), and the fit on the same frames: mean absolute 3D error, mm."""
    from handvar.evaluation.metrics import joint_errors
    from realistic import triangulated

    tri = triangulated(case, nearest_points(case, k))
    fit = np.full_like(tri, np.nan)
    for t in np.flatnonzero(score.match[k] >= 0):
        fit[t] = tracks[score.ids[score.match[k, t]]]["joints"][t]
    both = (
        case.in_view[0, k] & np.isfinite(tri).all(axis=(1, 2)) & np.isfinite(fit).all(axis=(1, 2))
    )
    if not both.any():
        return np.nan, np.nan
    truth = case.joints[k, both]
    return (float(joint_errors(truth, tri[both], alignment="none").mean()),
            float(joint_errors(truth, fit[both], alignment="none").mean()))  # fmt: skip


#: The study's options that set a constant of `handvar.tracking.hands` for the run:
#: (option, type, constant, what it is).
RULE_OPTIONS = (
    ("--side-run", int, "SIDE_RUN", "sure labels in a row that turn a hand's side"),
    ("--missed-carry", int, "MISSED_CARRY", "frames a missed hand is followed by optical flow"),
    ("--hidden-frames", int, "HIDDEN_FRAMES",
     "frames a hand behind or against the other is carried, held, at most GONE_FRAMES + 1"),
    ("--missed-frames", int, "MISSED_FRAMES", "frames a hand missed in the open is carried, held"),
    ("--held-view", float, "HELD_VIEW",
     "confidence of the points a missed hand followed in one camera only is held at in the "
     "others"),
    ("--same-hand", float, "SAME_HAND",
     "palm lengths within which two hands' views are one hand's"),
    ("--hidden-weight", float, "HIDDEN_WEIGHT",
     "confidence factor of a keypoint inside the outline of the hand in front"),
    ("--alone-palm", float, "ALONE_PALM",
     "mm: the shortest palm a hand's views may make where no other hand's view is left over"),
)  # fmt: skip


def main() -> None:
    from handvar.evaluation.two_hands import (
        SCENARIOS,
        detections_as_tracks,
        score_two_hands,
        two_hand_case,
    )

    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seeds", type=int, default=2)
    parser.add_argument("--cameras", type=int, default=1, choices=(1, 2))
    parser.add_argument("--detector", default="simulated", choices=("simulated", "mediapipe"))
    parser.add_argument("--scenario", nargs="*", default=list(SCENARIOS))
    parser.add_argument("--size", type=int, nargs=2, default=(640, 360))
    parser.add_argument("--every", type=int, default=1,
                        help="the detector on every K-th frame (the detections' baseline: "
                             "interpolated between them)")  # fmt: skip
    for option, kind, constant, what in RULE_OPTIONS:  # the tracker's constants, per run
        parser.add_argument(option, type=kind, default=None,
                            help=f"{what} (handvar.tracking.hands.{constant})")  # fmt: skip
    parser.add_argument("--landmarks", default="full", choices=("full", "lite"),
                        help="MediaPipe's landmark model (the pipeline's: full)")  # fmt: skip
    parser.add_argument("--mirror", action="store_true",
                        help="only MediaPipe's PCK per hand on the frames as rendered and "
                             "mirrored (camera 0)")  # fmt: skip
    parser.add_argument("--palms", action="store_true",
                        help="only the palm lengths two cameras' views triangulate to, "
                             "one hand's and two hands' (the test of PALM_MM)")  # fmt: skip
    parser.add_argument("--no-look", action="store_true",
                        help="with MediaPipe, no second look where a hand expected was "
                             "missed (HandsTracker's look)")  # fmt: skip
    parser.add_argument("--lost-frames", action="store_true",
                        help="print each frame the fit lost a visible hand on")  # fmt: skip
    parser.add_argument("--forward-only", action="store_true",
                        help="no hand found late carried back (HandsTracker.back_fill), "
                             "as live")  # fmt: skip
    parser.add_argument("--confidence", type=float, default=0.5,
                        help="MediaPipe's detection and tracking thresholds (the "
                             "pipeline's: 0.5)")  # fmt: skip
    parser.add_argument(
        "--cache", default=None, help="a folder keeping MediaPipe's detections per case, for reruns"
    )
    parser.add_argument("--silhouette-term", type=float, default=0.0,
                        help="σ of the keypoint fit's silhouette term, hand sizes (handvar "
                             "track --silhouette-term; 0: off)")  # fmt: skip
    parser.add_argument("--no-split", action="store_true",
                        help="with --silhouette-term: each hand given the skin as one hand "
                             "would be, not its share (HandsTracker, rule 5)")  # fmt: skip
    args = parser.parse_args()
    if args.mirror:
        mirrored_pck(args)
        return
    if args.palms:
        palm_pairs(args)
        return
    import handvar.tracking.hands as rules
    from handvar.tracking.recovery import RECOVERY_DEFAULTS

    recovery = RECOVERY_DEFAULTS.with_silhouette_term(args.silhouette_term)

    for option, _, constant, _ in RULE_OPTIONS:
        value = getattr(args, option[2:].replace("-", "_"))
        if value is not None:  # the tracker's constant, for this run
            setattr(rules, constant, value)
    print(f"{args.detector} detector on every {args.every} frame(s), {args.cameras} camera(s), "
          f"{args.size[0]}x{args.size[1]}, seeds 0..{args.seeds - 1}")  # fmt: skip
    head = (f"{'case':<18}{'hand':<6}{'switches det/fit':>17}{'PCK det':>9}{'PCK fit':>9}"
            f"{'lost det/fit':>13}{'3D rel':>8}{'abs':>7}")  # fmt: skip
    if args.detector == "mediapipe":
        head += f"{'MP 3D':>7}{'fit':>6}"
    if args.cameras == 2:
        head += f"{'tri':>7}{'fit':>7}"
    print(head + f"{'fits/s':>8}")
    totals = {"det": [], "fit": [], "sw_det": 0, "sw_fit": 0, "lost_det": [], "lost_fit": [],
              "seen_det": 0, "seen_fit": 0, "off_det": 0, "off_fit": 0, "off_hidden": 0,
              "away_det": 0, "away_fit": 0,
              "side_det": 0, "side_fit": 0, "runs": {True: [], False: []},
              "rel": [], "abs": [], "mp": [], "tri": [], "same": [], "fps": [],
              "view": 0}  # fmt: skip
    by_scenario = {}
    for scenario in args.scenario:
        for seed in range(args.seeds):
            first = len(totals["det"])  # this case's rows of the totals start here
            case = two_hand_case(scenario, cameras=args.cameras, seed=seed, size=tuple(args.size))
            detections = case.detections
            if args.detector == "mediapipe":
                detections = mediapipe_detections(case, args.cache, int(args.landmarks == "full"),
                                                  args.every, args.confidence)  # fmt: skip
                case = dataclasses.replace(case, detections=detections)
            raw_tracks = detections_as_tracks(case)
            if args.every > 1:
                raw_tracks = interpolated(raw_tracks, args.every)
            raw = score_two_hands(case, raw_tracks)
            look = "mediapipe" if args.detector == "mediapipe" and not args.no_look else None
            tracks, fps, results = fitted_tracks(case, detections, args.every,
                                                 not args.forward_only, look, recovery,
                                                 not args.no_split)  # fmt: skip
            fit = score_two_hands(case, tracks)
            totals["side_det"] += wrong_sides(case, raw, {side: side for side in raw_tracks})
            for right, found in label_runs(case, fit, tracks, results).items():
                totals["runs"][right] += found
            totals["side_fit"] += wrong_sides(case, fit, {
                key: [r.hands[key].side for r in results] for key in tracks
            })  # fmt: skip
            mp = (
                world_error(case, detections, tracks, fit) if args.detector == "mediapipe" else None
            )
            totals["held"] = totals.get("held", 0) + honoured(case, detections, tracks, fit)
            totals["causes"] = totals.get("causes", 0) + lost_causes(
                case, detections, fit, tracks, show=args.lost_frames
            )
            for k, side in enumerate(case.sides):
                if not case.in_view[0, k].any():
                    continue
                line = (f"{case.name:<18}{side:<6}{raw.switches:>8}/{fit.switches:<8}"
                        f"{raw.pck[k]:>9.3f}{fit.pck[k]:>9.3f}{raw.lost[k]:>7}/{fit.lost[k]:<5}"
                        f"{fit.mpjpe_relative[k]:>8.1f}{fit.mpjpe[k]:>7.1f}")  # fmt: skip
                if mp is not None:
                    line += f"{mp[k][0]:>7.1f}{mp[k][1]:>6.1f}"
                    totals["mp"].append(mp[k])
                if args.cameras == 2:
                    tri, same = triangulation_error(case, k, tracks, fit)
                    line += f"{tri:>7.1f}{same:>7.1f}"
                    totals["tri"].append(tri)
                    totals["same"].append(same)
                print(line + f"{fps:>8.1f}", flush=True)
                totals["det"].append(raw.pck[k])
                totals["fit"].append(fit.pck[k])
                totals["rel"].append(fit.mpjpe_relative[k])
                totals["abs"].append(fit.mpjpe[k])
                totals["lost_det"].append(int(raw.lost[k]))
                totals["lost_fit"].append(int(fit.lost[k]))
                totals["seen_det"] += int(raw.lost_visible[k])
                totals["seen_fit"] += int(fit.lost_visible[k])
                totals["view"] += int(case.in_view[0, k].sum())
            totals["off_det"] += raw.drawn_off
            totals["off_fit"] += fit.drawn_off
            totals["off_hidden"] += drawn_off_hidden(fit, results)
            totals["away_det"] += raw.drawn_away
            totals["away_fit"] += fit.drawn_away
            totals["sw_det"] += raw.switches
            totals["sw_fit"] += fit.switches
            totals["fps"].append(fps)
            if args.silhouette_term > 0:
                totals["skin"] = totals.get("skin", 0) + skin_frames(case)
            row = by_scenario.setdefault(scenario, {"sw_det": 0, "sw_fit": 0, "rows": []})
            row["sw_det"] += raw.switches
            row["sw_fit"] += fit.switches
            row["rows"].extend(range(first, len(totals["det"])))
    held = totals.get("held", np.zeros((2, 4)))
    causes = totals.get("causes", np.zeros(3, np.int64))
    held_all, held_mean = (" / ".join(f"{h[i] / max(h[0], 1):.1%} of {h[0]:.0f}" for h in held)
                           for i in (1, 2))  # fmt: skip
    held_truth = " / ".join(f"{h[3] / max(21 * h[0], 1):.3f}" for h in held)
    print(f"all: identity switches {totals['sw_det']} (detector's labels) / {totals['sw_fit']} "
          f"(fit); PCK {np.nanmean(totals['det']):.3f} / {np.nanmean(totals['fit']):.3f}; "
          f"lost {sum(totals['lost_det'])} / {sum(totals['lost_fit'])} of {totals['view']} "
          f"hand-frames in view ({totals['seen_det']} / {totals['seen_fit']} with at least "
          f"half the hand visible; of the fit's, a detection within 0.5 hand sizes of "
          f"it on {causes[0]}, none for up to {BRIEF_MISS} frames in a row on {causes[1]}, "
          f"longer on {causes[2]}); drawn on no hand {totals['off_det']} / {totals['off_fit']} "
          f"({totals['off_hidden']} of them carried hidden; farther than a hand size "
          f"from both hands {totals['away_det']} / {totals['away_fit']}); on a "
          f"hand of the other side {totals['side_det']} / {totals['side_fit']} (labels "
          f"sure of the other side in a row on a track: at most "
          f"{max(totals['runs'][True], default=0)} where its side is right, "
          f"{sorted(totals['runs'][False])} where wrong); "
          f"fit 3D {np.nanmean(totals['rel']):.1f} mm wrist-relative, "
          f"{np.nanmean(totals['abs']):.1f} mm absolute"
          + (f"; on the frames MediaPipe found the hand, its world landmarks "
             f"{np.nanmean([m for m, _ in totals['mp']]):.1f} mm, the fit "
             f"{np.nanmean([f for _, f in totals['mp']]):.1f} mm wrist-relative"
             if totals["mp"] else "")
          + (f"; absolute 3D on the frames both cameras detected the hand: triangulated "
             f"{np.nanmean(totals['tri']):.1f} mm, fit {np.nanmean(totals['same']):.1f} mm"
             if totals["tri"] else "")
          + f"; keypoints held (camera 0, frames with a detection of the hand and a track"
            f" on it; the left hand / the right): every point within 0.2 hand sizes on "
            f"{held_all}, the mean on {held_mean}; on those frames the detection's PCK@0.2"
            f" against the truth {held_truth}"
          + f"; {np.mean(totals['fps']):.1f} fits/s (both hands)")  # fmt: skip
    if "skin" in totals:
        frames = len(args.scenario) * args.seeds * case.n_frames
        print(f"a skin silhouette (camera 0) on {totals['skin']} of {frames} frames (the "
              f"others' backgrounds are skin-coloured: no silhouette, no term)")  # fmt: skip
    print_scenarios(by_scenario, totals)


def skin_frames(case) -> int:
    """Camera 0's frames of `case` on which the skin gives a silhouette (the published
    skin model and clean-up, as the fit's silhouette term has it): one that does not
    touch every border of the image."""
    from handvar.vision.skin import SkinModel
    from handvar.vision.sources import frame_silhouettes

    model = SkinModel()
    found = 0
    for t in range(case.n_frames):
        image = cv2.cvtColor(case.frames[0, t], cv2.COLOR_RGB2BGR)
        found += bool(frame_silhouettes([image], model, index=t, names=["cam0"], wrist=False,
                                        allow_empty=True)[0].any())  # fmt: skip
    return found


def print_scenarios(by_scenario, totals) -> None:
    """Per scenario (its seeds and both hands) and overall, a Markdown table of the
    detector's and the fit's switches, PCK (the mean of the hands') and lost frames, and
    the fit's 3D error (wrist-relative, absolute; mm), with MediaPipe's world landmarks
    and the triangulated detections beside it where the run has them."""
    mp = bool(totals["mp"])  # MediaPipe's world landmarks beside the fit's 3D
    tri = bool(totals["tri"])  # two cameras: the detections triangulated, the fit there

    def mean(key, k, column=None) -> float:
        values = np.asarray(totals[key], dtype=float)[k]
        return float(np.nanmean(values if column is None else values[:, column]))

    def line(name, sw_det, sw_fit, k) -> str:
        lost = [int(np.asarray(totals[key])[k].sum()) for key in ("lost_det", "lost_fit")]
        out = (
            f"| {name} | {sw_det} / **{sw_fit}** | {mean('det', k):.3f} / "
            f"**{mean('fit', k):.3f}** | {lost[0]} / **{lost[1]}** | {mean('rel', k):.1f}"
        )
        if mp:
            out += f" | {mean('mp', k, 0):.1f} / **{mean('mp', k, 1):.1f}**"
        out += f" | {mean('abs', k):.1f} |"
        if tri:
            out += f" {mean('tri', k):.1f} / **{mean('same', k):.1f}** |"
        return out  # fmt: skip

    print("\n| scenario | switches | PCK | lost | 3D wrist-relative |"
          + (" the same, where MediaPipe found the hand: MP / **fit** |" if mp else "")
          + " 3D absolute |" + (" triangulated / **fit**, same frames |" if tri else "")
          + "\n|---|---:|---:|---:|---:|---:|" + ("---:|" if mp else "")
          + ("---:|" if tri else ""))  # fmt: skip
    for scenario, row in by_scenario.items():
        print(line(scenario, row["sw_det"], row["sw_fit"], row["rows"]))
    print(line(f"**all** ({totals['view']} hand-frames in view)", totals["sw_det"],
               totals["sw_fit"], np.arange(len(totals["det"]))))  # fmt: skip


if __name__ == "__main__":
    main()
