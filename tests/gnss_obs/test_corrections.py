"""Look angles, troposphere and Klobuchar ionosphere against closed forms and properties."""
from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from gnss_obs.constants import WEEK_S
from gnss_obs.corrections import (ionosphere_scale, klobuchar_delay_s, look_angles,
                                  niell_mapping, standard_atmosphere, troposphere_delay_m,
                                  zenith_delays_m)
from trackmodel.earth import WGS84, geodetic_to_ecef

ATOL_ANGLE_RAD = 1e-12
ATOL_DELAY_M = 1e-6  # 1 µm: closed forms evaluated to double precision
ATOL_IONO_S = 1e-20


@pytest.mark.parametrize("offset_e,elevation_deg,azimuth_deg", [
    ((1e7, 0.0, 0.0), 90.0, None),     # straight up from (0°, 0°)
    ((0.0, 0.0, 1e7), 0.0, 0.0),       # due north on the horizon
    ((0.0, 1e7, 0.0), 0.0, 90.0),      # due east
    ((0.0, -1e7, 0.0), 0.0, 270.0),    # due west
    ((0.0, 0.0, -1e7), 0.0, 180.0),    # due south
    ((1e7, 1e7, 0.0), 45.0, 90.0),     # east, 45° up
])
def test_look_angles_edge_table(offset_e, elevation_deg, azimuth_deg):
    r_rx = np.array([WGS84.a_m, 0.0, 0.0])
    el, az = look_angles(r_rx, (r_rx + np.array(offset_e))[None, :])
    assert abs(el[0] - np.deg2rad(elevation_deg)) < ATOL_ANGLE_RAD
    if azimuth_deg is not None:
        assert abs(az[0] - np.deg2rad(azimuth_deg)) < ATOL_ANGLE_RAD


def test_zenith_hydrostatic_delay_closed_form():
    """Saastamoinen/Davis at sea level and 45°: ZHD = 0.0022768 · 1013.25 / 1 = 2.30697 m."""
    zhd, zwd = zenith_delays_m(np.deg2rad(45.0), 0.0)
    assert abs(zhd - 0.0022768 * 1013.25) < ATOL_DELAY_M
    assert 0.05 < zwd < 0.3  # standard-atmosphere wet delay, 5-30 cm


def test_standard_atmosphere_lapse():
    """Pressure falls by the barometric formula: 1013.25 (1 - 2.2557e-5 h)^5.2568 hPa."""
    p, temperature, _ = standard_atmosphere(np.array([0.0, 1000.0]))
    np.testing.assert_allclose(p, [1013.25, 1013.25 * (1 - 2.2557e-2) ** 5.2568])
    np.testing.assert_allclose(temperature, [288.15, 281.65])


def test_mapping_is_one_at_zenith_and_near_cosecant_above_30_degrees():
    """Niell 1996: m(90°) = 1 (its normalisation); the troposphere is a thin shell, so at
    moderate elevations m ≈ 1/sin(el) within 1 %."""
    lat, h, doy = np.deg2rad(41.6), 250.0, 334.0
    m_h, m_w = niell_mapping(np.deg2rad(90.0), lat, 0.0, day_of_year=doy)
    assert abs(m_h - 1.0) < 1e-12 and abs(m_w - 1.0) < 1e-12
    el = np.deg2rad(np.array([30.0, 45.0, 60.0]))
    m_h, m_w = niell_mapping(el, lat, h, day_of_year=doy)
    np.testing.assert_allclose(m_h * np.sin(el), 1.0, atol=0.01)
    np.testing.assert_allclose(m_w * np.sin(el), 1.0, atol=0.01)
    m5, _ = niell_mapping(np.deg2rad(5.0), lat, h, day_of_year=doy)
    assert 9.5 < m5 < 10.5  # Niell (1996) Fig. 1: ~10 at 5°


@settings(max_examples=50, deadline=None)
@given(st.floats(-89.0, 89.0), st.floats(1.0, 365.0))
def test_niell_seasons_mirror_between_hemispheres(lat_deg, doy):
    """The southern hemisphere's season is the northern one shifted by half a year."""
    el = np.deg2rad(12.0)
    north, _ = niell_mapping(el, np.deg2rad(abs(lat_deg)), 0.0, day_of_year=doy)
    south, _ = niell_mapping(el, -np.deg2rad(abs(lat_deg)), 0.0,
                             day_of_year=doy - 365.25 / 2.0)
    assert abs(north - south) < 1e-12


def test_slant_delay_is_zenith_times_mapping():
    lat, h, t = np.deg2rad(41.6), 250.0, 2134 * WEEK_S + 45_600.0
    el = np.deg2rad(np.array([10.0, 35.0, 90.0]))
    slant = troposphere_delay_m(el, lat, h, gps_time_s=t)
    zhd, zwd = zenith_delays_m(lat, h)
    assert abs(slant[2] - (zhd + zwd)) < ATOL_DELAY_M
    assert np.all(np.diff(slant) < 0)  # longer paths at low elevation


def _klobuchar_zenith(alpha, beta, sow, lon_deg=0.0):
    return klobuchar_delay_s(alpha, beta, lat=0.0, lon=np.deg2rad(lon_deg),
                             elevation=np.array([np.pi / 2]), azimuth=np.array([0.0]),
                             gps_time_s=2134 * WEEK_S + sow)[0]


def test_klobuchar_closed_form_at_peak_and_night():
    """With α = (A, 0, 0, 0) the amplitude is A whatever the geomagnetic latitude; at the
    zenith the slant factor is F = 1 + 16 (0.53 - 0.5)³ and the pierce point is the receiver.
    At local time 14:00 (50400 s) the cosine term is 1: T = F (5 ns + A); at night T = F·5 ns
    (IS-GPS-200N Figure 20-4)."""
    A = 2e-8
    alpha, beta = [A, 0.0, 0.0, 0.0], [100_000.0, 0.0, 0.0, 0.0]
    F = 1.0 + 16.0 * (0.53 - 0.5) ** 3
    assert abs(_klobuchar_zenith(alpha, beta, 50_400.0) - F * (5e-9 + A)) < ATOL_IONO_S
    assert abs(_klobuchar_zenith(alpha, beta, 10_000.0) - F * 5e-9) < ATOL_IONO_S
    # local time = 43200 λ(semicircles) + t: 90° east is 6 h ahead.
    assert abs(_klobuchar_zenith(alpha, beta, 50_400.0 - 21_600.0, lon_deg=90.0)
               - F * (5e-9 + A)) < ATOL_IONO_S


def test_klobuchar_on_the_file_coefficients_is_physical(nav):
    """The 2020-11-29 broadcast model near Barcelona at 12:40: a daytime vertical delay of
    1-5 m at L1 (solar minimum), larger at lower elevations (slant factor up to ~3)."""
    el = np.deg2rad(np.array([90.0, 30.0, 10.0]))
    d = 299_792_458.0 * klobuchar_delay_s(nav.header.iono_gps_alpha, nav.header.iono_gps_beta,
                                          lat=np.deg2rad(41.64), lon=np.deg2rad(2.35),
                                          elevation=el, azimuth=np.zeros(3),
                                          gps_time_s=2134 * WEEK_S + 45_600.0)
    assert 1.0 < d[0] < 5.0 and d[0] < d[1] < d[2] < 3.2 * d[0]


def test_ionosphere_scale():
    """(f_L1/f)²: Galileo E5a (1176.45 MHz) = (154/115)²; L1 itself 1."""
    np.testing.assert_allclose(ionosphere_scale([1575.42e6, 1176.45e6]),
                               [1.0, (154.0 / 115.0) ** 2], rtol=1e-14)


def test_receiver_frame_is_geodetic():
    """Elevation is measured from the ellipsoid normal, not the geocentric radius."""
    lat = np.deg2rad(45.0)
    r_rx = geodetic_to_ecef(lat, 0.0, 0.0)
    normal = np.array([np.cos(lat), 0.0, np.sin(lat)])
    el, _ = look_angles(r_rx, (r_rx + 2e7 * normal)[None, :])
    assert abs(el[0] - np.pi / 2) < ATOL_ANGLE_RAD


@given(st.floats(min_value=-np.pi / 2, max_value=np.pi / 2, allow_nan=False),
       st.floats(min_value=np.deg2rad(1.0), max_value=np.pi / 2))
@settings(max_examples=300, deadline=None)
def test_niell_of_one_latitude_is_the_batch_value(lat, el):
    """Reference: the same receiver in a batch of two latitudes, which takes `np.interp`'s
    own path (`_interp_lat`'s scalar path must give the same bits); the table's nodes
    (15°..75°) and both sides of them are among the draws' range."""
    doy = 100.0
    one = niell_mapping(el, lat, 200.0, day_of_year=doy)
    batch = niell_mapping(el, np.array([lat, 0.3]), 200.0, day_of_year=doy)
    assert one[0] == batch[0][0] and one[1] == batch[1][0]


@pytest.mark.parametrize("lat_deg", [0.0, 15.0, 30.0, 44.9, 45.0, 75.0, 80.0, -15.0, -60.0])
def test_niell_table_nodes_and_beyond(lat_deg):
    """Edge table: at the nodes and outside the table the scalar path equals the batch."""
    lat = np.deg2rad(lat_deg)
    one = niell_mapping(0.3, lat, 0.0, day_of_year=10.0)
    batch = niell_mapping(0.3, np.array([lat, lat]), 0.0, day_of_year=10.0)
    assert one[0] == batch[0][0] and one[1] == batch[1][0]


@given(st.floats(min_value=-np.pi / 2, max_value=np.pi / 2, allow_nan=False),
       st.floats(min_value=-100.0, max_value=3000.0, allow_nan=False),
       st.floats(min_value=0.0, max_value=2.0e9, allow_nan=False))
@settings(max_examples=300, deadline=None)
def test_troposphere_of_one_receiver_is_the_batch_value(lat, h, t):
    """Reference: the same receiver in a batch of two (latitude, height, time), which takes
    the NumPy path; one receiver's terms are Python floats (`_receiver_scalar`) and must
    give the same values, heights below 0 m included (floored). On this project's
    machines (no AVX-512) `math`'s exp/cos/pow and NumPy's give the same bits, so the two
    paths are equal; a NumPy build that uses its own SIMD exp/cos (AVX-512) may differ
    from `math` by an ulp in each, hence `MAX_ULP_MATH_VS_NUMPY` and not ``==``."""
    el = np.deg2rad(np.array([3.0, 10.0, 35.0, 89.0]))
    one = troposphere_delay_m(el, lat, h, gps_time_s=t)
    both = [troposphere_delay_m(e, np.array([lat, 0.3]), np.array([h, 10.0]),
                                gps_time_s=np.array([t, 1.0e9]))[0] for e in el]
    np.testing.assert_array_max_ulp(np.asarray(one, dtype=float), np.array(both),
                                    maxulp=MAX_ULP_MATH_VS_NUMPY)
    zenith = zenith_delays_m(lat, h)
    batch = zenith_delays_m(np.array([lat, 0.3]), np.array([h, 10.0]))
    np.testing.assert_array_max_ulp(np.array([zenith[0], zenith[1]], dtype=float),
                                    np.array([batch[0][0], batch[1][0]]),
                                    maxulp=MAX_ULP_MATH_VS_NUMPY)


#: An ulp in each of the few libm calls a delay goes through (exp, cos, pow), compounded.
MAX_ULP_MATH_VS_NUMPY = 8
