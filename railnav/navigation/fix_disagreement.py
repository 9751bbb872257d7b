"""How far a position fix is from hypotheses' track points, in its own and their σ.

The spawn test's statistic (`railnav.navigation.spawning`; a start's candidates',
`railnav.navigation.network_start`): for each hypothesis ``h`` the horizontal disagreement
of the fix with the track point at its ``s``,

``d_h² = eᵀ (Σ_fix + σ_s² t tᵀ + σ_c² c cᵀ)⁻¹ e``

(``e`` the fix minus the track point in east/north, ``t`` and ``c`` the track's horizontal
tangent and normal there, ``σ_s`` the hypothesis's along-track σ, ``σ_c`` the map's
across, `railnav.filters.fix_epochs.FixModelConfig.track_cross_sigma_m`): χ²₂ when the
hypothesis is the truth with right σ. Heights of fixes and map differ: only the
horizontal offset counts.
"""
from __future__ import annotations

import numpy as np
import numpy.typing as npt

from trackmodel.earth import C_n_e, geodetic_to_ecef

__all__ = ["fix_disagreement", "fix_frames"]

Array = npt.NDArray[np.float64]


def fix_disagreement(r_e: Array, tangent_e: Array, sigma_s_m: Array, fixes, k: int,
                     cross_sigma_m: float, frame: tuple[Array, Array] | None = None) -> Array:
    """``d_h²`` of fix `k` against each hypothesis's track point (module docstring),
    shape (K,).

    Parameters
    ----------
    r_e, tangent_e : ndarray, shape (K, 3)
        ECEF position (m) and unit tangent of each hypothesis's track point.
    sigma_s_m : ndarray, shape (K,)
        σ of each hypothesis's ``s``, m.
    fixes : railnav.filters.fix_epochs.FixEpochs
        (``lat``, ``lon`` in rad, ``cov_n_m2`` ENU covariances.)
    k : int
        The fix.
    cross_sigma_m : float
        σ of the track's centre-line across, m.
    frame : (ndarray (3,), ndarray (3, 3)), optional
        The fix's ECEF position at zero height and its ECEF-to-ENU rotation
        (`fix_frames`; computed when not given).
    """
    if frame is None:
        lat, lon = float(fixes.lat[k]), float(fixes.lon[k])
        frame = (np.asarray(geodetic_to_ecef(lat, lon, 0.0), dtype=float).reshape(3),
                 C_n_e(lat, lon).T)
    r_fix, C_e_n = frame
    # only the horizontal (east, north) offset counts: heights of fixes and map differ
    e = ((r_fix[None, :] - np.atleast_2d(r_e)) @ C_e_n[:2].T)        # (K, 2)
    t = np.atleast_2d(tangent_e) @ C_e_n[:2].T
    t = t / np.maximum(np.hypot(t[:, 0], t[:, 1]), 1e-12)[:, None]
    along, cross = e[:, 0] * t[:, 0] + e[:, 1] * t[:, 1], e[:, 1] * t[:, 0] - e[:, 0] * t[:, 1]
    (f00, f01), (f10, f11) = np.asarray(fixes.cov_n_m2[k], dtype=float)[:2, :2].tolist()
    # the covariance on the track's axes (along t, across c = (-t_n, t_e)): 2×2 in closed
    # form, tᵀF t, cᵀF c and tᵀF c elementwise
    t0, t1 = t[:, 0], t[:, 1]
    tf0, tf1 = t0 * f00 + t1 * f10, t0 * f01 + t1 * f11
    cf0, cf1 = t0 * f10 - t1 * f00, t0 * f11 - t1 * f01
    f_aa, f_cc, f_ac = tf0 * t0 + tf1 * t1, cf1 * t0 - cf0 * t1, tf1 * t0 - tf0 * t1
    a = f_aa + np.asarray(sigma_s_m, dtype=float) ** 2
    b = f_cc + cross_sigma_m ** 2
    det = a * b - f_ac ** 2
    return (b * along ** 2 - 2.0 * f_ac * along * cross + a * cross ** 2) / det


def fix_frames(fixes) -> tuple[Array, Array]:
    """Every fix's ECEF position at zero height (N, 3) and ECEF-to-ENU rotation (N, 3, 3)."""
    lat, lon = np.asarray(fixes.lat, dtype=float), np.asarray(fixes.lon, dtype=float)
    r = np.asarray(geodetic_to_ecef(lat, lon, np.zeros_like(lat)), dtype=float).reshape(-1, 3)
    return r, np.swapaxes(C_n_e(lat, lon).reshape(-1, 3, 3), 1, 2)
