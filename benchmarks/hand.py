"""Timings of the hand model (kinematics, Jacobians, surface queries) and its rendering.

Run ``python benchmarks/hand.py``. Prints the median (and the fastest) of many
repetitions, in microseconds; on a shared machine the median is the figure to quote.
Target (design §10 via the tracker budget): forward kinematics and Jacobian of 600
surface points ≤ 200 µs; drawing 300 surface samples ≤ 30 µs.
"""

from __future__ import annotations

import timeit

import numpy as np

from handvar.camera import Rig
from handvar.hand import HandModel, named_pose


def _report(label: str, func, number: int, repeat: int = 15) -> float:
    """Print and return the median time per call, µs."""
    times = np.array(timeit.repeat(func, number=number, repeat=repeat)) / number * 1e6
    print(f"{label:<58s} median {np.median(times):9.1f} µs   min {times.min():9.1f} µs")
    return float(np.median(times))


def _fresh_poses(rng: np.random.Generator, count: int) -> list[np.ndarray]:
    """Poses that differ from call to call, so that no cached kinematics is reused."""
    base = named_pose("fist")
    return [base + rng.normal(0.0, 0.5, 26) for _ in range(count)]


def bench_kinematics() -> dict[str, float]:
    """Forward kinematics, joints and points with their Jacobians (fresh pose per call)."""
    rng = np.random.default_rng(0)
    model = HandModel()
    samples = model.sample_surface(600, rng)
    results = {}
    number = 200
    for label, call in [
        ("joints G(x)", lambda x: model.joints(x)),
        ("joints G(x) + Jacobian (21, 3, 26)", lambda x: model.joints_jacobian(x)),
        ("600 surface points", lambda x: model.points(x, samples.bone, samples.local)),
        (
            "600 surface points + Jacobian (600, 3, 26)  [target 200]",
            lambda x: model.points(x, samples.bone, samples.local, jacobian=True),
        ),
    ]:
        poses = iter(_fresh_poses(rng, number * 16))
        results[label] = _report(label, lambda c=call, p=poses: c(next(p)), number)
    x = named_pose("fist")
    model.points(x, samples.bone, samples.local)
    label = "600 points + Jacobian, same pose again (cached FK)"
    results[label] = _report(
        label, lambda: model.points(x, samples.bone, samples.local, jacobian=True), number
    )
    return results


def bench_surface() -> dict[str, float]:
    """Sampling, ray casting and the closest projected point."""
    rng = np.random.default_rng(1)
    model = HandModel()
    results = {}
    model.sample_surface(1, rng)  # build the pool
    label = "draw 300 surface samples  [target 30]"
    results[label] = _report(label, lambda: model.sample_surface(300, rng), 2000)
    poses = iter(_fresh_poses(rng, 20 * 16))
    label = "world spheres + Jacobian (20 primitives)"
    results[label] = _report(label, lambda: model.world_spheres(next(poses), True), 20)
    cam = Rig.default()[0]
    x = named_pose("open")
    pixels = cam.project(model.joints(x)) + rng.normal(0.0, 30.0, (21, 2))
    pixels = np.repeat(pixels, 15, axis=0)[:300]
    poses = iter(_fresh_poses(rng, 50 * 16))
    label = "closest projected point + Jacobian, 300 pixels, 1 camera"
    results[label] = _report(
        label, lambda: model.closest_projected_point(next(poses), cam, pixels), 50
    )
    u, v = np.meshgrid(np.arange(640.0), np.arange(480.0))
    origins, directions = cam.rays(np.stack([u.ravel(), v.ravel()], axis=1))
    label = "ray cast a 640×480 image (307 200 rays)"
    results[label] = _report(
        label, lambda: model.intersect_rays(x, origins, directions), 1, repeat=3
    )
    return results


def bench_render() -> dict[str, float]:
    """Silhouettes and colour images of the default stereo rig (`handvar.render`)."""
    from handvar import render

    model = HandModel()
    rig = Rig.default()
    x = named_pose("open")
    results = {}
    label = "silhouettes, 2 × 640×480 (render.silhouettes)"
    results[label] = _report(label, lambda: render.silhouettes(model, x, rig), 1, repeat=7)
    label = "colour images, 2 × 640×480 (render.render_rgb)"
    results[label] = _report(label, lambda: render.render_rgb(model, x, rig), 1, repeat=3)
    return results


def main() -> None:
    print("handvar.hand — kinematics")
    bench_kinematics()
    print("handvar.hand — surface")
    bench_surface()
    print("handvar.render")
    bench_render()


if __name__ == "__main__":
    main()
