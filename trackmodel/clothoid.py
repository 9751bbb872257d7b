"""Plane curves of straights, arcs and clothoids: the horizontal model the fitter adjusts.

A curve in a conformal plane (complex ``z = X + iY``, X east, Y north, plane metres)
parametrised by the along-track distance ``s`` (m)::

    A(s) = A0 + ∫₀ˢ κ(σ) dσ,      z(s) = z0 + ∫₀ˢ w(σ) e(A(σ)) dσ,     e(A) = sinA + i cosA

with ``κ`` a typed piecewise-linear profile (`trackmodel.pieces`: straights, arcs and
clothoid transitions, the azimuth continuous: no kink) and ``w(s)`` the known plane metres
per track metre (map scale, elevation, height). In a Mercator plane ``A`` is the
geographic azimuth, so the pieces map one to one onto track sections.

Positions come from Simpson's rule per cell (cells never straddle a knot; error per metre
~ (ds κ)⁴ / 2880) and cubic Hermite interpolation within a cell. The Jacobian of
``z(s_i)`` with respect to ``z0``, ``A0`` and each piece's length and start/end curvature
is assembled from four running integrals of ``g = w ∂e/∂A = w e^{-iA}`` (``∫g``, ``∫gκ``,
``∫g t``, ``∫g t²`` with t the distance into the piece), because the azimuth at σ depends
on piece j's parameters through

* ``∂A/∂a_j = t − t²/2L_j``, ``∂A/∂b_j = t²/2L_j`` inside the piece and ``L_j/2`` after it;
* ``∂A/∂L_j = −(b_j − a_j) t²/2L_j²`` inside and ``(a_j + b_j)/2 − κ(σ)`` after it
  (the later pieces move along by the change of length).
"""
from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from functools import cached_property

import numpy as np
import numpy.typing as npt

from trackmodel.pieces import CellGrid, Pieces

__all__ = ["PlaneCurve", "GRID_STEP_M", "GRID_TURN_RAD"]

Array = npt.NDArray[np.float64]
CArray = npt.NDArray[np.complex128]

#: Cells are at most this long, m, and turn at most this much, rad (Simpson's relative
#: error per cell ~ (0.05)⁴ / 2880 ≈ 2e-9).
GRID_STEP_M = 10.0
GRID_TURN_RAD = 0.05
PROJECTION_NEWTON_STEPS = 2
#: A foot point has settled when the last Newton step is below this, m.
FOOT_TOL_M = 1e-4
#: Candidate distances computed at once in the nearest-node search.
NEAREST_CHUNK = 2_000_000


def _unit(azimuth: Array) -> CArray:
    """``e(A) = sinA + i cosA``."""
    return np.exp(1j * (0.5 * np.pi - azimuth))


@dataclass(frozen=True)
class PlaneCurve:
    """A plane curve of typed pieces, evaluated on a cell grid.

    Parameters
    ----------
    pieces : Pieces
        The curvature profile ``κ(s)``, 1/m.
    z0 : complex
        Start point, plane metres.
    azimuth0 : float
        Start azimuth, rad.
    w_of_s : callable
        ``w(s)``: plane metres per track metre for an array of s (m).
    """

    pieces: Pieces
    z0: complex
    azimuth0: float
    w_of_s: Callable[[Array], Array]

    @cached_property
    def grid(self) -> CellGrid:
        kmax = np.maximum(np.abs(self.pieces.start), np.abs(self.pieces.end))
        step = np.minimum(GRID_STEP_M, GRID_TURN_RAD / np.maximum(kmax, 1e-12))
        return CellGrid.build(self.pieces, step)

    @property
    def length(self) -> float:
        return self.pieces.length

    def azimuth(self, s: Array, j=None) -> Array:
        """``A(s)``, rad (not wrapped)."""
        return self.azimuth0 + self.pieces.integral(s, j)

    @cached_property
    def _samples(self) -> dict[str, Array]:
        """Azimuth, w and curvature at the cells' left ends, midpoints and right ends."""
        g = self.grid
        out = {}
        for name, s in zip(("left", "mid", "right"), g.points()):
            out[name] = (self.azimuth(s, g.piece), self.w_of_s(s),
                         self.pieces.value(s, g.piece), s - self.pieces.knots[g.piece])
        return out

    @cached_property
    def _position_integral(self) -> tuple[CArray, ...]:
        f = {k: w * _unit(A) for k, (A, w, _, _) in self._samples.items()}
        return (*self.grid.cumulative(f["left"], f["mid"], f["right"]), f["left"], f["right"])

    def position(self, s: Array) -> tuple[CArray, CArray, Array]:
        """``z(s)``, the unit direction ``e(A(s))`` and ``w(s)`` (plane m per track m)."""
        z = self.z0 + self.grid.hermite(*self._position_integral, s, self.grid.cell_of(s))
        return z, _unit(self.azimuth(s)), self.w_of_s(s)

    @cached_property
    def node_positions(self) -> CArray:
        """``z`` at the grid nodes (G + 1,), plane metres."""
        F_left, F_right = self._position_integral[:2]
        return self.z0 + np.append(F_left, F_right[-1])

    def foot_points(self, P: CArray, s: Array, window_m: Array) -> Array:
        """Foot points (m) of points P near guesses s.

        Newton steps from the guesses; where they do not settle within `FOOT_TOL_M` or
        leave the window, the nearest grid node within ``window_m`` (per point) of the
        guess, then Newton steps again.
        """
        guess = s
        s, moved = self._newton(P, s, PROJECTION_NEWTON_STEPS)
        lost = (moved > FOOT_TOL_M) | (np.abs(s - guess) > window_m)
        if lost.any():
            near = self._nearest_node(P[lost], guess[lost], window_m[lost])
            s[lost] = self._newton(P[lost], near, PROJECTION_NEWTON_STEPS + 1)[0]
        return s

    def _newton(self, P: CArray, s: Array, steps: int) -> tuple[Array, Array]:
        """Newton steps ``s += e·(P − z) / w``; also the size of the last step, m."""
        step = np.zeros_like(s)
        for _ in range(steps):
            z, e, w = self.position(s)
            new = np.clip(s + np.real(np.conj(e) * (P - z)) / w, 0.0, self.length)
            step, s = np.abs(new - s), new
        return s, step

    def _nearest_node(self, P: CArray, s: Array, window_m: Array) -> Array:
        """The grid node nearest to each point within its window of s, m."""
        nodes, zn = self.grid.nodes, self.node_positions
        lo = np.searchsorted(nodes, s - window_m)
        hi = np.searchsorted(nodes, s + window_m, side="right")
        width = max(1, int((hi - lo).max()))
        best = np.empty(len(P), dtype=np.intp)
        chunk = max(1, NEAREST_CHUNK // width)
        for c in range(0, len(P), chunk):
            sl = slice(c, c + chunk)
            idx = lo[sl, None] + np.arange(width)[None, :]
            d = np.abs(zn[np.minimum(idx, nodes.size - 1)] - P[sl, None])
            d[idx >= hi[sl, None]] = np.inf
            best[sl] = np.minimum(idx[np.arange(idx.shape[0]), np.argmin(d, axis=1)],
                                  nodes.size - 1)
        return nodes[best]

    @cached_property
    def _moments(self) -> tuple[CArray, CArray, CArray]:
        """Running integrals of ``g·[1, κ, t, t²]`` at the nodes, and g·[…] at the cell ends."""
        f = {}
        for k, (A, w, kappa, t) in self._samples.items():
            g = w * np.exp(-1j * A)
            f[k] = np.stack([g, g * kappa, g * t, g * t * t], axis=-1)
        return (*self.grid.cumulative(f["left"], f["mid"], f["right"]), f["left"], f["right"])

    def azimuth_jacobian(self, s: Array) -> Array:
        """``∂A(s)/∂(X0, Y0, A0, L_j…, a_j…, b_j…)`` at fixed s, shape (N, 3 + 3m), rad per
        parameter unit."""
        head = np.zeros((len(s), 3))
        head[:, 2] = 1.0
        return np.concatenate([head, *self.pieces.integral_jacobian(s)], axis=1)

    def jacobian(self, s: Array) -> CArray:
        """``∂z(s)/∂(X0, Y0, A0, L_0..L_{m-1}, a_0..a_{m-1}, b_0..b_{m-1})``.

        Parameters
        ----------
        s : ndarray, shape (N,)
            Along-track positions, m (held fixed: foot points).

        Returns
        -------
        ndarray of complex, shape (N, 3 + 3m)
            Plane metres per parameter unit (m for lengths, 1/m for curvatures).
        """
        pc = self.pieces
        M_left, M_right, _, _ = self._moments
        at_s = self.grid.hermite(*self._moments, s, self.grid.cell_of(s))   # (N, 4)
        at_k = np.concatenate([M_left[self.grid.first_cell], M_right[-1:]])  # (m + 1, 4)
        L, slope = pc.lengths, pc.slope
        mean = 0.5 * (pc.start + pc.end)
        K = pc.piece_of(s)
        cols = np.arange(len(L))
        before = cols[None, :] < K[:, None]
        dE = at_s[:, None, 0] - at_k[None, 1:, 0]                         # E(s) − E(τ_{j+1})
        dK = at_s[:, None, 1] - at_k[None, 1:, 1]
        full = at_k[1:, 2:] - at_k[:-1, 2:]                                 # (m, 2): t, t²
        part = at_s[:, 2:] - at_k[K, 2:]                                    # (N, 2)
        da = np.where(before, (full[:, 0] - full[:, 1] / (2 * L)) + 0.5 * L * dE, 0)
        db = np.where(before, full[:, 1] / (2 * L) + 0.5 * L * dE, 0)
        dL = np.where(before, -slope * full[:, 1] / (2 * L) + mean * dE - dK, 0)
        rows = np.arange(len(s))
        da[rows, K] = part[:, 0] - part[:, 1] / (2 * L[K])
        db[rows, K] = part[:, 1] / (2 * L[K])
        dL[rows, K] = -slope[K] * part[:, 1] / (2 * L[K])
        head = np.stack([np.ones(len(s)), np.full(len(s), 1j), at_s[:, 0]], axis=-1)
        return np.concatenate([head, dL, da, db], axis=1)
