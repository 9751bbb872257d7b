"""A run's start from GNSS position fixes (`railnav.navigation.fix_start`): fixes placed by
hand at known distances on the east_west track (its first 10 km are a straight due east),
some far off it (some also ahead along it), some with heights that are not the track's."""
from __future__ import annotations

import numpy as np
import pandas as pd
import pytest

from gnss_obs.fixes.table import FIX_COLUMNS
from railnav.config import NavigatorConfig
from railnav.errors import ConfigError, RailnavError
from railnav.filters.common import MIN_FIX_SIGMA_S_M
from railnav.filters.fix_epochs import FixEpochs, FixModelConfig
from railnav.filters.gnss_only import GnssOnlyFilter
from railnav.navigation.fix_start import (
    UNKNOWN_SPEED_SIGMA_MPS,
    initial_at_fix,
    initial_from_fixes,
)
from railnav.simulation.scenarios import TRACKS_DIR
from trackmodel.earth import C_n_e, ecef_to_geodetic
from trackmodel.io import read_track

TRACK = read_track(TRACKS_DIR / "east_west.csv")
SPEED_MPS, STEP_S, SIGMA_M = 10.0, 0.4, 0.5


def _fixes(n: int, *, off_m=(), ahead_m: float = 0.0, dh_m: float | None = None
           ) -> FixEpochs:
    """Fixes every 0.4 s at 10 m/s from s = 500 m; those in `off_m` 100 m to the right
    and `ahead_m` ahead along the track; with `dh_m` heights that far above the track
    (else none)."""
    s = 500.0 + SPEED_MPS * STEP_S * np.arange(n)
    s[list(off_m)] += ahead_m
    p = TRACK.at(s)
    across = np.zeros(n)
    across[list(off_m)] = 100.0
    right = np.column_stack([np.cos(p.azimuth), -np.sin(p.azimuth), np.zeros(n)])
    r = p.r_e + np.einsum("kij,kj->ki", C_n_e(p.lat, p.lon), right * across[:, None])
    lat, lon, h = ecef_to_geodetic(r, earth=TRACK.earth)
    cols = {c: np.full(n, np.nan) for c in FIX_COLUMNS}
    cols.update(gps_time_s=1e9 + STEP_S * np.arange(n), lat_deg=np.degrees(lat),
                lon_deg=np.degrees(lon), h_m=np.nan if dh_m is None else h + dh_m,
                sigma_east_m=SIGMA_M, sigma_north_m=SIGMA_M, sigma_up_m=1.0, cov_en_m2=0.0,
                sigma_speed_mps=0.05, quality=np.full(n, "dgps", dtype=object))
    return FixEpochs.from_table(pd.DataFrame(cols), start_gps_time_s=1e9)


def _start(fixes: FixEpochs, config: NavigatorConfig):
    filt = GnssOnlyFilter(TRACK, config, None, fixes=fixes)
    return filt, initial_from_fixes(filt, fixes, config)


def test_start_skips_fixes_off_the_track():
    """Fixes 0-2 lie 100 m off: the start is fix 3, at its s (placed there), with the
    speed from fixes 3-4 (10 m/s, σ √2·σ_fix/Δt) and the fix's σ along the track."""
    filt, start = _start(_fixes(10, off_m=(0, 1, 2)), NavigatorConfig(filter="gnss-only"))
    assert filt.layout.names == ("s", "v")
    assert start.time_s == pytest.approx(3 * STEP_S)
    assert start.x0[0] == pytest.approx(500.0 + 3 * SPEED_MPS * STEP_S, abs=1e-6)
    assert start.x0[1] == pytest.approx(SPEED_MPS, abs=1e-6)
    # the fix's σ along, floored as every start from a fix (MIN_FIX_SIGMA_S_M)
    assert np.sqrt(start.P0[0, 0]) == pytest.approx(max(SIGMA_M, MIN_FIX_SIGMA_S_M), rel=1e-6)
    assert np.sqrt(start.P0[1, 1]) == pytest.approx(np.hypot(SIGMA_M, SIGMA_M) / STEP_S,
                                                    rel=1e-6)


def test_a_start_at_a_fix_off_the_track_takes_no_speed_from_it():
    """`initial_at_fix` starts at the fix it is given, here a jump 100 m across and 60 m
    ahead: at its projection (s + 60 m), with no speed (the difference to the next fix's
    s would say (4 − 60 m)/0.4 s = −140 m/s); from the next fix, on the track, the speed is
    the difference again (10 m/s)."""
    config = NavigatorConfig(filter="gnss-only")
    fixes = _fixes(10, off_m=(0,), ahead_m=60.0)
    filt = GnssOnlyFilter(TRACK, config, None, fixes=fixes)
    jumped = initial_at_fix(filt, fixes, 0, config)
    # (a point 100 m across projects within µm of its s: the straight is a geodesic)
    assert jumped.x0[0] == pytest.approx(560.0, abs=1e-3)
    assert jumped.x0[1] == 0.0
    assert np.sqrt(jumped.P0[1, 1]) == pytest.approx(UNKNOWN_SPEED_SIGMA_MPS, rel=1e-9)
    on_track = initial_at_fix(filt, fixes, 1, config)
    assert on_track.x0[0] == pytest.approx(500.0 + SPEED_MPS * STEP_S, abs=1e-6)
    assert on_track.x0[1] == pytest.approx(SPEED_MPS, abs=1e-6)


def test_no_fix_on_the_track_is_an_error():
    with pytest.raises(RailnavError, match="none of the first 4 GNSS fixes"):
        _start(_fixes(4, off_m=range(4)), NavigatorConfig(filter="gnss-only"))


def test_heights_off_the_track_are_an_error_unless_ignored():
    fixes = _fixes(5, dh_m=45.0)        # e.g. heights above the geoid on an ellipsoid track
    with pytest.raises(ConfigError, match="no-fix-heights"):
        _start(fixes, NavigatorConfig(filter="gnss-only"))
    _, start = _start(fixes, NavigatorConfig(
        filter="gnss-only", fix_model=FixModelConfig(use_height=False)))
    assert start.time_s == 0.0
