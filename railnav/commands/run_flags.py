"""The arguments of ``railnav run`` and the one check of their combinations.

`add_run_arguments` declares every flag (grouped by what it feeds: sensor files and fixes,
the simulated trip, several tracks, augmentation, outputs); `check_flags` is the one place
where flags are checked against each other and against the inputs given, before any engine
is imported (`railnav.commands.run.handler`); the small translators below turn flags into
the keywords of `railnav.jobs.run`. Like every parser module, this one imports only light
owner modules at its top (start-up: `railnav.commands`).
"""
from __future__ import annotations

import argparse

from railnav.commands.result_flags import add_result_arguments, check_result_flags
from railnav.commands.support import (
    add_augmentation_arguments,
    add_output_arguments,
    augmentation_requested,
    nonnegative_float,
    nonnegative_int,
    outage_window,
    positive_float,
    positive_int,
)
from railnav.defaults import (
    DEFAULT_BALISE_SIGMA_M,
    DEFAULT_CROSSING_RATE_PER_S,
    DEFAULT_FILTER,
    DEFAULT_ODOMETER_SIGMA_MPS,
    DEFAULT_SEED,
    DEFAULT_SYSTEMS,
)
from railnav.commands.attitude_flags import add_attitude_arguments, check_attitude_flags
from railnav.commands.receiver_flags import add_receiver_arguments, check_receiver_flags
from railnav.commands.run_network_flags import (
    _check_network_flags,
    add_network_arguments,
    parse_start,
)
from railnav.errors import ConfigError
from railnav.filters.protocol import FILTER_KINDS, filter_kind
from railnav.simulation.scenarios import DEFAULT_SCENARIO, SCENARIOS, scenario_for_track
from strapdown.imu_errors import IMU_GRADES

__all__ = ["add_run_arguments", "add_file_arguments", "add_network_arguments", "parse_start",
           "check_flags",
           "time_window",
           "DEFAULT_OUT", "DEFAULT_SCENARIO", "DEFAULT_SEED", "SIMULATION_FLAGS",
           "measurement", "files_given", "fix_sigmas", "fix_model", "augmentation", "seed",
           "scenario_of", "SCENARIO_HELP", "add_real_input_arguments",
           "real_inputs", "REAL_INPUT_FLAGS", "lever_arm"]

#: Output directory when --out is not given.
DEFAULT_OUT = "railnav-run"
#: Help of --scenario (``run`` and ``simulate``: one rule, `scenario_for_track`).
SCENARIO_HELP = (f"scenario to simulate (default: the track's file name if it is a scenario's, "
                 f"else {DEFAULT_SCENARIO}: railnav.scenario_for_track)")
#: Flags that shape a simulated trip (attribute -> flag); with sensor files there is none.
SIMULATION_FLAGS = {"scenario": "--scenario", "speed_mps": "--speed-mps",
                    "duration_s": "--duration-s", "seed": "--seed",
                    "true_track": "--true-track"}


def time_window(text: str) -> tuple[float, float]:
    """argparse type for ``START:END`` (seconds from the trip start)."""
    try:
        start, end = (float(x) for x in text.split(":"))
    except ValueError:
        raise argparse.ArgumentTypeError(f"{text!r} is not START:END in seconds") from None
    if not (0 <= start < end < float("inf")):
        raise argparse.ArgumentTypeError(f"{text!r}: need 0 <= START < END")
    return start, end


def add_run_arguments(p) -> None:
    """Every argument of ``run`` (`register` builds the parser around them)."""
    p.add_argument("tracks", metavar="TRACK", nargs="*",
                   help="track file(s) (.csv); several: candidate tracks named by file stem "
                        "(none with --network)")
    p.add_argument("--imu", metavar="IMU.csv",
                   help="IMU samples: railnav's imu.csv (railnav simulate's), or a logger's "
                        "CSV read with --imu-spec")
    p.add_argument("--obs", metavar="RINEX_OBS", help="RINEX observation file")
    p.add_argument("--nav", metavar="RINEX_NAV", help="RINEX navigation file")
    add_file_arguments(p)
    p.add_argument("--scenario", choices=sorted(SCENARIOS), default=None, help=SCENARIO_HELP)
    p.add_argument("--imu-grade", choices=sorted(IMU_GRADES), default=None,
                   help="the IMU grade the filter assumes (simulated trip: also the grade "
                        "simulated; default the scenario's). A recorded IMU file needs it, "
                        "or an --imu-spec with a [noise] table (files written by railnav "
                        "simulate: default the simulated grade)")
    p.add_argument("--speed-mps", type=positive_float, default=None,
                   help="top speed of the simulated trip, m/s")
    p.add_argument("--duration-s", type=positive_float, default=None,
                   help="duration of the simulated trip, s")
    p.add_argument("--outage", type=outage_window, action="append", default=None,
                   metavar="START:DURATION",
                   help="GNSS outage, s from the start (repeatable; replaces the scenario's)")
    p.add_argument("--filter", choices=FILTER_KINDS, default=None,
                   help=f"which filter (default: {DEFAULT_FILTER}; gnss-only for sensor "
                        "files without --imu)")
    p.add_argument("--systems", default=None,
                   help="GNSS systems to use, e.g. G or GE (default: the simulated ones for "
                        "railnav simulate's files, else G)")
    p.add_argument("--window", type=time_window, default=None, metavar="START:END",
                   help="also summarize the errors over this window, s")
    p.add_argument("--seed", type=nonnegative_int, default=None,
                   help=f"random seed of the simulation (default {DEFAULT_SEED})")
    p.add_argument("--true-track", type=positive_int, default=None, metavar="N",
                   help="several tracks, simulated trip: the track it runs on, 1 = the first "
                        "given (default 1; the filters are not told)")
    p.add_argument("--crossing-rate-per-s", type=nonnegative_float,
                   default=None, metavar="RATE",
                   help="several tracks: rate of changing tracks, 1/s (default "
                        f"{DEFAULT_CROSSING_RATE_PER_S:g}; 0: no crossovers)")
    p.add_argument("--baro", metavar="BARO.csv", default=None,
                   help="barometric altimeter readings (columns gps_time_s or time_s, "
                        "baro_h_m): bias estimated against the track height, GNSS heights "
                        "checked against the calibrated baro (baro.csv, baro_gnss.csv, "
                        "summary.json 'baro'); one track only")
    add_augmentation_arguments(p)
    add_network_arguments(p)
    add_attitude_arguments(p)
    add_real_input_arguments(p)
    add_receiver_arguments(p)
    p.add_argument("--no-plots", action="store_true", help="do not draw the PNG plots")
    add_result_arguments(p)
    add_output_arguments(p, DEFAULT_OUT)


def add_file_arguments(p) -> None:
    """The GNSS fix, scoring and start-time flags of ``run`` (sensor files only)."""
    p.add_argument("--fixes", metavar="FILE",
                   help="GNSS position fixes (loose coupling): CSV, NMEA 0183, u-blox UBX or "
                        "GPX, told by content; alone (the gnss-only filter on [s, v]) or "
                        "with --imu and/or --obs/--nav")
    p.add_argument("--fix-sigma", action="append", default=None, metavar="QUALITY=H[,V[,S]]",
                   help="σ of a fix class where the fix file has none: horizontal and "
                        "vertical m, speed m/s (classes rtk_fixed, rtk_float, dgps, single, "
                        "dead_reckoning; repeatable)")
    p.add_argument("--fix-track-sigma-m", type=nonnegative_float, default=None, metavar="M",
                   help="σ of the antenna's distance from the track centre-line beyond the "
                        "fix σ, m (default 1.5)")
    p.add_argument("--no-fix-heights", action="store_true",
                   help="ignore the fixes' heights (a track without heights)")
    p.add_argument("--correlated-fix-errors", action="store_true",
                   help="the code fixes' (single-point, DGPS) errors are correlated from "
                        "epoch to epoch like their pseudoranges': their rows are inflated "
                        "and their slow part estimated (FixModelConfig."
                        "correlated_code_errors; the gnss-only filter on one track). Use it "
                        "for a receiver's single-point fixes: on the shared urban drive's, "
                        "the epochs beyond 3σ_s go from 315 to 0 of 952")
    p.add_argument("--truth", metavar="FILE",
                   help="score the run against railnav's truth.csv, a reference trajectory "
                        "(gps_time_s or GPS week/SOW, lat, lon, h) or a fix file (its best "
                        "class, rows that agree with the track); default for railnav "
                        "simulate's files: the truth.csv beside scenario.json")
    p.add_argument("--truth-quality", default=None, metavar="CLASS",
                   help="--truth is a fix file: the class of its rows that serve as the "
                        "reference (rtk_fixed, rtk_float, dgps, single, dead_reckoning; "
                        "default its best)")
    p.add_argument("--start-gps-time-s", type=float, default=None,
                   help="GPS time (s since 1980-01-06) of the IMU's time_s = 0 (default: from "
                        "scenario.json beside the IMU file, else the first GNSS epoch)")


def check_flags(args: argparse.Namespace) -> None:
    """The one place where ``run``'s flags are checked against each other and against the
    inputs given: a flag that cannot apply is an error that says why, never ignored
    (single values are checked by their argparse types)."""
    measurement(args.systems)   # validates --systems before any work
    _check_network_flags(args)
    files = files_given(args)
    check_attitude_flags(args, files=files)
    kind = filter_kind(args.filter)
    given = [flag for attr, flag in SIMULATION_FLAGS.items() if getattr(args, attr) is not None]
    if files and given:
        raise ConfigError(f"{', '.join(given)}: shape a simulated trip; with sensor files "
                          "(--imu/--obs/--fixes) there is none to shape")
    if files and kind.needs_imu and args.imu is None:
        raise ConfigError(f"--filter {args.filter}: needs --imu (without one, the gnss-only "
                          "filter runs on the observations or fixes)")
    if not files and args.start_gps_time_s is not None:
        raise ConfigError("--start-gps-time-s: only with sensor files (a simulated trip "
                          "starts at its scenario's time)")
    if not kind.needs_imu and (args.imu_grade is not None or args.imu is not None):
        flag = "--imu-grade" if args.imu_grade is not None else "--imu"
        raise ConfigError(f"{flag}: the {args.filter} filter uses no IMU")
    several = len(args.tracks) > 1
    _check_fix_flags(args, kind, several)
    _check_real_input_flags(args, kind, several)
    check_receiver_flags(args, kind, files=files, several=several)
    if args.true_track is not None and args.true_track > len(args.tracks):
        raise ConfigError(f"--true-track {args.true_track}: only {len(args.tracks)} track(s) "
                          "given")
    if several and args.baro is not None:
        raise ConfigError("--baro works with one track")
    if augmentation_requested(args) and (args.obs is None or several):
        raise ConfigError("--base/--base-position/--smooth-window-s/--sp3: need --obs and one "
                          "track")
    if args.base_position is not None and args.base is None:
        raise ConfigError("--base-position needs --base")
    if not several and args.crossing_rate_per_s is not None and args.network is None:
        raise ConfigError("--crossing-rate-per-s: only with several tracks or --network")
    check_result_flags(args, several)
    if several and not (kind.banks or (kind.fixes and args.fixes is not None)):
        banked = " or ".join(k for k in FILTER_KINDS if filter_kind(k).banks)
        raise ConfigError(f"several tracks run the {banked} filter, or a filter that takes "
                          f"--fixes with them, not --filter {args.filter}")


def _check_fix_flags(args: argparse.Namespace, kind, several: bool) -> None:
    """The fix and truth flags against the inputs (part of `check_flags`)."""
    fix_flags = [flag for flag, given in (("--fix-sigma", args.fix_sigma),
                                          ("--fix-track-sigma-m",
                                           args.fix_track_sigma_m is not None),
                                          ("--no-fix-heights", args.no_fix_heights),
                                          ("--correlated-fix-errors",
                                           args.correlated_fix_errors)) if given]
    if fix_flags and args.fixes is None:
        raise ConfigError(f"{', '.join(fix_flags)}: only with --fixes")
    if args.correlated_fix_errors and (several or args.network is not None
                                       or args.filter != "gnss-only"):
        raise ConfigError("--correlated-fix-errors: the gnss-only filter on one track only "
                          "(a network run takes --fix-correlation-s)")
    if args.fixes is not None and not kind.fixes:
        takes = " or ".join(k for k in FILTER_KINDS if filter_kind(k).fixes)
        raise ConfigError(f"--fixes: the {args.filter} filter takes no fixes (the {takes} "
                          "filters do)")
    if args.truth is not None and not files_given(args):
        raise ConfigError("--truth: a simulated run is scored against its own truth; "
                          "--truth goes with sensor files")
    if args.truth is not None and several:
        raise ConfigError("--truth works with one track")
    if args.truth_quality is not None and args.truth is None:
        raise ConfigError("--truth-quality: only with --truth (a fix file)")
    fix_sigmas(args)


def lever_arm(text: str) -> tuple[float, float, float]:
    """argparse type for ``F,L,U`` (m: forward, left, up)."""
    from railnav.filters.track_frame import parse_lever_arm
    try:
        return parse_lever_arm(text)
    except ConfigError as exc:
        raise argparse.ArgumentTypeError(exc.message) from None


def add_real_input_arguments(p) -> None:
    """The IMU spec, odometer, balise and lever-arm flags of ``run`` (sensor files only;
    the receiver's σ: `railnav.commands.receiver_flags`)."""
    p.add_argument("--imu-spec", metavar="SPEC.toml", default=None,
                   help="how the --imu log is laid out (columns, units, increments, axes, "
                        "mounting) and, in its [noise] table, what the filter assumes "
                        "(instead of --imu-grade); docs/file-formats.md")
    p.add_argument("--odometer", metavar="ODO.csv", default=None,
                   help="odometer readings (time_s or gps_time_s; speed_mps, or pulses with "
                        "--wheel-circumference-m and --pulses-per-rev): a speed row with a "
                        "scale-factor state, slips flagged; constrained and gnss-only")
    p.add_argument("--wheel-circumference-m", type=positive_float, default=None, metavar="M",
                   help="nominal wheel circumference of an odometer of pulses, m")
    p.add_argument("--pulses-per-rev", type=positive_float, default=None, metavar="N",
                   help="pulses per wheel revolution of an odometer of pulses")
    p.add_argument("--odometer-sigma-mps", type=positive_float, default=None, metavar="S",
                   help="1σ of an odometer reading without its own, m/s (default "
                        f"{DEFAULT_ODOMETER_SIGMA_MPS:g})")
    p.add_argument("--balises", metavar="BALISES.csv", default=None,
                   help="balise passages (time_s or gps_time_s; s_m, or lat_deg, lon_deg "
                        "projected on the track): updates of s")
    p.add_argument("--balise-sigma-m", type=positive_float, default=None, metavar="S",
                   help=f"1σ of a passage without its own, m (default "
                        f"{DEFAULT_BALISE_SIGMA_M:g})")
    p.add_argument("--lever-arm", type=lever_arm, default=None, metavar="F,L,U",
                   help="the GNSS antenna's offset from the reference point (the track "
                        "centre-line point at s): forward (along +s), left, up from the "
                        "rail, m")
    p.add_argument("--imu-lever-arm", type=lever_arm, default=None, metavar="F,L,U",
                   help="the IMU's offset from the reference point, m (its specific force "
                        "is moved there)")
    p.add_argument("--balise-reader-forward-m", type=float, default=None, metavar="F",
                   help="the balise reader's forward offset from the reference point, m")


#: The flags of `add_real_input_arguments` (attribute -> flag).
REAL_INPUT_FLAGS = {"imu_spec": "--imu-spec", "odometer": "--odometer",
                    "wheel_circumference_m": "--wheel-circumference-m",
                    "pulses_per_rev": "--pulses-per-rev",
                    "odometer_sigma_mps": "--odometer-sigma-mps", "balises": "--balises",
                    "balise_sigma_m": "--balise-sigma-m", "lever_arm": "--lever-arm",
                    "imu_lever_arm": "--imu-lever-arm",
                    "balise_reader_forward_m": "--balise-reader-forward-m"}
#: Each of these needs the flag it maps to.
_NEEDS = {"imu_spec": "imu", "wheel_circumference_m": "odometer",
          "pulses_per_rev": "odometer", "odometer_sigma_mps": "odometer",
          "balise_sigma_m": "balises", "balise_reader_forward_m": "balises"}


def _check_real_input_flags(args: argparse.Namespace, kind, several: bool) -> None:
    """The IMU spec, odometer, balise and lever-arm flags against the inputs (part of
    `check_flags`)."""
    given = [a for a in REAL_INPUT_FLAGS if getattr(args, a, None) is not None]
    for attr in given:
        need = _NEEDS.get(attr)
        if need is not None and getattr(args, need) is None:
            raise ConfigError(f"{REAL_INPUT_FLAGS[attr]}: only with --{need}")
    if not given:
        return
    flags = ", ".join(REAL_INPUT_FLAGS[a] for a in given)
    if not files_given(args):
        raise ConfigError(f"{flags}: go with sensor files (railnav simulate --odometer "
                          "--balises writes them for a simulated trip)")
    if several:
        raise ConfigError(f"{flags}: work with one track")
    track_flags = [REAL_INPUT_FLAGS[a] for a in given if a != "imu_spec"]
    if track_flags and not kind.track_sensors:
        takes = " or ".join(k for k in FILTER_KINDS if filter_kind(k).track_sensors)
        raise ConfigError(f"{', '.join(track_flags)}: the {args.filter} filter takes no "
                          f"odometer, balises or lever arms (the {takes} filters do)")


def real_inputs(args: argparse.Namespace) -> dict:
    """`run_files` keywords of `add_real_input_arguments`'s flags."""
    out = {"imu_spec": args.imu_spec, "odometer_path": args.odometer,
           "balises_path": args.balises, "wheel_circumference_m": args.wheel_circumference_m,
           "pulses_per_rev": args.pulses_per_rev}
    if args.odometer_sigma_mps is not None:
        from railnav.filters.odometer_epochs import OdometerConfig
        out["odometer_model"] = OdometerConfig(sigma_speed_mps=args.odometer_sigma_mps)
    if args.balise_sigma_m is not None:
        from railnav.filters.balise_epochs import BaliseModelConfig
        out["balise_model"] = BaliseModelConfig(sigma_m=args.balise_sigma_m)
    arms = {k: v for k, v in (("antenna_m", args.lever_arm), ("imu_m", args.imu_lever_arm),
                              ("balise_reader_forward_m", args.balise_reader_forward_m))
            if v is not None}
    if arms:
        from railnav.filters.track_frame import LeverArms
        out["lever_arms"] = LeverArms(**arms)
    return out


def measurement(systems: str | None):
    from gnss_obs.errors import GnssError
    from gnss_obs.measurements import MeasurementConfig
    try:
        return MeasurementConfig(systems=systems or DEFAULT_SYSTEMS)
    except GnssError as exc:
        raise ConfigError(f"--systems: {exc}") from None


def files_given(args: argparse.Namespace) -> bool:
    """Sensor files were given (else a simulated trip runs)."""
    return args.imu is not None or args.obs is not None or args.fixes is not None


def fix_sigmas(args: argparse.Namespace) -> dict | None:
    """--fix-sigma as a table of overrides (`gnss_obs.fixes.quality.parse_fix_sigma`)."""
    if not args.fix_sigma:
        return None
    from gnss_obs.errors import GnssError
    from gnss_obs.fixes.quality import parse_fix_sigma
    try:
        return dict(parse_fix_sigma(text) for text in args.fix_sigma)
    except GnssError as exc:
        raise ConfigError(f"--fix-sigma: {exc}") from None


def fix_model(args: argparse.Namespace):
    """The fix model's settings from --fix-track-sigma-m, --no-fix-heights and
    --correlated-fix-errors (None: the defaults)."""
    if args.fix_track_sigma_m is None and not args.no_fix_heights \
            and not args.correlated_fix_errors:
        return None
    from railnav.filters.fix_epochs import FixModelConfig
    extra = {} if args.fix_track_sigma_m is None else {
        "track_cross_sigma_m": args.fix_track_sigma_m}
    return FixModelConfig(use_height=not args.no_fix_heights,
                          correlated_code_errors=args.correlated_fix_errors, **extra)


def augmentation(args: argparse.Namespace) -> dict:
    """`run_files` keywords of ``--base ... --sp3``."""
    from gnss_obs.smoothing import SmoothingConfig

    return {"base_path": args.base, "base_lat_lon_h": args.base_position,
            "smoothing": (SmoothingConfig(window_s=args.smooth_window_s)
                          if args.smooth_window_s else None),
            "sp3_paths": tuple(args.sp3), "max_correction_age_s": args.max_age_s}


def seed(args: argparse.Namespace) -> int:
    return DEFAULT_SEED if args.seed is None else args.seed


def scenario_of(args):
    """The scenario of a simulated trip on the first track: --scenario, else
    `railnav.simulation.scenarios.scenario_for_track`'s rule."""
    return scenario_for_track(args.tracks[0], args.scenario)
