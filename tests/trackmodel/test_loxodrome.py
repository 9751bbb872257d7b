"""Straight sections: closed form against an independent ODE integration and the paper."""
from __future__ import annotations

import numpy as np
import pytest
from scipy.integrate import solve_ivp

from trackmodel.earth import WGS84, geodetic_to_ecef, radii, sphere
from trackmodel.loxodrome import loxodrome_position
from trackmodel.sections import Section
from trackmodel.track import Origin, Track

ATOL_POS_M = 1e-3            # the goal: 1 mm after 20 km
ATOL_PAPER_RAD = 1e-13       # paper's closed forms vs ours: the same formula up to rounding
ATOL_PAPER_H_M = 1e-6        # exp() of ~1e-3 rad times 6.4e6 m: rounding of a few 1e-9 m
LENGTH_M = 20_000.0
ORIGIN = Origin(50.45, 30.52, 100.0)
AZIMUTHS_DEG = [0.0, 30.0, 89.9, 90.0, 135.0, 180.0, 270.0]


def ode_reference(earth, origin: Origin, azimuth: float, elevation: float, s: np.ndarray):
    """φ, λ, h from solve_ivp of the three ODEs of the issue (rtol 1e-12)."""
    def rhs(_, y):
        M, N = radii(y[0], earth=earth)
        return [np.cos(elevation) * np.cos(azimuth) / (M + y[2]),
                np.cos(elevation) * np.sin(azimuth) / ((N + y[2]) * np.cos(y[0])),
                np.sin(elevation)]
    sol = solve_ivp(rhs, (0.0, s[-1]), [origin.lat, origin.lon, origin.h], t_eval=s,
                    method="DOP853", rtol=1e-12, atol=1e-14)
    return sol.y


@pytest.mark.parametrize("earth", [WGS84, sphere()], ids=["wgs84", "sphere"])
@pytest.mark.parametrize("azimuth_deg", AZIMUTHS_DEG)
@pytest.mark.parametrize("elevation_deg", [3.0, 0.0, -2.0])
def test_straight_matches_ode(earth, azimuth_deg, elevation_deg):
    track = Track([Section(LENGTH_M, azimuth_deg, elevation_deg)], ORIGIN, earth)
    s = np.linspace(0.0, LENGTH_M, 21)
    ref = ode_reference(earth, ORIGIN, np.radians(azimuth_deg), np.radians(elevation_deg), s)
    err = np.linalg.norm(track.at(s).r_e - geodetic_to_ecef(*ref, earth=earth), axis=-1)
    assert err.max() < ATOL_POS_M


def test_high_mountain_long_straight_matches_ode():
    # h from 3000 m up a 5 % grade over 60 km: the height coupling terms at their largest
    origin = Origin(-33.0, -70.0, 3000.0)
    track = Track([Section(60_000.0, 47.0, 2.86)], origin, WGS84)
    s = np.linspace(0.0, 60_000.0, 7)
    ref = ode_reference(WGS84, origin, np.radians(47.0), np.radians(2.86), s)
    err = np.linalg.norm(track.at(s).r_e - geodetic_to_ecef(*ref), axis=-1)
    assert err.max() < ATOL_POS_M


def test_paper_closed_forms_on_sphere():
    # Dolgiy et al. 2017: λ(φ) = λ0 + tanA (ψ(φ) − ψ(φ0)), ψ = ln tan(π/4 + φ/2),
    # h(φ) = (r + h0) exp(tanϑ secA (φ − φ0)) − r, and h = h0 + s sinϑ along the track.
    r, A, E = 6_371_000.0, np.pi / 6, np.pi / 60
    lat0, lon0, h0 = np.radians(50.45), np.radians(30.52), 100.0
    s = np.linspace(0.0, 25_000.0, 11)
    lat, lon, h = loxodrome_position(lat0, lon0, h0, azimuth=A, elevation=E, t=s,
                                     earth=sphere(r))
    lat_paper = lat0 + np.cos(A) / np.tan(E) * np.log((r + h0 + s * np.sin(E)) / (r + h0))
    psi = lambda phi: np.log(np.tan(np.pi / 4 + phi / 2))  # noqa: E731
    lon_paper = lon0 + np.tan(A) * (psi(lat) - psi(lat0))
    h_paper = (r + h0) * np.exp(np.tan(E) / np.cos(A) * (lat - lat0)) - r
    assert np.abs(lat - lat_paper).max() < ATOL_PAPER_RAD
    assert np.abs(lon - lon_paper).max() < ATOL_PAPER_RAD
    assert np.abs(h - h_paper).max() < ATOL_PAPER_H_M


def test_east_west_on_equator_stays_on_equator():
    # edge table: due east on the equator is a great circle; λ = s/(a + h) exactly (ϑ = 0)
    lat, lon, h = loxodrome_position(0.0, 0.0, 0.0, azimuth=np.pi / 2, elevation=0.0,
                                     t=np.array([1e3, 1e5]), earth=WGS84)
    assert np.abs(lat).max() < ATOL_PAPER_RAD and np.all(h == 0.0)   # cos(π/2) ≈ 6e-17
    assert np.allclose(lon, np.array([1e3, 1e5]) / WGS84.a_m, rtol=0, atol=ATOL_PAPER_RAD)


def test_meridian_length_is_meridian_arc():
    # a track due north at h = 0 is a meridian: its length is the meridian arc (pyproj Geod)
    from pyproj import Geod
    lat, lon, _ = loxodrome_position(np.radians(40.0), 0.0, 0.0, azimuth=0.0, elevation=0.0,
                                     t=np.array([50_000.0]), earth=WGS84)
    _, _, dist = Geod(ellps="WGS84").inv(0.0, 40.0, 0.0, np.degrees(lat[0]))
    assert lon[0] == 0.0
    assert dist == pytest.approx(50_000.0, abs=ATOL_POS_M)
