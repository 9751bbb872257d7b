"""Vertical profile fit: heights along s by a piecewise-linear elevation (vertical curves).

Model: ``h(s) = h0 + ∫₀ˢ sin ϑ(σ) dσ`` with ``ϑ`` piecewise linear and continuous between
knots (constant grades joined by vertical curves: the 3-D tangent is continuous). Fitted
by Gauss–Newton on the height residuals, with a weak penalty on elevation changes between
knots (as for the curvature, `trackmodel.fit_plane`).
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import numpy.typing as npt
from scipy.integrate import cumulative_simpson

from trackmodel.clothoid import heading_basis

__all__ = ["Profile", "fit_profile", "flat_profile"]

Array = npt.NDArray[np.float64]

#: Weight of the elevation-change penalty relative to a height residual.
SMOOTH_WEIGHT = 1e-2
GN_STEPS = 4
#: Fitted elevations are kept within ±0.2 rad (20 % grade: beyond any railway or tramway).
MAX_ELEVATION_RAD = 0.2
GRID_STEP_M = 1.0


@dataclass(frozen=True)
class Profile:
    """A vertical profile: height at the start and elevation at knots.

    Attributes
    ----------
    knots : ndarray, shape (m + 1,)
        Knot positions along s, m.
    h0 : float
        Height at s = 0, m.
    elevation : ndarray, shape (m + 1,)
        Elevation at the knots, rad.
    """

    knots: Array
    h0: float
    elevation: Array

    def elevation_at(self, s: Array) -> Array:
        """``ϑ(s)``, rad (constant beyond the ends)."""
        return np.interp(s, self.knots, self.elevation)

    def height_at(self, s: Array) -> Array:
        """``h(s)``, m, by Simpson's rule on a grid (error far below a millimetre)."""
        s = np.asarray(s, dtype=float)
        hi = max(float(self.knots[-1]), float(s.max(initial=0.0)))
        g = np.linspace(0.0, hi, max(3, int(np.ceil(hi / GRID_STEP_M)) + 1))
        h = self.h0 + cumulative_simpson(np.sin(self.elevation_at(g)), dx=g[1] - g[0], initial=0.0)
        return np.interp(s, g, h)


def flat_profile(length_m: float) -> Profile:
    """h = 0 with elevation 0 (a survey without heights)."""
    return Profile(np.array([0.0, length_m]), 0.0, np.zeros(2))


def fit_profile(s: Array, h: Array, knots: Array, *,
                start: Profile | None = None) -> tuple[Profile, Array, Array]:
    """Fit heights ``h`` (m) at positions ``s`` (m) with elevation knots.

    Returns
    -------
    profile : Profile
    residual_m : ndarray, shape (N,)
        ``h − h(s)``, m.
    elevation : ndarray, shape (m + 1,)
        The knot values (for `trackmodel.knots`).
    """
    B = heading_basis(knots, s)                   # ∫₀ˢ hat_j: d h / d ϑ_j for small ϑ
    A = np.column_stack([np.ones_like(s), B])
    dt = np.diff(knots)
    m = len(knots) - 1
    D = np.zeros((m, m + 2))
    idx = np.arange(m)
    scale = np.sqrt(SMOOTH_WEIGHT) * 0.5 * dt * dt
    D[idx, idx + 1], D[idx, idx + 2] = -scale, scale
    if start is None:
        x = np.zeros(m + 2)
        x[0] = h[0]
    else:
        x = np.concatenate([[start.h0], start.elevation_at(knots)])
    for _ in range(GN_STEPS):
        profile = Profile(knots, float(x[0]), x[1:])
        r = h - profile.height_at(s)
        cos_e = np.cos(profile.elevation_at(s))[:, None]
        J = np.column_stack([A[:, :1], A[:, 1:] * cos_e])
        lhs = J.T @ J + D.T @ D + 1e-12 * np.eye(m + 2)
        x = x + np.linalg.solve(lhs, J.T @ r - D.T @ (D @ x))
        x[1:] = np.clip(x[1:], -MAX_ELEVATION_RAD, MAX_ELEVATION_RAD)
    profile = Profile(knots, float(x[0]), x[1:])
    return profile, h - profile.height_at(s), x[1:]
