"""``railnav track fit|sample|info|plot``: the track model from the command line.

Thin layer over `railnav.jobs.survey.fit_survey` (`trackmodel.fit.fit_track` on a survey
file) and `trackmodel` (sample_track, track_info, plot_track).
"""
from __future__ import annotations

import argparse
import json
import math
import sys

from railnav.commands.support import (
    check_outputs,
    output_path,
    positive_float,
    progress_bar,
)
from trackmodel.files import atomic_write_text
from trackmodel.fit_defaults import DEFAULT_TOL_M, DEFAULT_VTOL_M

__all__ = ["register"]


def _fit(args: argparse.Namespace) -> int:
    from railnav.jobs.survey import fit_survey
    from trackmodel.io import write_track
    check_outputs({"the survey being fitted": args.polyline},
                  {"--out": args.out, "--residuals": args.residuals})
    with progress_bar("fitting", enabled=not args.quiet) as progress:
        fitted = fit_survey(args.polyline, leg=args.leg, tol_m=args.tol_m,
                            vtol_m=args.vtol_m, progress=progress)
    result = fitted.fit
    write_track(result.track, args.out, comments=[
        f"fitted by railnav track fit from {args.polyline}{fitted.note} (tol_m={args.tol_m}): "
        f"{result.n_sections} sections, max horizontal deviation "
        f"{result.max_horizontal_m:.3f} m over {int(result.residuals.kept.sum())} points"])
    if args.residuals:
        atomic_write_text(args.residuals, result.residuals.to_csv(index=False))
    print(f"{args.out}: {result.n_sections} sections, {result.track.length_m:.1f} m, "
          f"max horizontal deviation {result.max_horizontal_m:.3f} m")
    if args.residuals:
        print(f"{args.residuals}: the deviation of each of the {len(result.residuals)} points")
    return 0


def _sample(args: argparse.Namespace) -> int:
    from trackmodel.io import read_track
    from trackmodel.summary import sample_track
    check_outputs({"the track being sampled": args.track}, {"--out": args.out})
    frame = sample_track(read_track(args.track), args.step_m)
    atomic_write_text(args.out, frame.to_csv(index=False, float_format="%.10g"))
    print(f"{args.out}: {len(frame)} points every {args.step_m:g} m along {args.track}")
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
    check_outputs({"the track being plotted": args.track}, {"--out": args.out})
    plot_track(read_track(args.track), args.out)
    print(f"{args.out}: map, height and curvature of {args.track}")
    return 0


def register(subparsers) -> None:
    """Add ``track`` and its subcommands."""
    parser = subparsers.add_parser(
        "track", help="fit, sample, describe and plot track files",
        description="Track files (docs/file-formats.md): fit one to a survey, sample it, "
                    "describe it, plot it.")
    sub = parser.add_subparsers(dest="track_command", metavar="SUBCOMMAND", required=True)

    p = sub.add_parser(
        "fit", help="fit a track file to a surveyed polyline",
        description="Fit a track (straights, arcs, clothoids, grades, vertical curves) to "
                    "surveyed points in travel order, every point within --tol-m of it, and "
                    "write it as a track file. A survey that turns round is refused with "
                    "its legs listed; --leg N fits one.")
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
    p.add_argument("--out", required=True, type=output_path, metavar="TRACK.csv",
                   help="track file to write")
    p.add_argument("--residuals", type=output_path, metavar="CSV",
                   help="also write per-point deviations")
    p.set_defaults(func=_fit)

    p = sub.add_parser(
        "sample", help="sample a track every --step-m metres",
        description="Write the track's position, azimuth, elevation and curvature every "
                    "--step-m metres along it as CSV (s_m, lat_deg, lon_deg, h_m, "
                    "azimuth_deg, elevation_deg, curvature_1pm).")
    p.add_argument("track", metavar="TRACK.csv")
    p.add_argument("--step-m", type=positive_float, default=1.0,
                   help="spacing along the track, m (default %(default)s)")
    p.add_argument("--out", required=True, type=output_path, metavar="SAMPLES.csv",
                   help="CSV to write")
    p.set_defaults(func=_sample)

    p = sub.add_parser(
        "info", help="length, sections, min radius, max grade",
        description="Print a track's length, its sections by kind (straights, arcs, "
                    "transitions), smallest radius, largest grade, height range and Earth "
                    "model; --json for a machine-readable form.")
    p.add_argument("track", metavar="TRACK.csv")
    p.add_argument("--json", action="store_true", help="print JSON")
    p.set_defaults(func=_info)

    p = sub.add_parser(
        "plot", help="map, height and curvature profiles",
        description="Draw the track's map (start and end marked, section joints dotted), "
                    "its height and its curvature along s into one figure.")
    p.add_argument("track", metavar="TRACK.csv")
    p.add_argument("--out", required=True, type=output_path, metavar="FILE.png",
                   help="figure to write (PNG, PDF or SVG by the extension)")
    p.set_defaults(func=_plot)
