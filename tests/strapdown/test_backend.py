"""The NumPy <-> CasADi batch adapter: row order, broadcasting of 1-D inputs, shape errors."""
from __future__ import annotations

import casadi as ca
import numpy as np
import pytest

from strapdown.backend import batch_call


def test_rows_broadcast_and_order(rng):
    a, b = ca.SX.sym("a", 2), ca.SX.sym("b", 3)
    fn = ca.Function("f", [a, b], [ca.vertcat(a[0] * b, a[1]), ca.sum1(b)], ["a", "b"], ["y", "z"])
    A, B = rng.normal(size=(7, 2)), rng.normal(size=3)
    y, z = batch_call(fn, A, B)
    np.testing.assert_allclose(y, np.c_[A[:, :1] * B, A[:, 1]], rtol=1e-15)
    np.testing.assert_allclose(z[:, 0], np.full(7, B.sum()), rtol=1e-15)
    (single,) = batch_call(ca.Function("g", [a], [2 * a]), np.array([1.0, 2.0]))
    assert single.shape == (1, 2)


def test_shape_errors():
    a = ca.SX.sym("a", 2)
    fn = ca.Function("f", [a, ca.SX.sym("b", 2)], [a])
    with pytest.raises(ValueError, match="needs 2 components"):
        batch_call(fn, np.zeros((4, 3)), np.zeros(2))
    with pytest.raises(ValueError, match="rows"):
        batch_call(fn, np.zeros((4, 2)), np.zeros((5, 2)))
