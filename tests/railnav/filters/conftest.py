"""Shared fixtures of the filter tests."""
from __future__ import annotations

import numpy as np
import pytest

from trackmodel.sections import Section
from trackmodel.track import Track


@pytest.fixture(scope="session")
def curve_onset_track():
    """200 m of straight, then an arc of R 500 m entered without a transition (the attitude
    rows' tests: the azimuth bends at 200 m, the grade changes along the arc)."""
    return Track.from_sections([Section(200.0, azimuth_deg=350.0, elevation_deg=0.3),
                                Section(400.0, curvature_1pm=1 / 500.0,
                                        elevation_end_deg=-0.4)],
                               lat=np.radians(47.0), lon=np.radians(8.0))
