"""Earth model against closed forms, pyproj (PROJ's own implementation) and round trips."""
from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from pyproj import Transformer

from trackmodel.earth import (WGS84, C_n_e, earth_from_name, ecef_to_enu, ecef_to_geodetic,
                              enu_to_ecef, geodetic_to_ecef, isometric_latitude,
                              latitude_from_isometric, radii, sphere)

ATOL_POS_M = 1e-6        # 1 µm: both sides are closed forms in float64
ATOL_LAT_RAD = 1e-13     # ~0.6 mm... of arc is 6e-7 m: far below anything we navigate
ATOL_H_M = 1e-6

lat_deg = st.floats(-89.9, 89.9)           # the poles are excluded (longitude undefined)
lon_deg = st.floats(-180.0, 180.0)
h_m = st.floats(-1000.0, 30_000_000.0)      # from below sea level to beyond GNSS orbits


def test_wgs84_defining_constants():
    # TR8350.2 Table 3.1 and 3.3: b = 6356752.3142 m, e² = 6.69437999014e-3
    assert WGS84.b_m == pytest.approx(6356752.3142, abs=1e-4)
    assert WGS84.e2 == pytest.approx(6.69437999014e-3, rel=1e-11)


def test_radii_closed_forms():
    M0, N0 = radii(0.0)
    Mp, Np = radii(np.pi / 2)
    assert M0 == pytest.approx(WGS84.a_m * (1 - WGS84.e2), abs=1e-6)   # meridian at equator
    assert N0 == pytest.approx(WGS84.a_m, abs=1e-6)                    # prime vertical at equator
    assert Mp == pytest.approx(WGS84.a_m ** 2 / WGS84.b_m, abs=1e-6)   # polar radius of curvature
    assert Np == pytest.approx(WGS84.a_m ** 2 / WGS84.b_m, abs=1e-6)
    M, N = radii(0.7, earth=sphere(6e6))
    assert M == N == 6e6


def test_geodetic_to_ecef_matches_pyproj(rng):
    lat = rng.uniform(-89.9, 89.9, 500)
    lon = rng.uniform(-180, 180, 500)
    h = rng.uniform(-500, 2e7, 500)
    to_ecef = Transformer.from_crs("EPSG:4979", "EPSG:4978", always_xy=True)
    x, y, z = to_ecef.transform(lon, lat, h)
    r = geodetic_to_ecef(np.radians(lat), np.radians(lon), h)
    np.testing.assert_allclose(r, np.stack([x, y, z], -1), rtol=0, atol=1e-5)  # PROJ: ~µm


def test_geodetic_to_ecef_of_one_point_is_that_of_many_to_the_bit(rng):
    # the one-point path (a fix at each epoch) and the broadcast path of many points
    # are the same operations on each point: the same bits, on both Earth models
    lat, lon = rng.uniform(-1.55, 1.55, 500), rng.uniform(-np.pi, np.pi, 500)
    h = rng.uniform(-1000.0, 3.0e7, 500)
    for earth in (WGS84, sphere(6371000.0)):
        many = geodetic_to_ecef(lat, lon, h, earth=earth)
        one = np.array([geodetic_to_ecef(a, b, c, earth=earth) for a, b, c
                        in zip(lat.tolist(), lon.tolist(), h.tolist())])
        assert one.shape == many.shape and np.array_equal(one, many)
        assert geodetic_to_ecef(lat[0], lon[0], h[0], earth=earth).shape == (3,)


@settings(max_examples=300, deadline=None)
@given(lat_deg, lon_deg, h_m)
def test_ecef_geodetic_round_trip(lat, lon, h):
    r = geodetic_to_ecef(np.radians(lat), np.radians(lon), h)
    la, lo, hh = ecef_to_geodetic(r)
    r2 = geodetic_to_ecef(la, lo, hh)
    np.testing.assert_allclose(r2, r, rtol=0, atol=ATOL_POS_M * max(1.0, abs(h) / 1e6))
    assert la == pytest.approx(np.radians(lat), abs=ATOL_LAT_RAD)
    assert hh == pytest.approx(h, abs=ATOL_H_M * max(1.0, abs(h) / 1e6))


def test_ecef_to_geodetic_on_sphere():
    earth = sphere(6_371_000.0)
    r = geodetic_to_ecef(0.3, -1.2, 150.0, earth=earth)
    assert np.linalg.norm(r) == pytest.approx(6_371_150.0, abs=1e-7)
    la, lo, h = ecef_to_geodetic(r, earth=earth)
    assert (la, lo, h) == pytest.approx((0.3, -1.2, 150.0), abs=1e-9)


def test_C_n_e_columns_are_derivatives_of_position():
    """East, north, up = unit directions of ∂r/∂λ, ∂r/∂φ, ∂r/∂h (central differences)."""
    lat, lon, h, d = 0.72, 0.04, 300.0, 1e-7
    C = C_n_e(lat, lon)
    np.testing.assert_allclose(C.T @ C, np.eye(3), atol=1e-15)
    assert np.linalg.det(C) == pytest.approx(1.0, abs=1e-15)
    for col, (dl, dn, dh) in enumerate([(0, d, 0), (d, 0, 0), (0, 0, 1.0)]):
        diff = geodetic_to_ecef(lat + dl, lon + dn, h + dh) - geodetic_to_ecef(lat - dl, lon - dn, h - dh)
        np.testing.assert_allclose(diff / np.linalg.norm(diff), C[:, col], atol=1e-8)


def test_enu_round_trip_and_known_offset():
    lat0, lon0, h0 = np.radians(41.64), np.radians(2.35), 80.0
    up_point = geodetic_to_ecef(lat0, lon0, h0 + 10.0)
    np.testing.assert_allclose(ecef_to_enu(up_point, lat0=lat0, lon0=lon0, h0=h0),
                               [0, 0, 10.0], atol=1e-8)
    enu = np.array([[100.0, -250.0, 3.0], [0.0, 0.0, 0.0]])
    back = ecef_to_enu(enu_to_ecef(enu, lat0=lat0, lon0=lon0, h0=h0), lat0=lat0, lon0=lon0, h0=h0)
    np.testing.assert_allclose(back, enu, atol=1e-8)


def test_shape_is_checked():
    with pytest.raises(ValueError, match=r"\(\.\.\., 3\)"):
        ecef_to_geodetic(np.zeros((3, 4)))


@pytest.mark.parametrize("earth", [WGS84, sphere()], ids=["wgs84", "sphere"])
def test_isometric_latitude(earth):
    lat = np.linspace(-1.5, 1.5, 41)
    psi = isometric_latitude(lat, earth=earth)
    # derivative dψ/dφ = M / (N cos φ), by central differences
    d = 1e-6
    dpsi = (isometric_latitude(lat + d, earth=earth) - isometric_latitude(lat - d, earth=earth)) / (2 * d)
    M, N = radii(lat, earth=earth)
    np.testing.assert_allclose(dpsi, M / (N * np.cos(lat)), rtol=1e-7)
    np.testing.assert_allclose(latitude_from_isometric(psi, earth=earth), lat, atol=1e-14)
    if earth.is_sphere:   # the 2017 paper's ln tan(π/4 + φ/2)
        np.testing.assert_allclose(psi, np.log(np.tan(np.pi / 4 + lat / 2)), atol=1e-13)


def test_earth_from_name():
    assert earth_from_name("WGS84") is WGS84
    assert earth_from_name("sphere", radius_m=6e6).a_m == 6e6
    with pytest.raises(ValueError, match="wgs84"):
        earth_from_name("mars")
