"""One formula, two backends: NumPy arrays and CasADi symbols.

The physics of this package (Euler DCM, gravity, Earth and transport rates) is written
once against the small operation set below and evaluated either on NumPy arrays
(vectorized over a leading time axis, vectors ``(..., 3)``, matrices ``(..., 3, 3)``) or on
CasADi ``SX``/``MX`` scalars (vectors ``3x1`` columns, matrices ``3x3``) to build the
symbolic models. `ops_for` picks the backend from the arguments, so no formula has a
NumPy twin and a CasADi twin.

`batch_call` is the one adapter between CasADi's column-major ``DM`` and NumPy
``(N, k)`` arrays (STYLE.md §2.6): no other module touches ``DM``.
"""
from __future__ import annotations

import functools
from typing import Any

import casadi as ca
import numpy as np
import numpy.typing as npt

__all__ = ["ops_for", "NumpyOps", "CasadiOps", "batch_call"]

_SYMBOLIC = (ca.SX, ca.MX, ca.DM)


class NumpyOps:
    """Operations on NumPy arrays; vectors ``(..., 3)``, matrices ``(..., 3, 3)``."""

    sin = staticmethod(np.sin)
    cos = staticmethod(np.cos)
    tan = staticmethod(np.tan)
    sqrt = staticmethod(np.sqrt)

    @staticmethod
    def vec3(x: Any, y: Any, z: Any) -> np.ndarray:
        """Stack three broadcastable components into ``(..., 3)``."""
        if np.ndim(x) == np.ndim(y) == np.ndim(z) == 0:    # one vector: no broadcasting
            return np.array([x, y, z], dtype=float)
        x, y, z = np.broadcast_arrays(*(np.asarray(c, dtype=float) for c in (x, y, z)))
        return np.stack([x, y, z], axis=-1)

    @staticmethod
    def mat3(rows: list[list[Any]]) -> np.ndarray:
        """A ``(..., 3, 3)`` matrix from a 3x3 nested list of broadcastable entries."""
        flat = np.broadcast_arrays(*(np.asarray(c, dtype=float) for r in rows for c in r))
        return np.stack(flat, axis=-1).reshape(flat[0].shape + (3, 3))

    @staticmethod
    def comp(v: Any, i: int) -> Any:
        """Component ``i`` of a vector."""
        return v[..., i]

    @staticmethod
    def matvec(M: Any, v: Any) -> np.ndarray:
        """``M @ v`` over leading axes."""
        return np.einsum("...ij,...j->...i", M, v)

    @staticmethod
    def mat_t_vec(M: Any, v: Any) -> np.ndarray:
        """``Mᵀ @ v`` over leading axes."""
        return np.einsum("...ji,...j->...i", M, v)

    @staticmethod
    def cross(a: Any, b: Any) -> np.ndarray:
        """``a × b`` over leading axes."""
        return np.cross(a, b)

    @staticmethod
    def dot(a: Any, b: Any) -> np.ndarray:
        """``aᵀ b`` over leading axes."""
        return np.einsum("...i,...i->...", a, b)


class CasadiOps:
    """Operations on CasADi scalars; vectors are ``3x1`` columns, matrices ``3x3``."""

    sin = staticmethod(ca.sin)
    cos = staticmethod(ca.cos)
    tan = staticmethod(ca.tan)
    sqrt = staticmethod(ca.sqrt)

    @staticmethod
    def vec3(x: Any, y: Any, z: Any) -> Any:
        """A ``3x1`` column."""
        return ca.vertcat(x, y, z)

    @staticmethod
    def mat3(rows: list[list[Any]]) -> Any:
        """A ``3x3`` matrix from a nested list of rows."""
        return ca.vertcat(*(ca.horzcat(*r) for r in rows))

    @staticmethod
    def comp(v: Any, i: int) -> Any:
        """Component ``i`` of a column."""
        return v[i]

    @staticmethod
    def matvec(M: Any, v: Any) -> Any:
        """``M @ v``."""
        return ca.mtimes(M, v)

    @staticmethod
    def mat_t_vec(M: Any, v: Any) -> Any:
        """``Mᵀ @ v``."""
        return ca.mtimes(M.T, v)

    @staticmethod
    def cross(a: Any, b: Any) -> Any:
        """``a × b``."""
        return ca.cross(a, b)

    @staticmethod
    def dot(a: Any, b: Any) -> Any:
        """``aᵀ b``."""
        return ca.dot(a, b)


def ops_for(*values: Any) -> type[NumpyOps] | type[CasadiOps]:
    """The backend for these arguments: CasADi if any is a CasADi value, else NumPy."""
    if any(isinstance(v, _SYMBOLIC) for v in values):
        return CasadiOps
    return NumpyOps


def batch_call(fn: ca.Function, *args: npt.ArrayLike) -> tuple[np.ndarray, ...]:
    """Evaluate a CasADi function on a batch of NumPy rows.

    Parameters
    ----------
    fn : casadi.Function
        Every input and output a column vector (``k x 1``).
    *args : array_like, shape (N, k_i) or (k_i,)
        One array per input; a 1-D array is the same value for every row. Inputs of
        size 1 may also be given as shape (N,).

    Returns
    -------
    tuple of ndarray, each shape (N, m_j)
        One array per output, rows in the order of the input rows (evaluated by CasADi's
        map through a function buffer: the arrays are its memory, no ``casadi.DM``
        conversion, which took 0.23 s for 100 000 rows of 18).
    """
    arrays = []
    n_rows = None
    for i, arg in enumerate(args):
        a = np.asarray(arg, dtype=float)
        k = fn.size1_in(i)
        if a.ndim == 1 and k == 1 and a.shape[0] != 1:
            a = a[:, None]
        if a.shape[-1] != k:
            raise ValueError(f"input {fn.name_in(i)!r} needs {k} components, got shape {a.shape}")
        if a.ndim == 2:
            if n_rows is not None and a.shape[0] != n_rows:
                raise ValueError(f"inputs have {n_rows} and {a.shape[0]} rows")
            n_rows = a.shape[0]
        arrays.append(a)
    n_rows = 1 if n_rows is None else n_rows
    block = min(n_rows, _MAP_BLOCK)
    padded = -(-n_rows // block) * block
    # a (N, k) C-ordered array is the (k, N) column-major input of the map: each block of
    # rows is a contiguous slice, and the outputs are written straight into (N, m) arrays
    # (no casadi.DM in between); the last block is padded with copies of the last row
    inputs = [np.ascontiguousarray(np.broadcast_to(a, (n_rows, a.shape[-1]))) for a in arrays]
    inputs = [np.concatenate([a, np.repeat(a[-1:], padded - n_rows, axis=0)])
              if padded > n_rows else a for a in inputs]
    outputs = [np.empty((padded, fn.numel_out(j))) for j in range(fn.n_out())]
    buffer, evaluate = _dense_map(fn, block).buffer()
    for start in range(0, padded, block):
        for i, a in enumerate(inputs):
            buffer.set_arg(i, memoryview(a[start:start + block]))
        for j, o in enumerate(outputs):
            buffer.set_res(j, memoryview(o[start:start + block]))
        evaluate()
    return tuple(o[:n_rows] for o in outputs)


#: Rows per evaluation of `batch_call` (building a CasADi map costs ~1 µs per column).
_MAP_BLOCK = 2048


@functools.lru_cache(maxsize=64)
def _dense_map(fn: ca.Function, n_rows: int) -> ca.Function:
    """``fn`` with dense outputs, mapped over `n_rows` columns (kept for repeated calls)."""
    if all(fn.sparsity_out(j).is_dense() for j in range(fn.n_out())):
        return fn.map(n_rows)
    sym = ca.SX.sym if fn.is_a("SXFunction") else ca.MX.sym
    ins = [sym(fn.name_in(i), fn.sparsity_in(i)) for i in range(fn.n_in())]
    outs = fn.call(ins)
    dense = ca.Function(f"{fn.name()}_dense", ins, [ca.densify(o) for o in outs])
    return dense.map(n_rows)
