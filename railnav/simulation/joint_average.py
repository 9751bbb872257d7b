r"""The simulated IMU across a rate-step joint: the mean over the sample's interval.

A real IMU does not deliver point samples of its input. Navigation and tactical units
output increments ``Δθ = ∫ω dt``, ``Δv = ∫f dt`` over each interval (the ring-laser and
fibre-optic gyros count the phase; `strapdown.imu_log` reads such a log as the mean rates
``Δ/dt`` stamped at the intervals' midpoints), and MEMS units average their internal
kHz samples in a decimation filter before they output a rate. Either way each output
is the mean of the true rate over an interval around its stamp, and the record keeps
the integral of the rate: the trapezoid of the filter's step (`strapdown.rk4`, linear
interpolation of the samples) over two or more intervals telescopes to the exact angle,
whatever the rate does in between.

Where a track's curvature or grade rate steps (an arc entered without a transition, or the
ends of a vertical curve: `trackmodel.sections.JointSteps.rate_steps_m`), the vehicle's
angular rate steps by ``v Δκ`` and its specific force by ``v² Δκ``. A point sample of that
step is what no sensor delivers: the trapezoid over the point samples is off by
``Δω (τ − dt/2)`` of angle for a crossing ``τ`` after a sample, for good (5 mrad of yaw at
100 m/s on a 100-m arc with the joint on a sample). The simulator therefore gives each sample
whose interval ``[t_k − dt/2, t_k + dt/2)`` holds the crossing of such a joint the exact
mean of the ideal IMU over the interval: the interval split at the crossing time (the
profile's distance solved for the joint's ``s`` by bisection) and each piece integrated by
Gauss–Legendre, where the motion is smooth. With these means the trapezoid's angle is
exact again one sample after the joint (a transient of at most ``Δω dt/4`` at the sample
in the joint's interval).

Everywhere else the sample stays the ideal IMU at ``t_k``: where the motion is smooth
over the interval the interval mean is that value to ``dt² |ü|/24`` (a 0.4-mm/s² and
4-µrad/s bound at 100 Hz for ``|ü|`` of 1 m/s⁴ or 1 mrad/s³; the raised-cosine speed
profiles, `railnav.simulation.profiles`, keep the acceleration C¹, and a clothoid's
rate has a kink, not a step). The car body's trips (`railnav.simulation.car_body_motion`)
are not averaged: its chord between the bogies turns the yaw and pitch rate steps into
kinks, and its suspension's point samples are what `railnav.filters.suspension_noise`
models.
"""
from __future__ import annotations

import numpy as np
import numpy.typing as npt

from railnav.simulation.truth import ideal_imu, truth_at
from strapdown.imu import Imu
from trackmodel.sections import joint_steps

__all__ = ["interval_mean_imu", "average_across_joints", "joint_crossing_times",
           "GAUSS_NODES"]

Array = npt.NDArray[np.float64]

#: Gauss–Legendre nodes per smooth piece of an interval (exact for a motion polynomial
#: of degree 5 in time over the piece).
GAUSS_NODES = 3
#: Bisection steps for a crossing time (the bracket, one sample interval, halves each).
_BISECTIONS = 60


def interval_mean_imu(track, profile, imu: Imu, *, start_s: float, rate_hz: float) -> Imu:
    """The ideal IMU `imu` of a trip on `track` (`railnav.simulation.truth.ideal_imu` at
    the trip's samples, or a block of them) as the sensor delivers it: the samples whose
    interval holds a rate-step joint's crossing replaced by the interval's mean (module
    docstring).

    Parameters
    ----------
    track : trackmodel.Track
    profile : railnav.simulation.profiles.SpeedProfile
    imu : strapdown.imu.Imu
        The ideal IMU at samples ``k / rate_hz``.
    start_s : float
        Along-track distance at t = 0, m.
    rate_hz : float
        The sample rate, Hz.

    Returns
    -------
    strapdown.imu.Imu
    """
    half = 0.5 / rate_hz
    t0, t1 = max(float(imu.time_s[0]) - half, 0.0), float(imu.time_s[-1]) + half
    crossings = joint_crossing_times(track, profile, start_s=start_s, t0_s=t0, t1_s=t1)
    if not crossings.size:
        return imu
    return average_across_joints(
        imu, crossings, lambda times: ideal_imu(track, truth_at(track, profile, times,
                                                                start_s=start_s)[0]),
        interval_s=1.0 / rate_hz)


def joint_crossing_times(track, profile, *, start_s: float, t0_s: float, t1_s: float
                         ) -> Array:
    """Times at which the trip crosses the rate-step joints of `track` inside
    ``(s(t0_s), s(t1_s)]`` (s, increasing).

    Parameters
    ----------
    track : trackmodel.Track
    profile : railnav.simulation.profiles.SpeedProfile
        The trip's speed profile (``s`` non-decreasing).
    start_s : float
        Along-track distance at t = 0, m.
    t0_s, t1_s : float
        The time span searched, s (``0 <= t0_s <= t1_s``).

    Returns
    -------
    ndarray, shape (J,)
        The first time at which ``s(t)`` reaches each joint, s.
    """
    joints = joint_steps(track.table).rate_steps_m
    s0, s1 = start_s + profile.evaluate([t0_s, t1_s]).s
    joints = joints[(joints > s0) & (joints <= s1)]
    lo = np.full(joints.size, float(t0_s))
    hi = np.full(joints.size, float(t1_s))
    for _ in range(_BISECTIONS if joints.size else 0):
        mid = 0.5 * (lo + hi)
        reached = start_s + profile.evaluate(mid).s >= joints
        hi = np.where(reached, mid, hi)
        lo = np.where(reached, lo, mid)
    return hi


def average_across_joints(imu: Imu, crossings_s: Array, evaluate, *, interval_s: float
                          ) -> Imu:
    """`imu` with each sample whose interval holds a crossing replaced by the interval's
    mean (module docstring).

    Parameters
    ----------
    imu : strapdown.imu.Imu
        Ideal IMU at its sample times (a uniform grid of step `interval_s`).
    crossings_s : ndarray, shape (J,)
        Joint crossing times, s (`joint_crossing_times`); those outside the samples'
        intervals are ignored.
    evaluate : callable
        ``evaluate(times) -> Imu``: the ideal IMU at increasing times inside the trip.
    interval_s : float
        The sample interval, s.

    Returns
    -------
    strapdown.imu.Imu
        The same times; the samples of the joints' intervals are means.
    """
    t = imu.time_s
    half = 0.5 * interval_s
    crossings = np.asarray(crossings_s, dtype=float)
    # the sample whose interval [t_k − dt/2, t_k + dt/2) holds each crossing
    k = np.searchsorted(t, crossings + half, side="right") - 1
    keep = (k >= 0) & (crossings < t[np.maximum(k, 0)] + half)
    if not keep.any():
        return imu
    crossings, k = crossings[keep], k[keep]
    samples = np.unique(k)
    ends = [_pieces(t[j], half, crossings[k == j], t[0], t[-1]) for j in samples]
    x, w = np.polynomial.legendre.leggauss(GAUSS_NODES)
    nodes, weights, owner = [], [], []
    for row, edges in enumerate(ends):
        for a, b in zip(edges[:-1], edges[1:]):
            nodes.append(0.5 * (a + b) + 0.5 * (b - a) * x)
            weights.append(0.5 * (b - a) * w / (edges[-1] - edges[0]))
            owner.append(np.full(GAUSS_NODES, row))
    nodes, weights, owner = (np.concatenate(v) for v in (nodes, weights, owner))
    at = evaluate(nodes)
    f_b, omega = imu.f_b.copy(), imu.omega_ib_b.copy()
    f_b[samples] = np.zeros((samples.size, 3))
    omega[samples] = np.zeros((samples.size, 3))
    np.add.at(f_b, samples[owner], weights[:, None] * at.f_b)
    np.add.at(omega, samples[owner], weights[:, None] * at.omega_ib_b)
    return Imu(time_s=t, f_b=f_b, omega_ib_b=omega)


def _pieces(t_k: float, half: float, crossings: Array, t_first: float, t_last: float
            ) -> Array:
    """Edges of the smooth pieces of sample ``t_k``'s interval (clipped to the trip)."""
    a, b = max(t_k - half, t_first), min(t_k + half, t_last)
    inside = crossings[(crossings > a) & (crossings < b)]
    return np.concatenate([[a], np.sort(inside), [b]])
