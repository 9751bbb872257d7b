"""A track fitted to a surveyed path: the public API of ``railnav track fit``.

`read_survey` reads the path (a polyline CSV, or a reference trajectory in GPS week /
seconds-of-week layout); `fit_survey` fits a track to it (`trackmodel.fit.fit_track`), or
to one of its legs when the survey turns round (`trackmodel.polyline.split_legs`), with
every error located in the survey file.
"""
from __future__ import annotations

import os
from dataclasses import dataclass
from typing import Callable

import numpy as np

from trackmodel.errors import InputError, TrackError, TrackFileError
from trackmodel.fit import TrackFit, fit_track
from trackmodel.fit_defaults import DEFAULT_TOL_M, DEFAULT_VTOL_M
from trackmodel.polyline import POLYLINE_COLUMNS, Polyline, read_polyline, split_legs

__all__ = ["read_survey", "fit_survey", "SurveyFit"]


def read_survey(path: str | os.PathLike) -> Polyline:
    """A surveyed path: a polyline CSV (`trackmodel.polyline.read_polyline`), or a reference
    trajectory in GPS week / seconds-of-week layout (`railnav.evaluation.spp_accuracy`), in
    time order.

    The reference layout is tried only when the file lacks the polyline's columns; an error
    located in either layout's rows (a bad value, a ragged row) is the file's error.

    Raises
    ------
    trackmodel.TrackFileError, railnav.errors.ConfigError
        Located at the row/line and column of the problem; when the file is in neither
        layout, the polyline reader's "required column missing".
    """
    try:
        return read_polyline(path)
    except TrackFileError as polyline_error:
        if not _missing_polyline_column(polyline_error):
            raise
        from railnav.evaluation.spp_accuracy import read_reference_trajectory
        try:
            ref = read_reference_trajectory(path)
        except InputError as ref_error:
            if ref_error.row is None and ref_error.line is None:
                raise polyline_error from None     # not that layout either
            raise
        return Polyline(np.radians(ref["lat_deg"].to_numpy()),
                        np.radians(ref["lon_deg"].to_numpy()), ref["h_m"].to_numpy())


def _missing_polyline_column(error: TrackFileError) -> bool:
    """True for the polyline reader's error of a file without its columns (nothing located
    in the rows: the file may be in the other layout)."""
    return error.column in POLYLINE_COLUMNS and error.row is None and error.line is None


@dataclass(frozen=True)
class SurveyFit:
    """`fit_survey`'s result: the `fit` (`trackmodel.fit.TrackFit`: track, residuals,
    sections, largest deviation) and `note`, which leg of the survey was fitted (``""``:
    all of it; else ``", leg N of M (points I-J)"``, for the track file's comment)."""

    fit: TrackFit
    note: str


def fit_survey(path: str | os.PathLike, *, leg: int | None = None,
               tol_m: float = DEFAULT_TOL_M, vtol_m: float = DEFAULT_VTOL_M,
               progress: Callable[[int, int], None] | None = None) -> SurveyFit:
    """Fit a track to the survey in `path` (`read_survey`).

    Parameters
    ----------
    path : path
        The survey, points in travel order.
    leg : int, optional
        Fit only leg `leg` (1-based) of a survey that reverses its direction (default: a
        reversal is an error that lists the legs).
    tol_m : float
        Largest horizontal deviation of a point from the track, m.
    vtol_m : float
        Height tolerance of the vertical profile, m.
    progress : callable(done, total), optional

    Raises
    ------
    trackmodel.TrackFileError
        A survey the fitter cannot use, or no leg `leg`, located in `path`.
    """
    try:
        poly, note = _leg(read_survey(path), leg, path)
        fit = fit_track(poly.lat, poly.lon, poly.h, tol_m=tol_m, vtol_m=vtol_m,
                        progress=progress)
    except TrackFileError:
        raise
    except TrackError as exc:       # a survey the fitter cannot use: say which file
        raise TrackFileError(str(exc), path=path) from None
    return SurveyFit(fit, note)


def _leg(poly: Polyline, leg: int | None, path) -> tuple[Polyline, str]:
    """The points of leg `leg` (1-based) of a survey, and `SurveyFit.note`."""
    if leg is None:
        return poly, ""
    legs = split_legs(poly)
    if not 1 <= leg <= len(legs):
        raise TrackFileError(f"leg {leg}: the survey has {len(legs)} leg(s)", path=path)
    index = legs[leg - 1]
    return poly.take(index), f", leg {leg} of {len(legs)} (points {index[0]}-{index[-1]})"
