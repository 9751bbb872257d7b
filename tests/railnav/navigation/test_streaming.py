"""Streaming mode: segments of a simulated trip, running statistics, the streamed filter.

References: `railnav.evaluation.metrics.summarize` of the whole error series (for the running
statistics); `strapdown.imu_errors.apply_imu_errors` and the IMU error model written out
as an explicit loop (for the block-wise IMU errors); `railnav.navigate` run in memory on
the very samples and observations the stream produced (for the streamed filter); the
scenario's outage windows and the clock's continuity (for the segment boundaries).
"""
from __future__ import annotations

import logging
import math
from dataclasses import replace

import numpy as np
import pandas as pd
import pytest

from gnss_obs.rinex_nav import read_rinex_nav
from gnss_obs.rinex_obs import RinexObs
from gnss_obs.sim_events import in_outages as in_outage
from gnss_obs.simulate import default_nav_path
from railnav.errors import ConfigError
from railnav.evaluation.metrics import (
    ERROR_QUANTITIES,
    ErrorSeries,
    error_series,
    summarize,
)
from railnav.evaluation.running_stats import RunningSummary
from railnav.filters.protocol import make_filter
from railnav.navigation.navigator import navigate
from railnav.navigation.streaming import _initial_state, stream_simulated
from railnav.sensor_data import SensorData
from railnav.simulation.profiles import constant_speed
from railnav.simulation.scenarios import TRACKS_DIR, Scenario, get_scenario
from railnav.simulation.trip import navigator_config_for
from railnav.simulation.trip_stream import ImuErrorStream, concat_truth, trip_segments
from railnav.simulation.truth import ideal_imu, simulate_truth
from strapdown.imu import Imu
from strapdown.imu_errors import IMU_GRADES, apply_imu_errors
from trackmodel.earth import WGS84
from trackmodel.io import read_track
from trackmodel.sections import Section
from trackmodel.track import Origin, Track

#: Sums of squares in a different order: relative rounding ~1e-16 per term.
RTOL_SUMS = 1e-12
#: The streamed and the in-memory filter see the same samples, epochs and start; only the
#: chunk boundaries at segment ends differ (each chunk's track linearization starts from
#: the engine's state there), which the model's third-order track expansion absorbs to
#: rounding (measured: 4e-14 m). 1e-9 m / 1e-9 relative leaves room for other platforms.
ATOL_STREAM_M = 1e-9
RTOL_STREAM = 1e-9
#: Explicit-loop Gauss–Markov against scipy's lfilter: the biases agree to ~1e-19; added
#: to a specific force of ~10 m/s² the sums may round one ulp apart (1.8e-15): two ulps.
ATOL_GM_MPS2 = 4e-15


@pytest.fixture(scope="module")
def nav():
    return read_rinex_nav(default_nav_path())


def _errors(rng, n: int) -> ErrorSeries:
    t = np.arange(n) * 0.1
    values = {q: rng.standard_normal(n) for q in ERROR_QUANTITIES}
    values["attitude_rad"][rng.random(n) < 0.1] = np.nan        # some unknown values
    return ErrorSeries(time_s=t, **values, nees=rng.chisquare(5, n), nees_dof=5)


def _slice(errors: ErrorSeries, a: int, b: int) -> ErrorSeries:
    return ErrorSeries(**{k: (v[a:b] if isinstance(v, np.ndarray) else v)
                          for k, v in errors.__dict__.items()})


def test_running_summary_equals_summarize_of_the_whole_series(rng):
    """Blocks of random lengths (an outage ending in one block and starting in another,
    one whose last sample is NaN) give summarize's dictionary."""
    errors = _errors(rng, 2000)
    errors.attitude_rad[1299] = np.nan                      # last sample of outage 2
    outages = ((10.0, 20.5), (100.0, 30.0), (150.0, 5.0), (500.0, 10.0))   # last: after
    reference = summarize(errors, window=(30.0, 160.0), outages=outages)
    cuts = np.sort(rng.choice(np.arange(1, 2000), size=12, replace=False))
    running = RunningSummary(window=(30.0, 160.0), outages=outages)
    for a, b in zip(np.r_[0, cuts], np.r_[cuts, 2000]):
        running.add(_slice(errors, a, b))
    got = running.summary()
    assert [o["start_s"] for o in got["outages"]] == [o["start_s"] for o in reference["outages"]]
    assert got["outages"][1]["at_end"]["attitude_rad"] is None
    _assert_same(got, reference)


def _assert_same(got, reference) -> None:
    if isinstance(reference, dict):
        assert set(got) == set(reference)
        for key in reference:
            _assert_same(got[key], reference[key])
    elif isinstance(reference, list):
        assert len(got) == len(reference)
        for a, b in zip(got, reference):
            _assert_same(a, b)
    elif isinstance(reference, float):
        assert got == pytest.approx(reference, rel=RTOL_SUMS, abs=0.0)
    else:
        assert got == reference


def _ideal_record(n: int) -> Imu:
    track = read_track(TRACKS_DIR / "curvy.csv")
    truth = simulate_truth(track, constant_speed(20.0), duration_s=(n - 1) / 100.0)
    return ideal_imu(track, truth)


def test_imu_error_stream_in_one_block_is_apply_imu_errors():
    """One block draws in apply_imu_errors' order: the same measured record."""
    ideal = _ideal_record(3000)
    expected = apply_imu_errors(ideal, "tactical", np.random.default_rng(11))
    got = ImuErrorStream("tactical", np.random.default_rng(11), dt=ideal.dt).apply(ideal)
    np.testing.assert_array_equal(got.f_b, expected.f_b)
    np.testing.assert_array_equal(got.omega_ib_b, expected.omega_ib_b)


def test_imu_error_stream_blocks_follow_the_error_model():
    """Three blocks against the model of strapdown.imu_errors written as a loop over the
    documented draws: constants once, the Gauss–Markov bias continued across blocks."""
    ideal = _ideal_record(2500)
    sizes = (1000, 999, 501)
    stream = ImuErrorStream("mems", np.random.default_rng(3), dt=ideal.dt)
    edges = np.cumsum((0,) + sizes)
    blocks = [stream.apply(Imu(ideal.time_s[a:b], ideal.f_b[a:b], ideal.omega_ib_b[a:b]))
              for a, b in zip(edges[:-1], edges[1:])]
    rng = np.random.default_rng(3)
    errors = IMU_GRADES["mems"]
    const, state, out = {}, {}, {"accel": [], "gyro": []}
    true = {"accel": ideal.f_b, "gyro": ideal.omega_ib_b}
    for a, b in zip(edges[:-1], edges[1:]):
        for sensor in ("accel", "gyro"):
            p = errors.triad(sensor)
            if sensor not in const:
                scale = p.scale_factor_ppm * 1e-6 * rng.standard_normal(3)
                mis = p.misalignment_rad * rng.standard_normal((3, 3))
                np.fill_diagonal(mis, 0.0)
                const[sensor] = (np.eye(3) + np.diag(scale) + mis, p.bias * rng.standard_normal(3))
                state[sensor] = p.instability * rng.standard_normal(3)
            drive = rng.standard_normal((b - a, 3))
            noise = rng.standard_normal((b - a, 3)) * p.noise_density / math.sqrt(ideal.dt)
            phi = math.exp(-ideal.dt / p.tau_s)
            gm = np.empty((b - a, 3))
            for k in range(b - a):
                state[sensor] = phi * state[sensor] + p.instability * math.sqrt(
                    1.0 - phi * phi) * drive[k]
                gm[k] = state[sensor]
            matrix, bias = const[sensor]
            out[sensor].append(true[sensor][a:b] @ matrix.T + bias + gm + noise)
    np.testing.assert_allclose(np.concatenate([b.f_b for b in blocks]),
                               np.concatenate(out["accel"]), rtol=0, atol=ATOL_GM_MPS2)
    np.testing.assert_allclose(np.concatenate([b.omega_ib_b for b in blocks]),
                               np.concatenate(out["gyro"]), rtol=0, atol=ATOL_GM_MPS2)


def _short_curvy(duration_s: float = 120.0) -> Scenario:
    return replace(get_scenario("curvy"), duration_s=duration_s, outages=((40.0, 30.0),))


def test_segments_continue_the_clock_and_respect_the_outages(nav):
    """Segments of 29.99 s (boundaries off the epoch grid, one inside the outage): each
    segment's clock starts at the previous one's last epoch value; every epoch outside the
    outage has observations, none inside; the segments tile the trip's samples."""
    track = read_track(TRACKS_DIR / "curvy.csv")
    scenario = _short_curvy()
    config = navigator_config_for(scenario)
    segments = list(trip_segments(scenario, track, seed=4, config=config, nav=nav,
                                  segment_s=29.99))
    for prev, seg in zip(segments, segments[1:]):
        assert seg.clock.iloc[0].tolist() == prev.clock.iloc[-1].tolist()
        assert seg.truth_window.time_s[0] == prev.truth.time_s[-1]
    times = np.concatenate([s.imu.time_s for s in segments])
    np.testing.assert_array_equal(times, np.arange(12001) / 100.0)
    epoch_times = np.concatenate([s.gnss.time_s for s in segments])
    nominal = np.arange(121.0)
    np.testing.assert_allclose(epoch_times, nominal[~in_outage(nominal, scenario.outages)],
                               rtol=0, atol=1e-6)


@pytest.mark.parametrize("filter_kind", ["constrained", "unconstrained"])
def test_streamed_run_equals_navigate_on_the_same_data(nav, filter_kind):
    """The stream's statistics against `navigate` + `summarize` on the concatenated
    segments (IMU, observations, truth, clock) from the same initial state."""
    track = read_track(TRACKS_DIR / "curvy.csv")
    scenario = _short_curvy()
    config = navigator_config_for(scenario, filter=filter_kind)
    got = stream_simulated(track, scenario, config=config, seed=5, segment_s=29.99,
                           nav=nav).summary
    segments = list(trip_segments(scenario, track, seed=5, config=config, nav=nav,
                                  segment_s=29.99))
    imu = Imu(*(np.concatenate([getattr(s.imu, k) for s in segments])
                for k in ("time_s", "f_b", "omega_ib_b")))
    obs = RinexObs(segments[0].obs.header,
                   pd.concat([s.obs.table for s in segments], ignore_index=True))
    initial = _initial_state(make_filter(track, config, None), config, scenario, segments[0], 5)
    result = navigate(track, SensorData(scenario.start_gps_time_s, imu=imu, obs=obs, nav=nav),
                      config, initial=initial)
    truth = segments[0].truth
    for s in segments[1:]:
        truth = concat_truth(truth, s.truth)
    clock = pd.concat([s.clock for s in segments]).drop_duplicates("time_s")

    def clock_truth(t):
        return (np.interp(t, clock["time_s"], clock["clock_bias_m"]),
                np.interp(t, clock["time_s"], clock["clock_drift_mps"]))

    reference = summarize(error_series(result, truth, track, clock_truth=clock_truth),
                          outages=scenario.outages)
    for q in ERROR_QUANTITIES:
        for stat in ("rms", "max"):
            assert got["errors"]["all"][q][stat] == pytest.approx(
                reference["all"][q][stat], rel=RTOL_STREAM, abs=ATOL_STREAM_M), (q, stat)
    end_got, end_ref = got["errors"]["outages"][0], reference["outages"][0]
    assert end_got["end_sample_s"] == end_ref["end_sample_s"]
    for q in ("along_track_m", "cross_track_m", "position_3d_m", "speed_mps"):
        assert end_got["at_end"][q] == pytest.approx(end_ref["at_end"][q], rel=RTOL_STREAM,
                                                     abs=ATOL_STREAM_M)
    assert got["errors"]["nees"]["mean"] == pytest.approx(reference["nees"]["mean"],
                                                          rel=RTOL_STREAM)
    assert got["statistics"]["gnss_epochs"] == result.n_epochs
    assert got["steps"] == 12000
    # the divergence monitor runs in the stream as in navigate (track-based filters only)
    mon = result.statistics().get("monitor")
    assert (mon is None) == (filter_kind == "unconstrained")
    if mon is not None:
        assert got["statistics"]["monitor"]["epochs"] == mon["epochs"]
        assert got["statistics"]["monitor"]["final_status"] == mon["final_status"]
        assert sum(got["statistics"]["monitor"]["estimate_rows"].values()) > 0


def test_outputs_decimated_and_atomic(tmp_path, nav, caplog):
    """estimates.csv / errors.csv at 1 Hz and summary.json; a trip that reaches the end
    of a 500-m track stops there without unused epochs; an interrupted stream leaves no
    output file; the GNSS-only filter does not stream."""
    track = Track([Section(500.0, 30.0, 0.0)], Origin(50.45, 30.52, 100.0), WGS84)
    scenario = replace(get_scenario("paper2017"), duration_s=60.0, outages=((5.0, 5.0),))
    with caplog.at_level(logging.WARNING):
        out = stream_simulated(track, scenario, seed=1, segment_s=7.0, nav=nav,
                               out_dir=tmp_path / "run")
    assert not [r for r in caplog.records if "were not used" in r.getMessage()]
    last = simulate_truth(track, scenario.profile, duration_s=60.0).time_s[-1]
    stored_last = out.summary["duration_s"]        # the last step's start, stored at 10 Hz
    assert last - 0.1 - 1e-9 <= stored_last < last
    estimates = pd.read_csv(tmp_path / "run" / "estimates.csv")
    errors = pd.read_csv(tmp_path / "run" / "errors.csv")
    np.testing.assert_allclose(estimates["time_s"], np.arange(estimates.shape[0]), atol=1e-9)
    assert estimates.shape[0] == math.floor(stored_last) + 1 == errors.shape[0]
    assert sorted(p.name for p in (tmp_path / "run").iterdir()) == [
        "errors.csv", "estimates.csv", "summary.json"]

    def interrupt(done, total):
        if done > 1000:
            raise KeyboardInterrupt

    with pytest.raises(KeyboardInterrupt):
        stream_simulated(track, scenario, seed=1, segment_s=7.0, nav=nav,
                         out_dir=tmp_path / "cut", progress=interrupt)
    assert list((tmp_path / "cut").iterdir()) == []
    with pytest.raises(ConfigError, match="streaming runs"):
        stream_simulated(track, scenario, config=navigator_config_for(
            scenario, filter="gnss-only"), nav=nav)
