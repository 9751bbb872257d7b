"""A one-netelement GeoJSON network with and without heights, and fixes on it, for the
tests of networks without heights: the netelement runs `LENGTH_M` east along the parallel
`LAT0_DEG` from `LON0_DEG` (longitude from the WGS-84 radius of the parallel, closed form)
with the heights `height_m` (closed form), and the fixes are its points, noise-free, with
those heights."""
from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np
import pandas as pd

__all__ = ["LAT0_DEG", "LON0_DEG", "LENGTH_M", "height_m", "write_geojson", "write_fixes",
           "ELEMENT"]

LAT0_DEG, LON0_DEG = 50.88, 4.46
LENGTH_M, STEP_M = 1200.0, 10.0
ELEMENT = "E"
#: WGS-84 (NIMA TR8350.2): semi-major axis, m, and flattening.
_A_M, _F = 6378137.0, 1.0 / 298.257223563
#: GPS time of the first fix, s (January 2022).
START_GPS_TIME_S = 1_326_186_787.0


def height_m(x_m):
    """Ellipsoidal height `x_m` metres along the netelement, m: a 0.4 % grade and a 3-m
    wave of 1200 m (grades up to 2 %)."""
    x = np.asarray(x_m, dtype=float)
    return 100.0 + 0.004 * x + 3.0 * np.sin(2.0 * math.pi * x / 1200.0)


def _lon_deg(x_m):
    """Longitude `x_m` metres east along the parallel, degrees (radius N cos φ)."""
    phi = math.radians(LAT0_DEG)
    e2 = _F * (2.0 - _F)
    radius = _A_M / math.sqrt(1.0 - e2 * math.sin(phi) ** 2) * math.cos(phi)
    return LON0_DEG + np.degrees(np.asarray(x_m, dtype=float) / radius)


def write_geojson(path: Path, *, heights: bool) -> Path:
    """The netelement as GeoJSON: ``[lon, lat, h]`` with `heights`, else ``[lon, lat]``."""
    x = np.arange(0.0, LENGTH_M + STEP_M / 2, STEP_M)
    columns = [_lon_deg(x), np.full(x.size, LAT0_DEG)] + ([height_m(x)] if heights else [])
    feature = {"type": "Feature", "properties": {"id": ELEMENT},
               "geometry": {"type": "LineString",
                            "coordinates": np.column_stack(columns).tolist()}}
    path.write_text(json.dumps({"type": "FeatureCollection", "features": [feature]}))
    return path


def write_fixes(path: Path, *, speed_mps: float = 10.0, start_x_m: float = 100.0,
                end_x_m: float = 1000.0) -> Path:
    """Fixes every second at `speed_mps` east from `start_x_m` to `end_x_m`, on the
    netelement with its heights, class ``rtk_fixed``."""
    x = np.arange(start_x_m, end_x_m, speed_mps)
    pd.DataFrame({"gps_time_s": START_GPS_TIME_S + (x - start_x_m) / speed_mps,
                  "lat_deg": LAT0_DEG, "lon_deg": _lon_deg(x), "h_m": height_m(x),
                  "quality": "rtk_fixed"}).to_csv(path, index=False, float_format="%.12f")
    return path
