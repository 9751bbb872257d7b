r"""Plausibility of IMU data on a rail vehicle: the common unit and axis mistakes as errors.

A log read with the wrong units or axes still integrates: gyros in deg/s read as rad/s ran
to "beyond the track's start" and accelerometers in g to a 1.2-km error, both with exit
status 0 (issue 17). `check_imu_plausible` refuses such data before any filtering, with a
message that names the likely mistake and the spec key that fixes it
(`strapdown.imu_spec.ImuSpec`). The limits hold for every rail vehicle, standing or moving:

=====================================  ============================  ===========================
test                                   limit                         what fails it
=====================================  ============================  ===========================
median ``|f|`` against standard g      within ±`GRAVITY_TOLERANCE`   accelerometers in g or mg,
                                       (10 %): ``|f| = √(g² + a²)``  increments read as rates,
                                       is within 2 % of g for        gravity removed by the
                                       ``|a| <= 2 m/s²`` (emergency   sensor
                                       braking), vibration averages
                                       out in the median
median ``f_z/|f|`` (vehicle up axis)   >= `MIN_UP_COSINE` (0.9:      the sensor's z down (FRD),
                                       25°; grades and cant give      its x or y vertical: the
                                       < 10°)                         mounting axes wrong
largest ``|ω|`` averaged over          <= `MAX_RATE_RADPS` (1 rad/s,  gyros in deg/s read as
`RATE_WINDOW_S` (1 s)                  57°/s; a tram's 20-m curve     rad/s whenever the vehicle
                                       at 10 m/s turns 0.5 rad/s)     turns
=====================================  ============================  ===========================

Not caught: gyros in deg/s on a dead straight line (the rates are then noise and Earth rate,
plausible in either unit), and rad/s data declared in deg/s (rates 57 times too small).
"""
from __future__ import annotations

import os

import numpy as np
import numpy.typing as npt

from strapdown.errors import ImuInputError
from strapdown.imu import Imu
from strapdown.imu_errors import STANDARD_GRAVITY_MPS2

__all__ = ["check_imu_plausible", "GRAVITY_TOLERANCE", "MIN_UP_COSINE", "MAX_RATE_RADPS",
           "RATE_WINDOW_S"]

Array = npt.NDArray[np.float64]

#: Largest relative difference between the median |f| and standard gravity.
GRAVITY_TOLERANCE = 0.1
#: Smallest median cosine between the specific force and the vehicle's up axis.
MIN_UP_COSINE = 0.9
#: Largest angular rate of a rail vehicle averaged over `RATE_WINDOW_S`, rad/s.
MAX_RATE_RADPS = 1.0
#: Averaging window of the rate test, s (noise averages out, turns stay).
RATE_WINDOW_S = 1.0
_AXIS_NAMES = ("x", "y", "z")


def check_imu_plausible(imu: Imu, *, path: str | os.PathLike | None = None,
                        spec=None) -> None:
    """Refuse IMU data no rail vehicle produces (module docstring).

    Parameters
    ----------
    imu : Imu
        Samples in the vehicle frame, SI.
    path : path, optional
        The file, for the message.
    spec : strapdown.imu_spec.ImuSpec, optional
        How the file was read (the message names its units).

    Raises
    ------
    ImuInputError
        Saying which test failed, the value seen and the likely mistake.
    """
    if imu.time_s.size < 2:
        return
    _check_gravity(imu.f_b, path, spec)
    _check_up(imu.f_b, path)
    _check_rates(imu, path, spec)


def _check_gravity(f_b: Array, path, spec) -> None:
    median = float(np.median(np.linalg.norm(f_b, axis=1)))
    ratio = median / STANDARD_GRAVITY_MPS2
    if abs(ratio - 1.0) <= GRAVITY_TOLERANCE:
        return
    unit = getattr(spec, "accel_unit", "m/s^2")
    if abs(median - 1.0) <= GRAVITY_TOLERANCE:
        hint = 'the accelerometers seem to be in g: units.accel = "g"'
    elif abs(median / 1000.0 - 1.0) <= GRAVITY_TOLERANCE:
        hint = 'the accelerometers seem to be in mg: units.accel = "mg"'
    elif ratio < GRAVITY_TOLERANCE:
        hint = ("too small for a specific force: increments read as rates (units.kind = "
                '"increments"), or gravity removed by the sensor (railnav needs specific force)')
    else:
        hint = f"check units.accel (read as {unit})"
    raise ImuInputError(f"median |specific force| is {median:.4g} m/s², not about g = "
                        f"{STANDARD_GRAVITY_MPS2} m/s²: {hint}", path=path)


def _check_up(f_b: Array, path) -> None:
    norm = np.linalg.norm(f_b, axis=1)
    cosine = float(np.median(f_b[:, 2] / np.where(norm > 0, norm, np.inf)))
    if cosine >= MIN_UP_COSINE:
        return
    median = np.median(f_b, axis=0)
    axis = int(np.argmax(np.abs(median)))
    sign = "-" if median[axis] < 0 else "+"
    raise ImuInputError(f"the specific force at rest points along the vehicle's {sign}"
                        f"{_AXIS_NAMES[axis]} axis (median f = [{median[0]:.3g}, "
                        f"{median[1]:.3g}, {median[2]:.3g}] m/s²), not up (z): set "
                        '[mounting] axes, e.g. ["x", "-y", "-z"] for a sensor with z down',
                        path=path)


def _check_rates(imu: Imu, path, spec) -> None:
    mean = _moving_mean(imu.time_s, imu.omega_ib_b, RATE_WINDOW_S)
    peak = float(np.max(np.linalg.norm(mean, axis=1)))
    if peak <= MAX_RATE_RADPS:
        return
    unit = getattr(spec, "gyro_unit", "rad/s")
    hint = 'the gyros seem to be in deg/s: units.gyro = "deg/s"' if unit == "rad/s" else \
        f"check units.gyro (read as {unit})"
    raise ImuInputError(f"the angular rate averaged over {RATE_WINDOW_S:g} s reaches "
                        f"{peak:.3g} rad/s, far above any rail vehicle's "
                        f"({MAX_RATE_RADPS:g} rad/s): {hint}", path=path)


def _moving_mean(t: Array, values: Array, window_s: float) -> Array:
    """Means of `values` (N, k) over the samples of each trailing window of `window_s`
    (the whole record when it is shorter)."""
    csum = np.vstack([np.zeros((1, values.shape[1])), np.cumsum(values, axis=0)])
    end = np.arange(1, t.size + 1)
    start = np.searchsorted(t, t - window_s, side="left")
    if t[-1] - t[0] < window_s:
        return (csum[-1] / t.size)[None, :]
    keep = t - t[0] >= window_s
    start, end = start[keep], end[keep]
    return (csum[end] - csum[start]) / (end - start)[:, None]
