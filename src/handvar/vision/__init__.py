"""Hand silhouettes from colour video (paper section 6).

`skin` classifies pixels by colour (the Jones–Rehg skin / non-skin mixtures, or a
histogram trained on labelled images); `silhouette` cleans the resulting masks and
handles any number of cameras, `wrist` cuts a visible forearm off at the wrist; `frames` reads one
camera's video file or image folder, and `sources` puts the cameras of a recording
together with their rig.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from handvar.lazy import attach

# imported on first use: importing one module of the package (the detector's process
# imports `handvar.vision.mediapipe` alone) loads neither SciPy's image tools nor the
# skin model's tables
__getattr__, __dir__ = attach(__name__, {
    "handvar.vision.silhouette": ["CLEANUP_SETTINGS", "CleanupSettings",
                                  "EmptySilhouetteError", "NotAHandError", "clean_mask",
                                  "nearest_silhouette_pixel", "silhouettes_from_frames",
                                  "silhouettes_from_videos"],
    "handvar.vision.skin": ["SKIN_SETTINGS", "GaussianMixture", "HistogramSkinModel",
                            "SkinModel", "SkinSettings", "jones_rehg_mixtures"],
    "handvar.vision.wrist": ["WRIST_CUT_SETTINGS", "WristCut", "WristCutSettings",
                             "cut_wrist", "find_wrist"],
})  # fmt: skip

if TYPE_CHECKING:  # what static checkers and editors see
    from handvar.vision.silhouette import (
        CLEANUP_SETTINGS,
        CleanupSettings,
        EmptySilhouetteError,
        NotAHandError,
        clean_mask,
        nearest_silhouette_pixel,
        silhouettes_from_frames,
        silhouettes_from_videos,
    )
    from handvar.vision.skin import (
        SKIN_SETTINGS,
        GaussianMixture,
        HistogramSkinModel,
        SkinModel,
        SkinSettings,
        jones_rehg_mixtures,
    )
    from handvar.vision.wrist import (
        WRIST_CUT_SETTINGS,
        WristCut,
        WristCutSettings,
        cut_wrist,
        find_wrist,
    )

__all__ = [
    "CLEANUP_SETTINGS",
    "SKIN_SETTINGS",
    "WRIST_CUT_SETTINGS",
    "CleanupSettings",
    "EmptySilhouetteError",
    "GaussianMixture",
    "HistogramSkinModel",
    "NotAHandError",
    "SkinModel",
    "SkinSettings",
    "WristCut",
    "WristCutSettings",
    "clean_mask",
    "cut_wrist",
    "find_wrist",
    "jones_rehg_mixtures",
    "nearest_silhouette_pixel",
    "silhouettes_from_frames",
    "silhouettes_from_videos",
]
