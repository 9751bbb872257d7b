"""Odometer, balise and lever-arm rows (issue 17): values against closed forms or the track
queried directly, Jacobians against central differences, the standstill rule, the slip
screen, the lever-armed GNSS rows against the antenna's geometry computed independently
(`Track.at` and the track frame's axes written out here)."""
from __future__ import annotations

import numpy as np
import pandas as pd
import pytest

from ekf.update import Observation
from gnss_obs.epoch import PreparedEpoch
from gnss_obs.observables import build_measurement_model
from railnav.config import NavigatorConfig
from railnav.errors import ConfigError
from railnav.filters.balise_epochs import BaliseEpochs, BaliseModelConfig
from railnav.filters.balise_rows import BaliseRowBuilder, build_balise_rows
from railnav.filters.fault_config import FaultDetectionConfig
from railnav.filters.fault_detection import RowScreen
from railnav.filters.fix_rows import stack_epoch_rows
from railnav.filters.gnss_only_model import build_gnss_only_model
from railnav.filters.gnss_rows import (
    build_gnss_rows,
    pseudorange_parameters,
    range_rate_parameters,
    track_rows,
)
from railnav.filters.odometer_epochs import OdometerConfig, OdometerEpochs
from railnav.filters.odometer_rows import OdometerRowBuilder, build_odometer_rows
from railnav.filters.sensor_rows import SensorRows, sensor_states, slip_episodes
from railnav.filters.track_frame import antenna_track_part
from railnav.sensors.balises import BaliseLog
from railnav.sensors.odometer import OdometerLog
from railnav.simulation.scenarios import TRACKS_DIR
from trackmodel.earth import C_n_e
from trackmodel.io import read_track

CURVY = read_track(TRACKS_DIR / "curvy.csv")
S_CLOTHOID_M = 4350.0             # in the clothoid into the 1200-m curve, on a 2 % grade
ARM = (3.0, -1.2, 4.1)           # forward, left, up: an antenna on the roof, right of centre
CONFIG = NavigatorConfig(filter="gnss-only")
SCALED = build_gnss_only_model(("E",), extra_blocks=sensor_states(CONFIG, "odometer")).layout


def _fd(model, x, p, step=1e-4):
    out = np.zeros(x.size)
    for i in range(x.size):
        dx = np.zeros(x.size)
        dx[i] = step
        out[i] = (model.evaluate(x + dx, p)[0][0] - model.evaluate(x - dx, p)[0][0]) / (2 * step)
    return out


def _log(t, speed, direction=None, *, resolution=None, kind="speed", pulse_m=0.0):
    n = len(t)
    return OdometerLog(np.asarray(t, float), "time_s", np.asarray(speed, float),
                       np.zeros(n) if direction is None else np.asarray(direction, float),
                       np.zeros(n) if resolution is None else np.asarray(resolution, float),
                       np.full(n, np.nan), kind, "odo.csv", pulse_m)


def test_odometer_row_value_and_jacobian(rng):
    model = build_odometer_rows(SCALED)
    i_v, i_k = SCALED.index("v"), SCALED.index("odo_scale")
    for _ in range(5):
        x = rng.normal(size=SCALED.size)
        x[i_v], x[i_k] = rng.uniform(-30, 30), rng.normal(scale=0.02)
        d = rng.choice([-1.0, 1.0])
        z, H = model.evaluate(x, np.array([[d]]))
        assert z[0] == pytest.approx((1 + x[i_k]) * d * x[i_v], rel=1e-14)
        np.testing.assert_allclose(H[0], _fd(model, x, np.array([[d]])), atol=1e-8)
        assert H[0, i_k] == pytest.approx(d * x[i_v]) and H[0, i_v] == pytest.approx(
            d * (1 + x[i_k]))


def test_odometer_direction_standstill_and_skips():
    t = np.arange(0.0, 3.01, 0.1)
    speed = np.where(t < 1.55, 0.0, 2.0)
    epochs = OdometerEpochs.from_log(_log(t, speed), start_gps_time_s=0.0,
                                     config=OdometerConfig(), span_s=(0.0, 3.0))
    # no motion for >= 1 s: standstill from t = 1.0 to 1.5 (the run started at t = 0)
    np.testing.assert_array_equal(np.flatnonzero(epochs.standstill), np.arange(10, 16))
    builder = OdometerRowBuilder(SCALED, epochs, OdometerConfig())
    x, P = np.zeros(SCALED.size), np.eye(SCALED.size) * 0.01
    obs, sv, kind = builder.observations(12, x, P)
    assert kind[0] == "odo_zero_speed" and obs[0].z[0, 0] == 0.0
    assert obs[0].R[0] == pytest.approx(OdometerConfig().zero_speed_sigma_mps ** 2)
    assert builder.observations(20, x, P) is None and builder.skipped == 1   # v = 0 ± 0.1
    x[SCALED.index("v")] = -2.0                                              # 20σ: backwards
    obs, _, kind = builder.observations(20, x, P)
    assert kind[0] == "odo_speed" and obs[0].p[0, 0] == -1.0 and obs[0].z[0, 0] == 2.0
    with pytest.raises(ConfigError, match="odo.csv: odometer times"):
        OdometerEpochs.from_log(_log(t, speed), start_gps_time_s=0.0, config=OdometerConfig(),
                                span_s=(10.0, 20.0))


def test_pulse_quantization_in_sigma_and_zero_bound():
    """A 3-cm pulse over 0.1 s: step 0.3 m/s, σ² = σ_w² + 0.3²/12; no pulse for 1 s bounds
    |v| < 0.03 m/s: zero-speed σ = 0.03/√3."""
    t = np.arange(0.05, 2.0, 0.1)
    epochs = OdometerEpochs.from_log(_log(t, np.zeros(t.size), resolution=np.full(t.size, 0.3),
                                          kind="pulses", pulse_m=0.03),
                                     start_gps_time_s=0.0, config=OdometerConfig(),
                                     span_s=(0.0, 2.0))
    assert epochs.sigma_mps[0] == pytest.approx(np.sqrt(0.05 ** 2 + 0.09 / 12))
    assert epochs.zero_sigma_mps[0] == pytest.approx(0.03 / np.sqrt(3))


def test_slip_rows_are_excluded_as_an_episode():
    """A wheel 25 % fast for 3 s at 20 m/s (5 m/s over a 0.05-m/s row): the channel fails,
    is excluded, and comes back after ten good readings; the episode is a slip."""
    t = np.arange(0.0, 10.0, 0.1)
    slip = (t >= 3.0) & (t < 6.0)
    speed = np.where(slip, 25.0, 20.0)
    epochs = OdometerEpochs.from_log(_log(t, speed, np.ones(t.size)), start_gps_time_s=0.0,
                                     config=OdometerConfig(), span_s=(0.0, 10.0))
    layout = build_gnss_only_model((), clock=False).layout
    rows = SensorRows(layout, CONFIG, odometer=epochs)
    screen = RowScreen(FaultDetectionConfig())
    from railnav.filters.fix_epochs import EpochSchedule
    sched = EpochSchedule.merge([], [], extra={"odometer": t})
    x, P = np.array([100.0, 20.0]), np.diag([1.0, 0.02 ** 2])
    status = []
    for k in range(t.size):
        obs, sv, kind, modes, groups = stack_epoch_rows(None, None, gnss_mode="channel",
                                                        fix_group=-1,
                                                        extra=rows.parts(sched, k, x, P))
        screen.screen(obs, sv, kind, x, P, modes=modes, groups=groups)
        status.append(screen.last.status[0])
    status = np.array(status)
    assert set(status[~slip][:30]) == {"used"} and set(status[slip]) <= {"rejected", "excluded"}
    assert status[-1] == "used" and (status[slip] == "excluded").sum() >= 25
    frame = pd.DataFrame({"time_s": t, "kind": "odo_speed", "status": status,
                          "innovation": speed - 20.0})
    episodes = slip_episodes(frame)
    assert len(episodes) == 1 and episodes[0]["kind"] == "slip"
    assert episodes[0]["start_s"] == pytest.approx(3.0) and episodes[0]["max_excess_mps"] == 5.0


def test_balise_row_and_projection():
    model = build_balise_rows(SCALED)
    x = np.zeros(SCALED.size)
    x[SCALED.index("s")] = 1234.5
    z, H = model.evaluate(x, np.array([[2.5]]))
    assert z[0] == pytest.approx(1237.0) and H[0, SCALED.index("s")] == 1.0
    assert np.count_nonzero(H[0]) == 1
    point = CURVY.at(S_CLOTHOID_M)
    left = np.array([-np.cos(point.azimuth), np.sin(point.azimuth), 0.0])
    off = C_n_e(point.lat, point.lon) @ (3.0 * left)         # 3 m beside the track
    from trackmodel.earth import ecef_to_geodetic
    lat, lon, _ = ecef_to_geodetic((point.r_e + off)[None, :], earth=CURVY.earth)
    log = BaliseLog(np.array([5.0, 9.0]), "time_s", np.array([800.0, np.nan]),
                    np.array([np.nan, np.degrees(lat[0])]), np.array([np.nan, np.degrees(lon[0])]),
                    np.array([np.nan, 0.3]), np.array(["a", "b"], dtype=object), "bal.csv")
    epochs = BaliseEpochs.from_log(log, CURVY, start_gps_time_s=0.0,
                                   config=BaliseModelConfig(), span_s=(0.0, 10.0))
    np.testing.assert_allclose(epochs.s_m, [800.0, S_CLOTHOID_M], atol=1e-3)
    np.testing.assert_allclose(epochs.sigma_m, [1.0, 0.3])
    obs, sv, kind = BaliseRowBuilder(SCALED, epochs, 2.5).observations(1, x, None)
    assert list(sv) == ["balise:b"] and kind[0] == "balise" and obs[0].p[0, 0] == 2.5
    with pytest.raises(ConfigError, match=r"bal.csv: row 2, lat_deg: balise 3.0 m from"):
        BaliseEpochs.from_log(log, CURVY, start_gps_time_s=0.0,
                              config=BaliseModelConfig(max_offset_m=2.0), span_s=(0.0, 10.0))


def _antenna(s: float) -> np.ndarray:
    """The antenna's ECEF position at distance s, from Track.at and the frame written out."""
    q = CURVY.at(s)
    A, E = float(q.azimuth), float(q.elevation)
    left = np.array([-np.cos(A), np.sin(A), 0.0])
    up = np.array([-np.sin(E) * np.sin(A), -np.sin(E) * np.cos(A), np.cos(E)])
    return q.r_e + C_n_e(q.lat, q.lon) @ (ARM[0] * q.u_n + ARM[1] * left + ARM[2] * up)


def test_lever_armed_gnss_rows_follow_the_antenna():
    """Pseudorange and range rate with the antenna's lever arm, within ±5 m of s_ref,
    against |r_sat − r_a(s)| and (v_sat − v ṙ_a)·e with r_a from `_antenna`; their
    ∂/∂s and ∂/∂v against central differences of those independent functions."""
    layout = build_gnss_only_model(()).layout
    rows = build_gnss_rows(layout)
    ref = CURVY.at(S_CLOTHOID_M)
    part = antenna_track_part(CURVY, track_rows(ref, earth=CURVY.earth), ARM)
    sat = ref.r_e + np.array([1.2e7, -8e6, 1.9e7])
    sat_v = np.array([1500.0, 2200.0, -600.0])
    one, zero = np.ones(1), np.zeros(1)
    prep = PreparedEpoch(gps_time_s=0.0, sv=np.array(["G01"], dtype=object),
                         system=np.array(["G"], dtype=object), sat_pos_e=sat[None, :],
                         sat_vel_e=sat_v[None, :], sat_clock_m=zero, sat_clock_drift_mps=zero,
                         iono_m=zero, tropo_m=zero, elevation=one, azimuth=one,
                         pseudorange_m=zero, range_rate_mps=zero, cn0_dbhz=45.0 * one,
                         sigma_pr_m=one, sigma_rr_mps=one)
    obs_eq = build_measurement_model()

    def rho(s):
        return float(obs_eq.pseudorange(_antenna(s), 0.0, sat, 0.0, 0.0)[0])

    def rho_dot(s, v):
        r_dot = (_antenna(s + 1e-3) - _antenna(s - 1e-3)) / 2e-3 * v
        return float(obs_eq.range_rate(_antenna(s), r_dot, 0.0, sat, sat_v, 0.0)[0])
    p_pr = pseudorange_parameters(part, prep, ())
    p_rr = range_rate_parameters(part, prep)
    i_s, i_v = layout.index("s"), layout.index("v")
    for delta in (-5.0, -1.0, 2.0, 5.0):
        s, v = S_CLOTHOID_M + delta, 18.0
        x = np.zeros(layout.size)
        x[i_s], x[i_v] = s, v
        z_pr, H_pr = rows.pseudorange.evaluate(x, p_pr)
        z_rr, H_rr = rows.range_rate.evaluate(x, p_rr)
        assert z_pr[0] == pytest.approx(rho(s), abs=1e-3)
        assert z_rr[0] == pytest.approx(rho_dot(s, v), abs=1e-4)
        assert H_pr[0, i_s] == pytest.approx((rho(s + 1e-2) - rho(s - 1e-2)) / 2e-2, abs=1e-5)
        assert H_rr[0, i_v] == pytest.approx((rho_dot(s, v + 0.1) - rho_dot(s, v - 0.1)) / 0.2,
                                             abs=1e-6)
        np.testing.assert_allclose(H_pr[0], _fd(rows.pseudorange, x, p_pr, 1e-3), atol=1e-5)
        np.testing.assert_allclose(H_rr[0], _fd(rows.range_rate, x, p_rr, 1e-3), atol=1e-5)
    # the arm matters: without it the pseudorange differs by the arm's projection
    plain = pseudorange_parameters(track_rows(ref, earth=CURVY.earth), prep, ())
    x = np.zeros(layout.size)
    x[i_s] = S_CLOTHOID_M
    shift = rows.pseudorange.evaluate(x, plain)[0][0] - rows.pseudorange.evaluate(x, p_pr)[0][0]
    assert abs(shift) > 1.0


def test_observation_types_are_those_of_the_engine():
    """The builders give `ekf.Observation` rows with diagonal R (the fault screen's need)."""
    epochs = BaliseEpochs(np.array([1.0]), np.array([10.0]), np.array([1.0]),
                          np.array(["x"], dtype=object))
    obs, _, _ = BaliseRowBuilder(SCALED, epochs).observations(0, np.zeros(SCALED.size), None)
    assert isinstance(obs[0], Observation) and obs[0].R.shape == (1,)


def test_lever_armed_fix_rows_follow_the_antenna():
    """A fix exactly at the antenna of the point 3 m ahead: the rows' prediction at that s
    equals the measured z (the antenna's offset cancels), their ∂/∂s match central
    differences; without the arm the cross-track row would see the 1.2-m offset."""
    from railnav.filters.fix_epochs import FixModelConfig
    from railnav.filters.fix_rows import FixRowBuilder
    from tests.railnav.filters.test_fix_rows import _fixes_at
    layout = build_gnss_only_model((), clock=False).layout
    s_true = S_CLOTHOID_M + 3.0
    fixes = _fixes_at(_antenna(s_true))
    armed = FixRowBuilder(CURVY, layout, fixes, FixModelConfig(), antenna_m=ARM)
    obs, _, kind = armed.observations(0, np.array([S_CLOTHOID_M, 20.0]))
    pred, H = obs[0].model.evaluate(np.array([s_true, 20.0]), obs[0].p)
    np.testing.assert_allclose(pred, obs[0].z[:, 0], atol=2e-3)
    fd = [(obs[0].model.evaluate(np.array([s_true + 1e-3, 20.0]), obs[0].p)[0][i]
           - obs[0].model.evaluate(np.array([s_true - 1e-3, 20.0]), obs[0].p)[0][i]) / 2e-3
          for i in range(len(pred))]
    np.testing.assert_allclose(H[:, 0], fd, atol=1e-5)
    plain = FixRowBuilder(CURVY, layout, fixes, FixModelConfig())
    cross = dict(zip(plain.observations(0, np.array([s_true, 20.0]))[2],
                     plain.observations(0, np.array([s_true, 20.0]))[0][0].z[:, 0]))
    assert cross["fix_cross"] == pytest.approx(-ARM[1], abs=0.05)   # 1.2 m right of the track
