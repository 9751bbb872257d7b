"""Exceptions of the estimation engine (which imports nothing else of the project)."""
from __future__ import annotations

__all__ = ["FilterError", "ModelError", "FilterDivergedError"]


class FilterError(Exception):
    """Base class of estimation-engine errors."""


class ModelError(FilterError, ValueError):
    """A model or layout that does not fit together (wrong sizes, missing inputs)."""


class FilterDivergedError(FilterError, ArithmeticError):
    """The covariance lost positive definiteness or the state became non-finite."""
