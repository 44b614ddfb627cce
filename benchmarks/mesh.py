"""Timings of the skinned mesh hand (design §15).

Run ``python benchmarks/mesh.py``. Prints the median (and the fastest) of many
repetitions; on a shared machine the median is the figure to quote. Targets: mesh
kinematics and Jacobian of 600 surface samples ≤ 200 µs (a fresh pose per call, so the
forward kinematics is included); a 640×480 mesh silhouette ≤ 5 ms.
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


def main() -> None:
    rng = np.random.default_rng(0)
    hand = HandModel(surface="mesh")
    mesh = hand.mesh
    samples = mesh.sample_surface(600, rng)
    cam = Rig.default()[0]
    poses = [named_pose("fist") + rng.normal(0.0, 0.5, 26) for _ in range(4000)]
    it = iter(poses * 100)
    mesh.points(poses[0], samples, jacobian=True)  # compile
    mesh.silhouette(poses[0], cam)
    print(f"mesh: {mesh.skinned.n_vertices} vertices, {len(mesh.triangles)} triangles; "
          f"600 samples with up to {samples.bone.shape[1]} bone influences")  # fmt: skip
    _report("kinematics + 600 samples, positions", lambda: mesh.points(next(it), samples), 200)
    _report(
        "kinematics + 600 samples, positions and Jacobian (≤ 200)",
        lambda: mesh.points(next(it), samples, jacobian=True),
        200,
    )
    _report("kinematics + all vertices with Jacobian", lambda: mesh.vertices(next(it), True), 50)
    for name in ("open", "fist"):
        x = named_pose(name)
        _report(
            f"640×480 silhouette, {name}, touch (≤ 5000)", lambda x=x: mesh.silhouette(x, cam), 20
        )
        _report(
            f"640×480 silhouette, {name}, centre",
            lambda x=x: mesh.silhouette(x, cam, coverage="centre"),
            20,
        )
    _report("640×480 depth buffer, open", lambda: mesh.depth_buffer(named_pose("open"), cam), 20)

    # one optimiser iteration of the tracker's cost (stereo, 300 + 300 samples), 5 mm off
    from handvar.render import silhouettes
    from handvar.tracking.costs import SilhouetteCost
    from handvar.tracking.mesh_cost import MeshSilhouetteCost

    rig = Rig.default()
    x = named_pose("pinch")
    xp = x + 1.0
    for label, model, cls in [
        ("cost iteration, sphere-mesh (compiled kernel)", HandModel(), SilhouetteCost),
        ("cost iteration, mesh (MeshSilhouetteCost)", hand, MeshSilhouetteCost),
    ]:
        cost = cls(model, rig)
        frame = cost.prepare(silhouettes(model, x, rig))
        cost.evaluate(xp, frame, cost.draw(frame, rng), residuals=True)  # compile, pool
        _report(
            label, lambda c=cost, f=frame: c.evaluate(xp, f, c.draw(f, rng), residuals=True), 10
        )


if __name__ == "__main__":
    main()
