"""The full 9-state mechanization: Jacobians vs central differences, a stationary IMU
(closed form: gyro = C_n_b ω_ie_n, accel = −C_n_b g_n) gives zero rates, bias states."""
from __future__ import annotations

import numpy as np
import pytest

from strapdown.euler import C_b_n
from strapdown.frames import omega_ie_n
from strapdown.gravity import g_n
from strapdown.kinematics import SensorBiasStates
from strapdown.mechanization import build_full_model
from trackmodel.earth import WGS84, sphere

# Central differences (conftest.FD_STEP = 1e-6 relative): error ~ 1e-12 * f''' plus rounding
# 1e-16 * |f| / 1e-6; the state rates are O(10), so 1e-7 relative is the honest bound.
RTOL_JAC = 1e-6
ATOL_JAC = 1e-8
ATOL_STATIONARY = 1e-13     # m/s², rad/s: exact cancellation, float rounding only


def random_state(rng, n_bias=0):
    att = rng.uniform([0, -0.1, -0.1], [2 * np.pi, 0.1, 0.1])
    vel = rng.uniform(-30, 30, size=3)
    pos = [rng.uniform(-1.3, 1.3), rng.uniform(-3, 3), rng.uniform(-50, 1500)]
    return np.concatenate([att, vel, pos, rng.normal(0, 1e-3, size=n_bias)])


@pytest.mark.parametrize("biases", [None, SensorBiasStates(accel_tau_s=300.0)])
def test_jacobians_match_central_differences(rng, biases, central_jacobian):
    model = build_full_model(WGS84, biases)
    for _ in range(5):
        x = random_state(rng, 6 if biases else 0)
        u = np.concatenate([rng.normal(0, 1, 3) + [0, 0, 9.8], rng.normal(0, 0.1, 3)])
        np.testing.assert_allclose(np.asarray(model.F_x(x, u)),
                                   central_jacobian(lambda xx: model.f(xx, u), x),
                                   rtol=RTOL_JAC, atol=ATOL_JAC)
        np.testing.assert_allclose(np.asarray(model.G(x, u)),
                                   central_jacobian(lambda uu: model.f(x, uu), u),
                                   rtol=RTOL_JAC, atol=ATOL_JAC)


@pytest.mark.parametrize("earth", [WGS84, sphere()])
def test_stationary_imu_gives_zero_rates(rng, earth):
    model = build_full_model(earth)
    for _ in range(10):
        x = random_state(rng)
        x[3:6] = 0.0
        yaw, pitch, roll, lat, h = x[0], x[1], x[2], x[6], x[8]
        C = C_b_n(yaw, pitch, roll)
        u = np.concatenate([-C.T @ g_n(lat, h, earth=earth), C.T @ omega_ie_n(lat, earth=earth)])
        np.testing.assert_allclose(np.asarray(model.f(x, u)).ravel(), 0.0, atol=ATOL_STATIONARY)


def test_bias_states_are_subtracted_and_decay(rng):
    tau_a, tau_g = 100.0, 400.0
    plain = build_full_model(WGS84)
    aug = build_full_model(WGS84, SensorBiasStates(accel_tau_s=tau_a, gyro_tau_s=tau_g))
    x = random_state(rng, 6)
    u = rng.normal(0, 1, 6)
    out = np.asarray(aug.f(x, u)).ravel()
    np.testing.assert_allclose(out[:9], np.asarray(plain.f(x[:9], u - x[9:])).ravel(), atol=1e-15)
    np.testing.assert_allclose(out[9:], -x[9:] / np.repeat([tau_a, tau_g], 3), atol=1e-18)
    assert aug.layout.index("b_gz") == 14
