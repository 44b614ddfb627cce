"""MediaPipe Hands' time per frame by its options: how many hands it is asked for and its
landmark model.

The pipeline asks MediaPipe (video mode) for two hands with the full landmark model.
Asked for two, MediaPipe runs its palm detector on every frame where it tracks fewer than
two; asked for one, only when it loses the hand.  Each option is run on the example video
(1280×720, one hand, its first 200 frames) and on the two-hand benchmark's `cross`
scenario (640×360, seed 0, 125 frames), one MediaPipe on every frame, in this process.
Printed per run: ms per frame (mean) and the frames with a hand found (with two or more).

    python benchmarks/detector_options.py
"""

from __future__ import annotations

import time

import cv2

from handvar.data import example_path

#: (hands asked for, landmark model: 1 full, 0 lite)
OPTIONS = ((2, 1), (1, 1), (2, 0))


def _video_frames(n: int) -> list:
    cap = cv2.VideoCapture(str(example_path("video")))
    frames = []
    while len(frames) < n:
        ok, image = cap.read()
        if not ok:
            break
        frames.append(cv2.cvtColor(image, cv2.COLOR_BGR2RGB))
    cap.release()
    return frames


def main() -> None:
    from handvar.evaluation.two_hands import two_hand_case
    from handvar.vision.mediapipe import hands_module_alone

    hands = hands_module_alone()
    recordings = {
        "example video": _video_frames(200),
        "two hands (cross)": list(two_hand_case("cross", seed=0).frames[0]),
    }
    print(f"{'recording':<19}{'hands asked':>12}{'model':>7}{'ms/frame':>10}{'found':>7}{'two':>6}")
    for name, frames in recordings.items():
        for asked, model in OPTIONS:
            detector = hands.Hands(static_image_mode=False, max_num_hands=asked,
                                   model_complexity=model)  # fmt: skip
            detector.process(frames[0])  # the graph built and its models loaded
            start = time.perf_counter()
            found = [len(detector.process(f).multi_hand_landmarks or []) for f in frames]
            ms = 1000.0 * (time.perf_counter() - start) / len(frames)
            detector.close()
            one, two = sum(k > 0 for k in found), sum(k > 1 for k in found)
            kind = "full" if model else "lite"
            print(f"{name:<19}{asked:>12}{kind:>7}{ms:>10.1f}{one:>7}{two:>6}", flush=True)


if __name__ == "__main__":
    main()
