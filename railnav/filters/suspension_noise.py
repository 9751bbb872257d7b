r"""The attitude error of sampling a car body's suspension rates: extra gyro noise.

A car body rolls, pitches and yaws on its secondary suspension
(`railnav.filters.attitude_rows`; the simulator's
`railnav.simulation.car_body_motion`): per axis a damped oscillator driven by white noise,
``x'' + 2ζω₀x' + ω₀²x = w``, with stationary σ (``TrackAttitudeConfig.sigma_rad``),
natural frequency ``f₀ = ω₀/2π`` and damping ζ. Its angular acceleration has the white
part ``w``, of density

    ``q = 4 ζ ω₀³ σ²``   (rad/s²)²·s  (the stationary variance of the oscillator is
                                       ``q/(4ζω₀³)``),

so its rate ``x'`` is continuous but has independent increments at every scale, like a
Brownian motion of intensity ``q``. The IMU samples are instantaneous values
(`strapdown.imu_errors`, ``docs/file-formats.md``) and the filter's step interpolates the
rate linearly between two samples (`ekf.step`, ``input_hold="linear"``): over a step of
length ``dt`` the trapezoid misses the integral of the rate's Brownian bridge, of variance
``q dt³/12``, independently from step to step (`SAMPLING_VARIANCE_FACTOR`). The attitude
therefore makes a random walk the gyros do not report, of density

    ``q_s = q dt²/12``   (rad/s)²·s per axis, added to the gyro white noise of that axis,

since a step's process noise is ``dt · q_c``. With the defaults (σ = 1 / 2 / 3 mrad
yaw / pitch / roll, f₀ = 1 Hz, ζ = 0.3) at 100 Hz: q = 3.0e-4 / 1.2e-3 / 2.7e-3 (rad/s²)²·s
and q_s = 2.5e-9 / 9.9e-9 / 2.2e-8 (rad/s)²·s, against the tactical gyro's
(0.1 °/√h)² = 8.5e-10 and the MEMS gyro's (0.3 °/√h)² = 7.6e-9: for a tactical IMU the
roll's sampling error is a random walk 5 times its angle random walk (measured: the
angle between two samples of the simulated car body against the trapezoid of its rates,
1.5e-5 rad rms per 10-ms step for the roll, ``√(q dt³/12)`` = 1.49e-5). Without it the
tactical filter on ``curvy`` with the car body was overconfident: median NEES over a
300-s outage 32.7 for 7 states, 34.6 for 10 with the attitude rows (10.4 with this
density; ``benchmarks/bench_track_attitude.py``, 10 seeds), the roll's sampling error
moving yaw and pitch through the pseudo-observation. The suspension alone did it
(switched off in the simulation: 5.8 and 7.2 over seeds 1-5; the chord and the mounting
switched off changed nothing).

The suspension moves only when the train runs (track irregularities excite it): its
amplitude is ``σ (1 − exp(−(v/v_f)²))`` (``full_motion_speed_mps`` ``v_f``), so ``q``
scales with that factor squared, at the prior's speed of each chunk. Axes: roll about the
body x axis, pitch about y, yaw about z (the Euler rates are the body rates to first order
in pitch and roll, which are a few mrad to a few percent here).

An IMU that delivers increments (``--imu-spec`` ``kind = "increments"``) integrates the
rate between its samples; its mean rates, placed at the intervals' midpoints and
interpolated, leave a smaller error than this, which the filter then overstates.
"""
from __future__ import annotations

import math

import numpy as np
import numpy.typing as npt


__all__ = ["SAMPLING_VARIANCE_FACTOR", "DEFAULT_SUSPENSION_SIGMA_RAD",
           "DEFAULT_SUSPENSION_FREQUENCY_HZ",
           "DEFAULT_SUSPENSION_DAMPING", "DEFAULT_FULL_MOTION_SPEED_MPS",
           "excitation_density", "motion_gain", "sampling_densities"]

Array = npt.NDArray[np.float64]

#: The Brownian bridge's variance at mid-step, ``dt/12`` of its intensity per ``dt²``
#: (module docstring).
SAMPLING_VARIANCE_FACTOR = 1.0 / 12.0
#: 1σ of the suspension's yaw, pitch, roll at speed, rad.
DEFAULT_SUSPENSION_SIGMA_RAD = (1e-3, 2e-3, 3e-3)
#: Natural frequency of the car body's modes on its secondary suspension, Hz (bounce,
#: pitch and roll of passenger stock lie at 0.8–1.5 Hz).
DEFAULT_SUSPENSION_FREQUENCY_HZ = 1.0
#: Their damping ratio.
DEFAULT_SUSPENSION_DAMPING = 0.3
#: The speed ``v_f`` of the amplitude's factor ``1 − exp(−(v/v_f)²)``, m/s.
DEFAULT_FULL_MOTION_SPEED_MPS = 5.0


def excitation_density(sigma_rad, *, frequency_hz: float, damping: float) -> Array:
    """White angular-acceleration density ``q = 4ζω₀³σ²`` of oscillators with stationary
    σ `sigma_rad` (rad; any shape), natural frequency `frequency_hz` (Hz) and damping
    ratio `damping`, (rad/s²)²·s, shaped like `sigma_rad`."""
    w0 = 2.0 * math.pi * float(frequency_hz)
    return 4.0 * float(damping) * w0 ** 3 * np.square(np.asarray(sigma_rad, dtype=float))


def motion_gain(speed_mps: float, full_motion_speed_mps: float) -> float:
    """The suspension amplitude's factor ``1 − exp(−(v/v_f)²)`` at speed |`speed_mps`|."""
    return 1.0 - math.exp(-(float(speed_mps) / float(full_motion_speed_mps)) ** 2)


def sampling_densities(config, step_s: Array, speed_mps: float) -> Array:
    """The gyro white-noise density the sampled suspension rates add (module docstring).

    Parameters
    ----------
    config : railnav.filters.attitude_config.TrackAttitudeConfig
        ``sigma_rad`` (yaw, pitch, roll), ``suspension_frequency_hz``,
        ``suspension_damping``, ``full_motion_speed_mps``.
    step_s : ndarray, shape (M,)
        Length of the step that starts at each sample, s.
    speed_mps : float
        The vehicle's speed over the steps, m/s.

    Returns
    -------
    ndarray, shape (M, 3)
        Extra density of the gyro x, y, z axes (roll, pitch, yaw), (rad/s)²·s.
    """
    yaw, pitch, roll = excitation_density(config.sigma_rad,
                                          frequency_hz=config.suspension_frequency_hz,
                                          damping=config.suspension_damping)
    gain = motion_gain(speed_mps, config.full_motion_speed_mps)
    dt2 = np.square(np.asarray(step_s, dtype=float))[:, None]
    return (SAMPLING_VARIANCE_FACTOR * gain * gain) * dt2 * np.array([[roll, pitch, yaw]])
