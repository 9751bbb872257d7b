"""NEES/NIS helpers (ekf/consistency.py) and the statistical consistency of the whole
filter on a nonlinear toy: a vehicle on a circle (truth in closed form), measured inputs
[forward accel, lateral accel, yaw rate] whose noise drives both the dynamics and a
continuous no-slip pseudo-measurement (f_lat − v ω = 0: correlated noise), and 1 Hz
ranges to three beacons. Bands: Bar-Shalom et al. 2001, §5.4.

The per-sample gyro noise is kept small against the yaw rate: ``H = ∂h_c/∂v = −ω`` is
evaluated at the MEASURED rate, so its noise correlates with the innovation noise
(errors in variables) and biases ``v`` by the factor ``ω²/(ω² + σ²)`` — a property of
every EKF whose measurement Jacobian depends on a noisy input, kept negligible here
(σ/ω = 0.005)."""
from __future__ import annotations

import casadi as ca
import numpy as np
import pytest

from ekf.cd_filter import CdFilter, FilterConfig
from ekf.consistency import chi2_band, normalized_squares
from ekf.layout import StateLayout
from ekf.model import CdModel, MeasurementModel
from ekf.packing import unpack_sym
from ekf.series import Epoch, InputSeries
from ekf.step import StepOptions
from ekf.update import Observation

SPEED, YAW_RATE = 10.0, 0.2  # m/s, rad/s: a circle of radius 50 m
DT, DURATION = 0.01, 10.0  # s
Q_C = np.array([1e-3, 1e-6, 1e-8])  # (m/s²)²·s, (m/s²)²·s, (rad/s)²·s
SIGMA_RANGE = 1.0  # m
BEACONS = np.array([[150.0, 0.0], [-80.0, 120.0], [0.0, -200.0]])  # m, east/north
P0 = np.diag([25.0, 25.0, 0.01, 1.0])  # m², m², rad², (m/s)²
RUNS = 100
BAND_PROBABILITY = 0.999  # per checked statistic (a handful are checked)


def test_normalized_squares_and_band_closed_forms():
    """Reference: eᵀ C⁻¹ e with an explicit inverse; for 2 degrees of freedom the χ² CDF
    is 1 − exp(−x/2), so its q-quantile is −2 ln(1 − q)."""
    C = np.array([[2.0, 0.5], [0.5, 1.0]])
    e = np.array([0.3, -1.2])
    assert normalized_squares(e, C) == pytest.approx(e @ np.linalg.inv(C) @ e, rel=1e-14)
    low, high = chi2_band(2, 1, 0.9)
    assert low == pytest.approx(-2 * np.log(1 - 0.05), rel=1e-12)
    assert high == pytest.approx(-2 * np.log(1 - 0.95), rel=1e-12)


def _model() -> tuple[CdModel, MeasurementModel]:
    layout = StateLayout.from_blocks([("east", 1), ("north", 1), ("heading", 1), ("v", 1)])
    x, u, p = ca.SX.sym("x", 4), ca.SX.sym("u", 3), ca.SX.sym("p", 0)
    xdot = ca.vertcat(x[3] * ca.sin(x[2]), x[3] * ca.cos(x[2]), u[2], u[0])
    model = CdModel.from_expressions(layout, x, u, p, xdot, h_c=u[1] - x[3] * u[2],
                                     name="circle")
    b = ca.SX.sym("b", 2)
    rng_model = MeasurementModel.from_expression(x, b, ca.norm_2(x[:2] - b), "range")
    return model, rng_model


def _truth(t: np.ndarray, start: np.ndarray) -> np.ndarray:
    heading = start[2] + YAW_RATE * t
    radius = start[3] / YAW_RATE
    east = start[0] + radius * (np.cos(start[2]) - np.cos(heading))
    north = start[1] + radius * (np.sin(heading) - np.sin(start[2]))
    return np.stack([east, north, heading, np.full_like(t, start[3])], axis=1)


def test_nees_and_nis_inside_chi2_bands(rng):
    model, ranges = _model()
    # the simulated samples are step averages with white noise: zero-order hold
    filt = CdFilter(model, FilterConfig(step=StepOptions(input_hold="zoh"), store_every=100,
                                        full_covariance=True))
    steps = int(round(DURATION / DT))
    t = np.arange(steps + 1) * DT
    x_est0 = np.array([0.0, 0.0, 0.3, SPEED])
    nees, nis_d, nis_c_sum, nis_c_n = [], [], 0.0, 0
    for _ in range(RUNS):
        start = rng.multivariate_normal(x_est0, P0)
        truth = _truth(t, start)
        u_true = np.array([0.0, start[3] * YAW_RATE, YAW_RATE])  # no slip: f_lat = v ω
        u = u_true + rng.normal(size=(steps + 1, 3)) * np.sqrt(Q_C / DT)  # step means
        epochs = []
        for k in range(100, steps + 1, 100):
            z = np.linalg.norm(truth[k, :2] - BEACONS, axis=1)
            z += rng.normal(0.0, SIGMA_RANGE, 3)
            epochs.append(Epoch(t[k], [Observation(ranges, z[:, None],
                                                   np.full(3, SIGMA_RANGE ** 2), BEACONS)]))
        res = filt.run(InputSeries(t=t, u=u, q_c=Q_C), epochs, x0=x_est0, P0=P0)
        idx = np.round(res.t / DT).astype(int)
        nees.append(normalized_squares(truth[idx] - res.x, unpack_sym(res.P)))
        nis_d.append(res.nis_d)
        nis_c_sum, nis_c_n = nis_c_sum + res.nis_c_sum, nis_c_n + res.nis_c_count
    nees = np.array(nees)  # (RUNS, times)
    low, high = chi2_band(4, RUNS, BAND_PROBABILITY)
    assert np.all((nees.mean(axis=0) >= low) & (nees.mean(axis=0) <= high))
    nis_d = np.concatenate(nis_d)
    low, high = chi2_band(3, nis_d.size, BAND_PROBABILITY)
    assert low <= nis_d.mean() <= high
    low, high = chi2_band(1, nis_c_n, BAND_PROBABILITY)
    assert low <= nis_c_sum / nis_c_n <= high
