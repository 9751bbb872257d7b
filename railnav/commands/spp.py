"""``railnav spp --obs OBS --nav NAV [--systems GE] [--ref CSV] [--base BASE.rnx
[--base-position LAT,LON,H] [--max-age-s S]] [--smooth-window-s S] [--sp3 SP3 ...]
[--out DIR]``.

Thin layer over `gnss_obs.dgps.augment` (carrier smoothing, base corrections, precise
orbits) and `gnss_obs.spp.solve_spp` (STYLE.md §2.11): reads the files, builds an
`SppConfig`, writes ``DIR/spp.csv`` (columns of `gnss_obs.spp_result`) and
``DIR/spp.png``, prints a summary and, with ``--ref``, the accuracy against the reference
(`railnav.evaluation.spp_accuracy`).
"""
from __future__ import annotations

import argparse
import logging
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from gnss_obs.corrections import IONOSPHERE_MODELS
from railnav.commands.support import (
    add_augmentation_arguments,
    add_output_arguments,
    output_dir,
    progress_bar,
    read_augmentation,
    written_line,
)
from railnav.defaults import DEFAULT_SYSTEMS
from railnav.errors import ConfigError
from trackmodel.files import atomic_write_csv

if TYPE_CHECKING:
    from gnss_obs.spp import SppConfig

__all__ = ["register", "handler", "FLOAT_FORMAT", "DEFAULT_OUT"]

log = logging.getLogger(__name__)

#: CSV float format: 12 significant digits (0.1 mm in ECEF-sized numbers, 1e-10 deg).
FLOAT_FORMAT = "%.12g"
#: ``gps_time_s`` is written with 6 decimals (1 µs): 12 significant digits of a GPS time
#: (~1.3e9 s) would be 10 ms, coarser than receivers' sub-ms epoch offsets (issue 16).
TIME_FORMAT = "{:.6f}"
#: Output directory when --out is not given.
DEFAULT_OUT = "railnav-spp"


def register(subparsers) -> None:
    """Add the ``spp`` subcommand."""
    p = subparsers.add_parser(
        "spp", help="single-point positioning from RINEX files",
        description="Per-epoch least-squares position, velocity and clock (with RAIM/FDE) "
                    "from RINEX 3 observation and navigation files; writes DIR/spp.csv and "
                    "DIR/spp.png.")
    p.add_argument("--obs", required=True, metavar="OBS.rnx", help="RINEX observation file")
    p.add_argument("--nav", required=True, metavar="NAV.rnx", help="RINEX navigation file")
    p.add_argument("--systems", default=DEFAULT_SYSTEMS,
                   help=f"GNSS systems to use, letters of GERCJ (default: {DEFAULT_SYSTEMS}, "
                        "as every command)")
    p.add_argument("--ionosphere", choices=IONOSPHERE_MODELS, default="klobuchar",
                   help="ionosphere handling (default: klobuchar)")
    p.add_argument("--elevation-mask-deg", type=float, default=10.0,
                   help="elevation mask in degrees (default 10)")
    p.add_argument("--no-raim", dest="raim", action="store_false",
                   help="flag faulty epochs but do not exclude satellites")
    p.add_argument("--ref", metavar="CSV",
                   help="reference trajectory: print RMS/95 %% errors against it")
    add_augmentation_arguments(p)
    add_output_arguments(p, DEFAULT_OUT)
    p.set_defaults(func=handler)


def _config(args: argparse.Namespace) -> SppConfig:
    from gnss_obs.measurements import MeasurementConfig
    from gnss_obs.spp import SppConfig
    systems = args.systems.strip().upper()
    try:
        return SppConfig(measurement=MeasurementConfig(systems=systems,
                                                       ionosphere=args.ionosphere),
                         elevation_mask_deg=args.elevation_mask_deg, raim=args.raim)
    except ValueError as exc:
        raise ConfigError(str(exc)) from None


def handler(args: argparse.Namespace) -> int:
    """Run ``railnav spp``; returns the exit status."""
    from gnss_obs.rinex_nav import read_rinex_nav
    from gnss_obs.rinex_obs import read_rinex_obs
    from gnss_obs.spp import solve_spp
    from railnav.evaluation.spp_accuracy import (
        accuracy_summary,
        plot_spp,
        read_reference_trajectory,
        spp_errors,
    )
    config = _config(args)
    with output_dir(args, [args.obs, args.nav, args.ref, args.base, *args.sp3]) as tmp:
        obs = read_rinex_obs(args.obs)
        nav = read_rinex_nav(args.nav)
        reference = read_reference_trajectory(args.ref) if args.ref else None
        aug = read_augmentation(args, obs, nav, config.measurement)
        with progress_bar("spp", enabled=not args.quiet) as progress:
            result = solve_spp(aug.obs, nav, config, corrections=aug.corrections,
                               max_correction_age_s=aug.max_age_s, precise=aug.precise,
                               progress=progress)
        frame = result.to_frame()
        errors = spp_errors(frame, reference) if reference is not None else None
        atomic_write_csv(tmp / "spp.csv", frame.assign(gps_time_s=frame["gps_time_s"].map(
            TIME_FORMAT.format)), float_format=FLOAT_FORMAT)
        plot_spp(frame, tmp / "spp.png", errors=errors, reference=reference)
        written = written_line(args.out, [tmp / "spp.csv", tmp / "spp.png"], tmp)
    for line in _summary(frame, config, args):
        print(line)
    if errors is not None:
        for line in accuracy_summary(errors).lines():
            print(line)
    print(written)
    return 0


def _summary(frame, config: SppConfig, args: argparse.Namespace) -> list[str]:
    fixed = frame[frame["fix_ok"]]
    mode = ("DGNSS (base " + Path(args.base).name + ")" if args.base else "single point")
    mode += f", code smoothed over {args.smooth_window_s:g} s" if args.smooth_window_s else ""
    mode += ", precise orbits (SP3)" if args.sp3 else ", broadcast orbits"
    return [f"mode                 {mode}",
            f"systems              {config.measurement.systems} "
            f"(ionosphere: {config.measurement.ionosphere})",
            f"epochs               {len(frame)} ({len(fixed)} with a fix, "
            f"{int(frame['velocity_ok'].sum())} with a velocity)",
            f"satellites used      {fixed['n_sat_used'].mean():.1f} mean, "
            f"{int(fixed['n_sat_used'].min()) if len(fixed) else 0} min",
            f"HDOP / VDOP median   {np.nanmedian(fixed['hdop']):.2f} / "
            f"{np.nanmedian(fixed['vdop']):.2f}",
            f"RAIM                 {int((~fixed['raim_ok']).sum())} epochs failed, "
            f"{int(frame['n_excluded'].sum())} satellites excluded"]
