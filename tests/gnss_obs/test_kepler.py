"""Keplerian broadcast orbits: closed forms, numerical derivatives, a GEO's published slot."""
from __future__ import annotations

import numpy as np
import pandas as pd
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from gnss_obs.constants import GM_BDS, GM_GPS, OMEGA_E_BDS, SPEED_OF_LIGHT_MPS, WEEK_S
from gnss_obs.ephemeris import satellite_states, select_ephemeris
from gnss_obs.kepler import eccentric_anomaly, kepler_states
from trackmodel.earth import ecef_to_geodetic

T_1240 = 2134 * WEEK_S + 45_600.0  # 2020-11-29 12:40:00 GPST
#: Central differences with h = 1/64 s: truncation ~h²/6 |d³r/dt³| < 1e-9 m/s, round-off
#: ~1e-16 × 3e7 m / 0.03 s ~ 1e-7 m/s; 10 µm/s leaves a margin of 100.
ATOL_VEL_MPS = 1e-5
ATOL_DRIFT_SPS = 1e-15  # clock-rate round-off ~ 1e-16 s / 0.02 s
H_S = 2.0 ** -6  # exactly representable at t ~ 1.3e9 s (float64 spacing 2.4e-7 s)
ATOL_REL_S = 1e-17  # relativistic term, a 1e-8 s quantity to double precision
ATOL_KEPLER_RAD = 1e-13


def _pure_kepler(gm_system: str, e: float, m0: float, t: float) -> pd.DataFrame:
    """A record without harmonic corrections, node drift or inclination rate."""
    zero = 0.0
    return pd.DataFrame([{
        "sv": f"{gm_system}11", "prn": 11, "toe_gps_s": t - 1200.0, "toc_gps_s": t - 1200.0,
        "toe_sow": 43_200.0, "af0_s": 1e-4, "af1_sps": 1e-12, "af2_sps2": zero,
        "sqrt_a_sqrtm": 5153.6, "delta_n_radps": zero, "m0_rad": m0, "e": e,
        "omega_rad": 0.7, "cuc_rad": zero, "cus_rad": zero, "crc_m": zero, "crs_m": zero,
        "cic_rad": zero, "cis_rad": zero, "i0_rad": 0.95, "idot_radps": zero,
        "omega0_rad": 1.1, "omega_dot_radps": -8e-9}])


@pytest.mark.parametrize("system,gm", [("G", GM_GPS), ("C", GM_BDS)])
@pytest.mark.parametrize("e,m0", [(0.0, 0.3), (0.012, 1.0), (0.02, -2.5)])
def test_relativistic_term_equals_minus_two_r_dot_v_over_c2(system, gm, e, m0):
    """For an unperturbed orbit F e sqrt(A) sin E = -2 r·v / c² exactly (IS-GPS-200N
    §20.3.3.3.3.1 derives the first from the second); r·v is the same in ECEF and inertial
    axes because the frame rotation adds ω × r ⊥ r."""
    rec = _pure_kepler(system, e, m0, T_1240)
    s = kepler_states(rec, [T_1240])
    expected = -2.0 * np.einsum("ni,ni->n", s.r_e, s.v_e) / SPEED_OF_LIGHT_MPS ** 2
    np.testing.assert_allclose(s.relativity_s, expected, rtol=0, atol=ATOL_REL_S)


def test_circular_orbit_radius_is_semi_major_axis():
    """e = 0 and no corrections: |r| = A at any time (closed form)."""
    rec = _pure_kepler("G", 0.0, 0.3, T_1240)
    t = T_1240 + np.array([-3600.0, 0.0, 5000.0])
    s = kepler_states(pd.concat([rec] * 3, ignore_index=True), t)
    np.testing.assert_allclose(np.linalg.norm(s.r_e, axis=1), 5153.6 ** 2, rtol=1e-14)


@settings(max_examples=200, deadline=None)
@given(st.floats(-10.0, 10.0), st.floats(0.0, 0.9))
def test_eccentric_anomaly_solves_keplers_equation(mean_anomaly, e):
    E = eccentric_anomaly(mean_anomaly, e)
    assert abs(E - e * np.sin(E) - mean_anomaly) < ATOL_KEPLER_RAD


@pytest.mark.parametrize("sv", ["G05", "G15", "E01", "E11", "C05", "C10", "C14", "C26"])
def test_velocity_and_clock_drift_are_time_derivatives(nav, sv):
    """Analytic velocity (IS-GPS-200N Table 20-IV; BeiDou GEO rotation) and clock drift
    against central differences of the position and clock (second method)."""
    sel = select_ephemeris(nav.records, [sv] * 3, [T_1240] * 3)
    assert sel["ephemeris_ok"].all()
    t = T_1240 + np.array([-H_S, 0.0, H_S])
    s = satellite_states(sel, t)
    np.testing.assert_allclose(s.v_e[1], (s.r_e[2] - s.r_e[0]) / (2 * H_S), rtol=0,
                               atol=ATOL_VEL_MPS)
    assert abs(s.clock_drift_sps[1] - (s.clock_s[2] - s.clock_s[0]) / (2 * H_S)) < ATOL_DRIFT_SPS


def test_beidou_geo_sits_at_its_published_slot(nav):
    """C05 is the BDS-2 GEO at 58.75° E (CSNO, BeiDou constellation status): its sub-satellite
    point stays within 0.5° of that longitude, near the equator (small inclination), at the
    geostationary radius (GM T²/4π²)^(1/3) with T the sidereal day 2π/Ω. Without the GEO
    rotation of BDS-SIS-ICD §5.2.4.12 the latitude would be off by about 5°."""
    sel = select_ephemeris(nav.records, ["C05"] * 4, [T_1240] * 4)
    t = T_1240 + np.array([0.0, 900.0, 1800.0, 3600.0])
    s = satellite_states(sel, t)
    lat, lon, _ = ecef_to_geodetic(s.r_e)
    geo_radius = (GM_BDS / OMEGA_E_BDS ** 2) ** (1.0 / 3.0)
    np.testing.assert_allclose(np.rad2deg(lon), 58.75, atol=0.5)
    assert np.all(np.abs(np.rad2deg(lat)) < 3.0)
    np.testing.assert_allclose(np.linalg.norm(s.r_e, axis=1), geo_radius, atol=50e3)
    assert np.all(np.linalg.norm(s.v_e, axis=1) < 50.0)  # nearly fixed in ECEF, m/s


def test_rejects_unknown_systems_and_bad_shapes(nav):
    rec = nav.records["G"].iloc[:2]
    with pytest.raises(ValueError, match="shape"):
        kepler_states(rec, [T_1240])
    with pytest.raises(ValueError, match="systems"):
        kepler_states(rec.assign(sv=["S20", "S22"]), [T_1240, T_1240])
