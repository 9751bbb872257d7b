"""Least-squares fit of a plane clothoid spline (fixed knots) to surveyed points.

The points ``P_i`` (complex plane metres) are fitted by a `ClothoidSpline` with
Levenberg–Marquardt on the **normal** residuals ``n(s_i)·(P_i − z(s_i)) / μ_i`` (ground
metres; ``s_i`` the foot point of ``P_i``, re-projected at every step; ``μ`` the plane
metres per ground metre). The first point also gives an along-track residual (it pins the
start) and the end of the spline follows the last point's foot. A weak penalty on the
curvature change between knots (a lateral-offset equivalent weighted by `SMOOTH_WEIGHT`)
keeps knots without nearby points determined.

Before the normal-residual stage, a few steps with full 2-D residuals at fixed ``s_i``
(the chord lengths) bring a rough initial guess close (no foot-point ambiguity there).
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import numpy.typing as npt

from trackmodel.clothoid import ClothoidSpline, heading_basis

__all__ = ["PlaneFit", "fit_plane", "initial_knots", "initial_spline", "project_on_spline"]

Array = npt.NDArray[np.float64]
CArray = npt.NDArray[np.complex128]

#: Weight of the curvature-smoothness penalty relative to a point residual (m per m).
SMOOTH_WEIGHT = 1e-2
#: Grid step of the spline integration, m, and at most this turn per step, rad
#: (Simpson's error per metre ~ (step κ)⁴/2880: < 1e-9 at 0.05 rad).
GRID_STEP_M = 1.0
GRID_TURN_RAD = 0.05
MIN_GRID_STEP_M = 0.02
PROJECTION_STEPS = 5
MAX_LM_STEPS = 15
#: LM stops when the cost falls by less than this fraction.
LM_RTOL = 1e-6
INITIAL_2D_STEPS = 6
#: Chord length used for the initial heading estimate, m.
HEADING_CHORD_M = 5.0
#: Largest move of the spline end towards the last point per fit, m.
MAX_END_SHIFT_M = 20.0
#: Initial knots: one where the chord heading has turned by this much, rad, or after
#: `INITIAL_KNOT_SPACING_M`.
TURN_PER_KNOT_RAD = 0.2
INITIAL_KNOT_SPACING_M = 200.0


@dataclass(frozen=True)
class PlaneFit:
    """A fitted spline with the foot points and normal residuals of the points (m)."""

    spline: ClothoidSpline
    s: Array
    residual_m: Array


def _grid(length: float, curvature: Array) -> Array:
    step = max(min(GRID_STEP_M, GRID_TURN_RAD / max(np.abs(curvature).max(), 1e-12)),
               MIN_GRID_STEP_M)
    n = max(2, int(np.ceil(length / step)) + 1)
    return np.linspace(0.0, length, n)


def make_spline(knots: Array, z0: complex, azimuth0: float, curvature: Array,
                w_of_s) -> ClothoidSpline:
    """Spline on a fresh grid; ``w_of_s(s)`` gives plane metres per track metre."""
    curvature = np.asarray(curvature, float)
    g = _grid(knots[-1], curvature)
    return ClothoidSpline(knots, complex(z0), float(azimuth0), curvature,
                          g, w_of_s(g), w_of_s(0.5 * (g[:-1] + g[1:])))


def project_on_spline(spline: ClothoidSpline, P: CArray, s: Array) -> Array:
    """Foot points ``s`` (m) of points P, by Newton steps from a guess."""
    L = spline.knots[-1]
    for _ in range(PROJECTION_STEPS):
        z, e = spline.position(s)
        w = np.interp(s, spline.grid_s, spline.w)
        s = np.clip(s + np.real(np.conj(e) * (P - z)) / w, 0.0, L)
    return s


def chord_headings(P: CArray, s: Array) -> tuple[Array, Array]:
    """Azimuth (rad, unwrapped) of chords of about `HEADING_CHORD_M`, at their midpoints."""
    j = np.searchsorted(s, s + HEADING_CHORD_M)
    i = np.flatnonzero(j < len(s))
    if len(i) < 2:
        i, j = np.arange(len(s) - 1), np.arange(1, len(s))
    else:
        j = j[i]
    return 0.5 * (s[i] + s[j]), np.unwrap(np.pi / 2 - np.angle(P[j] - P[i]))


def initial_knots(P: CArray, s: Array) -> Array:
    """Knots where the survey's heading turns (dense in corners, sparse on straights), m."""
    mid, heading = chord_headings(P, s)
    turn = np.concatenate([[0.0], np.cumsum(np.abs(np.diff(heading)))])
    knots, last_turn = [0.0], 0.0
    for x, t in zip(mid, turn):
        if (t - last_turn >= TURN_PER_KNOT_RAD or x - knots[-1] >= INITIAL_KNOT_SPACING_M) \
                and x - knots[-1] >= 2.0 and s[-1] - x >= 2.0:
            knots.append(x)
            last_turn = t
    return np.append(knots, s[-1])


def initial_spline(P: CArray, s: Array, knots: Array, w_of_s) -> ClothoidSpline:
    """Spline from the chord headings of the points (least squares over the knots)."""
    mid, heading = chord_headings(P, s)
    B = np.column_stack([np.ones_like(mid), heading_basis(knots, mid)])
    D = _smooth_rows(knots)
    lhs = B.T @ B + np.pad(D.T @ D, ((1, 0), (1, 0))) + 1e-12 * np.eye(B.shape[1])
    x = np.linalg.solve(lhs, B.T @ heading)
    return make_spline(knots, P[0], x[0], x[1:], w_of_s)


def _smooth_rows(knots: Array) -> Array:
    """Penalty rows on the curvature differences (lateral-offset equivalent), (m, m + 1)."""
    dt = np.diff(knots)
    m = len(knots) - 1
    D = np.zeros((m, m + 1))
    idx = np.arange(m)
    scale = np.sqrt(SMOOTH_WEIGHT) * 0.5 * dt * dt
    D[idx, idx], D[idx, idx + 1] = -scale, scale
    return D


def _rows(spline: ClothoidSpline, P: CArray, s: Array, s_fixed: bool):
    """Residuals (ground m) and Jacobian rows for the current spline."""
    z, e = spline.position(s)
    mu = np.interp(s, spline.grid_s, spline.w)
    J = spline.jacobian(s)
    if s_fixed:                                   # full 2-D residuals at fixed s
        d = (P - z) / mu
        Jd = J / mu[:, None]
        return np.concatenate([d.real, d.imag]), -np.vstack([Jd.real, Jd.imag])
    n = e * (-1j)                                 # right-hand normal
    r = np.real(np.conj(n) * (P - z)) / mu
    Jr = -np.real(np.conj(n)[:, None] * J) / mu[:, None]
    along = np.real(np.conj(e[0]) * (P[0] - z[0])) / mu[0]
    Ja = -np.real(np.conj(e[0]) * J[0]) / mu[0]
    return np.append(r, along), np.vstack([Jr, Ja])


def _theta(spline: ClothoidSpline) -> Array:
    return np.concatenate([[spline.z0.real, spline.z0.imag, spline.azimuth0], spline.curvature])


def _with_theta(spline: ClothoidSpline, theta: Array, knots: Array, w_of_s) -> ClothoidSpline:
    return make_spline(knots, theta[0] + 1j * theta[1], theta[2], theta[3:], w_of_s)


def _cost(spline, P, s, s_fixed, D):
    if not s_fixed:
        s = project_on_spline(spline, P, s)
    r, J = _rows(spline, P, s, s_fixed)
    pen = D @ spline.curvature
    return r @ r + pen @ pen, r, J, s


def _lm(spline: ClothoidSpline, P: CArray, s: Array, w_of_s, *, s_fixed: bool,
        max_steps: int) -> tuple[ClothoidSpline, Array]:
    knots = spline.knots
    D = _smooth_rows(knots)
    lam = 1e-3
    cost, r, J, s = _cost(spline, P, s, s_fixed, D)
    for _ in range(max_steps):
        theta = _theta(spline)
        DD = np.pad(D.T @ D, ((3, 0), (3, 0)))
        JTJ = J.T @ J + DD
        g = J.T @ r + DD @ theta
        improved = False
        for _ in range(8):
            A = JTJ + lam * np.diag(np.diag(JTJ) + 1e-12)
            step = -np.linalg.solve(A, g)
            trial = _with_theta(spline, theta + step, knots, w_of_s)
            t_cost, t_r, t_J, t_s = _cost(trial, P, s, s_fixed, D)
            if t_cost < cost:
                improved = True
                break
            lam *= 10.0
        if not improved:
            break
        done = cost - t_cost < 1e-12 + LM_RTOL * cost
        spline, cost, r, J, s = trial, t_cost, t_r, t_J, t_s
        lam = max(lam / 10.0, 1e-9)
        if done:
            break
    return spline, s


def _follow_last_point(spline: ClothoidSpline, P: CArray, w_of_s) -> ClothoidSpline:
    """Move the last knot so that the spline ends at the last point's foot."""
    L = spline.knots[-1]
    z, e = spline.position(np.array([L]))
    w = spline.w[-1]
    extra = float(np.real(np.conj(e[0]) * (P[-1] - z[0])) / w)
    last = spline.knots[-1] - spline.knots[-2]
    extra = float(np.clip(extra, -0.5 * last, max(last, MAX_END_SHIFT_M)))
    knots = spline.knots.copy()
    knots[-1] = L + extra
    curvature = spline.curvature.copy()
    return make_spline(knots, spline.z0, spline.azimuth0, curvature, w_of_s)


def fit_plane(P: CArray, s: Array, knots: Array, w_of_s, *,
              start: ClothoidSpline | None = None) -> PlaneFit:
    """Fit a clothoid spline with the given knots to points P.

    Parameters
    ----------
    P : ndarray of complex, shape (N,)
        Points in the plane (X east + i Y north), plane metres.
    s : ndarray, shape (N,)
        Initial along-track positions of the points, m (increasing).
    knots : ndarray, shape (m + 1,)
        Knots, m; ``knots[-1]`` is the initial length.
    w_of_s : callable
        Plane metres per track metre as a function of s.
    start : ClothoidSpline, optional
        Warm start: its azimuth and curvature profile are resampled at `knots`.

    Returns
    -------
    PlaneFit
    """
    if start is None:
        spline = initial_spline(P, s, knots, w_of_s)
        spline, _ = _lm(spline, P, s, w_of_s, s_fixed=True, max_steps=INITIAL_2D_STEPS)
    else:
        spline = make_spline(knots, start.z0, start.azimuth0,
                             start.curvature_at(knots), w_of_s)
    for _ in range(2):
        spline, s = _lm(spline, P, s, w_of_s, s_fixed=False, max_steps=MAX_LM_STEPS)
        spline = _follow_last_point(spline, P, w_of_s)
        s = project_on_spline(spline, P, s)
    r, _ = _rows(spline, P, s, s_fixed=False)
    return PlaneFit(spline, s, r[:-1])
