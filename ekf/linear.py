"""Linear discrete-time Kalman filtering as a special case of the engine.

A linear KF is :func:`predict_linear` followed by :func:`ekf.update.kalman_update` — the
same update the EKF uses, so the Kalman equations exist once. :class:`LinearModel` bundles
the matrices of one model ``x_{k+1} = Φ x_k + B u_k + w_k``, ``z_k = H x_k + v_k`` and is
what :class:`ekf.bank.ModelBank` runs for each hypothesis of a linear problem.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import numpy.typing as npt

from ekf.errors import ModelError
from ekf.gating import Gate
from ekf.update import UpdateRecord, kalman_update

__all__ = ["LinearModel", "predict_linear"]

Array = npt.NDArray[np.float64]


def predict_linear(x: Array, P: Array, Phi: Array, Q: Array,
                   Bu: Array | None = None) -> tuple[Array, Array]:
    """Prediction ``x⁺ = Φ x + B u``, ``P⁺ = Φ P Φᵀ + Q`` (symmetrized).

    Parameters
    ----------
    x : ndarray, shape (n,)
    P : ndarray, shape (n, n)
    Phi : ndarray, shape (n, n)
    Q : ndarray, shape (n, n)
        Discrete process-noise covariance.
    Bu : ndarray, shape (n,), optional
        Known input term ``B u``.
    """
    x_next = Phi @ x if Bu is None else Phi @ x + Bu
    P_next = Phi @ P @ Phi.T + Q
    return x_next, 0.5 * (P_next + P_next.T)


@dataclass(frozen=True, eq=False)
class LinearModel:
    """One linear-Gaussian model ``(Φ, Q, H, R)``.

    Attributes
    ----------
    Phi, Q : ndarray, shape (n, n)
    H : ndarray, shape (m, n)
    R : ndarray, shape (m, m)
    gate : Gate or None
        Optional gate of its updates.
    """

    Phi: Array
    Q: Array
    H: Array
    R: Array
    gate: Gate | None = None

    def __post_init__(self) -> None:
        n = np.shape(self.Phi)[0]
        m = np.shape(self.H)[0]
        shapes = {"Phi": (n, n), "Q": (n, n), "H": (m, n), "R": (m, m)}
        for name, shape in shapes.items():
            value = np.asarray(getattr(self, name), dtype=float)
            if value.shape != shape:
                raise ModelError(f"LinearModel.{name} has shape {value.shape}, expected {shape}")
            object.__setattr__(self, name, value)

    def predict(self, x: Array, P: Array, Bu: Array | None = None) -> tuple[Array, Array]:
        """:func:`predict_linear` with this model's ``Φ, Q``."""
        return predict_linear(x, P, self.Phi, self.Q, Bu)

    def update(self, x: Array, P: Array, z: Array) -> tuple[Array, Array, UpdateRecord]:
        """:func:`~ekf.update.kalman_update` of ``z (m,)`` with this model's ``H, R``."""
        return kalman_update(x, P, np.asarray(z, dtype=float) - self.H @ x, self.H, self.R,
                             gate=self.gate)
