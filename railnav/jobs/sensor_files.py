"""The sensor files of a file run: reading them, and the configuration they imply.

`read_sensor_files` is what `railnav.jobs.run.run_files` reads (and
`railnav.jobs.tracks.run_files_tracks`): the IMU log (`strapdown.imu_log.read_imu_log` with
its spec: layout, units, mounting, plausibility; `--imu-spec`), RINEX observations and
navigation data, GNSS fixes, odometer readings and balise passages
(`railnav.sensors`), with the trip's start time and the navigator configuration:

* for files written by ``railnav simulate`` (a ``scenario.json`` beside them) the
  simulation's sensor models; otherwise `NavigatorConfig`'s defaults;
* the IMU noise the filter assumes: the spec's ``[noise]``, else ``imu_grade``; a recorded
  IMU needs one of them (both: an error, the spec's is not silently overridden);
* the receiver's GNSS noise, when given (``sigma_pr_m``, ``sigma_rr_mps``: the σ at zenith
  and high C/N0 of `gnss_obs.MeasurementConfig`; ``--sigma-pr-m``/``--sigma-rr-mps``): the
  defaults are a real receiver's, calibrated on the urban drive, and a noisier one (the
  simulator's paper receiver, √15 m and √0.5 m/s) must be told, else the filter trusts
  its rows too much (a simulated 1000-s curvy trip run as plain files: NEES 17 for 5
  states, 52 % of its GNSS rows rejected);
* the odometer and balise models and the lever arms, when given.
"""
from __future__ import annotations

import logging
from dataclasses import replace

from gnss_obs.errors import GnssError
from gnss_obs.fixes.read import read_fixes
from gnss_obs.measurements import MeasurementConfig
from gnss_obs.rinex_nav import read_rinex_nav
from gnss_obs.rinex_obs import read_rinex_obs
from railnav.config import DEFAULT_SYSTEMS, NavigatorConfig
from railnav.defaults import default_filter
from railnav.errors import ConfigError
from railnav.filters.fix_epochs import FixModelConfig
from railnav.filters.protocol import filter_kind
from railnav.jobs.scoring import simulation_meta
from railnav.sensor_data import SensorData, check_gnss_pair
from railnav.simulation.trip import navigator_config_from_simulation
from strapdown.imu_errors import IMU_GRADES

__all__ = ["read_sensor_files", "read_imu_file", "sensor_summary"]

log = logging.getLogger(__name__)


def read_sensor_files(*, imu_path=None, obs_path=None, nav_path=None, fixes_path=None,
                      start_gps_time_s: float | None = None,
                      config: NavigatorConfig | None = None, filter: str | None = None,
                      systems: str | None = None, imu_grade: str | None = None,
                      fix_sigmas=None, fix_model: FixModelConfig | None = None,
                      imu_spec=None, odometer_path=None, balises_path=None,
                      wheel_circumference_m: float | None = None,
                      pulses_per_rev: float | None = None, sigma_pr_m: float | None = None,
                      sigma_rr_mps: float | None = None, **models
                      ) -> tuple[SensorData, NavigatorConfig]:
    """The sensor data of `railnav.jobs.run.run_files` and the navigator configuration it
    uses (see there for the parameters and the defaults; `models`: ``odometer_model``,
    ``balise_model``, ``lever_arms`` of `NavigatorConfig`, applied to the default
    configuration; `sigma_pr_m`, `sigma_rr_mps`: the receiver's GNSS σ in the default
    configuration's `gnss_obs.MeasurementConfig`, default its own).

    Raises
    ------
    ConfigError
        No sensor file; observations without navigation data (or the reverse); a
        recorded IMU file without the noise the filter should assume, or with two of
        them; an input the filter would ignore (`_check_filter_inputs`); with `config`,
        an argument that only shapes the default configuration (`filter`, `systems`,
        `imu_grade`, `fix_model`, `sigma_pr_m`, `sigma_rr_mps`, `models`).
    """
    check_gnss_pair(obs_path, nav_path)
    if imu_path is None and obs_path is None and fixes_path is None:
        raise ConfigError("no sensor data: give imu_path, obs_path with nav_path, or "
                          "fixes_path", arguments=("imu_path", "obs_path", "nav_path",
                                                   "fixes_path"))
    if config is not None:                 # what only the default configuration takes
        _check_config_alone(filter=filter, systems=systems, imu_grade=imu_grade,
                            fix_model=fix_model, sigma_pr_m=sigma_pr_m,
                            sigma_rr_mps=sigma_rr_mps, **models)
    filter = default_filter(filter, imu=imu_path is not None)
    if config is None:                     # before any file is read
        _check_filter_inputs(filter, imu_path=imu_path, imu_grade=imu_grade,
                             fix_model=fix_model)
    imu_log = read_imu_file(imu_path, imu_spec) if imu_path is not None else None
    if config is None:
        config = _default_file_config(imu_path, obs_path, fixes_path, filter, systems,
                                      _imu_assumption(imu_log, imu_grade, imu_path))
        extra = {k: v for k, v in models.items() if v is not None}
        config = replace(config, **({"fix_model": fix_model} if fix_model else {}), **extra)
        config = _receiver_sigmas(config, sigma_pr_m, sigma_rr_mps)
    obs = read_rinex_obs(obs_path) if obs_path is not None else None
    nav = read_rinex_nav(nav_path) if nav_path is not None else None
    fixes = read_fixes(fixes_path, sigmas=fix_sigmas) if fixes_path is not None else None
    odometer, balises = _railway_sensors(odometer_path, balises_path, wheel_circumference_m,
                                         pulses_per_rev)
    if start_gps_time_s is None:
        start_gps_time_s = _start_time(imu_path, imu_log, obs, fixes, fixes_path)
    data = SensorData(float(start_gps_time_s), imu=imu_log.imu if imu_log else None, obs=obs,
                      nav=nav, fixes=fixes, odometer=odometer, balises=balises,
                      imu_log=imu_log)
    return data, config


def _check_config_alone(**given) -> None:
    """With a `NavigatorConfig` given, the arguments that only shape the default
    configuration are errors, never dropped: they belong in that configuration."""
    names = [k for k, v in given.items() if v is not None]
    if names:
        raise ConfigError(f"{', '.join(names)}: given with config, which they would not "
                          "change; set them in the NavigatorConfig instead",
                          arguments=tuple(names))


def _check_filter_inputs(filter: str, *, imu_path, imu_grade, fix_model) -> None:
    """Inputs that `filter` would ignore are errors, never dropped (as ``railnav run``'s):
    an IMU file or grade for a filter that uses no IMU, correlated code-fix errors
    (`FixModelConfig.correlated_code_errors`, the gnss-only filter's) for another."""
    if not filter_kind(filter).needs_imu and (imu_path is not None or imu_grade is not None):
        name = "imu_grade" if imu_grade is not None else "imu_path"
        raise ConfigError(f"{name}: the {filter} filter uses no IMU", arguments=(name,))
    if fix_model is not None and fix_model.correlated_code_errors and filter != "gnss-only":
        raise ConfigError(f"fix_model.correlated_code_errors: the gnss-only filter's, not "
                          f"the {filter} filter's", arguments=("fix_model",))


def read_imu_file(path, spec=None):
    """An IMU log read with its spec (`strapdown.imu_spec.ImuSpec`, a TOML path, or None:
    railnav's ``imu.csv``), timing checked and plausibility tested
    (`strapdown.imu_log.read_imu_log`); gaps are logged. A log without the ``imu.csv``
    columns, read without a spec, is a `ConfigError` that says a spec reads it."""
    from strapdown.errors import ImuColumnsError
    from strapdown.imu_log import read_imu_log
    from strapdown.imu_spec import ImuSpec, read_imu_spec
    if spec is not None and not isinstance(spec, ImuSpec):
        spec = read_imu_spec(spec)
    try:
        imu_log = read_imu_log(path, spec)
    except ImuColumnsError as exc:
        if spec is not None:
            raise
        raise ConfigError(f"{exc}; a log with other columns is read with imu_spec (a TOML "
                          "file naming its columns and units)",
                          arguments=("imu_spec",)) from None
    if imu_log.gaps:
        log.warning("%s: %d gaps in the IMU samples (longest %.3f s at t = %.2f s), "
                    "%d samples missing at %.0f Hz", path, len(imu_log.gaps),
                    max(g[1] for g in imu_log.gaps),
                    max(imu_log.gaps, key=lambda g: g[1])[0], imu_log.dropped_samples,
                    1.0 / imu_log.nominal_interval_s)
    return imu_log


def _imu_assumption(imu_log, imu_grade, imu_path):
    """The IMU noise the filter assumes: the spec's, else the grade (not both)."""
    spec_errors = None if imu_log is None else imu_log.spec.errors
    if spec_errors is not None and imu_grade is not None:
        raise ConfigError(f"{imu_path}: the IMU spec ({imu_log.spec.name}) has a [noise] "
                          f"table and --imu-grade {imu_grade} was given: give one of them")
    return spec_errors if spec_errors is not None else imu_grade


def _receiver_sigmas(config: NavigatorConfig, sigma_pr_m, sigma_rr_mps) -> NavigatorConfig:
    """`config` with the receiver's pseudorange and range-rate σ that are given."""
    given = {k: v for k, v in (("sigma_pr_m", sigma_pr_m), ("sigma_rr_mps", sigma_rr_mps))
             if v is not None}
    if not given:
        return config
    try:
        return replace(config, measurement=replace(config.measurement, **given))
    except GnssError as exc:
        raise ConfigError(str(exc)) from None


def _railway_sensors(odometer_path, balises_path, circumference, per_rev):
    from railnav.sensors.balises import read_balises_csv
    from railnav.sensors.odometer import read_odometer_csv
    if odometer_path is None and (circumference is not None or per_rev is not None):
        raise ConfigError("the wheel circumference and pulses per revolution go with an "
                          "odometer file (--odometer)")
    odometer = None if odometer_path is None else read_odometer_csv(
        odometer_path, wheel_circumference_m=circumference, pulses_per_rev=per_rev)
    return odometer, None if balises_path is None else read_balises_csv(balises_path)


def _default_file_config(imu_path, obs_path, fixes_path, filter: str, systems: str | None,
                         imu_grade) -> NavigatorConfig:
    found = simulation_meta(imu_path, obs_path, fixes_path)
    if found is not None:
        meta = found[0]
        extra = {} if systems is None else {"measurement": replace(
            navigator_config_from_simulation(meta).measurement, systems=systems)}
        if imu_grade is not None:
            extra["imu_errors"] = imu_grade
        log.info("sensor models from the simulation's scenario.json")
        # the scenario's initial σ of s and v are those of a start drawn about the truth
        # (run_simulated); a file run starts from its first fix, with that fix's σ
        return navigator_config_from_simulation(meta, filter=filter, initial_s_sigma_m=None,
                                                initial_v_sigma_mps=None, **extra)
    if imu_grade is None and imu_path is not None and filter_kind(filter).needs_imu:
        raise ConfigError(f"{imu_path}: a recorded IMU file needs the noise the filter "
                          f"assumes: give imu_grade ({', '.join(sorted(IMU_GRADES))}) or "
                          "an imu_spec with a [noise] table",
                          arguments=("imu_grade", "imu_spec"))
    grade = {} if imu_grade is None else {"imu_errors": imu_grade}
    return NavigatorConfig(filter=filter, **grade,
                           measurement=MeasurementConfig(systems=systems or DEFAULT_SYSTEMS))


def _start_time(imu_path, imu_log, obs, fixes, fixes_path) -> float:
    """The trip's start in GPS time when the user did not give it."""
    found = simulation_meta(imu_path, fixes_path)
    if found is not None:
        try:
            return float(found[0]["scenario"]["start_gps_time_s"])
        except (KeyError, ValueError, TypeError) as exc:
            raise ConfigError(f"scenario.json: no scenario.start_gps_time_s ({exc})") from None
    if imu_log is not None and imu_log.start_gps_time_s is not None:
        return imu_log.start_gps_time_s
    starts = []
    if obs is not None and len(obs.table):
        starts.append(float(obs.table["gps_time_s"].iloc[0]))
    if fixes is not None:
        starts.append(float(fixes.table["gps_time_s"].iloc[0]))
    if starts:
        return min(starts)
    raise ConfigError("cannot tell when the trip starts (no GNSS observations or fixes, and "
                      "the IMU log has no GPS time): give start_gps_time_s",
                      arguments=("start_gps_time_s",))


def sensor_summary(data: SensorData) -> dict:
    """The ``summary.json`` entries of the files read: ``imu`` (timing, gaps), ``odometer``
    and ``balises`` files (what the filter made of their rows: the run's statistics)."""
    out = {}
    if data.imu_log is not None:
        out["imu"] = data.imu_log.summary()
    if data.odometer is not None:
        out["odometer_file"] = {"path": data.odometer.path, "kind": data.odometer.kind,
                                "readings": len(data.odometer)}
    if data.balises is not None:
        out["balises_file"] = {"path": data.balises.path, "passages": len(data.balises)}
    return out
