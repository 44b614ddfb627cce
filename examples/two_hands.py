"""Both hands tracked through a rendered crossing, drawn as a strip of frames.

Renders the two-hand benchmark's ``cross`` scenario (`handvar.evaluation.two_hands`:
a left and a right hand, one passing in front of the other) to a video, tracks it the
way a user would — ``handvar.track(video, hands=2)``, MediaPipe inside, asked for two
hands — and draws six evenly spaced frames of its overlay (each hand in its side's
colour: right orange, left light blue) into one image.

    python examples/two_hands.py [--out docs/images/two-hands-strip.png] [--seed S]
"""

from __future__ import annotations

import argparse
import tempfile
from pathlib import Path

import cv2
import numpy as np


def main() -> None:
    import handvar
    from handvar.evaluation.two_hands import two_hand_case
    from handvar.render.overlay import side_by_side

    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", type=Path, default=Path("two-hands-strip.png"))
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--scenario", default="cross")
    args = parser.parse_args()
    case = two_hand_case(args.scenario, seed=args.seed)
    with tempfile.TemporaryDirectory() as tmp:
        video = Path(tmp) / f"{args.scenario}.mp4"
        h, w = case.frames.shape[2:4]
        writer = cv2.VideoWriter(str(video), cv2.VideoWriter_fourcc(*"mp4v"), case.fps, (w, h))
        for rgb in case.frames[0]:
            writer.write(cv2.cvtColor(rgb, cv2.COLOR_RGB2BGR))
        writer.release()
        result = handvar.track(str(video), hands=2)
        result.save(Path(tmp) / "out")
        capture = cv2.VideoCapture(str(Path(tmp) / "out" / "overlay.mp4"))
        frames = []
        while True:
            ok, frame = capture.read()
            if not ok:
                break
            frames.append(cv2.cvtColor(frame, cv2.COLOR_BGR2RGB))
    picks = np.linspace(0, len(frames) - 1, 6).round().astype(int)
    views = [cv2.resize(frames[t], (320, int(320 * frames[t].shape[0] / frames[t].shape[1])),
                        interpolation=cv2.INTER_AREA) for t in picks]  # fmt: skip
    top, bottom = (
        side_by_side(views[:3], [f"frame {t}" for t in picks[:3]]),
        side_by_side(views[3:], [f"frame {t}" for t in picks[3:]]),
    )
    strip = np.concatenate([top, bottom], axis=0)
    args.out.parent.mkdir(parents=True, exist_ok=True)
    cv2.imwrite(str(args.out), cv2.cvtColor(strip, cv2.COLOR_RGB2BGR))
    sides = ", ".join(f"{k}: {t.shape.side}" for k, t in sorted(result.tracks.items()))
    print(f"{args.scenario}: {result.n_frames} frames, hands {sides} -> {args.out}")


if __name__ == "__main__":
    main()
