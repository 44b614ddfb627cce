"""What a track is exported to: standard keypoint files, BVH, glTF 2.0 and a 3D viewer.

Every function here takes arrays and model objects (poses (T, 26), a `HandShape`, a
`Rig`, per-frame confidences), never a track directory, so it works on any track:

- :mod:`~handvar.export.keypoints`: the 21 keypoints per frame in 2D per camera and in
  3D (each camera's frame and the world frame), per-joint visibility, the fit's
  confidence; handvar's own JSON and OpenPose's per-frame layout;
- :mod:`~handvar.export.bvh`: the 26 parameters as a BVH skeleton and motion;
- :mod:`~handvar.export.gltf`: the skinned mesh hand and its animation as glTF 2.0
  binary (.glb);
- :mod:`~handvar.export.viewer`: one self-contained HTML page with the hand's surface
  and skeleton in 3D over time, seen through the camera, the recording's frames beside
  it and the quality curves.

A frame without a hand (its pose NaN as a whole) keeps its place in every one of them
(:mod:`~handvar.export.absent`).

Both hands of a track go into one file of each format (`hands_keypoint_frames`,
`hands_openpose_frames`, `hands_bvh_text`, `hands_glb_bytes`, `hands_viewer_html`), each
hand given as a `TrackedHand` (:mod:`~handvar.export.hands`).

The formats, frames, units and conventions are described in docs/outputs.md.
"""

from handvar.export.bvh import bvh_text, hands_bvh_text, write_bvh, write_hands_bvh
from handvar.export.gltf import (
    glb_bytes,
    hands_glb_bytes,
    mesh_vertices,
    write_glb,
    write_hands_glb,
)
from handvar.export.hands import TrackedHand
from handvar.export.keypoints import (
    fit_confidence,
    hands_keypoint_frames,
    hands_openpose_frames,
    joint_visibility,
    keypoint_frames,
    keypoint_share,
    openpose_frames,
    write_keypoints_json,
    write_openpose,
)
from handvar.export.viewer import hands_viewer_html, viewer_html, write_hands_viewer, write_viewer

__all__ = [
    "TrackedHand",
    "bvh_text",
    "fit_confidence",
    "glb_bytes",
    "hands_bvh_text",
    "hands_glb_bytes",
    "hands_keypoint_frames",
    "hands_openpose_frames",
    "hands_viewer_html",
    "joint_visibility",
    "keypoint_frames",
    "keypoint_share",
    "mesh_vertices",
    "openpose_frames",
    "viewer_html",
    "write_bvh",
    "write_glb",
    "write_hands_bvh",
    "write_hands_glb",
    "write_hands_viewer",
    "write_keypoints_json",
    "write_openpose",
    "write_viewer",
]
