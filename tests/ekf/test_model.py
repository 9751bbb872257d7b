"""CdModel: default noise maps −∂f/∂u and −∂h_c/∂u against central differences, and
refusal of inconsistent functions."""
from __future__ import annotations

import casadi as ca
import numpy as np
import pytest

from ekf.errors import ModelError
from ekf.layout import StateLayout
from ekf.model import CdModel
from tests.support.ekf_examples import attitude_speed_clock_numpy, attitude_speed_clock_toy

STEP = 1e-6  # central-difference step (rad, m/s, rad/s, m/s²): error O(step²)
ATOL_FD = 1e-8


def _fd(fun, point, j):
    e = np.zeros_like(point)
    e[j] = STEP
    return (fun(point + e) - fun(point - e)) / (2 * STEP)


def test_default_noise_maps_are_minus_input_jacobians(rng):
    model = attitude_speed_clock_toy("fdcheck")
    x = np.array([0.3, 0.05, -0.04, 10.0, 15.0, 1.0, 0.1])
    u = np.concatenate([rng.normal(0, 0.3, 3) + [0, 0, 9.81], rng.normal(0, 0.05, 3)])
    p = np.zeros(0)
    f = lambda uu: np.array(model.f(x, uu, p)).ravel()  # noqa: E731
    h = lambda uu: np.array(model.h_c(x, uu, p)).ravel()  # noqa: E731
    G, D = np.array(model.G(x, u, p)), np.array(model.D(x, u, p))
    for j in range(6):
        np.testing.assert_allclose(-G[:, j], _fd(f, u, j), atol=ATOL_FD)
        np.testing.assert_allclose(-D[:, j], _fd(h, u, j), atol=ATOL_FD)
    # and the toy's hand-written NumPy maps (used by the reference loop) agree
    ref = attitude_speed_clock_numpy()
    np.testing.assert_allclose(ref.G(x, u, p), G, atol=1e-14)
    np.testing.assert_allclose(ref.D(x, u, p), D, atol=1e-14)
    fx = lambda xx: np.array(model.f(xx, u, p)).ravel()  # noqa: E731
    for j in range(7):
        np.testing.assert_allclose(ref.F_x(x, u, p)[:, j], _fd(fx, x, j), atol=ATOL_FD)


def test_inconsistent_models_are_refused():
    layout = StateLayout.from_blocks([("x", 2)])
    x, u, p = ca.SX.sym("x", 2), ca.SX.sym("u", 1), ca.SX.sym("p", 0)
    with pytest.raises(ModelError):
        CdModel.from_expressions(layout, x, u, p, ca.vertcat(x[0], x[1], u))  # 3 ≠ 2
    with pytest.raises(ModelError):
        CdModel.from_expressions(layout, x, u, p, x, h_c=x[0], D=ca.SX.ones(2, 1))
    with pytest.raises(ModelError):
        CdModel.from_expressions(layout, x, u, p, x * u, name="not an identifier")
