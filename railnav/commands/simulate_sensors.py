"""``railnav simulate``'s railway sensors: odometer, balises, barometer, a jittered IMU log,
the antenna.

The flags (`add_sensor_arguments`) and their configurations (`sensor_configs`, checked before
anything is simulated): the keywords ``odometer``, ``balises``, ``baro`` and ``imu_log`` of
`railnav.jobs.simulated_files.write_simulated_trip`, which simulates and writes the files
(``odometer.csv``, ``balises.csv``, ``baro.csv``, ``imu.csv`` as a jittered log with
dropouts) that `railnav run` reads with ``--odometer``, ``--balises``, ``--baro`` and
``--imu`` (by flag, not found: a run on the folder uses only the sensors it is given; their
models come from ``scenario.json``).
"""
from __future__ import annotations

import argparse

from railnav.commands.support import nonnegative_float, nonnegative_int, positive_float
from railnav.errors import ConfigError

__all__ = ["add_sensor_arguments", "sensor_configs", "slip_episode"]


def slip_episode(text: str):
    """argparse type for ``START:DURATION:EXCESS`` (s, s, fraction)."""
    from railnav.simulation.track_sensors import SlipEpisode
    try:
        start, duration, excess = (float(x) for x in text.split(":"))
        return SlipEpisode(start, duration, excess)
    except (ValueError, ConfigError):
        raise argparse.ArgumentTypeError(
            f"{text!r} is not START:DURATION:EXCESS (s, s > 0, -1 <= EXCESS <= 10)") from None


def _lever_arm(text: str):
    from railnav.commands.run_flags import lever_arm
    return lever_arm(text)


def add_sensor_arguments(p) -> None:
    """The odometer, balise, IMU-log and antenna flags of ``simulate``."""
    p.add_argument("--odometer", action="store_true",
                   help="also write odometer.csv (scale error, noise, slips: below)")
    p.add_argument("--odometer-kind", choices=("speed", "pulses"), default=None,
                   help="speed readings or pulse counts (default speed)")
    p.add_argument("--odometer-rate-hz", type=positive_float, default=None,
                   help="odometer rate, Hz (default 10)")
    p.add_argument("--odometer-scale-error", type=float, default=None, metavar="K",
                   help="the wheel's scale error (reading (1 + K)|v|; default drawn, σ 0.02)")
    p.add_argument("--slip", type=slip_episode, action="append", default=None,
                   metavar="START:DURATION:EXCESS",
                   help="a slip (EXCESS > 0, traction) or slide (< 0, braking; -1 locked) "
                        "episode of the odometer wheel (repeatable)")
    p.add_argument("--balises", action="store_true",
                   help="also write balises.csv (passages of balises along the track)")
    p.add_argument("--balise-spacing-m", type=positive_float, default=None, metavar="M",
                   help="distance between balises, m (default 1000, the first at 500)")
    p.add_argument("--baro", action="store_true",
                   help="also write baro.csv (a barometric altimeter: bias, bias walk, noise; "
                        "1 Hz), the file 'railnav run --baro' reads")
    p.add_argument("--baro-bias-m", type=float, default=None, metavar="M",
                   help="with --baro: the altimeter's bias at the start, m (default 7)")
    p.add_argument("--imu-jitter-s", type=nonnegative_float, default=None, metavar="S",
                   help="write imu.csv as a logger's: sample instants jittered by ±S s")
    p.add_argument("--imu-dropouts", type=nonnegative_int, default=None, metavar="N",
                   help="with --imu-jitter-s: N dropouts of 5 samples each")
    p.add_argument("--lever-arm", type=_lever_arm, default=None, metavar="F,L,U",
                   help="the GNSS antenna's offset from the reference point (forward, left, "
                        "up), m: GNSS and fixes are simulated there")


def sensor_configs(args: argparse.Namespace) -> dict:
    """The simulation configs of the flags: ``odometer``, ``balises``, ``baro``, ``imu_log`` (None
    when not asked).

    Raises
    ------
    ConfigError
        A flag that shapes a sensor that is not simulated.
    """
    from railnav.simulation.imu_logs import ImuLogSimConfig
    from railnav.simulation.track_sensors import (
        BaliseSimConfig,
        BaroSimConfig,
        OdometerSimConfig,
    )
    odo_flags = {"odometer_kind": "kind", "odometer_rate_hz": "rate_hz",
                 "odometer_scale_error": "scale_error", "slip": "slips"}
    _needs(args, list(odo_flags), "odometer")
    _needs(args, ["balise_spacing_m"], "balises")
    _needs(args, ["imu_dropouts"], "imu_jitter_s")
    _needs(args, ["baro_bias_m"], "baro")
    out = {"odometer": None, "balises": None, "imu_log": None, "baro": None}
    if args.odometer:
        kw = {key: getattr(args, a) for a, key in odo_flags.items() if getattr(args, a) is not None}
        if "slips" in kw:
            kw["slips"] = tuple(kw["slips"])
        out["odometer"] = OdometerSimConfig(**kw)
    if args.balises:
        out["balises"] = BaliseSimConfig(**({} if args.balise_spacing_m is None else
                                            {"spacing_m": args.balise_spacing_m}))
    if args.baro:
        out["baro"] = BaroSimConfig(**({} if args.baro_bias_m is None else
                                       {"bias_m": args.baro_bias_m}))
    if args.imu_jitter_s is not None:
        out["imu_log"] = ImuLogSimConfig(jitter_s=args.imu_jitter_s,
                                         dropouts=args.imu_dropouts or 0)
    return out


def _needs(args, attrs, flag: str) -> None:
    given = ["--" + a.replace("_", "-") for a in attrs if getattr(args, a) is not None]
    if given and not getattr(args, flag):
        raise ConfigError(f"{', '.join(given)}: only with --{flag.replace('_', '-')}")
