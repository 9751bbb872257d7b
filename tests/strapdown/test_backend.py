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


def test_many_rows_and_sparse_outputs(rng):
    """Several evaluation blocks, the last one partial, and an output with structural
    zeros: each row equals the function evaluated on that row alone (the CasADi VM)."""
    from strapdown.backend import _MAP_BLOCK
    a = ca.SX.sym("a", 3)
    fn = ca.Function("f", [a], [ca.jacobian(ca.vertcat(ca.sin(a[0]) * a[1], a[2] ** 2), a)])
    assert not fn.sparsity_out(0).is_dense()
    A = rng.normal(size=(2 * _MAP_BLOCK + 5, 3))
    (out,) = batch_call(fn, A)
    assert out.shape == (A.shape[0], 6)
    for i in (0, _MAP_BLOCK - 1, _MAP_BLOCK, A.shape[0] - 1):
        assert np.array_equal(out[i], np.asarray(ca.densify(fn(A[i]))).T.reshape(-1))


def test_vec3_of_scalars_equals_the_broadcast_stack():
    """Reference: `np.stack` of the broadcast components (the general path)."""
    from strapdown.backend import NumpyOps
    parts = (np.float64(1.5), 2, np.array(-3.25))
    fast = NumpyOps.vec3(*parts)
    assert fast.shape == (3,) and fast.dtype == float
    assert np.array_equal(fast, np.stack(np.broadcast_arrays(
        *(np.asarray(p, dtype=float) for p in parts)), axis=-1))
    rows = NumpyOps.vec3(np.zeros(4), 1.0, np.arange(4.0))
    assert rows.shape == (4, 3) and np.array_equal(rows[:, 1], np.ones(4))
