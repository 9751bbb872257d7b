"""Plane clothoid splines: the horizontal model the fitter adjusts.

A curve in a conformal plane (complex ``z = X + iY``, X east, Y north, metres) parametrised
by the along-track distance ``s`` (m)::

    A(s) = A0 + ∫₀ˢ κ(σ) dσ,      z(s) = z0 + ∫₀ˢ w(σ) e(A(σ)) dσ,     e(A) = sinA + i cosA

with ``κ`` piecewise linear and continuous between knots ``τ_0 = 0 < … < τ_m = L`` (a
chain of straights, arcs and clothoid transitions: tangent continuous) and ``w(s)`` the
known plane-metres per track-metre (map scale, elevation, height). In a Mercator plane
``A`` is the geographic azimuth, so the curve maps one to one onto track sections.

Positions come from a uniform grid (Simpson's rule per cell, error ~ (ds κ)⁴ ds / 2880) with cubic
Hermite interpolation between grid points; the Jacobian of ``z(s_i)`` with respect to
``(z0, A0, κ_j)`` uses the compact support of each knot's hat function.
"""
from __future__ import annotations

from dataclasses import dataclass
from functools import cached_property

import numpy as np
import numpy.typing as npt

__all__ = ["ClothoidSpline", "heading_basis"]

Array = npt.NDArray[np.float64]
CArray = npt.NDArray[np.complex128]


def _interval(knots: Array, s: Array) -> npt.NDArray[np.intp]:
    return np.clip(np.searchsorted(knots, s, side="right") - 1, 0, len(knots) - 2)


def heading_basis(knots: Array, s: Array) -> Array:
    """``B_j(s) = ∫₀ˢ b_j`` for the hat functions ``b_j`` of the knots, shape (N, m + 1).

    ``A(s) = A0 + B(s) @ κ``. Dense: use for modest N (the initial heading fit).
    """
    m = len(knots) - 1
    out = np.zeros((len(s), m + 1))
    for j in range(m + 1):
        out[:, j] = _hat_integral(knots, j, s)
    return out


def _hat_integral(knots: Array, j: int, s: Array) -> Array:
    """``∫₀ˢ b_j`` for the hat function of knot j (zero-extended at the ends)."""
    out = np.zeros_like(s, dtype=float)
    if j > 0:
        a, b = knots[j - 1], knots[j]
        t = np.clip(s, a, b) - a
        out += t * t / (2.0 * (b - a))
    if j < len(knots) - 1:
        b, c = knots[j], knots[j + 1]
        t = np.clip(s, b, c) - b
        out += t - t * t / (2.0 * (c - b))
    return out


@dataclass(frozen=True)
class ClothoidSpline:
    """A plane clothoid spline evaluated on a grid.

    Parameters
    ----------
    knots : ndarray, shape (m + 1,)
        Knot positions along s, m, increasing, ``knots[0] == 0``.
    z0 : complex
        Start point, plane metres.
    azimuth0 : float
        Start azimuth, rad.
    curvature : ndarray, shape (m + 1,)
        Curvature ``dA/ds`` at the knots, 1/m.
    grid_s : ndarray, shape (G,)
        Uniform grid over [0, L], m.
    w : ndarray, shape (G,)
        Plane metres per track metre on the grid.
    w_mid : ndarray, shape (G - 1,)
        The same at the midpoints of the grid cells.
    """

    knots: Array
    z0: complex
    azimuth0: float
    curvature: Array
    grid_s: Array
    w: Array
    w_mid: Array

    def azimuth(self, s: Array) -> Array:
        """``A(s)``, rad (not wrapped)."""
        j = _interval(self.knots, s)
        dt = np.diff(self.knots)
        k = self.curvature
        turn = np.concatenate([[0.0], np.cumsum(0.5 * (k[:-1] + k[1:]) * dt)])
        t = s - self.knots[j]
        return self.azimuth0 + turn[j] + k[j] * t + 0.5 * (k[j + 1] - k[j]) / dt[j] * t * t

    def curvature_at(self, s: Array) -> Array:
        """``κ(s)``, 1/m."""
        return np.interp(s, self.knots, self.curvature)

    def _cumulative(self, f) -> CArray:
        """``∫₀ˢ f`` on the grid by Simpson's rule per cell; ``f(s, w)`` vectorised."""
        g = self.grid_s
        mid = 0.5 * (g[:-1] + g[1:])
        fg, fm = f(g, self.w), f(mid, self.w_mid)
        cells = np.diff(g) / 6.0 * (fg[:-1] + 4.0 * fm + fg[1:])
        return np.concatenate([[0.0], np.cumsum(cells)])

    @cached_property
    def grid_z(self) -> CArray:
        """``z`` on the grid, plane metres."""
        return self.z0 + self._cumulative(
            lambda s, w: w * np.exp(1j * (np.pi / 2 - self.azimuth(s))))

    def position(self, s: Array) -> tuple[CArray, CArray]:
        """``z(s)`` (cubic Hermite between grid points) and the unit direction ``e(A(s))``."""
        g = self.grid_s
        i = np.clip(np.searchsorted(g, s, side="right") - 1, 0, len(g) - 2)
        h = g[i + 1] - g[i]
        x = (s - g[i]) / h
        z = self.grid_z
        A = self.azimuth(np.stack([g[i], g[i + 1]]))
        d0 = self.w[i] * np.exp(1j * (np.pi / 2 - A[0])) * h
        d1 = self.w[i + 1] * np.exp(1j * (np.pi / 2 - A[1])) * h
        x2, x3 = x * x, x * x * x
        zs = ((2 * x3 - 3 * x2 + 1) * z[i] + (x3 - 2 * x2 + x) * d0
              + (-2 * x3 + 3 * x2) * z[i + 1] + (x3 - x2) * d1)
        return zs, np.exp(1j * (np.pi / 2 - self.azimuth(s)))

    def jacobian(self, s: Array) -> CArray:
        """``∂z(s)/∂(X0, Y0, A0, κ_0..κ_m)``, shape (N, m + 4), complex plane metres."""
        g = self.grid_s
        e_perp = self.w * np.exp(-1j * self.azimuth(g))          # w ∂e/∂A = w (cosA − i sinA)
        E = self._cumulative(lambda s, w: w * np.exp(-1j * self.azimuth(s)))  # ∫₀ˢ w ∂e/∂A
        E_s = np.interp(s, g, E.real) + 1j * np.interp(s, g, E.imag)
        m = len(self.knots) - 1
        J = np.zeros((len(s), m + 4), dtype=complex)
        J[:, 0], J[:, 1], J[:, 2] = 1.0, 1j, E_s
        for j in range(m + 1):
            lo = self.knots[max(j - 1, 0)]
            hi = self.knots[min(j + 1, m)]
            a, b = np.searchsorted(g, [lo, hi])
            a, b = max(a - 1, 0), min(b + 1, len(g))
            gs = g[a:b]
            f = e_perp[a:b] * _hat_integral(self.knots, j, gs)
            local = np.concatenate([[0.0], np.cumsum(0.5 * (f[1:] + f[:-1]) * np.diff(gs))])
            inside = (s > gs[0]) & (s < gs[-1])
            J[inside, j + 3] = (np.interp(s[inside], gs, local.real)
                                + 1j * np.interp(s[inside], gs, local.imag))
            after = s >= gs[-1]
            area = _hat_integral(self.knots, j, np.array([gs[-1]]))[0]
            E_end = E[b - 1]
            J[after, j + 3] = local[-1] + area * (E_s[after] - E_end)
        return J
