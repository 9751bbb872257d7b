"""The flags of ``railnav run`` for the vehicle body's rows and the simulated car body:
declared in `add_attitude_arguments` (called from
`railnav.commands.run_flags.add_run_arguments`), checked in `check_attitude_flags` (called
from `railnav.commands.run_flags.check_flags`), turned into the public API's arguments by
`attitude_config` (``NavigatorConfig.track_attitude``/``standstill``/``suspension_noise``,
and ``run_files``' keywords of the same names) and `car_body_scenario`
(``Scenario.car_body``). Light imports only (start-up: `railnav.commands`).

* ``--track-attitude``: the attitude of the body against the track as rows, with the IMU's
  mounting as states (`railnav.filters.attitude_rows`; `TrackAttitudeConfig` defaults);
* ``--standstill``: standstill detection from the IMU (vetoed by odometer and fix speeds) and
  its zero-speed and zero-yaw-rate rows (`railnav.filters.standstill`, `StandstillConfig`
  defaults);
* ``--no-recover``: no recovery by the divergence monitor (`railnav.navigation.monitor`,
  ``MonitorConfig(recover=False)``; by default a ``lost`` filter restarts from the epoch's
  single-point fix); the ``monitor`` keyword of ``run_files``. ``--recover``, the default,
  is kept for scripts that name it;
* ``--suspension-noise``: the IMU on a car body's suspension: its sampling error as gyro
  noise (``NavigatorConfig.suspension_noise``, `railnav.filters.suspension_noise`);
* ``--car-body``: a simulated trip's IMU on a car body: chord between bogies, suspension,
  mounting (`railnav.simulation.car_body_motion`, `CarBodyMotion` defaults).
"""
from __future__ import annotations

import argparse

from railnav.commands.support import one_of_pair
from railnav.errors import ConfigError

__all__ = ["add_attitude_arguments", "check_attitude_flags", "attitude_config",
           "car_body_scenario"]


def add_attitude_arguments(p) -> None:
    """The body flags of ``run`` (module docstring)."""
    p.add_argument("--track-attitude", action="store_true",
                   help="constrained filter: rows of the body's attitude against the track "
                        "(yaw - azimuth, pitch - grade, roll), with the IMU's mounting "
                        "estimated (prior 1 deg) and the car body a chord between bogies "
                        "19 m apart, the IMU over the leading one")
    p.add_argument("--standstill", action="store_true",
                   help="constrained filter: detect standstills from the IMU (variance and "
                        "level over 1-s windows; vetoed by odometer and fix speeds) and "
                        "apply zero-speed and zero-yaw-rate rows")
    p.add_argument("--recover", action="store_true",
                   help="when the divergence monitor says lost, restart the filter from the "
                        "epoch's single-point fix (the default)")
    p.add_argument("--no-recover", action="store_true",
                   help="no restart when the divergence monitor says lost (the status "
                        "column still says so)")
    p.add_argument("--suspension-noise", action="store_true",
                   help="constrained filter: the IMU rides a car body on its suspension (a "
                        "train): its sampled rates' attitude error as gyro noise (implied "
                        "by --track-attitude and, for a simulated trip, by --car-body)")
    p.add_argument("--car-body", action="store_true",
                   help="simulated trip: the IMU on a car body (chord between bogies, "
                        "suspension motion 1/2/3 mrad at 1 Hz, mounting N(0, 1 deg))")


def check_attitude_flags(args: argparse.Namespace, *, files: bool) -> None:
    """The body flags against the others (part of `check_flags`)."""
    mine = [flag for flag, on in (("--track-attitude", args.track_attitude),
                                  ("--standstill", args.standstill),
                                  ("--suspension-noise", args.suspension_noise)) if on]
    if mine and args.filter not in (None, "constrained"):
        raise ConfigError(f"{', '.join(mine)}: only with the constrained filter (not "
                          f"--filter {args.filter})")
    if mine and (getattr(args, "network", None) is not None or len(args.tracks) > 1):
        raise ConfigError(f"{', '.join(mine)}: one track only (not with --network or "
                          "several tracks)")
    recover = one_of_pair(("--recover", args.recover),
                          ("--no-recover", getattr(args, "no_recover", False)),
                          default="recovery is the default")
    if recover and (getattr(args, "network", None) is not None or len(args.tracks) > 1):
        raise ConfigError(f"{recover}: one track only (a network run spawns hypotheses "
                          "instead: --no-spawn)")
    if args.car_body and (files or len(args.tracks) > 1
                          or getattr(args, "network", None) is not None):
        raise ConfigError("--car-body: shapes a simulated trip on one track (not with sensor "
                          "files, several tracks or --network)")


def attitude_config(args: argparse.Namespace) -> dict:
    """``track_attitude`` and ``standstill`` (the configs' defaults, or None when off),
    ``suspension_noise`` when ``--suspension-noise`` and ``monitor`` without recovery when
    ``--no-recover`` (each absent otherwise: the default, or what a simulated trip sets)."""
    from railnav.filters.attitude_config import TrackAttitudeConfig
    from railnav.filters.standstill import StandstillConfig
    out = {"track_attitude": TrackAttitudeConfig() if args.track_attitude else None,
           "standstill": StandstillConfig() if args.standstill else None}
    if args.suspension_noise:       # absent otherwise: a simulated car body sets it
        out["suspension_noise"] = True
    if getattr(args, "no_recover", False):
        from railnav.navigation.monitor_config import MonitorConfig
        out["monitor"] = MonitorConfig(recover=False)
    return out


def car_body_scenario(args: argparse.Namespace, scenario):
    """`scenario` with the car body when ``--car-body`` is given."""
    if not args.car_body:
        return scenario
    from dataclasses import replace

    from railnav.simulation.car_body_config import CarBodyMotion
    return replace(scenario, car_body=CarBodyMotion())
