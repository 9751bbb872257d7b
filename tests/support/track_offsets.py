"""A reference trajectory against the track a filter was given, and a solution's largest
horizontal error split into its along-track part and the reference's offset from the track
(`benchmarks/bench_real_pieces.py`; tested in ``tests/railnav/evaluation/test_track_offsets.py``).

A track-constrained estimate lies on the track: its horizontal error is the along-track
error and the reference's own distance from the track, ``√(e_s² + d²)`` where the track is
straight. Where the reference is off the track (a car in another lane than the one the
track was fitted on, standing beside its end), no estimate on the track is closer than
``d``: `reference_offsets` gives that floor beside the figures, `largest_error_parts` the
split at a solution's worst epoch.

`on_track_shift` is the same question for one epoch's pseudoranges: solved alone on the
track for ``s`` and the receiver clocks, where does a receiver off the track, or a code
error, put ``s`` (the part of an along-track error that the rows themselves hold, before
any filter; `benchmarks/_track_mismatch.py`).
"""
from __future__ import annotations

import numpy as np
import numpy.typing as npt
import pandas as pd

__all__ = ["reference_offsets", "offset_summary", "largest_error_parts", "on_track_shift",
           "along_track_s"]

Array = npt.NDArray[np.float64]


def along_track_s(track, lat_deg: npt.ArrayLike, lon_deg: npt.ArrayLike) -> Array:
    """Points' along-track coordinate on `track`: the projection's ``s``, and beyond a
    track end its remainder along the tangent (before the start negative, beyond the end
    past the length), as a filter's state ``s`` runs on there; the scale the pieces'
    along-track errors are taken on (a reference point beyond an end clamped to it put a
    state beside the point a metre or more wrong)."""
    proj = track.project(np.radians(np.asarray(lat_deg, float)),
                         np.radians(np.asarray(lon_deg, float)))
    return proj.s + proj.along_m


def reference_offsets(track, lat_deg: npt.ArrayLike, lon_deg: npt.ArrayLike,
                      h_m: npt.ArrayLike) -> pd.DataFrame:
    """Points against `track` (horizontal projection, as the pieces' reference ``s``).

    Returns
    -------
    DataFrame
        ``s_m`` (projected), ``cross_track_m`` (signed, right of +s positive),
        ``horizontal_m`` (horizontal distance from the track: the cross-track offset and,
        beyond a track end, the along-track remainder), ``vertical_m`` (height above the
        track at ``s_m``).
    """
    lat = np.radians(np.asarray(lat_deg, float))
    lon = np.radians(np.asarray(lon_deg, float))
    proj = track.project(lat, lon)
    return pd.DataFrame({"s_m": proj.s, "cross_track_m": proj.cross_track_m,
                         "horizontal_m": np.hypot(proj.cross_track_m, proj.along_m),
                         "vertical_m": np.asarray(h_m, float) - track.at(proj.s).h})


def offset_summary(offsets: pd.DataFrame) -> dict:
    """RMS and largest of `reference_offsets`' horizontal and vertical offsets, m."""
    h, v = offsets["horizontal_m"].to_numpy(), np.abs(offsets["vertical_m"].to_numpy())
    return {"horizontal_rms_m": float(np.sqrt(np.mean(h ** 2))),
            "horizontal_max_m": float(h.max()),
            "vertical_rms_m": float(np.sqrt(np.mean(v ** 2))),
            "vertical_max_m": float(v.max())}


def largest_error_parts(gps_time_s: Array, horizontal_m: Array, along_track_m: Array,
                        offset_m: Array) -> dict:
    """The largest along-track error, and the epoch of the largest horizontal error with
    its along-track error and offset across the track there (for an estimate on the
    track the reference's offset from it; for a fix, its own cross-track error)."""
    k = int(np.argmax(horizontal_m))
    return {"along_track_max_m": float(np.max(np.abs(along_track_m))),
            "at_horizontal_max": {"gps_time_s": float(gps_time_s[k]),
                                  "horizontal_m": float(horizontal_m[k]),
                                  "along_track_m": float(along_track_m[k]),
                                  "offset_m": float(offset_m[k])}}


def on_track_shift(drho_ds: npt.ArrayLike, y_m: npt.ArrayLike, variances_m2: npt.ArrayLike,
                   clock_of: npt.ArrayLike) -> tuple[float, float]:
    """One epoch's pseudorange misfits `y_m` solved by weighted least squares for a shift
    ``δs`` along the track and one receiver clock per value of `clock_of` (a system's).

    Parameters
    ----------
    drho_ds : array_like, shape (m,)
        Each range's change per metre along the track, ``−e_i·t`` (dimensionless).
    y_m : array_like, shape (m,)
        Pseudorange minus the range from the track's point (a receiver off it, a code error;
        any part common to a system's rows is its clock's), m.
    variances_m2 : array_like, shape (m,)
        The rows' variances, m².
    clock_of : array_like, shape (m,)
        Each row's clock (its system's letter).

    Returns
    -------
    (float, float)
        ``δs`` (m) and its σ from `variances_m2` (m); NaN for fewer rows than unknowns.
    """
    h = np.asarray(drho_ds, float)
    clocks = np.asarray(clock_of)
    names = np.unique(clocks)
    A = np.column_stack([h, *(clocks == c for c in names)]).astype(float)
    if h.size <= A.shape[1]:
        return float("nan"), float("nan")
    w = 1.0 / np.asarray(variances_m2, float)
    N = A.T @ (w[:, None] * A)
    x = np.linalg.solve(N, A.T @ (w * np.asarray(y_m, float)))
    return float(x[0]), float(np.sqrt(np.linalg.inv(N)[0, 0]))
