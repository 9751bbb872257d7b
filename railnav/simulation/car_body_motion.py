r"""A car body's attitude on its track: the chord between bogies, suspension, IMU mounting.

With a scenario's `CarBodyMotion` (`railnav.simulation.scenarios.Scenario.car_body`; off by
default, so every existing trip is unchanged), the simulated IMU is on a car body whose
attitude is not the track's:

* **chord**: the body is the chord between its bogie pivots (`railnav.filters.car_body`):
  yaw ``A + δψ(s)``, pitch ``ϑ + δθ(s)``; over the leading bogie of a 19-m body that is
  ``−b/(2R)`` = −15.8 mrad on R = 600 m;
* **suspension**: yaw, pitch and roll of the body on its secondary suspension, each a damped
  oscillator driven by white noise (`suspension_angles`), from the seed's ``car_body``
  stream (`RNG_STREAMS`). Defaults: stationary σ = 1 / 2 / 3 mrad (yaw / pitch / roll),
  natural frequency f0 = 1.0 Hz, damping ζ = 0.3 (car-body bounce, pitch and roll modes of
  passenger stock lie at 0.8–1.5 Hz); its autocorrelation ``e^{−ζω₀τ}(cos ω_d τ +
  ζ/√(1−ζ²) sin ω_d τ)`` is 0.02 after 2 s. Track irregularities excite it, so its
  amplitude grows with speed, ``1 − exp(−(v/v_f)²)``, ``v_f = 5 m/s``: none at a
  standstill. The oscillator's rate is its second state, so the angles are C¹ and the IMU
  exact at its samples; between them the rate moves by the white angular acceleration's
  increments, which an interpolation of the samples misses (the filter's model of that:
  `railnav.filters.suspension_noise`);
* **mounting**: the IMU's axes are turned from the body's by three small constant angles
  (yaw, pitch, roll of the IMU in body axes), drawn N(0, ``mount_sigma_rad``²), default 1°.

Angles and their rates are exact at the samples, so the ideal IMU (`railnav.simulation.truth.ideal_imu`
with the body's Euler rates) is exact; the IMU's ``f_b, ω_ib_b`` are the body's turned by the
mounting, and the truth's yaw, pitch and roll are the IMU frame's
(``C_imu_n = C_body_n C_imu_body``). The truth carries the mounting (`CarBodyTruth`).
Not simulated: the body's lateral offset from the centre-line (the chord's versine, 0.15 m at
the centre on R = 300 m; 0 over a bogie) and the quasi-static roll outwards in curves (the
body's flexibility times the cant deficiency), which the attitude rows would see as a bias.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, replace

import numpy as np
import numpy.typing as npt

from railnav.filters.car_body import chord_offsets
from railnav.simulation.car_body_config import CarBodyMotion
from railnav.simulation.truth import Truth, ideal_imu
from strapdown.euler import C_b_n, euler_from_C_b_n, relative_dcm
from strapdown.imu import Imu

__all__ = ["CarBodyMotion", "CarBodyTruth", "car_body_trip", "suspension_angles"]

Array = npt.NDArray[np.float64]

@dataclass(frozen=True)
class CarBodyTruth(Truth):
    """A `Truth` whose attitude is the IMU's on a car body, with the mounting.

    Attributes
    ----------
    mount_rad : ndarray, shape (3,)
        The IMU's yaw, pitch, roll in body axes, rad.
    body_attitude : ndarray, shape (N, 3)
        The body's yaw, pitch, roll, rad.
    """

    mount_rad: Array = None
    body_attitude: Array = None


def suspension_angles(time_s: Array, v: Array, a: Array, motion: CarBodyMotion,
                      rng: np.random.Generator) -> tuple[Array, Array]:
    """Suspension yaw, pitch, roll (rad) and their rates (rad/s), each (N, 3): per axis a
    damped oscillator ``x'' + 2ζω₀x' + ω₀²x = w`` in its stationary state (variance
    ``σ² = q/(4ζω₀³)``), sampled exactly (its transition and noise over the sample step:
    ``expm`` and Van Loan's method), times the speed gain ``1 − exp(−(v/v_f)²)``."""
    from scipy.linalg import expm
    t, v, a = (np.asarray(q, dtype=float) for q in (time_s, v, a))
    dt = np.diff(t)
    step = float(np.median(dt)) if dt.size else 1.0
    if dt.size and not np.allclose(dt, step, rtol=1e-6, atol=1e-9):
        raise ValueError("suspension_angles needs uniform sample times")
    w0, zeta = 2.0 * np.pi * motion.suspension_frequency_hz, motion.suspension_damping
    A = np.array([[0.0, 1.0], [-w0 ** 2, -2.0 * zeta * w0]])
    n = t.size
    states = np.zeros((n, 3, 2))
    for j, sigma in enumerate(motion.suspension_sigma_rad):
        q = 4.0 * zeta * w0 ** 3 * sigma ** 2
        M = expm(np.block([[-A, np.diag([0.0, q])], [np.zeros((2, 2)), A.T]]) * step)
        Phi = M[2:, 2:].T
        Qd = Phi @ M[:2, 2:]
        L = np.linalg.cholesky(Qd + 1e-30 * np.eye(2))
        x = np.array([sigma, w0 * sigma]) * rng.standard_normal(2)
        noise = rng.standard_normal((n, 2)) @ L.T
        for k in range(n):
            states[k, j] = x
            x = Phi @ x + noise[k]
    ratio = (v / motion.full_motion_speed_mps) ** 2
    gain = (1.0 - np.exp(-ratio))[:, None]
    dgain = (2.0 * v / motion.full_motion_speed_mps ** 2 * np.exp(-ratio) * a)[:, None]
    return gain * states[:, :, 0], dgain * states[:, :, 0] + gain * states[:, :, 1]


def car_body_trip(track, truth: Truth, motion: CarBodyMotion,
                  rng: np.random.Generator) -> tuple[CarBodyTruth, Imu]:
    """The IMU frame's truth and the ideal IMU of a car body on `truth`'s path.

    Parameters
    ----------
    track : trackmodel.Track
    truth : Truth
        The path on the track (attitude the track's).
    motion : CarBodyMotion
    rng : numpy.random.Generator
        The ``car_body`` stream: the suspension's draws, then the mounting's.

    Returns
    -------
    CarBodyTruth, strapdown.imu.Imu
    """
    chord = chord_offsets(track, truth.s, bogie_spacing_m=motion.bogie_spacing_m,
                          imu_offset_m=motion.imu_offset_m)
    susp, susp_rate = suspension_angles(truth.time_s, truth.v, truth.a, motion, rng)
    mount = rng.normal(0.0, motion.mount_sigma_rad, 3)
    pt = track.at(truth.s)
    body = np.column_stack([truth.yaw + chord.yaw, truth.pitch + chord.pitch,
                            truth.roll]) + susp
    rates = np.column_stack([truth.v * (pt.curvature_1pm + chord.yaw_rate_1pm),
                             truth.v * (pt.elevation_rate + chord.pitch_rate_1pm),
                             np.zeros_like(truth.v)]) + susp_rate
    body_truth = replace(truth, yaw=np.mod(body[:, 0], 2.0 * np.pi), pitch=body[:, 1],
                         roll=body[:, 2])
    imu_body = ideal_imu(track, body_truth, attitude_rates=rates)
    C_imu_body = relative_dcm(*mount)
    C_imu_n = C_b_n(body_truth.yaw, body_truth.pitch, body_truth.roll) @ C_imu_body
    yaw, pitch, roll = euler_from_C_b_n(C_imu_n)
    turn = lambda vec: vec @ C_imu_body  # noqa: E731  (C_body_imu @ vec, row-wise)
    imu = Imu(time_s=imu_body.time_s, f_b=turn(imu_body.f_b),
              omega_ib_b=turn(imu_body.omega_ib_b))
    fields = {name: getattr(truth, name) for name in Truth.__dataclass_fields__}
    fields.update(yaw=yaw, pitch=pitch, roll=roll)
    return CarBodyTruth(**fields, mount_rad=mount, body_attitude=body), imu
