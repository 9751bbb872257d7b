"""``railnav simulate TRACK --scenario NAME ...``: truth.csv, imu.csv and scenario.json.

Thin layer over `railnav.simulation.trip.simulate_trip` (STYLE.md §2.11), and with
``--fixes-format`` over `railnav.simulation.fixes.simulate_fixes` and the fix writers of
`gnss_obs.fixes.writers`.
"""
from __future__ import annotations

import argparse
import json
import logging
from pathlib import Path

from railnav.commands.run_flags import SCENARIO_HELP, scenario_for
from railnav.commands.support import (
    add_output_arguments,
    outage_window,
    output_dir,
    positive_float,
    progress_bar,
    written_line,
)
from railnav.defaults import DEFAULT_SYSTEMS
from railnav.errors import ConfigError
from railnav.simulation.fixes import (
    DEFAULT_QUALITY_MIX,
    FIX_FORMATS_WRITTEN,
    FixSimConfig,
    parse_quality_mix,
)
from railnav.simulation.scenarios import SCENARIOS, get_scenario, scenario_to_dict
from strapdown.imu_errors import IMU_GRADES
from trackmodel.files import atomic_write_csv, atomic_write_text

__all__ = ["register", "handler", "FLOAT_FORMAT", "DEFAULT_OUT"]

log = logging.getLogger(__name__)

#: CSV float format: 17 significant digits round-trip every float64 exactly.
FLOAT_FORMAT = "%.17g"
#: Output directory when --out is not given.
DEFAULT_OUT = "railnav-simulate"


def register(subparsers) -> None:
    """Add the ``simulate`` subcommand."""
    p = subparsers.add_parser(
        "simulate", help="simulate a trip: truth, IMU (and GNSS) files",
        description="Simulate a scenario (speed profile + sensors) on a track and write "
                    "truth.csv, imu.csv and scenario.json to DIR (+ GNSS observations, "
                    "and fixes with --fixes-format).")
    p.add_argument("track", metavar="TRACK", help="track file (.csv)")
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
    p.add_argument("--seed", type=int, default=0, help="random seed (default 0)")
    add_output_arguments(p, DEFAULT_OUT)
    p.set_defaults(func=handler)


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


def _write_fixes(out: Path, fixes, config: FixSimConfig, fmt: str) -> dict:
    """Write the simulated fixes; their ``scenario.json`` entry."""
    from gnss_obs.fixes.writers import write_fixes_csv, write_fixes_nmea
    name = f"fixes.{fmt}"
    (write_fixes_csv if fmt == "csv" else write_fixes_nmea)(out / name, fixes.table)
    return {"file": name, "format": fmt, "count": len(fixes), **config.to_dict()}


def handler(args: argparse.Namespace) -> int:
    """Run ``railnav simulate``; returns the exit status."""
    from railnav.simulation.fixes import trip_fixes
    from railnav.simulation.trip import simulate_trip
    from trackmodel.io import read_track
    fix_config = _fix_config(args)
    scenario = get_scenario(scenario_for(args.track, args.scenario)).with_overrides(
        speed_mps=args.speed_mps, duration_s=args.duration_s, imu_errors=args.imu_grade,
        outages=args.outage)
    track = read_track(args.track)
    with output_dir(args, [args.track]) as tmp:
        with progress_bar("simulate", enabled=not args.quiet) as progress:
            trip = simulate_trip(scenario, track=track, seed=args.seed, gnss=args.gnss,
                                 systems=args.systems, progress=progress)
        fixes = None if fix_config is None else trip_fixes(trip, fix_config)
        written, meta = _write(tmp, trip, scenario, args, fixes, fix_config)
    print(f"{written_line(args.out, written, tmp)} ({meta['n_samples']} IMU samples, "
          f"{meta['end_time_s']:.1f} s of the {scenario.name} scenario on {args.track})")
    return 0


def _write(out: Path, trip, scenario, args, fixes, fix_config) -> tuple[list[Path], dict]:
    """Write a simulated trip's files into `out`: (paths written, scenario.json content)."""
    from gnss_obs.sim_files import write_simulation
    result = trip.simulation
    written = list(write_simulation(out, trip.gnss, trip.nav)) if trip.gnss is not None else []
    atomic_write_csv(out / "truth.csv", result.truth.to_frame(), float_format=FLOAT_FORMAT)
    atomic_write_csv(out / "imu.csv", result.imu_measured.to_frame(), float_format=FLOAT_FORMAT)
    meta = {"scenario": scenario_to_dict(scenario), "track": str(Path(args.track)),
            "seed": args.seed, "gnss_written": trip.gnss is not None,
            "gnss_systems": args.systems if trip.gnss is not None else None,
            "n_samples": int(len(result.truth.time_s)),
            "end_time_s": float(result.truth.time_s[-1])}
    if fix_config is not None:
        meta["fixes"] = _write_fixes(out, fixes, fix_config, args.fixes_format)
        written.append(out / meta["fixes"]["file"])
    atomic_write_text(out / "scenario.json", json.dumps(meta, indent=2) + "\n")
    return [out / "truth.csv", out / "imu.csv", *written, out / "scenario.json"], meta
