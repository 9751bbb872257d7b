"""The flags of ``railnav run --network`` (`railnav.commands.network_run`): declared in
`add_network_arguments` (called from `railnav.commands.run_flags.add_run_arguments`),
checked against the others in `_check_network_flags` (called from
`railnav.commands.run_flags.check_flags`), ``--start`` parsed by `parse_start`. Light
imports only (start-up: `railnav.commands`).
"""
from __future__ import annotations

import argparse

from railnav.commands.support import (augmentation_requested, nonnegative_float,
                                      one_of_pair, positive_int)
from railnav.errors import ConfigError

__all__ = ["add_network_arguments", "parse_start", "NETWORK_EXCLUDES"]

#: Flags of ``run`` that a network run does not take (attribute -> flag).
NETWORK_EXCLUDES = {"baro": "--baro", "true_track": "--true-track", "window": "--window",
                    "imu_spec": "--imu-spec", "odometer": "--odometer",
                    "balises": "--balises", "lever_arm": "--lever-arm",
                    "imu_lever_arm": "--imu-lever-arm", "sigma_pr_m": "--sigma-pr-m",
                    "sigma_rr_mps": "--sigma-rr-mps"}


def add_network_arguments(p) -> None:
    """The flags of a run on a track network (`railnav.commands.network_run`)."""
    p.add_argument("--network", metavar="NETWORK", default=None,
                   help="a track network (a folder of railnav network build, or GeoJSON "
                        "netelements + netrelations) instead of TRACK: follow the train "
                        "through it with hypotheses that branch at switches (sensor files "
                        "only); writes hypotheses.csv, route.csv, network.png, and "
                        "estimates.csv gains netelement, netelement_offset_m, direction, "
                        "netelement_probability")
    p.add_argument("--start", metavar="NETELEMENT[:OFFSET_M[:+|-]]", default=None,
                   help="--network: the netelement the train starts on, optionally the "
                        "offset from its first coordinate (m) and the direction (+ towards "
                        "its last coordinate); default: every netelement near the first fix")
    p.add_argument("--start-abreast-probability", type=nonnegative_float, default=None,
                   metavar="P",
                   help="--network, with --start: the prior probability, together, of the "
                        "netelements within 10 m abreast of the told one, which start too "
                        "(NetworkNavConfig.start_abreast_probability, in [0, 1); default "
                        "0.01; 0: the told netelement only)")
    p.add_argument("--max-hypotheses", type=positive_int, default=None, metavar="N",
                   help="--network: most live hypotheses (default 16)")
    p.add_argument("--spawn", action="store_true",
                   help="--network: when no live hypothesis agrees with the last fixes "
                        "(--fixes, else each GNSS epoch's own single-point fix of --obs/--nav) "
                        "and the network does, start new ones from a fix of GNSS quality "
                        "(NetworkNavConfig.spawn; the default)")
    p.add_argument("--fix-correlation-s", type=nonnegative_float, default=None,
                   metavar="TAU_S",
                   help="--network, with --fixes: the fixes' errors are correlated over "
                        "TAU_S seconds (e.g. 60 for a receiver's single-point fixes): each "
                        "fix then weighs the hypotheses as the share of an independent one "
                        "that such a sequence brings (NetworkNavConfig."
                        "evidence_correlation_s; default 0: independent fixes)")
    p.add_argument("--fix-bias-sigma-m", type=nonnegative_float, default=None,
                   metavar="SIGMA_M",
                   help="--network, with --fixes: besides their σ, the fixes carry a bias "
                        "per horizontal axis (SIGMA_M, Gauss-Markov over --fix-correlation-s; "
                        "new at every fix without it) "
                        "that each hypothesis estimates (NetworkNavConfig.fix_bias_sigma_m; "
                        "default 0: none)")
    p.add_argument("--no-spawn", action="store_true",
                   help="--network: never start hypotheses from the fixes or single-point "
                        "fixes (the test and the status column still run)")


def _check_network_flags(args: argparse.Namespace) -> None:
    """The network flags against the others (part of `check_flags`)."""
    if args.network is None:
        mine = [flag for flag, value in (("--start", args.start),
                                         ("--start-abreast-probability",
                                          args.start_abreast_probability),
                                         ("--max-hypotheses", args.max_hypotheses),
                                         ("--spawn", args.spawn or None),
                                         ("--no-spawn", args.no_spawn or None),
                                         ("--fix-correlation-s", args.fix_correlation_s),
                                         ("--fix-bias-sigma-m", args.fix_bias_sigma_m))
                if value is not None]
        if mine:
            raise ConfigError(f"{', '.join(mine)}: only with --network")
        if not args.tracks:
            raise ConfigError("give a TRACK file (or several), or --network NETWORK")
        return
    if args.tracks:
        raise ConfigError("--network replaces TRACK: give one or the other")
    if args.imu is None and args.obs is None and args.fixes is None:
        raise ConfigError("--network: needs sensor files (--fixes, --imu, --obs/--nav); a "
                          "simulated trip on a network: railnav network run")
    others = [flag for attr, flag in NETWORK_EXCLUDES.items()
              if getattr(args, attr, None) is not None]
    if augmentation_requested(args):
        others.append("--base/--sp3/--smooth-window-s")
    if getattr(args, "smooth", False):
        others.append("--smooth")
    if others:
        raise ConfigError(f"{', '.join(others)}: not with --network")
    fix_model = [flag for flag, value in (("--fix-correlation-s", args.fix_correlation_s),
                                          ("--fix-bias-sigma-m", args.fix_bias_sigma_m))
                 if value is not None]
    if fix_model and args.fixes is None:
        raise ConfigError(f"{', '.join(fix_model)}: the error model of --fixes (give them)")
    one_of_pair(("--spawn", args.spawn), ("--no-spawn", args.no_spawn),
                default="spawning is the default")
    if args.spawn and args.fixes is None and args.obs is None:
        raise ConfigError("--spawn: needs --fixes or --obs/--nav (new hypotheses start from "
                          "the fixes or the epochs' single-point fixes)")
    parse_start(args.start)
    p = args.start_abreast_probability
    if p is not None and args.start is None:
        raise ConfigError("--start-abreast-probability: the prior of the tracks abreast of "
                          "--start (give it)")
    if p is not None and not p < 1.0:
        raise ConfigError(f"--start-abreast-probability {p:g}: must be in [0, 1) (the told "
                          "netelement keeps 1 - P)")


def parse_start(text: str | None) -> tuple[str, float | None, int | None] | None:
    """``NETELEMENT[:OFFSET_M[:+|-]]`` as ``(element, offset_m, direction)`` (None for
    None): the netelement, the offset from its first coordinate (m) and the direction of
    travel (``+`` towards its last coordinate); the keywords of
    `railnav.navigation.network_start.NetworkStart` (no import here: argument errors stay
    fast)."""
    if text is None:
        return None
    parts = text.split(":")
    try:
        if not 1 <= len(parts) <= 3 or not parts[0]:
            raise ValueError
        offset = float(parts[1]) if len(parts) > 1 and parts[1] != "" else None
        direction = {"+": 1, "-": -1}[parts[2]] if len(parts) == 3 else None
        if offset is not None and not offset >= 0.0:
            raise ValueError
    except (ValueError, KeyError):
        raise ConfigError(f"--start {text!r}: expected NETELEMENT[:OFFSET_M[:+|-]] with "
                          "OFFSET_M >= 0 (e.g. 88_L_111:250)") from None
    return parts[0], offset, direction
