"""Exceptions of the application layer."""
from __future__ import annotations

from trackmodel.errors import InputError

__all__ = ["RailnavError", "ConfigError"]


class RailnavError(Exception):
    """Base class of application errors."""


class ConfigError(RailnavError, InputError):
    """A scenario, study or command-line configuration that cannot be used."""
