"""``railnav reproduce EXPERIMENT [--runs N] [--seed N] [--out DIR]`` (DIR: `DEFAULT_OUT`).

Thin layer over `railnav.reproduce.common.run_experiment` (STYLE.md §2.11): runs a source
paper's experiment as a seeded Monte Carlo, prints our figures (median and 95th
percentile over the runs) next to the paper's, and writes ``DIR/<EXPERIMENT>.json``
atomically (`railnav.reproduce.common.write_result_json`); an existing one is refused
before the work unless ``--overwrite`` (`trackmodel.files.check_output_file`). DIR is a
folder of results, one file per experiment, so both experiments share the default.
"""
from __future__ import annotations

import argparse
import logging

from railnav.commands.support import (
    nonnegative_int,
    output_path,
    positive_int,
    progress_bar,
)
from railnav.reproduce.common import (
    DEFAULT_SEED,
    EXPERIMENTS,
    result_path,
    run_experiment,
    write_result_json,
)

__all__ = ["register", "handler", "DEFAULT_SEED", "DEFAULT_OUT"]

log = logging.getLogger(__name__)

#: Output folder when ``--out`` is not given (as ``railnav run``'s ``railnav-run``): never
#: the working directory itself.
DEFAULT_OUT = "railnav-reproduce"


def register(subparsers) -> None:
    """Add the ``reproduce`` subcommand."""
    lines = "; ".join(f"{e.name}: {e.description} (default {e.default_runs} runs)"
                      for e in EXPERIMENTS.values())
    p = subparsers.add_parser(
        "reproduce", help="run a source paper's experiment and compare with its figures",
        description="Run a source paper's experiment as a seeded Monte Carlo, print our "
                    "median and 95th percentile next to the paper's figures and write "
                    f"DIR/EXPERIMENT.json. Experiments: {lines}.")
    p.add_argument("experiment", choices=sorted(EXPERIMENTS), metavar="EXPERIMENT",
                   help=f"one of: {', '.join(sorted(EXPERIMENTS))}")
    p.add_argument("--runs", type=positive_int, default=None,
                   help="Monte Carlo runs (default: the experiment's)")
    p.add_argument("--seed", type=nonnegative_int, default=DEFAULT_SEED,
                   help=f"random seed (default {DEFAULT_SEED})")
    p.add_argument("--out", default=DEFAULT_OUT, type=output_path, metavar="DIR",
                   help=f"output directory (default: {DEFAULT_OUT}); an existing "
                        "DIR/EXPERIMENT.json is refused unless --overwrite")
    p.add_argument("--overwrite", action="store_true",
                   help="replace an existing DIR/EXPERIMENT.json")
    p.set_defaults(func=handler)


def handler(args: argparse.Namespace) -> int:
    """Run ``railnav reproduce``; returns the exit status."""
    from trackmodel.files import check_output_file
    check_output_file(result_path(args.experiment, args.out),    # before the work
                      overwrite=args.overwrite)
    with progress_bar(args.experiment, enabled=not args.quiet) as progress:
        result = run_experiment(args.experiment, runs=args.runs, seed=args.seed,
                                progress=progress)
    path = write_result_json(result, args.out)
    print(result.format_table())
    print(f"\nwritten: {path}")
    return 0
