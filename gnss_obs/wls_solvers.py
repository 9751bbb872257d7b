r"""The linear solves of `gnss_obs.raim`'s weighted least squares.

A problem ``z ≈ H dx`` with independent errors of std σ (shapes (n, k), (n,), (n,)) is
solved at weights ``w`` (the measurements' σ scaled to ``σ/√w``: `gnss_obs.raim.huber_wls`
reweights it; ``w = 1`` for `gnss_obs.raim.wls_step`), and gives what `gnss_obs.raim`
builds its `gnss_obs.raim.WlsStep` from: the whitened design ``A = H √w/σ``, the
covariance ``(AᵀA)⁻¹``, the gain ``(AᵀA)⁻¹Aᵀ``, ``dx`` and the whitened post-fit residuals.
Two methods, equal to round-off (``tests/gnss_obs/test_wls_solvers.py``), chosen by
`wls_problem` from the number of unknowns:

* `CholeskyWls`, any k (the single-point solution's position or velocity with its clock
  columns, k ≥ 4): whitens ``H`` and ``z`` by ``σ/√w`` and inverts ``AᵀA`` by LAPACK's
  Cholesky factor (`cholesky_inverse`), the bits `gnss_obs.raim` has always given;
* `ClosedFormWls`, k ≤ `CLOSED_FORM_MAX_UNKNOWNS` (the divergence monitor's fix on the
  track, ``s`` and one or two clock offsets, `railnav.navigation.snapshot`, once an epoch:
  on paper2017 one Huber iteration at 63 % of the epochs, 6-11 at the rest): ``B = [H z]/σ``
  is formed once, and each weight's normal matrix and right-hand side are one product
  ``wᵀ P`` with the rows' outer products ``P`` (formed at the first reweighting), inverted
  by its adjugate in Python floats, the singular case told by the leading minors
  (Sylvester's criterion, the test Cholesky makes). An iteration makes half the NumPy
  calls and no LAPACK call: the snapshot's exclusion 62.7 → 46.8 µs a call on its 909
  problems of paper2017 (with `gnss_obs.raim.WlsStep`'s lazy leverages), one iteration
  26 → 23 µs, 8-11 iterations 111-149 → 81-104 µs. The cost left is NumPy's per call
  (~0.5-1 µs, ~2x that inside a filter run), not the algebra.

The two differ by round-off (dx, cov: ≤ c κ(AᵀA) ε). Where two rows tie for the largest
standardized residual (a system of two satellites with its own clock column: their two
are equal and opposite), which one the exclusion drops is round-off's choice in either.
"""
from __future__ import annotations

import math
from functools import lru_cache

import numpy as np
import numpy.typing as npt
from scipy import linalg

__all__ = ["CLOSED_FORM_MAX_UNKNOWNS", "ClosedFormWls", "CholeskyWls", "cholesky_inverse",
           "closed_form_solve", "wls_problem"]

Array = npt.NDArray[np.float64]
#: `wls_problem` solves problems of at most this many unknowns in closed form.
CLOSED_FORM_MAX_UNKNOWNS = 3
#: ``(A, cov, gain, dx, whitened residuals)`` of one solution (module docstring).
Core = tuple[Array, Array, Array, Array, Array]

#: LAPACK's Cholesky factorization and solve of float64 matrices, the routines
#: `scipy.linalg.cho_factor` and `scipy.linalg.cho_solve` call.
_POTRF, _POTRS = linalg.get_lapack_funcs(("potrf", "potrs"), (np.empty((1, 1)),))


def cholesky_inverse(normal: Array) -> Array:
    """``normal⁻¹`` of a symmetric positive-definite (k, k) matrix by Cholesky.

    The LAPACK calls of ``cho_solve(cho_factor(normal), eye(k))`` made directly, with the
    same arguments (upper factor, inputs not overwritten), so the same bits; without
    SciPy's batch and argument handling, ~20x its cost on the 4x4 to 5x5 matrices of a
    single-epoch solution.

    Raises
    ------
    numpy.linalg.LinAlgError
        If `normal` is not positive definite (a singular geometry).
    ValueError
        If it has a NaN or infinity (as `scipy.linalg.cho_factor`).
    """
    if np.count_nonzero(np.isfinite(normal)) != normal.size:   # .all(), cheaper
        raise ValueError("array must not contain infs or NaNs")
    chol, info = _POTRF(normal, lower=False, overwrite_a=False, clean=False)
    if info > 0:
        raise linalg.LinAlgError(f"{info}-th leading minor of the array is not positive "
                                 "definite")
    if info < 0:
        raise ValueError(f"LAPACK reported an illegal value in {-info}-th argument on entry "
                         "to POTRF")
    cov, info = _POTRS(chol, _identity(normal.shape[0]), lower=False, overwrite_b=False)
    if info != 0:
        raise ValueError(f"illegal value in {-info}th argument of internal potrs")
    return cov


@lru_cache(maxsize=16)
def _identity(k: int) -> Array:
    """The (k, k) identity, read only (`cholesky_inverse` solves against it)."""
    eye = np.eye(k)
    eye.flags.writeable = False
    return eye


def closed_form_solve(gram: list[float], k: int) -> tuple[list[list[float]], list[float]]:
    """``N⁻¹`` and ``N⁻¹ b`` of a symmetric positive-definite k×k matrix ``N``, k = 1, 2 or
    3, by its adjugate, from ``gram``: the (k+1)×(k+1) matrix ``[[N, b], [bᵀ, ·]]`` row by
    row, Python floats (the upper triangle of ``N`` is read); where the determinant is not
    finite (a NaN or infinity in ``N``, or an overflow), `cholesky_inverse`'s ``N⁻¹``.

    Raises
    ------
    numpy.linalg.LinAlgError
        Where a leading principal minor of ``N`` is not > 0 (not positive definite:
        Cholesky's test, in exact arithmetic).
    ValueError
        If an entry of ``N`` is a NaN or infinity (`cholesky_inverse`).
    """
    if k == 1:
        a, p = gram[0], gram[1]
        minors = det = a
        adjugate = [[1.0]]
        rhs = [p]
    elif k == 2:
        a, b, p, c, q = gram[0], gram[1], gram[2], gram[4], gram[5]
        det = a * c - b * b
        minors = min(a, det)
        adjugate = [[c, -b], [-b, a]]
        rhs = [p, q]
    elif k == 3:
        (a, b, c, p), (d, e, q), (f, t) = gram[0:4], gram[5:8], gram[10:12]
        c00, c01, c02 = d * f - e * e, c * e - b * f, b * e - c * d
        c11, c12, c22 = a * f - c * c, b * c - a * e, a * d - b * b
        det = a * c00 + b * c01 + c * c02
        minors = min(a, c22, det)
        adjugate = [[c00, c01, c02], [c01, c11, c12], [c02, c12, c22]]
        rhs = [p, q, t]
    else:
        raise ValueError(f"closed form for 1 to 3 unknowns, got {k}")
    if not math.isfinite(det):
        full = np.array(gram, dtype=float).reshape(k + 1, k + 1)[:k, :k]
        inverse = cholesky_inverse(np.triu(full) + np.triu(full, 1).T).tolist()
    elif not minors > 0.0:
        raise linalg.LinAlgError("a leading minor of the normal matrix is not positive")
    else:
        inverse = [[v / det for v in row] for row in adjugate]
    return inverse, [sum([g * r for g, r in zip(row, rhs)]) for row in inverse]


class CholeskyWls:
    """A weighted least-squares problem solved by whitening and Cholesky (module
    docstring): `residuals` at each weight, `solution` at the last."""

    def __init__(self, H: Array, z: Array, sigma: Array) -> None:
        self.H, self.z, self.sigma = H, z, sigma
        self._core: Core | None = None

    def _sigma(self, weight: Array | None) -> Array:
        """``σ/√w`` (σ itself for unit weights, None)."""
        return self.sigma if weight is None else self.sigma / np.sqrt(weight)

    def residuals(self, weight: Array | None) -> Array:
        """``|z − H dx|/σ`` of the solution at `weight` (None: 1), kept for `solution`."""
        sigma_w = self._sigma(weight)
        self._core = core = _whitened_core(self.H, self.z, sigma_w)
        return np.abs(core[4] * sigma_w / self.sigma)

    def solution(self, weight: Array | None, *, again: bool = True) -> tuple[Array, Core]:
        """``σ/√w`` and the solution at `weight`: solved again, or (not `again`) the
        last `residuals`' (of the same weights)."""
        sigma_w = self._sigma(weight)
        if again or self._core is None:
            return sigma_w, _whitened_core(self.H, self.z, sigma_w)
        return sigma_w, self._core


def _whitened_core(H: Array, z: Array, sigma: Array) -> Core:
    """``A = H/σ``, the covariance, the gain, ``dx`` and the whitened post-fit residuals
    (float arrays in)."""
    A = H / sigma[:, None]
    y = z / sigma
    cov = cholesky_inverse(A.T @ A)  # raises LinAlgError when singular
    gain = cov @ A.T
    dx = gain @ y
    return A, cov, gain, dx, y - A @ dx


class ClosedFormWls:
    """A weighted least-squares problem of 1 to 3 unknowns solved in closed form (module
    docstring), with `CholeskyWls`'s methods."""

    def __init__(self, H: Array, z: Array, sigma: Array) -> None:
        self.k = H.shape[1]
        if z.size < self.k:                   # rank < k: singular, whatever the rounding
            raise linalg.LinAlgError(f"{z.size} rows for {self.k} unknowns")
        self.B = np.concatenate((H, z[:, None]), axis=1) / sigma[:, None]     # [H z]/σ
        self.sigma = sigma
        self._products: Array | None = None
        self._solved: tuple | None = None

    def residuals(self, weight: Array | None) -> Array:
        """``|z − H dx|/σ`` of the solution at `weight` (None: 1), kept for `solution`."""
        B = self.B
        # Bᵀ diag(w) B, row by row: the normal matrix and the right-hand side (column k)
        if weight is None:
            gram = B.T.dot(B).ravel().tolist()
        else:
            if self._products is None:        # the rows' outer products, (n, (k+1)²)
                self._products = (B[:, :, None] * B[:, None, :]).reshape(B.shape[0], -1)
            gram = weight.dot(self._products).tolist()
        inverse, dx = closed_form_solve(gram, self.k)
        residual = B.dot(np.array([-d for d in dx] + [1.0]))            # (z − H dx)/σ
        self._solved = weight, inverse, dx, residual
        return np.abs(residual)

    def solution(self, weight: Array | None, *, again: bool = True) -> tuple[Array, Core]:
        """As `CholeskyWls.solution`."""
        if again or self._solved is None:
            self.residuals(weight)
        solved_at, inverse, dx, residual = self._solved
        A = self.B[:, :self.k]
        sigma_w = self.sigma
        if solved_at is not None:             # (unit weights, as solved: σ as it is)
            root = np.sqrt(weight)
            A, residual, sigma_w = A * root[:, None], residual * root, sigma_w / root
        cov = np.array(inverse)
        return sigma_w, (A, cov, cov.dot(A.T), np.array(dx), residual)


def wls_problem(H: Array, z: Array, sigma: Array) -> CholeskyWls | ClosedFormWls:
    """The problem ``z ≈ H dx`` (float arrays) in closed form where it has at most
    `CLOSED_FORM_MAX_UNKNOWNS` unknowns, else by Cholesky."""
    if 1 <= H.shape[1] <= CLOSED_FORM_MAX_UNKNOWNS:
        return ClosedFormWls(H, z, sigma)
    return CholeskyWls(H, z, sigma)
