"""Track queries: curved sections vs an independent ODE, tangent vs finite differences,
arc curvature vs 1/R, joints, edge cases and errors."""
from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy.integrate import solve_ivp

# (tests import submodules: under pytest, tests/trackmodel shadows the package name)
from trackmodel.earth import WGS84, C_n_e, geodetic_to_ecef, radii, sphere
from trackmodel.errors import TrackError
from trackmodel.sections import Section
from trackmodel.track import Origin, Track

ATOL_POS_M = 1e-3            # the goal: 1 mm, also for integrated sections
ATOL_TANGENT = 1e-6          # FD of position over ±0.5 m: O(h²κ²) ≈ 1e-7 for R ≥ 600 m
ATOL_CURVATURE_1PM = 1e-12   # A(s) is a polynomial: dA/ds exact to rounding
FD_STEP_M = 0.5
R_M = 800.0

CURVY = [Section(3000.0, 30.0, 0.5), Section(150.0, None, None, 0.0, 1 / R_M, 1.0),
         Section(1200.0, None, None, 1 / R_M), Section(150.0, None, None, 1 / R_M, 0.0),
         Section(5000.0, None, 1.0, elevation_end_deg=-1.0),
         Section(400.0, None, None, 0.0, -1 / 20.0, -0.5)]
ORIGIN = Origin(41.6, 2.35, 250.0)


@pytest.fixture(scope="module")
def curvy() -> Track:
    return Track(CURVY, ORIGIN, WGS84)


def ode_track(track: Track, s_eval: np.ndarray) -> np.ndarray:
    """The whole track integrated section by section with Radau (not the build's DOP853),
    from the section table's A(s), ϑ(s) written out here: independent of the code."""
    out = np.empty((len(s_eval), 3))
    y = np.array([ORIGIN.lat, ORIGIN.lon, ORIGIN.h])
    s0, az = 0.0, np.radians(CURVY[0].azimuth_deg)
    el = np.radians(CURVY[0].elevation_deg)
    for sec in CURVY:
        L, k0, k1 = sec.length_m, sec.curvature_1pm, sec.curvature_end
        e0 = el if sec.elevation_deg is None else np.radians(sec.elevation_deg)
        e1 = e0 if sec.elevation_end_deg is None else np.radians(sec.elevation_end_deg)

        def rhs(t, y, az=az, k0=k0, k1=k1, L=L, e0=e0, e1=e1):
            A = az + k0 * t + (k1 - k0) * t * t / (2 * L)
            E = e0 + (e1 - e0) * t / L
            M, N = radii(y[0])
            return [np.cos(E) * np.cos(A) / (M + y[2]),
                    np.cos(E) * np.sin(A) / ((N + y[2]) * np.cos(y[0])), np.sin(E)]
        sol = solve_ivp(rhs, (0.0, L), y, method="Radau", rtol=1e-12, atol=1e-14,
                        dense_output=True)
        m = (s_eval >= s0) & (s_eval <= s0 + L)
        out[m] = sol.sol(s_eval[m] - s0).T
        y, s0, az, el = sol.y[:, -1], s0 + L, az + L * (k0 + k1) / 2, e1
    return out


def test_curved_sections_match_ode(curvy):
    s = np.linspace(0.0, curvy.length_m, 301)
    ref = geodetic_to_ecef(*ode_track(curvy, s).T)
    assert np.linalg.norm(curvy.at(s).r_e - ref, axis=-1).max() < ATOL_POS_M


def test_tangent_is_derivative_of_position(curvy):
    s = np.array([10.0, 3075.0, 3700.0, 4420.0, 6000.0, 9700.0])
    pt = curvy.at(s)
    fd = (curvy.at(s + FD_STEP_M).r_e - curvy.at(s - FD_STEP_M).r_e) / (2 * FD_STEP_M)
    u_e = np.einsum("...ij,...j->...i", C_n_e(pt.lat, pt.lon), pt.u_n)
    assert np.abs(fd[:-1] - u_e[:-1]).max() < ATOL_TANGENT
    # the last point is on the 20 m-radius clothoid end: FD error (h κ)² / 6 ≈ 1e-4
    assert np.abs(fd[-1] - u_e[-1]).max() < (FD_STEP_M / 20.0) ** 2


def test_du_ds_is_derivative_of_tangent(curvy):
    s = np.array([3075.0, 3700.0, 4420.0, 6000.0, 9700.0])
    d = 1e-2
    fd = (curvy.at(s + d).u_n - curvy.at(s - d).u_n) / (2 * d)
    fd2 = (curvy.at(s + d).du_ds_n - curvy.at(s - d).du_ds_n) / (2 * d)
    pt = curvy.at(s)
    assert np.abs(fd - pt.du_ds_n).max() < 1e-8            # O(d² |u'''|) with |κ| ≤ 1/20
    assert np.abs(fd2 - pt.d2u_ds2_n).max() < 1e-7


def test_arc_curvature_is_one_over_radius(curvy):
    s = np.linspace(3160.0, 4340.0, 7)                      # inside the 800 m arc
    pt = curvy.at(s)
    assert np.allclose(pt.curvature_1pm, 1 / R_M, rtol=0, atol=ATOL_CURVATURE_1PM)
    # horizontal curvature of the ENU tangent: |du/ds| = cosϑ |dA/ds| (ϑ' = 0 here)
    assert np.allclose(np.linalg.norm(pt.du_ds_n, axis=-1), np.cos(pt.elevation) / R_M,
                       rtol=1e-12)


def test_straight_has_zero_du_ds(curvy):
    pt = curvy.at(np.array([5.0, 2999.0]))
    assert np.all(pt.du_ds_n == 0.0) and np.all(pt.d2u_ds2_n == 0.0)


def test_position_and_tangent_continuous_across_joints(curvy):
    joints = np.cumsum([sec.length_m for sec in CURVY])[:-1]
    eps = 1e-7
    before, after = curvy.at(joints - eps), curvy.at(joints + eps)
    assert np.linalg.norm(before.r_e - after.r_e, axis=-1).max() < 1e-6
    assert np.abs(before.u_n - after.u_n).max() < 1e-9
    assert list(curvy.at(joints).section) == list(range(1, len(CURVY)))


def test_explicit_azimuth_makes_a_kink():
    """A small kink (within `MAX_KINK_DEG`) is taken as written; a larger one is refused
    (issue 18: a 180° kink ran with NEES 2.5e8)."""
    track = Track([Section(100.0, 0.0, 0.0), Section(100.0, 4.0, 0.0)], ORIGIN)
    assert np.degrees(track.at(100.0).azimuth) == pytest.approx(4.0)
    assert np.degrees(track.at(99.0).azimuth) == pytest.approx(0.0)
    with pytest.raises(TrackError, match="turns the track by 90°"):
        Track([Section(100.0, 0.0, 0.0), Section(100.0, 90.0, 0.0)], ORIGIN)


def test_scalar_and_array_queries_agree(curvy):
    s = np.array([0.0, 123.4, curvy.length_m])
    batch = curvy.at(s)
    for i, si in enumerate(s):
        one = curvy.at(float(si))
        assert one.r_e.shape == (3,) and one.lat.shape == ()
        assert np.array_equal(one.r_e, batch.r_e[i])


def test_section_at_is_section_of_for_one_distance(curvy):
    """`Track.section_at` (Python floats) against `Track.section_of` (NumPy): the track's
    ends, each joint and its neighbouring floats, outside the track, NaN, -0.0."""
    joints = np.cumsum([0.0] + [sec.length_m for sec in CURVY])
    near = np.concatenate([np.nextafter(joints, -np.inf), joints, np.nextafter(joints, np.inf)])
    s = np.concatenate([near, [-5.0, -0.0, 1e9, np.nan, np.inf, -np.inf, 4000.0]])
    assert [curvy.section_at(float(x)) for x in s] == curvy.section_of(s).tolist()


@pytest.mark.parametrize("bad", [-1.0, 1e9, np.nan, np.inf])
def test_s_outside_track_raises(curvy, bad):
    with pytest.raises(TrackError, match="s must"):
        curvy.at(np.array([0.0, bad]))


def test_first_section_needs_azimuth():
    with pytest.raises(TrackError, match="first section"):
        Track([Section(10.0, None, 0.0)], ORIGIN)


@pytest.mark.parametrize("kwargs", [dict(length_m=0.0), dict(length_m=-1.0),
                                    dict(length_m=1.0, elevation_deg=90.0),
                                    dict(length_m=np.nan)])
def test_bad_section_raises(kwargs):
    with pytest.raises(TrackError):
        Section(**{"azimuth_deg": 0.0, **kwargs})


@settings(max_examples=25, deadline=None)
@given(azimuth_deg=st.floats(0.0, 360.0), kappa=st.floats(-1 / 300, 1 / 300),
       lat_deg=st.floats(-80.0, 80.0))
def test_arc_on_sphere_matches_small_circle_length(azimuth_deg, kappa, lat_deg):
    """Property: on any track |r(s2) − r(s1)| ≤ s2 − s1 (a chord is never longer than
    the arc), and u_n stays a unit vector."""
    track = Track([Section(500.0, azimuth_deg, 1.0, kappa)], Origin(lat_deg, 10.0, 0.0),
                  sphere())
    pt = track.at(np.array([0.0, 250.0, 500.0]))
    chord = np.linalg.norm(pt.r_e[2] - pt.r_e[0])
    assert chord <= 500.0 + 1e-9
    assert np.allclose(np.linalg.norm(pt.u_n, axis=-1), 1.0, atol=1e-15)
