"""`handvar synth` and `handvar show`: a synthetic sequence, a pose drawn in the rig.

Also how a pose argument is read and checked (`load_pose`, `check_limits`; for the
camera, `handvar.camera.check_in_front`), for `show POSE` and `track --init`.
"""

from __future__ import annotations

import click

from handvar.cli.common import _FiniteRange, _one_line_errors

# --- synth: render a synthetic sequence with ground truth ------------------------------


@click.command("synth")
@click.argument("name")
@click.argument("out", type=click.Path())
@click.option(
    "--seed",
    type=click.IntRange(min=0),
    default=0,
    show_default=True,
    help="Seed of the motion (and of the colour frames).",
)
@click.option("--model", type=click.Choice(("spheres", "mesh")), default="spheres",
              show_default=True, help="Hand surface: sphere-mesh or skinned mesh.")  # fmt: skip
@click.option("--rgb", is_flag=True, help="Also render shaded colour frames.")
@click.option(
    "--frames",
    "n_frames",
    type=click.IntRange(min=1),
    default=None,
    help="Keep only the first N frames (a quick preview).",
)
@click.option("--size", nargs=2, type=float, default=(1.0, 1.0), show_default=True,
              metavar="LENGTH BREADTH",
              help="Hand length and breadth as factors of the default 185 mm hand.")  # fmt: skip
@click.option("--speed", type=click.FloatRange(min=1.0), default=1.0, show_default=True,
              help="Replay the motion this many times faster (fewer frames).")  # fmt: skip
@click.option("--noise", type=click.FloatRange(min=0.0, max=50.0), default=0.0,
              show_default=True, help="Segmentation errors, px.")  # fmt: skip
@_one_line_errors
def synth_command(
    name: str,
    out: str,
    model: str,
    seed: int,
    rgb: bool,
    n_frames: int | None,
    size: tuple[float, float] = (1.0, 1.0),
    speed: float = 1.0,
    noise: float = 0.0,
) -> None:
    """Render the synthetic sequence NAME (benchmark, flexion, flip) into directory OUT.

    OUT receives sequence.json, per-camera PNG masks (and colour frames with --rgb)
    and truth.npz; an existing sequence there is replaced only once the new one is
    complete.
    """
    from tqdm import tqdm

    from handvar.io import check_output_dir, write_sequence
    from handvar.synth.mismatch import generator_hand
    from handvar.synth.sequences import make_sequence

    check_output_dir(out, argument="OUT")  # fail before rendering, not after
    seq = make_sequence(
        name,
        seed=seed,
        rgb=rgb,
        n_frames=n_frames,
        hand=generator_hand(model, *size),
        speed=speed,
        silhouette_noise=noise,
        progress=lambda it: tqdm(it, desc=f"rendering {name}", unit="frame", leave=False),
    )
    path = write_sequence(
        seq, out, progress=lambda it: tqdm(it, desc="writing", unit="frame", leave=False)
    )
    w, h = seq.image_size
    click.echo(
        f"{seq.name}: {seq.n_frames} frames, {seq.n_cameras} cameras {w}x{h}, "
        f"{seq.fps:g} fps -> {path}"
    )


# --- show: draw a pose in the default stereo rig -----------------------------------------


def load_pose(spec: str):
    """A (26,) pose from a named pose (``open``, ``fist``, ...) or a pose file.

    A pose file holds the 26 parameters (mm, degrees): a text file of 26 numbers
    (whitespace or comma separated) or a ``.npy`` array.
    """
    import os

    import numpy as np

    from handvar.hand.kinematics import POSE_NAMES, named_pose
    from handvar.params import check_pose

    if spec in POSE_NAMES:
        return named_pose(spec)
    if not os.path.isfile(spec):
        raise ValueError(
            f"POSE: expected a named pose ({', '.join(POSE_NAMES)}) or a pose file; got {spec!r}"
        )
    try:
        if spec.lower().endswith(".npy"):
            values = np.load(spec, allow_pickle=False)
        else:
            with open(spec) as fh:
                values = np.array(fh.read().replace(",", " ").split(), dtype=float)
    except ValueError as exc:
        raise ValueError(f"{spec}: expected 26 numbers; {exc}") from None
    values = np.asarray(values, dtype=float).ravel()
    return check_limits(check_pose(values, spec), spec)


def check_limits(x, name: str):
    """`x` if every parameter lies within the joint limits of `handvar.params`, else raise."""
    import numpy as np

    from handvar.params import LOWER, NAMES, UPPER

    outside = np.flatnonzero((x < LOWER) | (x > UPPER))
    if outside.size:
        i = int(outside[0])
        raise ValueError(
            f"{name}: expected a pose within the parameter limits; {NAMES[i]} = {x[i]:g} "
            f"is outside [{LOWER[i]:g}, {UPPER[i]:g}]"
        )
    return x


@click.command("show")
@click.argument("pose")
@click.option(
    "--out",
    type=click.Path(dir_okay=False),
    default=None,
    help="PNG file to write [default: POSE.png, named after the pose].",
)
@click.option(
    "--hand-length",
    type=_FiniteRange(min=50.0, max=400.0),
    default=185.0,
    show_default=True,
    help="Hand length (wrist crease to middle fingertip), mm (as for `track`).",
)
@click.option(
    "--shaded/--silhouette",
    default=False,
    show_default=True,
    help="Draw a shaded colour rendering instead of the silhouette.",
)
@click.option(
    "--frame",
    type=click.IntRange(min=0),
    default=None,
    help="POSE is a sequence directory: draw the true pose of frame K over its masks.",
)
@click.option("--model", type=click.Choice(("spheres", "mesh")), default="spheres",
              show_default=True, help="Hand surface: sphere-mesh or skinned mesh.")  # fmt: skip
@_one_line_errors
def show_command(
    pose: str,
    out: str | None,
    hand_length: float,
    shaded: bool,
    frame: int | None,
    model: str,
) -> None:
    """Draw POSE (a named pose or a file of 26 numbers) in both default cameras.

    Writes a PNG with the two views side by side: the model's silhouette (or a shaded
    rendering) with the 21 joints and the bones drawn on it.
    """
    import os

    import cv2
    import numpy as np

    from handvar.atomic import OutputSet, check_output_file
    from handvar.camera import Rig, check_in_front
    from handvar.hand.anthropometry import HandShape
    from handvar.hand.kinematics import HandModel
    from handvar.render import draw_overlay, render_rgb, side_by_side, silhouettes

    if out is not None:
        check_output_file(out, "--out", suffixes=(".png",))
    x = load_pose(pose) if frame is None else None
    hand = HandModel(HandShape.from_size(hand_length), surface=model)
    rig = Rig.default()
    if frame is not None:  # a frame of a sequence: its true pose, its rig, its masks
        x, rig, masks = _sequence_frame(pose, frame)
        pose = f"{pose.rstrip(os.sep)}-{frame:05d}"
    label = os.path.splitext(os.path.basename(pose))[0]
    if out is None:
        out = check_output_file(f"{label}.png", "--out", suffixes=(".png",))
    joints = hand.joints(x)
    check_in_front(joints, rig, "POSE")
    if frame is None:
        masks = silhouettes(hand, x, rig)
    if shaded:
        base = render_rgb(hand, x, rig, background="plain", rng=np.random.default_rng(0))
    else:
        base = masks
    views = [draw_overlay(b, cam, joints) for b, cam in zip(base, rig, strict=True)]
    titles = [f"{label} - {name} camera" for name in rig.names]
    image = side_by_side(views, titles)

    def write_png(tmp: str) -> None:
        if not cv2.imwrite(tmp, cv2.cvtColor(image, cv2.COLOR_RGB2BGR)):
            raise OSError(f"{out}: cannot write the PNG")

    with OutputSet() as outputs:
        outputs.add(out, write_png)
    click.echo(f"{label}: {len(rig)} views -> {out}")


def _sequence_frame(path: str, frame: int):
    """True pose, rig and masks of frame `frame` of the sequence directory `path`."""
    from handvar.io import read_sequence

    seq = read_sequence(path, lazy=True)
    if frame >= seq.n_frames:
        raise ValueError(f"--frame: expected a frame below {seq.n_frames}; got {frame}")
    if seq.truth is None:
        raise ValueError(f"{path}: expected a sequence with truth.npz for --frame; it has none")
    return seq.truth.poses[frame], seq.rig, seq.masks[frame]
