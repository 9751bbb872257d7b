"""Noise of the gnss-only filter's rows on real data, beyond each row's own σ.

* Errors correlated from epoch to epoch (code multipath while the vehicle is slow or
  stopped): the variance inflation of `correlation_inflation` over the correlation time of
  `correlation_time_s` (``NavigatorConfig.pseudorange_correlation_s`` and ``_m``);
* the velocity's angle to the track (a map's heading error, a vehicle that does not follow
  the fitted line): one angle per epoch, the range-rate covariance of
  `heading_covariance_mps2`, of σ `heading_sigma_rad` (``NavigatorConfig.track_heading_sigma_rad``
  and ``track_heading_curvature_m``), inflated by `heading_inflation` for an angle that
  lasts over a distance (``track_heading_correlation_m``).

The filter that uses them is `railnav.filters.gnss_only.GnssOnlyFilter`; the slow part of the
code errors, which no inflation models, is `railnav.filters.code_bias`. The constrained
(inertial) filter inflates its pseudoranges alike (`pseudorange_inflation` at its prior's
speed, `railnav.filters.constrained.ConstrainedFilter`).
"""
from __future__ import annotations

import math

import numpy as np
import numpy.typing as npt

from railnav.filters.gnss_rows import TRACK_ROW_NAMES
from trackmodel.earth import WGS84

__all__ = ["correlation_time_s", "correlation_inflation", "pseudorange_inflation",
           "epoch_interval_s", "heading_covariance_mps2", "heading_inflation",
           "heading_sigma_rad", "robust_heading_sigma_rad"]

Array = npt.NDArray[np.float64]


def correlation_time_s(correlation_s: float, correlation_m: float, speed_mps: float) -> float:
    """The pseudorange errors' correlation time at a speed: ``min(τ, d / |v|)``.

    Code multipath is a function of where the antenna is among the reflectors: standing,
    it repeats epoch after epoch (correlation time τ, set by the satellites' slow motion);
    moving, it decorrelates over a distance ``d`` travelled. Measured on the urban drive
    (``benchmarks/results/real_pieces.json``, every piece): with τ alone (20 s) the filter
    held a start-up error of 5-9 m for a minute while the car drove at 5 m/s (leg 1
    part 4: horizontal RMS 5.36 m against single-point 3.87 m); with ``d`` = 20 m as
    well, 3.50 m, and the RMS is below the single-point RMS on every piece.

    Parameters
    ----------
    correlation_s : float
        τ, s (0: white).
    correlation_m : float
        ``d``, m (0: τ alone).
    speed_mps : float
        ``v``, m/s (signed).

    Returns
    -------
    float
        s.
    """
    speed = abs(float(speed_mps))
    if correlation_m <= 0.0 or speed * correlation_s <= correlation_m:
        return float(correlation_s)
    return float(correlation_m) / speed


def correlation_inflation(correlation_s: float, interval_s: float) -> float:
    """Variance factor ``(1 + ρ)/(1 − ρ)``, ``ρ = exp(−Δt/τ)``, for errors correlated over τ.

    The variance of the mean of ``n`` samples of a first-order Gauss–Markov sequence (step
    ``Δt``, correlation time ``τ``) is ``(1 + ρ)/(1 − ρ)`` times that of ``n`` white samples
    for ``n ≫ τ/Δt``; a filter fed the sequence as white noise of that inflated variance
    gets the right weight for long averages.

    Parameters
    ----------
    correlation_s : float
        τ, s (0: white, factor 1).
    interval_s : float
        Δt, the epoch interval, s (> 0).

    Returns
    -------
    float
        >= 1.
    """
    if correlation_s <= 0.0:
        return 1.0
    rho = float(np.exp(-interval_s / correlation_s))
    return (1.0 + rho) / (1.0 - rho)


def pseudorange_inflation(config, speed_mps: float, interval_s: float) -> float:
    """The pseudorange variance factor at a speed: `correlation_inflation` of
    `correlation_time_s` (``config.pseudorange_correlation_s`` and ``_m``; 1 when the
    former is 0: white errors, a simulated trip).

    Parameters
    ----------
    config : railnav.NavigatorConfig
    speed_mps : float
        The prior's ``v`` (signed), m/s.
    interval_s : float
        Δt, the epoch interval (`epoch_interval_s`), s.

    Returns
    -------
    float
        >= 1.
    """
    return correlation_inflation(
        correlation_time_s(config.pseudorange_correlation_s, config.pseudorange_correlation_m,
                           speed_mps), interval_s)


def epoch_interval_s(gnss) -> float:
    """Δt of `correlation_inflation` for a GNSS data set, s: its nominal ``interval_s`` where
    it has one (a streamed run's epochs, `railnav.navigation.streaming`), else the median
    interval of its epochs' ``time_s`` (`railnav.filters.gnss_epochs.GnssEpochs`); 1 with
    fewer than two epochs or none."""
    nominal = getattr(gnss, "interval_s", None)
    if nominal is not None:
        return float(nominal)
    times = getattr(gnss, "time_s", None)
    if times is None or len(times) < 2:
        return 1.0
    return float(np.median(np.diff(times)))


#: Columns of a range-rate row's parameters (`railnav.filters.gnss_rows.range_rate_parameters`
#: of `railnav.filters.gnss_rows.track_rows`): the reference point, the tangent, the satellite.
_R_REF = slice(1, 4)
_T_REF = slice(4, 7)
_SAT_POS = slice(len(TRACK_ROW_NAMES), len(TRACK_ROW_NAMES) + 3)


_K_REF = slice(7, 10)


def _heading_projections(p: Array) -> Array:
    """``c_i = e_i·n`` of range-rate rows: the line of sight to each satellite on the
    track's horizontal normal at the rows' reference point (`heading_covariance_mps2`)."""
    r = p[0, _R_REF]
    up = r / np.array([1.0, 1.0, (1.0 - WGS84.f) ** 2])    # the ellipsoid's normal at r
    normal = np.cross(up, p[0, _T_REF])     # ⊥ the tangent and the up: horizontal
    normal = normal / np.linalg.norm(normal)
    los = p[:, _SAT_POS] - r
    return (los @ normal) / np.linalg.norm(los, axis=1)


def heading_covariance_mps2(p: Array, speed_mps: float, sigma_rad: float) -> Array:
    """Range-rate covariance of a velocity off the track's heading: ``(σ_ψ v)² c cᵀ``.

    The antenna's velocity is ``v (t + ψ n)``, ``n`` the track's horizontal normal and ψ
    an angle of σ_ψ (small), one for the epoch: the range rate along the line of sight
    ``e_i`` errs by ``v ψ c_i``, ``c_i = e_i·n``, the same ψ in every row. The filter's
    model is ``v t(s)``; this is what it leaves out
    (`railnav.NavigatorConfig.track_heading_sigma_rad`). The angle to the track's grade is
    left out: heights are smooth (on the urban drive the isotropic variant,
    ``(σ_ψ v)² (1 − (e·t)²)``, also cost the Doppler rows of the high satellites their
    weight). Taken as independent row variances (the diagonal alone), ψ averages out over
    the satellites: on the urban drive the filter then drew ``s`` from the Doppler rows
    through the curvature in every corner (``benchmarks/bench_real_pieces.py``, with the
    slow code error's state: leg 1 part 4 horizontal RMS 6.13 m with the diagonal,
    3.09 m with the covariance; epochs beyond 3σ_s on the nine pieces 88 with the
    diagonal, 53 with it).

    Parameters
    ----------
    p : ndarray, shape (N, k)
        Range-rate row parameters (`railnav.filters.gnss_rows.range_rate_parameters` with
        the `railnav.filters.gnss_rows.track_rows` part: reference point, tangent, then the
        satellite's position; ECEF).
    speed_mps : float
        ``v`` (signed), m/s.
    sigma_rad : float
        σ_ψ, rad.

    Returns
    -------
    ndarray, shape (N, N)
        (m/s)².
    """
    c = (sigma_rad * float(speed_mps)) * _heading_projections(p)
    return np.outer(c, c)


def heading_inflation(correlation_s: float, correlation_m: float, speed_mps: float,
                      interval_s: float) -> float:
    """Factor on the range-rate rows' heading covariance (`heading_covariance_mps2`) for a
    heading error correlated over a distance: `correlation_inflation` of
    `correlation_time_s` (``min(τ, d / |v|)``), 1 when `correlation_m` is 0
    (`railnav.NavigatorConfig.track_heading_correlation_m`).

    Parameters
    ----------
    correlation_s : float
        τ, s: the cap standing (the pseudoranges' correlation time; 0: white, factor 1).
    correlation_m : float
        d, m (0: off, factor 1).
    speed_mps : float
        ``v`` (signed), m/s.
    interval_s : float
        Δt, the epoch interval, s (> 0).

    Returns
    -------
    float
        >= 1.
    """
    if correlation_m <= 0.0:
        return 1.0
    return correlation_inflation(correlation_time_s(correlation_s, correlation_m, speed_mps),
                                 interval_s)


def heading_sigma_rad(p: Array, sigma_rad: float, curvature_m: float) -> float:
    """σ_ψ where the track curves: ``√(σ_ψ² + (κ d)²)``, κ = ``|dt/ds|`` at the rows'
    reference point (`railnav.NavigatorConfig.track_heading_curvature_m`: d, m).

    Parameters
    ----------
    p : ndarray, shape (N, k)
        Range-rate row parameters (`heading_covariance_mps2`).
    sigma_rad : float
        σ_ψ, rad.
    curvature_m : float
        d, m (0: σ_ψ).

    Returns
    -------
    float
        rad.
    """
    if curvature_m <= 0.0:
        return float(sigma_rad)
    kappa = float(np.linalg.norm(p[0, _K_REF]))
    return math.hypot(float(sigma_rad), kappa * float(curvature_m))


def robust_heading_sigma_rad(innovation_mps: Array, H: Array, P: Array, R_mps2: Array,
                             p: Array, speed_mps: float, sigma_rad: float, k: float) -> float:
    """σ_ψ of one epoch with its heading angle Huber-weighted at the prior.

    The angle between the vehicle's velocity and the track is heavier-tailed than a
    Gaussian of σ_ψ: where a car turns in a street corner tighter than the fitted line
    follows, or turns round, its velocity is tens of degrees off the track's tangent for
    seconds, and the range-rate rows, taken at σ_ψ, move ``s`` by ``δψ/κ`` along the
    curvature. The epoch's angle is estimated from its range-rate innovations at the
    prior, by generalised least squares on the rows' heading direction ``g = v c``
    (`heading_covariance_mps2`'s ``c``) with the innovation covariance of everything but
    the angle, ``S₀ = H P Hᵀ + R`` (the prior's ``s``, speed and clock drift: a mismatch
    that an error of ``s`` along the curvature explains stays with the prior):
    ``ψ̂ = gᵀS₀⁻¹ν / gᵀS₀⁻¹g``, of variance ``σ_ψ² + 1/(gᵀS₀⁻¹g)`` under the model. Its
    normalised value ``r`` gets Huber's weight (`railnav.filters.robust_rows`): the
    angle's variance becomes ``σ_ψ² + (max(1, r/k) − 1)(σ_ψ² + 1/gᵀS₀⁻¹g)``, so that it
    enters the update at ``√(k r)`` instead of ``r``.

    ``NavigatorConfig.track_heading_huber_k`` = k, default 4: the smallest of 1.5, 2.5,
    3.5, 4 and 5 that leaves the 3-minute excerpt (issue 7's test,
    ``tests/railnav/jobs/test_real_data.py``: horizontal RMS 0.453 / 0.491 of
    single-point's, GPS / GPS+Galileo, against 0.455 / 0.491 without; 1.5 gave 0.488 /
    0.540). There the angle is within 4σ at 99 % of the epochs (3 % beyond 3.5σ); at
    the starts of the urban drive's pieces cut in corners of < 20 m radius it is 5-11σ,
    while the car turns round 5-8σ. On those pieces (``benchmarks/bench_real_pieces.py``)
    leg 1 part 5, which starts in such a corner, goes from 1.76 / 3.68 to 0.78 / 2.27 m
    horizontal RMS / max (single-point 2.48 / 3.11; its first update had put ``s`` 6.9 m
    before the track's start, 3.7σ), and the epochs beyond 3σ_s from 57 to 49 of 952
    (the U-turn 14 to 7). It does not stop a correlated mismatch that the prior's σ_s
    can explain along the curvature (the U-turn's car driving back through leg 2's
    curve 4-8° off the line for 4 s: 4.4 m at σ_s 0.76).

    Parameters
    ----------
    innovation_mps : ndarray, shape (N,)
        Range-rate innovations at the prior, m/s.
    H : ndarray, shape (N, n)
        Their Jacobian.
    P : ndarray, shape (n, n)
        Prior covariance.
    R_mps2 : ndarray, shape (N,)
        The rows' own variances (without the heading's), (m/s)².
    p : ndarray, shape (N, k)
        Range-rate row parameters (`heading_covariance_mps2`).
    speed_mps : float
        ``v`` (signed), m/s.
    sigma_rad : float
        σ_ψ of the epoch (`heading_sigma_rad`), rad.
    k : float
        Huber threshold, in σ of ψ̂ (> 0).

    Returns
    -------
    float
        rad, >= `sigma_rad`.
    """
    g = float(speed_mps) * _heading_projections(p)
    S0 = H @ P @ H.T + np.diag(R_mps2)
    try:
        w = np.linalg.solve(S0, g)
    except np.linalg.LinAlgError:
        return float(sigma_rad)
    information = float(g @ w)
    if not information > 0.0:
        return float(sigma_rad)
    psi = float(w @ innovation_mps) / information
    variance = sigma_rad ** 2 + 1.0 / information
    scale = max(1.0, abs(psi) / math.sqrt(variance) / k)
    return math.sqrt(sigma_rad ** 2 + (scale - 1.0) * variance)
