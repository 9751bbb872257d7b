"""Vertical profile: heights along s by constant grades joined by vertical curves.

Model: ``h(s) = h0 + ∫₀ˢ sin ϑ(σ) dσ`` with the elevation ``ϑ`` a continuous typed
piecewise-linear profile (`trackmodel.pieces`: `CONST` grades and `RAMP` vertical curves;
no jump, so the 3-D tangent is continuous). The fit mirrors the horizontal one: a first
segmentation of the heights (`trackmodel.segment`, degree 1 = grade, 2 = vertical curve),
then Levenberg–Marquardt on the height residuals at the points' (fixed) along-track
positions, adding vertical curves where points are outside ``vtol_m`` and removing pieces
while they stay inside (`trackmodel.knots`). Fitted elevations stay within
±`MAX_ELEVATION_RAD`.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import numpy.typing as npt
from scipy.integrate import cumulative_simpson

from trackmodel.knots import prune, refine
from trackmodel.lsq import levenberg_marquardt
from trackmodel.pieces import CONST, Layout, Shape
from trackmodel.segment import VERTICAL_KINDS, fit_values, segment

__all__ = ["Profile", "VerticalFit", "fit_vertical", "flat_profile"]

Array = npt.NDArray[np.float64]

#: Fitted elevations are kept within ±0.2 rad (20 % grade: beyond any railway or tramway).
MAX_ELEVATION_RAD = 0.1
GRID_STEP_M = 1.0
#: The first segmentation follows the heights within this fraction of ``vtol_m`` (RMS).
SEGMENT_RMS_FRACTION = 0.3
MAX_ITERATIONS = 20
#: Weak prior on the piece lengths (residual metres per metre of change), as horizontally.
LENGTH_PRIOR_WEIGHT = 0.01


@dataclass(frozen=True)
class Profile:
    """A vertical profile: the height at s = 0 and the elevation pieces.

    Attributes
    ----------
    shape : Shape
        Elevation pieces (lengths m, values rad).
    h0 : float
        Height at s = 0, m.
    """

    shape: Shape
    h0: float

    @property
    def knots(self) -> Array:
        """Piece ends along s, m."""
        return self.shape.pieces.knots

    def elevation_at(self, s: Array) -> Array:
        """``ϑ(s)``, rad (the end pieces extended)."""
        return self.shape.pieces.value(np.asarray(s, dtype=float))

    def height_at(self, s: Array) -> Array:
        """``h(s)``, m, by Simpson's rule on a grid (error far below a millimetre)."""
        s = np.asarray(s, dtype=float)
        lo = min(0.0, float(s.min(initial=0.0)))
        hi = max(float(self.knots[-1]), float(s.max(initial=0.0)))
        n = max(3, int(np.ceil((hi - lo) / GRID_STEP_M)) + 1)
        g = np.linspace(lo, hi, n)
        h = cumulative_simpson(np.sin(self.elevation_at(g)), dx=g[1] - g[0], initial=0.0)
        return self.h0 + np.interp(s, g, h - np.interp(0.0, g, h))


def flat_profile(length_m: float) -> Profile:
    """h = 0 with elevation 0 (a survey without heights)."""
    return Profile(Shape(Layout((CONST,)), np.array([length_m]), np.zeros(1)), 0.0)


@dataclass(frozen=True)
class VerticalFit:
    """A fitted profile with the points' positions (m) and height residuals (m)."""

    profile: Profile
    s: Array
    residual_m: Array

    @property
    def shape(self) -> Shape:
        return self.profile.shape


def _fit(s: Array, h: Array, shape: Shape, *, min_length_m: float) -> VerticalFit:
    """Least-squares profile of a layout: values by linear least squares, then
    Levenberg–Marquardt on h0, lengths and values."""
    (h0,), shape = fit_values(s, h, shape, integrations=1)
    layout, m = shape.layout, len(shape.kinds)
    x0 = np.concatenate([[h0], shape.lengths, np.clip(shape.values, -MAX_ELEVATION_RAD,
                                                      MAX_ELEVATION_RAD)])
    lengths0 = np.maximum(shape.lengths, min_length_m)

    def profile(x: Array) -> Profile:
        return Profile(Shape(layout, x[1:1 + m], x[1 + m:]), float(x[0]))

    def residuals(x: Array) -> Array:
        return np.concatenate([h - profile(x).height_at(s),
                               LENGTH_PRIOR_WEIGHT * (x[1:1 + m] - lengths0)])

    def jacobian(x: Array) -> Array:
        pc = profile(x).shape.pieces
        dL, da, db = pc.integral_jacobian(s)
        cos = np.cos(pc.value(s))[:, None]
        Jv = layout.value_jacobian(da, db)
        J = -np.column_stack([np.ones_like(s), dL * cos, Jv * cos])
        prior = np.zeros((m, J.shape[1]))
        prior[np.arange(m), 1 + np.arange(m)] = LENGTH_PRIOR_WEIGHT
        return np.vstack([J, prior])

    lower = np.concatenate([[-np.inf], np.full(m, min_length_m),
                            np.full(layout.n_values, -MAX_ELEVATION_RAD)])
    upper = np.concatenate([[np.inf], np.full(m, np.inf),
                            np.full(layout.n_values, MAX_ELEVATION_RAD)])
    x = levenberg_marquardt(residuals, jacobian, x0, lower, upper,
                            max_iterations=MAX_ITERATIONS)
    fitted = profile(x)
    return VerticalFit(fitted, s, h - fitted.height_at(s))


def fit_vertical(s: Array, h: Array, *, vtol_m: float, min_length_m: float,
                 max_fits: int) -> VerticalFit:
    """Fit a profile of grades and vertical curves to heights.

    Parameters
    ----------
    s : ndarray, shape (N,)
        Along-track positions of the points, m, non-decreasing from 0.
    h : ndarray, shape (N,)
        Their heights, m.
    vtol_m : float
        Height deviation the fit aims to stay within, m.
    min_length_m : float
        Shortest piece, m.
    max_fits : int
        Refits allowed to the pruning.

    Returns
    -------
    VerticalFit
    """
    shape = segment(s, h, SEGMENT_RMS_FRACTION * vtol_m, VERTICAL_KINDS, continuous=True)
    scale = s[-1] / shape.pieces.length
    shape = Shape(shape.layout, shape.lengths * scale, shape.values)

    def fit(shape: Shape, warm) -> VerticalFit:
        return _fit(s, h, shape, min_length_m=min_length_m)

    result = refine(fit, shape, vtol_m, min_length_m=min_length_m, continuous=True)
    return prune(fit, result, vtol_m, continuous=True, max_fits=max_fits)
