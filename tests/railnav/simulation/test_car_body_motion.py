"""The car body on its track (`railnav.filters.car_body`, `railnav.simulation.car_body_motion`).

References: the chord offsets' closed forms (−κd on an arc, b/(2R) over a bogie, κ'b²/24 at
the centre of a transition); the simulated IMU against a second method, the finite
differences of the truth's own DCM (the gyro) and of its ECEF position (the accelerometer);
the suspension's σ against its stated value; and a scenario without a car body gives the
same trip as before (the default path is untouched).
"""
from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest

from railnav.errors import ConfigError
from railnav.filters.car_body import chord_offsets
from railnav.simulation.car_body_config import CarBodyMotion
from railnav.simulation.scenarios import get_scenario, simulate_scenario
from strapdown.euler import C_b_n
from trackmodel.earth import C_n_e
from trackmodel.sections import Section
from trackmodel.track import Track

B_M, R_M = 19.0, 600.0
#: Quadrature and third-order terms of the chord mean: < 1e-6 rad (module docstring).
ATOL_CHORD_RAD = 2e-6
#: Central differences at 100 Hz of a 1-Hz suspension: O((2π f h)²/6) relative ≈ 7e-4 of a
#: 20-mrad/s rate, and the track's own rate ~ v/R: 1e-5 rad/s is far below either signal.
ATOL_RATE_RADPS = 2e-5


@pytest.fixture(scope="module")
def arc_track():
    """Straight 300 m, clothoid 120 m to R 600 m, arc 500 m, straight 300 m."""
    return Track.from_sections([Section(300.0, azimuth_deg=30.0),
                                Section(120.0, curvature_1pm=0.0, curvature_end_1pm=1 / R_M),
                                Section(500.0, curvature_1pm=1 / R_M),
                                Section(300.0, curvature_1pm=0.0)],
                               lat=np.radians(47.0), lon=np.radians(8.0))


@pytest.mark.parametrize("d_m", [0.0, 4.0, B_M / 2])
def test_chord_offset_on_an_arc_is_minus_kappa_d(arc_track, d_m):
    off = chord_offsets(arc_track, np.array([600.0, 700.0]), bogie_spacing_m=B_M,
                        imu_offset_m=d_m)
    np.testing.assert_allclose(off.yaw, -d_m / R_M, atol=ATOL_CHORD_RAD)
    np.testing.assert_allclose(off.yaw_rate_1pm, 0.0, atol=1e-9)
    np.testing.assert_allclose(off.pitch, 0.0, atol=1e-12)


def test_chord_offset_over_a_bogie_is_b_over_2r(arc_track):
    off = chord_offsets(arc_track, np.array([650.0]), bogie_spacing_m=B_M, imu_offset_m=B_M / 2)
    assert off.yaw[0] == pytest.approx(-B_M / (2 * R_M), abs=ATOL_CHORD_RAD)   # -15.8 mrad


def test_chord_offset_in_a_transition_is_kappa_prime_b2_over_24(arc_track):
    kappa_prime = 1 / R_M / 120.0
    off = chord_offsets(arc_track, np.array([360.0]), bogie_spacing_m=B_M, imu_offset_m=0.0)
    assert off.yaw[0] == pytest.approx(kappa_prime * B_M ** 2 / 24, abs=ATOL_CHORD_RAD)


def test_chord_rate_is_the_derivative_of_the_offset(arc_track):
    """Across the joints (kinks of A'), the stated rate against central differences."""
    s = np.linspace(290.0, 440.0, 61)
    h = 1e-3
    up, down, mid = (chord_offsets(arc_track, s + e) for e in (h, -h, 0.0))
    np.testing.assert_allclose(mid.yaw_rate_1pm, (up.yaw - down.yaw) / (2 * h), atol=1e-7)


@pytest.fixture(scope="module")
def body_sim():
    scenario = replace(get_scenario("curvy"), duration_s=200.0, car_body=CarBodyMotion())
    return simulate_scenario(scenario, seed=3)


@pytest.fixture(scope="module")
def smooth_body_sim():
    """Chord and mounting without the suspension (whose rate is only C⁰: finite
    differences of its angle do not converge fast enough for a tight check)."""
    scenario = replace(get_scenario("curvy"), duration_s=200.0,
                       car_body=CarBodyMotion(suspension_sigma_rad=(0.0, 0.0, 0.0)))
    return simulate_scenario(scenario, seed=3)


def test_gyro_is_the_rate_of_the_truths_attitude(smooth_body_sim):
    """ω_ib_b against the finite-difference rate of C_b_e = C_n_e C_b_n(truth angles):
    [ω_eb_b ×] = C_b_eᵀ dC_b_e/dt, plus Earth rate (a second method: no Euler rates)."""
    tr, imu, earth = (smooth_body_sim.truth, smooth_body_sim.imu_ideal,
                      smooth_body_sim.track.earth)
    assert np.ptp(tr.body_attitude[:, 0] - tr.yaw) > 0.0     # the chord is there
    k = np.arange(1000, 19000, 997)
    C = C_n_e(tr.lat, tr.lon) @ C_b_n(tr.yaw, tr.pitch, tr.roll)
    dt = tr.time_s[1] - tr.time_s[0]
    dC = (C[k + 1] - C[k - 1]) / (2 * dt)
    W = np.swapaxes(C[k], -1, -2) @ dC
    w = 0.5 * np.stack([W[:, 2, 1] - W[:, 1, 2], W[:, 0, 2] - W[:, 2, 0],
                        W[:, 1, 0] - W[:, 0, 1]], axis=-1)
    w += np.einsum("kji,j->ki", C[k], np.array([0.0, 0.0, earth.omega_radps]))
    np.testing.assert_allclose(imu.omega_ib_b[k], w, atol=ATOL_RATE_RADPS)


def test_accelerometer_is_the_truths_acceleration_in_imu_axes(body_sim):
    """f_b against the second difference of r_e (Coriolis, gravity added) turned into the
    truth's IMU axes."""
    from strapdown.gravity import g_n
    tr, imu, earth = body_sim.truth, body_sim.imu_ideal, body_sim.track.earth
    k = np.arange(1000, 19000, 997)
    dt = tr.time_s[1] - tr.time_s[0]
    a_e = (tr.r_e[k + 1] - 2 * tr.r_e[k] + tr.r_e[k - 1]) / dt ** 2
    v_e = (tr.r_e[k + 1] - tr.r_e[k - 1]) / (2 * dt)
    omega = np.array([0.0, 0.0, earth.omega_radps])
    C_ne = C_n_e(tr.lat[k], tr.lon[k])
    f_e = a_e + 2 * np.cross(omega, v_e) - np.einsum("kij,kj->ki", C_ne,
                                                     g_n(tr.lat[k], tr.h[k], earth=earth))
    C = C_ne @ C_b_n(tr.yaw[k], tr.pitch[k], tr.roll[k])
    f_b = np.einsum("kji,kj->ki", C, f_e)
    np.testing.assert_allclose(imu.f_b[k], f_b, atol=2e-3)   # 2nd differences of ~1e6 m


def test_suspension_oscillator_matches_its_closed_forms():
    """Stationary σ of the angle (σ) and of its rate (ω₀σ), and the autocorrelation at 2 s,
    e^{−ζω₀τ}(cos ω_dτ + ζ/√(1−ζ²) sin ω_dτ), at full speed over 2000 s (~3800 correlation
    times: the sample σ within 5 %, the correlation within 0.05)."""
    from railnav.simulation.car_body_motion import suspension_angles
    motion = CarBodyMotion()
    t = np.arange(0.0, 2000.0, 0.01)
    v = np.full(t.size, 100.0)
    ang, rate = suspension_angles(t, v, np.zeros(t.size), motion, np.random.default_rng(5))
    w0, zeta = 2 * np.pi * motion.suspension_frequency_hz, motion.suspension_damping
    np.testing.assert_allclose(ang.std(axis=0), motion.suspension_sigma_rad, rtol=0.05)
    np.testing.assert_allclose(rate.std(axis=0), w0 * np.array(motion.suspension_sigma_rad),
                               rtol=0.05)
    lag = 200
    rho = [np.corrcoef(ang[:-lag, j], ang[lag:, j])[0, 1] for j in range(3)]
    wd, tau = w0 * np.sqrt(1 - zeta ** 2), 2.0
    expected = np.exp(-zeta * w0 * tau) * (np.cos(wd * tau)
                                           + zeta / np.sqrt(1 - zeta ** 2) * np.sin(wd * tau))
    np.testing.assert_allclose(rho, expected, atol=0.05)


def test_suspension_sigma_and_mounting_are_as_stated(body_sim):
    body, motion = body_sim.truth.body_attitude, CarBodyMotion()
    cruise = body_sim.truth.v > 20.0
    pt = body_sim.track.at(body_sim.truth.s[cruise])
    roll = body[cruise, 2]
    # ~150 s of a 1-Hz oscillator (ζ 0.3: ~60 correlation times): sample σ within 25 %
    assert np.std(roll) == pytest.approx(motion.suspension_sigma_rad[2], rel=0.25)
    assert np.all(np.abs(body_sim.truth.mount_rad) < 4 * motion.mount_sigma_rad)
    # the IMU's yaw is the body's plus the mounting's (small angles: to ~1e-3 rad)
    yaw_diff = (body_sim.truth.yaw - body[:, 0] + np.pi) % (2 * np.pi) - np.pi
    np.testing.assert_allclose(yaw_diff, body_sim.truth.mount_rad[0], atol=2e-3)
    assert pt.s.size > 1000
    still = body_sim.truth.v == 0.0
    assert np.all(body[still, 2] == 0.0)      # no suspension motion at a standstill


def test_default_scenario_is_unchanged():
    a = simulate_scenario(replace(get_scenario("curvy"), duration_s=20.0), seed=1)
    assert not hasattr(a.truth, "mount_rad")
    np.testing.assert_array_equal(a.truth.roll, 0.0)


@pytest.mark.parametrize("bad", [dict(bogie_spacing_m=-1.0), dict(imu_offset_m=20.0),
                                 dict(suspension_sigma_rad=(1e-3, 1e-3)),
                                 dict(mount_sigma_rad=float("nan"))])
def test_bad_car_body_is_refused(bad):
    with pytest.raises(ConfigError, match="car body motion"):
        CarBodyMotion(**bad)
