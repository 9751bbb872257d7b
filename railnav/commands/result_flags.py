"""The flags of what ``railnav run`` adds to its outputs (``--smooth``, ``--export``) and
their check against the other flags, called by `railnav.commands.run_flags` (a parser
module: light imports only)."""
from __future__ import annotations

import argparse

from railnav.errors import ConfigError

__all__ = ["add_result_arguments", "check_result_flags"]


def add_result_arguments(p) -> None:
    """What ``run`` adds to its outputs: the RTS-smoothed trajectory, exports."""
    p.add_argument("--smooth", action="store_true",
                   help="also a forward-backward (Rauch-Tung-Striebel) pass over the run: "
                        "smoothed.csv (+ smoothed_errors.csv with a truth) and summary.json "
                        "'smoothed' (one track; keeps every filter step in memory)")
    p.add_argument("--export", metavar="FORMATS", default=None,
                   help="also write the estimated trajectory with its σ (and any optional "
                        "columns) as trajectory.FORMAT for each of geojson, kml, gpx, nmea "
                        "(comma-separated; with --smooth also smoothed.FORMAT)")


def check_result_flags(args: argparse.Namespace, several: bool) -> None:
    """--smooth and --export against the inputs (part of `check_flags`)."""
    if args.export is not None:
        from railnav.jobs.export import parse_export_formats  # light: no engine
        parse_export_formats(args.export)
    if args.smooth and several:
        raise ConfigError("--smooth works with one track (a run over several tracks "
                          "keeps no smoother data)")
