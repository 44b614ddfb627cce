"""What one camera tells of the hand's 3D: its size, its depth, and its orientation.

Seen by one camera, a hand's 3D error relative to its wrist has three parts: its size,
its orientation (how it is turned towards the camera), and its articulation.  On the
realistic benchmark's renders (`studies/realistic.py --out DIR --detector inside`
writes the cases and the one command's tracks, with MediaPipe's points and world
landmarks in ``keypoints.npz``), this prints per mono case and overall:

- **size**: the true wrist → middle-MCP length against MediaPipe's world landmarks'
  (median over the frames), their ratio, and the correlation of the two over the cases
  (all cases, mono and stereo: MediaPipe sees camera 0 alone);
- **depth**: per mono case the fit's depth against the truth's, beside the fitted
  hand's size and the size of MediaPipe's 2D palm, each over the true one's (a fit
  matching points p times the true spread with a hand s times the true size lies at
  s / p times the true depth);
- **orientation**: the wrist-relative error (MPJPE) of MediaPipe's world landmarks (as
  they are, and turned from the ray through their palm into the camera's axes, as the
  fit takes them: `world_in_camera`) and of the fit, then the same once each frame's
  estimate is turned about its wrist onto the truth (`joint_errors(alignment=
  "rotation")`: size and articulation left), the median angle of that turn (the
  orientation error) and of its part about the optical axis (a turn within the image,
  which the 2D points show), the case's mean turn (what stays over the case: its angle
  and rotation vector in camera 0's axes) and each frame's angle from it (what varies);
  the last column is the median angle between a
  fit's orientation and MediaPipe's turned one.  With the 2D-only fits of ``--detector
  mediapipe`` in the same DIR, their row too (the fit given MediaPipe's 2D points alone,
  no world landmarks).

    PYTHONPATH=src python studies/mono_3d.py --cases DIR
"""

from __future__ import annotations

import argparse
from pathlib import Path

import numpy as np
from scipy.spatial.transform import Rotation

from handvar.evaluation.metrics import joint_errors, rotation_about_wrist, rotation_angle
from handvar.evaluation.realistic import read_case
from handvar.hand.anthropometry import MIDDLE_MCP, WRIST
from handvar.pipeline import Track
from handvar.vision.keypoints import read_keypoints, world_in_camera
from realistic import fit_points

#: The estimates compared, by the name of their track in DIR/fits (None: the world
#: landmarks the inside track kept, as they are; "turned": the same turned from the ray
#: through their palm into the camera's axes, `world_in_camera`).
ESTIMATES = (
    ("MediaPipe world", None),
    ("MediaPipe world, turned", "turned"),
    ("fit, the one command", "inside"),
    ("fit, MediaPipe 2D only", "mediapipe"),
)
#: The orientation the fits' are compared with: the world landmarks as the fit takes them.
REFERENCE = "MediaPipe world, turned"


def palm_length(points: np.ndarray) -> float:
    """Median over frames of the wrist → middle-MCP distance of (T, 21, 3) points."""
    return float(np.nanmedian(np.linalg.norm(points[:, MIDDLE_MCP] - points[:, WRIST], axis=1)))


def roll(R: np.ndarray) -> float:
    """The part of rotation `R` about camera 0's optical axis (z), degrees: |rotation
    vector's z|, the turn within the image plane."""
    return float(abs(np.degrees(Rotation.from_matrix(R).as_rotvec()[2])))


def orientation_row(truth: np.ndarray, estimate: np.ndarray) -> dict[str, np.ndarray]:
    """Per scored frame (those with every point of the estimate): wrist-relative error,
    the error once turned, the orientation error (degrees) and the rotation."""
    seen = np.isfinite(estimate).all(axis=(1, 2))
    truth, estimate = truth[seen], estimate[seen]
    turns = [rotation_about_wrist(e, z) for e, z in zip(estimate, truth, strict=True)]
    return {
        "frames": seen,
        "wrist": np.nanmean(joint_errors(truth, estimate, alignment="wrist"), axis=1),
        "turned": np.nanmean(joint_errors(truth, estimate, alignment="rotation"), axis=1),
        "angle": np.array([rotation_angle(R) for R in turns]),
        "roll": np.array([roll(R) for R in turns]),
        "turns": turns,
    }


def steady_turn(turns) -> tuple[Rotation, np.ndarray]:
    """The mean of a case's per-frame rotations onto the truth (`Rotation.mean`, the
    chordal L2 mean) and each frame's angle from it, degrees: the part of the
    orientation error that stays over the case, and what varies about it."""
    mean = Rotation.from_matrix(np.stack(turns)).mean()
    rest = [rotation_angle(R @ mean.as_matrix().T) for R in turns]
    return mean, np.asarray(rest)


def size_table(cases: Path) -> None:
    true, seen = [], []
    print(f"{'case':<28} {'hand mm':>7} {'true W-MMCP':>11} {'MediaPipe':>9} {'ratio':>6}")
    for truth in sorted(cases.glob("*/truth.npz")):
        name = truth.parent.name
        files = sorted((cases / "fits" / f"{name}-inside-every1").glob("keypoints*.npz"))
        if not files:
            continue
        with np.load(truth) as z:
            t, length = palm_length(z["joints"]), float(z["hand_length"])
        m = palm_length(read_keypoints(files[0]).world)
        true.append(t)
        seen.append(m)
        print(f"{name:<28} {length:>7.0f} {t:>11.1f} {m:>9.1f} {m / t:>6.3f}")
    true, seen = np.array(true), np.array(seen)
    ratio = seen / true
    print(f"ratio MediaPipe / true: median {np.median(ratio):.3f}, range "
          f"{ratio.min():.3f}-{ratio.max():.3f}; correlation over the cases "
          f"{np.corrcoef(true, seen)[0, 1]:.2f}\n")  # fmt: skip


def depth_table(cases: Path) -> None:
    """Where the fit's absolute error comes from with one camera: its depth, against the
    hand's size and the size of the detector's 2D points.  A fit whose 2D points match
    points p times the true ones' spread, with a hand s times the true size, lies at
    s / p times the true depth."""
    from handvar.tracking.keypoint_cost import hand_length

    print(f"{'case':<26} {'depth':>6} {'fit/true':>8} {'size':>6} {'2D':>6} {'size/2D':>7} "
          f"{'abs':>6} {'depth bias':>10}")  # fmt: skip
    rows = []
    for truth in sorted(cases.glob("*-mono-*/truth.npz")):
        name = truth.parent.name
        fits = cases / "fits" / f"{name}-inside-every1"
        if not (fits / "poses.csv").exists():
            continue
        case = read_case(cases / name)
        side = "left" if "-left-" in name else "right"
        try:
            points = fit_points(fits, side)[0]
        except RuntimeError:  # the wrong hand tracked (studies/realistic.py)
            continue
        cam = case.rig.cameras[0]
        seen = np.isfinite(points).all(axis=(1, 2))
        mid = [WRIST, MIDDLE_MCP]
        z_true = cam.camera_from_world(case.joints[seen][:, mid].mean(axis=1))[:, 2]
        z_fit = cam.camera_from_world(points[seen][:, mid].mean(axis=1))[:, 2]
        size = hand_length(Track.load(fits).hand) / palm_length(case.joints)
        xy = read_keypoints(fits / "keypoints.npz").xy
        true_2d = case.truth_2d[0]
        with np.errstate(invalid="ignore"):
            ratio_2d = np.nanmedian(
                np.linalg.norm(xy[:, MIDDLE_MCP] - xy[:, WRIST], axis=-1)
                / np.linalg.norm(true_2d[:, MIDDLE_MCP] - true_2d[:, WRIST], axis=-1)
            )
        depth = float(np.median(z_fit / z_true))
        error = np.linalg.norm(points[seen] - case.joints[seen], axis=-1).mean()
        rows.append((depth, size / ratio_2d, float(np.mean(z_fit - z_true))))
        print(f"{name:<26} {z_true.mean():>6.0f} {depth:>8.3f} {size:>6.3f} {ratio_2d:>6.3f} "
              f"{size / ratio_2d:>7.3f} {error:>6.1f} {rows[-1][2]:>10.1f}")  # fmt: skip
    depth, predicted, bias = np.array(rows).T
    print(f"{'all mono':<26} {'':>6} {np.median(depth):>8.3f} {'':>6} {'':>6} "
          f"{np.median(predicted):>7.3f} {'':>6} {bias.mean():>10.1f}")  # fmt: skip
    print(
        "mm; depth: the true palm centre's (wrist, middle MCP) from camera 0; fit/true: "
        "median ratio of the fit's to it; size: the fitted hand's wrist → middle-MCP "
        "length over the true one; 2D: median ratio of the detector's wrist → middle-MCP "
        "distance in the image to the true one's; abs: the fit's absolute error; depth "
        "bias: mean fit − true depth\n"
    )


def estimates_of(cases: Path, name: str) -> dict[str, np.ndarray]:
    """(T, 21, 3) points in camera 0's axes of each estimate there is for case `name`."""
    case = read_case(cases / name)
    side = "left" if "-left-" in name else "right"
    R = case.rig.cameras[0].R
    kept = read_keypoints(cases / "fits" / f"{name}-inside-every1" / "keypoints.npz")
    out = {"truth": case.joints @ R.T}
    for label, run in ESTIMATES:
        if run is None:
            out[label] = np.where(kept.present[..., None], kept.world, np.nan)
            continue
        if run == "turned":
            cam = case.rig.cameras[0]
            pairs = zip(out["MediaPipe world"], kept.xy, strict=True)
            out[label] = np.stack([world_in_camera(w, p, cam) for w, p in pairs])
            continue
        fits = cases / "fits" / f"{name}-{run}-every1"
        if (fits / "poses.csv").exists():
            out[label] = fit_points(fits, side)[0] @ R.T
    return out


def orientation_table(cases: Path) -> None:
    names = sorted(p.parent.name for p in cases.glob("*-mono-*/truth.npz")
                   if (cases / "fits" / f"{p.parent.name}-inside-every1").exists())  # fmt: skip
    header = (f"{'case':<26} {'estimate':<24} {'frames':>6} {'MPJPE':>6} {'turned':>6} "
              f"{'orient.':>7} {'in-img':>6} {'steady':>6} {'about x, y, z':>17} "
              f"{'rest':>5} {'vs MP':>6}")  # fmt: skip
    print(header)
    pooled: dict[str, dict[str, list]] = {}
    for name in names:
        points = estimates_of(cases, name)
        rows = {k: orientation_row(points["truth"], v) for k, v in points.items() if k != "truth"}
        mp = rows[REFERENCE]
        for label, row in rows.items():
            both = row["frames"] & mp["frames"]
            mine = [R for R, f in zip(row["turns"], both[row["frames"]], strict=True) if f]
            theirs = [R for R, f in zip(mp["turns"], both[mp["frames"]], strict=True) if f]
            apart = [rotation_angle(a @ b.T) for a, b in zip(mine, theirs, strict=True)]
            steady, rest = steady_turn(row["turns"])
            acc = pooled.setdefault(label, {"wrist": [], "turned": [], "angle": [], "roll": [],
                                            "apart": [], "steady": [], "rest": []})  # fmt: skip
            for key in ("wrist", "turned", "angle", "roll"):
                acc[key].extend(row[key])
            acc["rest"].extend(rest)
            acc["apart"].extend(apart)
            acc["steady"].append(rotation_angle(steady.as_matrix()))
            axes = ", ".join(f"{v:+.0f}" for v in np.degrees(steady.as_rotvec()))
            vs = "" if label.startswith("MediaPipe") else f"{np.median(apart):>6.1f}"
            print(f"{name:<26} {label:<24} {len(row['wrist']):>6} {row['wrist'].mean():>6.1f} "
                  f"{row['turned'].mean():>6.1f} {np.median(row['angle']):>7.1f} "
                  f"{np.median(row['roll']):>6.1f} {acc['steady'][-1]:>6.1f} {axes:>17} "
                  f"{np.median(rest):>5.1f} {vs}")  # fmt: skip
    print()
    for label, acc in pooled.items():
        vs = "" if label.startswith("MediaPipe") else f"{np.median(acc['apart']):>6.1f}"
        print(f"{'all mono':<26} {label:<24} {len(acc['wrist']):>6} {np.mean(acc['wrist']):>6.1f} "
              f"{np.mean(acc['turned']):>6.1f} {np.median(acc['angle']):>7.1f} "
              f"{np.median(acc['roll']):>6.1f} {np.median(acc['steady']):>6.1f} {'':>17} "
              f"{np.median(acc['rest']):>5.1f} {vs}")  # fmt: skip
    print(
        "mm, degrees; MPJPE wrist-relative, turned: after each frame's best rotation about "
        "the wrist; orient.: median angle of that rotation; in-img: median of its part about "
        "the optical axis (a turn within the image); steady: the angle of the case's mean "
        "rotation (all mono: the median over the cases), about x, y, z: its rotation vector "
        "in camera 0's axes (x right, y down the image, z along the optical axis); rest: "
        "median angle of each frame's rotation from that mean; vs MP: median angle between "
        "the fit's orientation and MediaPipe's turned one"
    )


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--cases", required=True, type=Path)
    args = parser.parse_args()
    size_table(args.cases)
    depth_table(args.cases)
    orientation_table(args.cases)


if __name__ == "__main__":
    main()
