"""Euler kinematics against the DCM they are derived from (numerical dC/dt = C[ω×])."""
from __future__ import annotations

import casadi as ca
import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from strapdown.backend import batch_call
from strapdown.euler import (C_b_n, euler_from_C_b_n, euler_rates, omega_nb_b_from_rates,
                             skew)

# Exact-arithmetic identities evaluated in float64 on O(1) numbers.
ATOL_ORTHO = 1e-14
# Central difference with step 1e-6 rad: truncation ~1e-12, rounding ~1e-16/1e-6 = 1e-10.
ATOL_DCDT = 1e-8
STEP_RAD = 1e-6

angle = st.floats(-np.pi, np.pi, allow_nan=False)
# Excluded region: |pitch| > 80 deg (the rate matrix is singular at 90 deg; see euler.py).
pitch = st.floats(-1.4, 1.4, allow_nan=False)
rate = st.floats(-2.0, 2.0, allow_nan=False)


@given(angle, pitch, angle)
def test_dcm_is_a_rotation(yaw, pitch_, roll):
    C = C_b_n(yaw, pitch_, roll)
    np.testing.assert_allclose(C @ C.T, np.eye(3), atol=ATOL_ORTHO)
    assert np.linalg.det(C) == pytest.approx(1.0, abs=ATOL_ORTHO)


@given(angle, pitch, angle)
def test_body_x_is_the_tangent(yaw, pitch_, roll):
    """Column 0 = u = [cosθ sinψ, cosθ cosψ, sinθ] (ARCHITECTURE.md, Track)."""
    C = C_b_n(yaw, pitch_, roll)
    u = [np.cos(pitch_) * np.sin(yaw), np.cos(pitch_) * np.cos(yaw), np.sin(pitch_)]
    np.testing.assert_allclose(C[:, 0], u, atol=ATOL_ORTHO)


@pytest.mark.parametrize("yaw_deg, x_axis, y_axis", [
    (0.0, [0, 1, 0], [-1, 0, 0]),     # north, left = west
    (90.0, [1, 0, 0], [0, 1, 0]),     # east, left = north
    (180.0, [0, -1, 0], [1, 0, 0]),   # south, left = east
    (270.0, [-1, 0, 0], [0, -1, 0]),  # west, left = south
])
def test_yaw_edge_table(yaw_deg, x_axis, y_axis):
    C = C_b_n(np.radians(yaw_deg), 0.0, 0.0)
    np.testing.assert_allclose(C[:, 0], x_axis, atol=ATOL_ORTHO)
    np.testing.assert_allclose(C[:, 1], y_axis, atol=ATOL_ORTHO)
    np.testing.assert_allclose(C[:, 2], [0, 0, 1], atol=ATOL_ORTHO)


def test_positive_roll_lowers_the_right_side():
    C = C_b_n(0.0, 0.0, 0.1)
    assert C[2, 1] > 0  # body y (left) points up


@settings(max_examples=200)
@given(angle, pitch, angle, rate, rate, rate)
def test_rate_matrix_reproduces_dcm_derivative(yaw, pitch_, roll, wx, wy, wz):
    """dC/dt along the Euler rates E(θ,φ)ω equals C [ω×] (SEEDS.md erratum 1)."""
    omega_nb_b = np.array([wx, wy, wz])
    rates = euler_rates(pitch_, roll, omega_nb_b)
    angles = np.array([yaw, pitch_, roll])
    dC = (C_b_n(*(angles + STEP_RAD * rates)) - C_b_n(*(angles - STEP_RAD * rates))) / (
        2 * STEP_RAD)
    np.testing.assert_allclose(dC, C_b_n(*angles) @ skew(omega_nb_b), atol=ATOL_DCDT)


@given(pitch, angle, rate, rate, rate)
def test_forward_and_inverse_kinematics(pitch_, roll, a, b, c):
    rates = np.array([a, b, c])
    back = euler_rates(pitch_, roll, omega_nb_b_from_rates(pitch_, roll, rates))
    np.testing.assert_allclose(back, rates, atol=1e-11 * (1 + 1 / np.cos(pitch_) ** 2))


@given(st.floats(0, 2 * np.pi - 1e-9), pitch, st.floats(-3.1, 3.1))
def test_angles_round_trip(yaw, pitch_, roll):
    out = euler_from_C_b_n(C_b_n(yaw, pitch_, roll))
    np.testing.assert_allclose(np.unwrap([yaw, out[0]]), [yaw, yaw], atol=1e-10)
    np.testing.assert_allclose(out[1:], [pitch_, roll], atol=1e-10)


def test_rate_matrix_is_singular_at_vertical_pitch():
    rates = euler_rates(np.pi / 2, 0.0, np.array([0.0, 0.0, 1.0]))
    assert not np.all(np.isfinite(rates)) or np.max(np.abs(rates)) > 1e12


def test_batch_equals_row_by_row_and_casadi(rng):
    """One definition, two backends: NumPy batch = NumPy rows = CasADi Function."""
    angles = rng.uniform(-1.0, 1.0, size=(50, 3))
    batch = C_b_n(angles[:, 0], angles[:, 1], angles[:, 2])
    rows = np.stack([C_b_n(*a) for a in angles])
    a_sym = ca.SX.sym("a", 3)
    fn = ca.Function("C", [a_sym], [ca.reshape(C_b_n(a_sym[0], a_sym[1], a_sym[2]), 9, 1)])
    (flat,) = batch_call(fn, angles)
    np.testing.assert_allclose(batch, rows, atol=0)
    np.testing.assert_allclose(flat.reshape(50, 3, 3).transpose(0, 2, 1), batch, atol=1e-15)
