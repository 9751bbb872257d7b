"""Runs on a track network from the command line: ``railnav run --network`` and
``railnav network run``.

Thin layer over `railnav.jobs.network` (`run_files_network`, `run_simulated_network`,
`write_network_run`): the flags are turned into its keywords here, the report printed;
the flags themselves are declared and checked in `railnav.commands.run_flags`
(`add_network_arguments`, `_check_network_flags`, `parse_start`) and
`railnav.commands.network`.
Imports of the engine happen inside the functions (start-up: `railnav.commands`).
"""
from __future__ import annotations

import argparse
import logging
from pathlib import Path

__all__ = ["run_network", "network_report", "nav_config"]

log = logging.getLogger(__name__)


def nav_config(args: argparse.Namespace):
    """The `railnav.navigation.network_config.NetworkNavConfig` of the flags."""
    from railnav.jobs.network import with_nav
    from railnav.navigation.network_config import NetworkNavConfig
    return with_nav(NetworkNavConfig(), max_hypotheses=getattr(args, "max_hypotheses", None),
                    crossing_rate_per_s=getattr(args, "crossing_rate_per_s", None),
                    spawn=False if getattr(args, "no_spawn", False) else None,
                    start_abreast_probability=getattr(args, "start_abreast_probability",
                                                      None),
                    evidence_correlation_s=getattr(args, "fix_correlation_s", None),
                    fix_bias_sigma_m=getattr(args, "fix_bias_sigma_m", None))


def run_network(args: argparse.Namespace, out: Path, *, progress) -> object:
    """``railnav run --network``: the sensor files of `args` on the network."""
    from railnav.commands.network_data import check_netelements
    from railnav.commands.run_flags import fix_model, fix_sigmas, parse_start
    from railnav.jobs.network import load_network, run_files_network
    from railnav.navigation.network_start import NetworkStart
    network = load_network(args.network)
    parsed = parse_start(args.start)
    check_netelements(network, args.network, "--start", [] if parsed is None else [parsed[0]])
    start = None if parsed is None else NetworkStart(*parsed)
    return run_files_network(
        network, fixes_path=args.fixes, imu_path=args.imu, obs_path=args.obs,
        nav_path=args.nav, start=start, nav=nav_config(args), truth_path=args.truth,
        truth_quality=args.truth_quality, start_gps_time_s=args.start_gps_time_s,
        filter=args.filter, systems=args.systems, imu_grade=args.imu_grade,
        fix_sigmas=fix_sigmas(args), fix_model=fix_model(args),
        outages=None if args.outage is None else tuple(args.outage), progress=progress)


def network_report(run, out: Path) -> str:
    """What a network run prints: the route and its probabilities, the hypotheses, the
    truth's scores when there was one, and the status counts (and an end ``lost``)."""
    from railnav.commands.run_report import monitor_lines
    route = run.outcome.summary["route"]
    res = run.network_result
    lines = [f"network run -> {out}/ ({res.runtime_s:.1f} s, {route['cycles']} cycles, "
             f"hypotheses median {route['hypotheses_median']:g}, max "
             f"{route['hypotheses_max']})",
             f"  route ({len(route['netelements'])} netelements, final probability "
             f"{route['final_probability']:.4f}): " + " > ".join(route["netelements"])]
    truth = route.get("truth")
    if truth:
        share = truth["share_right"]
        lines.append(f"  netelement right on {truth['right']}/{truth['epochs']} epochs with a "
                     f"truth" + ("" if share is None else f" ({100 * share:.2f} %)") +
                     f"; route navigable: {truth['navigable']}, passes the truth's "
                     f"netelements: {truth['passes_truth']}")
    if route["restarts"]:
        lines.append(f"  restarted at t = {', '.join(f'{t:.1f}' for t in route['restarts'])} s")
    lines.extend(monitor_lines(run.outcome.summary["statistics"].get("monitor"), "spawns"))
    return "\n".join(lines)
