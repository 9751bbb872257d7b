"""``railnav network import|build|info|check|plot|route|routes|run``: track networks.

``import``/``build``, ``check``, ``plot`` and ``route`` are `railnav.commands.network_data`
(network files: `trackmodel.network_routes.load_network`, `trackmodel.network_check`);
``info`` and ``routes`` (the ways a train may take from a start) are here, over
`trackmodel`; ``run`` (which way the train took) over `railnav.jobs.network`.
"""
from __future__ import annotations

import argparse
from pathlib import Path

from railnav.commands.network_data import (
    check_netelements,
    import_handler,
    load,
    register_data_commands,
    start_position,
)
from railnav.commands.support import (
    add_output_arguments,
    nonnegative_int,
    output_dir,
    positive_float,
    positive_int,
    progress_bar,
    written_line,
)
from railnav.defaults import DEFAULT_HORIZON_M, DEFAULT_NETWORK_SPEED_MPS, DEFAULT_SEED
from railnav.errors import ConfigError
from trackmodel.fit_defaults import DEFAULT_TOL_M

__all__ = ["register", "start_position", "DEFAULT_OUT"]

#: Output directory of ``network run`` when --out is not given.
DEFAULT_OUT = "railnav-network-run"


def register(subparsers) -> None:
    """Add the ``network`` subcommand and its own subcommands."""
    p = subparsers.add_parser(
        "network", help="track networks: import (GeoJSON, OpenStreetMap), check, plot, "
                        "routes, which way",
        description="Track networks of netelements joined by switches: import a GeoJSON "
                    "(RINF topology layout), OpenStreetMap or track file into a network "
                    "folder, check and plot it, give routes between positions or through "
                    "named netelements (as track files), list the routes a train may take "
                    "from a start, and find the route it took.")
    sub = p.add_subparsers(dest="network_command", metavar="ACTION", required=True)
    register_data_commands(sub)
    b = sub.add_parser("build", help="fit a GeoJSON network into a network folder (= import)",
                       description="Fit every netelement of a GeoJSON FeatureCollection "
                                   "(LineString netelements, Point netrelations) and write "
                                   "a network folder (elements.csv, connections.csv, "
                                   "elements/*.csv); the same as 'network import'.")
    b.add_argument("geojson", metavar="NETWORK.geojson")
    b.add_argument("--tol-m", type=positive_float, default=DEFAULT_TOL_M,
                   help="largest deviation of a netelement's points from its track, m "
                        f"(default {DEFAULT_TOL_M:g})")
    b.add_argument("--out", required=True, metavar="DIR", help="network folder to write")
    b.set_defaults(func=import_handler)
    i = sub.add_parser("info", help="netelements, joints, kinks and checks of a network",
                       description="Print the size of a network, its netelements by kind, "
                                   "its largest kinks and the count of its check findings.")
    i.add_argument("network", metavar="NETWORK",
                   help="network folder, GeoJSON, OpenStreetMap or track .csv")
    i.set_defaults(func=_info)
    r = sub.add_parser("routes", help="the routes a train may take from a start",
                       description="List every route through the switches ahead of a "
                                   "start position, up to a horizon.")
    _add_start(r)
    r.set_defaults(func=_routes)
    run = sub.add_parser("run", help="which route did the train take",
                         description="The network navigator from a known start "
                                     "(hypotheses that branch at every switch, merge and "
                                     "are pruned): on a trip simulated along route "
                                     "--true-route (of 'network routes'), or on sensor "
                                     "files (--imu, --obs --nav). Writes what 'railnav run "
                                     "--network' writes: estimates.csv with the netelement "
                                     "columns, hypotheses.csv, route.csv, summary.json "
                                     "'route', network.png.")
    _add_start(run)
    run.add_argument("--true-route", type=nonnegative_int, default=None, metavar="N",
                     help="simulated trip: the route it takes, 0 = the first listed "
                          "(default 0; the filters are not told)")
    run.add_argument("--duration-s", type=positive_float, default=None,
                     help="simulated trip: its duration, s (default: the time to run 90 %% "
                          "of the shortest route ahead)")
    run.add_argument("--speed-mps", type=positive_float, default=None,
                     help=f"simulated trip: its constant speed, m/s (default "
                          f"{DEFAULT_NETWORK_SPEED_MPS:g})")
    run.add_argument("--seed", type=nonnegative_int, default=None,
                     help=f"simulated trip: random seed (default {DEFAULT_SEED})")
    run.add_argument("--imu", metavar="IMU.csv", help="IMU samples (sensor files)")
    run.add_argument("--obs", metavar="RINEX_OBS", help="RINEX observation file")
    run.add_argument("--nav", metavar="RINEX_NAV", help="RINEX navigation file")
    run.add_argument("--max-hypotheses", type=positive_int, default=None, metavar="N",
                     help="most live hypotheses (default 16)")
    run.add_argument("--no-plots", action="store_true", help="do not draw the PNG plots")
    add_output_arguments(run, DEFAULT_OUT)
    run.set_defaults(func=_run)


def _add_start(p) -> None:
    p.add_argument("network", metavar="NETWORK",
                   help="network folder (railnav network build), GeoJSON, OpenStreetMap or "
                        "track .csv")
    p.add_argument("--start", type=start_position, required=True,
                   metavar="ELEMENT:S_M[:+|-]",
                   help="where the train starts: netelement, distance along it (m), "
                        "direction (+ increasing s, - decreasing; default +)")
    p.add_argument("--horizon-m", type=positive_float, default=DEFAULT_HORIZON_M,
                   help=f"how far ahead to follow the switches, m (default "
                        f"{DEFAULT_HORIZON_M:g})")


def _info(args: argparse.Namespace) -> int:
    from collections import Counter

    from trackmodel.network_check import check_network
    network = load(args.network, args)
    kinks = network.kinks()
    print(f"{args.network}: {len(network.elements)} netelements, "
          f"{sum(network.length_m(e) for e in network.elements) / 1000:.1f} km; "
          f"{len(network.connections)} joints, {len(kinks)} navigable "
          f"({int(kinks['continuous'].sum()) if len(kinks) else 0} with a continuous tangent); "
          + ("with" if network.heights else "no") + " heights")
    kinds = Counter(network.attributes.get(e, {}).get("railway") for e in network.elements)
    if set(kinds) - {None}:
        print("  netelements by railway=: " + ", ".join(
            f"{k or 'unknown'} {n}" for k, n in sorted(kinds.items(), key=lambda x: str(x[0]))))
    for row in kinks.sort_values("kink_deg", ascending=False).head(5).itertuples():
        print(f"  kink {row.kink_deg:6.2f} deg, gap {row.gap_m:.2f} m: {row.a}[{row.a_end}] "
              f"- {row.b}[{row.b_end}]")
    findings = check_network(network)
    errors = sum(f.level == "error" for f in findings)
    print(f"  checks: {errors} error(s), {len(findings) - errors} warning(s) "
          f"('railnav network check' lists them)")
    return 0


def _routes(args: argparse.Namespace) -> int:
    from railnav.jobs.network import load_network, route_candidates
    network = load_network(args.network)
    check_netelements(network, args.network, "--start", [args.start.element])
    names, routes, _ = route_candidates(network, args.start, horizon_m=args.horizon_m)
    for k, (name, route) in enumerate(zip(names, routes)):
        print(f"{k}: {route.length_m:8.1f} m  {name}")
    return 0


def _run(args: argparse.Namespace) -> int:
    """``network run``: the network navigator (`railnav.commands.network_run`) from a known
    start, on a trip simulated along route --true-route or on sensor files."""
    from railnav.commands.network_run import network_report
    from railnav.jobs.network import write_network_run
    from railnav.navigation.network_start import NetworkStart
    from railnav.jobs.network import load_network
    network = load_network(args.network)
    check_netelements(network, args.network, "--start", [args.start.element])
    files = args.imu is not None or args.obs is not None
    shaping = [flag for flag, value in (("--true-route", args.true_route),
                                        ("--duration-s", args.duration_s),
                                        ("--speed-mps", args.speed_mps),
                                        ("--seed", args.seed)) if value is not None]
    if files and shaping:
        raise ConfigError(f"{'/'.join(shaping)}: shape a simulated trip; with sensor "
                          "files there is none to shape")
    out = Path(args.out)
    start = NetworkStart(args.start.element, args.start.s_m, args.start.direction)
    with output_dir(args, [args.network, args.imu, args.obs, args.nav]) as tmp:
        with progress_bar("network", enabled=not args.quiet) as progress:
            run = _network_run(network, args, start, files, progress)
        written = write_network_run(run, tmp, plots=not args.no_plots)
    print(network_report(run, out))
    print(written_line(out, written, tmp))
    return 0


def _network_run(network, args: argparse.Namespace, start, files: bool, progress):
    """The navigator from `start`: on the sensor files, or on a trip simulated along route
    --true-route ahead of it."""
    from railnav.commands.network_run import nav_config
    from railnav.jobs.network import run_files_network
    from railnav.jobs.network_sim import run_simulated_route
    if files:
        return run_files_network(network, imu_path=args.imu, obs_path=args.obs,
                                 nav_path=args.nav, start=start, nav=nav_config(args),
                                 progress=progress)
    given = {k: getattr(args, k) for k in ("true_route", "speed_mps", "duration_s", "seed")
             if getattr(args, k) is not None}
    return run_simulated_route(network, args.start, horizon_m=args.horizon_m,
                               nav=nav_config(args), progress=progress, **given)
