"""Re-issued broadcast records (the synthetic constellation of long simulated trips).

References: the IS-GPS-200 orbit and clock of the ORIGINAL record evaluated at the same
instants (`gnss_obs.kepler.kepler_states`: the re-issued elements are a re-parametrization
of the same functions of time), and the real 14:00 records of the shipped file (a 12:00
record re-issued 2 h later must describe the orbit the satellite broadcast then).
"""
from __future__ import annotations

import numpy as np
import pytest

from gnss_obs.constants import SPEED_OF_LIGHT_MPS, WEEK_S
from gnss_obs.ephemeris import MAX_AGE_S, select_ephemeris
from gnss_obs.ephemeris_reissue import (DEFAULT_REISSUE_INTERVAL_S, propagate_records,
                                        reissue_ephemerides)
from gnss_obs.errors import GnssError
from gnss_obs.kepler import kepler_states

#: Rounding of the shifted angles: |n Δt| reaches ~80 rad over a week, and 80 rad × 2e-16
#: × 2.7e7 m ≈ 4e-7 m; 1e-5 m leaves a factor 20.
ATOL_POSITION_M = 1e-5
ATOL_VELOCITY_MPS = 1e-9
#: The clock polynomial re-expanded about the new toc: exact up to rounding of af0 (1e-4 s)
#: at 1e-16 relative: 1e-15 s (0.3 µm).
ATOL_CLOCK_S = 1e-15
#: A record evaluated at the end of its 4-h fit interval against the next real record at
#: that record's reference time: the broadcast fit error (user range error of a few metres
#: at the interval's edges, IS-GPS-200N §20.3.4.4).
ATOL_BROADCAST_FIT_M = 5.0
ATOL_BROADCAST_CLOCK_M = 1.0
HOUR_S = 3600.0


@pytest.mark.parametrize("dt_s", [DEFAULT_REISSUE_INTERVAL_S, 10 * HOUR_S, -2 * HOUR_S,
                                  6.5 * 86_400.0])
def test_reissued_record_describes_the_same_orbit_and_clock(nav, dt_s):
    """At instants around the new toe (including across a GPS week boundary for 6.5 days),
    the shifted record gives the original record's position, velocity and clock."""
    gps = nav.records["G"]
    moved = propagate_records(gps, dt_s, "G")
    for offset_s in (-1800.0, 0.0, 1234.5):
        t = gps["toe_gps_s"].to_numpy() + dt_s + offset_s
        ref, got = kepler_states(gps, t), kepler_states(moved, t)
        np.testing.assert_allclose(got.r_e, ref.r_e, rtol=0, atol=ATOL_POSITION_M)
        np.testing.assert_allclose(got.v_e, ref.v_e, rtol=0, atol=ATOL_VELOCITY_MPS)
        np.testing.assert_allclose(got.clock_s, ref.clock_s, rtol=0, atol=ATOL_CLOCK_S)
    np.testing.assert_allclose(moved["toe_gps_s"] - gps["toe_gps_s"], dt_s)
    seconds = moved["week"].to_numpy() * WEEK_S + moved["toe_sow"].to_numpy()
    np.testing.assert_allclose(seconds, moved["toe_gps_s"], rtol=0, atol=1e-6)


def test_reissued_record_matches_the_next_real_issue(nav):
    """Satellites with records at 12:00 and 14:00: the 12:00 record moved by 2 h, at 14:00,
    against the satellite's own 14:00 record."""
    gps = nav.records["G"].sort_values("toe_gps_s")
    pairs = gps.groupby("sv").filter(lambda d: len(d) == 2).groupby("sv")
    first, second = pairs.head(1).set_index("sv"), pairs.tail(1).set_index("sv").sort_index()
    first = first.loc[second.index]
    assert len(second) >= 5
    dt = (second["toe_gps_s"] - first["toe_gps_s"]).to_numpy()
    moved = propagate_records(first.reset_index(), DEFAULT_REISSUE_INTERVAL_S, "G")
    t = second["toe_gps_s"].to_numpy()
    ref = kepler_states(second.reset_index(), t)
    got = kepler_states(moved, t)
    assert np.all(np.abs(dt - DEFAULT_REISSUE_INTERVAL_S) <= 60.0)
    assert np.max(np.linalg.norm(got.r_e - ref.r_e, axis=1)) < ATOL_BROADCAST_FIT_M
    clock_m = SPEED_OF_LIGHT_MPS * np.abs(got.clock_s - ref.clock_s)
    assert np.max(clock_m) < ATOL_BROADCAST_CLOCK_M


def test_extended_file_covers_a_ten_hour_trip(nav):
    """Every healthy GPS and Galileo satellite has a valid record at every minute from
    12:00 to 22:40 (10 h after the default trip start), with original records kept."""
    start = 2134 * WEEK_S + 43_200.0
    end = start + 10 * HOUR_S + 2400.0
    ext = reissue_ephemerides(nav, end_gps_time_s=end, systems="GE")
    for system in "GE":
        recs = nav.records[system]
        healthy = sorted(set(recs.loc[recs["health"] == 0, "sv"]))
        first_toe = recs.groupby("sv")["toe_gps_s"].min()
        t = np.arange(start, end, 60.0)
        for sv in healthy:
            times = t[t >= first_toe[sv] - MAX_AGE_S[system]]
            sel = select_ephemeris(ext.records, np.full(times.size, sv), times)
            assert sel["ephemeris_ok"].all(), sv
        kept = ext.records[system].merge(recs, how="inner")
        assert len(kept) == len(recs)
    assert ext.records["R"] is nav.records["R"]


def test_backwards_and_bad_arguments(nav):
    """Backwards re-issue covers an earlier start; bad intervals and systems are refused."""
    start = 2134 * WEEK_S + 43_200.0 - 5 * HOUR_S
    ext = reissue_ephemerides(nav, end_gps_time_s=start + HOUR_S, start_gps_time_s=start,
                              systems="G")
    healthy = sorted(set(nav.records["G"].query("health == 0")["sv"]))
    sel = select_ephemeris(ext.records, healthy, np.full(len(healthy), start))
    assert sel["ephemeris_ok"].all()
    with pytest.raises(GnssError, match="interval_s"):
        reissue_ephemerides(nav, end_gps_time_s=start, interval_s=0.0)
    with pytest.raises(GnssError, match="not Keplerian"):
        reissue_ephemerides(nav, end_gps_time_s=start, systems="R")
    with pytest.raises(GnssError, match="GEO"):
        propagate_records(nav.records["C"], 60.0, "C")
