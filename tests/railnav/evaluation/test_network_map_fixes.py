"""`railnav.evaluation.network_map.fix_points`: what ``railnav network plot --fixes`` draws,
from a path as the command gives it, from fixes read, or from arrays (rad).

Reference: the shipped Brussels fix excerpt's own ``latitude``/``longitude`` columns
(degrees), read with pandas, in radians.
"""
from __future__ import annotations

import numpy as np
import pandas as pd

from gnss_obs.fixes.read import read_fixes
from railnav.evaluation.network_map import fix_points
from tests.conftest import DATA

EXCERPT = DATA / "fixes" / "brussels" / "log_28876_L36-B_excerpt.csv"


def test_fix_points_of_a_path_fixes_read_and_arrays():
    raw = pd.read_csv(EXCERPT)
    lat, lon = fix_points(EXCERPT)
    kept = read_fixes(EXCERPT).table          # the rows the reader keeps, in its order
    assert lat.size == len(kept) > 0
    np.testing.assert_allclose(np.degrees(lat[:5]), raw["latitude"].to_numpy()[:5],
                               rtol=0, atol=1e-12)
    np.testing.assert_allclose(np.degrees(lon[:5]), raw["longitude"].to_numpy()[:5],
                               rtol=0, atol=1e-12)
    again = fix_points(read_fixes(EXCERPT))
    np.testing.assert_array_equal(again[0], lat)
    np.testing.assert_array_equal(fix_points((lat, lon))[1], lon)
