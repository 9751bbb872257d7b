"""The tiny study and its serial reference, shared by the study tests."""
from __future__ import annotations

import pandas as pd
import pytest

from railnav.studies.file import load_study_config
from railnav.studies.study import run_study
from tests.conftest import DATA

TINY = DATA / "studies" / "tiny.toml"
#: Columns that differ between two executions of the same run (wall time).
TIMING = ["runtime_s"]
#: Give up waiting for a killed study's first part after this long, s.
PART_WAIT_S = 120.0


@pytest.fixture(scope="session")
def config():
    return load_study_config(TINY)


@pytest.fixture(scope="session")
def reference(config, tmp_path_factory):
    """The tiny study run serially in this process."""
    return run_study(config, tmp_path_factory.mktemp("serial"), workers=1)


def same_table(a: pd.DataFrame, b: pd.DataFrame) -> None:
    """The same table, up to the wall times."""
    pd.testing.assert_frame_equal(a.drop(columns=TIMING), b.drop(columns=TIMING),
                                  check_exact=True)
