"""Shared test helpers: paths to the shipped data and a seeded random generator."""
from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

REPO = Path(__file__).resolve().parents[1]
DATA = REPO / "data"
TRACKS = DATA / "tracks"
GNSS_DATA = DATA / "gnss"


@pytest.fixture
def rng() -> np.random.Generator:
    """A seeded generator: tests draw noise from it, never at import."""
    return np.random.default_rng(20171103)
