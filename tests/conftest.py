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


#: Files run first, the longest first (pytest --durations on 2 cores, the sum over each
#: file's tests; notebooks and Monte Carlo studies). With the work-stealing scheduler
#: (pyproject.toml: ``--dist worksteal``) an idle worker takes half of the other's queue,
#: so the run ends on short tests on both cores, not on one core waiting for a notebook that
#: was collected last (06 ran alone for its last ~3 min). Order only: every file still runs.
LONGEST_FIRST = (
    "tests/railnav/studies/test_studies.py",
    "notebooks/06_multiple_models.ipynb",
    "tests/trackmodel/test_fit.py",
    "tests/railnav/reproduce/test_paper2017.py",
    "notebooks/05_outage_analysis.ipynb",
    "tests/railnav/studies/test_issue18_study_interrupts.py",
    "tests/railnav/filters/test_sensor_consistency.py",
    "notebooks/04_paper2017.ipynb",
    "notebooks/03_gnss_real_data.ipynb",
    "notebooks/08_networks.ipynb",
    "notebooks/02_strapdown.ipynb",
    "tests/railnav/reproduce/test_anomaly2021.py",
    "notebooks/07_real_inputs.ipynb",
    "tests/railnav/commands/test_cli_attitude.py",
    "tests/strapdown/test_rk4.py",
    "tests/railnav/commands/test_issue18_outputs.py",
)


def pytest_collection_modifyitems(session, config, items):
    """`LONGEST_FIRST` to the front; everything else keeps pytest's order (a stable sort,
    so each file's tests stay together and share their module fixtures)."""
    rank = {path: i for i, path in enumerate(LONGEST_FIRST)}

    def key(item) -> int:
        try:
            path = item.path.resolve().relative_to(REPO).as_posix()
        except ValueError:              # outside the repository
            return len(rank)
        return rank.get(path, len(rank))

    items.sort(key=key)
