"""The flags of ``railnav run`` for the GNSS receiver's σ: declared in
`add_receiver_arguments` (called from `railnav.commands.run_flags.add_run_arguments`),
checked in `check_receiver_flags` (called from `railnav.commands.run_flags.check_flags`)
and turned into the public API's arguments by `receiver_inputs` (``run_files``' keywords)
and `receiver_config` (``NavigatorConfig`` fields of a simulated trip). Light imports
only (start-up: `railnav.commands`).

* ``--sigma-pr-m``, ``--sigma-rr-mps``: the receiver's pseudorange and range-rate σ at
  zenith and high C/N0 (``run_files``' keywords of the same names; sensor files with
  ``--obs``);
* ``--no-noise-scale``: the GNSS observation rows keep the σ they are given: no adaptive
  noise scale (`railnav.filters.noise_scale`; ``NavigatorConfig.noise_scale=None``,
  ``run_files(noise_scale=False)``). The constrained and GNSS-only filters, one track.
"""
from __future__ import annotations

import argparse

from railnav.commands.support import positive_float
from railnav.errors import ConfigError

__all__ = ["add_receiver_arguments", "check_receiver_flags", "receiver_inputs",
           "receiver_config", "RECEIVER_FLAGS"]

#: The σ flags (attribute -> flag): sensor files with --obs only.
RECEIVER_FLAGS = {"sigma_pr_m": "--sigma-pr-m", "sigma_rr_mps": "--sigma-rr-mps"}


def add_receiver_arguments(p) -> None:
    """The receiver flags of ``run`` (module docstring)."""
    p.add_argument("--sigma-pr-m", type=positive_float, default=None, metavar="M",
                   help="the receiver's pseudorange σ at zenith and high C/N0, m (default: "
                        "a real receiver's, gnss_obs.MeasurementConfig's; railnav "
                        "simulate's files: the simulated); give it for a noisier receiver")
    p.add_argument("--sigma-rr-mps", type=positive_float, default=None, metavar="S",
                   help="the receiver's range-rate (Doppler) σ at zenith and high C/N0, m/s "
                        "(default as --sigma-pr-m)")
    p.add_argument("--no-noise-scale", action="store_true",
                   help="keep the GNSS rows' σ as given: no adaptive noise scale (by "
                        "default each row kind's σ grows when the filter's own innovations "
                        "show it too small; constrained and gnss-only filters, one track)")


def check_receiver_flags(args: argparse.Namespace, kind, *, files: bool,
                         several: bool) -> None:
    """The receiver flags against the inputs (part of `check_flags`); `kind` is the
    filter's `railnav.filters.protocol.FilterKind`."""
    given = [flag for attr, flag in RECEIVER_FLAGS.items() if getattr(args, attr) is not None]
    if given and args.obs is None:
        raise ConfigError(f"{', '.join(given)}: only with --obs (the receiver's "
                          "observations)")
    if given and several:
        raise ConfigError(f"{', '.join(given)}: work with one track")
    if not args.no_noise_scale:
        return
    if several or getattr(args, "network", None) is not None:
        raise ConfigError("--no-noise-scale: one track only (not with --network or several "
                          "tracks)")
    if not kind.noise_scale:
        raise ConfigError(f"--no-noise-scale: the {args.filter} filter has no noise scale "
                          "(the constrained and gnss-only filters do)")
    if files and args.obs is None:
        raise ConfigError("--no-noise-scale: scales GNSS observation rows (--obs); fixes "
                          "keep their σ")


def receiver_inputs(args: argparse.Namespace) -> dict:
    """`run_files` keywords of the receiver flags (``noise_scale`` only when
    ``--no-noise-scale``: absent, the configuration's own)."""
    out = {"sigma_pr_m": args.sigma_pr_m, "sigma_rr_mps": args.sigma_rr_mps}
    if args.no_noise_scale:
        out["noise_scale"] = False
    return out


def receiver_config(args: argparse.Namespace) -> dict:
    """`NavigatorConfig` fields of the receiver flags for a simulated trip
    (``noise_scale=None`` when ``--no-noise-scale``; empty otherwise)."""
    return {"noise_scale": None} if args.no_noise_scale else {}
