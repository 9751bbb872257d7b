"""``railnav simulate TRACK --scenario NAME ...``: truth.csv, imu.csv and scenario.json.

Thin layer (STYLE.md §2.11) over `railnav.simulation.trip.simulate_trip` on a track file
(the scenario: `railnav.simulation.scenarios.scenario_for_track`) or, with ``--network N
--route E1,E2``, on the route's line (`trackmodel.route_track`), and
`railnav.jobs.simulated_files.write_simulated_trip`, which writes the files (with
``--fixes-format`` the fixes of `railnav.simulation.fixes.trip_fixes`; with ``--odometer``,
``--balises``, ``--baro`` and ``--imu-jitter-s`` the sensors whose configurations
`railnav.commands.simulate_sensors` reads from the flags).
"""
from __future__ import annotations

import argparse
import logging
from dataclasses import replace
from pathlib import Path

from railnav.commands.run_flags import SCENARIO_HELP
from railnav.commands.simulate_sensors import add_sensor_arguments, sensor_configs
from railnav.commands.support import (
    add_output_arguments,
    outage_window,
    output_dir,
    positive_float,
    progress_bar,
    written_line,
)
from railnav.defaults import DEFAULT_SEED, DEFAULT_SYSTEMS
from railnav.errors import ConfigError
from railnav.simulation.fixes import (
    DEFAULT_QUALITY_MIX,
    FIX_FORMATS_WRITTEN,
    FixSimConfig,
    parse_quality_mix,
)
from railnav.simulation.scenarios import SCENARIOS, scenario_for_track
from strapdown.imu_errors import IMU_GRADES

__all__ = ["register", "handler"]

log = logging.getLogger(__name__)

#: Output directory when --out is not given.
DEFAULT_OUT = "railnav-simulate"


def register(subparsers) -> None:
    """Add the ``simulate`` subcommand."""
    p = subparsers.add_parser(
        "simulate", help="simulate a trip: truth, IMU (and GNSS) files",
        description="Simulate a scenario (speed profile + sensors) on a track and write "
                    "truth.csv, imu.csv and scenario.json to DIR (+ GNSS observations, "
                    "and fixes with --fixes-format).")
    p.add_argument("track", metavar="TRACK", nargs="?", default=None,
                   help="track file (.csv); or --network with --route")
    add_network_route_arguments(p)
    p.add_argument("--scenario", default=None, choices=sorted(SCENARIOS), help=SCENARIO_HELP)
    p.add_argument("--imu-grade", choices=sorted(IMU_GRADES), default=None,
                   help="IMU error preset (default: the scenario's; 'perfect' = ideal IMU)")
    p.add_argument("--speed-mps", type=positive_float, default=None,
                   help="top speed in m/s (scales the scenario's speed profile)")
    p.add_argument("--duration-s", type=positive_float, default=None,
                   help="trip duration in s (the trip ends at the track end at the latest)")
    p.add_argument("--outage", type=outage_window, action="append", default=None,
                   metavar="START:DURATION",
                   help="GNSS outage in seconds from the start (repeatable; replaces the "
                        "scenario's outages)")
    p.add_argument("--gnss", action=argparse.BooleanOptionalAction, default=True,
                   help="also simulate GNSS observations: gnss_obs.rnx and the navigation "
                        "file used, gnss_nav.rnx (default: yes)")
    p.add_argument("--systems", default=DEFAULT_SYSTEMS,
                   help=f"GNSS systems to simulate, e.g. G or GE (default {DEFAULT_SYSTEMS})")
    p.add_argument("--fixes-format", choices=FIX_FORMATS_WRITTEN, default=None,
                   help="also write GNSS position fixes of the truth: fixes.csv or "
                        "fixes.nmea (GGA, RMC, VTG, GST)")
    p.add_argument("--fixes-rate-hz", type=positive_float, default=None,
                   help="fix rate, Hz (default 1; must divide the IMU rate)")
    p.add_argument("--fixes-quality", default=None, metavar="CLASS=W,...",
                   help="mix of fix classes by share of 30-s segments, e.g. "
                        "rtk_fixed=0.5,single=0.5 (default "
                        + ",".join(f"{q}={w:g}" for q, w in DEFAULT_QUALITY_MIX) + ")")
    add_sensor_arguments(p)
    p.add_argument("--seed", type=int, default=DEFAULT_SEED,
                   help=f"random seed (default {DEFAULT_SEED})")
    add_output_arguments(p, DEFAULT_OUT)
    p.set_defaults(func=handler)


def add_network_route_arguments(p) -> None:
    """``--network NETWORK --route E1,E2,...``: simulate on a route through a network."""
    p.add_argument("--network", metavar="NETWORK", default=None,
                   help="a network (folder, GeoJSON, OpenStreetMap) to simulate on, along "
                        "--route, instead of TRACK")
    p.add_argument("--route", metavar="E1,E2,...", default=None,
                   help="with --network: the netelements in order (',' or '>'; '-E' "
                        "backwards); the route's line is written as route_track.csv")


def _check_network_flags(args: argparse.Namespace) -> None:
    if (args.network is None) != (args.route is None):
        raise ConfigError("--network and --route go together")
    if (args.track is None) == (args.network is None):
        raise ConfigError("give a TRACK file, or --network with --route (not both)")


def _track_of(args: argparse.Namespace):
    """The track simulated on, and its name in scenario.json and the report."""
    if args.network is None:
        from trackmodel.io import read_track
        return read_track(args.track), str(Path(args.track))
    from railnav.commands.network_data import check_netelements
    from trackmodel.network_routes import load_network, parse_route, route_legs, route_text
    network = load_network(args.network)
    check_netelements(network, args.network, "--route", [n for n, _ in parse_route(args.route)])
    legs = route_legs(network, args.route)
    return network.route_track(legs), f"{args.network}:{route_text(legs)}"


def _fix_config(args: argparse.Namespace) -> FixSimConfig | None:
    """The fix simulation of the flags (None without --fixes-format)."""
    given = [f for f, v in (("--fixes-rate-hz", args.fixes_rate_hz),
                            ("--fixes-quality", args.fixes_quality)) if v is not None]
    if args.fixes_format is None:
        if given:
            raise ConfigError(f"{', '.join(given)}: only with --fixes-format")
        return None
    extra = {} if args.fixes_rate_hz is None else {"rate_hz": args.fixes_rate_hz}
    if args.fixes_quality is not None:
        extra["quality_mix"] = parse_quality_mix(args.fixes_quality)
    return FixSimConfig(**extra)


def handler(args: argparse.Namespace) -> int:
    """Run ``railnav simulate``; returns the exit status."""
    from railnav.jobs.simulated_files import write_simulated_trip
    from railnav.simulation.trip import simulate_trip
    _check_network_flags(args)
    fix_config = _fix_config(args)
    sensors = sensor_configs(args)
    scenario = scenario_for_track(args.track or "", args.scenario).with_overrides(
        speed_mps=args.speed_mps, duration_s=args.duration_s, imu_errors=args.imu_grade,
        outages=args.outage)
    if args.lever_arm is not None:
        scenario = replace(scenario, antenna_m=args.lever_arm)
    track, track_name = _track_of(args)
    with output_dir(args, [args.track, args.network]) as tmp:
        with progress_bar("simulate", enabled=not args.quiet) as progress:
            trip = simulate_trip(scenario, track=track, seed=args.seed, gnss=args.gnss,
                                 systems=args.systems, progress=progress)
        written, meta = write_simulated_trip(
            trip, tmp, track_name=track_name, fixes=fix_config,
            fixes_format=args.fixes_format or "csv", route_track=args.network is not None,
            **sensors)
    print(f"{written_line(args.out, written, tmp)} ({meta['n_samples']} IMU samples, "
          f"{meta['end_time_s']:.1f} s of the {scenario.name} scenario on {track_name})")
    return 0
