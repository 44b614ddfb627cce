"""Where the data files are: the package's own, and the repository's example recordings.

The package's files (this folder, listed in its README.md) are read at run time through
`importlib.resources`.  The example recordings live outside the package, in the
repository's ``examples/data`` (their provenance and licences in its README.md): the
examples, the tests, the benchmarks and the studies find them with `example_path`; the
library itself never reads them.
"""

from __future__ import annotations

from pathlib import Path

__all__ = ["EXAMPLES", "EXAMPLE_DATA", "example_path"]

#: The repository's folder of example recordings (absent from an installed package).
EXAMPLE_DATA = Path(__file__).resolve().parents[3] / "examples" / "data"

#: The example files, by the short names `example_path` takes.
EXAMPLES: dict[str, str] = {
    "video": "dex-human-hand-video.mp4",
    "video-keypoints": "dex-human-hand-video-keypoints.npy",
    "video-landmarks": "dex-human-hand-landmarks.npy",
    "htrack": "htrack-fingerfist.txt",
    "fingerspelling": "tfjs-asl-hand.mp4",
    "fingerspelling-keypoints": "tfjs-asl-hand-keypoints.npy",
    "fingerspelling-mediapipe": "tfjs-asl-hand-mediapipe.npz",
    "counting": "boreep-counting.mp4",
    "counting-keypoints": "boreep-counting-keypoints.npy",
    "counting-mediapipe": "boreep-counting-mediapipe.npz",
}


def example_path(name: str) -> Path:
    """The path of an example recording of ``examples/data``, by short name.

    Parameters
    ----------
    name : str
        One of `EXAMPLES`: ``"video"`` (the monocular video of a right hand),
        ``"video-keypoints"`` (its MediaPipe keypoints), ``"video-landmarks"`` (its
        MediaPipe world landmarks), ``"htrack"`` (recorded hand poses of htrack);
        ``"fingerspelling"`` and ``"counting"`` (two more real videos of a right hand)
        with their ``-keypoints`` and ``-mediapipe`` files (examples/data/README.md).

    Returns
    -------
    Path
        The file's path; it exists in a checkout of the repository, not in an
        installed package (check with ``.exists()`` where that matters).

    Raises
    ------
    ValueError
        If `name` is none of `EXAMPLES`.

    Examples
    --------
    >>> example_path("video").name
    'dex-human-hand-video.mp4'
    """
    if name not in EXAMPLES:
        raise ValueError(f"name: expected one of {', '.join(EXAMPLES)}; got {name!r}")
    return EXAMPLE_DATA / EXAMPLES[name]
