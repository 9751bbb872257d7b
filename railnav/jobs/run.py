"""One navigation run from end to end: the public API behind ``railnav run``.

* `run_simulated` simulates a scenario on a track (truth, IMU, GNSS: `railnav.simulation.trip`) and
  filters it, starting from the truth with errors drawn from the filter's own initial
  covariance (so that NEES is meaningful);
* `run_files` filters recorded or previously simulated files (IMU CSV, RINEX obs + nav),
  starting from the first GNSS fix; a truth CSV, when given, is used for the errors;
* `write_run` writes ``estimates.csv``, ``innovations.csv``, ``summary.json`` (and
  ``errors.csv`` with a truth) and the plots into a directory, each file atomically.
"""
from __future__ import annotations

import functools
import json
import logging
import os
from dataclasses import dataclass, replace
from pathlib import Path
from typing import Callable

import numpy as np
import pandas as pd

from gnss_obs.measurements import MeasurementConfig
from gnss_obs.rinex_nav import read_rinex_nav
from gnss_obs.rinex_obs import read_rinex_obs
from railnav.config import (
    DEFAULT_FILTER,
    DEFAULT_SYSTEMS,
    NavigatorConfig,
    SensorData,
    check_gnss_pair,
)
from railnav.errors import ConfigError
from railnav.evaluation.metrics import ErrorSeries, error_series, summarize
from railnav.filters.protocol import filter_kind
from railnav.navigation.initialization import initial_from_truth
from railnav.navigation.navigator import navigate
from railnav.navigation.result import CSV_DECIMALS, CSV_FLOAT_FORMAT, NavigationResult
from railnav.simulation.scenarios import RNG_STREAMS, Scenario
from railnav.simulation.trip import (
    SimulatedTrip,
    navigator_config_for,
    navigator_config_from_simulation,
    simulate_trip,
)
from strapdown.imu import read_imu_csv
from strapdown.imu_errors import IMU_GRADES
from trackmodel.files import atomic_write_csv, atomic_write_text

__all__ = ["RunOutcome", "run_simulated", "run_files", "write_run", "CSV_FLOAT_FORMAT",
           "read_sensor_files", "run_summary", "truth_start"]

log = logging.getLogger(__name__)



@dataclass(frozen=True, eq=False)
class RunOutcome:
    """A finished run.

    Attributes
    ----------
    result : NavigationResult
    track : trackmodel.Track
    summary : dict
        The ``summary.json`` content.
    errors : railnav.evaluation.metrics.ErrorSeries or None
        Against the truth, when known.
    trip : SimulatedTrip or None
        The simulation, for simulated runs.
    truth : railnav.simulation.truth.Truth or None
    data : SensorData or None
        The sensor data read, for runs on files.
    """

    result: NavigationResult
    track: object
    summary: dict
    errors: ErrorSeries | None = None
    trip: SimulatedTrip | None = None
    truth: object = None
    data: SensorData | None = None


def run_simulated(track, scenario: Scenario, *, config: NavigatorConfig | None = None,
                  seed: int = 0, systems: str = DEFAULT_SYSTEMS, window: tuple[float, float] | None = None,
                  faults: tuple = (),
                  progress: Callable[[int, int], None] | None = None) -> RunOutcome:
    """Simulate `scenario` on `track` and filter it.

    Parameters
    ----------
    track : trackmodel.Track or path
    scenario : Scenario
        Outages, IMU grade, GNSS σ... (see `railnav.simulation.scenarios`).
    config : NavigatorConfig, optional
        Default: `railnav.simulation.trip.navigator_config_for(scenario)` (the filter assumes what is
        simulated).
    seed : int
    systems : str
        GNSS systems simulated and used.
    window : (start_s, end_s), optional
        Extra error-summary window.
    faults : tuple of gnss_obs.SatelliteFault
        Satellite faults simulated in the GNSS observations (times from the trip start).
    progress : callable(done, total), optional
        Filter steps.
    """
    config = config or navigator_config_for(scenario, systems=systems)
    trip = simulate_trip(scenario, track=track, seed=seed, systems=systems, faults=faults)
    result = navigate(trip.track, trip.sensor_data(), config, outages=scenario.outages,
                      initial=functools.partial(truth_start, trip=trip, config=config),
                      progress=progress)
    errors = error_series(result, trip.truth, trip.track, clock_truth=trip.clock_truth)
    summary = run_summary(result, trip.track, errors, window, scenario.outages,
                       {"scenario": scenario.name, "seed": int(seed), "systems": systems})
    return RunOutcome(result, trip.track, summary, errors, trip, trip.truth)


def truth_start(filt, trip: SimulatedTrip, config: NavigatorConfig, x_true=None):
    """A simulated run's start: the true state plus an error drawn from the filter's own
    initial covariance (`railnav.navigation.initialization.initial_from_truth`; the draw depends on
    the trip's seed only).

    Parameters
    ----------
    filt : railnav.filters.protocol.Filter
        The run's filter object.
    trip : SimulatedTrip
    config : NavigatorConfig
    x_true : ndarray, shape (n,), optional
        The true state at the trip start in the filter's layout (default: from
        ``filt.truth_states``).
    """
    scenario = trip.scenario
    states, known = filt.truth_states(trip.truth, *trip.clock_truth(trip.truth.time_s))
    if x_true is None:
        x_true = states[0]
    P0 = filt.initial_covariance(sigma_s_m=config.initial_s_sigma_m or scenario.initial_s_sigma_m,
                                 sigma_v_mps=config.initial_v_sigma_mps
                                 or scenario.initial_v_sigma_mps)
    rng = np.random.default_rng(trip.simulation.rng_streams[RNG_STREAMS["initial"]])
    return initial_from_truth(x_true, P0, time_s=float(trip.truth.time_s[0]), rng=rng,
                              drawn=known)


def run_files(track, *, imu_path=None, obs_path=None, nav_path=None,
              start_gps_time_s: float | None = None, config: NavigatorConfig | None = None,
              filter: str = DEFAULT_FILTER, systems: str | None = None,
              imu_grade: str | None = None, outages=(),
              window: tuple[float, float] | None = None,
              progress: Callable[[int, int], None] | None = None) -> RunOutcome:
    """Filter sensor files on a track.

    Parameters
    ----------
    track : trackmodel.Track
    imu_path : path, optional
        ``imu.csv`` (`strapdown.imu.read_imu_csv`), times from the trip start.
    obs_path, nav_path : path, optional
        RINEX observation and navigation files (both or neither).
    start_gps_time_s : float, optional
        GPS time of the IMU's ``time_s = 0``; default: from ``scenario.json`` beside the IMU
        file (written by ``railnav simulate``), else the first GNSS epoch.
    config : NavigatorConfig, optional
        Default: for files written by ``railnav simulate`` (a ``scenario.json`` beside the
        IMU or observation file) the simulation's sensor models
        (`railnav.simulation.trip.navigator_config_from_simulation`); otherwise `NavigatorConfig`'s
        defaults (GNSS σ from elevation and C/N0). `filter`, `systems` and `imu_grade`
        apply to the default only.
    filter : str
    systems : str, optional
        GNSS systems to use (default: the simulated ones, else `railnav.config.DEFAULT_SYSTEMS`).
    imu_grade : str, optional
        The IMU grade the filter assumes (`strapdown.imu_errors.IMU_GRADES`); default: the
        simulated grade for files written by ``railnav simulate``. A recorded IMU file
        (no ``scenario.json`` beside it) needs one for the inertial filters.
    outages : sequence of (start_s, duration_s)
        Windows whose GNSS data are ignored (s from the trip start).
    window : (start_s, end_s), optional
    progress : callable(done, total), optional
    """
    data, config = read_sensor_files(imu_path=imu_path, obs_path=obs_path, nav_path=nav_path,
                                     start_gps_time_s=start_gps_time_s, config=config,
                                     filter=filter, systems=systems, imu_grade=imu_grade)
    result = navigate(track, data, config, outages=outages, progress=progress)
    summary = run_summary(result, track, None, window, tuple(outages), {})
    return RunOutcome(result, track, summary, data=data)


def read_sensor_files(*, imu_path=None, obs_path=None, nav_path=None,
                      start_gps_time_s: float | None = None,
                      config: NavigatorConfig | None = None, filter: str = DEFAULT_FILTER,
                      systems: str | None = None, imu_grade: str | None = None
                      ) -> tuple[SensorData, NavigatorConfig]:
    """The sensor data of `run_files` and the navigator configuration it uses (see there
    for the parameters and the defaults).

    Raises
    ------
    ConfigError
        Observations without navigation data (or the reverse); a recorded IMU file
        without the grade the filter should assume.
    """
    check_gnss_pair(obs_path, nav_path)
    imu = read_imu_csv(imu_path) if imu_path is not None else None
    if config is None:
        config = _default_file_config(imu_path, obs_path, filter, systems, imu_grade)
    obs = read_rinex_obs(obs_path) if obs_path is not None else None
    nav = read_rinex_nav(nav_path) if nav_path is not None else None
    if start_gps_time_s is None:
        start_gps_time_s = _start_time(imu_path, obs)
    return SensorData(float(start_gps_time_s), imu=imu, obs=obs, nav=nav), config


def _simulation_meta(*paths) -> dict | None:
    """The ``scenario.json`` beside the first of `paths` that has one (None if none)."""
    for path in paths:
        if path is None:
            continue
        meta = Path(path).with_name("scenario.json")
        if meta.is_file():
            try:
                return json.loads(meta.read_text())
            except ValueError as exc:
                raise ConfigError(f"{meta}: not valid JSON ({exc})") from None
    return None


def _default_file_config(imu_path, obs_path, filter: str, systems: str | None,
                         imu_grade: str | None) -> NavigatorConfig:
    meta = _simulation_meta(imu_path, obs_path)
    if meta is not None:
        extra = {} if systems is None else {"measurement": replace(
            navigator_config_from_simulation(meta).measurement, systems=systems)}
        if imu_grade is not None:
            extra["imu_errors"] = imu_grade
        log.info("sensor models from the simulation's scenario.json")
        return navigator_config_from_simulation(meta, filter=filter, **extra)
    if imu_grade is None and imu_path is not None and filter_kind(filter).needs_imu:
        raise ConfigError(f"{imu_path}: a recorded IMU file needs the grade the filter "
                          f"assumes: give --imu-grade ({', '.join(sorted(IMU_GRADES))})")
    grade = {} if imu_grade is None else {"imu_errors": imu_grade}
    return NavigatorConfig(filter=filter, **grade,
                           measurement=MeasurementConfig(systems=systems or DEFAULT_SYSTEMS))


def _start_time(imu_path, obs) -> float:
    """The trip's start in GPS time when the user did not give it."""
    meta = _simulation_meta(imu_path)
    if meta is not None:
        try:
            return float(meta["scenario"]["start_gps_time_s"])
        except (KeyError, ValueError, TypeError) as exc:
            raise ConfigError(f"scenario.json: no scenario.start_gps_time_s ({exc})") from None
    if obs is not None and len(obs.table):
        return float(obs.table["gps_time_s"].iloc[0])
    raise ConfigError("cannot tell when the trip starts: give --start-gps-time-s")


def run_summary(result: NavigationResult, track, errors, window, outages, extra: dict) -> dict:
    """The ``summary.json`` content of a run: filter, track, duration, statistics, left
    track, `extra` keys, and with `errors` their summary (`railnav.evaluation.metrics.summarize`)."""
    est = result.estimates
    out = {"filter": result.filter, **extra,
           "track": {"length_m": float(track.length_m), "earth": track.earth.name},
           "start_gps_time_s": result.start_gps_time_s,
           "duration_s": float(est["time_s"].iloc[-1] - est["time_s"].iloc[0]) if len(est) else 0.0,
           "steps": result.n_steps, "outages": [list(o) for o in outages],
           "runtime_s": result.runtime_s, "statistics": result.statistics(),
           "left_track": result.left_track}
    if errors is not None:
        out["errors"] = summarize(errors, window=window, outages=outages)
    return out


def write_run(outcome: RunOutcome, out_dir: str | os.PathLike, *, plots: bool = True) -> list[Path]:
    """Write a run's files into `out_dir` (created); returns the paths written."""
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    written = []

    def csv(name: str, frame: pd.DataFrame) -> None:
        atomic_write_csv(out / name, frame, float_format=CSV_FLOAT_FORMAT, decimals=CSV_DECIMALS)
        written.append(out / name)

    csv("estimates.csv", outcome.result.estimates)
    csv("innovations.csv", outcome.result.innovations)
    if outcome.errors is not None:
        csv("errors.csv", outcome.errors.to_frame())
    atomic_write_text(out / "summary.json", json.dumps(outcome.summary, indent=2) + "\n")
    written.append(out / "summary.json")
    if plots:                       # matplotlib only when drawing (~0.5 s to import)
        from railnav.evaluation.plots import (
            plot_errors,
            plot_estimates,
            plot_track_estimate,
        )
        if outcome.errors is not None:
            plot_errors(outcome.errors, outcome.result, out / "errors.png")
            written.append(out / "errors.png")
        else:
            plot_estimates(outcome.result, out / "estimates.png")
            written.append(out / "estimates.png")
        plot_track_estimate(outcome.track, outcome.result, out / "track.png", truth=outcome.truth)
        written.append(out / "track.png")
    return written
