"""Packed storage of symmetric matrices, and the one CasADi ↔ NumPy adapter.

Convention (owned here): a symmetric ``(n, n)`` matrix is stored as its lower triangle,
row by row — the order of ``numpy.tril_indices(n)``: ``P00, P10, P11, P20, P21, P22, ...``
— a vector of ``n (n + 1) / 2`` numbers. The symbolic step functions use the same
order, so a packed covariance moves between NumPy and compiled code without copies.

:func:`to_numpy` / :func:`to_casadi` are the only places that touch ``casadi.DM``.
CasADi stores matrices column-major: a per-step quantity of size ``k`` over ``N`` steps
is a ``(k, N)`` DM, which is the ``(N, k)`` C-ordered NumPy array (time first,
components last, STYLE.md 2.4).
"""
from __future__ import annotations

from functools import lru_cache

import casadi as ca
import numpy as np
import numpy.typing as npt

__all__ = ["packed_size", "diagonal_indices", "pack_sym", "unpack_sym", "pack_sym_sx",
           "unpack_sym_sx", "to_numpy", "to_casadi"]

Array = npt.NDArray[np.float64]


def packed_size(n: int) -> int:
    """Length ``n (n + 1) / 2`` of a packed symmetric ``(n, n)`` matrix."""
    return n * (n + 1) // 2


@lru_cache(maxsize=64)
def _tril(n: int) -> tuple[np.ndarray, np.ndarray]:
    rows, cols = np.tril_indices(n)
    rows.setflags(write=False)
    cols.setflags(write=False)
    return rows, cols


@lru_cache(maxsize=64)
def _unpacked_positions(n: int) -> np.ndarray:
    """``(n, n)`` positions in the packed vector of each entry of the matrix (read only):
    one gather unpacks (`unpack_sym`; 1.4 µs of CPU at n = 7, the two scatters 2.7), each pair
    ``(i, j)``, ``(j, i)`` reading the same number."""
    rows, cols = _tril(n)
    index = np.empty((n, n), dtype=np.intp)
    index[rows, cols] = np.arange(rows.size)
    index[cols, rows] = np.arange(rows.size)
    index.setflags(write=False)
    return index


@lru_cache(maxsize=64)
def diagonal_indices(n: int) -> np.ndarray:
    """Positions of the diagonal ``P[i, i]`` in a packed ``(n, n)`` matrix (read-only):
    ``packed[..., diagonal_indices(n)]`` is ``np.diagonal(unpack_sym(packed))``, without
    unpacking."""
    i = np.arange(n)
    index = i * (i + 1) // 2 + i
    index.setflags(write=False)
    return index


@lru_cache(maxsize=64)
def _size_from_packed(m: int) -> int:
    n = int(round((np.sqrt(8 * m + 1) - 1) / 2))
    if packed_size(n) != m:
        raise ValueError(f"{m} is not a packed symmetric size n(n+1)/2")
    return n


def pack_sym(P: npt.ArrayLike) -> Array:
    """Pack symmetric matrices (their lower triangle, row by row).

    Parameters
    ----------
    P : array_like, shape (..., n, n)
        Symmetric matrices. Only the lower triangle is read.

    Returns
    -------
    ndarray, shape (..., n (n + 1) / 2)
    """
    P = np.asarray(P, dtype=float)
    rows, cols = _tril(P.shape[-1])
    return P[..., rows, cols]


def unpack_sym(p: npt.ArrayLike) -> Array:
    """Unpack packed symmetric matrices.

    Parameters
    ----------
    p : array_like, shape (..., n (n + 1) / 2)

    Returns
    -------
    ndarray, shape (..., n, n)
        Exactly symmetric matrices.
    """
    p = np.asarray(p, dtype=float)
    return p[..., _unpacked_positions(_size_from_packed(p.shape[-1]))]


def pack_sym_sx(P: ca.SX) -> ca.SX:
    """Symbolic :func:`pack_sym` of an ``(n, n)`` SX matrix (lower triangle read)."""
    rows, cols = _tril(P.shape[0])
    return ca.vertcat(*[P[int(i), int(j)] for i, j in zip(rows, cols)])


def unpack_sym_sx(p: ca.SX, n: int) -> ca.SX:
    """Symbolic :func:`unpack_sym`: an ``(n, n)`` symmetric SX from a packed vector."""
    rows, cols = _tril(n)
    P = ca.SX.zeros(n, n)
    for k, (i, j) in enumerate(zip(rows, cols)):
        P[int(i), int(j)] = p[k]
        P[int(j), int(i)] = p[k]
    return P


def to_casadi(a: npt.ArrayLike) -> ca.DM:
    """NumPy → CasADi: ``(N, k)`` time-first array → ``(k, N)`` DM; ``(k,)`` → ``(k, 1)``."""
    a = np.asarray(a, dtype=float)
    if a.ndim == 1:
        return ca.DM(a)
    return ca.DM(np.ascontiguousarray(a.T))


def to_numpy(m: ca.DM, *, columns: bool = True) -> Array:
    """CasADi → NumPy: ``(k, N)`` DM → ``(N, k)`` array (``columns=True``), else ``(k, N)``.

    A ``(k, 1)`` DM becomes a ``(k,)`` vector when ``columns`` is true.
    """
    a = np.array(m.full(), dtype=float)
    if not columns:
        return a
    if a.shape[1] == 1:
        return a[:, 0]
    return np.ascontiguousarray(a.T)
