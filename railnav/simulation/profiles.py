"""Speed profiles of a trip: along-track distance, speed and acceleration versus time.

A `SpeedProfile` starts at ``initial_speed_mps`` and runs through `ProfileSegment` s, each
taking the speed from the previous segment's end value to its own ``end_speed_mps`` in
``duration_s`` with a **raised-cosine acceleration**::

    a(τ) = Δv/T (1 − cos 2πτ/T),    v(τ) = v0 + Δv (τ/T − sin(2πτ/T)/2π)
    s(τ) = s0 + v0 τ + Δv (τ²/2T + T (cos(2πτ/T) − 1)/4π²)

so acceleration and jerk are continuous everywhere (``a`` is C¹: the IMU record has no
steps and RK4 over its samples stays exact to rounding). Peak acceleration is ``2Δv/T``.
A segment with the same start and end speed is a cruise, or a station dwell at 0 m/s.
After the last segment the final speed is held. All quantities SI: s in m, v in m/s,
a in m/s², t in s from the start of the trip.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, replace

import numpy as np
import numpy.typing as npt

from railnav.errors import ConfigError

__all__ = ["ProfileSegment", "SpeedProfile", "ProfileSample", "constant_speed",
           "station_stop_profile"]

Array = npt.NDArray[np.float64]
_TWO_PI = 2.0 * math.pi


@dataclass(frozen=True)
class ProfileSegment:
    """One segment: reach ``end_speed_mps`` (m/s, >= 0) in ``duration_s`` (s, > 0)."""

    duration_s: float
    end_speed_mps: float

    def __post_init__(self) -> None:
        if not (math.isfinite(self.duration_s) and self.duration_s > 0):
            raise ConfigError(f"segment duration_s must be finite and > 0, got {self.duration_s!r}")
        if not (math.isfinite(self.end_speed_mps) and self.end_speed_mps >= 0):
            raise ConfigError(f"segment end_speed_mps must be finite and >= 0, "
                              f"got {self.end_speed_mps!r}")


@dataclass(frozen=True)
class ProfileSample:
    """A profile evaluated at times: arrays of shape (N,).

    Attributes
    ----------
    time_s : ndarray
        Time since the start of the trip, s.
    s : ndarray
        Distance travelled, m.
    v : ndarray
        Speed, m/s.
    a : ndarray
        Acceleration dv/dt, m/s².
    """

    time_s: Array
    s: Array
    v: Array
    a: Array


@dataclass(frozen=True)
class SpeedProfile:
    """A smooth speed profile (see the module docstring).

    Parameters
    ----------
    initial_speed_mps : float
        Speed at t = 0, m/s, >= 0.
    segments : tuple of ProfileSegment
        Consecutive segments; may be empty (constant speed).
    """

    initial_speed_mps: float
    segments: tuple[ProfileSegment, ...] = ()

    def __post_init__(self) -> None:
        object.__setattr__(self, "segments", tuple(self.segments))
        if not (math.isfinite(self.initial_speed_mps) and self.initial_speed_mps >= 0):
            raise ConfigError(f"initial_speed_mps must be finite and >= 0, "
                              f"got {self.initial_speed_mps!r}")

    @property
    def max_speed_mps(self) -> float:
        """Highest speed reached, m/s."""
        return max([self.initial_speed_mps] + [g.end_speed_mps for g in self.segments])

    @property
    def segments_duration_s(self) -> float:
        """Total duration of the segments, s (the final speed holds afterwards)."""
        return float(sum(g.duration_s for g in self.segments))

    def scaled_to(self, max_speed_mps: float) -> "SpeedProfile":
        """The same profile with every speed scaled so the highest is `max_speed_mps`.

        A profile that never moves becomes constant at `max_speed_mps`.
        """
        if not (math.isfinite(max_speed_mps) and max_speed_mps > 0):
            raise ConfigError(f"max_speed_mps must be finite and > 0, got {max_speed_mps!r}")
        top = self.max_speed_mps
        if top == 0.0:
            return constant_speed(max_speed_mps)
        k = max_speed_mps / top
        return SpeedProfile(self.initial_speed_mps * k, tuple(
            replace(g, end_speed_mps=g.end_speed_mps * k) for g in self.segments))

    def _breakpoints(self) -> tuple[Array, Array, Array, Array]:
        """Start time, duration, start speed, start distance of each segment + a final hold."""
        durations = [g.duration_s for g in self.segments] + [math.inf]
        v0 = [self.initial_speed_mps] + [g.end_speed_mps for g in self.segments]
        t0, s0 = [0.0], [0.0]
        for g, v_start in zip(self.segments, v0):
            t0.append(t0[-1] + g.duration_s)
            s0.append(s0[-1] + 0.5 * (v_start + g.end_speed_mps) * g.duration_s)
        return np.array(t0), np.array(durations), np.array(v0), np.array(s0)

    def evaluate(self, time_s: npt.ArrayLike) -> ProfileSample:
        """Distance, speed and acceleration at times `time_s` (s, >= 0), shape (N,)."""
        t = np.atleast_1d(np.asarray(time_s, dtype=float))
        if not np.all(np.isfinite(t)) or np.any(t < 0):
            raise ConfigError("profile times must be finite and >= 0")
        t0, T, v0, s0 = self._breakpoints()
        k = np.searchsorted(t0, t, side="right") - 1
        v_end = np.append(v0[1:], v0[-1])
        tau, Tk, dv = t - t0[k], T[k], v_end[k] - v0[k]
        ramp = np.isfinite(Tk) & (dv != 0.0)
        Tr = np.where(ramp, Tk, 1.0)
        phase = _TWO_PI * tau / Tr
        dv_r = np.where(ramp, dv, 0.0)
        a = dv_r / Tr * (1.0 - np.cos(phase))
        v = v0[k] + dv_r * (tau / Tr - np.sin(phase) / _TWO_PI)
        s = s0[k] + v0[k] * tau + dv_r * (tau * tau / (2 * Tr)
                                          + Tr * (np.cos(phase) - 1.0) / _TWO_PI ** 2)
        return ProfileSample(time_s=t, s=s, v=v, a=a)


def constant_speed(speed_mps: float) -> SpeedProfile:
    """Constant speed `speed_mps` (m/s) from the start."""
    return SpeedProfile(speed_mps)


def station_stop_profile(*, cruise_speed_mps: float, accel_time_s: float, brake_time_s: float,
                         cruise_before_stop_s: float, dwell_s: float,
                         start_dwell_s: float = 0.0) -> SpeedProfile:
    """Start at rest, accelerate, cruise, brake to a station stop, dwell, accelerate again.

    Parameters
    ----------
    cruise_speed_mps : float
        Line speed, m/s.
    accel_time_s, brake_time_s : float
        Durations of the speed-up and braking ramps, s (peak acceleration 2v/T).
    cruise_before_stop_s : float
        Time at line speed before braking, s.
    dwell_s : float
        Standstill at the station, s.
    start_dwell_s : float
        Standstill before the first departure, s (0 for none).

    Returns
    -------
    SpeedProfile
        Ends at line speed after the second departure (held until the trip ends).
    """
    v = cruise_speed_mps
    segments = [ProfileSegment(start_dwell_s, 0.0)] if start_dwell_s > 0 else []
    segments += [ProfileSegment(accel_time_s, v), ProfileSegment(cruise_before_stop_s, v),
                 ProfileSegment(brake_time_s, 0.0), ProfileSegment(dwell_s, 0.0),
                 ProfileSegment(accel_time_s, v)]
    return SpeedProfile(0.0, tuple(segments))
