"""Exceptions of the strapdown package."""
from __future__ import annotations

from trackmodel.errors import InputError

__all__ = ["StrapdownError", "ImuInputError", "ImuColumnsError"]


class StrapdownError(Exception):
    """Base class of inertial-model errors (bad configuration, unknown preset...)."""


class ImuInputError(StrapdownError, InputError):
    """IMU data (file or array) that cannot be used as documented."""


class ImuColumnsError(ImuInputError):
    """An IMU table without the columns its layout names: `missing` those not found,
    `found` the file's (a caller may say how to read another layout)."""

    def __init__(self, message: str, *, missing=(), found=(), **where) -> None:
        super().__init__(message, **where)
        self.missing, self.found = tuple(missing), tuple(found)
