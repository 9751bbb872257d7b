r"""The track geometry's share of the pseudo-observation's uncertainty when ``s`` is uncertain.

The accelerometer pseudo-observation predicts the centripetal acceleration across the
track, ``v² P⊥ du/ds(s)``, at the estimated ``s`` and linearizes it there
(`strapdown.reduced`: ``du/ds(s) ≈ du/ds(s_ref) + d²u/ds²(s_ref) (s − s_ref)``). Where the
geometry is not linear within the uncertainty of ``s`` — at the joints of sections, where
the curvature steps (an arc or a vertical curve without transition) or kinks (the ends of
a clothoid) — the linearized EKF takes a tiny pseudo-observation noise at face value and
explains the mismatch by the wrong states: during a GNSS outage an estimate a few metres
ahead of the truth "sees" a vertical curve start 0.1 s early, and with a navigation-grade
accelerometer (1 mm/s² per 100-Hz sample against v²Δκ ≈ 0.04 m/s²) it then drags ``v`` and
``s`` back by tens of metres while σ_s stays at a metre.

The remedy is statistical linearization (Gelb 1974, §6.2; the "consider" view of the
geometry). With ``s ~ N(s_ref, σ_s²)`` and σ_s above a few grid steps, the curvature
vector's value and slope in ``p`` become its mean and regression slope over that prior
(`statistical_parameters`), so that a curve the estimate may already be in is predicted in
proportion and moves ``s``; and the part of the predicted centripetal term that the line
does not carry,

``r(s') = du/ds(s') − (du/ds)_lin − (d²u/ds²)_lin (s' − s_ref)``,

is an error of the pseudo-observation with variance ``v⁴ E[(P⊥ r)²]`` (per component,
lateral and normal), evaluated here over the prior on the track grid (`railnav.filters.track_grid`)
with a midpoint rule of `QUADRATURE_NODES` points over ±4σ (a step's weight to within
``φ(ξ)·Δξ/2 ≤ 0.04``; Gauss–Hermite rules, exact for polynomials, resolve steps worse).
It is zero on straights, arcs and clothoids alike when σ_s is small against the distance
to a joint (with GNSS, σ_s ≈ 0.5 m), so the information
the filter draws from the track is untouched there, and it grows only where the geometry
the filter assumes is really in doubt. The variances enter the engine as the independent
continuous-measurement noise (`ekf.InputSeries.r_c`, a density: variance × step).

**The remainder is not white.** ``r`` is a function of where the train is against the
feature, and of the error of ``s``, which both change little from one IMU sample to the
next: while the feature passes through the window of the prior, the remainder keeps its
sign and size for about the time the train needs to run across that window. Taken as
white noise of variance ``v⁴ E[r²]`` per 100-Hz sample it would be averaged down as if
each sample were independent, and a curvature or grade feature crossed during an outage
would lend ``s`` the information of a hundred independent looks per second (measured:
σ_s from 9.6 m to 0.2 m across a vertical curve and a transition of ``curvy`` in a 20-min
tactical outage, while the error grew to 35 m). `remainder_correlation_s` gives the
correlation time of the remainder, ``2 σ_s / |v|`` (the time to cross the ±1σ window;
at least one sample step, at most `MAX_CORRELATION_S`), and the filter uses the density
``v⁴ E[r²] · T_c`` (the white density with the same integral over the crossing as a
noise of that variance held for ``T_c``).

**Interval means.** An IMU sample is the mean of the input over its interval
(`railnav.simulation.joint_average`: what increment and decimating sensors deliver), so
what a sample's centripetal term really is at ``s'`` is the mean of ``du/ds`` over the
distance run in that interval, ``s' ± |v| dt/2``, not its value at ``s'``: across a
curvature step, a blend of the two sides, which the local expansion on either side does
not carry. With ``interval_m = |v| dt`` the remainder is taken for that mean
(`INTERVAL_NODES` points per interval, on the grid whose nodes beside each step keep every
point on its side), and the prior's nodes are centred on the predicted ``s`` itself
(``s_m``) rather than on the grid node of its parameters, which lies up to half a grid step
(0.25 m) away: at 100 m/s on a 100-m arc with σ_s = 0.11 m, a window centred 0.19 m
behind the predicted ``s`` missed the exit that the sample's interval straddled, and the
filter took a 4.4 m/s² blend at a density of 1e-8 (m/s²)²·s (seed 72 of the circle:
0.58 m and 8 mrad in one step, NEES 1100 after the exit; `docs/consistency-ablations.md`,
stop 33). Without the interval the same circle's NEES was 92 over 90 seeds. Where the
prior's window and the interval meet a horizontal curvature step (the grid's
`curvature_steps`), the blend is a ramp over ``|v| dt`` in ``s``, which neither side's
expansion carries: those samples' parameters are the interval means' statistical
linearization over the prior (their mean and regression slope on the prior's exact
offsets: the grid's nodes are coarser than σ_s there), so a straddling sample is
predicted as a blend and tells ``s`` where the step is (circle, seeds 11–100 with the
joint on a sample: beyond 3σ_s 0.49 → 0.08 %). Grade-rate steps are left as point values
(the grid has no nodes beside them, `railnav.filters.track_grid`).

Limit: this is still one Gaussian. When σ_s is tens of metres at the onset of a curve's
centripetal acceleration (a long outage with a MEMS IMU), the filter can explain the
onset with its attitude instead of ``s`` and run away (notebooks/05, MEMS 300 s).
"""
from __future__ import annotations

import numpy as np
import numpy.typing as npt

from strapdown.reduced import TRACK_PARAMETER_NAMES, cross_track_basis

__all__ = ["statistical_parameters", "straight_priors", "remainder_correlation_s",
           "angle_statistics",
           "MAX_CORRELATION_S",
           "QUADRATURE_NODES", "INTERVAL_NODES",
           "QUADRATURE_HALF_WIDTH", "MAX_OFFSET_M", "STATISTICAL_MIN_SIGMA_M"]

Array = npt.NDArray[np.float64]

#: Points of the midpoint rule over a sample's interval (`statistical_parameters`'s
#: ``interval_m``).
INTERVAL_NODES = 8
#: Points of the midpoint rule over ±`QUADRATURE_HALF_WIDTH` standard deviations.
QUADRATURE_NODES = 41
QUADRATURE_HALF_WIDTH = 4.0
#: Offsets from ``s_ref`` are capped at this distance, m (a σ_s of kilometres smears every
#: curvature the track has; the cap only bounds the grid window).
MAX_OFFSET_M = 2000.0
#: Above this σ_s (m) the curvature vector is linearized statistically over the prior:
#: four grid steps (`railnav.filters.track_grid.GRID_STEP_M`), so that the ±4σ nodes are distinct.
STATISTICAL_MIN_SIGMA_M = 2.0
#: Longest correlation time given to the remainder, s (a train crawling past a feature
#: with a large σ_s: the remainder variance there is ~v⁴, negligible anyway).
MAX_CORRELATION_S = 10.0

_XI = np.linspace(-QUADRATURE_HALF_WIDTH, QUADRATURE_HALF_WIDTH, QUADRATURE_NODES)
_W = np.exp(-0.5 * _XI ** 2)
_W = _W / _W.sum()
_U = slice(TRACK_PARAMETER_NAMES.index("u_E"), TRACK_PARAMETER_NAMES.index("u_U") + 1)
_DU = slice(TRACK_PARAMETER_NAMES.index("du_E_ds"), TRACK_PARAMETER_NAMES.index("du_U_ds") + 1)
_D2U = slice(TRACK_PARAMETER_NAMES.index("d2u_E_ds2"),
             TRACK_PARAMETER_NAMES.index("d2u_U_ds2") + 1)


def statistical_parameters(grid, params: Array, *, sigma_s_m: float, speed_mps: float,
                           interval_m: float = 0.0, s_m: Array | None = None
                           ) -> tuple[Array, Array]:
    """Track parameters linearized over the prior of ``s``, and what they leave out.

    Where the prior is wider than the grid (``σ_s`` > `STATISTICAL_MIN_SIGMA_M`), the
    curvature vector's value and slope in ``p`` are replaced by their statistical
    linearization over ``s' ~ N(s_ref, σ_s²)`` (Gelb 1974, §6.2): the mean
    ``E[du/ds(s')]`` and the regression slope ``Cov(du/ds(s'), s') / Var(s')``. A
    GNSS-less estimate a hundred metres short of a curve then predicts the curve's share
    of centripetal acceleration and gets a slope with respect to ``s`` (the curve's onset
    moves ``s``) instead of a zero slope that leaves the lateral acceleration to the
    attitude. With a narrow prior the local expansion is kept.

    Parameters
    ----------
    grid : railnav.filters.track_grid.TrackParameterGrid
        The track's parameter grid.
    params : ndarray, shape (M, 16)
        The samples' track parameters (`strapdown.reduced.TRACK_PARAMETER_NAMES`).
    sigma_s_m : float
        Standard deviation of the along-track distance, m.
    speed_mps : float
        Speed, m/s.
    interval_m : float
        The distance run over one IMU sample's interval, ``|v| dt``, m: a sample is the
        mean over its interval (`railnav.simulation.joint_average`), so the remainder
        is that of the curvature vector's mean over ``s' ± interval_m/2`` (the module
        docstring's "Interval means"); 0: point values.
    s_m : ndarray, shape (M,), optional
        The prior's mean of ``s`` at each sample, m (the predicted path); default: the
        parameters' grid nodes ``s_ref``, up to half a grid step from it.

    Returns
    -------
    params : ndarray, shape (M, 16)
        The parameters the filter uses (a copy when changed).
    variance : ndarray, shape (M, 2)
        ``v⁴ E[(l·r)²]`` and ``v⁴ E[(n·r)²]`` of the remainder ``r`` of the curvature
        vector about the linearization used, (m/s²)².
    """
    m = params.shape[0]
    offsets = np.minimum(np.maximum(sigma_s_m * _XI, -MAX_OFFSET_M), MAX_OFFSET_M)
    centre = params[:, 0] if s_m is None else np.asarray(s_m, dtype=float)
    half = 0.5 * interval_m
    if _inside_one_loxodrome(grid.track, centre.min() + offsets[0] - half,
                             centre.max() + offsets[-1] + half):
        return params, np.zeros((m, 2))
    du, delta = _nodes(grid, params, offsets, centre)
    if sigma_s_m > STATISTICAL_MIN_SIGMA_M:
        params = params.copy()
        mean_delta = delta @ _W
        centred = delta - mean_delta[:, None]
        var_delta = centred ** 2 @ _W
        slope = np.einsum("mki,mk,k->mi", du, centred, _W) / var_delta[:, None]
        params[:, _DU] = np.einsum("mki,k->mi", du, _W) - slope * mean_delta[:, None]
        params[:, _D2U] = slope
    near = _near_a_step(grid, centre + offsets[0] - half, centre + offsets[-1] + half) \
        if interval_m > 0.0 else np.zeros(m, dtype=bool)
    if not near.any():
        return params, _remainder_variance(params, du, delta, speed_mps)
    box = du.copy()
    box[near] = _interval_means(grid, params[near], offsets, interval_m, centre[near])
    params, delta = _across_a_step(params, box, delta, centre, offsets, near)
    return params, _remainder_variance(params, box, delta, speed_mps)


def straight_priors(tracks, s_m: Array, *, sigma_s_m: Array, interval_m: Array
                    ) -> list[bool]:
    """For each row k of a bank's predicted paths `s_m` (shape (K, M), m), whether
    `statistical_parameters` of ``tracks[k]``'s grid with ``sigma_s_m[k]``,
    ``interval_m[k]`` and ``s_m[k]`` takes its short cut (the prior's window inside one
    straight section: the parameters unchanged, the variance zero): the window's ends
    of all rows computed together (the same operations), each row's sections looked up
    on its own track."""
    lo = np.minimum(np.maximum(sigma_s_m * _XI[0], -MAX_OFFSET_M), MAX_OFFSET_M)
    hi = np.minimum(np.maximum(sigma_s_m * _XI[-1], -MAX_OFFSET_M), MAX_OFFSET_M)
    half = 0.5 * interval_m
    lo = np.minimum.reduce(s_m, axis=1) + lo - half
    hi = np.maximum.reduce(s_m, axis=1) + hi + half
    return [_inside_one_loxodrome(track, a, b)
            for track, a, b in zip(tracks, lo.tolist(), hi.tolist())]


def _near_a_step(grid, lo: Array, hi: Array) -> Array:
    """Which samples' windows ``[lo, hi]`` (m, shape (M,)) hold a horizontal curvature step
    of the grid's track (`TrackParameterGrid.curvature_steps`), shape (M,)."""
    steps = grid.curvature_steps
    return np.any((steps[None, :] > lo[:, None]) & (steps[None, :] < hi[:, None]), axis=1)


def _across_a_step(params: Array, box: Array, delta: Array, centre: Array, offsets: Array,
                   rows: Array) -> tuple[Array, Array]:
    """The parameters of `rows` (whose prior and interval meet a curvature step)
    linearized statistically over the prior (module docstring, "Interval means"): the
    interval means' regression on the prior's offsets, exact ones (the grid's nodes are
    coarser than σ_s there); those offsets as the rows' ``delta``."""
    params = params.copy()
    d_q = (centre - params[:, 0])[:, None] + offsets[None, :]
    mean_d = d_q @ _W
    centred = d_q - mean_d[:, None]
    variance = np.maximum(centred ** 2 @ _W, np.finfo(float).tiny)      # σ_s = 0: no slope
    slope = np.einsum("mki,mk,k->mi", box, centred, _W) / variance[:, None]
    params[rows, _DU] = (np.einsum("mki,k->mi", box, _W) - slope * mean_d[:, None])[rows]
    params[rows, _D2U] = slope[rows]
    return params, np.where(rows[:, None], d_q, delta)


def remainder_correlation_s(*, sigma_s_m: float, speed_mps: float, step_s: float) -> float:
    """Correlation time of the geometry remainder (module docstring), s.

    Parameters
    ----------
    sigma_s_m : float
        σ of ``s``, m.
    speed_mps : float
        |speed|, m/s.
    step_s : float
        The sample step, s (the shortest correlation time: one sample).

    Returns
    -------
    float
        ``clip(2 σ_s / |v|, step_s, max(step_s, MAX_CORRELATION_S))``.
    """
    step_s = max(float(step_s), 0.0)
    if speed_mps <= 0.0:
        return max(step_s, MAX_CORRELATION_S)
    return min(max(2.0 * float(sigma_s_m) / float(speed_mps), step_s),
               max(step_s, MAX_CORRELATION_S))


def angle_statistics(angles, s0_m: float, sigma_s_m: float) -> tuple[Array, Array, Array]:
    """Track angles as functions of an uncertain ``s``: line and remainder over the prior.

    The attitude rows (`railnav.filters.attitude_rows`) compare the body's yaw and pitch with
    the chord's azimuth and elevation at ``s``, ``g(s)``, linearized about the prior's
    ``s₀``. Where the geometry bends within ±σ_s (the onset of a curve, a vertical curve)
    the line ``g(s₀) + g'(s₀)(s − s₀)`` is wrong by far more than the rows' milliradian σ
    once σ_s is metres, and a row taken at face value then turns the attitude, or ``s``,
    the wrong way. As for the curvature pseudo-observation (`statistical_parameters`):
    above `STATISTICAL_MIN_SIGMA_M` the line is the statistical linearization over
    ``s' ~ N(s₀, σ_s²)`` (mean and regression slope); at any σ_s the remainder
    ``g(s') − line(s')`` has the variance returned, to be added to the row's (the midpoint
    rule of `QUADRATURE_NODES` points over ±4σ, offsets capped at `MAX_OFFSET_M`).

    Parameters
    ----------
    angles : callable
        ``angles(s)`` for ``s`` of shape (K,), m: the angles, shape (K, J), rad, continuous
        in ``s`` (azimuths unwrapped about the value at ``s₀``).
    s0_m, sigma_s_m : float
        The prior's mean and standard deviation of ``s``, m.

    Returns
    -------
    value, slope, variance : ndarray, shape (J,)
        The line's value at ``s₀`` (rad) and slope (rad/m), and the remainder's variance
        (rad²); with σ_s ≤ `STATISTICAL_MIN_SIGMA_M` the local value and slope (central
        difference over ±σ_s/100, at least 1 mm) of ``angles``.
    """
    sigma = max(float(sigma_s_m), 0.0)
    offsets = np.minimum(np.maximum(sigma * _XI, -MAX_OFFSET_M), MAX_OFFSET_M)
    g = np.asarray(angles(float(s0_m) + offsets), dtype=float)
    if sigma > STATISTICAL_MIN_SIGMA_M:
        mean_d = offsets @ _W
        centred = offsets - mean_d
        slope = (centred * _W) @ g / (centred ** 2 @ _W)
        value = _W @ g - slope * mean_d
    else:
        h = max(1e-2 * sigma, 1e-3)
        ends = np.asarray(angles(float(s0_m) + np.array([-h, 0.0, h])), dtype=float)
        value, slope = ends[1], (ends[2] - ends[0]) / (2.0 * h)
    remainder = g - (value[None, :] + slope[None, :] * offsets[:, None])
    return value, slope, _W @ remainder ** 2


def _inside_one_loxodrome(track, s_lo: float, s_hi: float) -> bool:
    """Whether [s_lo, s_hi] (m, clipped to the track) lies in one straight section: its
    tangent is smooth to all orders there (a loxodrome at constant grade), and the part the
    second-order expansion leaves out is ~(Δs/R_earth)³, far below any accelerometer."""
    length = track.length_m         # np.clip's bounds, in floats (`Track.section_at`)
    k_lo = track.section_at(min(max(float(s_lo), 0.0), length))
    k_hi = track.section_at(min(max(float(s_hi), 0.0), length))
    # the section's is_loxodrome, from the track's cached lists (`Track.table_lists`)
    return bool(k_lo == k_hi and track.table_lists[k_lo][7])


def _nodes(grid, params: Array, offsets: Array, centre: Array | None = None
           ) -> tuple[Array, Array]:
    """Curvature vectors (M, K, 3), 1/m, at the grid nodes nearest ``centre + offsets``
    (default centre: ``s_ref``), and the nodes' distances from ``s_ref`` (M, K), m."""
    m, s_ref = params.shape[0], params[:, 0]
    centre = s_ref if centre is None else centre
    s_q = np.minimum(np.maximum(centre[:, None] + offsets[None, :], 0.0), grid.track.length_m)
    at_q, _ = grid.parameters(s_q.ravel())
    at_q = at_q.reshape(m, offsets.size, -1)
    return at_q[:, :, _DU], at_q[:, :, 0] - s_ref[:, None]


def _interval_means(grid, params: Array, offsets: Array, interval_m: float,
                    centre: Array) -> Array:
    """The curvature vectors' means over ``centre + offsets ± interval_m/2`` (M, K, 3), 1/m,
    by the midpoint rule of `INTERVAL_NODES` points (a step's share to 1/`INTERVAL_NODES`:
    the grid's nodes beside each curvature step put every point on its own side)."""
    box = interval_m * ((np.arange(INTERVAL_NODES) + 0.5) / INTERVAL_NODES - 0.5)
    du, _ = _nodes(grid, params, (offsets[:, None] + box[None, :]).ravel(), centre)
    return du.reshape(params.shape[0], offsets.size, INTERVAL_NODES, 3).mean(axis=2)


def _remainder_variance(params: Array, du: Array, delta: Array, speed_mps: float) -> Array:
    """``v⁴ E[(P⊥ r)²]`` per component for ``r = du/ds(s') − (du_ref + d2u_ref δ)``."""
    remainder = du - (params[:, None, _DU] + params[:, None, _D2U] * delta[..., None])
    lateral, normal = cross_track_basis(params[:, _U])
    r_l = np.einsum("mki,mi->mk", remainder, lateral)
    r_n = np.einsum("mki,mi->mk", remainder, normal)
    return speed_mps ** 4 * np.stack([r_l ** 2 @ _W, r_n ** 2 @ _W], axis=-1)


def _quadrature(grid, params: Array, offsets: Array, speed_mps: float) -> Array:
    """The remainder variance about the local expansion in `params`, by the midpoint rule
    at the given offsets (the general path that `_inside_one_loxodrome` short-cuts)."""
    du, delta = _nodes(grid, params, offsets)
    return _remainder_variance(params, du, delta, speed_mps)
