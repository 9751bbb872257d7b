"""Fault detection and exclusion (railnav/filters/fault_detection.py, railnav/filters/fault_channels.py).

Unit tests on a linear two-state "receiver" (``ρ_i = a_i s + b``, ``ρ̇_i = a_i v``-like rows
given directly) whose innovations are set exactly: references are the fault posterior by
Bayes' rule (`ekf.fault_probability` of ``ν²/S`` with ``S = H P Hᵀ + R`` written out), the
CUSUM by hand arithmetic, the Kalman gain with an explicit inverse. Integration tests run
the constrained filter on simulated `curvy` trips with injected faults
(`railnav.studies.faults`), each against the same trip without the fault.
"""
from __future__ import annotations

from dataclasses import replace

import casadi as ca
import numpy as np
import pytest

from ekf.model import MeasurementModel
from ekf.outliers import fault_probability
from ekf.series import EpochRows
from ekf.update import Observation
from gnss_obs.sim_events import SatelliteFault
from railnav.errors import ConfigError
from railnav.filters.fault_config import FaultDetectionConfig
from railnav.filters.fault_detection import RowScreen
from railnav.simulation.scenarios import TRACKS_DIR, get_scenario
from railnav.simulation.trip import navigator_config_for
from railnav.studies.faults import clock_jump_faults, fault_case
from trackmodel.io import read_track

#: Same closed form computed another way: relative agreement.
RTOL = 1e-9
SIGMA_M = 3.0
#: Line-of-sight coefficients of six "satellites" on the along-track distance.
LOS = np.array([0.9, -0.6, 0.3, -0.2, 0.7, -0.8])
SVS = np.array([f"G{i:02d}" for i in range(1, LOS.size + 1)], dtype=object)
X = np.array([100.0, 20.0])                      # s (m), clock bias (m)
P = np.array([[0.5, 0.1], [0.1, 2.0]])           # m²
CLOCK = 1


@pytest.fixture(scope="module")
def model() -> MeasurementModel:
    x, p = ca.SX.sym("x", 2), ca.SX.sym("p", 1)
    return MeasurementModel(ca.Function("pr", [x, p], [p[0] * x[0] + x[1]]), "pr",
                            compiled=False)


def _rows(model, offsets_sigma):
    """Rows whose innovation at (X, P) is exactly ``offsets_sigma · √S_ii``."""
    H = np.column_stack([LOS, np.ones(LOS.size)])
    S = H @ P @ H.T + SIGMA_M ** 2 * np.eye(LOS.size)
    z = H @ X + np.asarray(offsets_sigma, dtype=float) * np.sqrt(np.diag(S))
    obs = Observation(model, z[:, None], np.full(LOS.size, SIGMA_M ** 2), LOS[:, None])
    return [obs], H, S


def _screen(screen, model, offsets_sigma):
    obs, H, S = _rows(model, offsets_sigma)
    out = screen.screen(obs, SVS, np.full(LOS.size, "pseudorange", dtype=object), X, P)
    return out, screen.last


def _clean(k=0.0):
    return np.full(LOS.size, k)


def test_fault_probability_and_statuses_of_one_epoch(model):
    offsets = np.array([0.5, -1.0, 6.0, 0.0, -2.0, 1.5])
    screen = RowScreen(FaultDetectionConfig(), None)
    out, last = _screen(screen, model, offsets)
    expected = fault_probability(offsets ** 2, prior=0.01, scale=10.0)
    np.testing.assert_allclose(last.fault_probability, expected, rtol=RTOL)
    assert list(last.status) == ["used", "used", "rejected", "used", "used", "used"]
    assert isinstance(out, list) and out[0].rows == 5
    np.testing.assert_allclose(out[0].p[:, 0], LOS[[0, 1, 3, 4, 5]])
    _, H, S = _rows(model, offsets)
    np.testing.assert_allclose(last.S, S, rtol=RTOL)


def test_repeated_failures_exclude_and_consistent_passes_readmit(model):
    cfg = FaultDetectionConfig()   # 3 failures in 5 exclude; 10 passes re-admit
    screen = RowScreen(cfg, None)
    bad = _clean()
    bad[2] = 8.0
    outs = [_screen(screen, model, bad) for _ in range(4)]
    assert [last.status[2] for _, last in outs] == ["rejected", "rejected", "excluded",
                                                     "excluded"]
    # its rows were never used: nothing was pulled in, no covariance is added
    assert all(isinstance(out, list) for out, _ in outs)
    # the fault ends: ten consistent epochs while excluded, then used again
    statuses = [_screen(screen, model, _clean(0.3))[1].status[2] for _ in range(11)]
    assert statuses == ["excluded"] * 10 + ["used"]
    assert all((_screen(screen, model, _clean())[1].status == "used"))


def test_a_drifting_channel_is_excluded_by_the_cusum(model):
    """Innovations of +2σ: CUSUM grows by 2 − δ = 1.65 per epoch and passes h = 9 at the
    sixth epoch (8.25 after five); no row fails the 3.73σ row test on the way."""
    screen = RowScreen(FaultDetectionConfig(), None)
    drift = _clean()
    drift[4] = 2.0
    statuses = [_screen(screen, model, drift)[1].status[4] for _ in range(6)]
    assert statuses == ["used"] * 5 + ["excluded"]


def test_a_running_ramp_is_not_readmitted(model):
    """After exclusion, innovations at 2σ pass the row test but not the mean test
    (|Σ r|/√10 = 6.3 > 3): the channel stays out."""
    screen = RowScreen(FaultDetectionConfig(), None)
    drift = _clean()
    drift[4] = 2.0
    for _ in range(6):
        _screen(screen, model, drift)
    assert all(_screen(screen, model, drift)[1].status[4] == "excluded" for _ in range(30))


def test_exclusion_inflates_the_prior_by_what_the_channel_pulled_in(model):
    """The jump covariance at the drift exclusion is ΔΔᵀ, Δ = Σ K_i ν_i of the channel's
    five used rows (all at the same prior here), K from an explicit inverse."""
    screen = RowScreen(FaultDetectionConfig(), None)
    drift = _clean()
    drift[4] = 2.0
    for _ in range(5):
        out, _ = _screen(screen, model, drift)
        assert isinstance(out, list)
    out, _ = _screen(screen, model, drift)
    obs, H, S = _rows(model, drift)
    K = P @ H.T @ np.linalg.inv(S)
    nu = drift * np.sqrt(np.diag(S))
    delta = 5 * K[:, 4] * nu[4]
    assert isinstance(out, EpochRows)
    np.testing.assert_allclose(out.jump_covariance, np.outer(delta, delta), rtol=1e-8)


def test_a_clock_jump_inflates_the_clock_not_the_satellites(model):
    """All pseudoranges +40σ-ish alike: one offset; jump variance (3·â)² on the clock only,
    every row used; â is the weighted least-squares offset of the innovations."""
    obs, H, S = _rows(model, _clean())
    jump_m = 500.0
    obs = [replace(obs[0], z=obs[0].z + jump_m)]
    screen = RowScreen(FaultDetectionConfig(), CLOCK)
    out = screen.screen(obs, SVS, np.full(LOS.size, "pseudorange", dtype=object), X, P)
    assert isinstance(out, EpochRows) and out.observations[0].rows == LOS.size
    ones = np.ones(LOS.size)
    offset = ones @ np.linalg.inv(S) @ (ones * jump_m) / (ones @ np.linalg.inv(S) @ ones)
    assert screen.last.clock_jump_m == pytest.approx(offset, rel=RTOL)
    Q = np.zeros((2, 2))
    Q[CLOCK, CLOCK] = (3.0 * offset) ** 2
    np.testing.assert_allclose(out.jump_covariance, Q, rtol=RTOL)
    assert (screen.last.status == "used").all()
    # without a clock state to blame, every satellite fails
    blind = RowScreen(FaultDetectionConfig(), None)
    blind.screen(obs, SVS, np.full(LOS.size, "pseudorange", dtype=object), X, P)
    assert (blind.last.status == "rejected").all()


def test_one_faulty_satellite_is_not_a_clock_jump(model):
    obs, H, S = _rows(model, _clean())
    obs = [replace(obs[0], z=obs[0].z + 500.0 * (np.arange(LOS.size) == 0)[:, None])]
    screen = RowScreen(FaultDetectionConfig(), CLOCK)
    out = screen.screen(obs, SVS, np.full(LOS.size, "pseudorange", dtype=object), X, P)
    assert isinstance(out, list) and np.isnan(screen.last.clock_jump_m)
    assert list(screen.last.status).count("rejected") == 1


def test_without_configuration_every_row_is_used(model):
    screen = RowScreen(None, CLOCK)
    out, last = _screen(screen, model, np.full(LOS.size, 50.0))
    assert (last.status == "used").all() and np.isnan(last.fault_probability).all()
    assert len(screen.frame()) == LOS.size


@pytest.mark.parametrize("changes", [{"fault_prior": 0.0}, {"fault_scale": 1.0},
                                     {"exclusion_failures": 6}, {"readmission_passes": 0},
                                     {"clock_jump_false_alarm": 1.5},
                                     {"drift_threshold": -1.0}, {"drift_allowance": -0.1}])
def test_bad_configuration_is_refused(changes):
    with pytest.raises(ConfigError):
        FaultDetectionConfig(**changes)


# -- the constrained filter on simulated trips -----------------------------------------------
#: The issue's bound on how far a fault may pull the along-track estimate, in the filter's σ.
MAX_PULL_SIGMA = 3.0
#: Fault-free rows not used: the row test's 1.9e-4 and rare CUSUM alarms; 1 % bound.
MAX_FALSE_ALARM = 0.01


@pytest.fixture(scope="module")
def curvy_short():
    return read_track(TRACKS_DIR / "curvy.csv"), replace(get_scenario("curvy"),
                                                         duration_s=150.0)


def test_a_pseudorange_step_is_excluded_and_readmitted(curvy_short):
    track, sc = curvy_short
    case = fault_case(track, sc, (SatelliteFault("G05", 40.0, 60.0, step_m=200.0),), seed=2)
    assert case.time_to_detect_s <= 1.0 and case.time_to_exclude_s <= 2.0
    assert case.detection_rate == 1.0
    assert case.pull_sigma < MAX_PULL_SIGMA
    assert case.false_alarm_rate < MAX_FALSE_ALARM
    # the fault is over at 100 s: ten consistent epochs, then used again
    assert 10.0 <= case.readmission_delay_s <= 12.0
    inn = case.faulted.result.innovations
    g05 = inn[(inn["sv"] == "G05") & (inn["kind"] == "pseudorange")]
    assert (g05[g05["time_s"] >= 100.0 + case.readmission_delay_s]["status"] == "used").all()
    assert (inn[(inn["sv"] == "G05") & (inn["kind"] == "range_rate")]["status"] == "used").all()


def test_a_receiver_clock_jump_is_absorbed(curvy_short):
    track, sc = curvy_short
    satellites = [f"G{i:02d}" for i in range(1, 33)]
    jump_m = 1000.0
    case = fault_case(track, sc, clock_jump_faults(satellites, 60.0, jump_m), seed=2)
    assert len(case.clock_jumps) == 1 and case.clock_jumps[0]["time_s"] == 60.0
    # the estimated jump: within 5σ of a single epoch's common offset (σ_pr / √N ≈ 1.5 m)
    assert abs(case.clock_jumps[0]["jump_m"] - jump_m) < 5 * 1.5
    assert case.pull_sigma < 0.1 and case.false_alarm_rate < MAX_FALSE_ALARM
    # the same trip without the screen loses every pseudorange after the jump
    config = replace(navigator_config_for(sc), fault_detection=None)
    blind = fault_case(track, sc, clock_jump_faults(satellites, 60.0, jump_m), seed=2,
                       config=config)
    inn = blind.faulted.result.innovations
    late = inn[(inn["time_s"] > 60.0) & (inn["kind"] == "pseudorange")]
    assert (~late["accepted"]).mean() > 0.9


#: A variance factor for errors correlated over τ: ``(1+ρ)/(1−ρ)``, ρ = exp(−1/60) (τ 60 s
#: at 1 Hz).
INFLATION = (1.0 + np.exp(-1.0 / 60.0)) / (1.0 - np.exp(-1.0 / 60.0))


def _inflated_screen(screen, model, offsets_sigma):
    """Rows whose innovation is ``offsets_sigma`` times their own σ (``S₀ = H P Hᵀ + σ²``),
    given to the screen with the update's variance ``INFLATION σ²``."""
    obs, H, S0 = _rows(model, offsets_sigma)
    obs = [replace(obs[0], R=obs[0].R * INFLATION)]
    out = screen.screen(obs, SVS, np.full(LOS.size, "pseudorange", dtype=object), X, P,
                        inflation=np.full(LOS.size, INFLATION))
    return out, screen.last, H, S0


def test_inflated_rows_are_tested_at_their_own_variance(model):
    """The row test's fault probability is that of ``ν²/(H P Hᵀ + σ²)`` (not of the
    inflated variance, at which the 6σ row would be 0.6σ off); the update gets ``f σ²``."""
    offsets = np.array([0.5, -1.0, 6.0, 0.0, -2.0, 1.5])
    out, last, H, S0 = _inflated_screen(RowScreen(FaultDetectionConfig(), None), model,
                                        offsets)
    np.testing.assert_allclose(last.fault_probability,
                               fault_probability(offsets ** 2, prior=0.01, scale=10.0),
                               rtol=RTOL)
    assert list(last.status) == ["used", "used", "rejected", "used", "used", "used"]
    np.testing.assert_allclose(out[0].R, np.full(5, INFLATION * SIGMA_M ** 2), rtol=RTOL)
    np.testing.assert_allclose(last.S, H @ P @ H.T + INFLATION * SIGMA_M ** 2 * np.eye(6),
                               rtol=RTOL)


@pytest.mark.parametrize("inflated", [False, True])
def test_a_steady_bias_excludes_by_the_cusum_only_when_white(model, inflated):
    """One row held at 2σ of its own variance (a multipath bias): white (f = 1), the CUSUM
    adds 2 − 0.35 a epoch and passes h = 9 at the 6th; told τ 60 s it adds
    ``2 √(S₀/S) − 0.35 < 0`` (the sums at the update's variance, the long-run one) and
    the channel stays in for 20 epochs."""
    screen = RowScreen(FaultDetectionConfig(), None)
    offsets = np.array([2.0, 0, 0, 0, 0, 0])
    statuses = []
    for _ in range(20):
        if inflated:
            last = _inflated_screen(screen, model, offsets)[1]
        else:
            last = _screen(screen, model, offsets)[1]
        statuses.append(last.status[0])
    first = int(np.ceil(9.0 / (2.0 - 0.35)))
    expected = ["used"] * 20 if inflated else ["used"] * (first - 1) + ["excluded"] * (21 - first)
    assert statuses == expected


@pytest.mark.parametrize("offsets, jump_m, clock", [
    ([1.5, -1.5, 1.0, 2.0, -1.0, 0.8], 0.0, None),       # every row used, P as it is
    ([1.5, -1.5, 6.0, 2.0, -1.0, 0.8], 0.0, None),       # a row rejected: the used rows
    ([2.0, -2.0, 2.0, -2.0, 0.0, 0.0], 15.0, CLOCK)])     # a clock jump: P + Q
def test_each_used_rows_influence_is_its_gain_times_its_innovation(model, offsets, jump_m,
                                                                   clock):
    """After one epoch each channel's influence on a side whose CUSUM is open is
    ``K_i ν_i`` of its row, ``K = (P+Q) H_uᵀ (H_u (P+Q) H_uᵀ + R_u)⁻¹`` over the used rows
    (an explicit inverse; ``Q`` the epoch's jump covariance), zero elsewhere; rejected
    rows add nothing."""
    obs, H, _ = _rows(model, offsets)
    obs = [replace(obs[0], z=obs[0].z + jump_m)]
    screen = RowScreen(FaultDetectionConfig(), clock)
    out = screen.screen(obs, SVS, np.full(LOS.size, "pseudorange", dtype=object), X, P)
    last = screen.last
    Q = out.jump_covariance if isinstance(out, EpochRows) else np.zeros((2, 2))
    assert isinstance(out, EpochRows) == (jump_m > 0.0)
    used = last.status == "used"
    assert used.sum() == LOS.size - (np.abs(offsets) > 3.73).sum()
    H_u = H[used]
    S_u = H_u @ (P + Q) @ H_u.T + SIGMA_M ** 2 * np.eye(H_u.shape[0])
    K = (P + Q) @ H_u.T @ np.linalg.inv(S_u)
    pulls = K * last.innov[used]                         # column j: K_j ν_j
    opened = 0
    for j, i in enumerate(np.flatnonzero(used)):
        channel = screen._channels[f"{SVS[i]}/pseudorange"]
        for side in (0, 1):
            expected = pulls[:, j] if channel._cusum[side] > 0.0 else np.zeros(2)
            opened += channel._cusum[side] > 0.0
            np.testing.assert_allclose(channel._influence[side], expected, rtol=RTOL,
                                       atol=1e-12)
    for i in np.flatnonzero(~used):
        assert not np.count_nonzero(screen._channels[f"{SVS[i]}/pseudorange"]._influence)
    assert opened >= 2
