"""Projection of points onto a network's netelements: the candidates within a radius.

`project_onto` is `trackmodel.network.Network.project`: a cheap prefilter on points sampled
along each netelement (`_near_element`), then the exact projection onto each candidate
(`trackmodel.track.Track.project`).
"""
from __future__ import annotations

import math
from collections.abc import Mapping

import numpy as np
import numpy.typing as npt
import pandas as pd

from trackmodel.track import Track

__all__ = ["project_onto", "MEAN_RADIUS_M"]

Array = npt.NDArray[np.float64]

#: Mean Earth radius for local equirectangular distances, m (IUGG R1): the network
#: modules' one value.
MEAN_RADIUS_M = 6_371_008.8


def project_onto(elements: Mapping[str, Track], lat: npt.ArrayLike, lon: npt.ArrayLike, *,
                 radius_m: float) -> pd.DataFrame:
    """Candidate netelements within `radius_m` of each point (`Network.project`)."""

    lat, lon = np.atleast_1d(np.asarray(lat, float)), np.atleast_1d(np.asarray(lon, float))
    rows = []
    for element, track in elements.items():
        near = _near_element(track, lat, lon, radius_m)
        if not near.any():
            continue
        proj = track.project(lat[near], lon[near])
        inside = (np.abs(proj.along_m) < 1e-6) & (np.abs(proj.cross_track_m) <= radius_m)
        idx = np.flatnonzero(near)[inside]
        rows.append(pd.DataFrame({"point": idx, "element": element,
                                  "s_m": proj.s[inside],
                                  "cross_track_m": proj.cross_track_m[inside],
                                  "distance_m": np.abs(proj.cross_track_m[inside])}))
    columns = ["point", "element", "s_m", "cross_track_m", "distance_m"]
    if not rows:
        return pd.DataFrame(columns=columns)
    out = pd.concat(rows, ignore_index=True)[columns]
    return out.sort_values(["point", "distance_m"], ignore_index=True)


def _near_element(track: Track, lat: Array, lon: Array, radius_m: float
                  ) -> npt.NDArray[np.bool_]:
    """Points horizontally within `radius_m` (plus the sampling step and 1 %) of points
    sampled every <= 50 m along `track`: a cheap prefilter before the exact projection
    (equirectangular distances on the mean Earth radius)."""
    n = max(2, int(math.ceil(track.length_m / 50.0)) + 1)
    t_lat, t_lon, _ = track.geodetic(np.linspace(0.0, track.length_m, n))
    step = track.length_m / (n - 1)
    north = MEAN_RADIUS_M * (lat[:, None] - t_lat[None, :])
    dlon = (lon[:, None] - t_lon[None, :] + math.pi) % (2 * math.pi) - math.pi
    east = MEAN_RADIUS_M * np.cos(lat)[:, None] * dlon
    reach = 1.01 * (radius_m + step)
    return np.min(north ** 2 + east ** 2, axis=1) <= reach ** 2

