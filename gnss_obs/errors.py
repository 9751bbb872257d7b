"""Exceptions of the GNSS package."""
from __future__ import annotations

from trackmodel.errors import InputError

__all__ = ["GnssError", "GnssInputError"]


class GnssError(Exception):
    """Base class of GNSS errors (no ephemeris, too few satellites, ...)."""


class GnssInputError(GnssError, InputError):
    """A RINEX/SP3 file or GNSS array that cannot be read as documented."""
