"""``railnav network import|check|plot|route`` (and ``build``, ``info``): network data.

Thin layer over `railnav.jobs.network_import.import_network` (``import``, ``build``),
`trackmodel.network_routes.load_network` (a network folder, GeoJSON,
OpenStreetMap or a track CSV), `trackmodel.network_io.write_network`,
`trackmodel.network_check.check_network`, `railnav.evaluation.network_map` and
`trackmodel.network_routes` / `trackmodel.network.Network.routes`. Every NETWORK argument
takes any of these sources (a file is read and fitted on the fly; ``import`` writes the
folder once).
"""
from __future__ import annotations

import argparse
import logging
from pathlib import Path

from railnav.commands.support import (
    output_path,
    positive_float,
    positive_int,
    progress_bar,
)
from railnav.errors import ConfigError
from trackmodel.fit_defaults import DEFAULT_TOL_M  # load_network's, check_network's

__all__ = ["register_data_commands", "load", "start_position", "import_handler",
           "check_netelements"]

log = logging.getLogger(__name__)

SOURCE_HELP = ("network folder, GeoJSON (netelements + netrelations), OpenStreetMap "
               "(.osm, .osm.pbf) or track .csv")


def start_position(text: str):
    """argparse type for ``ELEMENT:S_M[:+|-]``: a netelement, the distance along it (m) and
    the direction of travel (``+``: increasing s, the default; ``-``: decreasing)."""
    from trackmodel.network import NetPosition
    parts = text.split(":")
    try:
        if len(parts) not in (2, 3) or not parts[0]:
            raise ValueError
        direction = {"+": 1, "-": -1}[parts[2] if len(parts) == 3 else "+"]
        return NetPosition(parts[0], float(parts[1]), direction)
    except (ValueError, KeyError):
        raise argparse.ArgumentTypeError(
            f"{text!r} is not ELEMENT:S_M[:+|-] (e.g. 88_L_111:250:-)") from None


def register_data_commands(sub) -> None:
    """Add ``import``, ``check``, ``plot`` and ``route`` to the ``network`` subcommands."""
    p = sub.add_parser("import", help="a GeoJSON, OpenStreetMap or track file -> a network "
                                      "folder",
                       description="Read a network (" + SOURCE_HELP + "), fit every "
                                   "netelement, check it (errors stop it, warnings are "
                                   "printed) and write a network folder (or GeoJSON).")
    p.add_argument("source", metavar="SOURCE", help=SOURCE_HELP)
    _add_tol(p)
    p.add_argument("--out", required=True, type=output_path, metavar="DIR|FILE.geojson",
                   help="network folder to write (replaced if it is one); a name ending in "
                        ".geojson writes GeoJSON netelements + netrelations instead")
    p.set_defaults(func=import_handler)
    c = sub.add_parser("check", help="gaps, open ends, duplicates, short netelements, kinks",
                       description="Check a network and print every finding on its own "
                                   "line (exit 2 if any is an error).")
    c.add_argument("network", metavar="NETWORK", help=SOURCE_HELP)
    _add_tol(c)
    c.set_defaults(func=_check)
    pl = sub.add_parser("plot", help="draw the network (and a route, fixes) to a PNG",
                        description="Map of the network: netelements, switches, open ends, "
                                    "a zoom on one joint showing its navigability; "
                                    "optionally a route and GNSS fixes.")
    pl.add_argument("network", metavar="NETWORK", help=SOURCE_HELP)
    pl.add_argument("--route", metavar="E1,E2,...", help="a route by its netelements")
    pl.add_argument("--fixes", metavar="FIXES", help="a fix file (CSV, NMEA, UBX, GPX)")
    pl.add_argument("--out", type=output_path, default="network.png", metavar="PNG",
                    help="PNG to write (default network.png)")
    _add_tol(pl)
    pl.set_defaults(func=_plot)
    r = sub.add_parser("route", help="the route between two positions, or one named by its "
                                     "netelements; optionally as a track file",
                       description="With --from/--to: the shortest routes between two "
                                   "network positions. With --elements: the route through "
                                   "these netelements. --out writes the (first) route's "
                                   "line as a track file for simulate/run/study.")
    r.add_argument("network", metavar="NETWORK", help=SOURCE_HELP)
    r.add_argument("--from", dest="start", type=start_position, metavar="ELEMENT:S_M[:+|-]")
    r.add_argument("--to", dest="end", type=start_position, metavar="ELEMENT:S_M")
    r.add_argument("--elements", metavar="E1,E2,...",
                   help="netelements in order (',' or '>'; '-E' travelled backwards)")
    r.add_argument("--max-routes", type=positive_int, default=None,
                   help="--from/--to: how many routes to list (default: "
                        "trackmodel.Network.routes', 5)")
    r.add_argument("--out", type=output_path, metavar="TRACK.csv",
                   help="write the route's line as a track file")
    _add_tol(r)
    r.set_defaults(func=_route)


def _add_tol(p) -> None:
    p.add_argument("--tol-m", type=positive_float, default=DEFAULT_TOL_M,
                   help="a file read from polylines: largest deviation of a netelement's "
                        f"points from its track, m (default {DEFAULT_TOL_M:g})")


def load(path: str, args: argparse.Namespace):
    """The network of `path` (any source), with a progress bar while fitting."""
    from trackmodel.network_routes import load_network
    with progress_bar("fitting netelements", enabled=not args.quiet) as progress:
        return load_network(path, tol_m=getattr(args, "tol_m", DEFAULT_TOL_M),
                            progress=progress)


def check_netelements(network, path, flag: str, names) -> None:
    """Refuse a netelement of `names` (given with `flag`) that `network` (read from
    `path`) does not have, in a line that names the network, the option and the name."""
    for name in names:
        if name not in network.elements:
            raise ConfigError(f"{path}: {flag} {name!r}: no such netelement among the "
                              f"network's {len(network.elements)}")


def _summary(network) -> str:
    km = sum(network.length_m(e) for e in network.elements) / 1000
    navigable = sum(c.navigability != "none" for c in network.connections)
    return (f"{len(network.elements)} netelements, {km:.1f} km, {len(network.connections)} "
            f"joints ({navigable} navigable), " + ("with" if network.heights else "no")
            + " heights")


def import_handler(args: argparse.Namespace) -> int:
    """``network import`` (and ``network build``): `railnav.jobs.network_import`."""
    from railnav.jobs.network_import import GEOJSON_SUFFIXES, import_network
    source = getattr(args, "source", None) or args.geojson
    with progress_bar("fitting netelements", enabled=not args.quiet) as progress:
        network, findings = import_network(source, args.out, tol_m=args.tol_m,
                                           progress=progress)
    folder = "" if Path(args.out).suffix.lower() in GEOJSON_SUFFIXES else "/"
    print(f"{args.out}{folder}: {_summary(network)}; {len(findings)} warning(s)")
    return 0


def _check(args: argparse.Namespace) -> int:
    from trackmodel.network_check import check_network
    network = load(args.network, args)
    findings = check_network(network, tol_m=args.tol_m)
    for finding in findings:
        print(f"{finding.level}: {args.network}: {finding}")
    errors = sum(f.level == "error" for f in findings)
    print(f"{args.network}: {_summary(network)}; {errors} error(s), "
          f"{len(findings) - errors} warning(s)")
    return 2 if errors else 0


def _plot(args: argparse.Namespace) -> int:
    from railnav.evaluation.network_map import plot_network_map
    from trackmodel.network_routes import route_legs
    network = load(args.network, args)
    route = None if args.route is None else route_legs(network, args.route)
    plot_network_map(network, args.out, route=route, fixes=args.fixes)
    print(f"{args.out}: {_summary(network)}"
          + ("" if route is None else f"; route of {len(route)} netelements"))
    return 0


def _route(args: argparse.Namespace) -> int:
    from trackmodel.network_routes import parse_route, route_legs, route_text
    if (args.elements is None) == (args.start is None and args.end is None):
        raise ConfigError("network route: give --elements, or --from and --to")
    if args.elements is None and (args.start is None or args.end is None):
        raise ConfigError("network route: --from and --to go together")
    network = load(args.network, args)
    if args.elements is not None:
        check_netelements(network, args.network, "--elements",
                          [n for n, _ in parse_route(args.elements)])
        legs = [route_legs(network, args.elements)]
        lengths = [sum(network.length_m(e) for e, _ in legs[0])]
    else:
        check_netelements(network, args.network, "--from", [args.start.element])
        check_netelements(network, args.network, "--to", [args.end.element])
        given = {} if args.max_routes is None else {"max_routes": args.max_routes}
        routes = network.routes(args.start, args.end, **given)
        if not routes:
            raise ConfigError(f"no route from {args.start.element} to {args.end.element} "
                              "(direction of travel and navigability respected)")
        legs, lengths = [r.legs for r in routes], [r.length_m for r in routes]
    for k, (these, length) in enumerate(zip(legs, lengths)):
        print(f"{k}: {length:9.1f} m  {route_text(these)}")
    if args.out is not None:
        _write_route(network, legs[0], Path(args.out))
    return 0


def _write_route(network, legs, out: Path) -> None:
    from trackmodel.io import write_track
    from trackmodel.network_routes import route_text
    line = network.route_track(tuple(legs))
    comments = [f"route {route_text(legs)}"]
    if not network.heights:                  # a track file has heights: say this one has not
        comments.append("the network has no heights: h = 0 is a placeholder")
        log.warning("the network has no heights: %s has h = 0, a placeholder that a run on "
                    "this track takes as the height", out)
    write_track(line, out, comments=comments)
    print(f"{out}: the route's line, {line.length_m:.1f} m, {len(line.sections)} sections")
