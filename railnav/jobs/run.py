"""One navigation run from end to end: the public API behind ``railnav run``.

* `run_simulated` simulates a scenario on a track (truth, IMU, GNSS: `railnav.simulation.trip`) and
  filters it, starting from the truth with errors drawn from the filter's own initial
  covariance (so that NEES is meaningful);
* `run_files` filters recorded or previously simulated files (IMU CSV, RINEX obs + nav,
  GNSS position fixes), starting from the first GNSS fix; a reference (railnav's truth.csv,
  a reference trajectory or a fix file: `railnav.jobs.scoring`), given or found beside
  ``railnav simulate``'s files, is used for the errors;
* `write_run` writes ``estimates.csv``, ``innovations.csv``, ``summary.json`` (+ ``errors.csv``
  with a truth that has samples of the run, ``smoothed.csv`` with ``smooth=True``) and the
  plots, each file atomically.
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

from gnss_obs.dgps import augment_files
from railnav.config import DEFAULT_SYSTEMS, NavigatorConfig
from railnav.defaults import DEFAULT_SEED
from railnav.errors import ConfigError
from railnav.evaluation.metrics import (
    ErrorSeries,
    check_trip_times,
    error_series,
    summarize,
)
from railnav.evaluation.reference import read_reference
from railnav.filters.fix_epochs import FixModelConfig
from railnav.filters.noise_scale import NoiseScaleConfig
from railnav.jobs.plot_worker import PlotHelper, draw
from railnav.jobs.run_figures import run_figures
from railnav.jobs.scoring import (
    file_outages,
    find_truth,
    score_run,
    with_timestamps,
)
from railnav.jobs.sensor_files import read_sensor_files, sensor_summary
from railnav.jobs.smoothed import smooth_outcome, write_smoothed
from railnav.navigation.initialization import initial_from_truth
from railnav.navigation.navigator import navigate
from railnav.navigation.result import CSV_DECIMALS, CSV_FLOAT_FORMAT, NavigationResult
from railnav.sensor_data import SensorData
from railnav.simulation.scenarios import RNG_STREAMS, Scenario
from railnav.simulation.trip import (
    SimulatedTrip,
    navigator_config_for,
    simulate_trip,
)
from trackmodel.files import atomic_write_csv, atomic_write_text

__all__ = ["RunOutcome", "run_simulated", "run_files", "write_run", "run_figures",
           "run_plot_helper",
           "CSV_FLOAT_FORMAT", "read_sensor_files", "run_summary", "truth_start"]

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
    smoothed : railnav.jobs.smoothed.SmoothedRun or None
        The RTS-smoothed twin, for runs with ``smooth=True``.
    """

    result: NavigationResult
    track: object
    summary: dict
    errors: ErrorSeries | None = None
    trip: SimulatedTrip | None = None
    truth: object = None
    data: SensorData | None = None
    smoothed: object = None


def run_simulated(track, scenario: Scenario, *, config: NavigatorConfig | None = None,
                  seed: int = DEFAULT_SEED, systems: str = DEFAULT_SYSTEMS, window: tuple[float, float] | None = None,
                  faults: tuple = (), smooth: bool = False,
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
    smooth : bool
        Also the RTS-smoothed twin, scored like the run (`railnav.jobs.smoothed`).
    progress : callable(done, total), optional
        Filter steps.
    """
    config = config or navigator_config_for(scenario, systems=systems)
    config = replace(config, rts_smoothing=True) if smooth else config
    trip = simulate_trip(scenario, track=track, seed=seed, systems=systems, faults=faults)
    check_trip_times(float(trip.truth.time_s[-1]), window=window)   # outages: simulate_trip
    result = navigate(trip.track, trip.sensor_data(), config, outages=scenario.outages,
                      initial=functools.partial(truth_start, trip=trip, config=config),
                      progress=progress)
    score = functools.partial(error_series, truth=trip.truth, track=trip.track,
                              clock_truth=trip.clock_truth)
    errors = score(result)
    summary = run_summary(result, trip.track, errors, window, scenario.outages,
                       {"scenario": scenario.name, "seed": int(seed), "systems": systems})
    outcome = RunOutcome(result, trip.track, summary, errors, trip, trip.truth)
    return smooth_outcome(outcome, score, window=window) if smooth else outcome


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


def run_files(track, *, imu_path=None, obs_path=None, nav_path=None, fixes_path=None,
              truth_path=None, truth_quality: str | None = None,
              start_gps_time_s: float | None = None, config: NavigatorConfig | None = None,
              filter: str | None = None, systems: str | None = None,
              imu_grade: str | None = None, fix_sigmas=None,
              fix_model: FixModelConfig | None = None, outages=None, window=None,
              base_path=None, base_lat_lon_h: tuple[float, float, float] | None = None,
              smoothing=None, sp3_paths=(), max_correction_age_s: float | None = None,
              progress: Callable[[int, int], None] | None = None, imu_spec=None,
              odometer_path=None, balises_path=None, wheel_circumference_m=None,
              pulses_per_rev=None, odometer_model=None, balise_model=None,
              lever_arms=None, smooth: bool = False, track_attitude=None,
              standstill=None, suspension_noise: bool | None = None,
              monitor=None, sigma_pr_m: float | None = None,
              sigma_rr_mps: float | None = None,
              noise_scale: bool | None = None) -> RunOutcome:
    """Filter sensor files on a track, and score the run when a reference is known.

    Parameters
    ----------
    track : trackmodel.Track
    imu_path : path, optional
        ``imu.csv`` (`strapdown.imu.read_imu_csv`), times from the trip start.
    obs_path, nav_path : path, optional
        RINEX observation and navigation files (both or neither).
    fixes_path : path, optional
        GNSS position fixes: CSV, NMEA, UBX or GPX (`gnss_obs.fixes.read_fixes`).
    truth_path, truth_quality : path, str, optional
        A reference to score against (`railnav.evaluation.reference.read_reference`:
        ``truth.csv``, a reference trajectory or a fix file, its rows of class
        `truth_quality`, default its best); default: the ``truth.csv`` beside the
        ``scenario.json`` of files written by ``railnav simulate``.
    start_gps_time_s : float, optional
        GPS time of the IMU's ``time_s = 0``; default: from ``scenario.json`` beside the
        input files (written by ``railnav simulate``), else the first GNSS epoch or fix.
    config : NavigatorConfig, optional
        Default: for files written by ``railnav simulate`` (a ``scenario.json`` beside the
        inputs) the simulation's sensor models
        (`railnav.simulation.trip.navigator_config_from_simulation`); otherwise `NavigatorConfig`'s
        defaults (GNSS σ from elevation and C/N0). `filter`, `systems`, `imu_grade`,
        `fix_model`, `sigma_pr_m`, `sigma_rr_mps`, `odometer_model`, `balise_model` and
        `lever_arms` shape the default only: given with `config`, they are refused
        (`ConfigError`), not ignored.
    filter : str, optional
        Default `railnav.config.DEFAULT_FILTER` with an IMU file, else ``gnss-only``.
    systems : str, optional
        GNSS systems to use (default: the simulated ones, else `railnav.config.DEFAULT_SYSTEMS`).
    imu_grade : str, optional
        The IMU grade the filter assumes (`strapdown.imu_errors.IMU_GRADES`); default: the
        simulated grade for files written by ``railnav simulate``. A recorded IMU file
        (no ``scenario.json`` beside it) needs one for the inertial filters.
    fix_sigmas, fix_model : dict of str to FixSigmas, FixModelConfig, optional
        σ of the fix classes the fix file lacks (`gnss_obs.fixes.quality`); the fix
        rows' assumptions (`railnav.filters.fix_epochs.FixModelConfig`).
    outages : sequence of gnss_obs.Outage or (start_s, duration_s), optional
        Windows whose GNSS data and fixes are ignored (s from the trip start); default:
        the outages of ``scenario.json`` (``railnav simulate``'s files), else none.
    window, progress : (start_s, end_s), callable(done, total), optional
    base_path : path, optional
        Base-station RINEX observations: code-differential pseudorange rows
        (`gnss_obs.augment`).
    base_lat_lon_h : (lat_deg, lon_deg, h_m), optional
        Base position (default: its header's APPROX POSITION XYZ).
    smoothing : gnss_obs.SmoothingConfig, optional
        Carrier-smooth the code (rover and base).
    sp3_paths : sequence of path
        Precise orbit/clock files for the GNSS rows.
    max_correction_age_s : float, optional
        Oldest base correction applied (default `gnss_obs.DgpsConfig`'s).
    imu_spec : strapdown.ImuSpec or path, optional
        How the IMU file is laid out (columns, units, increments, mounting) and, in its
        ``[noise]`` table, what the filter assumes (`strapdown.imu_spec`; instead of
        `imu_grade`); default railnav's ``imu.csv``. The log's timing and plausibility are
        checked (`strapdown.imu_log.read_imu_log`).
    odometer_path, balises_path : path, optional
        Odometer readings and balise passages (`railnav.sensors`); the constrained and
        GNSS-only filters.
    wheel_circumference_m, pulses_per_rev : float, optional
        The wheel of an odometer file of pulse counts.
    odometer_model, balise_model, lever_arms : optional
        `NavigatorConfig` fields for the default configuration (default theirs).
    smooth : bool
        Also the RTS-smoothed twin, scored like the run (`railnav.jobs.smoothed`).
    track_attitude, standstill : optional
        `NavigatorConfig` fields (default None: off) applied to whichever configuration
        (`railnav.filters.attitude_rows`, `railnav.filters.standstill_rows`).
    suspension_noise : bool, optional
        `NavigatorConfig.suspension_noise` applied to whichever configuration (default
        None: the configuration's own; True for files simulated with a car body).
    monitor : railnav.navigation.monitor_config.MonitorConfig, optional
        The divergence monitor applied to whichever configuration (default None: the
        configuration's own, on with recovery; ``MonitorConfig(recover=False)`` is
        ``railnav run --no-recover``).
    sigma_pr_m, sigma_rr_mps : float, optional
        The receiver's pseudorange (m) and range-rate (m/s) σ at zenith and high C/N0 in the
        default configuration (`railnav.jobs.sensor_files`; default: the simulation's for
        ``railnav simulate``'s files, else `gnss_obs.MeasurementConfig`'s, a real
        receiver's).
    noise_scale : bool, optional
        The GNSS rows' adaptive noise scale (`railnav.filters.noise_scale`) applied to
        whichever configuration: False off (the rows keep the σ given; ``railnav run
        --no-noise-scale``), True on with `NoiseScaleConfig`'s defaults; default None: the
        configuration's own (on by default).
    """
    data, config = read_sensor_files(imu_path=imu_path, obs_path=obs_path, nav_path=nav_path,
                                     fixes_path=fixes_path, start_gps_time_s=start_gps_time_s,
                                     config=config, filter=filter, systems=systems,
                                     imu_grade=imu_grade, fix_sigmas=fix_sigmas,
                                     fix_model=fix_model, imu_spec=imu_spec,
                                     odometer_path=odometer_path, balises_path=balises_path,
                                     wheel_circumference_m=wheel_circumference_m,
                                     pulses_per_rev=pulses_per_rev,
                                     odometer_model=odometer_model, balise_model=balise_model,
                                     lever_arms=lever_arms, sigma_pr_m=sigma_pr_m,
                                     sigma_rr_mps=sigma_rr_mps)
    config = replace(config, rts_smoothing=True) if smooth else config
    if track_attitude is not None or standstill is not None:
        config = replace(config, track_attitude=track_attitude, standstill=standstill)
    if suspension_noise is not None:
        config = replace(config, suspension_noise=suspension_noise)
    if monitor is not None:
        config = replace(config, monitor=monitor)
    if noise_scale is not None:
        config = replace(config, noise_scale=NoiseScaleConfig() if noise_scale else None)
    if base_path is not None or smoothing is not None or sp3_paths or base_lat_lon_h:
        data = _augmented(data, config, base_path=base_path, base_lat_lon_h=base_lat_lon_h,
                          smoothing=smoothing, sp3_paths=sp3_paths,
                          max_correction_age_s=max_correction_age_s)
    own = outages is not None
    outages = file_outages(outages, imu_path, obs_path, fixes_path)
    check_trip_times(data.end_s, outages=outages, window=window,
                     early_end="" if own else "where the simulated files end")
    result = with_timestamps(navigate(track, data, config, outages=outages,
                                      progress=progress), data.fixes)
    return _file_outcome(result, track, data, truth_path or find_truth(
        imu_path, obs_path, fixes_path), truth_quality, window, tuple(outages), smooth)


def _file_outcome(result, track, data: SensorData, truth_path, truth_quality, window,
                  outages, smooth: bool) -> RunOutcome:
    """A file run's outcome: scored against `truth_path` when there is one."""
    score = None if truth_path is None else functools.partial(
        score_run, track=track, truth_path=truth_path, start_gps_time_s=data.start_gps_time_s,
        quality=truth_quality, reference=_reference(track, data, truth_path, truth_quality))
    errors, extra = None, {}
    if score is not None:
        errors, extra["reference"] = score(result)
    if data.fixes is not None:
        extra["fixes"] = {"path": data.fixes.path, "format": data.fixes.format,
                          "read": len(data.fixes), "skipped": dict(data.fixes.skipped)}
    extra.update(sensor_summary(data))
    outcome = RunOutcome(result, track, run_summary(result, track, errors, window, outages,
                                                    extra), errors, data=data)
    return smooth_outcome(outcome, score and (lambda r: score(r)[0]), window=window) \
        if smooth else outcome


def _reference(track, data: SensorData, truth_path, truth_quality):
    """The reference file read once for the run and its smoothed twin; the run's own fix
    file, given as its reference, is not read again."""
    try:
        same = data.fixes is not None and os.path.samefile(data.fixes.path, truth_path)
    except OSError:                          # a missing file: read_reference says which
        same = False
    return read_reference(truth_path, track, start_gps_time_s=data.start_gps_time_s,
                          quality=truth_quality, fixes=data.fixes if same else None)


def _augmented(data: SensorData, config: NavigatorConfig, *, base_path, base_lat_lon_h,
               smoothing, sp3_paths, max_correction_age_s) -> SensorData:
    """`data` with carrier-smoothed observations, base corrections and precise orbits."""
    if data.obs is None:
        raise ConfigError("base corrections, smoothing and SP3 need GNSS observations (--obs)")
    aug = augment_files(data.obs, data.nav, config.measurement, base_path=base_path,
                        base_lat_lon_h=base_lat_lon_h, smoothing=smoothing,
                        sp3_paths=sp3_paths, max_age_s=max_correction_age_s)
    return replace(data, obs=aug.obs, augmentation=aug)


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


def write_run(outcome: RunOutcome, out_dir: str | os.PathLike, *, plots: bool = True,
              plotter: PlotHelper | None = None) -> list[Path]:
    """Write a run's files into `out_dir` (created); returns the paths written.

    `plots`: also draw the PNG figures (``railnav run --no-plots``: False). With `plotter`
    (started before the run, `railnav.jobs.plot_worker`), its helper process draws the
    figures while this one writes the tables; without, they are drawn here after the
    tables.
    """
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    figures = run_figures(outcome, out) if plots else []
    if plotter is not None:
        plotter.submit(figures)
    written = []

    def csv(name: str, frame: pd.DataFrame) -> None:
        atomic_write_csv(out / name, frame, float_format=CSV_FLOAT_FORMAT, decimals=CSV_DECIMALS)
        written.append(out / name)

    csv("estimates.csv", outcome.result.estimates)
    csv("innovations.csv", outcome.result.innovations)
    if outcome.errors is not None and outcome.errors.compared:
        csv("errors.csv", outcome.errors.to_frame())
    written += write_smoothed(outcome.smoothed, out)
    atomic_write_text(out / "summary.json", json.dumps(outcome.summary, indent=2) + "\n")
    written.append(out / "summary.json")
    if plotter is not None:
        plotter.wait()
    else:
        draw(figures)
    return written + [figure.path for figure in figures]
