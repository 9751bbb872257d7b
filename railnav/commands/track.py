"""``railnav track fit|sample|info|plot``: the track model from the command line.

Thin layer over `trackmodel` (fit_track, sample_track, track_info, plot_track).
"""
from __future__ import annotations

import argparse
import json
import math
import sys
from typing import TYPE_CHECKING

import numpy as np

from railnav.commands.support import positive_float, progress_bar
from trackmodel.errors import TrackFileError
from trackmodel.files import atomic_write_text
from trackmodel.fit_defaults import DEFAULT_TOL_M, DEFAULT_VTOL_M

if TYPE_CHECKING:
    from trackmodel.polyline import Polyline

__all__ = ["register"]


def read_survey(path) -> Polyline:
    """A surveyed path: a polyline CSV (`trackmodel.polyline.read_polyline`), or a reference
    trajectory in GPS week / seconds-of-week layout (`railnav.evaluation.spp_accuracy`), in time order.

    Raises
    ------
    trackmodel.TrackFileError
        When the file is neither (the polyline reader's error).
    """
    from trackmodel.polyline import Polyline, read_polyline
    try:
        return read_polyline(path)
    except TrackFileError as polyline_error:
        if polyline_error.column is None:
            raise
        from railnav.errors import ConfigError
        from railnav.evaluation.spp_accuracy import read_reference_trajectory
        try:
            ref = read_reference_trajectory(path)
        except (ConfigError, ValueError):
            raise polyline_error from None
        return Polyline(np.radians(ref["lat_deg"].to_numpy()),
                        np.radians(ref["lon_deg"].to_numpy()), ref["h_m"].to_numpy())


def _leg(poly: Polyline, leg: int | None, path) -> tuple[Polyline, str]:
    """The points of leg `leg` (1-based) of a survey, and a note for the file's comment."""
    from trackmodel.polyline import split_legs
    if leg is None:
        return poly, ""
    legs = split_legs(poly)
    if not 1 <= leg <= len(legs):
        raise TrackFileError(f"--leg {leg}: the survey has {len(legs)} leg(s)", path=path)
    index = legs[leg - 1]
    return poly.take(index), f", leg {leg} of {len(legs)} (points {index[0]}-{index[-1]})"


def _fit(args: argparse.Namespace) -> int:
    from trackmodel.fit import fit_track
    from trackmodel.io import write_track
    poly, note = _leg(read_survey(args.polyline), args.leg, args.polyline)
    with progress_bar("fitting", enabled=not args.quiet) as progress:
        result = fit_track(poly.lat, poly.lon, poly.h, tol_m=args.tol_m, vtol_m=args.vtol_m,
                           progress=progress)
    write_track(result.track, args.out, comments=[
        f"fitted by railnav track fit from {args.polyline}{note} (tol_m={args.tol_m}): "
        f"{result.n_sections} sections, max horizontal deviation "
        f"{result.max_horizontal_m:.3f} m over {int(result.residuals.kept.sum())} points"])
    if args.residuals:
        atomic_write_text(args.residuals, result.residuals.to_csv(index=False))
    print(f"{args.out}: {result.n_sections} sections, {result.track.length_m:.1f} m, "
          f"max horizontal deviation {result.max_horizontal_m:.3f} m")
    return 0


def _sample(args: argparse.Namespace) -> int:
    from trackmodel.io import read_track
    from trackmodel.summary import sample_track
    frame = sample_track(read_track(args.track), args.step_m)
    atomic_write_text(args.out, frame.to_csv(index=False, float_format="%.10g"))
    return 0


def _info(args: argparse.Namespace) -> int:
    from trackmodel.io import read_track
    from trackmodel.summary import track_info
    info = track_info(read_track(args.track)).to_dict()
    if args.json:
        json.dump({k: (None if isinstance(v, float) and math.isinf(v) else v)
                   for k, v in info.items()}, sys.stdout, indent=2)
        print()
        return 0
    print(f"{args.track}: {info['length_m']:.1f} m, {info['n_sections']} sections "
          f"({info['n_straights']} straights, {info['n_arcs']} arcs, "
          f"{info['n_transitions']} transitions), earth {info['earth']}")
    print(f"min radius {info['min_radius_m']:.1f} m, max grade "
          f"{info['max_grade_percent']:.2f} %, height {info['h_min_m']:.1f}..."
          f"{info['h_max_m']:.1f} m")
    return 0


def _plot(args: argparse.Namespace) -> int:
    from trackmodel.io import read_track
    from trackmodel.plot import plot_track
    plot_track(read_track(args.track), args.out)
    return 0


def register(subparsers) -> None:
    """Add ``track`` and its subcommands."""
    parser = subparsers.add_parser("track", help="fit, sample, describe and plot track files")
    sub = parser.add_subparsers(dest="track_command", metavar="SUBCOMMAND", required=True)

    p = sub.add_parser("fit", help="fit a track file to a surveyed polyline")
    p.add_argument("polyline", metavar="POLYLINE.csv",
                   help="columns lat_deg, lon_deg and optional h_m, in travel order; or a "
                        "reference trajectory (GPS week, seconds of week, lat, lon, h)")
    p.add_argument("--leg", type=int, default=None, metavar="N",
                   help="fit only leg N (1-based) of a survey that reverses its direction "
                        "(default: a reversal is an error that lists the legs)")
    p.add_argument("--tol-m", type=positive_float, default=DEFAULT_TOL_M,
                   help="largest horizontal deviation of a point, m (default %(default)s)")
    p.add_argument("--vtol-m", type=positive_float, default=DEFAULT_VTOL_M,
                   help="height tolerance of the vertical profile, m (default %(default)s)")
    p.add_argument("--out", required=True, metavar="TRACK.csv", help="track file to write")
    p.add_argument("--residuals", metavar="CSV", help="also write per-point deviations")
    p.set_defaults(func=_fit)

    p = sub.add_parser("sample", help="sample a track every --step-m metres")
    p.add_argument("track", metavar="TRACK.csv")
    p.add_argument("--step-m", type=positive_float, default=1.0,
                   help="spacing along the track, m (default %(default)s)")
    p.add_argument("--out", required=True, metavar="SAMPLES.csv")
    p.set_defaults(func=_sample)

    p = sub.add_parser("info", help="length, sections, min radius, max grade")
    p.add_argument("track", metavar="TRACK.csv")
    p.add_argument("--json", action="store_true", help="print JSON")
    p.set_defaults(func=_info)

    p = sub.add_parser("plot", help="map, height and curvature profiles")
    p.add_argument("track", metavar="TRACK.csv")
    p.add_argument("--out", required=True, metavar="FILE.png")
    p.set_defaults(func=_plot)
