"""``railnav run TRACK [...]``: filter a trip on a track (simulated, or from sensor files).

Thin layer over `railnav.runs.run_simulated` / `railnav.runs.run_files` and
`railnav.runs.write_run` (STYLE.md §2.11).
"""
from __future__ import annotations

import argparse
import logging
from dataclasses import replace
from pathlib import Path

from railnav.commands.support import outage_window, positive_float, progress_bar
from railnav.errors import ConfigError
from railnav.nav_config import FILTER_KINDS
from railnav.scenarios import SCENARIOS, get_scenario
from strapdown.imu_errors import IMU_GRADES
from trackmodel.io import read_track

__all__ = ["register", "handler", "DEFAULT_OUT", "DEFAULT_SCENARIO", "time_window"]

log = logging.getLogger(__name__)

#: Output directory when --out is not given.
DEFAULT_OUT = "railnav-run"
#: Scenario simulated on a track whose file name is not a scenario's name.
DEFAULT_SCENARIO = "curvy"


def time_window(text: str) -> tuple[float, float]:
    """argparse type for ``START:END`` (seconds from the trip start)."""
    try:
        start, end = (float(x) for x in text.split(":"))
    except ValueError:
        raise argparse.ArgumentTypeError(f"{text!r} is not START:END in seconds") from None
    if not (0 <= start < end < float("inf")):
        raise argparse.ArgumentTypeError(f"{text!r}: need 0 <= START < END")
    return start, end


def register(subparsers) -> None:
    """Add the ``run`` subcommand."""
    p = subparsers.add_parser(
        "run", help="filter a trip on a track (simulated, or from IMU/RINEX files)",
        description="With only a track, simulate a scenario on it (truth, IMU, GNSS) and "
                    "filter it; with --imu and/or --obs/--nav, filter those files. Writes "
                    "estimates.csv, innovations.csv, summary.json (+ errors.csv with a truth) "
                    "and plots to DIR.")
    p.add_argument("tracks", metavar="TRACK", nargs="+", help="track file(s) (.csv)")
    p.add_argument("--imu", metavar="IMU.csv", help="IMU samples (railnav simulate's imu.csv)")
    p.add_argument("--obs", metavar="RINEX_OBS", help="RINEX observation file")
    p.add_argument("--nav", metavar="RINEX_NAV", help="RINEX navigation file")
    p.add_argument("--start-gps-time-s", type=float, default=None,
                   help="GPS time (s since 1980-01-06) of the IMU's time_s = 0 (default: from "
                        "scenario.json beside the IMU file, else the first GNSS epoch)")
    p.add_argument("--scenario", choices=sorted(SCENARIOS), default=None,
                   help="scenario to simulate (default: the track's name if it is a "
                        f"scenario, else {DEFAULT_SCENARIO})")
    p.add_argument("--imu-grade", choices=sorted(IMU_GRADES), default=None,
                   help="IMU grade simulated and assumed (default: the scenario's)")
    p.add_argument("--speed-mps", type=positive_float, default=None,
                   help="top speed of the simulated trip, m/s")
    p.add_argument("--duration-s", type=positive_float, default=None,
                   help="duration of the simulated trip, s")
    p.add_argument("--outage", type=outage_window, action="append", default=None,
                   metavar="START:DURATION",
                   help="GNSS outage, s from the start (repeatable; replaces the scenario's)")
    p.add_argument("--filter", choices=FILTER_KINDS, default="constrained",
                   help="which filter (default: constrained)")
    p.add_argument("--systems", default=None,
                   help="GNSS systems to use, e.g. G or GE (default: the simulated ones for "
                        "railnav simulate's files, else G)")
    p.add_argument("--window", type=time_window, default=None, metavar="START:END",
                   help="also summarize the errors over this window, s")
    p.add_argument("--seed", type=int, default=0, help="random seed of the simulation")
    p.add_argument("--no-plots", action="store_true", help="do not draw the PNG plots")
    p.add_argument("--out", default=DEFAULT_OUT, metavar="DIR",
                   help=f"output directory (default: {DEFAULT_OUT})")
    p.set_defaults(func=handler)


def handler(args: argparse.Namespace) -> int:
    """Run ``railnav run``; returns the exit status."""
    from railnav.runs import run_files, run_simulated, write_run
    if len(args.tracks) > 1:
        raise ConfigError("several candidate tracks need the multiple-model bank, which is "
                          "not available in this version; give one track")
    if (args.obs is None) != (args.nav is None):
        raise ConfigError("--obs and --nav go together")
    if args.seed < 0:
        raise ConfigError(f"--seed must be >= 0, got {args.seed}")
    _measurement(args.systems)   # validates --systems before any work
    out = Path(args.out)
    if out.exists() and not out.is_dir():
        raise ConfigError(f"{out}: exists and is not a directory")
    track = read_track(args.tracks[0])
    files = args.imu is not None or args.obs is not None
    with progress_bar("filter", enabled=not args.quiet) as progress:
        if files:
            outcome = run_files(track, imu_path=args.imu, obs_path=args.obs,
                                nav_path=args.nav, start_gps_time_s=args.start_gps_time_s,
                                filter=args.filter, systems=args.systems,
                                outages=tuple(args.outage or ()), window=args.window,
                                progress=progress)
        else:
            scenario = _scenario(args)
            from railnav.trip import navigator_config_for
            systems = args.systems or "G"
            config = navigator_config_for(scenario, filter=args.filter, systems=systems)
            outcome = run_simulated(track, scenario, config=config, seed=args.seed,
                                    systems=systems, window=args.window, progress=progress)
    write_run(outcome, out, plots=not args.no_plots)
    print(_report(outcome, out))
    return 0


def _measurement(systems: str | None):
    from gnss_obs.errors import GnssError
    from gnss_obs.measurements import MeasurementConfig
    try:
        return MeasurementConfig(systems=systems or "G")
    except GnssError as exc:
        raise ConfigError(f"--systems: {exc}") from None


def _scenario(args):
    name = args.scenario
    if name is None:
        stem = Path(args.tracks[0]).stem
        name = stem if stem in SCENARIOS else DEFAULT_SCENARIO
    scenario = get_scenario(name).with_overrides(speed_mps=args.speed_mps,
                                                 duration_s=args.duration_s)
    if args.imu_grade is not None:
        scenario = replace(scenario, imu_errors=args.imu_grade)
    if args.outage is not None:
        scenario = replace(scenario, outages=tuple(args.outage))
    return scenario


def _report(outcome, out: Path) -> str:
    """A few lines for the terminal: what ran and the headline errors."""
    s = outcome.summary
    lines = [f"{s['filter']} filter: {s['steps']} steps, {s['statistics']['gnss_epochs']} GNSS "
             f"epochs in {s['runtime_s']:.2f} s -> {out}/"]
    left = s.get("left_track")
    if left:
        lines.append(f"  stopped at t={left['time_s']:.1f} s: s = {left['s_m']:.1f} m is beyond "
                     f"the track's {left['end']} ({left['track_length_m']:.1f} m); later data "
                     "not used")
    errors = s.get("errors")
    if errors:
        a = errors["all"]
        lines.append(f"  along-track RMS {a['along_track_m']['rms']:.3f} m, max "
                     f"{a['along_track_m']['max']:.3f} m; speed RMS "
                     f"{a['speed_mps']['rms']:.4f} m/s; NEES mean {errors['nees']['mean']:.2f} "
                     f"(dof {errors['nees']['dof']})")
        for o in errors["outages"]:
            lines.append(f"  outage {o['start_s']:g}+{o['duration_s']:g} s: along-track error "
                         f"at its end {o['at_end']['along_track_m']:+.3f} m")
    return "\n".join(lines)
