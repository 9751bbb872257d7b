"""``railnav spp --obs OBS --nav NAV [--systems GE] [--ref CSV] [--base BASE.rnx
[--base-position LAT,LON,H] [--max-age-s S]] [--smooth-window-s S] [--sp3 SP3 ...]
[--out DIR]``.

Thin layer over `railnav.jobs.spp.spp_files` (STYLE.md §2.11), with its defaults: parses
the flags into its arguments, writes ``DIR/spp.csv`` (columns of `gnss_obs.spp_result`)
and ``DIR/spp.png`` (`SppRun.write`) and prints `SppRun.lines` (a summary and, with
``--ref``, the accuracy against the reference).
"""
from __future__ import annotations

import argparse
import logging

from gnss_obs.corrections import IONOSPHERE_MODELS
from railnav.commands.support import (
    add_augmentation_arguments,
    add_output_arguments,
    output_dir,
    progress_bar,
    written_line,
)
from railnav.defaults import DEFAULT_ELEVATION_MASK_DEG, DEFAULT_IONOSPHERE, DEFAULT_SYSTEMS
from railnav.errors import ConfigError

__all__ = ["register", "handler", "DEFAULT_OUT"]

log = logging.getLogger(__name__)

#: Output directory when --out is not given.
DEFAULT_OUT = "railnav-spp"


def register(subparsers) -> None:
    """Add the ``spp`` subcommand."""
    p = subparsers.add_parser(
        "spp", help="single-point positioning from RINEX files",
        description="Per-epoch least-squares position, velocity and clock (with RAIM/FDE) "
                    "from RINEX 3 observation and navigation files; writes DIR/spp.csv and "
                    "DIR/spp.png. From Python: railnav.spp_files, with the same defaults.")
    p.add_argument("--obs", required=True, metavar="OBS.rnx", help="RINEX observation file")
    p.add_argument("--nav", required=True, metavar="NAV.rnx", help="RINEX navigation file")
    p.add_argument("--systems", default=DEFAULT_SYSTEMS,
                   help=f"GNSS systems to use, letters of GERCJ (default: {DEFAULT_SYSTEMS}, "
                        "as every command; gnss_obs.SppConfig's own default is GE)")
    p.add_argument("--ionosphere", choices=IONOSPHERE_MODELS, default=DEFAULT_IONOSPHERE,
                   help=f"ionosphere handling (default: {DEFAULT_IONOSPHERE})")
    p.add_argument("--elevation-mask-deg", type=float, default=DEFAULT_ELEVATION_MASK_DEG,
                   help=f"elevation mask in degrees (default {DEFAULT_ELEVATION_MASK_DEG:g})")
    p.add_argument("--no-raim", dest="raim", action="store_false",
                   help="flag faulty epochs but do not exclude satellites")
    p.add_argument("--ref", metavar="CSV",
                   help="reference trajectory: print RMS/95 %% errors against it")
    add_augmentation_arguments(p)
    add_output_arguments(p, DEFAULT_OUT)
    p.set_defaults(func=handler)


def handler(args: argparse.Namespace) -> int:
    """Run ``railnav spp``; returns the exit status."""
    from railnav.jobs.spp import spp_config, spp_files

    spp_config(systems=args.systems, ionosphere=args.ionosphere,      # bad values: before
               elevation_mask_deg=args.elevation_mask_deg, raim=args.raim)  # any file
    if args.base_position is not None and not args.base:
        raise ConfigError("--base-position needs --base")
    with output_dir(args, [args.obs, args.nav, args.ref, args.base, *args.sp3]) as tmp:
        with progress_bar("spp", enabled=not args.quiet) as progress:
            run = spp_files(args.obs, args.nav, systems=args.systems,
                            ionosphere=args.ionosphere,
                            elevation_mask_deg=args.elevation_mask_deg, raim=args.raim,
                            base=args.base, base_position=args.base_position,
                            max_age_s=args.max_age_s, smooth_window_s=args.smooth_window_s,
                            sp3=args.sp3, reference=args.ref, progress=progress)
        written = written_line(args.out, run.write(tmp), tmp)
    for line in run.lines():
        print(line)
    print(written)
    return 0
