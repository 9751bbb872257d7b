r"""An IMU's lever arm: its specific force moved to the vehicle's reference point.

On a rigid body an accelerometer at ``r`` (body axes, from the reference point) measures
(Groves, *Principles of GNSS, Inertial and Multisensor Integrated Navigation*, 2013,
eq. 2.156 with the body rigid)::

    f_imu = f_ref + ω̇_ib × r + ω_ib × (ω_ib × r)

and the gyros measure the same ``ω_ib`` everywhere. `move_specific_force` applies it with
``r`` of either sign: ``-r`` turns an IMU at ``r`` into the reference point's (what the
filters mechanize: `railnav.filters.track_frame.LeverArms.imu_m`), ``+r`` makes an IMU at
``r`` from the reference point's (the simulator). ``ω̇`` is the time derivative of the
gyro rates averaged over `SMOOTHING_S` (a centred moving mean over as many samples on
either side, then central differences on the actual sample times): differencing raw samples would put the gyro noise, ``σ/dt``, on
the specific force. On a train ``ω̇`` is small (``v² dκ/ds`` at a transition, ~0.03 rad/s²
for 20 m/s into a 300-m curve over 50 m), but ``ω̇ × r`` is lateral for a forward offset
and the centripetal ``ω²r`` is along the track for one, so a 10-m offset gives 0.3 and
0.04 m/s²: worth compensating.
"""
from __future__ import annotations

from dataclasses import replace

import numpy as np
import numpy.typing as npt

from strapdown.errors import ImuInputError
from strapdown.imu import Imu

__all__ = ["move_specific_force", "SMOOTHING_S"]

Array = npt.NDArray[np.float64]

#: Averaging window of the rates before they are differentiated, s.
SMOOTHING_S = 0.2


def move_specific_force(imu: Imu, r_b_m, *, smoothing_s: float = SMOOTHING_S) -> Imu:
    """The IMU record of a point at ``r_b_m`` from the IMU's own position (module docstring).

    Parameters
    ----------
    imu : Imu
    r_b_m : array_like, shape (3,)
        The new point relative to the IMU, body axes (x forward, y left, z up), m.
    smoothing_s : float
        Averaging window of the rates for ``ω̇``, s (> 0).

    Returns
    -------
    Imu
        Same times and rates; the specific force at the new point. `imu` itself for a zero
        arm.
    """
    r = np.asarray(r_b_m, dtype=float).reshape(3)
    if not np.any(r):
        return imu
    if not (np.all(np.isfinite(r)) and smoothing_s > 0):
        raise ImuInputError(f"lever arm {r!r} and smoothing {smoothing_s!r} s must be finite")
    w = imu.omega_ib_b
    w_dot = _derivative(imu.time_s, _centred_mean(imu.time_s, w, smoothing_s))
    extra = np.cross(w_dot, r) + np.cross(w, np.cross(w, r))
    return replace(imu, f_b=imu.f_b + extra)


def _centred_mean(t: Array, values: Array, window_s: float) -> Array:
    """Mean of `values` (N, k) over the ``2n + 1`` samples centred on each sample, ``n``
    the half window in median steps (symmetric in samples: a mean of a linear rate is
    exact; fewer samples within ``n`` of the ends)."""
    n = int(round(0.5 * window_s / float(np.median(np.diff(t))))) if t.size > 1 else 0
    csum = np.vstack([np.zeros((1, values.shape[1])), np.cumsum(values, axis=0)])
    k = np.arange(t.size)
    half = np.minimum(n, np.minimum(k, t.size - 1 - k))    # stays symmetric at the ends
    lo, hi = k - half, k + half + 1
    return (csum[hi] - csum[lo]) / (hi - lo)[:, None]


def _derivative(t: Array, values: Array) -> Array:
    if t.size < 2:
        return np.zeros_like(values)
    return np.gradient(values, t, axis=0)
