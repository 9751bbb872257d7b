"""``railnav study CONFIG.toml --out DIR``: a Monte Carlo study into one results table.

Thin layer over `railnav.studies.file.load_study_config` and `railnav.studies.study.run_study`
(STYLE.md §2.11).
"""
from __future__ import annotations

import argparse

from railnav.commands.support import output_path, positive_int, progress_bar

__all__ = ["register", "handler", "DEFAULT_OUT"]

#: Output directory when --out is not given.
DEFAULT_OUT = "railnav-study"


def register(subparsers) -> None:
    """Add the ``study`` subcommand."""
    p = subparsers.add_parser(
        "study", help="Monte Carlo grid of simulated runs -> results.parquet (resumable)",
        description="Run every combination of the grid in CONFIG.toml (tracks, IMU grades, "
                    "speeds, outages, GNSS noise, filters) for each replicate seed, on the "
                    "local cores or a Dask cluster. Writes DIR/results.parquet (one row per "
                    "run), summary plots and study.json; rerunning with the same DIR skips "
                    "the runs already written. Ctrl-C stops it after saving the finished "
                    "runs (the same command resumes).")
    p.add_argument("config", metavar="CONFIG.toml", help="study configuration (TOML)")
    p.add_argument("--out", default=DEFAULT_OUT, type=output_path, metavar="DIR",
                   help=f"output directory (default: {DEFAULT_OUT}); a study locks it while it "
                        "runs, and resumes the runs already in it")
    p.add_argument("--scheduler", default=None, metavar="ADDRESS",
                   help="Dask scheduler (tcp://HOST:PORT), or 'local' for a Dask LocalCluster "
                        "on this machine (default: a process pool on the local cores)")
    p.add_argument("--workers", type=positive_int, default=None, metavar="N",
                   help="local worker processes (default: the usable cores; 1 runs in this "
                        "process)")
    p.add_argument("--no-plots", action="store_true", help="do not draw the summary plots")
    p.set_defaults(func=handler)


def handler(args: argparse.Namespace) -> int:
    """Run ``railnav study``; returns the exit status."""
    from railnav.studies.file import load_study_config
    from railnav.studies.study import run_study
    config = load_study_config(args.config)
    with progress_bar("runs", enabled=not args.quiet) as progress:
        result = run_study(config, args.out, scheduler=args.scheduler, workers=args.workers,
                           progress=progress, plots=not args.no_plots)
    print(f"study {config.name!r}: {result.runs_total} runs ({result.runs_resumed} already "
          f"done, {result.runs_failed} failed) -> {result.results_path}")
    for path in result.plots:
        print(f"  {path}")
    return 0
