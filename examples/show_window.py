"""The ``handvar track --show`` window on the example video, captured from the screen.

Runs the command's preview (`handvar.cli.track`, ``--show``: MediaPipe inside, each
frame's model drawn in an OpenCV window) on the example video and, when the window
shows frame N, takes a screenshot of the display (``xwd -root``, converted by netpbm's
``xwdtopnm`` and ``pnmtopng``) and cuts the window's image out of it.  It needs a
display and OpenCV with a GUI (the ``mediapipe`` extra's); without a screen, Debian's
``xvfb`` gives one:

    xvfb-run -a -s "-screen 0 1024x768x24" python examples/show_window.py \\
        [--frame 66] [--out docs/images/show-window.png]
"""

from __future__ import annotations

import argparse
import subprocess
from pathlib import Path

import cv2
import numpy as np


def screenshot() -> np.ndarray:
    """The whole display, BGR."""
    xwd = subprocess.run(["xwd", "-root", "-silent"], capture_output=True, check=True).stdout
    pnm = subprocess.run(["xwdtopnm"], input=xwd, capture_output=True, check=True).stdout
    png = subprocess.run(["pnmtopng"], input=pnm, capture_output=True, check=True).stdout
    return cv2.imdecode(np.frombuffer(png, np.uint8), cv2.IMREAD_COLOR)


def main() -> None:
    import handvar.cli.track as command
    from handvar.data import example_path

    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--frame", type=int, default=66)
    parser.add_argument("--out", type=Path, default=Path("show-window.png"))
    args = parser.parse_args()

    shown, real = [], cv2.imshow

    def imshow(name, image):  # the window's own call, then the screen taken once drawn
        real(name, image)
        cv2.waitKey(50)
        if len(shown) == args.frame:
            screen = screenshot()
            # the window's image: where it matches what was drawn (below its toolbar)
            found = cv2.matchTemplate(screen, image, cv2.TM_SQDIFF_NORMED)
            _, _, (x, y), _ = cv2.minMaxLoc(found)
            h, w = image.shape[:2]
            cv2.imwrite(str(args.out), screen[y : y + h, x : x + w],
                        [cv2.IMWRITE_PNG_COMPRESSION, 9])  # fmt: skip
            print(f"frame {args.frame}: the window at ({x}, {y}) -> {args.out}")
        shown.append(name)

    cv2.imshow = imshow
    command._track_one(str(example_path("video")), show=True, hand=None, hand_length=185.0,
                       model="spheres", frames=args.frame + 2, scale=0.5)  # fmt: skip


if __name__ == "__main__":
    main()
