"""State layout (ekf's `StateLayout`, as the models build it) and bias-state configuration;
the shared acceleration equation against the ECEF form of Newton's law (independent:
inertial acceleration rotated to ENU)."""
from __future__ import annotations

import numpy as np
import pytest

from ekf.errors import ModelError
from ekf.layout import StateLayout
from strapdown.errors import StrapdownError
from strapdown.euler import C_b_n
from strapdown.gravity import g_n
from strapdown.kinematics import (BIAS_STATE_NAMES, SensorBiasStates, model_symbols,
                                  navigation_acceleration)
from strapdown.reduced import REDUCED_STATE_LAYOUT, REDUCED_STATE_NAMES
from trackmodel.earth import WGS84, C_n_e, radii

ATOL_ACCEL_MPS2 = 1e-12


def test_layout_indices_and_errors():
    """Reference: the documented state order, navigation states then the 6 bias states."""
    assert model_symbols(REDUCED_STATE_LAYOUT, None).layout == REDUCED_STATE_LAYOUT
    layout = model_symbols(REDUCED_STATE_LAYOUT, SensorBiasStates()).layout
    assert layout.size == 11 and [layout.index(n) for n in ("v", "yaw")] == [4, 0]
    assert layout.names == REDUCED_STATE_NAMES + BIAS_STATE_NAMES
    assert layout.slice("gyro_bias") == slice(8, 11)
    with pytest.raises(ModelError, match="no block"):
        layout.index("d")
    with pytest.raises(ModelError, match="twice|repeat"):
        model_symbols(StateLayout.from_blocks([("b_ax", 1)]), SensorBiasStates())


@pytest.mark.parametrize("kwargs", [dict(accel_tau_s=0.0), dict(gyro_tau_s=-1.0),
                                    dict(gyro_tau_s=float("nan"))])
def test_bias_time_constants_validated(kwargs):
    with pytest.raises(StrapdownError):
        SensorBiasStates(**kwargs)


def test_navigation_acceleration_equals_ecef_newton(rng):
    """For v_n given, the Earth-relative acceleration in ENU from ECEF: with C_n_e changing
    at the transport rate, dv_n/dt = C_e_n (r̈_e) − ω_en × v_n and r̈_e = f_e + g_e − 2Ω×ṙ_e."""
    for _ in range(20):
        lat, lon, h = rng.uniform(-1.3, 1.3), rng.uniform(-3, 3), rng.uniform(0, 2000)
        v_n = rng.uniform(-40, 40, 3)
        att = rng.uniform(-0.2, 0.2, 3)
        f_b = rng.normal(0, 1, 3) + [0, 0, 9.8]
        C = C_b_n(*att)
        a_n, _ = navigation_acceleration(C, f_b, v_n, lat, h, earth=WGS84)
        C_ne = C_n_e(lat, lon)
        omega_e = np.array([0, 0, WGS84.omega_radps])
        r_ddot = C_ne @ (C @ f_b + g_n(lat, h)) - 2 * np.cross(omega_e, C_ne @ v_n)
        R_M, R_N = radii(lat)
        w_en = np.array([-v_n[1] / (R_M + h), v_n[0] / (R_N + h), v_n[0] * np.tan(lat) / (R_N + h)])
        expected = C_ne.T @ r_ddot - np.cross(w_en, v_n)
        np.testing.assert_allclose(a_n, expected, atol=ATOL_ACCEL_MPS2)
