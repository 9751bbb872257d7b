"""Runs on a track network: the public API behind ``railnav run --network`` and
``railnav network run``.

* `run_files_network`: sensor files (fixes, IMU, RINEX) through the network navigator
  (`railnav.navigation.network_navigator.navigate_network`), started at a given netelement
  or at every netelement near the first fix; with ``truth_path`` (a fix file: its
  carrier-fixed rows) scored by issue 13's netelement truth
  (`railnav.jobs.network_scoring`);
* `run_simulated_network`: a trip simulated along one route (its netelements' legs, the
  line `Network.route_track` or, for tangent-continuous joints, the legs chained exactly),
  navigated without being told the route, each start candidate from the truth brought
  onto its own track plus one common error draw, scored per cycle against the true
  netelement (`railnav.jobs.network_scoring.true_netelements`);
* `write_network_run`: ``estimates.csv`` (with the network columns), ``innovations.csv``,
  ``hypotheses.csv``, ``route.csv``, ``summary.json`` (with ``route``), ``errors.csv`` with
  a truth, and the plots ``network.png`` and ``estimates.png``/``errors.png``.

`route_candidates` and `route_name` list the routes ahead of a start (``railnav network
routes``).

**A network without heights** (`trackmodel.network.Network` ``heights``: OpenStreetMap, a
GeoJSON file of ``[lon, lat]`` pairs, the shipped Brussels network) has tracks at
``h = 0``, a placeholder, so a run of recorded files on it (`run_files_network`) uses no
height: the fixes' heights are not used (no ``fix_up`` rows, no start-height check:
``FixModelConfig(use_height=False)``), the estimates' `HEIGHT_COLUMNS` are empty
(`railnav.navigation.result.without_heights`) and ``summary.json`` says ``"heights":
false``. Pseudoranges are refused (their geometry needs the antenna's height: ~100 m off
at Brussels); an IMU is navigated on the level tracks with the grade unknown
(``NavigatorConfig.track_grade_sigma_rad`` = `UNKNOWN_GRADE_SIGMA_RAD`, 20 ‰: the start's
pitch σ and the pseudo-observation's normal row carry it, `railnav.filters.grade_noise`;
without it a body pitched 1 % leaks 0.1 m/s² of gravity into the speed). A simulated
trip on such a network (`run_simulated_network`) runs in a world at ``h = 0``: its truth
and estimates keep their heights.
"""
from __future__ import annotations

import json
import logging
import os
from dataclasses import dataclass, replace
from pathlib import Path

import numpy as np

from railnav.defaults import DEFAULT_HORIZON_M, DEFAULT_SEED
from railnav.errors import ConfigError, RailnavError
from railnav.filters.grade_noise import UNKNOWN_GRADE_SIGMA_RAD
from railnav.jobs.network_scoring import (
    netelement_truth_of,
    scored_summary,
    true_netelements,
)
from railnav.jobs.run import RunOutcome, read_sensor_files, run_summary, truth_start
from railnav.navigation.network_config import NetworkNavConfig
from railnav.navigation.network_navigator import navigate_network
from railnav.navigation.state_conversion import converted
from railnav.navigation.result import CSV_DECIMALS, CSV_FLOAT_FORMAT, without_heights
from trackmodel.errors import TrackError
from trackmodel.files import atomic_write_csv, atomic_write_text
from trackmodel.network import NetPosition, Network, Route

__all__ = ["route_candidates", "route_name", "run_files_network", "run_simulated_network",
           "write_network_run", "NetworkRunOutcome", "load_network", "candidate_starts",
           "DEFAULT_HORIZON_M", "DEFAULT_MAX_ROUTES"]

log = logging.getLogger(__name__)

#: The most routes `route_candidates` lists.
DEFAULT_MAX_ROUTES = 16


@dataclass(frozen=True, eq=False)
class NetworkRunOutcome:
    """A finished network run.

    Attributes
    ----------
    outcome : RunOutcome
        The most probable hypothesis's estimates (`NetworkResult.combined`), the summary
        (with ``route``), errors against a simulated truth.
    network_result : railnav.navigation.network_result.NetworkResult
    network : trackmodel.network.Network
    true_legs : tuple of (str, int) or None
        The simulated route.
    """

    outcome: RunOutcome
    network_result: object
    network: Network
    true_legs: tuple | None = None


def load_network(path) -> Network:
    """A network folder, a GeoJSON or OpenStreetMap file or a track file
    (`trackmodel.network_routes.load_network`); a folder through the on-disk cache of
    loaded networks (`railnav.jobs.network_cache`)."""
    from trackmodel.network_routes import load_network as load
    path = Path(path)
    if not path.exists():
        raise ConfigError(f"{path}: no such network folder or file")
    if path.is_dir():
        from railnav.jobs.network_cache import cached_network_folder
        return cached_network_folder(path, load)
    return load(path)


def route_name(route: Route) -> str:
    """``E1>E2>-E3``: the netelements of a route in order (``-``: travelled backwards)."""
    return ">".join(e if d == 1 else f"-{e}" for e, d in route.legs)


def route_candidates(network: Network, start: NetPosition, *,
                     horizon_m: float = DEFAULT_HORIZON_M,
                     max_routes: int = DEFAULT_MAX_ROUTES):
    """The routes a train at `start` may take within `horizon_m`: their names
    (`route_name`), the `Route` objects, and `start`'s distance along each route's first
    leg (m).

    Raises
    ------
    ConfigError
        No route ahead, or too many (`max_routes`).
    """
    try:
        routes = network.routes_ahead(start, horizon_m=horizon_m, max_routes=max_routes)
    except TrackError as exc:
        raise ConfigError(str(exc)) from None
    length = network.length_m(start.element)
    start_s = start.s_m if start.direction == 1 else length - start.s_m
    return tuple(route_name(r) for r in routes), routes, float(start_s)


def run_files_network(network: Network, *, fixes_path=None, imu_path=None, obs_path=None,
                      nav_path=None, start=None, nav: NetworkNavConfig = NetworkNavConfig(),
                      truth_path=None, truth_quality: str | None = None,
                      start_gps_time_s: float | None = None, config=None,
                      filter: str | None = None, systems: str | None = None,
                      imu_grade: str | None = None, fix_sigmas=None, fix_model=None,
                      outages=None, window: tuple[float, float] | None = None,
                      progress=None) -> NetworkRunOutcome:
    """Navigate sensor files on `network` (module docstring).

    Parameters are those of `railnav.jobs.run.run_files` (the sensor files, the filter
    and fix model), plus `start` (`railnav.navigation.network_start.NetworkStart`, default
    unknown) and `nav` (`NetworkNavConfig`); `truth_path` gives the netelement truth:
    ``railnav simulate``'s ``truth.csv`` (default: the one beside the inputs'
    ``scenario.json``), a reference trajectory, or a fix file's rows of class
    `truth_quality` (default ``rtk_fixed``); `window`, an extra
    summary window ``(start_s, end_s)``. On a network without heights, no height is used or
    written (module docstring).

    Raises
    ------
    ConfigError
        Pseudoranges (`obs_path`) on a network without heights.
    """
    from railnav.jobs.scoring import file_outages, find_truth, with_timestamps
    outages = file_outages(outages, imu_path, obs_path, fixes_path)
    _check_heights(network, obs_path=obs_path, imu_path=imu_path)
    data, config = read_sensor_files(imu_path=imu_path, obs_path=obs_path, nav_path=nav_path,
                                     fixes_path=fixes_path, start_gps_time_s=start_gps_time_s,
                                     config=config, filter=filter, systems=systems,
                                     imu_grade=imu_grade, fix_sigmas=fix_sigmas,
                                     fix_model=fix_model)
    if not network.heights:
        config = replace(config, fix_model=replace(config.fix_model, use_height=False))
        if imu_path is not None and config.track_grade_sigma_rad is None:
            # the grade is unknown: the start's pitch and the normal row say so
            config = replace(config, track_grade_sigma_rad=UNKNOWN_GRADE_SIGMA_RAD)
    result = navigate_network(network, data, config, nav=nav, start=start,
                              outages=outages, progress=progress)
    combined = with_timestamps(result.combined(), data.fixes)
    if not network.heights:
        combined = without_heights(combined)
    track = result.tracks.placed(result.keys[-1])
    extra = {}
    if data.fixes is not None:
        extra["fixes"] = {"path": data.fixes.path, "format": data.fixes.format,
                          "read": len(data.fixes), "skipped": dict(data.fixes.skipped)}
    summary = run_summary(combined, track, None, window, outages,
                          {**extra, "heights": network.heights})
    truth_path = truth_path or find_truth(imu_path, obs_path, fixes_path)
    truth_t, truth = (None, None) if truth_path is None else netelement_truth_of(
        network, truth_path, truth_quality, data.start_gps_time_s)
    summary = scored_summary(summary, result, network, truth_t, truth, {})
    return NetworkRunOutcome(RunOutcome(combined, track, summary, data=data), result, network)


def _check_heights(network: Network, *, obs_path, imu_path) -> None:
    """A run of recorded files on a network without heights (module docstring): no
    pseudoranges; an IMU with the grade unknown (`railnav.filters.grade_noise`).

    Raises
    ------
    ConfigError
        `obs_path` given on a network without heights.
    """
    if network.heights:
        return
    if obs_path is not None:
        raise ConfigError("this network has no heights: pseudorange runs need a track with "
                          "heights (a network folder or GeoJSON file with them, or a track "
                          "file)")
    if imu_path is not None:
        log.info("this network has no heights: the IMU is navigated on level tracks with "
                 "an unknown grade of sigma %.0f per mille (railnav.filters.grade_noise)",
                 1e3 * UNKNOWN_GRADE_SIGMA_RAD)


def simulation_line(network: Network, legs):
    """The line a simulated trip along `legs` runs on: `Network.route_track`, the
    netelements with a tangent-continuous transition into each leg at its joint
    (`trackmodel.network_lines`: within the fit tolerance of the legs, a real turnout's
    curve where the map has a corner); for tangent-continuous joints the netelements as
    they are."""
    return network.route_track(legs)


def candidate_starts(trip, config, route_filter):
    """`navigate_network`'s ``initial`` for a simulated `trip` on `route_filter`'s track:
    each start candidate's initial state: the truth on the route line brought onto the
    candidate's track (`railnav.navigation.state_conversion.converted`) plus one common
    error draw (`truth_start`); none for a candidate an inertial filter would face the
    wrong way on."""
    x_route = route_filter.truth_states(trip.truth, *trip.clock_truth(trip.truth.time_s))[0][0]
    P0 = truth_start(route_filter, trip, config).P0

    def initial(filt, element, orientation):
        try:
            x = converted(route_filter, filt, x_route, P0)[0]
        except RailnavError:                # facing the other way on it
            return None
        return truth_start(filt, trip, config, x_true=x)
    return initial


def run_simulated_network(network: Network, legs, scenario, *, line=None, config=None,
                          seed: int = DEFAULT_SEED, systems: str | None = None,
                          nav: NetworkNavConfig = NetworkNavConfig(), known_start: bool = False,
                          start_direction: int | None = None, faults: tuple = (),
                          window: tuple[float, float] | None = None,
                          progress=None) -> NetworkRunOutcome:
    """Simulate `scenario` along the route `legs` and navigate it on `network` (module
    docstring).

    Parameters
    ----------
    network : Network
    legs : sequence of (str, int)
        The true route (the navigator is not told).
    scenario : railnav.simulation.scenarios.Scenario
        Its ``start_s`` is along the route's line.
    line : trackmodel.Track, optional
        The route's line (default `simulation_line`).
    config : NavigatorConfig, optional
        Default `railnav.simulation.trip.navigator_config_for(scenario)`.
    seed : int
    systems : str, optional
    nav : NetworkNavConfig
    known_start : bool
        Start on the first leg's netelement only (else every netelement near the start).
    start_direction : {1, -1}, optional
        Start hypotheses in this orientation of each netelement only (+1 along it; default
        both for an inertial filter: the truth brought onto each decides).
    faults : tuple of gnss_obs.SatelliteFault
    window : (start_s, end_s), optional
        Extra error-summary window.
    progress : callable(done, total), optional
    """
    from railnav.defaults import DEFAULT_SYSTEMS
    from railnav.evaluation.metrics import error_series
    from railnav.filters.protocol import make_filter
    from railnav.navigation.network_start import NetworkStart
    from railnav.simulation.trip import navigator_config_for, simulate_trip
    legs = tuple((e, int(o)) for e, o in legs)
    systems = systems or DEFAULT_SYSTEMS
    line = line if line is not None else simulation_line(network, legs)
    config = config or navigator_config_for(scenario, systems=systems)
    trip = simulate_trip(scenario, track=line, seed=seed, systems=systems, faults=faults)
    route_filter = make_filter(line, config, None)
    result = navigate_network(network, trip.sensor_data(), config, nav=nav,
                              start=NetworkStart(legs[0][0] if known_start else None,
                                                 direction=start_direction)
                              if known_start or start_direction is not None else None,
                              outages=scenario.outages,
                              initial=candidate_starts(trip, config, route_filter),
                              near=(float(trip.truth.lat[0]), float(trip.truth.lon[0])),
                              progress=progress)
    combined = result.combined()
    errors = error_series(combined, trip.truth, trip.track, clock_truth=trip.clock_truth)
    summary = run_summary(combined, trip.track, errors, window, scenario.outages,
                          {"scenario": scenario.name, "seed": int(seed), "systems": systems,
                           "heights": True})
    truth_s = np.interp(result.time_s, trip.truth.time_s, trip.truth.s)
    summary = scored_summary(summary, result, network, result.time_s,
                              true_netelements(network, legs, truth_s),
                              {"true_route": [e for e, _ in legs]})
    return NetworkRunOutcome(RunOutcome(combined, trip.track, summary, errors, trip,
                                        trip.truth), result, network, legs)


def write_network_run(run: NetworkRunOutcome, out_dir: str | os.PathLike, *,
                      plots: bool = True) -> list[Path]:
    """Write a network run into `out_dir` (module docstring); the paths written. `plots`:
    also draw the PNG figures (``--no-plots``: False)."""
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    res, outcome = run.network_result, run.outcome
    tables = {"estimates.csv": outcome.result.estimates,
              "innovations.csv": outcome.result.innovations,
              "hypotheses.csv": res.hypotheses, "route.csv": res.route_frame()}
    if outcome.errors is not None and outcome.errors.compared:
        tables["errors.csv"] = outcome.errors.to_frame()
    written = []
    for name, frame in tables.items():
        atomic_write_csv(out / name, frame, float_format=CSV_FLOAT_FORMAT,
                         decimals=CSV_DECIMALS)
        written.append(out / name)
    atomic_write_text(out / "summary.json", json.dumps(outcome.summary, indent=2) + "\n")
    written.append(out / "summary.json")
    if plots:
        written += _plots(run, out)
    return written


def _plots(run: NetworkRunOutcome, out: Path) -> list[Path]:
    from railnav.evaluation.network_plots import plot_network_run
    from railnav.evaluation.plots import plot_errors, plot_estimates
    outcome = run.outcome
    fixes = None if outcome.data is None else outcome.data.fixes
    plot_network_run(run.network, run.network_result, out / "network.png", fixes=fixes,
                     truth=outcome.truth)
    if outcome.errors is not None and outcome.errors.compared:
        plot_errors(outcome.errors, outcome.result, out / "errors.png")
        return [out / "network.png", out / "errors.png"]
    plot_estimates(outcome.result, out / "estimates.png")
    return [out / "network.png", out / "estimates.png"]


def with_nav(nav: NetworkNavConfig, **changes) -> NetworkNavConfig:
    """`nav` with the given fields changed (None values left as they are)."""
    return replace(nav, **{k: v for k, v in changes.items() if v is not None})
