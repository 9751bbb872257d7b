"""Exceptions of the application layer."""
from __future__ import annotations

from trackmodel.errors import InputError

__all__ = ["RailnavError", "ConfigError", "PlottingError", "FixesOffTrackError"]


class RailnavError(Exception):
    """Base class of application errors.

    `arguments`: the names of the library arguments the message names (``give
    start_gps_time_s``); the command line writes them as its flags
    (`railnav.cli.flag_names`: ``give --start-gps-time-s``).
    """

    def __init__(self, *args, arguments: tuple[str, ...] = (), **kwargs) -> None:
        super().__init__(*args, **kwargs)
        self.arguments = tuple(arguments)


class ConfigError(RailnavError, InputError):
    """A scenario, study or command-line configuration that cannot be used."""


class PlottingError(RailnavError):
    """The process drawing a run's figures ended without drawing them (killed, out of
    memory): the run's output was not written (`railnav.jobs.plot_worker`)."""


class FixesOffTrackError(ConfigError):
    """None of a trip's first fixes agrees with its track (another line's fixes, or the
    wrong track): the filter has no fix to start from
    (`railnav.navigation.fix_start.initial_from_fixes`). The command line adds both files."""
