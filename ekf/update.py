"""The discrete measurement update (paper 2017 eq. 16): Joseph form, Cholesky, gating.

:func:`kalman_update` is THE Kalman update of the engine (linear filters, the EKF's
discrete updates and the model bank all call it): given a prior ``x, P``, an innovation
``ν = z − h(x)``, its Jacobian ``H`` and noise ``R``,

``S = H P Hᵀ + R``, ``K = P Hᵀ S⁻¹`` (Cholesky solves, no inverse),
``x⁺ = x + K ν``, ``P⁺ = (I − K H) P (I − K H)ᵀ + K R Kᵀ`` (Joseph form).

Rejected components (:class:`~ekf.gating.Gate`) are left out. With ``sequential=True``
and a diagonal ``R`` the components are processed one scalar at a time (innovation
re-linearized as ``ν_i − H_i (x_cur − x)``), each gated on its own.

:func:`discrete_update` evaluates :class:`~ekf.model.MeasurementModel` rows and stacks
several :class:`Observation` s into one update; given :class:`EvaluatedObservations` (the
observations with their rows already evaluated and stacked at the same prior, e.g. by a
fault screen) it uses those instead of evaluating again.

The LAPACK calls are made directly (`_cho_factor`, `_solve_lower`, `_cho_solve`), exactly as
``scipy.linalg.cho_factor`` / ``solve_triangular`` / ``cho_solve`` make them (same routine,
same arguments: the same bits), without SciPy's per-call batch wrapper (~30 µs a call, three
calls an epoch).
"""
from __future__ import annotations

from dataclasses import dataclass, field
from functools import lru_cache
from typing import Sequence

import numpy as np
import numpy.typing as npt
import scipy.linalg as sla
from scipy.linalg import lapack

from ekf.errors import FilterDivergedError, ModelError
from ekf.gating import Gate
from ekf.model import MeasurementModel

__all__ = ["Observation", "EvaluatedObservations", "UpdateRecord", "kalman_update",
           "discrete_update", "LOG_2PI"]

Array = npt.NDArray[np.float64]

#: ln(2π), for Gaussian log-likelihoods.
LOG_2PI = float(np.log(2.0 * np.pi))


@dataclass(frozen=True, eq=False)
class Observation:
    """``m`` rows of one measurement model at one epoch.

    Attributes
    ----------
    model : MeasurementModel
    z : ndarray, shape (m, k)
        Measured values.
    R : ndarray, shape (m * k,) or (m * k, m * k)
        Noise variances (diagonal) or covariance, in ``z`` units squared.
    p : ndarray, shape (m, n_p)
        Row parameters (e.g. satellite positions).
    """

    model: MeasurementModel
    z: Array
    R: Array
    p: Array = field(default_factory=lambda: np.zeros((0, 0)))

    def __post_init__(self) -> None:
        k = self.model.k
        z = np.asarray(self.z, dtype=float).reshape(-1, k)
        p = np.asarray(self.p, dtype=float).reshape(z.shape[0], self.model.n_p)
        R = np.asarray(self.R, dtype=float)
        if R.shape not in ((z.size,), (z.size, z.size)):
            raise ModelError(f"{self.model.name}: R has shape {R.shape}, expected "
                             f"({z.size},) or ({z.size}, {z.size})")
        # each finite (np.isfinite(a).all(); a count of a bool array is cheaper)
        if not all(np.count_nonzero(np.isfinite(a)) == a.size for a in (z, R, p)):
            raise ModelError(f"{self.model.name}: non-finite z, R or p")
        for name, value in (("z", z), ("p", p), ("R", R)):
            object.__setattr__(self, name, value)

    @property
    def rows(self) -> int:
        """Number of rows ``m``."""
        return self.z.shape[0]

    def subset(self, keep: npt.NDArray[np.bool_]) -> "Observation":
        """The rows `keep` (mask, shape (m,)) of an observation with diagonal ``R``
        (variances, shape (m * k,)): what ``dataclasses.replace`` with the rows' ``z``,
        ``R`` and ``p`` gives, without checking again the rows of arrays already checked.

        Raises
        ------
        ModelError
            ``R`` is a full covariance.
        """
        if self.R.ndim != 1:
            raise ModelError(f"{self.model.name}: a subset of rows needs diagonal R")
        out = object.__new__(Observation)
        R = self.R.reshape(-1, self.model.k)[keep].reshape(-1)
        for name, value in (("model", self.model), ("z", self.z[keep]), ("R", R),
                            ("p", self.p[keep])):
            object.__setattr__(out, name, value)
        return out


class EvaluatedObservations(list):
    """A list of :class:`Observation` s with their rows evaluated and stacked at a state.

    It is the list it holds for every reader; :func:`discrete_update` at the same state
    takes the stacked rows from it instead of evaluating the models again.

    Parameters
    ----------
    observations : sequence of Observation
    x : ndarray, shape (n,)
        The state the rows were evaluated at.
    innov : ndarray, shape (m,)
        ``z − h(x)`` of all rows, in order.
    H : ndarray, shape (m, n)
    R : ndarray, shape (m,) or (m, m)
        Variances (diagonal) or covariance.
    groups : ndarray of int, shape (m,)
        Row id of each component (as :func:`discrete_update` numbers them).
    """

    def __init__(self, observations, *, x: Array, innov: Array, H: Array, R: Array,
                 groups: Array) -> None:
        super().__init__(observations)
        if innov.shape != (H.shape[0],) or groups.shape != innov.shape:
            raise ModelError(f"evaluated rows: innov {innov.shape}, H {H.shape}, groups "
                             f"{groups.shape} disagree")
        self.x, self.innov, self.H, self.R, self.groups = x, innov, H, R, groups

    def evaluated_at(self, x: Array) -> bool:
        """Whether the rows were evaluated at `x`."""
        return self.x is x or np.array_equal(self.x, x)


@dataclass(frozen=True)
class UpdateRecord:
    """Innovation statistics of one update.

    Attributes
    ----------
    innov : ndarray, shape (m,)
        ``z − h(x_prior)``.
    S : ndarray, shape (m, m)
        Its prior covariance ``H P Hᵀ + R``.
    nis : float
        ``νᵀ S⁻¹ ν`` over all components (NaN for ``m = 0``).
    nis_components : ndarray, shape (m,)
        Per component: sequential ``ν_i²/S_i`` when processed sequentially, else the
        marginal ``ν_i²/S_ii``.
    accepted : ndarray of bool, shape (m,)
    log_likelihood : float
        ``log N(ν; 0, S)`` of the full innovation (for model banks).
    K : ndarray, shape (n, m)
        Gain (zero columns for rejected components; for sequential processing, the
        equivalent batch gain of the accepted components).
    """

    innov: Array
    S: Array
    nis: float
    nis_components: Array
    accepted: Array
    log_likelihood: float
    K: Array


def _cho_factor(S: Array) -> tuple[Array, bool]:
    """``scipy.linalg.cho_factor(S, lower=True, check_finite=False)`` (module docstring)."""
    c, info = lapack.dpotrf(S, lower=True, overwrite_a=False, clean=False)
    if info > 0:
        raise np.linalg.LinAlgError(f"{info}-th leading minor of the array is not positive "
                                    "definite")
    if info < 0:
        raise ValueError(f"LAPACK reported an illegal value in {-info}-th argument of POTRF")
    return c, True


def _solve_lower(L: Array, b: Array) -> Array:
    """``scipy.linalg.solve_triangular(L, b, lower=True, check_finite=False)``."""
    if L.flags.f_contiguous:
        x, info = lapack.dtrtrs(L, b, overwrite_b=False, lower=True, trans=0, unitdiag=False)
    else:   # the transposed system, as SciPy solves it (trtrs expects Fortran order)
        x, info = lapack.dtrtrs(L.T, b, overwrite_b=False, lower=False, trans=1,
                                unitdiag=False)
    if info != 0:
        raise np.linalg.LinAlgError(f"singular matrix: resolution failed at diagonal {info-1}")
    return x


def _solve_lower_transposed(U: Array, b: Array) -> Array:
    """``L x = b`` given ``U = Lᵀ`` (only its upper triangle is read): the call
    `_solve_lower` makes for a C-ordered ``L``."""
    x, info = lapack.dtrtrs(U, b, overwrite_b=False, lower=False, trans=1, unitdiag=False)
    if info != 0:
        raise np.linalg.LinAlgError(f"singular matrix: resolution failed at diagonal {info-1}")
    return x


def _cho_solve(factor: tuple[Array, bool], b: Array) -> Array:
    """``scipy.linalg.cho_solve(factor, b, check_finite=False)``."""
    x, info = lapack.dpotrs(factor[0], b, lower=factor[1], overwrite_b=False)
    if info != 0:
        raise ValueError(f"illegal value in {-info}th argument of internal potrs")
    return x


def _log_likelihood(innov: Array, factor: tuple[Array, bool]) -> tuple[float, float]:
    if factor[1]:
        # the lower factor's transpose, upper triangular in C order: `_solve_lower`'s
        # transposed call reads its upper triangle only (what np.tril(c) would give, without
        # the copy that zeroes the other half)
        c = factor[0]
        white = _solve_lower_transposed(c.T, innov)
        nis = float(white @ white)
        # np.sum(np.log(np.diag(c))): the same reduction, without the wrappers
        log_det = 2.0 * float(np.add.reduce(np.log(c.diagonal())))
        return nis, -0.5 * (nis + log_det + innov.size * LOG_2PI)
    L = np.triu(factor[0]).T
    white = _solve_lower(L, innov)
    nis = float(white @ white)
    log_det = 2.0 * float(np.sum(np.log(np.diag(L))))
    return nis, -0.5 * (nis + log_det + innov.size * LOG_2PI)


def _joseph(P: Array, K: Array, H: Array, R: Array) -> Array:
    """``A P Aᵀ + K R Kᵀ`` with ``A = I − K H``; `R` a covariance or, shape (m,), the
    variances of a diagonal one (``K * R`` is ``K @ diag(R)`` to the bit: the other
    products are exact zeros)."""
    A = _identity(P.shape[0]) - K @ H
    P_post = A @ P @ A.T + ((K * R) if R.ndim == 1 else (K @ R)) @ K.T
    return 0.5 * (P_post + P_post.T)


@lru_cache(maxsize=8)
def _identity(n: int) -> Array:
    """The (n, n) identity, read only (`_joseph`'s ``I − K H``)."""
    eye = np.eye(n)
    eye.flags.writeable = False
    return eye


def _sequential(x: Array, P: Array, innov: Array, H: Array, r: Array,
                gate: Gate | None) -> tuple[Array, Array, Array, Array]:
    x_cur, P_cur = x.copy(), P.copy()
    nis_c = np.zeros(innov.size)
    accepted = np.zeros(innov.size, dtype=bool)
    for i in range(innov.size):
        h = H[i]
        nu = innov[i] - h @ (x_cur - x)
        s = float(h @ P_cur @ h + r[i])
        nis_c[i] = nu * nu / s
        if gate is not None and not gate.passes(np.array([nu]), np.array([[s]]))[0]:
            continue
        accepted[i] = True
        k = P_cur @ h / s
        x_cur = x_cur + k * nu
        P_cur = _joseph(P_cur, k[:, None], h[None, :], np.array([[r[i]]]))
    return x_cur, P_cur, nis_c, accepted


def kalman_update(x: Array, P: Array, innov: Array, H: Array, R: Array, *,
                  gate: Gate | None = None, groups: Array | None = None,
                  sequential: bool = False) -> tuple[Array, Array, UpdateRecord]:
    """Kalman measurement update with innovation statistics.

    Parameters
    ----------
    x : ndarray, shape (n,)
        Prior state.
    P : ndarray, shape (n, n)
        Prior covariance (SPD).
    innov : ndarray, shape (m,)
        ``z − h(x)``.
    H : ndarray, shape (m, n)
    R : ndarray, shape (m,) or (m, m)
        Measurement noise variances (diagonal) or covariance.
    gate : Gate, optional
        No gating when ``None``.
    groups : ndarray of int, shape (m,), optional
        Row id of each component, for ``gate.scope == "rows"``; default: each
        component its own row.
    sequential : bool
        Scalar-by-scalar processing (``R`` must be diagonal).

    Returns
    -------
    x_post : ndarray, shape (n,)
    P_post : ndarray, shape (n, n)
    record : UpdateRecord

    Raises
    ------
    FilterDivergedError
        ``S`` not positive definite.
    """
    m, n = innov.size, x.size
    R_mat = np.diag(R) if R.ndim == 1 else R
    if m == 0:
        return x, P, UpdateRecord(innov, np.zeros((0, 0)), float("nan"), np.zeros(0),
                                  np.zeros(0, dtype=bool), 0.0, np.zeros((n, 0)))
    PHt = P @ H.T
    S = H @ PHt + R_mat
    try:
        factor = _cho_factor(S)
    except np.linalg.LinAlgError as exc:
        raise FilterDivergedError(f"innovation covariance is not positive definite: {exc}") \
            from exc
    nis, log_lik = _log_likelihood(innov, factor)
    if sequential:
        if R.ndim != 1 and np.count_nonzero(R - np.diag(np.diag(R))):
            raise ModelError("sequential processing needs a diagonal R")
        x_post, P_post, nis_c, accepted = _sequential(x, P, innov, H, np.diag(R_mat), gate)
        K = np.zeros((n, m))
        if accepted.any():
            K[:, accepted] = _batch_gain(P, H[accepted], R_mat[np.ix_(accepted, accepted)])
        return x_post, P_post, UpdateRecord(innov, S, nis, nis_c, accepted, log_lik, K)
    groups = np.arange(m) if groups is None else np.asarray(groups)
    accepted = np.ones(m, dtype=bool) if gate is None else gate.accepted_rows(innov, S, groups)
    nis_c = innov ** 2 / S.diagonal()               # (np.diag's view of it)
    K = np.zeros((n, m))
    n_accepted = np.count_nonzero(accepted)      # (all(), any() without their wrappers)
    if n_accepted == m:
        K = _cho_solve(factor, PHt.T).T
    elif n_accepted:
        K[:, accepted] = _batch_gain(P, H[accepted], R_mat[np.ix_(accepted, accepted)])
    x_post = x + K @ innov
    P_post = _joseph(P, K, H, R)
    return x_post, P_post, UpdateRecord(innov, S, nis, nis_c, accepted, log_lik, K)


def _batch_gain(P: Array, H: Array, R: Array) -> Array:
    PHt = P @ H.T
    return _cho_solve(_cho_factor(H @ PHt + R), PHt.T).T


def _diagonal(R: Array) -> bool:
    """``R - diag(diag(R))`` is all zeros: a covariance (2-D) without off-diagonal terms,
    variances (1-D) all finite (a NaN or infinite variance leaves NaN on the diagonal of
    that difference, as it did when 1-D variances were made matrices first)."""
    if R.ndim == 1:
        return bool(np.isfinite(R).all())
    return np.count_nonzero(R - np.diag(np.diag(R))) == 0


def discrete_update(x: Array, P: Array, observations: Sequence[Observation], *,
                    gate: Gate | None = None, sequential: bool = False
                    ) -> tuple[Array, Array, UpdateRecord]:
    """EKF update with several observations stacked (rows in the order given).

    Parameters
    ----------
    x : ndarray, shape (n,)
    P : ndarray, shape (n, n)
    observations : sequence of Observation
        An :class:`EvaluatedObservations` evaluated at `x` is not evaluated again.
    gate : Gate, optional
    sequential : bool

    Returns
    -------
    x_post, P_post, record
        As :func:`kalman_update`; for ``gate.scope == "rows"`` a row is one row of
        one observation.
    """
    if isinstance(observations, EvaluatedObservations) and observations.evaluated_at(x):
        o = observations
        return kalman_update(x, P, o.innov, o.H, o.R, gate=gate, groups=o.groups,
                             sequential=sequential)
    innovs, Hs, Rs, groups = [], [], [], []
    row0 = 0
    for obs in observations:
        z_pred, H = obs.model.evaluate(x, obs.p)
        innovs.append(obs.z.reshape(-1) - z_pred)
        Hs.append(H)
        Rs.append(obs.R)                    # variances (1-D) or a covariance (2-D)
        groups.append(row0 + np.repeat(np.arange(obs.rows), obs.model.k))
        row0 += obs.rows
    if not innovs:
        return kalman_update(x, P, np.zeros(0), np.zeros((0, x.size)), np.zeros(0))
    if all(_diagonal(r) for r in Rs):
        # diagonal: kept as variances (a 1-D R's own numbers: np.diag(np.diag(r)) is r)
        R = np.concatenate([r if r.ndim == 1 else np.diag(r) for r in Rs])
    else:
        R = sla.block_diag(*(np.diag(r) if r.ndim == 1 else r for r in Rs))
    return kalman_update(x, P, np.concatenate(innovs), np.vstack(Hs), R, gate=gate,
                         groups=np.concatenate(groups), sequential=sequential)
