"""Helpers of the ekf tests: linear models as CdModels, and the documented discretization
written out independently of the engine (from the equations in ``ekf/step.py``'s
docstring, with NumPy matrices)."""
from __future__ import annotations

from dataclasses import dataclass
from math import factorial

import casadi as ca
import numpy as np
import pytest

from ekf.layout import StateLayout
from ekf.model import CdModel

#: Order of the RK4 Taylor polynomial that RK4 reproduces exactly on linear systems.
RK4_ORDER = 4


@dataclass(frozen=True)
class LinearSystem:
    """``ẋ = A x + G w``, ``z_c = H x + D w + v_c``; spectral densities ``q_c``, ``r_c``."""

    A: np.ndarray
    G: np.ndarray
    H: np.ndarray | None = None
    D: np.ndarray | None = None

    def model(self, name: str = "lin") -> CdModel:
        n = self.A.shape[0]
        layout = StateLayout.from_blocks([("x", n)])
        x, u, p = ca.SX.sym("x", n), ca.SX.sym("u", 0), ca.SX.sym("p", 0)
        h = None if self.H is None else ca.mtimes(ca.DM(self.H), x)
        D = None if self.D is None else ca.DM(self.D)
        return CdModel.from_expressions(layout, x, u, p, ca.mtimes(ca.DM(self.A), x), h_c=h,
                                        G=ca.DM(self.G), D=D, name=name)

    def discrete(self, dt: float, q_c: np.ndarray, r_c: np.ndarray | None = None) -> dict:
        """Φ (RK4 = 4th-order Taylor of expm), Q, and for a continuous measurement the
        sampled R and cross-covariance M, as documented in ekf/step.py."""
        n = self.A.shape[0]
        Phi = sum(np.linalg.matrix_power(self.A * dt, j) / factorial(j)
                  for j in range(RK4_ORDER + 1))
        G_bar = 0.5 * (np.eye(n) + Phi) @ self.G
        Qc = np.diag(q_c)
        out = {"Phi": Phi, "Q": G_bar @ Qc @ G_bar.T * dt}
        if self.H is not None:
            Rc = np.zeros((self.H.shape[0],) * 2) if r_c is None else np.diag(r_c)
            out["R"] = (self.D @ Qc @ self.D.T + Rc) / dt
            out["M"] = G_bar @ Qc @ self.D.T
        return out


@pytest.fixture
def linear_system() -> type[LinearSystem]:
    """The :class:`LinearSystem` class (tests build their own systems with it)."""
    return LinearSystem


@pytest.fixture
def tracking_system() -> LinearSystem:
    """A damped oscillator with a rate-like continuous measurement whose noise shares
    the process noise (correlated) — 2 states, 2 noise inputs."""
    A = np.array([[0.0, 1.0], [-0.5, -0.2]])
    G = np.array([[0.0, 0.0], [1.0, 0.3]])
    H = np.array([[0.4, 1.0]])
    D = np.array([[0.8, 0.5]])
    return LinearSystem(A=A, G=G, H=H, D=D)
