"""Synthetic hand motion and sequences with ground truth.

:mod:`handvar.synth.motion` makes pose series (minimum-jerk key poses, replay of a real
recording); :mod:`handvar.synth.sequences` builds the paper's three sequences
(``benchmark``, ``flexion``, ``flip``) and renders them into a
:class:`handvar.io.Sequence`; :mod:`handvar.synth.keypoints` makes a sequence's 2D
keypoints from its ground truth (noise and outliers, as a detector's);
:mod:`handvar.synth.mismatch` departs from the tracker's model (the rendering hand's
surface and size, the speed, silhouette noise; docs/results/mismatch.md).
"""

from typing import TYPE_CHECKING

from handvar.lazy import attach

# imported on first use: a recording's track reads `handvar.synth.sequences`'s names
# without the renderer's and the mismatch's imports (SciPy's ndimage)
__getattr__, __dir__ = attach(__name__, {
    "handvar.synth.keypoints": ["synthetic_keypoints"],
    "handvar.synth.mismatch": ["corrupt_silhouettes", "faster", "generator_hand"],
    "handvar.synth.motion": ["HtrackMapping", "builtin_recording", "htrack_to_handvar",
                             "keyframe_motion", "load_htrack", "minimum_jerk",
                             "minimum_jerk_path", "poses_from_keys", "replay", "retime"],
    "handvar.synth.sequences": ["SEQUENCE_NAMES", "BenchmarkSettings", "FlexionSettings",
                                "FlipSettings", "benchmark", "flexion", "flip",
                                "make_sequence", "render_sequence", "sequence_poses"],
})  # fmt: skip

if TYPE_CHECKING:  # what static checkers and editors see
    from handvar.synth.keypoints import synthetic_keypoints
    from handvar.synth.mismatch import corrupt_silhouettes, faster, generator_hand
    from handvar.synth.motion import (
        HtrackMapping,
        builtin_recording,
        htrack_to_handvar,
        keyframe_motion,
        load_htrack,
        minimum_jerk,
        minimum_jerk_path,
        poses_from_keys,
        replay,
        retime,
    )
    from handvar.synth.sequences import (
        SEQUENCE_NAMES,
        BenchmarkSettings,
        FlexionSettings,
        FlipSettings,
        benchmark,
        flexion,
        flip,
        make_sequence,
        render_sequence,
        sequence_poses,
    )

__all__ = [
    "SEQUENCE_NAMES",
    "BenchmarkSettings",
    "FlexionSettings",
    "FlipSettings",
    "HtrackMapping",
    "benchmark",
    "builtin_recording",
    "corrupt_silhouettes",
    "faster",
    "flexion",
    "flip",
    "generator_hand",
    "htrack_to_handvar",
    "keyframe_motion",
    "load_htrack",
    "make_sequence",
    "minimum_jerk",
    "minimum_jerk_path",
    "poses_from_keys",
    "render_sequence",
    "replay",
    "retime",
    "sequence_poses",
    "synthetic_keypoints",
]
