"""A reference trajectory against the track a filter was given, and a solution's largest
horizontal error split into its along-track part and the reference's offset from the track
(`benchmarks/bench_real_pieces.py`; tested in ``tests/railnav/evaluation/test_track_offsets.py``).

A track-constrained estimate lies on the track: its horizontal error is the along-track
error and the reference's own distance from the track, ``√(e_s² + d²)`` where the track is
straight. Where the reference is off the track (a car in another lane than the one the
track was fitted on, standing beside its end), no estimate on the track is closer than
``d``: `reference_offsets` gives that floor beside the figures, `largest_error_parts` the
split at a solution's worst epoch.
"""
from __future__ import annotations

import numpy as np
import numpy.typing as npt
import pandas as pd

__all__ = ["reference_offsets", "offset_summary", "largest_error_parts"]

Array = npt.NDArray[np.float64]


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
