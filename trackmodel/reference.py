"""A smooth reference through a surveyed polyline: its azimuth along the chord length.

The points' plane coordinates are smoothed against their chord length by
`scipy.interpolate.make_smoothing_spline`; the penalty weight is chosen by the discrepancy
principle (the lateral residual RMS equals the noise level estimated from the points by
`noise_level`; generalised cross-validation nearly interpolates such surveys, whose chord
lengths carry the noise too). The reference azimuth ``A_ref(σ)`` every `SAMPLE_STEP_M`
feeds the first segmentation (`trackmodel.segment`).
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import numpy.typing as npt
from scipy.interpolate import make_smoothing_spline

__all__ = ["Reference", "noise_level", "reference_azimuth", "SAMPLE_STEP_M"]

Array = npt.NDArray[np.float64]
CArray = npt.NDArray[np.complex128]

#: Spacing of the reference samples, m.
SAMPLE_STEP_M = 2.0
#: Spacing (in the chord parameter) of the dense samples that give the reference's own
#: arc length, m: the samples are re-spaced by arc length (the chord length of noisy,
#: dense points at a stop is longer than the path).
FINE_STEP_M = 0.25
#: Median absolute deviation to the standard deviation of a normal distribution.
MAD_TO_SIGMA = 1.4826
#: Range of log10 λ searched (λ: the smoothing spline's penalty weight, m³) and bisections.
LOG_LAMBDA_RANGE = (-3.0, 12.0)
LAMBDA_BISECTIONS = 14
MIN_SPLINE_POINTS = 5


def noise_level(P: CArray) -> float:
    """Robust estimate of the lateral noise of the points, m.

    The offset ``e_i`` of each point from the chord of its neighbours is the noise plus a
    slowly varying curvature term; consecutive differences remove the latter and have the
    variance ``5 σ²`` (equal spacing), estimated by the median absolute deviation.
    """
    if len(P) < 4:
        return 0.0
    chord = P[2:] - P[:-2]
    offset = np.imag(np.conj(chord) * (P[1:-1] - P[:-2])) / np.maximum(np.abs(chord), 1e-9)
    d = np.diff(offset)
    return float(MAD_TO_SIGMA * np.median(np.abs(d - np.median(d))) / np.sqrt(5.0))


def _smoothing_spline(P: CArray, s: Array, sigma_m: float):
    """x(s), y(s) smoothing splines whose lateral residual RMS is `sigma_m` (bisection on
    log λ: the discrepancy principle)."""
    lo, hi = LOG_LAMBDA_RANGE
    best = None
    for _ in range(LAMBDA_BISECTIONS):
        mid = 0.5 * (lo + hi)
        sx = make_smoothing_spline(s, P.real, lam=10.0 ** mid)
        sy = make_smoothing_spline(s, P.imag, lam=10.0 ** mid)
        d = sx.derivative()(s) + 1j * sy.derivative()(s)
        r = np.imag(np.conj(d) * (P - sx(s) - 1j * sy(s))) / np.maximum(np.abs(d), 1e-12)
        if np.sqrt(np.mean(r * r)) > sigma_m:
            hi = mid
        else:
            lo, best = mid, (sx, sy)
    return best if best is not None else (sx, sy)


@dataclass(frozen=True)
class Reference:
    """Samples of the smooth reference.

    Attributes
    ----------
    sigma : ndarray, shape (K,)
        Positions along the reference's parameter (the chord length), m.
    z : ndarray of complex, shape (K,)
        Reference points, plane metres.
    azimuth : ndarray, shape (K,)
        Unwrapped azimuth, rad.
    noise_m : float
        The lateral noise of the points estimated by `noise_level`, m.
    s_points : ndarray, shape (N,)
        The reference's arc length at each point's chord length, m: a first guess of the
        points' positions along a curve that follows the reference.
    """

    sigma: Array
    z: CArray
    azimuth: Array
    noise_m: float
    s_points: Array


def reference_azimuth(P: CArray, s: Array, *, step_m: float = SAMPLE_STEP_M) -> Reference:
    """A smoothing spline through the points, sampled every `step_m` of its arc length.

    Parameters
    ----------
    P : ndarray of complex, shape (N,)
        Plane points (X east + i Y north), m, in order.
    s : ndarray, shape (N,)
        Their chord lengths, m, strictly increasing.

    Returns
    -------
    Reference
        Samples at ``sigma`` = the spline's own arc length.
    """
    noise = noise_level(P)
    fine = np.linspace(0.0, s[-1], max(3, int(np.ceil(s[-1] / FINE_STEP_M)) + 1))
    if len(s) >= MIN_SPLINE_POINTS:
        sx, sy = _smoothing_spline(P, s, noise)
        z_fine = sx(fine) + 1j * sy(fine)
    else:
        z_fine = np.interp(fine, s, P.real) + 1j * np.interp(fine, s, P.imag)
    arc = np.concatenate([[0.0], np.cumsum(np.abs(np.diff(z_fine)))])
    n = max(3, int(np.ceil(arc[-1] / step_m)) + 1)
    sigma = np.linspace(0.0, arc[-1], n)
    at = np.interp(sigma, arc, fine)                     # chord parameter of each sample
    if len(s) >= MIN_SPLINE_POINTS:
        z = sx(at) + 1j * sy(at)
        d = sx.derivative()(at) + 1j * sy.derivative()(at)
    else:
        z = np.interp(at, fine, z_fine.real) + 1j * np.interp(at, fine, z_fine.imag)
        dz = np.diff(P)
        d = dz[np.clip(np.searchsorted(s, at, side="right") - 1, 0, len(dz) - 1)]
    return Reference(sigma, z, np.unwrap(np.arctan2(d.real, d.imag)), noise,
                     np.interp(s, fine, arc))
