"""Derived views of a track: a sampled table (`sample_track`) and key figures (`track_info`)."""
from __future__ import annotations

import math
from dataclasses import asdict, dataclass

import numpy as np
import pandas as pd

from trackmodel.errors import TrackError
from trackmodel.track import Track

__all__ = ["TrackInfo", "sample_track", "track_info", "SAMPLE_COLUMNS"]

SAMPLE_COLUMNS = ("s_m", "lat_deg", "lon_deg", "h_m", "azimuth_deg", "elevation_deg",
                  "curvature_1pm")


def sample_track(track: Track, step_m: float = 1.0) -> pd.DataFrame:
    """The track every `step_m` metres (and at its end).

    Parameters
    ----------
    track : Track
    step_m : float
        Spacing along the track, m, > 0.

    Returns
    -------
    pandas.DataFrame
        Columns `SAMPLE_COLUMNS`: ``s_m``, geodetic position in degrees and metres,
        azimuth and elevation in degrees, curvature ``dA/ds`` in 1/m.

    Raises
    ------
    TrackError
        For a step that is not a finite number > 0.
    """
    if not (math.isfinite(step_m) and step_m > 0):
        raise TrackError(f"step_m must be a finite number > 0, got {step_m!r}")
    n = int(math.floor(track.length_m / step_m))
    s = np.arange(n + 1) * step_m
    if track.length_m - s[-1] > 1e-9 * max(1.0, track.length_m):
        s = np.append(s, track.length_m)
    pt = track.at(np.minimum(s, track.length_m))
    return pd.DataFrame({"s_m": s, "lat_deg": np.degrees(pt.lat), "lon_deg": np.degrees(pt.lon),
                         "h_m": pt.h, "azimuth_deg": np.degrees(pt.azimuth),
                         "elevation_deg": np.degrees(pt.elevation),
                         "curvature_1pm": pt.curvature_1pm})


@dataclass(frozen=True)
class TrackInfo:
    """Key figures of a track.

    Attributes
    ----------
    length_m : float
    n_sections : int
    n_straights, n_arcs, n_transitions : int
        Sections with zero curvature, constant non-zero curvature, varying curvature.
    min_radius_m : float
        Smallest horizontal radius ``1/max|dA/ds|``, m (inf for a track without curves).
    max_grade_percent : float
        Largest ``|tan ϑ|`` in percent.
    earth : str
        ``wgs84`` or ``sphere``.
    h_min_m, h_max_m : float
        Height range of the section joints and ends, m.
    """

    length_m: float
    n_sections: int
    n_straights: int
    n_arcs: int
    n_transitions: int
    min_radius_m: float
    max_grade_percent: float
    earth: str
    h_min_m: float
    h_max_m: float

    def to_dict(self) -> dict:
        """Plain dict (for JSON and printing)."""
        return asdict(self)


def track_info(track: Track) -> TrackInfo:
    """Length, section counts, smallest radius and steepest grade of `track`."""
    tab = track.table
    k0, k1 = tab.curvature0, tab.curvature1
    kmax = float(np.max(np.maximum(np.abs(k0), np.abs(k1))))
    straight = (k0 == 0) & (k1 == 0)
    arc = (k0 == k1) & ~straight
    emax = float(np.max(np.maximum(np.abs(tab.elevation0), np.abs(tab.elevation1))))
    return TrackInfo(length_m=track.length_m, n_sections=len(track.sections),
                     n_straights=int(straight.sum()), n_arcs=int(arc.sum()),
                     n_transitions=int((~straight & ~arc).sum()),
                     min_radius_m=math.inf if kmax == 0 else 1.0 / kmax,
                     max_grade_percent=100.0 * math.tan(emax), earth=track.earth.name,
                     h_min_m=float(track.starts[:, 2].min()),
                     h_max_m=float(track.starts[:, 2].max()))
