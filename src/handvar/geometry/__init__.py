"""Geometry below the hand model: lens distortion, cone-spheres in 3D and in the image,
and triangle meshes (made coarser; their vertex normals).

A leaf package (design §12): it imports nothing from handvar but `handvar.validate`.

- :mod:`~handvar.geometry.distortion`: OpenCV's lens distortion and its Jacobian, with
  the compiled scalar form the tracking cost calls.
- :mod:`~handvar.geometry.cone_spheres`: cone-spheres in 3D (areas, area-uniform
  sampling, signed distance, normals, ray intersection).
- :mod:`~handvar.geometry.projected`: cone-spheres in the image plane (outline circles,
  the closest point of a union of them and its derivatives).
- :mod:`~handvar.geometry.rotations`: the shortest rotation between two directions.
- :mod:`~handvar.geometry.normals`: a triangle mesh's vertex normals.
"""

from handvar.geometry.cone_spheres import (
    cone_sphere_areas,
    cone_sphere_normals,
    cone_sphere_sdf,
    intersect_cone_spheres,
    sample_cone_spheres,
)
from handvar.geometry.decimate import decimate_mesh
from handvar.geometry.distortion import distort, distort_normalized, distortion_coefficients
from handvar.geometry.normals import vertex_normals
from handvar.geometry.projected import (
    ProjectedPrimitives,
    closest_point_cone_spheres_2d,
    outline_circles,
)
from handvar.geometry.rotations import shortest_rotation

__all__ = [
    "ProjectedPrimitives",
    "closest_point_cone_spheres_2d",
    "cone_sphere_areas",
    "cone_sphere_normals",
    "cone_sphere_sdf",
    "decimate_mesh",
    "distort",
    "distort_normalized",
    "distortion_coefficients",
    "intersect_cone_spheres",
    "outline_circles",
    "sample_cone_spheres",
    "shortest_rotation",
    "vertex_normals",
]
