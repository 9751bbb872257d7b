"""Packed symmetric storage: NumPy and symbolic packing use one order (numpy.tril_indices)."""
from __future__ import annotations

import casadi as ca
import numpy as np

from ekf.packing import pack_sym, pack_sym_sx, packed_size, to_casadi, to_numpy, unpack_sym


def test_round_trip_and_order(rng):
    A = rng.normal(size=(3, 4, 4))
    P = A @ np.swapaxes(A, 1, 2)
    packed = pack_sym(P)
    assert packed.shape == (3, packed_size(4))
    np.testing.assert_array_equal(unpack_sym(packed), P)
    np.testing.assert_array_equal(packed[0, :3], [P[0, 0, 0], P[0, 1, 0], P[0, 1, 1]])
    sym = ca.SX.sym("P", 4, 4)
    f = ca.Function("pack", [sym], [pack_sym_sx(sym)])
    np.testing.assert_array_equal(np.array(f(P[1])).ravel(), packed[1])


def test_adapter_is_time_first():
    a = np.arange(6.0).reshape(3, 2)  # 3 steps of 2 components
    m = to_casadi(a)
    assert m.shape == (2, 3)
    np.testing.assert_array_equal(to_numpy(m), a)


def test_diagonal_indices_pick_the_diagonal(rng):
    """Reference: the diagonal of the unpacked matrices (`np.diagonal`), exactly."""
    from ekf.packing import diagonal_indices
    for n in (1, 2, 7, 11):
        A = rng.standard_normal((5, n, n))
        packed = pack_sym(A + np.swapaxes(A, 1, 2))
        expected = np.diagonal(unpack_sym(packed), axis1=1, axis2=2)
        assert np.array_equal(packed[:, diagonal_indices(n)], expected)
