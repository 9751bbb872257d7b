"""railnav/reproduce/anomaly_filter.py against independent references.

* horizontal channel = a textbook Kalman filter written here (explicit inverse, matrices
  typed from the paper's lists of non-zero elements, eq. 14);
* vertical channel (measurement differencing, eqs. 23–24) = a textbook Kalman filter on
  the state augmented with the Gauss–Markov baro noise (Gelb 1974 §4.5): both are the
  exact optimal filter of the same model, so they agree to rounding;
* anomaly test: fires at every epoch of a 100 m jump; on fault-free data the statistics
  ``εᵀε / tr S`` follow their closed-form χ² laws (1-D: ``NIS``; 2-D with ``S = s I``:
  ``NIS / 2``), so the false-alarm rates are ``P(χ²₁ > γ̃)`` and ``e^{−γ̃}``;
* integrity monitor: decisions follow their definition, and it stops a slow horizontal
  GNSS drift that the anomaly test does not see.
"""
from __future__ import annotations

import numpy as np
import pytest
from scipy.stats import chi2

from ekf.consistency import chi2_band
from railnav.reproduce.anomaly_filter import AdaptiveConfig, run_adaptive_filter
from railnav.reproduce.anomaly_models import HORIZONTAL, VERTICAL, AnomalyParams
from railnav.reproduce.anomaly_sim import GnssFault, simulate_anomaly

#: Two exact algorithms on values up to 1e3 m: rounding only (1e-9 relative of 1e3 m).
ATOL_STATE = 1e-6
#: Fault-free statistics are taken after this settling time, s.
SETTLE_S = 5.0
#: Binomial tolerance of a false-alarm count, in standard deviations.
Z_SIGMA = 4.0
NO_TEST = AdaptiveConfig(trace_factor=None)


def _prior(data, params):
    """Truth as the prior of the kinematic states, 0 for the biases (as the experiment)."""
    x0h, x0v = data.truth_horizontal[0].copy(), data.truth_vertical[0].copy()
    x0h[HORIZONTAL.slice("accel_bias")] = 0.0
    x0v[[VERTICAL.index("baro_bias"), VERTICAL.index("bias_a_up")]] = 0.0
    return x0h, x0v


def _textbook_kf(x, P, z, Phi, Bu, Q, H, R):
    """x, P (prior at k=0), measurements z (N, m), inputs Bu (N, n) for the step k -> k+1."""
    out = np.zeros((z.shape[0], x.size))
    for k in range(z.shape[0]):
        if k > 0:
            x = Phi @ x + Bu[k - 1]
            P = Phi @ P @ Phi.T + Q
        K = P @ H.T @ np.linalg.inv(H @ P @ H.T + R)
        x = x + K @ (z[k] - H @ x)
        P = (np.eye(x.size) - K @ H) @ P
        P = 0.5 * (P + P.T)
        out[k] = x
    return out


def _paper_axis(T, s):
    """Eq. 14: Φ (3x3), Ψ (3,), Γ (3,) of one axis [position, velocity, bias]."""
    Phi = np.array([[1, T, -0.5 * T**2], [0, 1, -T], [0, 0, 1]])
    return Phi, np.array([0.5 * T**2, T, 0.0]), np.array([-0.5 * T**2 * s, -T * s, 0.0])


def _short_plain_run(rng):
    """2 s of nominal data through the filters without test, and the paper's axis block."""
    p = AnomalyParams()
    data = simulate_anomaly(p, duration_s=2.0, rng=rng)
    x0h, x0v = _prior(data, p)
    run = run_adaptive_filter(data, p, NO_TEST, x0_horizontal=x0h, x0_vertical=x0v)
    s = p.sigma_accel_mps2 * np.sqrt(2 * p.dt / p.accel_noise_rate_per_s)     # eq. 1
    return p, data, run, _paper_axis(p.dt, s)


def test_horizontal_channel_is_the_textbook_kalman_filter(rng):
    p, data, run, (Phi3, psi3, gam3) = _short_plain_run(rng)
    x0h = _prior(data, p)[0]
    # paper order [x, y, Vx, Vy, Δax, Δay] = our layout order
    order = [HORIZONTAL.index(k) for k in ("north", "east", "v_north", "v_east",
                                           "bias_a_north", "bias_a_east")]
    assert order == list(range(6))
    Phi, Psi, Gam = np.zeros((6, 6)), np.zeros((6, 2)), np.zeros((6, 2))
    for axis in (0, 1):
        idx = [axis, 2 + axis, 4 + axis]
        Phi[np.ix_(idx, idx)], Psi[idx, axis], Gam[idx, axis] = Phi3, psi3, gam3
    H = np.eye(4, 6)
    R = np.diag([p.sigma_gnss_horizontal_m**2] * 2 + [p.sigma_speed_mps**2] * 2)
    z = np.hstack([data.gnss_pos_m, data.speed_mps])
    ref = _textbook_kf(x0h, np.diag(p.P0_horizontal), z, Phi,
                       data.accel_ins_mps2[:, :2] @ Psi.T, Gam @ Gam.T, H, R)
    np.testing.assert_allclose(run.x_horizontal, ref, atol=ATOL_STATE)


def test_differencing_equals_augmented_state_filter(rng):
    """Augmented state [H, Vz, ΔH, Δaz, u]: baro = H + ΔH + u exactly (R = 0), u(0) ~ N(0, σ²)."""
    p, data, run, (Phi3, psi3, gam3) = _short_plain_run(rng)
    x0v = _prior(data, p)[1]
    phi = np.exp(-p.baro_noise_rate_per_s * p.dt)
    Phi, gam, psi = np.zeros((5, 5)), np.zeros(5), np.zeros(5)
    idx = [0, 1, 3]                     # H, Vz, Δaz; ΔH (2) constant; u (4) Gauss–Markov
    Phi[np.ix_(idx, idx)], gam[idx], psi[idx] = Phi3, gam3, psi3
    Phi[2, 2], Phi[4, 4] = 1.0, phi
    Q = np.outer(gam, gam)
    Q[4, 4] = p.sigma_baro_m**2 * (1 - phi**2)
    H = np.array([[1.0, 0, 1, 0, 1], [1.0, 0, 0, 0, 0]])
    R = np.diag([0.0, p.sigma_gnss_height_m**2])
    z = np.c_[data.baro_m, data.gnss_height_m - p.gnss_height_offset_m]
    Bu = np.outer(data.accel_ins_mps2[:, 2] - data.gravity_mps2, psi)
    P0 = np.diag([*p.P0_vertical, p.sigma_baro_m**2])
    ref = _textbook_kf(np.r_[x0v, 0.0], P0, z, Phi, Bu, Q, H, R)
    np.testing.assert_allclose(run.x_vertical, ref[:, :4], atol=ATOL_STATE)


@pytest.mark.parametrize("fault", [GnssFault(2.0, 3.0, offset_up_m=100.0),
                                   GnssFault(2.0, 3.0, offset_north_m=100.0,
                                             offset_east_m=100.0)])
def test_gate_fires_on_every_epoch_of_a_100m_jump(rng, fault):
    """100 m against √(γ̃ tr S) ≈ 3·7 m (height) or 3·√50 m (horizontal)."""
    p = AnomalyParams()
    data = simulate_anomaly(p, duration_s=7.0, faults=(fault,), rng=rng)
    x0h, x0v = _prior(data, p)
    run = run_adaptive_filter(data, p, AdaptiveConfig(trace_factor=9.0), x0_horizontal=x0h,
                              x0_vertical=x0v)
    assert run.anomaly[data.gnss_fault].all()
    assert not (run.gnss_used_horizontal | run.gnss_used_vertical)[data.gnss_fault].any()
    plain = run_adaptive_filter(data, p, NO_TEST, x0_horizontal=x0h, x0_vertical=x0v)
    assert not plain.anomaly.any() and plain.gnss_used_horizontal.all()


@pytest.fixture(scope="module")
def nominal():
    p = AnomalyParams()
    data = simulate_anomaly(p, duration_s=100.0, rng=np.random.default_rng(11))
    x0h, x0v = _prior(data, p)
    return data, run_adaptive_filter(data, p, NO_TEST, x0_horizontal=x0h, x0_vertical=x0v)


def test_innovation_statistics_on_nominal_data(nominal):
    """Time-averaged NIS of white innovations: inside the 99 % χ² band of its mean."""
    data, run = nominal
    settled = data.t >= SETTLE_S
    n = int(settled.sum())
    for nis, dof in ((run.trace_ratio_vertical[settled], 1),
                     (2.0 * run.trace_ratio_horizontal[settled], 2)):
        low, high = chi2_band(dof, n, probability=0.99)
        assert low <= nis.mean() <= high


@pytest.mark.parametrize("gamma", [4.0, 9.0])
def test_false_alarm_rates_on_nominal_data(nominal, gamma):
    data, run = nominal
    settled = data.t >= SETTLE_S
    n = int(settled.sum())
    for ratio, rate in ((run.trace_ratio_vertical, chi2.sf(gamma, 1)),
                        (run.trace_ratio_horizontal, np.exp(-gamma))):
        count = int((ratio[settled] > gamma).sum())
        assert abs(count - n * rate) <= Z_SIGMA * np.sqrt(n * rate * (1 - rate)) + 1


def test_decisions_follow_the_trace_ratios(rng):
    p = AnomalyParams()
    data = simulate_anomaly(p, duration_s=20.0, rng=rng)
    x0h, x0v = _prior(data, p)
    gamma = 4.0
    run = run_adaptive_filter(data, p, AdaptiveConfig(trace_factor=gamma), x0_horizontal=x0h,
                              x0_vertical=x0v)
    fired = (run.trace_ratio_horizontal > gamma) | (run.trace_ratio_vertical > gamma)
    np.testing.assert_array_equal(run.anomaly, fired)
    np.testing.assert_array_equal(run.gnss_used_vertical, ~fired)      # joint rejection
    split = run_adaptive_filter(data, p, AdaptiveConfig(trace_factor=gamma,
                                                        joint_rejection=False),
                                x0_horizontal=x0h, x0_vertical=x0v)
    np.testing.assert_array_equal(split.gnss_used_vertical[:1],
                                  split.trace_ratio_vertical[:1] <= gamma)


#: Integrity scenario: GNSS height 45 m high from the start (passes the first test:
#: 45 m < √(9·(300 + 49)) = 56 m), then a horizontal drift of DRIFT_MPS from DRIFT_START_S.
HEIGHT_OFFSET_M = 45.0
BARO_BIAS_MAX_M = 30.0
DRIFT_MPS = 1.0
DRIFT_START_S = 5.0
END_S = 25.0


def test_integrity_monitor_refuses_a_drifting_horizontal_fix(rng):
    p = AnomalyParams()
    drift = tuple(GnssFault(start_s=DRIFT_START_S + i, duration_s=END_S,
                            offset_north_m=DRIFT_MPS, offset_east_m=DRIFT_MPS)
                  for i in range(int(END_S - DRIFT_START_S)))
    faults = (GnssFault(0.0, END_S + 1.0, offset_up_m=HEIGHT_OFFSET_M), *drift)
    data = simulate_anomaly(p, duration_s=END_S, faults=faults, rng=rng)
    x0h, x0v = _prior(data, p)
    cfg = AdaptiveConfig(trace_factor=9.0, baro_bias_max_m=BARO_BIAS_MAX_M)
    run = run_adaptive_filter(data, p, cfg, x0_horizontal=x0h, x0_vertical=x0v)
    bias = np.abs(run.x_vertical[:, VERTICAL.index("baro_bias")])
    np.testing.assert_array_equal(run.integrity_refused, (bias >= BARO_BIAS_MAX_M) & ~run.anomaly)
    np.testing.assert_array_equal(run.gnss_used_horizontal,
                                  ~(run.anomaly | run.integrity_refused))
    assert not run.gnss_used_horizontal[data.t >= DRIFT_START_S].any()
    unmonitored = run_adaptive_filter(data, p, AdaptiveConfig(trace_factor=9.0),
                                      x0_horizontal=x0h, x0_vertical=x0v)
    # the anomaly test does not see the drift: the unmonitored filter keeps using the fix
    assert unmonitored.gnss_used_horizontal[data.t >= DRIFT_START_S].mean() > 0.95
    drift_m = DRIFT_MPS * (END_S - DRIFT_START_S)
    pos = HORIZONTAL.slice("pos")
    err = lambda r: np.abs(r.x_horizontal[-1, pos] - data.truth_horizontal[-1, pos]).max()  # noqa: E731
    assert err(unmonitored) > 0.5 * drift_m
    assert err(run) < 0.25 * drift_m


def test_frame_columns_carry_units(nominal):
    _, run = nominal
    frame = run.to_frame()
    np.testing.assert_array_equal(frame["height_m"], run.x_vertical[:, VERTICAL.index("height")])
    np.testing.assert_array_equal(frame["v_east_mps"],
                                  run.x_horizontal[:, HORIZONTAL.index("v_east")])
    assert {"t_s", "bias_a_north_mps2", "baro_bias_m", "anomaly", "integrity_refused",
            "trace_ratio_vertical"} <= set(frame.columns)
    assert len(frame) == run.t.size
