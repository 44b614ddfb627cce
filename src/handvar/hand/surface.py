"""The hand's surface: a sphere-mesh of cone-spheres, and samples on it.

Every primitive is a *cone-sphere*: the convex hull of two spheres (centres c1, c2,
radii r1, r2), i.e. two spherical caps joined by the frustum of their common tangent
cone (their geometry: :mod:`handvar.geometry.cone_spheres`). Each finger and thumb bone
carries one; the palm carries one per finger ray plus one for the thenar eminence
(`hand_primitives`). Centres are stored in their bone's frame, so the forward
kinematics moves them rigidly. `SurfacePool` holds the area-uniform samples on the
union's outer surface that the tracker draws from.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from handvar.geometry.cone_spheres import cone_sphere_sdf, sample_cone_spheres
from handvar.hand.anthropometry import BONES, HandShape, bone_index
from handvar.validate import as_array, as_instance, as_int, readonly

__all__ = ["Primitives", "SurfacePool", "SurfaceSamples", "hand_primitives"]


# --- primitives ------------------------------------------------------------------------


@dataclass(frozen=True, eq=False)
class Primitives:
    """The cone-spheres of a sphere-mesh, each attached to a bone.

    Attributes
    ----------
    bone : (P,) int ndarray
        Bone index (into `BONES`) of each primitive.
    centres : (P, 2, 3) ndarray
        Centres of the two end spheres in the bone's frame, mm.
    radii : (P, 2) ndarray
        Radii of the two end spheres, mm.
    names : tuple of str
        A name per primitive (the bone's name; ``palm_<finger>`` / ``thenar`` on the palm).
    """

    bone: np.ndarray
    centres: np.ndarray
    radii: np.ndarray
    names: tuple[str, ...] = ()

    def __post_init__(self) -> None:
        bone = np.asarray(self.bone)
        centres = as_array(self.centres, "centres", finite=False)
        radii = as_array(self.radii, "radii", finite=False)
        p = bone.shape[0] if bone.ndim == 1 else -1
        if bone.ndim != 1 or p < 1:
            raise ValueError(f"bone: expected a non-empty (P,) array; got shape {bone.shape}")
        if centres.shape != (p, 2, 3):
            raise ValueError(f"centres: expected shape ({p}, 2, 3); got shape {centres.shape}")
        if radii.shape != (p, 2):
            raise ValueError(f"radii: expected shape ({p}, 2); got shape {radii.shape}")
        if not (np.all(np.isfinite(centres)) and np.all(np.isfinite(radii))):
            raise ValueError("centres, radii: expected finite values; got NaN or infinity")
        if np.any(radii <= 0):
            raise ValueError(f"radii: expected positive radii; got minimum {radii.min()}")
        d = np.linalg.norm(centres[:, 1] - centres[:, 0], axis=1)
        bad = d <= np.abs(radii[:, 0] - radii[:, 1]) * (1 + 1e-9)
        if np.any(bad):
            raise ValueError(
                "centres, radii: expected end spheres that do not contain each other "
                f"(|c2 - c1| > |r1 - r2|); got primitives {np.flatnonzero(bad).tolist()}"
            )
        object.__setattr__(self, "bone", readonly(bone, np.intp))
        object.__setattr__(self, "centres", readonly(centres))
        object.__setattr__(self, "radii", readonly(radii))
        names = tuple(self.names) or tuple(f"primitive{i}" for i in range(p))
        if len(names) != p:
            raise ValueError(f"names: expected {p} names; got {len(names)}")
        object.__setattr__(self, "names", names)

    def __len__(self) -> int:
        return int(self.bone.shape[0])


def hand_primitives(shape: HandShape) -> Primitives:
    """The sphere-mesh of a hand: palm cone-spheres first, then one per digit bone.

    Parameters
    ----------
    shape : HandShape

    Returns
    -------
    Primitives
        ``P = Q + 15`` primitives (Q palm cone-spheres, 5 for `HandShape.from_size`).
        A digit bone's cone-sphere runs from its proximal joint (local origin) to the
        next joint (local ``(0, L, 0)``) with the radii of those joints; the distal bones
        end one tip radius short of the fingertip so that their surface reaches it.
    """
    q = shape.palm_centres.shape[0]
    bones = [0] * q
    centres = [c for c in shape.palm_centres]
    radii = [r for r in shape.palm_radii]
    palm_names = ["palm_index", "palm_middle", "palm_ring", "palm_little", "thenar"]
    names = palm_names[:q] if q == 5 else [f"palm{i}" for i in range(q)]
    for k in range(5):
        for level in range(3):
            length = shape.segments[k, level] if level < 2 else shape.tip_offsets[k]
            b = bone_index(k, level)
            bones.append(b)
            centres.append(np.array([[0.0, 0.0, 0.0], [0.0, length, 0.0]]))
            radii.append(shape.radii[k, level : level + 2])
            names.append(BONES[b])
    return Primitives(np.array(bones), np.array(centres), np.array(radii), tuple(names))


# --- surface samples ---------------------------------------------------------------------


@dataclass(frozen=True, eq=False)
class SurfaceSamples:
    """Points on the model surface, stored per bone in the bone's frame.

    Move them with ``HandModel.points(x, samples.bone, samples.local)``.

    Attributes
    ----------
    bone : (n,) int ndarray
        Bone index of each sample (into `BONES`).
    local : (n, 3) ndarray
        Position in the bone's frame, mm.
    normal : (n, 3) ndarray or None
        Outward unit surface normal in the bone's frame.
    primitive : (n,) int ndarray or None
        Index of the primitive the sample lies on.
    """

    bone: np.ndarray
    local: np.ndarray
    normal: np.ndarray | None = None
    primitive: np.ndarray | None = None

    def __len__(self) -> int:
        return int(self.bone.shape[0])


class SurfacePool:
    """A dense, fixed pool of area-uniform surface samples to draw from quickly.

    The tracker draws a few hundred fresh samples per optimiser iteration; drawing them
    from a pool (uniformly with replacement) costs a few microseconds, whereas sampling
    the cone-spheres afresh costs tens. The pool is drawn once with a fixed seed
    (`sample_cone_spheres`), so a model's pool is the same in every process.

    Samples buried in the union: every candidate is tested, in the rest pose (x = 0, the
    open hand), against the primitives of its own bone and of the bones next to it in the
    skeleton (parent and children); a candidate more than `tolerance` inside one of
    them is not on the union's outer surface and is kept only in the ``exposed=False``
    set. These overlaps (the palm's cone-spheres among themselves and with the thenar,
    the digits' bases inside the palm, the shared sphere at each finger joint) hardly
    change with the pose. Overlaps that do depend on the pose (adjacent fingers touching,
    a fingertip pressed on the palm, the back of a strongly flexed knuckle opening up)
    are not accounted for: such samples still project inside the model's silhouette, so
    they cost nothing in the silhouette term.

    Parameters
    ----------
    primitives : Primitives
    rest_frames : ((B, 3, 3), (B, 3)) tuple of ndarray
        world_from_bone rotations and origins of the bones in the rest pose.
    size : int
        Number of candidate samples.
    parents : (B,) int ndarray
        Parent bone of each bone, −1 for the root.
    seed : int, optional
        Seed of the pool.
    tolerance : float, optional
        How deep (mm) a candidate must lie inside a neighbour to count as buried.
    """

    def __init__(
        self,
        primitives: Primitives,
        rest_frames,
        *,
        size: int,
        parents,
        seed: int = 0,
        tolerance: float = 1e-6,
    ) -> None:
        rng = np.random.default_rng(seed)
        prim, local, normal = sample_cone_spheres(primitives.centres, primitives.radii, size, rng)
        bone = primitives.bone[prim]
        rot, org = (np.asarray(a, dtype=float) for a in rest_frames)
        world = np.einsum("nij,nj->ni", rot[bone], local) + org[bone]
        b = primitives.bone
        parents = np.asarray(parents)
        same = b[:, None] == b[None, :]
        adjacent = (parents[b][:, None] == b[None, :]) | (b[:, None] == parents[b][None, :])
        neighbours = (same | adjacent) & ~np.eye(len(b), dtype=bool)
        rest_centres = np.einsum("pij,pkj->pki", rot[b], primitives.centres) + org[b][:, None, :]
        buried = np.zeros(size, dtype=bool)
        for start in range(0, size, 16384):
            sl = slice(start, start + 16384)
            sdf = cone_sphere_sdf(rest_centres, primitives.radii, world[sl])
            buried[sl] = np.any((sdf < -tolerance) & neighbours[prim[sl]], axis=1)
        self.all = SurfaceSamples(
            readonly(bone, np.intp), readonly(local), readonly(normal), readonly(prim, np.intp)
        )
        keep = ~buried
        self.exposed = SurfaceSamples(
            readonly(bone[keep], np.intp),
            readonly(local[keep]),
            readonly(normal[keep]),
            readonly(prim[keep], np.intp),
        )

    def draw(self, n: int, rng: np.random.Generator, *, exposed: bool = True) -> SurfaceSamples:
        """Draw `n` samples uniformly (with replacement) from the pool.

        Parameters
        ----------
        n : int
            Number of samples, ≥ 0.
        rng : numpy.random.Generator
        exposed : bool, optional
            Draw from the samples on the union's outer surface (default) or from all
            candidates (area-uniform over every primitive's whole surface).

        Returns
        -------
        SurfaceSamples
            New arrays (writeable copies).
        """
        n = as_int(n, "n", minimum=0)
        as_instance(rng, np.random.Generator, "rng", what="a numpy.random.Generator")
        src = self.exposed if exposed else self.all
        idx = rng.integers(0, src.bone.shape[0], int(n))
        return SurfaceSamples(src.bone[idx], src.local[idx], src.normal[idx], src.primitive[idx])
