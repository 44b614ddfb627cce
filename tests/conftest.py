"""Shared fixtures: the real recordings shipped with the repository."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

EXAMPLES = Path(__file__).resolve().parent.parent / "examples" / "data"


@pytest.fixture(scope="session")
def fingerfist() -> np.ndarray:
    """The real htrack recording (6000 × 26, its own layout and units)."""
    return np.loadtxt(EXAMPLES / "htrack-fingerfist.txt")
