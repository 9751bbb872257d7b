"""``railnav run TRACK [...]``: filter a trip on a track (simulated, or from sensor files).

Thin layer over `railnav.jobs.run.run_simulated` / `railnav.jobs.run.run_files` and
`railnav.jobs.run.write_run` (STYLE.md §2.11). With several tracks (candidates: the tracks of
a double line, the routes after a switch) over `railnav.jobs.tracks.run_simulated_tracks` /
`run_files_tracks` and `write_track_run`: the network navigator on the tracks as
netelements without connections, and their probabilities. The flags and their checks are
`railnav.commands.run_flags`; the terminal report is `railnav.commands.run_report`.
"""
from __future__ import annotations

import argparse
import logging
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path

from railnav.commands.attitude_flags import attitude_config, car_body_scenario
from railnav.commands.receiver_flags import receiver_config, receiver_inputs
from railnav.commands.run_flags import (
    DEFAULT_OUT,
    DEFAULT_SCENARIO,
    add_run_arguments,
    augmentation,
    check_flags,
    files_given,
    fix_model,
    fix_sigmas,
    real_inputs,
    scenario_of,
    seed,
    time_window,
)
from railnav.commands.run_report import fix_hint_lines, receiver_hint_lines, report
from railnav.commands.support import (
    imports_without_gc,
    output_dir,
    progress_bar,
    written_line,
)
from railnav.defaults import DEFAULT_SYSTEMS, default_filter

__all__ = ["register", "handler", "DEFAULT_OUT", "DEFAULT_SCENARIO", "time_window"]

log = logging.getLogger(__name__)


def register(subparsers) -> None:
    """Add the ``run`` subcommand."""
    p = subparsers.add_parser(
        "run", help="filter a trip on a track (simulated, or from IMU/RINEX/fix files)",
        description="With only a track, simulate a scenario on it (truth, IMU, GNSS) and "
                    "filter it; with --imu, --obs/--nav and/or --fixes, filter those files. "
                    "Writes estimates.csv, innovations.csv, summary.json (+ errors.csv "
                    "with a truth) "
                    "and plots to DIR. With several tracks, run one constrained filter per "
                    "candidate track and identify the track the train is on: summary.json "
                    "gets track_probabilities, estimates.csv the columns track and "
                    "track_probability, and track_probabilities.csv/.png are written.")
    add_run_arguments(p)
    p.set_defaults(func=handler)


def handler(args: argparse.Namespace) -> int:
    """Run ``railnav run``; returns the exit status."""
    args.filter = default_filter(args.filter, imu=args.imu is not None or not files_given(args))
    with imports_without_gc():   # and frozen: the engine's objects too (~0.02 s CPU of GC)
        check_flags(args)              # before the engine is imported: errors stay fast
        import railnav.jobs.run  # noqa: F401  (every run's engine; the plot helper forks with it)
    inputs = [*args.tracks, args.imu, args.obs, args.nav, args.fixes, args.truth, args.baro,
              args.base, *args.sp3, args.network]
    with output_dir(args, inputs) as tmp:     # --out checked before any work
        text, written = (_network(args, tmp) if args.network is not None else
                         _several_tracks(args, tmp) if len(args.tracks) > 1
                         else _one_track(args, tmp))
    print(text)
    print(written_line(args.out, written, tmp))
    return 0


def _one_track(args: argparse.Namespace, tmp: Path) -> tuple[str, list[Path]]:
    """Run one filter on one track and write it into `tmp`: (report, files written). The
    figures are drawn by a helper process started now, which imports matplotlib and lays
    out the figures it expects while the run simulates and filters
    (`railnav.jobs.plot_worker`)."""
    from railnav.jobs.run_figures import run_plot_helper
    if args.no_plots:
        return _one_track_run(args, tmp, None)
    truth = not files_given(args) or args.truth is not None     # errors.png, likely
    with run_plot_helper(args.filter, truth) as plotter:
        return _one_track_run(args, tmp, plotter)


def _one_track_run(args: argparse.Namespace, tmp: Path, plotter) -> tuple[str, list[Path]]:
    from railnav.jobs.run import run_files, run_simulated, write_run
    from trackmodel.io import read_track
    baro = None
    if args.baro is not None:
        from railnav.jobs.baro import add_run_baro, read_baro_csv, write_run_baro
        baro = read_baro_csv(args.baro)
    track = read_track(args.tracks[0])
    with progress_bar("filter", enabled=not args.quiet) as progress, _fixes_named(args):
        if files_given(args):
            outcome = run_files(track, imu_path=args.imu, obs_path=args.obs,
                                nav_path=args.nav, fixes_path=args.fixes,
                                truth_path=args.truth, truth_quality=args.truth_quality,
                                start_gps_time_s=args.start_gps_time_s,
                                filter=args.filter, systems=args.systems,
                                imu_grade=args.imu_grade, fix_sigmas=fix_sigmas(args),
                                fix_model=fix_model(args),
                                outages=None if args.outage is None else tuple(args.outage),
                                window=args.window, smooth=args.smooth, progress=progress,
                                **augmentation(args), **real_inputs(args),
                                **receiver_inputs(args), **attitude_config(args))
        else:
            scenario = car_body_scenario(args, scenario_of(args).with_overrides(
                speed_mps=args.speed_mps, duration_s=args.duration_s,
                imu_errors=args.imu_grade, outages=args.outage))
            from railnav.simulation.trip import navigator_config_for
            systems = args.systems or DEFAULT_SYSTEMS
            config = navigator_config_for(scenario, filter=args.filter, systems=systems,
                                          **attitude_config(args), **receiver_config(args))
            outcome = run_simulated(track, scenario, config=config, seed=seed(args),
                                    systems=systems, window=args.window, smooth=args.smooth,
                                    progress=progress)
    baro_check = None if baro is None else add_run_baro(outcome, baro)
    written = write_run(outcome, tmp, plots=not args.no_plots, plotter=plotter)
    if baro_check is not None:
        written += write_run_baro(baro_check, tmp)
    text = report(outcome, Path(args.out))
    if args.fixes is not None and not args.correlated_fix_errors:
        text = "\n".join([text, *fix_hint_lines(outcome.summary)])
    if args.obs is not None and args.sigma_pr_m is None and args.sigma_rr_mps is None:
        text = "\n".join([text, *receiver_hint_lines(outcome.summary)])
    return text, written + _exports(args, outcome, tmp)


@contextmanager
def _fixes_named(args: argparse.Namespace) -> Iterator[None]:
    """A `FixesOffTrackError` (no fix agrees with the track) names the fix file and the
    track."""
    from railnav.errors import ConfigError, FixesOffTrackError
    try:
        yield
    except FixesOffTrackError as exc:
        raise ConfigError(f"{args.fixes}: {exc} (track {args.tracks[0]})") from None


def _exports(args: argparse.Namespace, outcome, tmp: Path) -> list[Path]:
    """--export: the trajectory (and the smoothed one) in the formats asked for."""
    if args.export is None:
        return []
    from railnav.jobs.export import parse_export_formats, write_run_exports
    return write_run_exports(outcome, tmp, parse_export_formats(args.export))


def _several_tracks(args: argparse.Namespace, tmp: Path) -> tuple[str, list[Path]]:
    """``railnav run A.csv B.csv ...``: identify the track among candidates (a network of
    the tracks, `railnav.jobs.tracks`); written into `tmp`: (report, files written)."""
    from railnav.defaults import DEFAULT_CROSSING_RATE_PER_S
    from railnav.jobs.tracks import (
        run_files_tracks,
        run_simulated_tracks,
        track_names,
        track_nav,
        write_track_run,
    )
    from trackmodel.io import read_track
    names = track_names(args.tracks)
    tracks = [read_track(path) for path in args.tracks]
    nav = track_nav(len(tracks), crossing_rate_per_s=DEFAULT_CROSSING_RATE_PER_S
                    if args.crossing_rate_per_s is None else args.crossing_rate_per_s)
    with progress_bar("tracks", enabled=not args.quiet) as progress:
        if files_given(args):
            run = run_files_tracks(tracks, names, imu_path=args.imu, obs_path=args.obs,
                                   nav_path=args.nav, fixes_path=args.fixes,
                                   start_gps_time_s=args.start_gps_time_s,
                                   filter=args.filter, systems=args.systems,
                                   imu_grade=args.imu_grade, fix_sigmas=fix_sigmas(args),
                                   fix_model=fix_model(args),
                                   outages=None if args.outage is None
                                   else tuple(args.outage), nav=nav,
                                   window=args.window, progress=progress)
        else:
            from railnav.simulation.trip import navigator_config_for
            scenario = scenario_of(args).with_overrides(
                speed_mps=args.speed_mps, duration_s=args.duration_s,
                imu_errors=args.imu_grade, outages=args.outage)
            systems = args.systems or DEFAULT_SYSTEMS
            run = run_simulated_tracks(tracks, names, scenario,
                                       true_track=(args.true_track or 1) - 1,
                                       config=navigator_config_for(scenario, systems=systems),
                                       seed=seed(args), systems=systems, nav=nav,
                                       window=args.window, progress=progress)
    written = write_track_run(run, tmp, plots=not args.no_plots) + _exports(args, run.outcome,
                                                                            tmp)
    probs = ", ".join(f"{k} {v:.4f}" for k, v in run.outcome.summary["track_probabilities"].items())
    return (report(run.outcome, Path(args.out)) + f"\n  track probabilities at the end: {probs}",
            written)


def _network(args: argparse.Namespace, tmp: Path) -> tuple[str, list[Path]]:
    """``railnav run --network NETWORK ...`` (`railnav.commands.network_run`) written into
    `tmp`: (report, files written)."""
    from railnav.commands.network_run import network_report, run_network
    from railnav.jobs.network import write_network_run
    with progress_bar("network", enabled=not args.quiet) as progress:
        run = run_network(args, Path(args.out), progress=progress)
    written = write_network_run(run, tmp, plots=not args.no_plots)
    return network_report(run, Path(args.out)), written + _exports(args, run.outcome, tmp)
