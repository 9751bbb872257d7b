"""Exceptions of the strapdown package."""
from __future__ import annotations

from trackmodel.errors import InputError

__all__ = ["StrapdownError", "ImuInputError"]


class StrapdownError(Exception):
    """Base class of inertial-model errors (bad configuration, unknown preset...)."""


class ImuInputError(StrapdownError, InputError):
    """IMU data (file or array) that cannot be used as documented."""
