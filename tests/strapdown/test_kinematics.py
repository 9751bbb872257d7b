"""State layout (ekf's `StateLayout`, as the models build it) and bias-state configuration;
the shared acceleration equation against the ECEF form of Newton's law (independent:
inertial acceleration rotated to ENU)."""
from __future__ import annotations

import casadi as ca
import numpy as np
import pytest

from ekf.errors import ModelError
from ekf.layout import StateLayout
from strapdown.errors import StrapdownError
from strapdown.euler import C_b_n
from strapdown.gravity import g_n
from strapdown.kinematics import (BIAS_STATE_NAMES, SensorBiasStates, model_symbols,
                                  navigation_acceleration, scale_state_name)
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


def test_scale_element_states_follow_the_biases_and_are_validated():
    """Reference: the documented order, the biases then the accelerometer's and the gyro's
    ``S + M`` elements, each triad's in row-major order."""
    states = SensorBiasStates(accel_scale_elements=("zy", "xy"), gyro_scale_elements=("zz",))
    layout = model_symbols(REDUCED_STATE_LAYOUT, states).layout
    assert layout.names == REDUCED_STATE_NAMES + BIAS_STATE_NAMES + ("k_a_xy", "k_a_zy",
                                                                     "k_g_zz")
    assert scale_state_name("g", "yz") == "k_g_yz"
    for kwargs in (dict(accel_scale_elements=("zy", "zy")), dict(gyro_scale_elements=("zw",)),
                   dict(gyro_scale_elements=("z",))):
        with pytest.raises(StrapdownError, match="distinct|element"):
            SensorBiasStates(**kwargs)
    with pytest.raises(StrapdownError, match="sensor"):
        scale_state_name("m", "xy")


@pytest.mark.parametrize("elements", [(("zy",), ("zz",)), (("xx", "zy", "yz"), ("xz", "yz")),
                                      (("xx", "xy", "xz", "yx", "yy", "yz", "zx", "zy", "zz"),
                                       ("zz",))])
def test_corrected_inputs_undo_the_estimated_elements_of_the_triad_errors(rng, elements):
    """A triad reads ``y = (I + E) x + b`` with ``E = S + M`` (`strapdown.imu_errors`,
    written out here with drawn E at the MEMS grade's size, 1e-3, and b). With the bias
    states at ``b`` and the element states at E's entries, the model's corrected input is
    ``y − b − E_k y = x + (E − E_k) x − E_k (E x + b)``, ``E_k`` the estimated entries of
    E (the others 0): the unestimated part to first order, the rest of second order,
    bounded by ``‖E_k‖ (‖E‖ ‖x‖ + ‖b‖)`` in the maximum norm (``‖·‖`` the largest row
    sum)."""
    states = SensorBiasStates(accel_scale_elements=elements[0],
                              gyro_scale_elements=elements[1])
    sym = model_symbols(REDUCED_STATE_LAYOUT, states)
    corrected = ca.Function("c", [sym.x, sym.u], [ca.vertcat(sym.f_b, sym.omega_ib_b)])
    axes = "xyz"
    for _ in range(20):
        x_true = np.concatenate([rng.normal(0, 2, 3) + [0, 0, 9.8], rng.normal(0, 0.5, 3)])
        state, u, first_order = np.zeros(sym.layout.size), np.empty(6), np.empty(6)
        bounds = []
        for k, (sensor, part, chosen, sigma_b) in enumerate((
                ("a", slice(0, 3), elements[0], 1e-2), ("g", slice(3, 6), elements[1], 1e-3))):
            error = rng.normal(0, 1e-3, (3, 3))           # S on the diagonal, M off it
            bias = rng.normal(0, sigma_b, 3)
            u[part] = (np.eye(3) + error) @ x_true[part] + bias
            state[sym.layout.slice("accel_bias" if k == 0 else "gyro_bias")] = bias
            estimated = np.zeros((3, 3))
            for element in chosen:
                i, j = axes.index(element[0]), axes.index(element[1])
                estimated[i, j] = error[i, j]
                state[sym.layout.index(scale_state_name(sensor, element))] = error[i, j]
            first_order[part] = x_true[part] + (error - estimated) @ x_true[part]
            norm_k, norm = np.abs(estimated).sum(axis=1).max(), np.abs(error).sum(axis=1).max()
            bounds.append((part, norm_k * (norm * np.abs(x_true[part]).max()
                                           + np.abs(bias).max()), len(chosen) < 9))
        got = np.array(corrected(state, u)).ravel()
        for part, bound, partial in bounds:
            np.testing.assert_allclose(got[part], first_order[part], rtol=0,
                                       atol=bound * (1.0 + 1e-9))
            if partial:     # the unestimated entries are left in, above the bound
                assert np.abs(first_order[part] - x_true[part]).max() > 3.0 * bound
