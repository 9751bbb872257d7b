"""Dilution of precision from the satellite geometry (unweighted, local-level axes).

With the geometry matrix ``G = [H_r C_n_e, S]`` (position columns turned to East-North-Up,
clock columns `observables.system_bias_matrix`), ``Q = (GᵀG)⁻¹`` and
``HDOP = sqrt(Q_EE + Q_NN)``, ``VDOP = sqrt(Q_UU)``, ``PDOP = sqrt(HDOP² + VDOP²)``,
``TDOP = sqrt(Q_bb)`` of the reference clock, ``GDOP = sqrt(PDOP² + TDOP²)``
(Misra & Enge, *Global Positioning System*, §6.1.3; each extra system's bias column is
estimated alongside and raises the DOPs accordingly).
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import numpy.typing as npt
from scipy import linalg

from trackmodel.earth import C_n_e

__all__ = ["Dop", "dilution_of_precision"]

Array = npt.NDArray[np.float64]


@dataclass(frozen=True)
class Dop:
    """Dilutions of precision (dimensionless); NaN when the geometry is singular."""

    gdop: float
    pdop: float
    hdop: float
    vdop: float
    tdop: float


_NAN_DOP = Dop(*(float("nan"),) * 5)


def dilution_of_precision(H_r: npt.ArrayLike, S: npt.ArrayLike, *, lat: float,
                          lon: float) -> Dop:
    """DOPs of a set of satellites.

    Parameters
    ----------
    H_r : array_like, shape (n, 3)
        ∂ρ/∂r_e of each satellite (minus the unit line of sight, ECEF).
    S : array_like, shape (n, m)
        Clock columns (first = reference clock).
    lat, lon : float
        Receiver latitude and longitude, rad (the ENU axes).

    Returns
    -------
    Dop
    """
    G = np.hstack([np.asarray(H_r, dtype=float) @ C_n_e(lat, lon), np.asarray(S, dtype=float)])
    if G.shape[0] < G.shape[1]:
        return _NAN_DOP
    try:
        Q = linalg.cho_solve(linalg.cho_factor(G.T @ G), np.eye(G.shape[1]))
    except linalg.LinAlgError:
        return _NAN_DOP
    d = np.diag(Q)
    hdop, vdop, tdop = np.sqrt(d[0] + d[1]), np.sqrt(d[2]), np.sqrt(d[3])
    pdop = np.hypot(hdop, vdop)
    return Dop(gdop=float(np.hypot(pdop, tdop)), pdop=float(pdop), hdop=float(hdop),
               vdop=float(vdop), tdop=float(tdop))
