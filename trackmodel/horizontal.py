"""The horizontal fit: from plane points to a lean chain of straights, arcs and clothoids.

1. A smooth reference through the points (`trackmodel.reference`) and its first
   segmentation into pieces (`trackmodel.segment`): the fewest pieces within
   `SEGMENT_RMS_FRACTION` of the tolerance (RMS) of the reference.
2. The least-squares fit of that layout to the points (`trackmodel.fit_plane`).
3. Pieces added where points are outside the tolerance, then simplified and removed
   while the fit stays inside (`trackmodel.knots`). Every changed layout starts from the
   fit it comes from: each piece starts on the previous curve, and the curvatures follow
   its azimuth (`trackmodel.segment.fit_values`).
"""
from __future__ import annotations

from collections.abc import Callable

import numpy as np
import numpy.typing as npt

from trackmodel.clothoid import PlaneCurve
from trackmodel.fit_plane import PlaneFit, fit_plane
from trackmodel.knots import prune, refine, simplify
from trackmodel.lsq import levenberg_marquardt
from trackmodel.pieces import Shape
from trackmodel.reference import reference_azimuth
from trackmodel.segment import HORIZONTAL_KINDS, fit_values, running_integral, segment

__all__ = ["fit_horizontal", "SEGMENT_RMS_FRACTION"]

Array = npt.NDArray[np.float64]
CArray = npt.NDArray[np.complex128]

#: The first segmentation follows the reference within this fraction of the tolerance (RMS).
SEGMENT_RMS_FRACTION = 0.1
#: Sample spacing of a fitted curve's azimuth when a changed layout is set to follow it, m.
FOLLOW_SAMPLE_M = 2.0
FOLLOW_MIN_PER_PIECE = 4
FOLLOW_MAX_PER_PIECE = 16
#: Weight of the prior holding each curvature near its start (see `_values_prior`).
VALUE_PRIOR_WEIGHT = 1e-3
FOLLOW_ITERATIONS = 20
FOLLOW_RTOL = 1e-3


def _bounded(shape: Shape, kappa_max: float, min_length_m: float) -> Shape:
    return Shape(shape.layout, np.maximum(shape.lengths, min_length_m),
                 np.clip(shape.values, -kappa_max, kappa_max))


def _start(z_ref: complex, offset: float, azimuth0: float) -> complex:
    """The start point `offset` metres to the right of `z_ref` across `azimuth0`."""
    return z_ref - 1j * offset * np.exp(1j * (0.5 * np.pi - azimuth0))


def _values_prior(shape: Shape) -> Array:
    """Weight of each free value's prior (m per 1/m): `VALUE_PRIOR_WEIGHT` · ℓ²/8, ℓ the
    longest piece the value acts on (its lateral effect there)."""
    layout, L = shape.layout, shape.lengths
    longest = np.zeros(layout.n_values + 1)
    np.maximum.at(longest, layout.start_index, L)
    np.maximum.at(longest, layout.end_index, L)
    return VALUE_PRIOR_WEIGHT * longest[1:] ** 2 / 8.0


def follow(shape: Shape, z0: complex, azimuth0: float, sigma: Array, z_target: CArray,
           w_of_s: Callable[[Array], Array], *, kappa_max: float
           ) -> tuple[complex, float, Shape]:
    """Start point, start azimuth and curvatures of a layout (lengths held) whose positions
    at the fixed arc lengths `sigma` (m) follow `z_target` (plane m): Levenberg–Marquardt
    on the 2-D position differences, with a weak prior on the curvatures.

    Fixed positions along the curve leave no foot-point ambiguity, so this converges from
    a rough start (a curve whose azimuth errors accumulated into tens of metres of drift)
    where the foot-point fit (`trackmodel.fit_plane`) would fall into a false minimum.
    """
    layout, lengths = shape.layout, shape.lengths
    values0 = np.clip(shape.values, -kappa_max, kappa_max)
    prior = _values_prior(shape)
    n = layout.n_values

    def curve(x: Array) -> PlaneCurve:
        return PlaneCurve(layout.pieces(lengths, x[3:]), complex(x[0], x[1]), float(x[2]),
                          w_of_s)

    def residuals(x: Array) -> Array:
        d = curve(x).position(sigma)[0] - z_target
        return np.concatenate([d.real, d.imag, prior * (x[3:] - values0)])

    def jacobian(x: Array) -> Array:
        Jz = curve(x).jacobian(sigma)
        m = len(lengths)
        Jz = np.concatenate([Jz[:, :3], layout.value_jacobian(Jz[:, 3 + m:3 + 2 * m],
                                                              Jz[:, 3 + 2 * m:])], axis=1)
        Jp = np.zeros((n, 3 + n))
        Jp[np.arange(n), 3 + np.arange(n)] = prior
        return np.concatenate([Jz.real, Jz.imag, Jp])

    x0 = np.concatenate([[z0.real, z0.imag, azimuth0], values0])
    bound = np.concatenate([np.full(3, np.inf), np.full(n, kappa_max)])
    x = levenberg_marquardt(residuals, jacobian, x0, -bound, bound,
                            max_iterations=FOLLOW_ITERATIONS, rtol=FOLLOW_RTOL)
    return complex(x[0], x[1]), float(x[2]), Shape(layout, lengths, x[3:])


def follow_samples(knots: Array) -> Array:
    """Positions (m) where a layout with these piece ends is made to follow a target:
    every `FOLLOW_SAMPLE_M` within each piece, but at least `FOLLOW_MIN_PER_PIECE` and at
    most `FOLLOW_MAX_PER_PIECE` per piece (a long straight needs no more than a short arc)."""
    L = np.diff(knots)
    n = np.clip(np.ceil(L / FOLLOW_SAMPLE_M), FOLLOW_MIN_PER_PIECE,
                FOLLOW_MAX_PER_PIECE).astype(np.intp)
    piece = np.repeat(np.arange(len(L)), n)
    k = np.arange(piece.size) - np.repeat(np.cumsum(n) - n, n)
    return np.append(knots[piece] + k * (L / n)[piece], knots[-1])


def _follow_curve(curve: PlaneCurve, shape: Shape, w_of_s: Callable[[Array], Array],
                  kappa_max: float) -> tuple[complex, float, Shape]:
    """A changed layout (with plane metres per track metre `w_of_s`) set to follow a
    fitted curve (its lengths scaled to the curve's)."""
    shape = Shape(shape.layout, shape.lengths * curve.length / shape.lengths.sum(),
                  shape.values)
    sigma = follow_samples(shape.pieces.knots)
    return follow(shape, curve.z0, curve.azimuth0, sigma, curve.position(sigma)[0],
                  w_of_s, kappa_max=kappa_max)


def fit_horizontal(P: CArray, s: Array, w_of_s: Callable[[Array], Array], *, tol_m: float,
                   kappa_max: float, min_length_m: float, max_fits: int,
                   warm: PlaneFit | None = None,
                   progress: Callable[[int, int], None] | None = None) -> PlaneFit:
    """Fit a lean chain of pieces to plane points within `tol_m`.

    Parameters
    ----------
    P : ndarray of complex, shape (N,)
        Points in the plane (X east + i Y north), plane metres, in order.
    s : ndarray, shape (N,)
        Their chord lengths, m, strictly increasing.
    w_of_s : callable
        Plane metres per track metre as a function of s (m).
    tol_m : float
        Largest normal distance of a point from the curve the fit aims for, m.
    kappa_max : float
        Largest |curvature|, 1/m.
    min_length_m : float
        Shortest piece, m.
    max_fits : int
        Refits allowed to each of the simplification and the pruning.
    warm : PlaneFit, optional
        An earlier fit to start from (another `w_of_s` or `tol_m`): its layout is refitted,
        refined and simplified instead of a new first segmentation.
    progress : callable(done, total), optional
        Called after each refinement round.

    Returns
    -------
    PlaneFit
    """
    def fit(shape: Shape, warm: PlaneFit | None) -> PlaneFit:
        if warm is None:
            z, azimuth, guess = first
        else:
            shape = _bounded(shape, kappa_max, min_length_m)
            z, azimuth, shape = _follow_curve(warm.curve, shape, w_of_s, kappa_max)
            guess = warm.s
        return fit_plane(P, guess, shape, z0=z, azimuth0=azimuth, w_of_s=w_of_s,
                         tol_m=tol_m, kappa_max=kappa_max, min_length_m=min_length_m)

    if warm is None:
        *first, shape = _first_guess(P, s, w_of_s, tol_m=tol_m, kappa_max=kappa_max,
                                     min_length_m=min_length_m)
    else:
        shape = warm.shape
    result = refine(fit, shape, tol_m, min_length_m=min_length_m, continuous=False,
                    warm=warm, progress=progress)
    result = simplify(fit, result, tol_m, max_fits=max_fits)
    return prune(fit, result, tol_m, continuous=False, max_fits=max_fits)


def _first_guess(P: CArray, s: Array, w_of_s: Callable[[Array], Array], *, tol_m: float,
                 kappa_max: float, min_length_m: float
                 ) -> tuple[complex, float, Array, Shape]:
    """Start point (plane m), start azimuth (rad), the points' positions along s (m) and
    the layout of a first guess: the segmentation of a smooth reference, set to follow its
    positions."""
    ref = reference_azimuth(P, s)
    Y = running_integral(ref.sigma, ref.azimuth)
    shape = segment(ref.sigma, Y, SEGMENT_RMS_FRACTION * tol_m, HORIZONTAL_KINDS)
    (offset, azimuth0), shape = fit_values(ref.sigma, Y, shape, integrations=2)
    shape = _bounded(shape, kappa_max, min_length_m)
    sigma = np.minimum(follow_samples(shape.pieces.knots), ref.sigma[-1])
    z_ref = np.interp(sigma, ref.sigma, ref.z.real) + 1j * np.interp(sigma, ref.sigma,
                                                                      ref.z.imag)
    z0, azimuth0, shape = follow(shape, _start(ref.z[0], offset, azimuth0), azimuth0,
                                 sigma, z_ref, w_of_s, kappa_max=kappa_max)
    return z0, azimuth0, ref.s_points, shape
