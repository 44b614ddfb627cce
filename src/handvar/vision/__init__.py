"""Hand silhouettes from colour video (paper section 6).

`skin` classifies pixels by colour (the Jones–Rehg skin / non-skin mixtures, or a
histogram trained on labelled images); `silhouette` cleans the resulting masks, cuts a
visible forearm at the wrist and handles any number of cameras; `frames` reads one
camera's video file or image folder, and `sources` puts the cameras of a recording
together with their rig.
"""

from handvar.vision.silhouette import (
    CLEANUP_SETTINGS,
    WRIST_SETTINGS,
    CleanupSettings,
    EmptySilhouetteError,
    NotAHandError,
    WristCut,
    WristSettings,
    clean_mask,
    cut_wrist,
    find_wrist,
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

__all__ = [
    "CLEANUP_SETTINGS",
    "SKIN_SETTINGS",
    "WRIST_SETTINGS",
    "CleanupSettings",
    "EmptySilhouetteError",
    "GaussianMixture",
    "HistogramSkinModel",
    "NotAHandError",
    "SkinModel",
    "SkinSettings",
    "WristCut",
    "WristSettings",
    "clean_mask",
    "cut_wrist",
    "find_wrist",
    "jones_rehg_mixtures",
    "nearest_silhouette_pixel",
    "silhouettes_from_frames",
    "silhouettes_from_videos",
]
