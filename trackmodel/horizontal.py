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


def _bounded(shape: Shape, kappa_max: float, min_length_m: float) -> Shape:
    return Shape(shape.layout, np.maximum(shape.lengths, min_length_m),
                 np.clip(shape.values, -kappa_max, kappa_max))


def _start(z_ref: complex, offset: float, azimuth0: float) -> complex:
    """The start point `offset` metres to the right of `z_ref` across `azimuth0`."""
    return z_ref - 1j * offset * np.exp(1j * (0.5 * np.pi - azimuth0))


def _follow(curve: PlaneCurve, shape: Shape) -> tuple[complex, float, Shape]:
    """Start point, start azimuth and curvatures of a new layout that follow a fitted
    curve's azimuth (linear least squares)."""
    n = max(3, int(np.ceil(curve.length / FOLLOW_SAMPLE_M)) + 1)
    sigma = np.linspace(0.0, curve.length, n)
    Y = running_integral(sigma, curve.azimuth(sigma))
    (offset, azimuth0), shape = fit_values(sigma, Y, shape, integrations=2)
    return _start(curve.z0, offset, azimuth0), azimuth0, shape


def fit_horizontal(P: CArray, s: Array, w_of_s: Callable[[Array], Array], *, tol_m: float,
                   kappa_max: float, min_length_m: float, max_fits: int,
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
    progress : callable(done, total), optional
        Called after each refinement round.

    Returns
    -------
    PlaneFit
    """
    ref = reference_azimuth(P, s)
    Y = running_integral(ref.sigma, ref.azimuth)
    shape = segment(ref.sigma, Y, SEGMENT_RMS_FRACTION * tol_m, HORIZONTAL_KINDS)
    (offset, azimuth0), shape = fit_values(ref.sigma, Y, shape, integrations=2)
    shape = _bounded(shape, kappa_max, min_length_m)
    z0 = _start(ref.z[0], offset, azimuth0)

    def fit(shape: Shape, warm: PlaneFit | None) -> PlaneFit:
        if warm is None:
            z, azimuth, guess = z0, azimuth0, s
        else:
            z, azimuth, shape = _follow(warm.curve, shape)
            shape, guess = _bounded(shape, kappa_max, min_length_m), warm.s
        return fit_plane(P, guess, shape, z0=z, azimuth0=azimuth, w_of_s=w_of_s,
                         tol_m=tol_m, kappa_max=kappa_max, min_length_m=min_length_m)

    result = refine(fit, shape, tol_m, min_length_m=min_length_m, continuous=False,
                    progress=progress)
    result = simplify(fit, result, tol_m, max_fits=max_fits)
    return prune(fit, result, tol_m, continuous=False, max_fits=max_fits)
