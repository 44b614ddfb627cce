"""`handvar export` and `handvar view`: a saved track as standard files and a 3D page."""

from __future__ import annotations

from pathlib import Path

import click

from handvar.cli.common import _one_line_errors

#: Formats of `handvar export` and the default output beside the track.
FORMATS = {
    "json": "keypoints.json",
    "openpose": "openpose",
    "bvh": "track.bvh",
    "gltf": "track.glb",
}
_SUFFIXES = {"json": (".json",), "bvh": (".bvh",), "gltf": (".glb",)}


def _load(track_dir, calib):
    """The track saved in TRACK_DIR (`handvar.Track.load`), with the cameras of `calib`
    instead of the stored ones when given."""
    from handvar.pipeline import Track

    rig = None
    if calib is not None:
        from handvar.camera import Rig

        rig = Rig.load(calib)
    try:
        return Track.load(track_dir, rig=rig)
    except ValueError as exc:
        raise ValueError(f"TRACK_DIR: {str(exc).removeprefix('directory: ')}") from None


def _is_hands(track_dir) -> bool:
    """Whether TRACK_DIR holds both hands (their index, or without one hand's track.npz
    a folder of a hand) rather than one."""
    from handvar.pipeline import HANDS_INDEX, SIDE_RGB

    folder = Path(track_dir)
    if (folder / HANDS_INDEX).is_file():
        return True
    return not (folder / "track.npz").exists() and any((folder / s).is_dir() for s in SIDE_RGB)


def _load_hands(track_dir, calib):
    """The name and the hands of a two-hand directory (`handvar.HandsTrack.load`), as
    ``[(id, track), ...]``."""
    from handvar.pipeline import HandsTrack

    rig = None
    if calib is not None:
        from handvar.camera import Rig

        rig = Rig.load(calib)
    try:
        hands = HandsTrack.load(track_dir, rig=rig)
    except ValueError as exc:
        message = str(exc)
        if message.startswith("directory: "):
            message = "TRACK_DIR: " + message.removeprefix("directory: ")
        raise ValueError(message) from None
    return hands.name, sorted(hands.tracks.items())


def _tracked(hands) -> list:
    """The hands of `_load_hands` as the exports take them (`TrackedHand`)."""
    from handvar.export.hands import TrackedHand

    return [TrackedHand(t.poses, t.hand, id=k, confidence=_confidence(t),
                        support=_support(t)) for k, t in hands]  # fmt: skip


def _hands_frames(hands) -> str:
    """``T frames, right hand (k without), left hand``: each hand and its absent frames."""
    import numpy as np

    parts = []
    for _, t in hands:
        absent = int(np.isnan(t.poses).all(axis=1).sum())
        parts.append(f"{t.shape.side} hand" + (f" ({absent} frames without it)" if absent else ""))
    return f"{len(hands[0][1].poses)} frames, " + ", ".join(parts)


def _confidence(track):
    """Per-frame fit confidence: the tracker's silhouette IoU, or on frames fitted to
    keypoints alone the share of them honoured; 0 on lost frames."""
    from handvar.export.keypoints import fit_confidence, keypoint_share

    share = None if track.quality is None else keypoint_share(track.quality)
    return fit_confidence(track.result.iou, track.result.lost, share)


def _support(track):
    """Per frame and keypoint what the point's own evidence (kept, rejected, far from the
    fit, carried) leaves of its frame's confidence; None without the track's quality."""
    from handvar.export.keypoints import point_support

    return None if track.quality is None else point_support(track.quality, track.detections)


def _frames(track) -> str:
    """``T frames``, and how many of them have no hand (their poses NaN) if any."""
    import numpy as np

    absent = int(np.isnan(track.poses).all(axis=1).sum())
    return f"{len(track.poses)} frames" + (f" ({absent} without a hand)" if absent else "")


_calib_option = click.option(
    "--calib", type=click.Path(dir_okay=False), default=None,
    help="OpenCV calibration file of the cameras to project into, instead of the "
    "track's own (TRACK_DIR/cameras.yml) [default: the track's].",
)  # fmt: skip


@click.command("export")
@click.argument("track_dir")
@click.option("--format", "fmt", type=click.Choice(tuple(FORMATS)), required=True,
              help="json: keypoints per frame (2D, 3D, visibility, confidence); openpose: "
              "OpenPose's per-frame JSON files in a directory; bvh: skeleton and motion; "
              "gltf: skinned mesh and animation (.glb).")  # fmt: skip
@click.option("--out", default=None,
              help="Output file (a directory for openpose) [default: in TRACK_DIR: "
              + ", ".join(f"{k} → {v}" for k, v in FORMATS.items()) + "].")  # fmt: skip
@click.option("--corrective/--no-corrective", default=True, show_default=True,
              help="gltf: helper joints that make the skinned mesh exactly the model's (up "
              "to 16 influences a vertex; without them plain skinning, off by up to 7 mm; "
              "see docs/outputs.md).")  # fmt: skip
@click.option("--units", type=click.Choice(("m", "cm", "mm")), default="m", show_default=True,
              help="bvh: length unit of the file (Blender reads BVH as metres).")  # fmt: skip
@click.option("--up", type=click.Choice(("y", "z")), default="y", show_default=True,
              help="bvh: the file's up axis, turned from the camera frame (y down).")  # fmt: skip
@_calib_option
@_one_line_errors
def export_command(track_dir, fmt, out, corrective, units, up, calib):
    """Export the track saved in TRACK_DIR (by `handvar track --out`) to a standard format.

    Formats, frames, units and conventions: docs/outputs.md.
    """
    import numpy as np

    from handvar.atomic import check_output_dir, check_output_file

    if not Path(track_dir).is_dir():
        raise ValueError(f"TRACK_DIR: expected a track directory; got {track_dir}")
    out = str(Path(track_dir) / FORMATS[fmt]) if out is None else out
    if fmt == "openpose":
        check_output_dir(out, "--out", parents=False)
        _check_openpose_out(out)
    else:
        check_output_file(out, "--out", suffixes=_SUFFIXES[fmt])
    index = Path(track_dir) / "hands.json"
    if Path(out).resolve() == index.resolve():
        raise ValueError(f"--out: expected a file other than the track's own; got {out}, "
                         f"the index of its hands")  # fmt: skip
    if _is_hands(track_dir):
        return _export_hands(track_dir, fmt, out, corrective, units, up, calib)
    track = _load(track_dir, calib)
    if fmt in ("bvh", "gltf") and np.isnan(track.poses).all():
        raise ValueError(
            f"TRACK_DIR: expected a hand on at least one frame ({fmt} holds a pose on every "
            f"frame); track {track.name} has none on its {len(track.poses)} frames"
        )
    if fmt == "json":
        from handvar.export.keypoints import keypoint_frames, write_keypoints_json

        doc = keypoint_frames(track.poses, track.hand, track.rig,
                              confidence=_confidence(track), support=_support(track))  # fmt: skip
        write_keypoints_json(out, doc)
    elif fmt == "openpose":
        from handvar.export.keypoints import openpose_frames, write_openpose

        if track.rig is None:
            raise ValueError("--calib: expected the cameras (the track holds none); got none")
        frames = openpose_frames(track.poses, track.hand, track.rig,
                                 confidence=_confidence(track),
                                 support=_support(track))  # fmt: skip
        write_openpose(out, frames, track.rig.names)
    elif fmt == "bvh":
        from handvar.export.bvh import write_bvh

        write_bvh(out, track.poses, track.shape, fps=track.fps, units=units, up=up)
    else:
        from handvar.export.gltf import write_glb

        write_glb(out, track.poses, track.shape, fps=track.fps, corrective=corrective)
    click.echo(f"{track.name}: {_frames(track)}, {track.shape.side} hand -> {out}")


def _check_openpose_out(out) -> None:
    """--out of --format openpose is replaced whole: a new folder, an empty one or an
    earlier OpenPose export (only ``*_keypoints.json`` files, in folders per camera)."""
    folder = Path(out)
    if not folder.is_dir():
        return
    other = next((p for p in folder.rglob("*") if not p.name.endswith("_keypoints.json")
                  and not (p.is_dir() and p.parent == folder)), None)  # fmt: skip
    if other is not None:
        raise ValueError(f"--out: expected a new folder, an empty one or an earlier OpenPose "
                         f"export (only *_keypoints.json files); {out} holds "
                         f"{other.relative_to(folder)}")  # fmt: skip


def _export_hands(track_dir, fmt, out, corrective, units, up, calib) -> None:
    """`handvar export` of a directory of both hands: one file (folder) holding them all
    (docs/outputs.md, "Both hands")."""
    import numpy as np

    name, hands = _load_hands(track_dir, calib)
    if fmt in ("bvh", "gltf"):
        for _, t in hands:
            if np.isnan(t.poses).all():
                raise ValueError(
                    f"TRACK_DIR: expected each hand on at least one frame ({fmt} holds a pose "
                    f"on every frame); the {t.shape.side} hand of {name} is on none of its "
                    f"{len(t.poses)} frames"
                )
    tracked = _tracked(hands)
    rig = hands[0][1].rig
    if fmt == "json":
        from handvar.export.keypoints import hands_keypoint_frames, write_keypoints_json

        write_keypoints_json(out, hands_keypoint_frames(tracked, rig))
    elif fmt == "openpose":
        from handvar.export.keypoints import hands_openpose_frames, write_openpose

        if rig is None:
            raise ValueError("--calib: expected the cameras (the track holds none); got none")
        write_openpose(out, hands_openpose_frames(tracked, rig), rig.names)
    elif fmt == "bvh":
        from handvar.export.bvh import write_hands_bvh

        write_hands_bvh(out, tracked, fps=hands[0][1].fps, units=units, up=up)
    else:
        from handvar.export.gltf import write_hands_glb

        write_hands_glb(out, tracked, fps=hands[0][1].fps, corrective=corrective)
    click.echo(f"{name}: {_hands_frames(hands)} -> {out}")


def _curves(track) -> dict:
    """The per-frame quality the track holds, by what it is: the silhouette IoU (mean over
    the cameras) where it was measured, the keypoint error in hand sizes where keypoints
    were fitted; NaN on frames without a value."""
    import numpy as np

    error = None
    if track.quality is not None:
        iou, error = track.quality.iou, track.quality.keypoint_error
    elif track.result is not None:  # tracked without recovery: the tracker's IoU
        per_camera = np.asarray(track.result.iou, dtype=float).reshape(track.n_frames, -1)
        seen = np.isfinite(per_camera).sum(axis=1)
        iou = np.where(seen > 0, np.nansum(per_camera, axis=1) / np.maximum(seen, 1), np.nan)
    else:
        return {}
    curves = {"silhouette IoU": np.asarray(iou, dtype=float)}
    if error is not None:
        curves["keypoint error (hand sizes)"] = np.asarray(error, dtype=float)
    return {label: v for label, v in curves.items() if np.isfinite(v).any()}


def _recording(track, video):
    """The recording to take the viewer's frames from and, without one, why (one line):
    `video` when given, else the one the track was made from where it still is."""
    if video is not None:
        return video, None
    paths, kind = track.options.get("source"), track.options.get("kind")
    if kind != "recording" or not isinstance(paths, list) or not paths:
        what = {None: "the track names no recording",
                "camera": "a live camera's frames are not kept"}.get(
            kind, f"the track was made from {paths!r}, not a recording")  # fmt: skip
        return None, f"frames left out: {what}; give one with --video, or --no-frames"
    if not Path(paths[0]).exists():
        return None, (f"frames left out: the recording {paths[0]} is not there; give it "
                      "with --video, or --no-frames")  # fmt: skip
    return paths[0], None


def _video_source(track, video, width: int):
    """The recording `video` opened in the track's first camera, at most `width` pixels
    wide, checked to hold the track's frames; its errors naming --video."""
    from handvar.camera import Rig
    from handvar.vision.sources import open_source

    if track.rig is None:
        raise ValueError("--video: expected the track's cameras to draw the model over the "
                         "frames (the track holds none); give them with --calib")  # fmt: skip
    camera = track.rig.cameras[0]
    try:
        source = open_source(video, Rig((camera,), track.rig.names[:1]),
                             scale=min(1.0, width / camera.size[0]))  # fmt: skip
    except (ValueError, FileNotFoundError) as exc:
        raise ValueError(f"--video: {exc}") from None
    if source.n_frames < track.n_frames:
        raise ValueError(f"--video: expected a recording of at least the track's "
                         f"{track.n_frames} frames; got {source.n_frames} in {video}")  # fmt: skip
    return source


def _viewer_images(track, video, width: int):
    """The frames of `video` (the first camera's recording) at most `width` pixels wide,
    with the model drawn over them at the track's poses (`overlay_views`), RGB: a
    generator, one frame in memory at a time."""
    import cv2

    from handvar.render.overlay import overlay_views

    source = _video_source(track, video, width)
    T, hand = track.n_frames, track.hand

    def frames():
        try:
            for t, (frame,) in source.frames(0, T):
                rgb = cv2.cvtColor(frame, cv2.COLOR_BGR2RGB)
                yield overlay_views(hand, source.rig, [rgb], track.poses[t], thickness=1)[0]
        except ValueError as exc:  # a recording that stops early
            raise ValueError(f"--video: {exc}") from None

    return frames()


@click.command("view")
@click.argument("track_dir")
@click.option("--out", default=None, help="Output page (.html) [default: TRACK_DIR/view.html].")
@click.option("--video", type=click.Path(), default=None,
              help="The recording the track was made from (the first camera's), for "
              "its frames beside the 3D view [default: the track's own, where it is].")  # fmt: skip
@click.option("--frames/--no-frames", default=True, show_default=True,
              help="Show the recording's frames with the model drawn over them (JPEG, at "
              "most 320 px wide).")  # fmt: skip
@_calib_option
@_one_line_errors
def view_command(track_dir, out, video, frames, calib):
    """Write a self-contained HTML page showing the track saved in TRACK_DIR in 3D.

    The hand model's surface and skeleton over time, seen through the camera (a button
    frees the view: drag to turn), the recording's frames with the model drawn over
    them, and the per-frame quality (silhouette IoU, keypoint error), all on one time
    slider; the page needs no network (docs/outputs.md).
    """
    from handvar.atomic import check_output_file

    if not Path(track_dir).is_dir():
        raise ValueError(f"TRACK_DIR: expected a track directory; got {track_dir}")
    if video is not None and not frames:
        raise ValueError(f"--video: expected without --no-frames; got {video}")
    out = str(Path(track_dir) / "view.html") if out is None else out
    check_output_file(out, "--out", suffixes=(".html",))
    if _is_hands(track_dir):
        return _view_hands(track_dir, out, video, frames, calib)
    track = _load(track_dir, calib)
    from handvar.export.viewer import IMAGE_WIDTH, hand_surface, write_viewer

    images = None
    if frames:
        recording, why = _recording(track, video)
        if recording is None:
            click.echo(f"handvar: note: {why}", err=True)
        else:
            images = _viewer_images(track, recording, IMAGE_WIDTH)
    write_viewer(out, track.joints, surface=hand_surface(track.shape, track.poses),
                 images=images, rig=track.rig, quality=_curves(track), fps=track.fps,
                 title=f"handvar track: {track.name}")  # fmt: skip
    size = Path(out).stat().st_size / 1e6
    click.echo(f"{track.name}: {_frames(track)} -> {out} ({size:.1f} MB)")


def _hands_viewer_images(hands, video, width: int):
    """`_viewer_images` of both hands: each hand's bones drawn over the frames in its
    side's colour (`handvar.pipeline.SIDE_RGB`), as the two-hand overlay draws them."""
    import cv2
    import numpy as np

    from handvar.pipeline import SIDE_RGB
    from handvar.render.overlay import draw_overlay

    first = hands[0][1]
    source = _video_source(first, video, width)
    T = first.n_frames
    shown = source.rig.cameras[0]

    def frames():
        try:
            for t, (frame,) in source.frames(0, T):
                rgb = cv2.cvtColor(frame, cv2.COLOR_BGR2RGB)
                for _, track in hands:
                    if np.isfinite(track.joints[t]).all():
                        rgb = draw_overlay(rgb, shown, track.joints[t], thickness=1,
                                           colour=SIDE_RGB[track.shape.side])  # fmt: skip
                yield rgb
        except ValueError as exc:  # a recording that stops early
            raise ValueError(f"--video: {exc}") from None

    return frames()


def _view_hands(track_dir, out, video, frames, calib) -> None:
    """`handvar view` of a directory of both hands: one page, each hand in its side's
    colour (docs/outputs.md, "Both hands")."""
    from handvar.export.viewer import IMAGE_WIDTH, write_hands_viewer
    from handvar.pipeline import SIDE_RGB

    name, hands = _load_hands(track_dir, calib)
    first = hands[0][1]
    images = None
    if frames:
        recording, why = _recording(first, video)
        if recording is None:
            click.echo(f"handvar: note: {why}", err=True)
        else:
            images = _hands_viewer_images(hands, recording, IMAGE_WIDTH)
    quality = {}  # each hand's first curve, by side: two at most
    for _, t in hands:
        for label, values in list(_curves(t).items())[:1]:
            quality[f"{t.shape.side}: {label}"] = values
    write_hands_viewer(out, _tracked(hands), colours=SIDE_RGB, images=images, rig=first.rig,
                       quality=quality, fps=first.fps,
                       title=f"handvar track: {name}")  # fmt: skip
    size = Path(out).stat().st_size / 1e6
    click.echo(f"{name}: {_hands_frames(hands)} -> {out} ({size:.1f} MB)")
