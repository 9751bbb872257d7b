"""Least-squares fit of a plane curve of typed pieces (`trackmodel.clothoid`) to points.

For a fixed `Layout` (which pieces are straights, arcs and transitions) the parameters are
the start point and azimuth, the piece lengths and the free curvatures. They are adjusted
by Levenberg–Marquardt (`trackmodel.lsq`; bounds: lengths at least ``min_length_m``,
curvatures within ``±kappa_max``) on

* the **normal** residuals ``n(s_i)·(P_i − z(s_i)) / w(s_i)`` (ground metres; ``s_i`` the
  foot point of ``P_i``, found again at every evaluation, so the along-track derivative
  vanishes);
* a **tolerance hinge** ``√β · max(0, |r_i| − t0)`` per point (``t0`` = `HINGE_FRACTION` of
  the tolerance): least squares alone centres the curve on the noise; the hinge makes the
  fit spend its freedom on the few points near the tolerance instead of needing new
  sections for them;
* the **along-track** residuals of the first and last point (weight `END_WEIGHT`): the
  track starts at the first point's foot and ends at the last one's.
"""
from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
import numpy.typing as npt

from trackmodel.clothoid import PlaneCurve
from trackmodel.lsq import levenberg_marquardt
from trackmodel.pieces import FREE, Layout, Shape

__all__ = ["PlaneFit", "fit_plane", "HINGE_FRACTION"]

Array = npt.NDArray[np.float64]
CArray = npt.NDArray[np.complex128]

#: The hinge starts at this fraction of the tolerance.
HINGE_FRACTION = 0.8
#: Weight of the hinge relative to a plain residual (its square multiplies the excess²).
HINGE_WEIGHT = 10.0
END_WEIGHT = 10.0
#: Weak prior on the piece lengths (residual metres per metre of change): joints whose
#: position hardly matters (two transitions in line, an arc of tiny curvature next to a
#: straight) stay put instead of creeping along a flat valley of the cost.
LENGTH_PRIOR_WEIGHT = 0.1
#: Weight of the curvature jumps at the ends of free transitions (lateral-equivalent):
#: pieces whose joint curvature is free otherwise leave near-null directions (zigzags of
#: the values that hardly move the curve).
JUMP_WEIGHT = 0.1

#: Foot points are searched within this distance of the previous ones, m, or within two
#: point gaps where the points are farther apart.
MIN_WINDOW_M = 10.0
MAX_ITERATIONS = 30


@dataclass(frozen=True)
class PlaneFit:
    """A fitted curve with the foot points (m) and normal residuals (ground m) of the points.

    Attributes
    ----------
    shape : Shape
        The fitted layout, lengths (m) and curvatures (1/m).
    curve : PlaneCurve
    s : ndarray, shape (N,)
        Foot points of the points, m.
    residual_m : ndarray, shape (N,)
        Signed normal distances of the points from the curve, ground m (+ right).
    """

    shape: Shape
    curve: PlaneCurve
    s: Array
    residual_m: Array

    @property
    def worst_m(self) -> float:
        return float(np.abs(self.residual_m).max(initial=0.0))


def _jump_rows(layout: Layout, lengths: Array) -> Array:
    """Weak penalty rows on the curvature jumps at the ends of `FREE` pieces, shape
    (joints, n): ``JUMP_WEIGHT · (b_j − a_{j+1}) · ℓ² / 8`` (lateral-equivalent metres,
    ℓ the shorter of the two pieces)."""
    rows = []
    kinds = layout.kinds
    for j in range(len(kinds) - 1):
        if FREE not in (kinds[j], kinds[j + 1]):
            continue
        row = np.zeros(layout.n_values + 1)
        scale = JUMP_WEIGHT * min(lengths[j], lengths[j + 1]) ** 2 / 8.0
        row[layout.end_index[j]] += scale
        row[layout.start_index[j + 1]] -= scale
        rows.append(row[1:])
    return np.array(rows) if rows else np.zeros((0, layout.n_values))


class _Problem:
    """Residuals and Jacobian of one layout; remembers the last foot points.

    Parameters ``x = [X0, Y0, A0, L_0…L_{m-1}, v_1…v_n]``.
    """

    def __init__(self, P: CArray, s: Array, layout: Layout, w_of_s, tol_m: float,
                 lengths0: Array) -> None:
        self.P, self.s, self.layout, self.w_of_s = P, s, layout, w_of_s
        self.m = len(layout)
        self.lengths0 = lengths0
        self.fixed = _jump_rows(layout, lengths0)
        gap = np.diff(s)
        gaps = np.maximum(np.append(gap, 0.0), np.insert(gap, 0, 0.0))
        self.window = np.maximum(MIN_WINDOW_M, 2.0 * gaps)
        self.t0 = HINGE_FRACTION * tol_m
        self.cache: dict = {}
        self.best_cost = np.inf

    def curve(self, x: Array) -> PlaneCurve:
        m = self.m
        return PlaneCurve(self.layout.pieces(x[3:3 + m], x[3 + m:]), complex(x[0], x[1]),
                          float(x[2]), self.w_of_s)

    def evaluate(self, x: Array):
        key = x.tobytes()
        if key not in self.cache:
            curve = self.curve(x)
            s = curve.foot_points(self.P, self.s, self.window)
            z, e, w = curve.position(s)
            r = np.real(np.conj(-1j * e) * (self.P - z)) / w
            self.cache = {key: (curve, s, e, w, r)}
            if r @ r < self.best_cost:           # warm start only from the best so far
                self.best_cost, self.s = r @ r, s
        return self.cache[key]

    def _end_state(self, curve: PlaneCurve):
        ends = np.array([0.0, curve.length])
        return ends, *curve.position(ends)

    def residuals(self, x: Array) -> Array:
        curve, _, _, _, r = self.evaluate(x)
        m = self.m
        excess = np.sign(r) * np.maximum(np.abs(r) - self.t0, 0.0)
        ends, z, e, w = self._end_state(curve)
        along = END_WEIGHT * np.real(np.conj(e) * (self.P[[0, -1]] - z)) / w
        parts = [r, HINGE_WEIGHT * excess, along]
        parts.append(LENGTH_PRIOR_WEIGHT * (x[3:3 + m] - self.lengths0))
        parts.append(self.fixed @ x[3 + m:])
        return np.concatenate(parts)

    def jacobian(self, x: Array) -> Array:
        curve, s, e, w, r = self.evaluate(x)
        m = self.m
        Jz = self._to_parameters(curve.jacobian(s))
        Jr = -np.real(np.conj(-1j * e)[:, None] * Jz) / w[:, None]
        active = (np.abs(r) > self.t0)[:, None]
        blocks = [Jr, HINGE_WEIGHT * active * Jr, END_WEIGHT * self._end_rows(curve)]
        Jp = np.zeros((m, Jr.shape[1]))
        Jp[np.arange(m), 3 + np.arange(m)] = LENGTH_PRIOR_WEIGHT
        Jf = np.zeros((len(self.fixed), Jr.shape[1]))
        Jf[:, 3 + m:] = self.fixed
        return np.concatenate(blocks + [Jp, Jf])

    def _to_parameters(self, Jz: Array) -> Array:
        """Columns (z0, A0, lengths, starts, ends) to (z0, A0, lengths, free values)."""
        m = self.m
        return np.concatenate([Jz[:, :3 + m], self.layout.value_jacobian(
            Jz[:, 3 + m:3 + 2 * m], Jz[:, 3 + 2 * m:])], axis=1)

    def _end_jacobians(self, curve: PlaneCurve):
        """``∂z`` and ``∂A`` at s = 0 and at the end s = L, which moves with every length
        (``dz(L)/dL_j += w e``, ``dA(L)/dL_j += κ(L)``)."""
        ends, z, e, w = self._end_state(curve)
        Jz, JA = curve.jacobian(ends), curve.azimuth_jacobian(ends)
        Jz[1, 3:3 + self.m] += w[1] * e[1]
        JA[1, 3:3 + self.m] += curve.pieces.value(ends[1:])[0]
        return ends, z, e, w, Jz, JA

    def _end_rows(self, curve: PlaneCurve) -> Array:
        """Jacobian of the along-track residuals ``e·(P − z)/w`` of the first point at
        s = 0 and of the last point at the end; the tangent turns with A."""
        ends, z, e, w, Jz, JA = self._end_jacobians(curve)
        de_dA = np.exp(-1j * curve.azimuth(ends))               # ∂e/∂A
        rows = (-np.real(np.conj(e)[:, None] * Jz)
                + np.real(np.conj(de_dA) * (self.P[[0, -1]] - z))[:, None] * JA)
        return self._to_parameters(rows) / w[:, None]

def fit_plane(P: CArray, s: Array, shape: Shape, *, z0: complex, azimuth0: float,
              w_of_s: Callable[[Array], Array], tol_m: float, kappa_max: float,
              min_length_m: float,
              max_iterations: int = MAX_ITERATIONS) -> PlaneFit:
    """Fit a curve of the shape's layout to points P, starting from the shape.

    Parameters
    ----------
    P : ndarray of complex, shape (N,)
        Points in the plane (X east + i Y north), plane metres, in order.
    s : ndarray, shape (N,)
        Guesses of their along-track positions from the curve's start, m.
    shape : Shape
        Layout, initial piece lengths (m) and curvatures (1/m).
    z0 : complex
        Initial start point, plane metres.
    azimuth0 : float
        Initial start azimuth, rad.
    w_of_s : callable
        Plane metres per track metre as a function of s (m, from the curve's start).
    tol_m : float
        The horizontal tolerance, m (sets the hinge).
    kappa_max : float
        Largest |curvature|, 1/m (1 / the smallest radius).
    min_length_m : float
        Shortest piece, m.

    Returns
    -------
    PlaneFit
    """
    layout = shape.layout
    m = len(layout)
    x0 = np.concatenate([[z0.real, z0.imag, azimuth0], shape.lengths, shape.values])
    lower = np.concatenate([np.full(3, -np.inf), np.full(m, min_length_m),
                            np.full(layout.n_values, -kappa_max)])
    upper = np.concatenate([np.full(3, np.inf), np.full(m, np.inf),
                            np.full(layout.n_values, kappa_max)])
    problem = _Problem(P, s, layout, w_of_s, tol_m, np.maximum(shape.lengths, min_length_m))
    x = levenberg_marquardt(problem.residuals, problem.jacobian, x0, lower, upper,
                            max_iterations=max_iterations)
    curve, s, _, _, r = problem.evaluate(x)
    return PlaneFit(Shape(layout, x[3:3 + m], x[3 + m:]), curve, s, r)
