"""Shared fixtures: the real recordings shipped with the repository."""

from __future__ import annotations

import numpy as np
import pytest

from handvar.data import example_path


@pytest.fixture(scope="session")
def fingerfist() -> np.ndarray:
    """The real htrack recording (6000 × 26, its own layout and units)."""
    return np.loadtxt(example_path("htrack"))
