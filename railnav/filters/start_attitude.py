r"""The attitude a track-constrained filter starts with at a fix, and its covariance with ``s``.

A filter started from a fix (`railnav.filters.constrained.ConstrainedFilter.initial_from_fix`:
a run's start from its first fixes, the monitor's restart when lost, a network's candidates)
takes its attitude from the track at the fix's projection ``ŝ``: yaw = A(ŝ), pitch = ϑ(ŝ),
roll = 0. The vehicle is at ``s = ŝ − e_s``, with ``e_s`` the projection's along-track error
(σ_s), so the attitude it takes is off by

``e_yaw = A(ŝ) − A(s) ≈ A′ e_s``,  ``e_pitch = ϑ(ŝ) − ϑ(s) ≈ ϑ′ e_s``

(``A′`` = `trackmodel.track.TrackPoint.curvature_1pm`, ``ϑ′`` = ``elevation_rate``), on top of
the body's own offset from the track, which the configured attitude σ describes and which is
independent of ``e_s``. With ``g`` the vector with 1 at ``s``, ``A′`` at yaw and ``ϑ′`` at
pitch, the start covariance is

``P₀ = D + σ_s² (g gᵀ − e_s e_sᵀ)``

(``D`` the diagonal of configured variances, σ_s² at ``s``): the yaw and pitch variances grow
by ``A′² σ_s²`` and ``ϑ′² σ_s²`` and they covary with ``s``. A diagonal ``P₀`` leaves this
out. On R = 100 m with σ_s = 1 m it is 10 mrad of yaw fully correlated with ``s``: the first
rows after a restart on such a curve then read the yaw error as an ``s`` error against a
prior that claims the two independent, and the posterior is overconfident
(`tests/railnav/filters/test_start_attitude.py`, the 100 m/s ring). On a straight and level
track ``P₀ = D``.
"""
from __future__ import annotations

import numpy as np
import numpy.typing as npt

__all__ = ["track_attitude", "with_track_attitude_covariance"]

Array = npt.NDArray[np.float64]


def track_attitude(point) -> dict[str, float]:
    """Yaw, pitch and roll of a body aligned with the track at `point`, rad (yaw = azimuth,
    pitch = elevation, roll = 0)."""
    return {"yaw": float(point.azimuth), "pitch": float(point.elevation), "roll": 0.0}


def with_track_attitude_covariance(P: Array, names: tuple[str, ...], point,
                                   sigma_s_m: float) -> Array:
    """`P` with the attitude's error from the start's along-track error (module docstring).

    Parameters
    ----------
    P : ndarray, shape (n, n)
        Start covariance without it (σ_s² at ``s``, the configured attitude variances).
    names : tuple of str
        State names of `P`'s rows (``s``, and ``yaw``/``pitch`` where estimated).
    point : trackmodel.track.TrackPoint
        The track at the start's ``s`` (scalar fields).
    sigma_s_m : float
        σ of the start's ``s``, m.

    Returns
    -------
    ndarray, shape (n, n)
        A new array.
    """
    rates = {"yaw": float(point.curvature_1pm), "pitch": float(point.elevation_rate)}
    g = np.zeros(len(names))
    for name, rate in rates.items():
        if name in names:
            g[names.index(name)] = rate
    out = np.array(P, dtype=float)
    i_s = names.index("s")
    out += sigma_s_m ** 2 * (np.outer(g, g))
    out[i_s, :] += sigma_s_m ** 2 * g
    out[:, i_s] += sigma_s_m ** 2 * g
    return out
