"""Exceptions of the application layer."""
from __future__ import annotations

from trackmodel.errors import InputError

__all__ = ["RailnavError", "ConfigError", "PlottingError"]


class RailnavError(Exception):
    """Base class of application errors."""


class ConfigError(RailnavError, InputError):
    """A scenario, study or command-line configuration that cannot be used."""


class PlottingError(RailnavError):
    """The process drawing a run's figures ended without drawing them (killed, out of
    memory): the run's output was not written (`railnav.jobs.plot_worker`)."""
