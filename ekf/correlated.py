"""One step of a linear filter whose measurement noise is correlated with the process noise.

The model of one step is

``x_{k+1} = Φ x_k + B u_k + w_k``,  ``y_k = H x_k + v_k``,
``E[w wᵀ] = Q``,  ``E[v vᵀ] = R``,  ``E[w vᵀ] = M``,

where the measurement ``y_k`` is written as a function of the state at the *start* of the
step. This is the form measurement differencing produces for a measurement with
first-order Gauss–Markov (coloured) noise ``u_{k+1} = φ u_k + n_k``: the differenced
measurement ``z_{k+1} − φ z_k = (H Φ − φ H) x_k + H B u_k + H w_k + n_k`` depends on
``x_k`` and its noise contains the process noise ``H w_k`` (Bryson & Henrikson, "Estimation
using sampled data containing sequentially correlated noise", J. Spacecraft 5(6), 1968;
Gelb, *Applied Optimal Estimation*, 1974, §4.5; Simon, *Optimal State Estimation*, 2006,
§7.1–7.2).

:func:`correlated_step` is exact for this model and writes no Kalman equations of its own:

1. ``x_k`` is updated with ``y_k`` by :func:`ekf.update.kalman_update` (``H``, ``R``);
2. the process equation is decorrelated by adding ``D (y_k − H x_k − v_k) = 0`` with
   ``D = M R⁻¹``: ``x_{k+1} = (Φ − D H) x_k + B u_k + D y_k + (w_k − D v_k)``, whose noise
   is uncorrelated with ``v_k`` and has covariance ``Q − D Mᵀ``;
3. that model is predicted by :func:`ekf.linear.predict_linear`.

The result equals the one-step-predictor form ``K = (Φ P Hᵀ + M)(H P Hᵀ + R)⁻¹``,
``x_{k+1} = Φ x + B u + K ν``, ``P_{k+1} = Φ P Φᵀ + Q − K (Φ P Hᵀ + M)ᵀ``.
"""
from __future__ import annotations

import numpy as np
import numpy.typing as npt
import scipy.linalg as sla

from ekf.errors import ModelError
from ekf.gating import Gate
from ekf.linear import predict_linear
from ekf.update import UpdateRecord, kalman_update

__all__ = ["correlated_step"]

Array = npt.NDArray[np.float64]


def correlated_step(x: Array, P: Array, innov: Array, H: Array, R: Array, *,
                    Phi: Array, Q: Array, M: Array, Bu: Array | None = None,
                    gate: Gate | None = None, groups: Array | None = None
                    ) -> tuple[Array, Array, UpdateRecord]:
    """Filter step ``(x_k, P_k) → (x_{k+1}, P_{k+1})`` with a measurement of ``x_k`` whose
    noise is correlated with the process noise of the step.

    Parameters
    ----------
    x : ndarray, shape (n,)
        Estimate of ``x_k`` given the measurements before ``y_k``.
    P : ndarray, shape (n, n)
        Its covariance.
    innov : ndarray, shape (m,)
        ``y_k − ŷ_k`` with ``ŷ_k = H x`` plus any known offset of the measurement.
    H : ndarray, shape (m, n)
        Measurement matrix with respect to ``x_k``.
    R : ndarray, shape (m, m)
        Measurement-noise covariance ``E[v vᵀ]`` (SPD).
    Phi : ndarray, shape (n, n)
        Transition ``Φ``.
    Q : ndarray, shape (n, n)
        Process-noise covariance ``E[w wᵀ]``.
    M : ndarray, shape (n, m)
        Cross-covariance ``E[w vᵀ]``.
    Bu : ndarray, shape (n,), optional
        Known input term ``B u_k``.
    gate, groups
        Passed to :func:`~ekf.update.kalman_update`; rejected components are neither
        used in the update nor in the decorrelation.

    Returns
    -------
    x_next : ndarray, shape (n,)
        Estimate of ``x_{k+1}`` given the measurements up to and including ``y_k``.
    P_next : ndarray, shape (n, n)
    record : UpdateRecord
        Innovation statistics of ``y_k`` (``S = H P Hᵀ + R``).

    Raises
    ------
    ModelError
        Inconsistent shapes.
    FilterDivergedError
        ``S`` not positive definite.
    """
    n, m = x.size, innov.size
    if H.shape != (m, n) or R.shape != (m, m) or M.shape != (n, m) \
            or Phi.shape != (n, n) or Q.shape != (n, n):
        raise ModelError(f"correlated_step: shapes H {H.shape}, R {R.shape}, M {M.shape}, "
                         f"Phi {Phi.shape}, Q {Q.shape} do not fit n={n}, m={m}")
    x_post, P_post, record = kalman_update(x, P, innov, H, R, gate=gate, groups=groups)
    used = record.accepted
    Bu_total = np.zeros(n) if Bu is None else np.asarray(Bu, dtype=float)
    if not used.any():
        x_next, P_next = predict_linear(x_post, P_post, Phi, Q, Bu_total)
        return x_next, P_next, record
    M_u, H_u = M[:, used], H[used]
    D = sla.cho_solve(sla.cho_factor(R[np.ix_(used, used)], lower=True), M_u.T).T
    measured = innov[used] + H_u @ x          # y_k minus its known offset
    x_next, P_next = predict_linear(x_post, P_post, Phi - D @ H_u, Q - D @ M_u.T,
                                    Bu_total + D @ measured)
    return x_next, P_next, record
