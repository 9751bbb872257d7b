"""A level straight at constant speed, where nothing observes the yaw: the closed-form
covariance of the yaw and the z-gyro bias that the constrained filter must reproduce there
(`benchmarks/bench_yaw_straight.py`, ``tests/railnav/filters/test_yaw_straight.py``).

On such a straight the along-track specific force ``f_x`` is zero, so the pseudo-observation
``h_c = P⊥ (C_b_n f_b + …)`` does not depend on the yaw (its yaw column is ``≈ f_x``), the
GNSS rows see only ``s``, ``v`` and the clock (``v_n = v u(s)`` whatever the yaw), and the
yaw error ``δψ`` and the z-gyro bias error ``δb`` evolve alone::

    δψ̇ = −δb − w_g,     δḃ = w_b

(``w_g``: the gyro's white noise, density ``q_g`` (rad/s)²·s; ``w_b``: the bias's random
walk as the filter models it, density ``q_b`` (rad/s)²/s). With ``Φ(t) = [[1, −t], [0, 1]]``
and a prior ``diag(σ_ψ0², σ_b0²)`` at ``t = 0``::

    P_ψψ(t) = σ_ψ0² + q_g t + σ_b0² t² + q_b t³ / 3
    P_ψb(t) = −σ_b0² t − q_b t² / 2
    P_bb(t) = σ_b0² + q_b t

Assumptions: level track (no grade: ``f_x = g sin ϑ = 0``), constant speed, pitch and roll
small (``E(θ, φ) ≈ I``: the yaw rate is the z gyro), the Earth-rate terms' coupling of the
tilt errors into the yaw rate neglected (``Ω_ie δθ`` ~ 5e-9 rad/s against ``σ_b0`` ~ 5e-6
rad/s), and no other noise on the yaw or the bias (no joints, no curvature steps on a
straight). The filter's own densities and initial variances are used, so the comparison
tests what the filter does with them, not the IMU model.
"""
from __future__ import annotations

import math

import numpy as np

from railnav.filters.ins_clock_model import initial_variances
from railnav.simulation.profiles import constant_speed
from railnav.simulation.scenarios import Scenario
from trackmodel.earth import WGS84
from trackmodel.sections import Section
from trackmodel.track import Origin, Track

__all__ = ["SPEED_MPS", "straight_track", "straight_scenario", "straight_yaw_covariance",
           "filter_yaw_densities"]

#: Speed on the straight, m/s (the 2017 paper's).
SPEED_MPS = 20.0
#: The straight's origin (the consistency benchmark's).
ORIGIN = Origin(50.45, 30.52, 100.0)


def straight_track(duration_s: float) -> Track:
    """A level straight heading east, 1 km longer than `duration_s` (s) at `SPEED_MPS`."""
    return Track([Section(SPEED_MPS * duration_s + 1000.0, 90.0, 0.0)], ORIGIN, WGS84)


def straight_scenario(duration_s: float, grade: str = "tactical") -> Scenario:
    """`SPEED_MPS` from the start for `duration_s` (s), IMU `grade`, GNSS all the way."""
    return Scenario(name="straight", profile=constant_speed(SPEED_MPS),
                    duration_s=duration_s, imu_errors=grade)


def straight_yaw_covariance(t_s, *, sigma_yaw0_rad: float, sigma_bias0_radps: float,
                            q_gyro: float, q_bias: float) -> np.ndarray:
    """The closed-form covariance of ``[δψ, δb_gz]`` at `t_s` (module docstring).

    Parameters
    ----------
    t_s : float or ndarray, shape (K,)
        Time from the prior, s.
    sigma_yaw0_rad, sigma_bias0_radps : float
        σ of the prior's yaw (rad) and z-gyro bias (rad/s), uncorrelated.
    q_gyro : float
        Density of the z gyro's white noise, (rad/s)²·s.
    q_bias : float
        Density of the bias's random walk, (rad/s)²/s.

    Returns
    -------
    ndarray, shape (..., 2, 2)
        rad², rad²/s, (rad/s)².
    """
    t = np.asarray(t_s, dtype=float)
    b0 = sigma_bias0_radps ** 2
    P = np.empty(t.shape + (2, 2))
    P[..., 0, 0] = sigma_yaw0_rad ** 2 + q_gyro * t + b0 * t ** 2 + q_bias * t ** 3 / 3.0
    P[..., 0, 1] = P[..., 1, 0] = -b0 * t - q_bias * t ** 2 / 2.0
    P[..., 1, 1] = b0 + q_bias * t
    return P


def filter_yaw_densities(filt, config) -> dict[str, float]:
    """The constrained filter's own numbers for `straight_yaw_covariance`: its z-gyro and
    bias densities (``filt.q_c``) and its initial σ of the yaw and the z-gyro bias."""
    names = filt.model.noise_names
    var = initial_variances(config, filt.layout)
    return {"sigma_yaw0_rad": math.sqrt(var["yaw"]),
            "sigma_bias0_radps": math.sqrt(var["b_gz"]),
            "q_gyro": float(filt.q_c[names.index("w_wz")]),
            "q_bias": float(filt.q_c[names.index("w_b_gz")])}
