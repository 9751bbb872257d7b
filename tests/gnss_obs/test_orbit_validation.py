"""Broadcast orbits and clocks against CODE final and IGS rapid products (2020-11-29).

Bounds from the published broadcast-ephemeris performance (Montenbruck, Steigenberger and
Hauschild, "Broadcast versus precise ephemerides: a multi-GNSS perspective", GPS Solutions
19, 2015; Montenbruck et al., "Multi-GNSS signal-in-space range error assessment",
Advances in Space Research 61, 2018): orbit errors of 1-2 m (3-D RMS) for GPS and Galileo,
a few metres for GLONASS; clock errors ~1-2 ns for GPS (after the common offset), < 1 ns
for Galileo, several ns for GLONASS. Each bound is about twice the published level, so
that a wrong relativistic term (up to 20 ns), a wrong group-delay or time-system handling
(tens of ns), a wrong sign of Earth rotation (tens of km) or a 1-s time error (~4 km)
fail clearly.
"""
from __future__ import annotations

import pytest

from gnss_obs.orbit_validation import compare_with_precise, orbit_clock_statistics

ORBIT_RMS_MAX_M = {"G": 3.0, "E": 3.0, "R": 10.0}
CLOCK_RMS_MAX_NS = {"G": 4.0, "E": 2.0, "R": 20.0}
#: CODE and IGS rapid GPS products agree to a few cm: the broadcast statistics against
#: either must agree to a few cm too (1-2 m RMS values, 0.05 m apart at most).
PRODUCT_AGREEMENT_M = 0.05


@pytest.fixture(scope="module")
def cod_stats(nav, cod_sp3):
    return orbit_clock_statistics(compare_with_precise(nav.records, cod_sp3.table))


@pytest.mark.parametrize("system", ["G", "E", "R"])
def test_orbit_and_clock_against_code_final(cod_stats, system):
    row = cod_stats.loc[system]
    assert row["n_sv"] >= 10  # the excerpt's satellites of the system are all compared
    assert row["orbit_rms_3d_m"] < ORBIT_RMS_MAX_M[system]
    assert row["clock_rms_ns"] < CLOCK_RMS_MAX_NS[system]


def test_galileo_fnav_clock_matches_code_signal_reference(nav, cod_sp3):
    """CODE's Galileo clocks refer to E1/E5a, as F/NAV clocks do: F/NAV clock residuals are
    within the I/NAV bound as well (both messages are usable)."""
    d = compare_with_precise(nav.records, cod_sp3.table, systems="E", galileo_message="fnav")
    stats = orbit_clock_statistics(d).loc["E"]
    assert stats["clock_rms_ns"] < CLOCK_RMS_MAX_NS["E"]
    assert stats["orbit_rms_3d_m"] < ORBIT_RMS_MAX_M["E"]


def test_gps_against_igs_rapid_agrees_with_code(nav, igr_sp3, cod_stats):
    igr = orbit_clock_statistics(compare_with_precise(nav.records, igr_sp3.table, systems="G"))
    assert abs(igr.loc["G", "orbit_rms_3d_m"] - cod_stats.loc["G", "orbit_rms_3d_m"]) \
        < PRODUCT_AGREEMENT_M
