"""GPS time conversions against published calendar facts and numpy's datetime64."""
from __future__ import annotations

import warnings

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from gnss_obs.constants import WEEK_S, relativistic_constant, GM_GPS, wavelength_m
from gnss_obs.gpstime import (calendar_to_gps_time_s, datetime64_to_gps_time_s,
                              from_gps_time_s, gps_time_s_to_calendar, gps_time_s_to_datetime64,
                              gps_time_s_to_week_sow, gpst_label, leap_seconds_at,
                              to_gps_time_s)


def test_shared_data_epoch_is_gps_week_2134():
    # The CODE final orbit file of 2020-11-29 is COD21340.sp3: GPS week 2134, day 0 (Sunday).
    t = calendar_to_gps_time_s(2020, 11, 29, 12, 40, 0.0)
    week, sow = gps_time_s_to_week_sow(t)
    assert (week, sow) == (2134, 12 * 3600 + 40 * 60)


def test_gps_epoch_is_zero_and_week_rollovers():
    assert calendar_to_gps_time_s(1980, 1, 6) == 0.0
    # first rollover of the 10-bit week counter: 1999-08-22 00:00 GPST = week 1024
    assert calendar_to_gps_time_s(1999, 8, 22) == 1024 * WEEK_S
    assert calendar_to_gps_time_s(2019, 4, 7) == 2048 * WEEK_S


@settings(max_examples=200, deadline=None)
@given(st.datetimes(min_value=__import__("datetime").datetime(1980, 1, 6),
                    max_value=__import__("datetime").datetime(2100, 1, 1)))
def test_calendar_matches_datetime64(dt):
    t = calendar_to_gps_time_s(dt.year, dt.month, dt.day, dt.hour, dt.minute,
                               dt.second + dt.microsecond * 1e-6)
    ref = datetime64_to_gps_time_s(np.datetime64(dt, "ns"))
    assert t == pytest.approx(ref, abs=1e-6)
    y, mo, d, h, mi, s = gps_time_s_to_calendar(t)
    assert (int(y), int(mo), int(d), int(h), int(mi)) == (dt.year, dt.month, dt.day, dt.hour, dt.minute)
    assert float(s) == pytest.approx(dt.second + dt.microsecond * 1e-6, abs=1e-6)


def test_time_systems():
    t = calendar_to_gps_time_s(2020, 11, 29, 12, 0, 0.0)
    assert leap_seconds_at(t) == 18                     # since 2017-01-01
    assert leap_seconds_at(calendar_to_gps_time_s(2016, 6, 1)) == 17
    assert to_gps_time_s(t, "BDT") == t + 14.0          # BDT = GPST - 14 s
    assert to_gps_time_s(t, "UTC") == t + 18.0
    assert to_gps_time_s(t, "GLO") == t + 18.0          # RINEX "GLO" tags are UTC
    for system in ("GPS", "GAL", "BDT", "UTC", "GLO"):
        assert from_gps_time_s(to_gps_time_s(t, system), system) == pytest.approx(t, abs=1e-9)
    with pytest.raises(ValueError, match="unknown time system"):
        to_gps_time_s(t, "TAI")


def test_constants_against_icd_values():
    assert relativistic_constant(GM_GPS) == pytest.approx(-4.442807633e-10, rel=1e-9)
    assert wavelength_m("G", 1) == pytest.approx(0.190293672798, rel=1e-11)
    assert wavelength_m("R", 1, glonass_channel=-7) == pytest.approx(299792458 / 1598.0625e6)
    with pytest.raises(KeyError):
        wavelength_m("R", 1)


def test_issue16_glo_time_system_is_utc():
    """RINEX 3.04 §3.2 / Table A1: the ``GLO`` time system of RINEX files is UTC (GLONASS
    time runs on UTC(SU); the +3 h Moscow offset is not in RINEX time tags), and RTKLIB's
    rinex.c converts GLO tags with utc2gpst. A RINEX tag 2020-11-29 12:40:00 GLO is therefore
    12:40:18 GPST (18 leap seconds, IERS Bulletin C), not 09:40:18."""
    label = calendar_to_gps_time_s(2020, 11, 29, 12, 40, 0.0)
    expected = calendar_to_gps_time_s(2020, 11, 29, 12, 40, 18.0)
    assert to_gps_time_s(label, "GLO") == expected
    assert to_gps_time_s(label, "GLO", leap_seconds=18) == expected
    assert from_gps_time_s(expected, "GLO") == label


def test_labels_outside_datetime64_are_nat_without_overflow():
    """datetime64[ns] ends at 2262-04-11T23:47:16.854775807 (int64 ns since 1970): a second
    before is labelled, a second after (and NaN, ±inf, a fuzzed 1e300) is NaT, with no
    overflowed cast (warnings are errors here); a message's label says NaT."""
    last = float(calendar_to_gps_time_s(2262, 4, 11, 23, 47, 16.0))
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        labels = gps_time_s_to_datetime64([last - 1.0, last + 1.0, np.nan, np.inf, -np.inf,
                                           1e300])
        nan_label = gpst_label(np.nan)
    # float64 seconds near 8.9e9 s are 1.9 µs apart: the label is the nearest of those
    expected = np.datetime64("2262-04-11T23:47:15", "ns")
    assert abs(labels[0] - expected) <= np.timedelta64(1, "us")
    assert np.isnat(labels[1:]).all()
    assert gps_time_s_to_datetime64(1.5) == np.datetime64("1980-01-06T00:00:01.5", "ns")
    assert nan_label == "NaT"
    t = float(calendar_to_gps_time_s(2021, 3, 17, 7, 6, 40.0))
    assert gpst_label(t) == "2021-03-17 07:06:40"
