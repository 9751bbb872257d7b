"""Exceptions of the track model, and the located input error every package reuses.

`InputError` is the one place that says how a problem in a user's file reads:
``path: row 3, azimuth_deg: 'abc' is not a number``. The command line prints it after
``error: `` and exits with status 2. `trackmodel` is the lowest package, so `strapdown`,
`gnss_obs` and `railnav` subclass `InputError` for their own file errors (`ekf` imports
nothing of ours and has its own hierarchy).
"""
from __future__ import annotations

import os

import numpy as np

__all__ = ["InputError", "TrackError", "TrackFileError", "finite_column"]


class InputError(ValueError):
    """Bad user input, located as precisely as the reader knows.

    Parameters
    ----------
    message : str
        What is wrong, in words a user understands ("'abc' is not a number",
        "must be -90 < elevation_deg < 90").
    path : str or os.PathLike, optional
        The file the problem is in.
    row : int, optional
        1-based data row of a table (header not counted).
    line : int, optional
        1-based line number of a text file (use for line-oriented formats such as RINEX).
    column : str, optional
        Column or field name.
    """

    def __init__(self, message: str, *, path: str | os.PathLike | None = None,
                 row: int | None = None, line: int | None = None,
                 column: str | None = None) -> None:
        super().__init__(message)
        self.message = message
        self.path = None if path is None else os.fspath(path)
        self.row = row
        self.line = line
        self.column = column

    def __str__(self) -> str:
        where = []
        if self.row is not None:
            where.append(f"row {self.row}")
        if self.line is not None:
            where.append(f"line {self.line}")
        loc = ", ".join(where)
        if self.column is not None:
            loc = f"{loc}, {self.column}" if loc else self.column
        parts = [p for p in (self.path, loc) if p]
        parts.append(self.message)
        return " ".join(": ".join(parts).splitlines())     # one line, whatever the input

    def at(self, path: str | os.PathLike) -> "InputError":
        """Return this error with `path` filled in when the raiser did not know it."""
        if self.path is None:
            self.path = os.fspath(path)
        return self


def finite_column(frame, column: str, *, path: str | os.PathLike | None = None,
                  error: type[InputError] = InputError) -> np.ndarray:
    """A table column as floats, or `error` located at the first value that is not a
    finite number (``row`` 1-based, header not counted).

    Parameters
    ----------
    frame : pandas.DataFrame
        The table as read (any dtype).
    column : str
        Column name (must exist).
    path : str or os.PathLike, optional
        The file, for the message.
    error : type
        The reader's `InputError` subclass.
    """
    import pandas as pd
    values = pd.to_numeric(frame[column], errors="coerce").to_numpy(dtype=float)
    bad = np.flatnonzero(~np.isfinite(values))
    if bad.size:
        raise error(_not_finite(frame[column].iloc[bad[0]]), path=path,
                    row=int(bad[0]) + 1, column=column)
    return values


def _not_finite(cell) -> str:
    """What is wrong with a cell that is not a finite number, in the file's words (never a
    NumPy repr such as ``np.float64(nan)``)."""
    if isinstance(cell, str):
        return f"{cell.strip()!r} is not a finite number"
    if cell is None or (isinstance(cell, (float, np.floating)) and np.isnan(cell)):
        return "empty or NaN (a finite number is needed)"
    try:
        return f"{float(cell)!r} is not a finite number"
    except (TypeError, ValueError):
        return f"{str(cell)!r} is not a finite number"


class TrackError(Exception):
    """Base class of track-model errors (bad geometry, query outside the track...)."""


class TrackFileError(TrackError, InputError):
    """A track or polyline file that cannot be read as documented."""
